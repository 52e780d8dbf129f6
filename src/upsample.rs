//! Fewer rays for the screen-space mirror pass (seed 004 Sec. 4.7.3,
//! 4.7.4) with refl-core's [`refl_core::upsample`]: one pixel of every 2x2
//! block traced by the mirror pass ([`refl_core::upsample::HalfPass`]),
//! the others reconstructed by cross-bilateral upsampling guided by the
//! full-resolution depth and normals
//! ([`refl_core::upsample::UpsamplePass`]), optionally with the pixels no
//! sample reaches re-traced at full resolution. The root package only
//! drives the row bands and times them; the report's `hiz` rows with
//! `half=` settings come from here ([`crate::report::half`]).

use crate::render::Timed;
use crate::screen::{self, PassImages, PassRun, ReflectionRays, ScreenMethod, PYRAMID_BAND};
use rayon::prelude::*;
use refl_core::upsample::{
    try_half_size, HalfPass, Subsample, UpsampleOptions, UpsamplePass, UpsampleStats,
    UpsampleStatus,
};
use refl_core::{DepthImage, ImageView, ImageViewMut, MirrorStats, MirrorTexel, RowRange};

/// Which pixels are traced and how the others are reconstructed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FewerRays {
    /// The traced pixel of each 2x2 block.
    pub subsample: Subsample,
    /// The reconstruction's settings.
    pub options: UpsampleOptions,
}

/// What [`run`] returns.
#[derive(Clone, Debug)]
pub struct FewerRun {
    /// The full-resolution result: every pixel's texel and color (as the
    /// full pass's [`screen::run`] returns them) and the half pass's
    /// counts.
    pub pass: PassRun,
    /// Every pixel's [`UpsampleStatus`] as a byte.
    pub status: Vec<u8>,
    /// The reconstruction's counts.
    pub upsample: UpsampleStats,
}

impl FewerRun {
    /// Pixels traced by the mirror pass (the block samples and the
    /// re-traced pixels), row-major indices.
    pub fn traced_pixels(&self) -> impl Iterator<Item = usize> + '_ {
        self.status
            .iter()
            .enumerate()
            .filter(|(_, &s)| {
                s == UpsampleStatus::Copied as u8 || s == UpsampleStatus::Retraced as u8
            })
            .map(|(i, _)| i)
    }

    /// The rays of `rays` whose pixels the mirror pass traced (for the
    /// kernel work of the traced pixels only).
    pub fn traced_rays(&self, rays: &ReflectionRays) -> ReflectionRays {
        let traced: std::collections::HashSet<usize> = self.traced_pixels().collect();
        let mut out = ReflectionRays::default();
        for k in 0..rays.len() {
            if traced.contains(&(rays.pixel[k] as usize)) {
                out.pixel.push(rays.pixel[k]);
                out.ray.push(rays.ray[k]);
                out.reference.push(rays.reference[k]);
                out.reference_pixel.push(rays.reference_pixel[k]);
                out.visible.push(rays.visible[k]);
            }
        }
        out
    }
}

fn add_upsample(a: UpsampleStats, b: &UpsampleStats) -> UpsampleStats {
    UpsampleStats {
        copied: a.copied + b.copied,
        interpolated: a.interpolated + b.interpolated,
        retrace: a.retrace + b.retrace,
        retrace_written: a.retrace_written + b.retrace_written,
        retraced: a.retraced + b.retraced,
        hits: a.hits + b.hits,
    }
}

/// Runs the mirror pass of `method` on the pixels `setting` traces and
/// reconstructs the full-resolution result, over the frame of `depth` and
/// `images` on `pool`, timed as [`screen::run`] times the full pass: Hi-Z's
/// pyramid build, the traced blocks in bands of [`PYRAMID_BAND`] / 2 block
/// rows, then the reconstruction (and any re-trace) in bands of
/// [`PYRAMID_BAND`] pixel rows; buffers are allocated outside the timed
/// part.
///
/// # Errors
/// A refl-core error (buffers that do not match the camera).
pub fn run(
    method: ScreenMethod,
    refine: bool,
    setting: &FewerRays,
    depth: &DepthImage<'_>,
    images: &PassImages,
    pool: &rayon::ThreadPool,
) -> Result<Timed<FewerRun>, refl_core::Error> {
    let (w, h) = (depth.width(), depth.height());
    let (hw, hh) = try_half_size(w, h)?;
    let (n, hn) = (w as usize * h as usize, hw as usize * hh as usize);
    let mut half_texels = vec![MirrorTexel::default(); hn];
    let mut half_color = vec![[0.0f32; 3]; hn];
    let mut texels = vec![MirrorTexel::default(); n];
    let mut color = vec![[0.0f32; 3]; n];
    let mut status = vec![0u8; n];
    let mut pyramid = screen::pyramid_storage(method, w, h)?;
    let half_band_rows = (PYRAMID_BAND / 2).max(1);
    let half_band = half_band_rows as usize * hw as usize;
    let band = PYRAMID_BAND as usize * w as usize;
    let t = crate::render::timed(|| {
        screen::with_pass(method, refine, depth, images, &mut pyramid, pool, |pass| {
            let lit = pass.gbuffer().color().is_some();
            let hp = HalfPass::new(*pass, setting.subsample);
            let half_stats = pool.install(|| {
                half_texels
                    .par_chunks_mut(half_band)
                    .zip(half_color.par_chunks_mut(half_band))
                    .enumerate()
                    .map(|(k, (t, c))| {
                        let y0 = k as u32 * half_band_rows;
                        let rows = RowRange::try_new(y0, (y0 + half_band_rows).min(hh), hh)?;
                        let mut out = ImageViewMut::try_band(t, hw, hh, hw, rows)?;
                        let mut col = ImageViewMut::try_band(c, hw, hh, hw, rows)?;
                        hp.try_run(&mut out, lit.then_some(&mut col), &mut [])
                    })
                    .try_fold(MirrorStats::default, |a, b| Ok(screen::add_stats(a, &b?)))
                    .try_reduce(MirrorStats::default, |a, b| Ok(screen::add_stats(a, &b)))
            })?;
            let up = UpsamplePass::try_new(
                *pass,
                setting.subsample,
                ImageView::try_new(&half_texels, hw, hh, hw)?,
                if lit {
                    Some(ImageView::try_new(&half_color, hw, hh, hw)?)
                } else {
                    None
                },
                setting.options,
            )?;
            let up_stats = pool.install(|| {
                texels
                    .par_chunks_mut(band)
                    .zip(color.par_chunks_mut(band))
                    .zip(status.par_chunks_mut(band))
                    .enumerate()
                    .map(|(k, ((t, c), s))| {
                        let y0 = k as u32 * PYRAMID_BAND;
                        let rows = RowRange::try_new(y0, (y0 + PYRAMID_BAND).min(h), h)?;
                        let mut out = ImageViewMut::try_band(t, w, h, w, rows)?;
                        let mut col = ImageViewMut::try_band(c, w, h, w, rows)?;
                        let mut st = ImageViewMut::try_band(s, w, h, w, rows)?;
                        up.try_run(&mut out, lit.then_some(&mut col), Some(&mut st), &mut [])
                    })
                    .try_fold(UpsampleStats::default, |a, b| Ok(add_upsample(a, &b?)))
                    .try_reduce(UpsampleStats::default, |a, b| Ok(add_upsample(a, &b)))
            })?;
            Ok::<_, refl_core::Error>((half_stats, up_stats))
        })
    });
    let (stats, upsample) = t.value??;
    Ok(Timed {
        value: FewerRun {
            pass: PassRun {
                texels,
                color,
                stats,
            },
            status,
            upsample,
        },
        ms: t.ms,
    })
}
