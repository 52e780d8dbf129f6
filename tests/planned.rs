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

#[test]
fn stage_choice_and_runs() {
    let scene = Scene::stage(8_000);
    let tracer = Tracer::new(&scene);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
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
