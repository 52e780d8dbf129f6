//! Seed 002 along the walkthrough path: the method's visibility equals full
//! traversal (ORSA) on every pixel of every frame, with the default
//! settings, and most pixels take one ray/object test.

use refl_app::epipolar::{measure, Gaze, PathSizes};
use refl_app::scene::Scene;
use refl_app::tracer::Tracer;

#[test]
fn walkthrough_has_no_visibility_errors() {
    let scene = Scene::walkthrough(20_000);
    let tracer = Tracer::new(&scene);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let sizes = PathSizes {
        width: 160,
        height: 120,
        frames: 8,
        step: 0.05,
        start: 0.3,
        gaze: Gaze::AlongPath,
        ablations: true,
    };
    let report = measure(&scene, &tracer, &sizes, 1, &pool, None).unwrap();
    let (_, default) = &report.totals[0];
    assert!(
        default.mismatches.is_empty(),
        "visibility errors: {:?}",
        &default.mismatches[..default.mismatches.len().min(10)]
    );
    // Frame 0 (and any frame failing the view-frustum check) is all ORSA;
    // the others mostly one test.
    let steady = (default.pixels - default.unavailable) as f64;
    assert!(default.unavailable < default.pixels / 2);
    assert!(default.resolved as f64 > 0.5 * steady, "{default:?}");
    let c_o = default.resampled as f64 / steady;
    assert!((c_o - 1.0 / 9.0).abs() < 0.01, "c_O = {c_o}");
    // Every setting with the depth guard and the occlusion check is exact.
    for (setting, t) in &report.totals {
        if setting != "depth_guard=off"
            && setting != "guard_margin=0"
            && setting != "guard_window=0"
            && setting != "occlusion_check=off"
            && setting != "shift_origin=on"
            && setting != "splat=1x1;m_cnt=1"
        {
            assert!(
                t.mismatches.is_empty(),
                "{setting}: {:?}",
                t.mismatches.first()
            );
        }
    }
    let (rows, _) = refl_app::report::epipolar::rows(&scene, &sizes, &report, 2, None).unwrap();
    for m in ["orsa", "irsa", "epipolar"] {
        assert!(rows.iter().any(|r| r.method == m), "{m}");
    }
}
