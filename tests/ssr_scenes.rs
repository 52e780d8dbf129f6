//! refl-core's mirror pass with its default options on the `stage` scene
//! (issue 13: a torus standing on a wide mirror floor, a wall and a box,
//! near and grazing poses), through the root package's driver
//! (`screen::run`) and measured with its evaluation (`screen::evaluate`:
//! reference hits of the pass's own rays by obvhs).
//!
//! Before issue 13 the root package traced its own rays (a start rule of
//! half a depth slope, a constant thickness of 0.005 scene diameters, no
//! hit validation): on this scene at 256x192 over the 12 poses stride-1
//! stepping (Hi-Z alike) reported hits for 9.16% of the rays whose
//! reflection is not visible (4.5% at pose 0 to 12.9% at pose 6, filling
//! the floor near the camera, whose reflection is the sky) and found 93.95%
//! of the visible reflections (90.7% to 99.2%). The pass: 2.85% and 98.82%.

use refl_app::gbuffer::GBuffer;
use refl_app::scene::Scene;
use refl_app::screen::{self, DepthBuffer, PassImages, RayStats, ScreenMethod};
use refl_app::shade::Shader;
use refl_app::tracer::Tracer;
use refl_core::hiz::HiZOptions;
use refl_core::{DepthConvention, MirrorStatus, StepOptions};

/// Per pose and kernel: the evaluation, and the visible reflections the
/// pass answered as sky (it should hand them to the host instead).
struct PoseResult {
    stats: RayStats,
    visible_as_sky: usize,
}

fn run_pose(
    scene: &Scene,
    tracer: &Tracer,
    shader: &Shader,
    pose: usize,
    pool: &rayon::ThreadPool,
) -> [PoseResult; 2] {
    let cam = scene.camera(pose, 256, 192).expect("camera");
    let g = GBuffer::render(scene, tracer, &cam, pool);
    let rays = screen::reflection_rays(scene, tracer, shader, &g, pool);
    let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY).expect("depth");
    let image = depth.image().expect("image");
    let images = PassImages::new(&g, None);
    [
        ScreenMethod::Step(StepOptions::default()),
        ScreenMethod::HiZ(HiZOptions::default()),
    ]
    .map(|m| {
        let out = screen::run(m, true, &image, &images, pool)
            .expect("pass")
            .value;
        let visible_as_sky = rays
            .pixel
            .iter()
            .zip(&rays.visible)
            .filter(|&(&p, &v)| v && out.texels[p as usize].status == MirrorStatus::Sky)
            .count();
        PoseResult {
            stats: screen::evaluate(&rays, &out.texels),
            visible_as_sky,
        }
    })
}

/// Every pose of the stage: few false hits, the pass's hits on visible
/// reflections land within a pixel, most visible reflections are found,
/// almost none is answered as sky, and stepping and Hi-Z agree.
#[test]
fn mirror_pass_defaults_are_robust_on_the_stage() {
    let scene = Scene::stage(30_000);
    let tracer = Tracer::new(&scene);
    let shader = Shader::new(&scene, &tracer);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("pool");
    let mut total = [RayStats::default(), RayStats::default()];
    let mut worst_false = 0.0f64;
    let mut sky = [0usize; 2];
    for pose in 0..scene.camera_path.len() {
        let r = run_pose(&scene, &tracer, &shader, pose, &pool);
        for (k, name) in ["step", "hiz"].iter().enumerate() {
            let s = &r[k].stats;
            eprintln!(
                "pose {pose} {name}: {} rays, {} visible, found {:.2}% ({} wrong, {} missed), \
                 false hits {:.2}% ({} of {})",
                s.rays,
                s.visible,
                100.0 * s.hit_rate(),
                s.wrong,
                s.missed,
                100.0 * s.false_hit_rate(),
                s.false_hits,
                s.rays - s.visible
            );
            total[k].add(s);
            sky[k] += r[k].visible_as_sky;
            worst_false = worst_false.max(s.false_hit_rate());
        }
        // Both kernels find the same hits.
        assert_eq!(r[0].stats.found, r[1].stats.found, "pose {pose}");
        assert!(r[0].stats.false_hits.abs_diff(r[1].stats.false_hits) <= 2);
    }
    for (k, name) in ["step", "hiz"].iter().enumerate() {
        let s = &total[k];
        let precise = s.found as f64 / (s.found + s.wrong) as f64;
        eprintln!(
            "{name}, all poses: found {:.2}%, hits on visible reflections within a pixel {:.2}%, \
             false hits {:.2}%, {} visible reflections answered as sky",
            100.0 * s.hit_rate(),
            100.0 * precise,
            100.0 * s.false_hit_rate(),
            sky[k]
        );
        // Measured (stepping and Hi-Z alike): false hits 2.85% over all
        // poses (1.41% to 4.53% per pose: sub-pixel ambiguities at the
        // torus's silhouette and at its contact with the floor, whose true
        // reflection is the hidden underside, and rays that pass behind
        // the torus where the box hides); 99.71% of the hits on visible
        // reflections within a pixel; 98.82% of the visible reflections
        // found (95.8% at pose 9, where rays to the wall behind the torus
        // go to the host); 6 of 126,704 visible reflections answered as
        // sky.
        assert!(s.false_hit_rate() <= 0.03, "{name}: {s:?}");
        assert!(worst_false <= 0.05, "{name}: worst pose {worst_false}");
        assert!(precise >= 0.99, "{name}: {s:?}");
        assert!(s.hit_rate() >= 0.98, "{name}: {s:?}");
        assert!(sky[k] * 10_000 <= s.visible, "{name}: {} as sky", sky[k]);
    }
}
