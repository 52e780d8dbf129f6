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
//! pass's color where it hit and the environment elsewhere. Errors are
//! measured on the pixels the pass hit. Timed: the bounce pass and the
//! mirror pass.

use crate::gbuffer::GBuffer;
use crate::render::{
    compare, composite, direct_image, mirror_env, timed, ImageError, ReflectionImage,
};
use crate::screen::{self, DepthBuffer, PassImages, ScreenMethod};
use crate::shade::{reflection_dir, Shader};
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
    /// Time of the bounce pass (0 on frame 0) and the mirror pass, ms.
    pub ms: f64,
    /// The bounce pass's counts (zero on frame 0).
    pub stats: BounceStats,
}

/// What [`run`] returns.
#[derive(Clone, Debug)]
pub struct BounceRun {
    /// One entry per frame.
    pub frames: Vec<BounceFrame>,
    /// Perfect-mirror pixels the pass hit on the last frame (the pixels
    /// every error is measured on).
    pub handled: Vec<bool>,
    /// Time of the two-bounce reference on the perfect-mirror pixels, ms.
    pub reference_ms: f64,
}

/// The reflection of every perfect-mirror pixel of `g` traced with
/// `bounces` bounces.
fn reference(
    shader: &Shader,
    g: &GBuffer,
    bounces: u32,
    pool: &rayon::ThreadPool,
) -> ReflectionImage {
    let mut out = ReflectionImage::empty(g.width(), g.height());
    out.fill(
        pool,
        |i| g.is_reflective(i) && g.roughness[i] == 0.0,
        |i| {
            let s = g.surface(i).expect("reflective pixels are hits");
            let view = -g.primary_ray(i).dir;
            let dir = reflection_dir(view, s.shading_normal, s.geo_normal);
            shader.trace_reflection_bounces(s.position, dir, shader.epsilon, bounces)
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
    let two = timed(|| reference(shader, g, 2, pool));
    let one = reference(shader, g, 1, pool);
    let depth = DepthBuffer::new(g, DepthConvention::ReversedZ, f32::INFINITY)?;
    let method = ScreenMethod::HiZ(HiZOptions::default());
    let mut out = Vec::new();
    let mut last: Option<Vec<Vec3>> = None;
    let mut handled = vec![false; n];
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
        for i in (0..n).filter(|&i| g.is_reflective(i) && g.roughness[i] == 0.0) {
            let hit = pass.value.texels[i].status == MirrorStatus::Hit;
            handled[i] = hit;
            img.rgb[i] = if hit {
                Vec3::from_array(pass.value.color[i])
            } else {
                mirror_env(g, i)
            };
            img.handled[i] = true;
        }
        let fin = composite(g, &direct, &img);
        passes.push((fin.clone(), bounce_ms + pass.ms, stats));
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
    for (fin, ms, stats) in passes {
        out.push(BounceFrame {
            error: compare(&truth2, &fin, &handled),
            error_one: compare(&truth1, &fin, &handled),
            fin,
            ms,
            stats,
        });
    }
    Ok(BounceRun {
        frames: out,
        handled,
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
