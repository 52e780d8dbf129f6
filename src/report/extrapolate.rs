//! The `hiz` rows with the seed's extrapolation of surfaces (seed 004
//! Sec. 4.6.2; [`crate::extrapolate`]): the Hi-Z mirror pass at its
//! default setting, then the bilateral dilation of the pixels whose ray
//! left the image, at several radii. Timed and measured like the other
//! `hiz` rows ([`super::methods`]): the filled pixels count as handled,
//! so `coverage` rises by what the dilation answers and the error on them
//! is its artifact (the seed expects it to "fail horribly" on mirrors,
//! which the report's scenes mostly are).

use super::accum::{Extra, ScreenAccum};
use super::methods::{median_run, Frame, FrameRun, Setting};
use super::{Level, Sizes};
use crate::screen::{self, RayStats, ScreenMethod};
use refl_core::extrapolate::ExtrapolateOptions;
use refl_core::DepthConvention;

/// One dilation setting after the pass of `kernel`.
struct ExtrapolateSetting {
    kernel: ScreenMethod,
    options: ExtrapolateOptions,
    label: String,
}

/// The dilation settings at `sizes`: radius 4 (the default); long also
/// radius 2 and 8 and every host ray filled (`holes=all`), not only the
/// rays that left the image.
pub fn settings(sizes: &Sizes, kernel: ScreenMethod) -> Vec<Box<dyn Setting>> {
    let base = ExtrapolateOptions::default();
    let mut v = vec![(base, "extrapolate=radius4".to_owned())];
    let radii: &[u32] = match sizes.level {
        Level::Quick | Level::Default => &[],
        Level::Long => &[2, 8],
    };
    for &radius in radii {
        v.push((
            ExtrapolateOptions { radius, ..base },
            format!("extrapolate=radius{radius}"),
        ));
    }
    if sizes.level == Level::Long {
        v.push((
            ExtrapolateOptions {
                all_host_rays: true,
                ..base
            },
            "extrapolate=radius4;holes=all".to_owned(),
        ));
    }
    v.into_iter()
        .map(|(options, label)| {
            Box::new(ExtrapolateSetting {
                kernel,
                options,
                label,
            }) as Box<dyn Setting>
        })
        .collect()
}

impl Setting for ExtrapolateSetting {
    fn label(&self) -> &str {
        &self.label
    }

    fn run(&self, f: &mut Frame<'_>) -> Result<FrameRun, String> {
        let (g, pool, pool_1t, runs, runs_1t) =
            (f.g, f.pool, f.pool_1t, f.sizes.runs, f.sizes.runs_1t);
        let convention = DepthConvention::ReversedZ;
        let kernel = self.kernel;
        let sf = f.screen();
        sf.prepare_depth(g, convention).map_err(|e| e.to_string())?;
        let sf = &*sf;
        let depth = sf.depth(convention).ok_or("depth buffer")?;
        let image = depth.image().map_err(|e| e.to_string())?;
        let run =
            |pool| crate::extrapolate::run(kernel, true, &self.options, &image, &sf.images, pool);
        let (out, ms) = median_run(runs, || run(pool)).map_err(|e| e.to_string())?;
        let (_, ms_1t) = median_run(runs_1t, || run(pool_1t)).map_err(|e| e.to_string())?;
        let (fetches, steps, iterations) =
            screen::kernel_work(kernel, &image, &sf.images, &sf.rays, pool)
                .map_err(|e| e.to_string())?;
        let stats = RayStats {
            fetches,
            steps,
            iterations,
            ..screen::evaluate(&sf.rays, &out.pass.texels)
        };
        Ok(FrameRun {
            image: crate::extrapolate::shade(g, &out),
            ms,
            extra: Extra::Screen(ScreenAccum {
                stats,
                kernel_ms: ms,
                kernel_ms_1t: ms_1t,
                obvhs_ms: sf.obvhs_ms,
                obvhs_ms_1t: sf.obvhs_ms_1t,
                bytes_per_pixel: kernel.bytes_per_pixel(g.width(), g.height())
                    + std::mem::size_of::<[f32; 3]>() as f64
                    + 1.0,
                layered: false,
                layered_lookups: None,
            }),
        })
    }
}
