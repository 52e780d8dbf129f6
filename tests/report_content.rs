//! What runs on a scene follows from its content, not its name: an OBJ
//! interior with glossy reflectors and a camera path inside its walls gets
//! the glossy study and the epipolar walk; the same scene seen from outside
//! gets the glossy study only and `summary.md` says why; bad scene input is
//! refused before anything is written.

use refl_app::report::content::Content;
use refl_app::report::{run, Options};
use refl_app::scene::Scene;
use refl_app::tracer::Tracer;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("refl-report-content-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A 6 m x 6 m room with 3 m walls and no ceiling: a glossy floor object,
/// four walls and a box standing in the middle (two triangles per face).
fn walled_room_obj(dir: &Path) -> PathBuf {
    let mut s = String::new();
    let mut v = 0;
    let mut quad = |s: &mut String, name: &str, p: [[f32; 3]; 4]| {
        let _ = writeln!(s, "o {name}");
        for q in p {
            let _ = writeln!(s, "v {} {} {}", q[0], q[1], q[2]);
        }
        let _ = writeln!(s, "f {} {} {}", v + 1, v + 2, v + 3);
        let _ = writeln!(s, "f {} {} {}", v + 1, v + 3, v + 4);
        v += 4;
    };
    let (h, w) = (3.0, 3.0);
    quad(
        &mut s,
        "floor",
        [[-w, 0.0, -w], [-w, 0.0, w], [w, 0.0, w], [w, 0.0, -w]],
    );
    quad(
        &mut s,
        "wall_n",
        [[-w, 0.0, -w], [w, 0.0, -w], [w, h, -w], [-w, h, -w]],
    );
    quad(
        &mut s,
        "wall_s",
        [[w, 0.0, w], [-w, 0.0, w], [-w, h, w], [w, h, w]],
    );
    quad(
        &mut s,
        "wall_w",
        [[-w, 0.0, w], [-w, 0.0, -w], [-w, h, -w], [-w, h, w]],
    );
    quad(
        &mut s,
        "wall_e",
        [[w, 0.0, -w], [w, 0.0, w], [w, h, w], [w, h, -w]],
    );
    let b = 0.5;
    quad(
        &mut s,
        "box",
        [[-b, 1.0, -b], [-b, 1.0, b], [b, 1.0, b], [b, 1.0, -b]],
    );
    quad(
        &mut s,
        "box",
        [[-b, 0.0, b], [b, 0.0, b], [b, 1.0, b], [-b, 1.0, b]],
    );
    quad(
        &mut s,
        "box",
        [[b, 0.0, -b], [-b, 0.0, -b], [-b, 1.0, -b], [b, 1.0, -b]],
    );
    quad(
        &mut s,
        "box",
        [[-b, 0.0, -b], [-b, 0.0, b], [-b, 1.0, b], [-b, 1.0, -b]],
    );
    quad(
        &mut s,
        "box",
        [[b, 0.0, b], [b, 0.0, -b], [b, 1.0, -b], [b, 1.0, b]],
    );
    let path = dir.join("walled.obj");
    std::fs::write(&path, s).unwrap();
    path
}

/// A walk along the room's south half at eye height, looking north.
fn inside_path(dir: &Path) -> PathBuf {
    let path = dir.join("walk.txt");
    std::fs::write(
        &path,
        "# eye x y z, target x y z, fov\n\
         -2.0 1.6 2.0  -1.0 1.0 -1.0  60\n\
         -1.0,1.6,2.2, 0.0,1.0,-1.0\n\
         0.0 1.6 2.3 0.5 1.0 -1.0\n\
         1.0 1.6 2.2 1.0 1.0 -1.0\n\
         2.0 1.6 2.0 1.5 1.0 -1.0\n",
    )
    .unwrap();
    path
}

fn read_csv(path: &Path) -> Vec<(String, String, String)> {
    let mut r = csv::Reader::from_path(path).unwrap();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            (rec[0].to_owned(), rec[1].to_owned(), rec[2].to_owned())
        })
        .collect()
}

fn options(obj: &Path, out: PathBuf, camera_path: Option<PathBuf>) -> Options {
    Options {
        quick: true,
        scene: vec![obj.display().to_string()],
        method: ["reference", "planar-mirror", "cone", "epipolar", "orsa"]
            .map(String::from)
            .to_vec(),
        out,
        threads: Some(2),
        reflective: vec!["floor:0.8:0.3".into()],
        camera_path,
        ..Options::default()
    }
}

#[test]
fn an_obj_interior_gets_the_glossy_study_and_the_epipolar_walk() {
    let dir = temp_dir("inside");
    let obj = walled_room_obj(&dir);
    let out = dir.join("report");
    run(&options(&obj, out.clone(), Some(inside_path(&dir)))).unwrap();
    let rows = read_csv(&out.join("summary.csv"));
    let has = |scene: &str, method: &str| rows.iter().any(|r| r.0 == scene && r.1 == method);
    // The floor is glossy (roughness 0.3): the reference sweeps sample
    // counts, the glossy study runs on the scene made glossy.
    assert!(has("walled", "reference"), "{rows:?}");
    assert!(has("walled-glossy-0.20", "cone"), "{rows:?}");
    // The walk runs inside walls: the epipolar walk with its ORSA baseline.
    assert!(
        has("walled", "epipolar") && has("walled", "orsa"),
        "{rows:?}"
    );
    // Only the selected methods: no multi-ray, no IRSA rows.
    assert!(!rows.iter().any(|r| r.1 == "multiray" || r.1 == "irsa"));
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("camera path of 5 poses, inside walls"), "{md}");
    // Every frame's plan from refl-core's planner is listed.
    assert!(md.contains("refl-core's plan (`refl plan`): "), "{md}");
    // The floor is planar but glossy, not a mirror.
    assert!(
        md.contains("`planar-mirror` skipped: no planar mirror in view"),
        "{md}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_same_obj_seen_from_outside_gets_no_epipolar_walk_and_says_why() {
    let dir = temp_dir("outside");
    let obj = walled_room_obj(&dir);
    let out = dir.join("report");
    let mut opts = options(&obj, out.clone(), None);
    opts.method = vec!["epipolar".into(), "orsa".into()];
    run(&opts).unwrap();
    assert!(read_csv(&out.join("summary.csv")).is_empty());
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(
        md.contains("epipolar walkthrough skipped: the camera path does not run inside walls"),
        "{md}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_interior_test_reads_the_geometry() {
    for (scene, inside) in [
        (Scene::walkthrough(8_000), true),
        (Scene::room(8_000), true),
        (Scene::concave(8_000), false),
        (Scene::stage(8_000), false),
    ] {
        let tracer = Tracer::new(&scene);
        assert_eq!(Content::interior(&scene, &tracer), inside, "{}", scene.name);
        // The content of no frames: only the scene-wide parts.
        let c = Content::of_scene(&scene, &tracer, []);
        assert_eq!(c.reflective_pixels, 0);
        assert_eq!(c.path_poses, scene.camera_path.len());
        assert_eq!(c.interior, inside);
    }
    // A path of one pose is no walk.
    let mut still = Scene::walkthrough(8_000);
    still.camera_path.truncate(1);
    assert!(!Content::interior(&still, &Tracer::new(&still)));
}

#[test]
fn bad_scene_input_is_refused_before_anything_is_written() {
    let dir = temp_dir("bad");
    let obj = walled_room_obj(&dir);
    let cases: [(&str, &str); 5] = [
        ("nan.txt", "0 1 2 NaN 1 0\n1 1 2 0 1 0\n"),
        ("short.txt", "0 1 2 0 1\n"),
        ("one.txt", "0 1 2 0 1 0\n"),
        ("same.txt", "0 1 2 0 1 2\n1 1 1 0 0 0\n"),
        ("up.txt", "0 1 0 0 5 0\n1 1 1 0 0 0\n"),
    ];
    let expect = [
        "line 1: non-finite value",
        "line 1: expected 6 or 7 numbers",
        "at least 2 poses, found 1",
        "line 1: the eye is its target",
        "line 1: the view is straight up or down",
    ];
    for ((file, text), want) in cases.iter().zip(expect) {
        let path = dir.join(file);
        std::fs::write(&path, text).unwrap();
        let out = dir.join(format!("out-{file}"));
        let err = run(&options(&obj, out.clone(), Some(path))).unwrap_err();
        assert!(err.contains(file) && err.contains(want), "{file}: {err}");
        assert!(!out.exists(), "{file}: nothing written");
    }
    let out = dir.join("out-flags");
    let mut opts = options(&obj, out.clone(), None);
    opts.reflective = vec!["floor:1.5:0.3".into()];
    let err = run(&opts).unwrap_err();
    assert!(err.contains("specular 1.5 is outside [0, 1]"), "{err}");
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn refl_plan_skips_what_a_frame_cannot_use_and_says_why() {
    let args = |bare_host| refl_app::report::PlanArgs {
        scene: vec!["room".into(), "concave".into()],
        width: 128,
        height: 96,
        tris: 4_000,
        reflective: Vec::new(),
        camera_path: None,
        bare_host,
        history: false,
        max_error: vec![0.5],
        max_time: Vec::new(),
        calibration: None,
    };
    let text = refl_app::report::plans(&args(false)).unwrap();
    let (room, concave) = text.split_at(text.find("concave:").unwrap());
    // The room's mirror floor goes to the planar pass; its glossy torus
    // needs the color pyramid.
    assert_eq!(room.matches("  pose ").count(), 12, "{room}");
    let poses = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| l.starts_with("  pose "))
            .map(String::from)
            .collect()
    };
    assert!(
        poses(room)
            .iter()
            .all(|l| l.contains("planar pass for mirror_floor") && l.contains("color pyramid (")),
        "{room}"
    );
    // The method choice per budget: one budget line per pose, and the
    // room's mirror floor exact on the planar pass (the checked-in table:
    // it is as accurate as rays and faster) with its reason.
    assert!(
        text.starts_with("calibration: cargo run --release -- calibrate"),
        "{text}"
    );
    assert_eq!(
        room.matches("    max_error=0.5: predicted").count(),
        12,
        "{room}"
    );
    assert!(room
        .lines()
        .filter(|l| l.starts_with("      - mirror_floor "))
        .all(|l| l.contains(": planar resolution=1/1 (") && l.contains("the most accurate")));
    // Concave: every mirror ray traced (the environment is far over the
    // budget).
    for l in concave.lines().filter(|l| l.starts_with("      - ")) {
        assert!(l.contains("mirror): ray spp=1 ("), "{l}");
    }
    // Concave: mirrors only, none planar: no color or visibility pyramid,
    // no planar pass, no glossy pass.
    for l in poses(concave) {
        for skipped in [
            "color pyramid (nothing reads it)",
            "visibility pyramid (nothing reads it)",
            "glossy pass (no pixels of its class)",
            "planar pass (no pixels of its class)",
        ] {
            assert!(l.contains(skipped), "{skipped}: {l}");
        }
    }
    // A host without extra views or a tracer keeps the mirror floor on the
    // mirror pass and traces nothing itself.
    let bare = refl_app::report::plans(&args(true)).unwrap();
    assert!(!bare.contains("planar pass for"), "{bare}");
    assert!(bare.contains("planar pass (the host cannot)"), "{bare}");
    assert!(bare.contains("host rays (the host cannot)"), "{bare}");
    // ... and has nothing the table measured but the screen-space hybrid,
    // which needs the tracer too: no option.
    assert!(
        bare.contains("no calibrated option applies: its pixels are left out"),
        "{bare}"
    );
    // A host that keeps its last reflections: the temporal pass joins the
    // mirror pass from the second pose on (the camera moves every pose),
    // and the first pose has no history.
    let mut history = args(false);
    history.history = true;
    let with = refl_app::report::plans(&history).unwrap();
    let room_poses = poses(with.split_at(with.find("concave:").unwrap()).0);
    assert!(
        !room_poses[0].contains("temporal pass,")
            && room_poses[0].contains("temporal pass (the host cannot)")
    );
    assert!(room_poses[1..]
        .iter()
        .all(|l| l.contains(", temporal pass;") && !l.contains("nothing moved")));
    assert!(poses(room)
        .iter()
        .all(|l| l.contains("temporal pass (the host cannot)")));
    // A budget that is not a number is refused with its flag.
    let mut nan = args(false);
    nan.max_time = vec![f32::NAN];
    let err = refl_app::report::plans(&nan).unwrap_err();
    assert!(err.contains("--max-time NaN"), "{err}");
}
