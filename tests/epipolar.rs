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
    // Seed 002's work counters over frames 1..: one primary ray per pixel;
    // IRSA tests only the object ORSA found, so fewer triangles, but at
    // least one per pixel that sees an object; the method tests fewer
    // triangles than ORSA and more than IRSA (Table 1: REPR's Ñ_IT 3.37
    // between ORSA's 9.23 and IRSA's 0.98 with kd-trees; with refl's
    // 8-wide BVHs of up to 3 triangles a leaf, ORSA's own Ñ_IT is already
    // low, so the gap is narrower).
    let pixels = (sizes.width * sizes.height) as u64 * (sizes.frames as u64 - 1);
    assert_eq!(report.orsa_count.rays, pixels);
    assert_eq!(default.steady_pixels, pixels);
    let (o_it, i_it, m_it) = (
        report.orsa_count.tests_per_ray(pixels),
        report.irsa_count.tests_per_ray(pixels),
        default.count.tests_per_ray(pixels),
    );
    assert!(i_it > 0.5 && i_it < o_it, "IRSA Ñ_IT {i_it}, ORSA {o_it}");
    assert!(
        m_it < o_it && m_it > i_it,
        "method Ñ_IT {m_it}, ORSA {o_it}, IRSA {i_it}"
    );
    let (o_ts, m_ts) = (
        report.orsa_count.steps_per_ray(pixels),
        default.count.steps_per_ray(pixels),
    );
    assert!(
        o_ts >= 1.0 && m_ts < o_ts,
        "Ñ_TS method {m_ts}, ORSA {o_ts}"
    );
    // Shadow rays (Sec. 7.4): reprojected occluders answer part of the
    // shadowed rays with one object test, and every answer is the full
    // traversal's.
    let sh = &report.shadows;
    assert!(sh.rays > 0 && sh.shadowed > 0, "{sh:?}");
    assert_eq!(sh.errors, 0, "{sh:?}");
    assert!(
        sh.reprojected > 0 && sh.reprojected <= sh.shadowed,
        "{sh:?}"
    );
    assert_eq!(sh.orsa_ms.len(), sizes.frames);
    eprintln!(
        "shadows: {} rays, {:.1}% shadowed, {:.1}% reprojected",
        sh.rays,
        100.0 * sh.shadowed as f64 / sh.rays as f64,
        100.0 * sh.reprojected as f64 / sh.rays as f64
    );
    let (rows, _) = refl_app::report::epipolar::rows(&scene, &sizes, &report, 2, None).unwrap();
    for setting in ["shadow_rays=any_hit", "shadow_rays=reprojected_occluder"] {
        assert!(rows.iter().any(|r| r.setting == setting), "{setting}");
    }
    for m in ["orsa", "irsa", "epipolar"] {
        let row = rows
            .iter()
            .find(|r| r.method == m)
            .unwrap_or_else(|| panic!("{m}"));
        for k in ["n_it", "n_ts"] {
            let v: f64 = row
                .extra
                .iter()
                .find(|(key, _)| key == k)
                .unwrap()
                .1
                .parse()
                .unwrap();
            assert!(v > 0.0, "{m} {k} {v}");
        }
    }
    eprintln!(
        "Ñ_IT ORSA {o_it:.2} IRSA {i_it:.2} method {m_it:.2}; Ñ_TS ORSA {o_ts:.2} method {m_ts:.2}"
    );
}
