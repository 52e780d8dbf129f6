//! Screen-space reflections and layered maps in the root package, against
//! the obvhs reference hits of the same rays: hit rates, agreement between
//! kernels and depth conventions, and what the report's rows are built from.

use refl_app::gbuffer::GBuffer;
use refl_app::layered_render::{self, LayeredScene};
use refl_app::scene::Scene;
use refl_app::screen::{self, DepthBuffer, ScreenMethod};
use refl_app::shade::Shader;
use refl_app::tracer::Tracer;
use refl_core::hiz::HiZOptions;
use refl_core::{DepthConvention, StepOptions, Thickness, Trace};

struct Fixture {
    scene: Scene,
    tracer: Tracer,
    pool: rayon::ThreadPool,
}

fn fixture() -> Fixture {
    let scene = Scene::room(10_000);
    let tracer = Tracer::new(&scene);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("pool");
    Fixture {
        scene,
        tracer,
        pool,
    }
}

fn traces(
    depth: &DepthBuffer,
    thickness: f32,
    m: ScreenMethod,
    rays: &[refl_core::Ray],
    pool: &rayon::ThreadPool,
) -> Vec<Trace> {
    let image = depth.image().expect("image");
    screen::run(m, true, &image, Thickness::Constant(thickness), rays, pool)
        .expect("run")
        .value
}

/// Stepping and Hi-Z find the visible reference hits within a pixel on the
/// room's reflection rays in every depth convention, and agree with each
/// other ray by ray.
#[test]
fn step_and_hiz_find_visible_hits_in_every_convention() {
    let f = fixture();
    let shader = Shader::new(&f.scene, &f.tracer);
    let cam = f.scene.camera(0, 192, 144).expect("camera");
    let g = GBuffer::render(&f.scene, &f.tracer, &cam, &f.pool);
    let rays = screen::reflection_rays(&f.scene, &f.tracer, &shader, &g, &f.pool);
    assert!(rays.len() > 1000, "{} rays", rays.len());
    assert!(rays.visible_count() > rays.len() / 5);
    let thickness = f.scene.diameter() * screen::THICKNESS_OF_DIAMETER;
    for c in DepthConvention::ALL {
        let far = if c == DepthConvention::ReversedZ {
            f32::INFINITY
        } else {
            cam.far()
        };
        let depth = DepthBuffer::new(&g, c, far).expect("depth");
        let step = traces(
            &depth,
            thickness,
            ScreenMethod::Step(StepOptions::default()),
            &rays.screen_ray,
            &f.pool,
        );
        let hiz = traces(
            &depth,
            thickness,
            ScreenMethod::HiZ(HiZOptions::default()),
            &rays.screen_ray,
            &f.pool,
        );
        let (s, h) = (
            screen::evaluate(&rays, &step),
            screen::evaluate(&rays, &hiz),
        );
        assert!(s.hit_rate() >= 0.93, "{c:?} step hit rate {}", s.hit_rate());
        assert!(h.hit_rate() >= 0.93, "{c:?} hiz hit rate {}", h.hit_rate());
        assert!(
            s.false_hit_rate() <= 0.15,
            "{c:?} false hits {}",
            s.false_hit_rate()
        );
        // Same hit (or same miss) within a pixel, ray by ray.
        let agree = step
            .iter()
            .zip(&hiz)
            .filter(|(a, b)| match (a.hit(), b.hit()) {
                (Some(a), Some(b)) => (a.pixel - b.pixel).length() <= 1.0,
                (None, None) => true,
                _ => false,
            })
            .count();
        assert!(
            agree as f64 >= 0.99 * step.len() as f64,
            "{c:?}: step and Hi-Z agree on {agree} of {}",
            step.len()
        );
        // Hi-Z reads far fewer texels than unit stepping.
        assert!(
            h.fetches * 3 < s.fetches,
            "{c:?}: {} vs {}",
            h.fetches,
            s.fetches
        );
    }
}

/// Coarse strides refine to the unit-stride hit on most rays.
#[test]
fn strided_stepping_refines_to_unit_hits() {
    let f = fixture();
    let shader = Shader::new(&f.scene, &f.tracer);
    let cam = f.scene.camera(1, 160, 120).expect("camera");
    let g = GBuffer::render(&f.scene, &f.tracer, &cam, &f.pool);
    let rays = screen::reflection_rays(&f.scene, &f.tracer, &shader, &g, &f.pool);
    let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY).expect("depth");
    let thickness = f.scene.diameter() * screen::THICKNESS_OF_DIAMETER;
    let unit = traces(
        &depth,
        thickness,
        ScreenMethod::Step(StepOptions::default()),
        &rays.screen_ray,
        &f.pool,
    );
    let coarse = traces(
        &depth,
        thickness,
        ScreenMethod::Step(StepOptions {
            stride: 4,
            max_steps: u32::MAX,
        }),
        &rays.screen_ray,
        &f.pool,
    );
    let same = unit
        .iter()
        .zip(&coarse)
        .filter(|(a, b)| match (a.hit(), b.hit()) {
            (Some(a), Some(b)) => (a.pixel - b.pixel).length() <= 1.0,
            (None, None) => true,
            _ => false,
        })
        .count();
    assert!(
        same as f64 >= 0.95 * unit.len() as f64,
        "{same} of {}",
        unit.len()
    );
    let (u, c) = (
        screen::evaluate(&rays, &unit),
        screen::evaluate(&rays, &coarse),
    );
    assert!(c.fetches < u.fetches);
}

/// Layered maps of the room's reflected objects hit the same object as the
/// reference within a texel diagonal for nearly every ray aimed at them.
#[test]
fn layered_maps_agree_with_reference_hits() {
    let f = fixture();
    let shader = Shader::new(&f.scene, &f.tracer);
    let objects = layered_render::reflected_objects(&f.scene);
    assert!(!objects.is_empty());
    for &o in &objects {
        assert!(!f.scene.materials[f.scene.objects[o as usize].material as usize].is_reflective());
    }
    let cam = f.scene.camera(0, 160, 120).expect("camera");
    let g = GBuffer::render(&f.scene, &f.tracer, &cam, &f.pool);
    let rays = screen::reflection_rays(&f.scene, &f.tracer, &shader, &g, &f.pool);
    let ls = LayeredScene::build(&f.scene, 64, 4, &f.pool).expect("maps");
    let frame = layered_render::LayeredFrame::new(&g);
    let tr = ls
        .trace(&g, &frame, &Default::default(), &f.pool)
        .expect("trace");
    let s = layered_render::evaluate(&f.scene, &ls, &rays, &tr);
    assert!(s.to_objects > 200, "{s:?}");
    assert!(
        s.agree as f64 >= 0.97 * s.to_objects as f64,
        "agree {} of {}",
        s.agree,
        s.to_objects
    );
    assert!(s.false_hits * 20 < s.to_objects, "{s:?}");
    let img = layered_render::shade(&shader, &g, &tr);
    assert!(img.handled_count() > 0);
}
