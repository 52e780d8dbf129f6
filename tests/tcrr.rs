//! TCRR on the built-in camera paths (seed 000): the stationary camera
//! reproduces its key frame exactly, TCRR beats naive warping on the room
//! path, and the re-traced pixels are exactly those the reference traces.

use refl_app::scene::Scene;
use refl_app::shade::Shader;
use refl_app::tcrr::{path_cameras, run_path, PathRun, Scheme, Setting};
use refl_app::tracer::Tracer;
use refl_core::TcrrOptions;

fn pool() -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
}

fn setting(scheme: Scheme) -> Setting {
    Setting {
        scheme,
        threshold: 0.3,
        params: TcrrOptions::default(),
    }
}

fn extra(row: &refl_app::report_out::Row, name: &str) -> f64 {
    row.extra
        .iter()
        .find(|(k, _)| k == name)
        .unwrap()
        .1
        .parse()
        .unwrap()
}

#[test]
fn stationary_camera_reproduces_the_key_frame_exactly() {
    let scene = Scene::room(20_000);
    let tracer = Tracer::new(&scene);
    let shader = Shader::new(&scene, &tracer);
    let cam = scene.camera(3, 128, 96).unwrap();
    let cams = vec![cam; 3];
    let pool = pool();
    let run = PathRun {
        shader: &shader,
        label: "room",
        cameras: &cams,
        threads: 2,
        pool: &pool,
    };
    let out = run_path(
        &run,
        &[setting(Scheme::Tcrr), setting(Scheme::NaiveWarp)],
        None,
    )
    .unwrap();
    for (name, frames) in &out.per_frame {
        assert!(frames[0].0, "{name}: frame 0 is the key frame");
        for &(key, share, mad) in &frames[1..] {
            assert!(!key, "{name}");
            assert_eq!(mad, 0.0, "{name}");
            assert!(share < 0.05, "{name}: {share}");
        }
    }
    for row in &out.rows {
        assert!(row.psnr_db.is_infinite(), "{}", row.method);
        assert_eq!(extra(row, "key_frames"), 1.0);
    }
}

#[test]
fn tcrr_beats_naive_warping_on_the_room_path() {
    let scene = Scene::room(20_000);
    let tracer = Tracer::new(&scene);
    let shader = Shader::new(&scene, &tracer);
    let cams = path_cameras(&scene, 5, (0.0, 0.06), 128, 96).unwrap();
    // The seed's warping (no re-trace contrast test) against naive
    // warping; then the default contrast test, which re-traces reflected
    // edges.
    let seed = Setting {
        params: TcrrOptions {
            retrace_contrast: f32::INFINITY,
            ..TcrrOptions::default()
        },
        ..setting(Scheme::Tcrr)
    };
    let strict = Setting {
        threshold: 1.0,
        ..setting(Scheme::Tcrr)
    };
    let pool = pool();
    let run = PathRun {
        shader: &shader,
        label: "room",
        cameras: &cams,
        threads: 2,
        pool: &pool,
    };
    let out = run_path(&run, &[seed, setting(Scheme::NaiveWarp), strict], None).unwrap();
    let (t, n, c) = (&out.rows[0], &out.rows[1], &out.rows[2]);
    assert_eq!(extra(c, "key_frames"), 1.0);
    assert!(
        extra(c, "mean_abs_255_reuse_frames") < extra(t, "mean_abs_255_reuse_frames"),
        "contrast test {} vs seed warping {}",
        extra(c, "mean_abs_255_reuse_frames"),
        extra(t, "mean_abs_255_reuse_frames")
    );
    assert!(extra(c, "retraced_share") > 0.0);
    assert_eq!(
        (t.method.as_str(), n.method.as_str()),
        ("tcrr", "naive-warp")
    );
    // Both reuse at least one frame; TCRR's reused frames are far closer to
    // the ray-traced reference than naive warping's.
    assert!(extra(t, "key_frames") < 5.0 && extra(n, "key_frames") < 5.0);
    let (et, en) = (
        extra(t, "mean_abs_255_reuse_frames"),
        extra(n, "mean_abs_255_reuse_frames"),
    );
    assert!(et * 2.0 < en, "tcrr {et} naive {en}");
    // TCRR re-traces a share of the mirror pixels, not all of them.
    let share = extra(t, "retraced_share");
    assert!(share > 0.0 && share < 1.0, "{share}");
}
