//! Multiple bounces on a static view (`refl_app::bounce`, seed 004 Sec.
//! 4.6.4): the room's mirror floor sees the mirror sphere and the sphere
//! the floor. Frame 0 (one bounce) is nearer the one-bounce reference;
//! each later frame adds a bounce whose change shrinks by the mirrors'
//! specular levels; with attenuation 0 it stays at one bounce. (Against
//! the two-bounce reference the seed's re-use of the previous frame's
//! view-dependent reflection does not get closer on a curved mirror: the
//! error is printed, not bounded.) The hall's two facing planar mirrors
//! measure issue 18's target, with the reason it is not met (the seed's
//! model against the two-bounce reference, the pipeline against the
//! model) and the attenuation.

use refl_app::bounce::run;
use refl_app::gbuffer::GBuffer;
use refl_app::scene::Scene;
use refl_app::shade::Shader;
use refl_app::tracer::Tracer;
use refl_core::bounce::BounceOptions;

#[test]
fn second_bounce_approaches_the_two_bounce_reference() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let scene = Scene::room(20_000);
    let tracer = Tracer::new(&scene);
    let shader = Shader::new(&scene, &tracer);
    let cam = scene.camera(0, 160, 120).unwrap();
    let g = GBuffer::render(&scene, &tracer, &cam, &pool);
    let full = BounceOptions {
        attenuation: 1.0,
        ..BounceOptions::default()
    };
    let r = run(&shader, &g, 3, full, &pool).unwrap();
    let e2: Vec<f64> = r.frames.iter().map(|f| f.error.mean_abs).collect();
    let e1: Vec<f64> = r.frames.iter().map(|f| f.error_one.mean_abs).collect();
    eprintln!("two-bounce error {e2:?}, one-bounce error {e1:?}");
    assert!(r.handled.iter().filter(|&&h| h).count() > 1000);
    assert_eq!(r.frames[0].stats.reprojected, 0);
    assert!(r.frames[1].stats.reprojected > 1000);
    // Frame 0 is the one-bounce pass: nearer the one-bounce reference.
    assert!(e1[0] < e2[0], "{e1:?} {e2:?}");
    // Each frame adds one bounce, attenuated by the specular levels of the
    // mirrors on the way (0.9 floor, 0.95 sphere): frame-to-frame changes
    // shrink.
    let change = |a: &[glam::Vec3], b: &[glam::Vec3]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (*x - *y).abs().element_sum() as f64)
            .sum::<f64>()
    };
    let d01 = change(&r.frames[0].fin, &r.frames[1].fin);
    let d12 = change(&r.frames[1].fin, &r.frames[2].fin);
    eprintln!("change 0->1 {d01:.1}, 1->2 {d12:.1}");
    assert!(d01 > 0.0 && d12 < d01, "{d01} {d12}");
    // Attenuation 0: the one-bounce source every frame.
    let none = run(
        &shader,
        &g,
        2,
        BounceOptions {
            attenuation: 0.0,
            ..BounceOptions::default()
        },
        &pool,
    )
    .unwrap();
    let d = (none.frames[1].error.mean_abs - none.frames[0].error.mean_abs).abs();
    assert!(d < 1e-3, "{d}");
}

/// Two facing planar mirrors (the hall, pose 0, static camera, 384x288, the report's size),
/// issue 18's target: "two facing mirrors' second bounce within 2/255 of a
/// ray-traced reference that also traces two bounces", with the stated
/// attenuation.
///
/// Pixels measured: the perfect-mirror pixels whose reflection the Hi-Z
/// pass hit (the pass handles them; the others show the environment
/// fallback, which no bounce changes), and among them the **second-bounce
/// pixels**, whose hit texel is itself a perfect-mirror pixel (the other
/// mirror): only there does the bounce pass change the image (every other
/// hit texel is a diffuse surface whose final color is its lit color in
/// every frame), so the target is measured there, not diluted by
/// one-bounce pixels.
///
/// Frame 1 (two bounces) against the two-bounce reference
/// (`Shader::trace_reflection_bounces`) on the second-bounce pixels:
/// 33.3/255 (frame 0, one bounce: 75.2). **The 2/255 target is not met**,
/// and the reason is the seed's approximation, not its implementation.
/// Seed 004 Sec. 4.6.4 shades the second bounce with the previous frame's
/// final color of the other mirror's point `Q`, i.e. with the reflection
/// *the eye* saw at `Q`; the reflected ray reaches `Q` from the mirrored
/// eye, and a planar mirror's reflection depends on where it is seen from:
/// the eye, half a unit from the left mirror, sees `Q` on the right mirror
/// at a grazing angle and its reflection far down the hall, while the ray
/// from the left mirror reflects at `Q` to a point several checker cells
/// away (on most such pixels both land on the end wall, at different
/// cells). The seed's model ray traced (`seed_model_reference`: the same
/// two bounces with the eye's direction at `Q`) is itself 29.9/255 from
/// the two-bounce reference on these pixels; the pipeline is 2.6/255 from
/// that model on the second-bounce pixels whose source the pass answered
/// (what remains is the Hi-Z pass's own one-bounce error at the texel it
/// reads, the texel quantization of `Q` and silhouettes; 5.2 at 256x192,
/// 7.5 at 160x120). The second-bounce pixels whose source's own ray left
/// the screen (23% of them) show the environment fallback there.
#[test]
fn facing_mirrors_second_bounce_against_the_two_bounce_reference() {
    use refl_app::bounce::reference;
    use refl_app::render::compare;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let scene = Scene::hall(20_000);
    let tracer = Tracer::new(&scene);
    let shader = Shader::new(&scene, &tracer);
    let cam = scene.camera(0, 384, 288).unwrap();
    let g = GBuffer::render(&scene, &tracer, &cam, &pool);
    let with = |attenuation: f32| BounceOptions {
        attenuation,
        ..BounceOptions::default()
    };
    let r = run(&shader, &g, 3, with(1.0), &pool).unwrap();
    let count = |m: &[bool]| m.iter().filter(|&&b| b).count();
    let (handled, second, answered) = (
        count(&r.handled),
        count(&r.second),
        count(&r.source_answered),
    );
    eprintln!("handled {handled}, second-bounce {second}, source answered {answered}");
    // Both mirrors on screen: a good share of the handled pixels see the
    // other mirror, and most of those find its reflection on screen.
    assert!(second * 10 > handled, "{second} of {handled}");
    assert!(answered * 2 > second, "{answered} of {second}");
    // A static camera: every surface pixel re-projects onto itself.
    let s = r.frames[1].stats;
    assert!(
        s.reprojected > 0 && s.rejected == 0 && s.off_screen == 0,
        "{s:?}"
    );

    let e2: Vec<f64> = r.frames.iter().map(|f| f.error_second.mean_abs).collect();
    let em: Vec<f64> = r.frames.iter().map(|f| f.error_model.mean_abs).collect();
    let model_vs_truth = compare(&r.truth, &r.model, &r.second).mean_abs;
    eprintln!(
        "second-bounce pixels: against the two-bounce reference {e2:?}; against the seed's model {em:?}; \
         the model against the reference {model_vs_truth:.3}"
    );
    // Frame 0 (one bounce) lacks the second bounce altogether; frame 1
    // adds it, and frame 2's third bounce changes almost nothing (the
    // sources' own reflections are diffuse surfaces).
    assert!(e2[1] < 0.6 * e2[0], "{e2:?}");
    assert!((e2[2] - e2[1]).abs() < 0.5, "{e2:?}");
    // The screen-space implementation follows the seed's model (measured
    // 2.59)...
    assert!(em[1] < 3.5, "{em:?}");
    assert!(em[1] < 0.1 * em[0], "{em:?}");
    // ... and the model's view dependence is what stands between it and
    // the target (measured 33.3 against 29.9): the pipeline is about as
    // far from the reference as the model is, and the target is met by
    // neither.
    assert!(e2[1] <= model_vs_truth + 5.0, "{e2:?} {model_vs_truth}");
    assert!(
        model_vs_truth > 2.0 && e2[1] > 2.0,
        "the target is met: update the docs"
    );

    // The stated attenuation (refl_core::bounce step 4: source = lit +
    // attenuation (previous - lit)): frame 1 is linear in it, exactly
    // between the one-bounce frame (attenuation 0) and the full bounce at
    // 0.5, on every pixel; the two-bounce reference weakened the same way
    // is linear in it too, and the pipeline follows the weakened model as
    // closely as the full one.
    let half = run(&shader, &g, 2, with(0.5), &pool).unwrap();
    let none = run(&shader, &g, 2, with(0.0), &pool).unwrap();
    let mut worst = 0.0f32;
    for i in 0..g.len() {
        let mid = (none.frames[1].fin[i] + r.frames[1].fin[i]) * 0.5;
        worst = worst.max((half.frames[1].fin[i] - mid).abs().max_element());
    }
    assert!(worst < 1e-5, "{worst}");
    assert_eq!(none.frames[1].fin, none.frames[0].fin);
    let at = |a: f32| reference(&shader, &g, 2, a, &pool).rgb;
    let (r0, r5, r1) = (at(0.0), at(0.5), at(1.0));
    let one = reference(&shader, &g, 1, 1.0, &pool).rgb;
    assert_eq!(r0, one);
    for i in 0..g.len() {
        let d = (r5[i] - (r0[i] + r1[i]) * 0.5).abs().max_element();
        assert!(d < 1e-5, "{i}: {d}");
    }
    let eh = half.frames[1].error_second.mean_abs;
    let emh = half.frames[1].error_model.mean_abs;
    eprintln!("attenuation 0.5: against the weakened reference {eh:.3}, against the weakened model {emh:.3}");
    // Measured 1.85 and 22.5.
    assert!(emh < 3.5 && eh < e2[1], "{emh} {eh}");
}

/// Issue 18's facing-mirror target met for planar mirrors by recursion
/// instead of the seed's re-use of the last frame: the planar pass with
/// two bounces (`refl_app::render::planar_mirror_bounces`: each mirror's
/// mirrored render, and for the other mirror it shows, a render through
/// the twice-mirrored camera) against the ray-traced two-bounce
/// reference, on the hall at 384x288, on every planar-mirror pixel and on
/// the second-bounce pixels (the mirrored render shows the other mirror
/// there): within the 2/255 target. With one bounce the same pass is the
/// one-bounce reference (the pass's own exactness).
#[test]
fn planar_recursion_meets_the_two_bounce_target_on_facing_mirrors() {
    use refl_app::bounce::reference;
    use refl_app::render::{compare, composite, direct_image, planar_mirror_bounces};
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let scene = Scene::hall(20_000);
    let tracer = Tracer::new(&scene);
    let shader = Shader::new(&scene, &tracer);
    let cam = scene.camera(0, 384, 288).unwrap();
    let g = GBuffer::render(&scene, &tracer, &cam, &pool);
    let direct = direct_image(&shader, &g, &pool);
    let one = planar_mirror_bounces(&shader, &g, 1, 1, &|_| true, &pool).unwrap();
    let two = planar_mirror_bounces(&shader, &g, 1, 2, &|_| true, &pool).unwrap();
    assert_eq!(one.handled, two.handled);
    let handled = &two.handled;
    let truth = |b: u32| {
        let mut r = reference(&shader, &g, b, 1.0, &pool);
        r.handled = handled.clone();
        composite(&g, &direct, &r)
    };
    let (truth1, truth2) = (truth(1), truth(2));
    let (fin1, fin2) = (composite(&g, &direct, &one), composite(&g, &direct, &two));
    // The second-bounce pixels: where the two bounces differ from one.
    let second: Vec<bool> = (0..g.len())
        .map(|i| handled[i] && (truth2[i] - truth1[i]).abs().max_element() > 1e-6)
        .collect();
    let count = |m: &[bool]| m.iter().filter(|&&b| b).count();
    let (nh, ns) = (count(handled), count(&second));
    let e1 = compare(&truth1, &fin1, handled).mean_abs;
    let e2 = compare(&truth2, &fin2, handled).mean_abs;
    let e2s = compare(&truth2, &fin2, &second).mean_abs;
    let e1s = compare(&truth2, &fin1, &second).mean_abs;
    eprintln!(
        "hall: {nh} planar-mirror pixels, {ns} second-bounce; one bounce vs the one-bounce reference {e1:.4}; \
         two bounces vs the two-bounce reference {e2:.4} (second-bounce pixels {e2s:.4}; one bounce there {e1s:.4})"
    );
    assert!(ns * 10 > nh, "{ns} of {nh}");
    assert!(e1 < 0.5, "{e1}");
    // The target: within 2/255 of the two-bounce reference.
    assert!(e2s < 2.0, "{e2s}");
    assert!(e2 < 2.0, "{e2}");
    // The second bounce is what closes the gap.
    assert!(e1s > 10.0 * e2s.max(0.1), "{e1s} vs {e2s}");
    // Refused settings.
    assert!(planar_mirror_bounces(&shader, &g, 2, 2, &|_| true, &pool).is_err());
    assert!(planar_mirror_bounces(&shader, &g, 1, 3, &|_| true, &pool).is_err());
}
