//! The glossy screen-space pipeline of the root package (`refl_app::cone`)
//! on the room: energy conservation through the whole pipeline, the
//! reference's convergence check, and the error trends the report plots.
#![allow(clippy::needless_range_loop)]

use glam::Vec3;
use refl_app::cone::{glossy_mask, run, Glossiness, GlossyBuffers, GlossyMethod, GlossyStats};
use refl_app::gbuffer::GBuffer;
use refl_app::render::{compare, composite, direct_image, reference_masked, ReflectionImage};
use refl_app::report::glossy::reference_ms_at_error;
use refl_app::scene::Scene;
use refl_app::screen::DepthBuffer;
use refl_app::shade::{env_map, Shader};
use refl_app::tracer::Tracer;
use refl_core::cone::ConeOptions;
use refl_core::DepthConvention;

const W: u32 = 128;
const H: u32 = 96;

struct Setup {
    scene: Scene,
    tracer: Tracer,
    g: GBuffer,
    depth: DepthBuffer,
    pool: rayon::ThreadPool,
}

fn setup(gloss: Glossiness) -> Setup {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let scene = Scene::room(8000);
    let tracer = Tracer::new(&scene);
    let cam = scene.camera(0, W, H).unwrap();
    let mut g = GBuffer::render(&scene, &tracer, &cam, &pool);
    let bounds = scene.bounds();
    gloss.apply(&mut g, (bounds.min.x, bounds.max.x));
    let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY).unwrap();
    Setup {
        scene,
        tracer,
        g,
        depth,
        pool,
    }
}

fn cone(circles: u32, normalize: bool) -> GlossyMethod {
    GlossyMethod::Cone {
        options: ConeOptions {
            max_circles: circles,
            normalize,
            ..ConeOptions::default()
        },
        fades: None,
        view_space: false,
    }
}

fn go(
    s: &Setup,
    m: GlossyMethod,
    lit: &[Vec3],
    fallback: impl Fn(Vec3, f32) -> Vec3 + Sync,
) -> (ReflectionImage, GlossyStats) {
    let mask = glossy_mask(&s.g);
    let mut buf = GlossyBuffers::new(W, H).unwrap();
    let image = s.depth.image().unwrap();
    run(m, &s.g, lit, &image, &mask, fallback, &mut buf, &s.pool)
        .unwrap()
        .value
}

#[test]
fn uniform_frame_reflects_its_color_exactly() {
    let s = setup(Glossiness::Uniform(0.35));
    let mask = glossy_mask(&s.g);
    assert!(mask.iter().filter(|&&m| m).count() > 1000);
    let c = Vec3::new(0.3, 0.55, 0.8);
    let lit = vec![c; s.g.len()];
    for m in [
        cone(1, false),
        cone(8, false),
        cone(16, true),
        GlossyMethod::Cone {
            options: ConeOptions {
                max_stretch: 4.0,
                use_visibility: false,
                ..ConeOptions::default()
            },
            fades: Some(refl_core::Fades {
                border: Some(refl_core::FadeRange {
                    start: 0.5,
                    end: 1.0,
                }),
                ..Default::default()
            }),
            view_space: true,
        },
        GlossyMethod::MultiRay { rays: 8 },
    ] {
        let (img, st) = go(&s, m, &lit, |_, _| c);
        assert_eq!(st.pixels, mask.iter().filter(|&&m| m).count());
        for i in 0..mask.len() {
            assert_eq!(img.handled[i], mask[i]);
            if mask[i] {
                assert!(
                    (img.rgb[i] - c).abs().max_element() < 1e-6,
                    "{m:?} {i}: {}",
                    img.rgb[i]
                );
            }
        }
    }
    // A different fallback: normalized cones that hit show the frame's
    // color exactly; unnormalized ones lie between frame and fallback.
    let f = Vec3::new(1.0, 0.0, 0.0);
    let (img, st) = go(&s, cone(8, true), &lit, |_, _| f);
    assert!(st.hits > 100, "{st:?}");
    let frame_colored = (0..mask.len())
        .filter(|&i| mask[i] && (img.rgb[i] - c).abs().max_element() < 1e-5)
        .count();
    assert!(
        frame_colored >= st.hits * 9 / 10,
        "{frame_colored} of {}",
        st.hits
    );
    let (img, _) = go(&s, cone(8, false), &lit, |_, _| f);
    for i in (0..mask.len()).filter(|&i| mask[i]) {
        let p = img.rgb[i];
        // On the segment from f to c.
        let t = (p.y - f.y) / (c.y - f.y);
        assert!((-1e-5..=1.0 + 1e-5).contains(&t));
        assert!((f + (c - f) * t - p).abs().max_element() < 1e-4);
    }
}

#[test]
fn the_fallback_gets_the_pixel_roughness_and_its_share_of_the_lobe() {
    // A ramp: every glossy pixel has its own roughness. Cone pixels whose
    // mirror ray misses show exactly fallback(dir, their roughness).
    let s = setup(Glossiness::Ramp(0.1, 0.45));
    let mask = glossy_mask(&s.g);
    let lit = vec![Vec3::new(0.0, 0.0, 1.0); s.g.len()];
    let fb = |_: Vec3, r: f32| Vec3::new(r, 1.0 - r, 0.0);
    let (img, st) = go(&s, cone(8, true), &lit, fb);
    let misses = st.pixels - st.hits;
    assert!(misses > 100, "{st:?}");
    let own = (0..mask.len())
        .filter(|&i| {
            mask[i]
                && (img.rgb[i] - fb(Vec3::Y, s.g.roughness[i]))
                    .abs()
                    .max_element()
                    < 1e-6
        })
        .count();
    assert!(own >= misses, "{own} of {misses} misses");
    // Multi-ray: the probe at the pixel's roughness takes the share `w`
    // of the lobe whose rays missed, the frame's blue the rest: (w r,
    // w (1 - r), 1 - w).
    let (img, st) = go(&s, GlossyMethod::MultiRay { rays: 8 }, &lit, fb);
    assert!(st.hits < st.coverage_sum as usize, "{st:?}");
    let mut mixed = 0;
    for i in (0..mask.len()).filter(|&i| mask[i]) {
        let p = img.rgb[i];
        let w = p.x + p.y;
        assert!((w + p.z - 1.0).abs() < 1e-5, "{i}: {p}");
        if w > 1e-3 {
            assert!((p.x / w - s.g.roughness[i]).abs() < 1e-4, "{i}: {p}");
            mixed += usize::from(w < 1.0 - 1e-3);
        }
    }
    assert!(mixed > 100, "{mixed}");
}

#[test]
fn cone_beats_the_fallback_and_improves_with_circles() {
    let s = setup(Glossiness::Uniform(0.2));
    let shader = Shader::new(&s.scene, &s.tracer);
    let mask = glossy_mask(&s.g);
    let direct = direct_image(&shader, &s.g, &s.pool);
    let truth = composite(
        &s.g,
        &direct,
        &reference_masked(&shader, &s.g, 64, &mask, &s.pool),
    );
    let err = |m: GlossyMethod| {
        let (img, _) = go(&s, m, &direct, |d, _| env_map(d));
        compare(&truth, &composite(&s.g, &direct, &img), &mask).mean_abs
    };
    let (none, one, sixteen, normalized) = (
        err(cone(0, false)),
        err(cone(1, false)),
        err(cone(16, false)),
        err(cone(8, true)),
    );
    // 0 circles is the environment alone.
    assert!(one < 0.8 * none, "{one} vs env {none}");
    assert!(sixteen < one, "16 circles {sixteen} vs 1 {one}");
    assert!(normalized < sixteen, "normalized {normalized} vs {sixteen}");
    let multi = err(GlossyMethod::MultiRay { rays: 16 });
    assert!(multi < 0.6 * none, "multi-ray {multi} vs env {none}");
}

#[test]
fn reference_noise_halves_with_four_times_the_samples() {
    // The report's convergence check: the difference between estimates at
    // N and N / 2 samples shrinks like N^-1/2.
    let s = setup(Glossiness::Uniform(0.35));
    let shader = Shader::new(&s.scene, &s.tracer);
    let mask = glossy_mask(&s.g);
    let direct = direct_image(&shader, &s.g, &s.pool);
    let at = |n| {
        composite(
            &s.g,
            &direct,
            &reference_masked(&shader, &s.g, n, &mask, &s.pool),
        )
    };
    let (r8, r16, r32, r64) = (at(8), at(16), at(32), at(64));
    let d_low = compare(&r16, &r8, &mask).mean_abs;
    let d_high = compare(&r64, &r32, &mask).mean_abs;
    assert!(d_high < 0.7 * d_low, "{d_high} vs {d_low}");
    assert!(d_high > 0.0);
}

#[test]
fn equal_error_interpolation() {
    // Reference points with error ~ spp^-1/2 and time ~ spp.
    let pts = [(4.0, 8.0), (2.0, 32.0), (1.0, 128.0)];
    let t = reference_ms_at_error(&pts, 2.0).unwrap();
    assert!((t - 32.0).abs() < 1e-9);
    let mid = reference_ms_at_error(&pts, 2f64.sqrt()).unwrap();
    assert!((mid - 64.0).abs() < 1e-6, "{mid}");
    // Beyond the range: time ~ error^-2.
    assert!((reference_ms_at_error(&pts, 0.5).unwrap() - 512.0).abs() < 1e-6);
    assert!((reference_ms_at_error(&pts, 8.0).unwrap() - 2.0).abs() < 1e-9);
    assert_eq!(reference_ms_at_error(&[], 1.0), None);
    assert_eq!(reference_ms_at_error(&pts, 0.0), None);
}
