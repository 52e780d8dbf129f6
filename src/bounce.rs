//! Multiple reflection bounces (seed 004 Sec. 4.6.4) with refl-core's
//! [`refl_core::bounce`]: on a static camera, frame `k`'s Hi-Z mirror pass
//! shades its hits with the previous frame's final image re-projected
//! ([`BouncePass`]) instead of the lit color, so a mirror that sees a
//! mirror shows that mirror's reflection one bounce more each frame. The
//! reference follows perfect mirrors for as many bounces
//! ([`Shader::trace_reflection_bounces`]).
//!
//! Per frame: the source (`lit` on frame 0, the bounce pass over the last
//! final image after), the mirror pass (reversed-Z, infinite far plane,
//! the report's default `hiz` setting), the final image `lit (1 - s) +
//! reflection s` on the perfect-mirror pixels, the reflection being the
//! pass's color where it hit and the environment elsewhere. Timed: the
//! bounce pass and the mirror pass.
//!
//! Errors are measured on the pixels the pass hit (the perfect-mirror
//! pixels whose reflection it handles; the others show the environment in
//! every frame), and separately on the **second-bounce pixels** among them
//! ([`BounceRun::second`]): those whose hit texel is itself a perfect
//! mirror, the only pixels a bounce changes. Three references: one and two
//! bounces ray traced ([`reference()`], the two-bounce one weakened by the
//! run's attenuation as the pass weakens it), and the seed's own model ray
//! traced ([`seed_model_reference`]: the second mirror shows the
//! reflection *the eye* sees there, which is what re-using the previous
//! frame computes), which splits the error into the approximation's (model
//! against two bounces) and the screen-space implementation's (pipeline
//! against model).

use crate::gbuffer::GBuffer;
use crate::render::{
    compare, composite, direct_image, mirror_env, timed, ImageError, ReflectionImage,
};
use crate::screen::{self, DepthBuffer, PassImages, ScreenMethod};
use crate::shade::{env_map, reflection_dir, Shader, Surface};
use glam::Vec3;
use rayon::prelude::*;
use refl_core::bounce::{BounceOptions, BouncePass, BounceStats, PreviousFrame};
use refl_core::hiz::HiZOptions;
use refl_core::{DepthConvention, ImageView, ImageViewMut, MirrorStatus, RowRange};

/// Rows per band of the bounce pass.
const BAND: u32 = 16;

/// One frame of [`run`].
#[derive(Clone, Debug)]
pub struct BounceFrame {
    /// The composited frame.
    pub fin: Vec<Vec3>,
    /// Error against the two-bounce reference on the pixels handled.
    pub error: ImageError,
    /// Error against the one-bounce reference on the same pixels.
    pub error_one: ImageError,
    /// Error against the two-bounce reference on the second-bounce pixels
    /// ([`BounceRun::second`]).
    pub error_second: ImageError,
    /// Error against the seed's own model ray traced
    /// ([`seed_model_reference`]) on the second-bounce pixels whose source
    /// was answered ([`BounceRun::source_answered`]): the screen-space
    /// implementation's share of the error.
    pub error_model: ImageError,
    /// Time of the bounce pass (0 on frame 0) and the mirror pass, ms.
    pub ms: f64,
    /// The bounce pass's counts (zero on frame 0).
    pub stats: BounceStats,
    /// Rays the mirror pass traced.
    pub rays: u64,
}

/// What [`run`] returns.
#[derive(Clone, Debug)]
pub struct BounceRun {
    /// One entry per frame.
    pub frames: Vec<BounceFrame>,
    /// Perfect-mirror pixels the pass hit on the last frame (the pixels
    /// every error is measured on).
    pub handled: Vec<bool>,
    /// The second-bounce pixels: handled pixels whose hit texel (on the
    /// last frame) is itself a perfect-mirror pixel, i.e. whose reflection
    /// shows a mirror. Only there does the bounce pass change the image;
    /// every other handled pixel's reflection is a diffuse surface, whose
    /// final color is its lit color in every frame.
    pub second: Vec<bool>,
    /// The second-bounce pixels whose hit texel's own reflection was a hit
    /// of the pass (on the first frame): their bounce source shows a
    /// screen-space reflection, not the environment fallback of a ray the
    /// screen could not answer (e.g. one that leaves the image).
    pub source_answered: Vec<bool>,
    /// Every pixel's hit texel on the last frame (row-major index), `None`
    /// where the pass did not hit.
    pub hit_texel: Vec<Option<usize>>,
    /// The two-bounce reference's final image on the handled pixels (the
    /// lit color elsewhere), attenuated as the run's options say.
    pub truth: Vec<Vec3>,
    /// [`seed_model_reference`]'s final image on the handled pixels (the
    /// lit color elsewhere).
    pub model: Vec<Vec3>,
    /// Time of the two-bounce reference on the perfect-mirror pixels, ms.
    pub reference_ms: f64,
}

/// The reflection of every perfect-mirror pixel of `g` traced with
/// `bounces` bounces, each further one weakened by `attenuation`
/// ([`Shader::trace_reflection_bounces_attenuated`]).
pub fn reference(
    shader: &Shader,
    g: &GBuffer,
    bounces: u32,
    attenuation: f32,
    pool: &rayon::ThreadPool,
) -> ReflectionImage {
    reference_where(shader, g, bounces, attenuation, pool, |_| true)
}

/// [`reference()`] on the perfect-mirror pixels where `mask` is true only
/// (the report times the reference on the pixels a method handles).
///
/// # Panics
/// If `mask` is shorter than the G-buffer.
pub fn reference_masked(
    shader: &Shader,
    g: &GBuffer,
    bounces: u32,
    attenuation: f32,
    mask: &[bool],
    pool: &rayon::ThreadPool,
) -> ReflectionImage {
    assert!(
        mask.len() >= g.len(),
        "reference_masked: mask shorter than the G-buffer"
    );
    reference_where(shader, g, bounces, attenuation, pool, |i| mask[i])
}

fn reference_where(
    shader: &Shader,
    g: &GBuffer,
    bounces: u32,
    attenuation: f32,
    pool: &rayon::ThreadPool,
    select: impl Fn(usize) -> bool + Sync,
) -> ReflectionImage {
    let mut out = ReflectionImage::empty(g.width(), g.height());
    out.fill(
        pool,
        |i| g.is_reflective(i) && g.roughness[i] == 0.0 && select(i),
        |i| {
            let s = g.surface(i).expect("reflective pixels are hits");
            let view = -g.primary_ray(i).dir;
            let dir = reflection_dir(view, s.shading_normal, s.geo_normal);
            shader.trace_reflection_bounces_attenuated(
                s.position,
                dir,
                shader.epsilon,
                bounces,
                attenuation,
            )
        },
    );
    out
}

/// The seed's own two-bounce model, ray traced (seed 004 Sec. 4.6.4: the
/// source of a reflection is the previous frame's final image, i.e. the
/// reflected surface *as the eye saw it*): for every perfect-mirror pixel
/// of `g`, the mirror ray's first hit `Q` shows its direct term, and, where
/// `Q` is a perfect mirror, its composite with the reflection of the
/// **eye's** ray `eye -> Q` at `Q` (one bounce, [`Shader::trace_reflection`])
/// rather than of the ray that arrived there, attenuated as the bounce pass
/// attenuates it (`direct + attenuation (composite - direct)`,
/// [`refl_core::bounce`] step 4). This is what frame 1 of [`run`] computes
/// in screen space wherever the second mirror and its own reflection are on
/// screen: the difference between it and [`reference()`] with two bounces is the
/// approximation's own error (view dependence), the difference between it
/// and frame 1 the screen-space implementation's.
pub fn seed_model_reference(
    shader: &Shader,
    g: &GBuffer,
    attenuation: f32,
    pool: &rayon::ThreadPool,
) -> ReflectionImage {
    let eye = g.camera.eye();
    let mut out = ReflectionImage::empty(g.width(), g.height());
    out.fill(
        pool,
        |i| g.is_reflective(i) && g.roughness[i] == 0.0,
        |i| {
            let s = g.surface(i).expect("reflective pixels are hits");
            let view = -g.primary_ray(i).dir;
            let dir = reflection_dir(view, s.shading_normal, s.geo_normal);
            let Some(hit) = shader
                .tracer
                .trace(s.position, dir, shader.epsilon, f32::INFINITY)
            else {
                return env_map(dir);
            };
            let q = Surface::at_hit(shader.scene, s.position, dir, &hit);
            let direct = shader.direct(&q);
            let m = &shader.scene.materials[q.material as usize];
            if !(m.specular > 0.0) || m.roughness != 0.0 {
                return direct;
            }
            // The eye's view of Q: its normals facing the eye.
            let from_eye = (q.position - eye).normalize();
            let (ns, ng) = if q.geo_normal.dot(from_eye) > 0.0 {
                (-q.shading_normal, -q.geo_normal)
            } else {
                (q.shading_normal, q.geo_normal)
            };
            let next = reflection_dir(-from_eye, ns, ng);
            let seen = shader.trace_reflection(q.position, next, shader.epsilon);
            let composite = direct * (1.0 - m.specular) + seen * m.specular;
            direct + (composite - direct) * attenuation
        },
    );
    out
}

/// Runs `frames` frames (at least 1) of the bounce pipeline on the static
/// view `g` with `options`, against the one- and two-bounce references.
///
/// # Errors
/// A refl-core error (a bug: every input is built here).
pub fn run(
    shader: &Shader,
    g: &GBuffer,
    frames: usize,
    options: BounceOptions,
    pool: &rayon::ThreadPool,
) -> Result<BounceRun, refl_core::Error> {
    let (w, h) = (g.width(), g.height());
    let n = g.len();
    let direct = direct_image(shader, g, pool);
    let two = timed(|| reference(shader, g, 2, options.attenuation, pool));
    let one = reference(shader, g, 1, 1.0, pool);
    let model = seed_model_reference(shader, g, options.attenuation, pool);
    let depth = DepthBuffer::new(g, DepthConvention::ReversedZ, f32::INFINITY)?;
    let method = ScreenMethod::HiZ(HiZOptions::default());
    let mut out = Vec::new();
    let mut last: Option<Vec<Vec3>> = None;
    let mut handled = vec![false; n];
    let mut answered_first = vec![false; n];
    let mut hit_texel: Vec<Option<usize>> = Vec::new();
    let mut passes = Vec::new();
    for _ in 0..frames.max(1) {
        // The source: lit on the first frame, else the bounce pass over
        // the last final image (the same camera: a static view).
        let (source, bounce_ms, stats) = match &last {
            None => (direct.clone(), 0.0, BounceStats::default()),
            Some(prev) => {
                let lit = PassImages::new(g, Some(&direct));
                let prev_rgb: Vec<[f32; 3]> = prev.iter().map(|c| c.to_array()).collect();
                let mut src = vec![[0.0f32; 3]; n];
                let t = timed(|| -> Result<BounceStats, refl_core::Error> {
                    let gb = lit.gbuffer(depth.image()?)?;
                    let previous = PreviousFrame::try_new(
                        depth.image()?,
                        ImageView::try_new(&prev_rgb, w, h, w)?,
                    )?;
                    let pass = BouncePass::try_new(gb, previous, options)?;
                    let band = BAND as usize * w as usize;
                    pool.install(|| {
                        src.par_chunks_mut(band)
                            .enumerate()
                            .map(|(k, c)| {
                                let y0 = k as u32 * BAND;
                                let rows = RowRange::try_new(y0, (y0 + BAND).min(h), h)?;
                                pass.try_run(&mut ImageViewMut::try_band(c, w, h, w, rows)?, None)
                            })
                            .try_reduce(BounceStats::default, |a, b| Ok(add(a, &b)))
                    })
                });
                let stats = t.value?;
                (
                    src.iter().map(|c| Vec3::from_array(*c)).collect(),
                    t.ms,
                    stats,
                )
            }
        };
        let images = PassImages::new(g, Some(&source));
        let pass = screen::run(method, true, &depth.image()?, &images, pool)?;
        // The final image an engine without a ray tracer shows: the pass's
        // color where it hit, the environment in the mirror direction on
        // the other perfect-mirror pixels (as the temporal path's `off`),
        // so that the next frame's bounce reads no lit color where a
        // reflection belongs.
        let mut img = ReflectionImage::empty(w, h);
        let first = hit_texel.is_empty();
        hit_texel = vec![None; n];
        for i in (0..n).filter(|&i| g.is_reflective(i) && g.roughness[i] == 0.0) {
            let t = &pass.value.texels[i];
            let hit = t.status == MirrorStatus::Hit;
            handled[i] = hit;
            if hit {
                // The texel the pass shaded the hit with (its floor).
                let (x, y) = (t.pixel.x.floor(), t.pixel.y.floor());
                if x >= 0.0 && y >= 0.0 && x < w as f32 && y < h as f32 {
                    hit_texel[i] = Some(y as usize * w as usize + x as usize);
                }
            }
            if first {
                answered_first[i] = hit;
            }
            img.rgb[i] = if hit {
                Vec3::from_array(pass.value.color[i])
            } else {
                mirror_env(g, i)
            };
            img.handled[i] = true;
        }
        let fin = composite(g, &direct, &img);
        passes.push((
            fin.clone(),
            bounce_ms + pass.ms,
            stats,
            u64::from(pass.value.stats.traced),
        ));
        last = Some(fin);
    }
    // Errors on the pixels the pass hit on the last frame (the same set
    // for every frame of a static view up to the pass's hits, which do not
    // depend on the color).
    let truth2 = composite(
        g,
        &direct,
        &ReflectionImage {
            handled: handled.clone(),
            ..two.value
        },
    );
    let truth1 = composite(
        g,
        &direct,
        &ReflectionImage {
            handled: handled.clone(),
            ..one
        },
    );
    let model = composite(
        g,
        &direct,
        &ReflectionImage {
            handled: handled.clone(),
            ..model
        },
    );
    let mirror = |j: usize| g.is_reflective(j) && g.roughness[j] == 0.0;
    let second: Vec<bool> = (0..n)
        .map(|i| handled[i] && hit_texel[i].is_some_and(mirror))
        .collect();
    let source_answered: Vec<bool> = (0..n)
        .map(|i| second[i] && hit_texel[i].is_some_and(|j| answered_first[j]))
        .collect();
    for (fin, ms, stats, rays) in passes {
        out.push(BounceFrame {
            error: compare(&truth2, &fin, &handled),
            error_one: compare(&truth1, &fin, &handled),
            error_second: compare(&truth2, &fin, &second),
            error_model: compare(&model, &fin, &source_answered),
            fin,
            ms,
            stats,
            rays,
        });
    }
    Ok(BounceRun {
        frames: out,
        handled,
        second,
        source_answered,
        hit_texel,
        truth: truth2,
        model,
        reference_ms: two.ms,
    })
}

fn add(a: BounceStats, b: &BounceStats) -> BounceStats {
    BounceStats {
        reprojected: a.reprojected + b.reprojected,
        rejected: a.rejected + b.rejected,
        off_screen: a.off_screen + b.off_screen,
        no_surface: a.no_surface + b.no_surface,
    }
}
