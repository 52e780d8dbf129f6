//! Extrapolation of surfaces (seed 004 Sec. 4.6.2) with refl-core's
//! [`refl_core::extrapolate`]: the screen-space mirror pass over the whole
//! frame, then the bilateral dilation of the pixels whose ray left the
//! image from the answered pixels around them. The root package only
//! drives the row bands and times them; the report's `hiz` rows with
//! `extrapolate=` settings come from here ([`crate::report::extrapolate`]).

use crate::render::{ReflectionImage, Timed};
use crate::screen::{self, PassImages, PassRun, ScreenMethod, PYRAMID_BAND};
use rayon::prelude::*;
use refl_core::extrapolate::{
    ExtrapolateOptions, ExtrapolatePass, ExtrapolateStats, ExtrapolateStatus,
};
use refl_core::glam::Vec3;
use refl_core::{DepthImage, ImageView, ImageViewMut, MirrorStatus, MirrorTexel, RowRange};

/// What [`run`] returns.
#[derive(Clone, Debug)]
pub struct ExtrapolatedRun {
    /// The mirror pass's result, as [`screen::run`] returns it.
    pub pass: PassRun,
    /// Every pixel's color after the dilation.
    pub color: Vec<[f32; 3]>,
    /// Every pixel's [`ExtrapolateStatus`] as a byte.
    pub status: Vec<u8>,
    /// The dilation's counts.
    pub stats: ExtrapolateStats,
}

/// Runs the mirror pass of `method` and the dilation over the frame of
/// `depth` and `images` on `pool`, timed as [`screen::run`] times the pass
/// alone plus the dilation in bands of [`PYRAMID_BAND`] rows; buffers are
/// allocated outside the timed part.
///
/// # Errors
/// A refl-core error (buffers that do not match the camera, options out
/// of range).
pub fn run(
    method: ScreenMethod,
    refine: bool,
    options: &ExtrapolateOptions,
    depth: &DepthImage<'_>,
    images: &PassImages,
    pool: &rayon::ThreadPool,
) -> Result<Timed<ExtrapolatedRun>, refl_core::Error> {
    let (w, h) = (depth.width(), depth.height());
    let n = w as usize * h as usize;
    let mut texels = vec![MirrorTexel::default(); n];
    let mut color = vec![[0.0f32; 3]; n];
    let mut filled = vec![[0.0f32; 3]; n];
    let mut status = vec![0u8; n];
    let mut pyramid = screen::pyramid_storage(method, w, h)?;
    let band = PYRAMID_BAND as usize * w as usize;
    let t = crate::render::timed(|| {
        screen::with_pass(method, refine, depth, images, &mut pyramid, pool, |pass| {
            let lit = pass.gbuffer().color().is_some();
            let stats = screen::run_bands(pass, lit, &mut texels, &mut color, pool)?;
            let dilate = ExtrapolatePass::try_new(
                *pass.gbuffer(),
                ImageView::try_new(&texels, w, h, w)?,
                ImageView::try_new(&color, w, h, w)?,
                *options,
            )?;
            let ex = pool.install(|| {
                filled
                    .par_chunks_mut(band)
                    .zip(status.par_chunks_mut(band))
                    .enumerate()
                    .map(|(k, (c, s))| {
                        let y0 = k as u32 * PYRAMID_BAND;
                        let rows = RowRange::try_new(y0, (y0 + PYRAMID_BAND).min(h), h)?;
                        let mut col = ImageViewMut::try_band(c, w, h, w, rows)?;
                        let mut st = ImageViewMut::try_band(s, w, h, w, rows)?;
                        dilate.try_run(&mut col, Some(&mut st), &mut [])
                    })
                    .try_fold(ExtrapolateStats::default, |a, b| Ok(add(a, &b?)))
                    .try_reduce(ExtrapolateStats::default, |a, b| Ok(add(a, &b)))
            })?;
            Ok::<_, refl_core::Error>((stats, ex))
        })
    });
    let (stats, ex) = t.value??;
    Ok(Timed {
        value: ExtrapolatedRun {
            pass: PassRun {
                texels,
                color,
                stats,
            },
            color: filled,
            status,
            stats: ex,
        },
        ms: t.ms,
    })
}

fn add(a: ExtrapolateStats, b: &ExtrapolateStats) -> ExtrapolateStats {
    ExtrapolateStats {
        holes: a.holes + b.holes,
        filled: a.filled + b.filled,
        unfilled: a.unfilled + b.unfilled,
        too_smooth: a.too_smooth + b.too_smooth,
        host_written: a.host_written + b.host_written,
    }
}

/// The reflection image: every mirror pixel (roughness 0) the pass hit or
/// the dilation filled takes its color; the others are not handled (as
/// [`screen::shade`]).
pub fn shade(g: &crate::gbuffer::GBuffer, out: &ExtrapolatedRun) -> ReflectionImage {
    let mut img = ReflectionImage::empty(g.width(), g.height());
    for (i, t) in out.pass.texels.iter().enumerate() {
        let answered =
            t.status == MirrorStatus::Hit || out.status[i] == ExtrapolateStatus::Filled as u8;
        if answered && g.roughness[i] == 0.0 {
            img.rgb[i] = Vec3::from_array(out.color[i]);
            img.handled[i] = true;
        }
    }
    img
}
