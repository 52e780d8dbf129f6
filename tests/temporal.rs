//! The temporal path (`refl_app::temporal`, seed 004 Sec. 4.6.5 and the
//! temporal super-sampling of Sec. 4.7.4) on a static camera: temporal
//! super-sampling traces a quarter of the rays per frame, and once every
//! pixel of a 2x2 block has been traced (four frames) its error comes back
//! to that of the full-resolution pass with recovery.

use refl_app::scene::Scene;
use refl_app::shade::Shader;
use refl_app::tcrr::PathRun;
use refl_app::temporal::{run_path, Setting};
use refl_app::tracer::Tracer;
use refl_core::temporal::TemporalOptions;

#[test]
fn super_sampling_converges_on_a_static_camera() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let scene = Scene::stage(20_000);
    let tracer = Tracer::new(&scene);
    let shader = Shader::new(&scene, &tracer);
    let cam = scene.camera(0, 160, 120).unwrap();
    let cameras = vec![cam; 6];
    let recovery = Setting {
        filter: Some(TemporalOptions {
            max_frames: 1.0,
            ..TemporalOptions::default()
        }),
        distances: true,
        tss: false,
    };
    let tss = Setting {
        tss: true,
        ..recovery
    };
    let off = Setting {
        filter: None,
        distances: false,
        tss: false,
    };
    let run = PathRun {
        shader: &shader,
        label: "stage",
        cameras: &cameras,
        threads: 2,
        pool: &pool,
    };
    let out = run_path(&run, &[off, recovery, tss], None).unwrap();
    assert_eq!(
        tss.label(),
        "temporal=on;reproject=virtual;max_frames=1;half=tss"
    );
    let errors = |label: &str| {
        out.per_frame
            .iter()
            .find(|(l, _)| l == label)
            .map(|(_, e)| e.clone())
            .unwrap()
    };
    let (e_off, e_rec, e_tss) = (
        errors(&off.label()),
        errors(&recovery.label()),
        errors(&tss.label()),
    );
    eprintln!("off {e_off:?}\nrecovery {e_rec:?}\ntss {e_tss:?}");
    // A quarter of the rays (blocks at the image edge round up).
    let rays = |label: &str| {
        let r = out.rows.iter().find(|r| r.setting == label).unwrap();
        let (_, v) = r.extra.iter().find(|(k, _)| k == "rays_per_frame").unwrap();
        v.parse::<f64>().unwrap()
    };
    let (full, quarter) = (rays(&recovery.label()), rays(&tss.label()));
    assert!(
        quarter > 0.2 * full && quarter < 0.3 * full,
        "{quarter} of {full}"
    );
    // Frame 0 has only a quarter traced and no history: worse than the
    // full pass; from frame 3 on every pixel has its own trace in the
    // history and the error is the full pass's with recovery, up to the
    // pixels whose own trace fails, which show the upsampled color of
    // their block's neighbors instead of the environment.
    assert!(e_tss[0] > e_rec[0], "{e_tss:?} {e_rec:?}");
    for f in 3..6 {
        assert!(
            (e_tss[f] - e_rec[f]).abs() < 0.25 * e_rec[f] + 0.1,
            "frame {f}: {} vs {}",
            e_tss[f],
            e_rec[f]
        );
        assert!(e_tss[f] < e_tss[0], "frame {f}");
    }
}
