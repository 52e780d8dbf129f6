//! Glossy screen-space reflections over the primary view (seed 004 Hi-Z
//! cone tracing, seed 003 Sec. 3.5 multi-ray) and the variants of a scene
//! made glossy ([`Glossiness`]). The report's glossy study over them is
//! [`crate::report::glossy`].
//!
//! # Pipeline ([`run`])
//!
//! Inputs an engine has at this point: the G-buffer (normals, roughness, a
//! mask of the glossy pixels), its depth buffer (the report uses
//! reversed-Z with an infinite far plane) and the direct-shaded frame
//! color ([`crate::render::direct_image`]: what the reflected surfaces look
//! like under the one-bounce rule of [`crate::shade`]). The timed pass is
//! refl-core's glossy pass ([`refl_core::glossy`]), as an engine calls it:
//!
//! 1. [`refl_core::try_prepare_glossy`]: the Hi-Z, color and (if the cone
//!    reads it) visibility pyramids (multi-ray: level 0 of the color
//!    pyramid only).
//! 2. [`refl_core::GlossyPass`] over row bands of 16 rows on the pool: per
//!    glossy pixel the mirror ray traced and validated as the mirror pass
//!    does, then the cone over the pyramids (or the multi-ray estimate),
//!    the fades, and the weight the probe takes.
//! 3. The probe: `color + fallback_weight * fallback(dir, roughness)`.
//!
//! The fallback (seed 004 Sec. 4.4.5: "blend in the rest of the visibility
//! using, say, cube-maps") is a caller function of the direction and the
//! pixel's roughness, asked for the pixel's mirror direction; the report
//! passes the roughness-prefiltered probe ([`crate::probe::PrefilteredEnv`],
//! built once per scene outside the timed pass, as an engine prefilters
//! probes at load) and, for one comparison row, the unfiltered environment
//! map ([`crate::shade::env_map`]). Multi-ray gives the probe the share of
//! the lobe its missed rays carry. Pyramid and output buffers are allocated
//! outside the timed part, as an engine keeps them across frames.

use crate::gbuffer::GBuffer;
use crate::render::{timed, ReflectionImage, Timed};
use crate::screen::PYRAMID_BAND;
use glam::Vec3;
use rayon::prelude::*;
use refl_core::cone::{ConeOptions, Fades};
use refl_core::hiz::{HiZLayout, HiZTexel};
use refl_core::{
    ColorTexel, DepthImage, GlossyOptions, GlossyPass, GlossyScratch, GlossyScratchMut,
    GlossyTexel, ImageView, ImageViewMut, MirrorStatus, NormalSpace, RowRange,
};

/// A glossy screen-space method with its setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GlossyMethod {
    /// Hi-Z trace of the mirror ray, then a cone trace from its hit.
    Cone {
        /// Cone-trace options (circles, visibility, stretch).
        options: ConeOptions,
        /// Fades of seed 004 Sec. 4.6.1 (blend toward the fallback).
        fades: Option<Fades>,
        /// Size the cone from its world travel ([`refl_core::Cone::travel`])
        /// instead of the seed's screen-space triangle.
        view_space: bool,
    },
    /// `rays` Hi-Z traced rays per pixel in the cone, Phong-weighted.
    MultiRay {
        /// Rays per pixel.
        rays: u32,
    },
}

impl GlossyMethod {
    /// Caller-buffer bytes per pixel the method reads besides the G-buffer:
    /// depth (4) + Hi-Z (8 per texel) + color pyramid (12 per texel) +
    /// visibility pyramid (4 per texel, cone only), all levels.
    pub fn bytes_per_pixel(&self, width: u32, height: u32) -> f64 {
        let texels = HiZLayout::try_new(width, height).map_or(0, |l| l.len()) as f64;
        let per_texel = match self {
            GlossyMethod::Cone { .. } => 8.0 + 12.0 + 4.0,
            GlossyMethod::MultiRay { .. } => 8.0 + 12.0,
        };
        4.0 + per_texel * texels / (f64::from(width) * f64::from(height))
    }

    /// The glossy pass's options for this method: refl-core's defaults
    /// (the mirror pass's axis settings) with the method's cone settings,
    /// every roughness above 0 traced.
    pub fn options(&self) -> GlossyOptions {
        let d = GlossyOptions {
            min_roughness: 0.0,
            ..GlossyOptions::default()
        };
        match *self {
            GlossyMethod::Cone {
                options,
                fades,
                view_space,
            } => GlossyOptions {
                cone: options,
                fades: fades.unwrap_or_default(),
                view_space,
                ..d
            },
            GlossyMethod::MultiRay { rays } => GlossyOptions {
                method: refl_core::GlossyMethod::MultiRay,
                rays,
                ..d
            },
        }
    }
}

/// Counts of one glossy pass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GlossyStats {
    /// Glossy pixels shaded.
    pub pixels: usize,
    /// Cone: pixels whose mirror ray hit in screen space. Multi-ray: rays
    /// that hit.
    pub hits: usize,
    /// Cone: sum of the coverage (1 - fallback weight before fades).
    /// Multi-ray: rays traced.
    pub coverage_sum: f64,
    /// Cone: circles taken. Multi-ray: 0.
    pub work: u64,
}

/// Buffers a glossy pass writes (allocated once, outside the timing): the
/// pass's pyramids and its per-pixel outputs.
pub struct GlossyBuffers {
    hiz: Vec<HiZTexel>,
    color: Vec<ColorTexel>,
    visibility: Vec<f32>,
    texels: Vec<GlossyTexel>,
    rgb: Vec<ColorTexel>,
}

impl GlossyBuffers {
    /// Buffers for a `width x height` frame (the visibility pyramid
    /// included, whatever the options).
    ///
    /// # Errors
    /// As [`HiZLayout::try_new`].
    pub fn new(width: u32, height: u32) -> Result<Self, refl_core::Error> {
        let n = width as usize * height as usize;
        Ok(Self {
            hiz: vec![[0.0; 2]; refl_core::hiz::try_hiz_len(width, height)?],
            color: vec![[0.0; 3]; refl_core::try_color_pyramid_len(width, height)?],
            visibility: vec![0.0; refl_core::try_visibility_pyramid_len(width, height)?],
            texels: vec![GlossyTexel::default(); n],
            rgb: vec![[0.0; 3]; n],
        })
    }
}

/// The glossy pixels of `g`: reflective with roughness > 0.
pub fn glossy_mask(g: &GBuffer) -> Vec<bool> {
    (0..g.len())
        .map(|i| g.is_reflective(i) && g.roughness[i] > 0.0)
        .collect()
}

/// The G-buffer images the glossy pass reads, as refl-core takes them.
struct PassImages {
    normals: Vec<[f32; 3]>,
    mask: Vec<u8>,
    lit: Vec<ColorTexel>,
}

impl PassImages {
    fn new(g: &GBuffer, lit: &[Vec3], mask: &[bool]) -> Self {
        Self {
            normals: g.normal.iter().map(|n| n.to_array()).collect(),
            mask: mask.iter().map(|&m| u8::from(m)).collect(),
            lit: lit.iter().map(|c| c.to_array()).collect(),
        }
    }

    fn gbuffer<'a>(
        &'a self,
        g: &'a GBuffer,
        depth: &DepthImage<'a>,
    ) -> Result<refl_core::GBuffer<'a>, refl_core::Error> {
        let (w, h) = (g.width(), g.height());
        refl_core::GBuffer::try_new(
            *depth,
            ImageView::try_new(&self.normals, w, h, w)?,
            NormalSpace::World,
        )?
        .try_with_mask(ImageView::try_new(&self.mask, w, h, w)?)?
        .try_with_roughness(ImageView::try_new(&g.roughness, w, h, w)?)?
        .try_with_color(ImageView::try_new(&self.lit, w, h, w)?)
    }
}

/// Runs `method` on the glossy pixels of `g` (those of `mask`) with
/// refl-core's glossy pass: timed pass as in the module docs. `lit` is the
/// direct-shaded frame, `fallback(dir, roughness)` the probe, asked for the
/// pixel's mirror direction and roughness.
///
/// # Errors
/// A refl-core error (bad buffers).
#[allow(clippy::too_many_arguments)]
pub fn run(
    method: GlossyMethod,
    g: &GBuffer,
    lit: &[Vec3],
    depth: &DepthImage<'_>,
    mask: &[bool],
    fallback: impl Fn(Vec3, f32) -> Vec3 + Sync,
    buffers: &mut GlossyBuffers,
    pool: &rayon::ThreadPool,
) -> Result<Timed<(ReflectionImage, GlossyStats)>, refl_core::Error> {
    let images = PassImages::new(g, lit, mask);
    let gb = images.gbuffer(g, depth)?;
    let options = method.options();
    let (w, h) = (g.width(), g.height());
    let t = timed(|| -> Result<_, refl_core::Error> {
        let GlossyBuffers {
            hiz,
            color,
            visibility,
            texels,
            rgb,
        } = buffers;
        refl_core::try_prepare_glossy(
            GlossyScratchMut {
                hiz,
                color,
                visibility,
            },
            &gb,
            &options,
        )?;
        let pass = GlossyPass::try_new(
            gb,
            options,
            GlossyScratch {
                hiz,
                color,
                visibility,
            },
        )?;
        let band = PYRAMID_BAND as usize * w as usize;
        let bands: Vec<refl_core::GlossyStats> = pool.install(|| {
            texels
                .par_chunks_mut(band)
                .zip(rgb.par_chunks_mut(band))
                .enumerate()
                .map(|(k, (t, c))| {
                    let y0 = k as u32 * PYRAMID_BAND;
                    let rows = RowRange::try_new(y0, (y0 + PYRAMID_BAND).min(h), h)?;
                    pass.try_run(
                        &mut ImageViewMut::try_band(t, w, h, w, rows)?,
                        Some(&mut ImageViewMut::try_band(c, w, h, w, rows)?),
                        &mut [],
                    )
                })
                .collect::<Result<_, _>>()
        })?;
        // The probe takes the rest of each lobe.
        let texels = &*texels;
        let rgb = &*rgb;
        let shaded: Vec<Vec3> = pool.install(|| {
            (0..g.len())
                .into_par_iter()
                .with_min_len(256)
                .map(|i| {
                    let t = &texels[i];
                    let c = Vec3::from_array(rgb[i]);
                    if t.fallback_weight > 0.0 {
                        c + t.fallback_weight * fallback(t.dir, g.roughness[i])
                    } else {
                        c
                    }
                })
                .collect()
        });
        let mut img = ReflectionImage::empty(w, h);
        let mut stats = GlossyStats::default();
        for (i, (t, c)) in texels.iter().zip(shaded).enumerate() {
            if matches!(t.status, MirrorStatus::Skipped | MirrorStatus::NoSurface) {
                continue;
            }
            img.rgb[i] = c;
            img.handled[i] = true;
            stats.pixels += 1;
            if t.status == MirrorStatus::Hit {
                stats.coverage_sum += f64::from(t.coverage);
            }
        }
        let lobe_rays: u64 = bands.iter().map(|b| b.lobe_rays).sum();
        match method {
            GlossyMethod::Cone { .. } => {
                stats.hits = bands.iter().map(|b| b.hits as usize).sum();
                stats.work = bands.iter().map(|b| b.circles).sum();
            }
            GlossyMethod::MultiRay { .. } => {
                stats.hits = bands.iter().map(|b| b.lobe_hits as usize).sum();
                stats.coverage_sum = lobe_rays as f64;
            }
        }
        Ok((img, stats))
    });
    let value = t.value?;
    Ok(Timed { value, ms: t.ms })
}

// ------------------------------------------------- glossy scene variants

/// A roughness assignment of the study's variants of a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Glossiness {
    /// Every reflective surface gets this roughness.
    Uniform(f32),
    /// Roughness rising linearly with world x from `lo` at the scene's
    /// smallest x to `hi` at its largest (on the room, -6 to +6: a ramp
    /// across the floor).
    Ramp(f32, f32),
}

impl Glossiness {
    /// The variant's label: the scene's label and the roughness
    /// (`room-glossy-0.20`, `room-ramp-0.10-0.45`).
    pub fn label(&self, scene: &str) -> String {
        match self {
            Glossiness::Uniform(r) => format!("{scene}-glossy-{r:.2}"),
            Glossiness::Ramp(lo, hi) => format!("{scene}-ramp-{lo:.2}-{hi:.2}"),
        }
    }

    /// Overrides the roughness of every reflective pixel of `g`; a ramp
    /// runs over world x from `x_range.0` to `x_range.1` (the scene's
    /// bounds).
    pub fn apply(&self, g: &mut GBuffer, x_range: (f32, f32)) {
        let (x0, x1) = x_range;
        let width = (x1 - x0).max(f32::MIN_POSITIVE);
        for i in 0..g.len() {
            if g.is_reflective(i) {
                g.roughness[i] = match *self {
                    Glossiness::Uniform(r) => r,
                    Glossiness::Ramp(lo, hi) => {
                        let s = ((g.position[i].x - x0) / width).clamp(0.0, 1.0);
                        lo + (hi - lo) * s
                    }
                };
            }
        }
    }
}

/// The study's variants: two glossiness levels (seed 003 Fig. 11) and a
/// roughness ramp.
pub const VARIANTS: [Glossiness; 3] = [
    Glossiness::Uniform(0.2),
    Glossiness::Uniform(0.35),
    Glossiness::Ramp(0.1, 0.45),
];
