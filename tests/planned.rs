//! The planner's glue in the root package (`refl_app::report::planned`):
//! on the stage (a mirror floor, a torus, a wall), the groups follow the
//! frame's objects, the choice follows a hand-made table, and a
//! technique's run covers exactly the pixels of its group (the planar
//! render's uncovered rest ray traced).

use refl_app::calibration::{Calibration, Technique};
use refl_app::gbuffer::GBuffer;
use refl_app::render;
use refl_app::report::plan::REPORT_HOST;
use refl_app::report::planned::{budgets_of, choose};
use refl_app::scene::Scene;
use refl_app::shade::Shader;
use refl_app::tracer::Tracer;
use refl_core::plan::{Budget, ChoiceReason, HostCaps};
use refl_core::summary::RoughnessClass;

const TABLE: &str = "# command: hand-made for this test\n# commit: none-needed\n\
method,setting,class,surface,time_ratio,error_255,pixels,frames\n\
ray,spp=1,mirror,any,1.0,0.0,1,1\n\
planar,resolution=1/1,mirror,planar,0.8,0.0,1,1\n\
planar,resolution=1/4,mirror,planar,0.5,2.0,1,1\n\
envmap,analytic,mirror,any,0.1,40.0,1,1\n";

/// The stage (8,000 triangles), its tracer and a two-thread pool.
fn stage() -> (Scene, Tracer, rayon::ThreadPool) {
    let scene = Scene::stage(8_000);
    let tracer = Tracer::new(&scene);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    (scene, tracer, pool)
}

#[test]
fn stage_choice_and_runs() {
    let (scene, tracer, pool) = stage();
    let camera = scene.camera(0, 96, 72).unwrap();
    let g = GBuffer::render(&scene, &tracer, &camera, &pool);
    let shader = Shader::new(&scene, &tracer);
    let direct = render::direct_image(&shader, &g, &pool);
    let cal = Calibration::parse(TABLE).unwrap();
    let table = cal.cost_table();

    // Exact: the planar pass on the floor (it dominates rays there), rays
    // on curved mirrors.
    let p = choose(&scene, &g, &REPORT_HOST, &table, Budget::MaxError(0.0)).unwrap();
    assert!(p.budget.met);
    let floor = p
        .choices
        .iter()
        .find(|c| c.group.planar)
        .expect("the stage's floor is a planar group");
    assert_eq!(
        scene.objects[floor.group.object as usize].name,
        "mirror_floor"
    );
    assert_eq!(floor.entry, Some(1));
    assert_eq!(floor.group.class, RoughnessClass::Mirror);
    for c in p.choices.iter().filter(|c| !c.group.planar) {
        assert_eq!(c.entry, Some(0), "{:?}", c.group);
    }
    assert_eq!(p.budget.covered, p.budget.reflective);
    // A time budget below every option: all fastest (the environment).
    let p = choose(&scene, &g, &REPORT_HOST, &table, Budget::MaxTime(0.05)).unwrap();
    assert!(!p.budget.met);
    assert!(p
        .choices
        .iter()
        .all(|c| c.entry == Some(3) && c.reason == ChoiceReason::TimeBudgetUnreachable));
    // A host with nothing: no option anywhere.
    let p = choose(
        &scene,
        &g,
        &HostCaps::default(),
        &table,
        Budget::MaxError(1.0),
    )
    .unwrap();
    assert_eq!(p.budget.covered, 0);

    // The planar technique on the floor's pixels: every one handled, none
    // outside, and the result is the ray-traced one (the planar pass at
    // full resolution is exact).
    let object = floor.group.object;
    let mask: Vec<bool> = (0..g.len())
        .map(|i| g.is_reflective(i) && g.object[i] == object)
        .collect();
    let planar = Technique::Planar { scale: 1 }
        .run(&shader, &g, &direct, &mask, &pool)
        .unwrap()
        .value;
    let rays = Technique::Ray { samples: 1 }
        .run(&shader, &g, &direct, &mask, &pool)
        .unwrap()
        .value;
    assert_eq!(planar.handled, mask);
    assert_eq!(rays.handled, mask);
    let err = render::compare(&planar.rgb, &rays.rgb, &mask);
    assert!(err.mean_abs < 0.05, "{}", err.mean_abs);
    // The hybrid: every pixel handled, close to the rays (its hits shade
    // the direct-lit color at the hit texel, the rest is traced).
    let hybrid = Technique::HiZRay
        .run(&shader, &g, &direct, &mask, &pool)
        .unwrap()
        .value;
    assert_eq!(hybrid.handled, mask);
    let env = Technique::EnvMap
        .run(&shader, &g, &direct, &mask, &pool)
        .unwrap()
        .value;
    assert_eq!(env.handled, mask);
}

#[test]
fn bad_budgets_are_refused_with_the_flag() {
    for v in [f32::NAN, f32::INFINITY, -0.5] {
        let e = budgets_of(&[v], &[]).unwrap_err();
        assert!(e.contains("--max-error") && e.contains("finite"), "{e}");
        let e = budgets_of(&[], &[v]).unwrap_err();
        assert!(e.contains("--max-time"), "{e}");
    }
    assert_eq!(
        budgets_of(&[0.5], &[2.0]).unwrap(),
        [Budget::MaxError(0.5), Budget::MaxTime(2.0)]
    );
}

/// Issue 15, part 3: the hybrid (`hiz+ray`) traces the mirror pass's own
/// list of rays it could not answer. The list holds exactly the pixels
/// whose status needs the host, once each, in row-major order; traced by
/// the host's tracer, those pixels match the reference tracer (which
/// traces from the G-buffer's exact surface point, the list from the point
/// the pass reconstructs from depth); the pass's own hits shade the lit
/// frame at the hit texel and its sky answers the environment, the only
/// approximate parts.
#[test]
fn hybrid_traces_the_pass_host_list() {
    use refl_app::screen::{run_with_host_rays, DepthBuffer, PassImages, ScreenMethod};
    use refl_core::{DepthConvention, MirrorStatus};
    let (scene, tracer, pool) = stage();
    let camera = scene.camera(0, 160, 120).unwrap();
    let g = GBuffer::render(&scene, &tracer, &camera, &pool);
    let shader = Shader::new(&scene, &tracer);
    let direct = render::direct_image(&shader, &g, &pool);
    let mask: Vec<bool> = (0..g.len()).map(|i| g.is_reflective(i)).collect();
    let images = PassImages::with_mask(&g, Some(&direct), &mask);
    let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY).unwrap();
    let image = depth.image().unwrap();
    let method = ScreenMethod::HiZ(refl_core::hiz::HiZOptions::default());
    let (run, list) = run_with_host_rays(method, true, &image, &images, &pool)
        .unwrap()
        .value;
    let w = g.width() as usize;
    let needs: Vec<usize> = (0..g.len())
        .filter(|&i| run.texels[i].status.needs_host())
        .collect();
    let listed: Vec<usize> = list
        .iter()
        .map(|r| r.y as usize * w + r.x as usize)
        .collect();
    assert_eq!(listed, needs, "the list is the host pixels in row order");
    assert_eq!(run.stats.host_rays as usize, list.len());
    for r in &list {
        let i = r.y as usize * w + r.x as usize;
        assert_eq!(r.status, run.texels[i].status);
        assert!((r.dir.length() - 1.0).abs() < 1e-4, "{r:?}");
    }
    let count = |s: MirrorStatus| run.texels.iter().filter(|t| t.status == s).count();
    let (hits, sky) = (count(MirrorStatus::Hit), count(MirrorStatus::Sky));
    assert!(
        list.len() > 100 && hits > 100,
        "the stage has both: {} host rays, {hits} hits",
        list.len()
    );

    let hybrid = Technique::HiZRay
        .run(&shader, &g, &direct, &mask, &pool)
        .unwrap()
        .value;
    let rays = Technique::Ray { samples: 1 }
        .run(&shader, &g, &direct, &mask, &pool)
        .unwrap()
        .value;
    assert_eq!(hybrid.handled, mask);
    let only = |keep: &dyn Fn(MirrorStatus) -> bool| -> Vec<bool> {
        (0..g.len())
            .map(|i| mask[i] && keep(run.texels[i].status))
            .collect()
    };
    let host_err = render::compare(&hybrid.rgb, &rays.rgb, &only(&|s| s.needs_host()));
    let sky_err = render::compare(&hybrid.rgb, &rays.rgb, &only(&|s| s == MirrorStatus::Sky));
    let hit_err = render::compare(&hybrid.rgb, &rays.rgb, &only(&|s| s == MirrorStatus::Hit));
    let all_err = render::compare(&hybrid.rgb, &rays.rgb, &mask);
    eprintln!(
        "host {} px {:.4}/255 (max {}), sky {sky} px {:.4}, hits {hits} px {:.4}, all {:.4}",
        host_err.pixels,
        host_err.mean_abs,
        host_err.max_abs,
        sky_err.mean_abs,
        hit_err.mean_abs,
        all_err.mean_abs
    );
    assert_eq!(host_err.pixels, list.len());
    assert!(host_err.mean_abs < 0.02, "{host_err:?}");
    // Sky is the pass's own answer (the ray stays in front of every depth
    // sample to its vanishing point): right but for the rare ray that
    // slips between the samples of a thin edge (5 of 2,984 here).
    assert!(sky > 100 && sky_err.share_over(0) < 0.01, "{sky_err:?}");
    // The pass's hits carry the screen's approximation; the hybrid as a
    // whole is at most as far from the reference as those hits make it.
    assert!(all_err.mean_abs <= hit_err.mean_abs + 0.1, "{all_err:?}");
}
