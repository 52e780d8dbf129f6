//! Screen-space reflections (refl-core's mirror pass) and layered maps in
//! the root package, against the obvhs reference hits of the same rays: hit
//! and false-hit rates, agreement between kernels and depth conventions,
//! and what the report's rows are built from.

use refl_app::gbuffer::GBuffer;
use refl_app::layered_render::{self, LayeredScene};
use refl_app::scene::Scene;
use refl_app::screen::{self, DepthBuffer, PassImages, ScreenMethod};
use refl_app::shade::Shader;
use refl_app::tracer::Tracer;
use refl_core::hiz::HiZOptions;
use refl_core::{DepthConvention, MirrorStatus, MirrorTexel, StepOptions};

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

fn pass(
    depth: &DepthBuffer,
    images: &PassImages,
    m: ScreenMethod,
    pool: &rayon::ThreadPool,
) -> Vec<MirrorTexel> {
    let image = depth.image().expect("image");
    screen::run(m, true, &image, images, pool)
        .expect("run")
        .value
        .texels
}

fn work(
    depth: &DepthBuffer,
    images: &PassImages,
    m: ScreenMethod,
    rays: &screen::ReflectionRays,
    pool: &rayon::ThreadPool,
) -> u64 {
    let image = depth.image().expect("image");
    screen::kernel_work(m, &image, images, rays, pool)
        .expect("work")
        .0
}

/// Same hit within a pixel, or both without a hit, pixel by pixel.
fn agreement(a: &[MirrorTexel], b: &[MirrorTexel], rays: &screen::ReflectionRays) -> usize {
    rays.pixel
        .iter()
        .filter(|&&p| {
            let (a, b) = (&a[p as usize], &b[p as usize]);
            match (a.status == MirrorStatus::Hit, b.status == MirrorStatus::Hit) {
                (true, true) => (a.pixel - b.pixel).length() <= 1.0,
                (false, false) => true,
                _ => false,
            }
        })
        .count()
}

/// The mirror pass with stepping and with Hi-Z finds the visible
/// reference hits within a pixel on the room's reflection rays in every
/// depth convention, with few false hits, and both kernels agree pixel by
/// pixel.
#[test]
fn step_and_hiz_find_visible_hits_in_every_convention() {
    let f = fixture();
    let shader = Shader::new(&f.scene, &f.tracer);
    let cam = f.scene.camera(0, 192, 144).expect("camera");
    let g = GBuffer::render(&f.scene, &f.tracer, &cam, &f.pool);
    let rays = screen::reflection_rays(&f.scene, &f.tracer, &shader, &g, &f.pool);
    assert!(rays.len() > 1000, "{} rays", rays.len());
    assert!(rays.visible_count() > rays.len() / 5);
    let images = PassImages::new(&g, None);
    for c in DepthConvention::ALL {
        let far = if c == DepthConvention::ReversedZ {
            f32::INFINITY
        } else {
            cam.far()
        };
        let depth = DepthBuffer::new(&g, c, far).expect("depth");
        let (sm, hm) = (
            ScreenMethod::Step(StepOptions::default()),
            ScreenMethod::HiZ(HiZOptions::default()),
        );
        let step = pass(&depth, &images, sm, &f.pool);
        let hiz = pass(&depth, &images, hm, &f.pool);
        let (s, h) = (
            screen::evaluate(&rays, &step),
            screen::evaluate(&rays, &hiz),
        );
        for (name, r) in [("step", &s), ("hiz", &h)] {
            eprintln!(
                "{c:?} {name}: found {:.4} false {:.4} ({} of {})",
                r.hit_rate(),
                r.false_hit_rate(),
                r.false_hits,
                r.rays - r.visible
            );
            // Measured: found 98.45%, false hits 5.04% (365 of 7237:
            // mostly beside the spheres' bases, whose true reflection is
            // their hidden underside) in every convention, both kernels.
            assert!(
                r.hit_rate() >= 0.97,
                "{c:?} {name} hit rate {}",
                r.hit_rate()
            );
            assert!(
                r.false_hit_rate() <= 0.07,
                "{c:?} {name} false hits {}",
                r.false_hit_rate()
            );
        }
        let agree = agreement(&step, &hiz, &rays);
        assert!(
            agree as f64 >= 0.99 * rays.len() as f64,
            "{c:?}: step and Hi-Z agree on {agree} of {}",
            rays.len()
        );
        // Hi-Z reads far fewer texels than unit stepping.
        let (sf, hf) = (
            work(&depth, &images, sm, &rays, &f.pool),
            work(&depth, &images, hm, &rays, &f.pool),
        );
        assert!(hf * 3 < sf, "{c:?}: {hf} vs {sf}");
    }
}

/// Coarse strides refine to the unit-stride hit on most pixels.
#[test]
fn strided_stepping_refines_to_unit_hits() {
    let f = fixture();
    let shader = Shader::new(&f.scene, &f.tracer);
    let cam = f.scene.camera(1, 160, 120).expect("camera");
    let g = GBuffer::render(&f.scene, &f.tracer, &cam, &f.pool);
    let rays = screen::reflection_rays(&f.scene, &f.tracer, &shader, &g, &f.pool);
    let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY).expect("depth");
    let images = PassImages::new(&g, None);
    let unit_m = ScreenMethod::Step(StepOptions::default());
    let coarse_m = ScreenMethod::Step(StepOptions {
        stride: 4,
        max_steps: u32::MAX,
    });
    let unit = pass(&depth, &images, unit_m, &f.pool);
    let coarse = pass(&depth, &images, coarse_m, &f.pool);
    let same = agreement(&unit, &coarse, &rays);
    assert!(
        same as f64 >= 0.95 * rays.len() as f64,
        "{same} of {}",
        rays.len()
    );
    assert!(
        work(&depth, &images, coarse_m, &rays, &f.pool)
            < work(&depth, &images, unit_m, &rays, &f.pool)
    );
}

/// The pass shades its hits with the lit frame's color at the hit texel,
/// and the report's image takes exactly the mirror pixels it hit.
#[test]
fn shade_takes_the_lit_color_at_each_hit() {
    let f = fixture();
    let cam = f.scene.camera(0, 96, 72).expect("camera");
    let g = GBuffer::render(&f.scene, &f.tracer, &cam, &f.pool);
    let lit: Vec<glam::Vec3> = (0..g.len())
        .map(|i| glam::Vec3::new(i as f32, 0.5, 1.0))
        .collect();
    let images = PassImages::new(&g, Some(&lit));
    let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY).expect("depth");
    let image = depth.image().expect("image");
    let out = screen::run(
        ScreenMethod::Step(StepOptions::default()),
        true,
        &image,
        &images,
        &f.pool,
    )
    .expect("run")
    .value;
    let img = screen::shade(&g, &out);
    let mut hits = 0;
    for (i, t) in out.texels.iter().enumerate() {
        let mirror_hit = t.status == MirrorStatus::Hit && g.roughness[i] == 0.0;
        assert_eq!(img.handled[i], mirror_hit, "pixel {i}");
        if mirror_hit {
            hits += 1;
            let q = (t.pixel.y as usize) * g.width() as usize + t.pixel.x as usize;
            assert_eq!(img.rgb[i], lit[q], "pixel {i}");
        }
    }
    assert!(hits > 100, "{hits} hits");
    assert_eq!(
        out.stats.hits as usize,
        out.texels
            .iter()
            .filter(|t| t.status == MirrorStatus::Hit)
            .count()
    );
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
    let img = layered_render::shade(
        &shader,
        &g,
        &ls,
        &tr,
        layered_render::LayeredShading::PrimitiveId,
        None,
    );
    assert!(img.handled_count() > 0);
    // With the global environment (seed 001 Sec. 4.1) every mirror pixel
    // the pass traced is answered: map hits as before, the rest from the
    // surroundings table in the ray's direction.
    let env = layered_render::Surroundings::build(&shader, &f.pool);
    let full = layered_render::shade(
        &shader,
        &g,
        &ls,
        &tr,
        layered_render::LayeredShading::PrimitiveId,
        Some(&env),
    );
    let mut from_env = 0;
    for (i, t) in tr.texels.iter().enumerate() {
        let traced = g.is_reflective(i) && g.roughness[i] == 0.0 && t.dir != glam::Vec3::ZERO;
        if img.handled[i] {
            assert_eq!(full.rgb[i], img.rgb[i], "a map hit keeps its shade");
        } else if traced {
            assert!(full.handled[i], "pixel {i} traced but unanswered");
            assert_eq!(full.rgb[i], env.sample(t.dir));
            from_env += 1;
        }
    }
    assert!(from_env > 0 && full.handled_count() > img.handled_count());
    // Seed 001's shading: a map hit takes the color its texel's layer
    // stores, the crossing of the texel's column ray shaded once; before
    // the samples are shaded no hit has a color.
    let texel = |ls: &LayeredScene| {
        layered_render::shade(
            &shader,
            &g,
            ls,
            &tr,
            layered_render::LayeredShading::Texel,
            None,
        )
    };
    assert_eq!(texel(&ls).handled_count(), 0);
    let mut ls = ls;
    ls.shade_samples(&shader, &f.pool);
    let by_texel = texel(&ls);
    assert_eq!(
        by_texel.handled, img.handled,
        "the same pixels, shaded otherwise"
    );
    let (mut checked, mut differ, mut gap) = (0, 0, 0.0f64);
    for (i, t) in tr.texels.iter().enumerate() {
        if !by_texel.handled[i] {
            continue;
        }
        let obj = &ls.objects[t.map as usize];
        let (o, d, h) = obj.sample(t.payload).expect("a hit names its sample");
        let want = shader.direct(&refl_app::shade::Surface::at_hit(&f.scene, *o, *d, h));
        assert_eq!(by_texel.rgb[i], want, "pixel {i}");
        differ += usize::from(by_texel.rgb[i] != img.rgb[i]);
        gap += f64::from((by_texel.rgb[i] - img.rgb[i]).abs().max_element());
        checked += 1;
    }
    assert!(
        checked > 100 && differ > 0,
        "{checked} checked, {differ} differ from the id shading"
    );
    // A texel's color is its sample's, a texel away from the exact hit:
    // close to the exact shade on average (a sample seen from inside the
    // solid, unlit, would be far off).
    let gap = gap / checked as f64;
    eprintln!("texel vs exact shading: mean max-channel gap {gap:.4} over {checked} pixels");
    assert!(gap < 0.05, "mean gap {gap}");
}

/// The surroundings table is the reference's view from its center, of
/// the scene without its mapped objects and reflectors: where the full
/// scene's first hit from the center in a texel's direction is a kept
/// surface, it is also the table's first hit, and the table holds its
/// reference shade (a lookup at a texel center returns that texel).
#[test]
fn surroundings_table_is_the_view_from_its_center() {
    let f = fixture();
    let shader = Shader::new(&f.scene, &f.tracer);
    let env = layered_render::Surroundings::build(&shader, &f.pool);
    let mapped = layered_render::reflected_objects(&f.scene);
    let (w, h) = (256, 128);
    let mut checked = 0;
    for y in (2..h).step_by(5) {
        for x in (1..w).step_by(7) {
            let d = refl_app::probe::texel_direction(x, y, w, h);
            let Some(hit) = f.tracer.trace(env.center, d, 0.0, f32::INFINITY) else {
                continue;
            };
            let o = f.scene.tri_object[hit.prim as usize];
            if mapped.contains(&o) || f.scene.material_of(hit.prim).is_reflective() {
                continue;
            }
            let want = shader.shade_reflection_hit(env.center, d, &hit);
            let got = env.sample(d);
            assert!(
                (got - want).abs().max_element() <= 1e-4 * (1.0 + want.abs().max_element()),
                "texel ({x}, {y}): {got} vs {want}"
            );
            checked += 1;
        }
    }
    assert!(checked > 50, "{checked} directions checked");
}

/// Seed 001 Sec. 3.2 in the root renderer: the potential-reflection-region
/// masks (one per reflector triangle, the pixel's triangle from the
/// G-buffer's primitive id) change no texel of the layered pass, bit for
/// bit, on every built-in scene with curved, smooth-shaded reflectors; the
/// map lookups they skip are exactly sphere tests the pass would have
/// failed, and on every scene they skip some.
#[test]
fn layered_regions_change_no_texel() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("pool");
    for (name, scene) in [
        ("room", Scene::room(8_000)),
        ("concave", Scene::concave(8_000)),
        ("stage", Scene::stage(8_000)),
        ("walkthrough", Scene::walkthrough(8_000)),
    ] {
        let tracer = Tracer::new(&scene);
        let cam = scene.camera(0, 128, 96).expect("camera");
        let g = GBuffer::render(&scene, &tracer, &cam, &pool);
        let mut ls = LayeredScene::build(&scene, 32, 4, &pool).expect("maps");
        assert!(ls.regions.is_some(), "{name}");
        let frame = layered_render::LayeredFrame::new(&g);
        let with = ls
            .trace(&g, &frame, &Default::default(), &pool)
            .expect("trace");
        let regions = ls.regions.take();
        let without = ls
            .trace(&g, &frame, &Default::default(), &pool)
            .expect("trace");
        assert!(without.prr.is_none() && with.prr.is_some());
        let prr = with.prr.expect("masks");
        let tris = regions.as_ref().map_or(0, |r| r.frame_regions(&g).0.len()) as u64;
        assert!(tris > 0 && tris < regions.as_ref().map_or(0, |r| r.triangles.len()) as u64);
        assert_eq!(prr.pairs, tris * ls.objects.len() as u64, "{name}");
        assert_eq!(without.texels.len(), with.texels.len());
        for (i, (a, b)) in without.texels.iter().zip(&with.texels).enumerate() {
            let bits = |t: &refl_core::LayeredPassTexel| {
                (
                    t.status,
                    t.map,
                    t.face,
                    t.texel,
                    t.layer,
                    t.payload,
                    [t.t, t.uv.x, t.uv.y, t.confidence].map(f32::to_bits),
                    t.position.to_array().map(f32::to_bits),
                    t.dir.to_array().map(f32::to_bits),
                    t.fetches,
                )
            };
            assert_eq!(bits(a), bits(b), "{name}: pixel {i}");
        }
        let (a, b) = (without.stats, with.stats);
        assert_eq!(a.prr_skipped, 0);
        assert_eq!(a.sphere_culled, b.sphere_culled + b.prr_skipped, "{name}");
        assert_eq!(
            (a.traced, a.hits, a.kernel_traces, a.fetches),
            (b.traced, b.hits, b.kernel_traces, b.fetches),
            "{name}"
        );
        assert!(b.prr_skipped > 0, "{name}: {b:?}");
        eprintln!(
            "{name}: {} traced, lookups {} -> {} ({} skipped), masks {}/{} set",
            b.traced,
            b.kernel_traces + b.sphere_culled + b.prr_skipped,
            b.kernel_traces + b.sphere_culled,
            b.prr_skipped,
            prr.may_reflect,
            prr.pairs
        );
    }
}
