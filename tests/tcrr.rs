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

/// The final image TCRR's rows are measured on is seed 000's Fresnel
/// composition: at a reflective pixel `(1 - w) direct + w reflection` with
/// Schlick's `w = f + (1 - f) (1 - cos)^5` of the specular factor `f` at
/// `cos = n . v` (geometric normal, direction to the eye), in f64 here;
/// the direct term alone where the specular factor is zero.
#[test]
fn finals_are_the_fresnel_composition_of_seed_000() {
    use glam::{DVec3, Vec3};
    let scene = Scene::room(20_000);
    let tracer = Tracer::new(&scene);
    let shader = Shader::new(&scene, &tracer);
    let cam = scene.camera(3, 96, 72).unwrap();
    let pool = pool();
    let g = refl_app::gbuffer::GBuffer::render(&scene, &tracer, &cam, &pool);
    let direct = refl_app::render::direct_image(&shader, &g, &pool);
    let reflection: Vec<Vec3> = (0..g.len())
        .map(|i| Vec3::new(0.9, 0.1 + (i % 7) as f32 * 0.1, 0.5))
        .collect();
    let spec: Vec<f32> = (0..g.len())
        .map(|i| {
            if g.is_reflective(i) {
                g.specular[i]
            } else {
                0.0
            }
        })
        .collect();
    let fin = refl_app::tcrr::fresnel_composite(&g, &direct, &reflection, &spec).unwrap();
    let w = g.width() as usize;
    let (mut blended, mut grazing) = (0, 0);
    for i in 0..g.len() {
        let f = f64::from(spec[i]);
        let want = if f > 0.0 && g.depth[i].is_finite() {
            let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
            let p = cam.primary_ray(glam::Vec2::new(x, y));
            let point = p.origin.as_dvec3()
                + p.dir.as_dvec3() * f64::from(g.depth[i])
                    / f64::from(cam.linear_depth(p.origin + p.dir));
            let v = (cam.eye().as_dvec3() - point).normalize();
            let cos = g.geo_normal[i]
                .as_dvec3()
                .normalize()
                .dot(v)
                .clamp(0.0, 1.0);
            let wgt = f + (1.0 - f) * (1.0 - cos).powi(5);
            blended += 1;
            grazing += usize::from(wgt > f + 0.05);
            direct[i].as_dvec3() * (1.0 - wgt) + reflection[i].as_dvec3() * wgt
        } else {
            direct[i].as_dvec3()
        };
        let d: DVec3 = fin[i].as_dvec3() - want;
        assert!(
            d.abs().max_element() < 2e-3,
            "pixel {i}: {} vs {want}",
            fin[i]
        );
    }
    assert!(blended > 100, "{blended} reflective pixels");
    assert!(grazing > 0, "no pixel where Fresnel raises the weight");
}
