//! The `hiz` rows that trace one ray per 2x2 block (seed 004 Sec. 4.7.3,
//! 4.7.4; [`crate::upsample`]): the Hi-Z mirror pass at its default
//! setting on a quarter of the pixels, the rest reconstructed by
//! cross-bilateral upsampling, with and without a full-resolution
//! re-trace of the pixels no sample reaches. Timed and measured like the
//! full-resolution `hiz` rows ([`super::methods`]), so each is a point of
//! the same error-vs-time curve.

use super::accum::{Extra, HalfAccum, ScreenAccum};
use super::methods::{median_run, Frame, FrameRun, Setting};
use super::Sizes;
use crate::screen::{self, RayStats, ScreenMethod};
use crate::upsample::{run, FewerRays};
use refl_core::upsample::{Subsample, UpsampleOptions, UpsampleStatus};
use refl_core::DepthConvention;

/// One fewer-rays setting of a screen-space kernel.
struct HalfSetting {
    kernel: ScreenMethod,
    pattern: Subsample,
    options: UpsampleOptions,
    label: String,
}

/// The fewer-rays settings of `kernel` at `sizes` (the reconstruction at
/// its defaults unless the label says otherwise): the uniform half grid,
/// the staggered lattice, the uniform grid with the pixels no sample
/// reaches re-traced at full resolution, and plain bilinear
/// reconstruction (the guide off: what the depth and normals buy); the
/// default and long runs also re-trace reflected silhouettes and edges
/// (`retrace=edges+mixed`), compare depths along the tangent plane
/// (`depth=plane`) and take the samples' mean color instead of shading
/// the interpolated hit (`color=mean`).
pub fn settings(sizes: &Sizes, kernel: ScreenMethod) -> Vec<Box<dyn Setting>> {
    let base = UpsampleOptions::default();
    let bilinear = UpsampleOptions {
        depth_threshold: f32::INFINITY,
        depth_sigma: f32::INFINITY,
        normal_power: 0.0,
        ..base
    };
    let retrace = UpsampleOptions {
        retrace: true,
        ..base
    };
    let uniform = Subsample::uniform(0);
    let mut v = vec![
        (uniform, base, "half=uniform;upsample=bilateral"),
        (
            Subsample::staggered(0),
            base,
            "half=staggered;upsample=bilateral",
        ),
        (
            uniform,
            retrace,
            "half=uniform;upsample=bilateral;retrace=edges",
        ),
        (uniform, bilinear, "half=uniform;upsample=bilinear"),
    ];
    if !sizes.quick() {
        let variants = [
            (
                UpsampleOptions {
                    retrace_mixed: true,
                    ..retrace
                },
                "half=uniform;upsample=bilateral;retrace=edges+mixed",
            ),
            (
                UpsampleOptions {
                    plane_depth: true,
                    ..base
                },
                "half=uniform;upsample=bilateral;depth=plane",
            ),
            (
                UpsampleOptions {
                    shade_hits: false,
                    ..base
                },
                "half=uniform;upsample=bilateral;color=mean",
            ),
        ];
        v.extend(variants.map(|(o, label)| (uniform, o, label)));
    }
    v.into_iter()
        .map(|(pattern, options, label)| {
            Box::new(HalfSetting {
                kernel,
                pattern,
                options,
                label: label.to_owned(),
            }) as Box<dyn Setting>
        })
        .collect()
}

impl Setting for HalfSetting {
    fn label(&self) -> &str {
        &self.label
    }

    fn run(&self, f: &mut Frame<'_>) -> Result<FrameRun, String> {
        let (g, pool, pool_1t, runs, runs_1t) =
            (f.g, f.pool, f.pool_1t, f.sizes.runs, f.sizes.runs_1t);
        // The frame number steps the traced sub-pixel (the rows pool the
        // four phases over the frames).
        let setting = FewerRays {
            subsample: Subsample {
                frame: f.index as u32,
                ..self.pattern
            },
            options: self.options,
        };
        let convention = DepthConvention::ReversedZ;
        let kernel = self.kernel;
        let sf = f.screen();
        sf.prepare_depth(g, convention).map_err(|e| e.to_string())?;
        let sf = &*sf;
        let depth = sf.depth(convention).ok_or("depth buffer")?;
        let image = depth.image().map_err(|e| e.to_string())?;
        let (out, ms) = median_run(runs, || {
            run(kernel, true, &setting, &image, &sf.images, pool)
        })
        .map_err(|e| e.to_string())?;
        let (_, ms_1t) = median_run(runs_1t, || {
            run(kernel, true, &setting, &image, &sf.images, pool_1t)
        })
        .map_err(|e| e.to_string())?;
        // The kernels' work on the rays the pass traced, per reflective
        // pixel (the `*_per_ray` columns divide by every ray).
        let (fetches, steps, iterations) =
            screen::kernel_work(kernel, &image, &sf.images, &out.traced_rays(&sf.rays), pool)
                .map_err(|e| e.to_string())?;
        let stats = RayStats {
            fetches,
            steps,
            iterations,
            ..screen::evaluate(&sf.rays, &out.pass.texels)
        };
        let skipped = UpsampleStatus::Skipped as u8;
        let half = HalfAccum {
            pixels: out.status.iter().filter(|&&s| s != skipped).count(),
            traced: out.traced_pixels().count(),
            retrace: out.upsample.retrace as usize,
        };
        Ok(FrameRun {
            image: screen::shade(g, &out.pass),
            ms,
            extra: Extra::Half(
                ScreenAccum {
                    stats,
                    kernel_ms: ms,
                    kernel_ms_1t: ms_1t,
                    obvhs_ms: sf.obvhs_ms,
                    obvhs_ms_1t: sf.obvhs_ms_1t,
                    bytes_per_pixel: kernel.bytes_per_pixel(g.width(), g.height())
                        + half_bytes_per_pixel(g.width(), g.height()),
                    layered: false,
                    layered_lookups: None,
                },
                half,
            ),
        })
    }
}

/// Caller-buffer bytes per pixel of the half-resolution texels and colors.
fn half_bytes_per_pixel(width: u32, height: u32) -> f64 {
    let n = refl_core::upsample::try_half_len(width, height).unwrap_or(0) as f64;
    let per = std::mem::size_of::<refl_core::MirrorTexel>() + std::mem::size_of::<[f32; 3]>();
    n * per as f64 / (f64::from(width) * f64::from(height))
}
