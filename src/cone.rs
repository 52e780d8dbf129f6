//! Glossy screen-space reflections over the primary view (seed 004 Hi-Z
//! cone tracing, seed 003 Sec. 3.5 multi-ray) and the glossy study of
//! `refl report` (methods `cone` and `multiray` against the Monte-Carlo
//! reference at low sample counts).
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
use crate::probe::{PrefilteredEnv, ProbeSizes};
use crate::render::{compare, composite, timed, ImageError, ReflectionImage, Timed};
use crate::report_out::Row;
use crate::scene::Scene;
use crate::screen::{reflection_rays, DepthBuffer, PYRAMID_BAND};
use crate::shade::{env_map, Shader};
use crate::tracer::Tracer;
use glam::Vec3;
use rayon::prelude::*;
use refl_core::cone::{ConeOptions, Fades};
use refl_core::hiz::{HiZLayout, HiZTexel};
use refl_core::{
    ColorTexel, DepthConvention, DepthImage, GlossyOptions, GlossyPass, GlossyScratch,
    GlossyScratchMut, GlossyTexel, ImageView, ImageViewMut, MirrorStatus, NormalSpace, RowRange,
};
use std::fmt::Write as _;
use std::path::Path;

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

// ------------------------------------------------------------ the study

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

/// Settings of the study.
#[derive(Clone, Copy, Debug)]
pub struct StudySizes {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel of the converged reference (its noise is checked
    /// against the reference at half as many).
    pub truth_samples: u32,
    /// Timed repetitions (median).
    pub runs: usize,
    /// `--quick`: fewer settings, variants and samples.
    pub quick: bool,
}

/// The cone settings of the study: 4, 8 and 16 circles with the seed's
/// screen-space triangle and rule (the uncovered rest takes the fallback),
/// the same normalized ([`ConeOptions::normalize`]), and normalized with the
/// view-space cone size ([`refl_core::Cone::travel`]); at 8 circles, normalized:
/// visibility off, anisotropic stretch, fades. `--quick`: 4 and 16 circles,
/// normalized.
pub fn cone_settings(quick: bool) -> Vec<(GlossyMethod, String)> {
    let base = ConeOptions::default();
    let cone = |options: ConeOptions, fades: Option<Fades>, view_space: bool, s: String| {
        (
            GlossyMethod::Cone {
                options,
                fades,
                view_space,
            },
            s,
        )
    };
    let norm = |c: u32| ConeOptions {
        max_circles: c,
        normalize: true,
        ..base
    };
    let mut v = Vec::new();
    if quick {
        for c in [4, 16] {
            v.push(cone(norm(c), None, false, format!("circles={c};normalize")));
        }
        return v;
    }
    for c in [4, 8, 16] {
        v.push(cone(
            ConeOptions {
                max_circles: c,
                ..base
            },
            None,
            false,
            format!("circles={c}"),
        ));
    }
    for c in [4, 8, 16] {
        v.push(cone(norm(c), None, false, format!("circles={c};normalize")));
    }
    for c in [4, 8, 16] {
        v.push(cone(
            norm(c),
            None,
            true,
            format!("circles={c};normalize;view"),
        ));
    }
    v.push(cone(
        ConeOptions {
            use_visibility: false,
            ..norm(8)
        },
        None,
        false,
        "circles=8;normalize;visibility=off".into(),
    ));
    v.push(cone(
        ConeOptions {
            max_stretch: 4.0,
            ..norm(8)
        },
        None,
        false,
        "circles=8;normalize;stretch=4".into(),
    ));
    v.push(cone(
        norm(8),
        Some(Fades {
            toward_camera: Some(refl_core::FadeRange {
                start: 0.2,
                end: 0.6,
            }),
            border: Some(refl_core::FadeRange {
                start: 0.85,
                end: 1.0,
            }),
            travel: None,
        }),
        false,
        "circles=8;normalize;fades=camera+border".into(),
    ));
    v
}

/// The multi-ray settings of the study (seed 003 Sec. 3.5: 8 to 49).
pub fn multiray_settings(quick: bool) -> Vec<(GlossyMethod, String)> {
    let counts: &[u32] = if quick { &[8] } else { &[8, 16, 49] };
    counts
        .iter()
        .map(|&n| (GlossyMethod::MultiRay { rays: n }, format!("rays={n}")))
        .collect()
}

/// The reference sample counts of the study's `reference` rows.
pub fn reference_counts(quick: bool) -> &'static [u32] {
    if quick {
        &[8]
    } else {
        &[8, 32, 64]
    }
}

fn median_ms<T>(runs: usize, mut f: impl FnMut() -> Timed<T>) -> (T, f64) {
    let mut first = None;
    let mut times = Vec::new();
    for _ in 0..runs.max(1) {
        let t = f();
        times.push(t.ms);
        first.get_or_insert(t.value);
    }
    (first.expect("runs >= 1"), crate::render::median(times))
}

#[allow(clippy::too_many_arguments)]
fn row(
    scene: &str,
    method: &str,
    setting: &str,
    threads: usize,
    ms: f64,
    reference_ms: f64,
    coverage: f64,
    err: &ImageError,
    extra: Vec<(String, String)>,
) -> Row {
    Row {
        scene: scene.to_owned(),
        method: method.to_owned(),
        setting: setting.to_owned(),
        threads,
        time_ms: ms,
        reference_ms,
        speedup: if ms > 0.0 {
            reference_ms / ms
        } else {
            f64::INFINITY
        },
        coverage,
        mean_abs_255: err.mean_abs,
        psnr_db: err.psnr,
        share_over_8: err.share_over_8(),
        extra,
    }
}

/// The reference time at error `e`, interpolated from the `(error, ms)` of
/// the reference rows in log-log (error falling like `spp^-1/2`, so time
/// grows like `e^-2` beyond the measured range).
pub fn reference_ms_at_error(points: &[(f64, f64)], e: f64) -> Option<f64> {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(err, ms)| *err > 0.0 && *ms > 0.0)
        .collect();
    if p.is_empty() || !(e > 0.0) {
        return None;
    }
    p.sort_by(|a, b| b.0.total_cmp(&a.0));
    // Beyond the range: extrapolate with time ~ error^-2 from the end point.
    if e >= p[0].0 {
        return Some(p[0].1 * (p[0].0 / e).powi(2));
    }
    let last = p[p.len() - 1];
    if e <= last.0 {
        return Some(last.1 * (last.0 / e).powi(2));
    }
    for w in p.windows(2) {
        let ((e0, t0), (e1, t1)) = (w[0], w[1]);
        if e <= e0 && e >= e1 {
            let s = (e.ln() - e0.ln()) / (e1.ln() - e0.ln());
            return Some((t0.ln() + s * (t1.ln() - t0.ln())).exp());
        }
    }
    None
}

/// Runs the glossy study on `scene`: per variant, the converged reference
/// (and its noise check at half the samples), the `reference` rows at low
/// sample counts, `cone` and `multiray` rows; all on the glossy pixels,
/// same threads. Returns the rows and a Markdown section.
///
/// # Errors
/// A message for a failed render or write.
#[allow(clippy::too_many_arguments)]
pub fn report_rows(
    scene: &Scene,
    tracer: &Tracer,
    sizes: StudySizes,
    methods: (bool, bool),
    threads: usize,
    pool: &rayon::ThreadPool,
    images: &Path,
) -> Result<(Vec<Row>, String), String> {
    let shader = Shader::new(scene, tracer);
    let camera = scene
        .camera(0, sizes.width, sizes.height)
        .map_err(|e| format!("glossy study: camera: {e}"))?;
    let variants: &[Glossiness] = if sizes.quick {
        &VARIANTS[..1]
    } else {
        &VARIANTS
    };
    let mut rows = Vec::new();
    // The cone's fallback: the environment pre-filtered per roughness, built
    // once per scene outside the timed passes (an engine prefilters its
    // probes at load).
    let probe_sizes = if sizes.quick {
        ProbeSizes::QUICK
    } else {
        ProbeSizes::DEFAULT
    };
    let probe_t = timed(|| pool.install(|| PrefilteredEnv::build(env_map, probe_sizes)));
    let probe_ms = probe_t.ms;
    let probe = probe_t.value;
    let mut md = format!(
        "\n## Glossy reflections on `{}` (cone tracing, multi-ray, Monte-Carlo reference)\n\n\
         Camera pose 0, every reflective surface made glossy (two levels and a roughness ramp across \
         the scene). Error on the glossy pixels (mean absolute difference on 0..255 of 8-bit sRGB composites, \
         PSNR) against the converged Monte-Carlo reference (Phong-lobe importance sampling, obvhs); \
         time is the whole reflection pass on those pixels, same threads. Cone and multi-ray include building \
         the Hi-Z, color and visibility pyramids. Where the cone's mirror ray finds no hit on screen, or its \
         circles do not cover the lobe, the cone takes the environment pre-filtered for the pixel's roughness \
         (`src/probe.rs`; the row with `;fallback=unfiltered` takes the unfiltered environment in the mirror \
         direction instead); multi-ray gives the same probe the lobe share of its rays that miss.\n\n",
        scene.name
    );
    let dims = probe.level_dims();
    let _ = writeln!(
        md,
        "- Pre-filtered environment probe: {} roughness levels 0..{:.2} (level 0 unfiltered), lat-long \
         {}x{} down to {}x{} texels, {} texels ({:.2} MB), {} lobe samples per texel; built in {:.0} ms \
         ({threads} threads, once per scene, not in the timed passes)",
        probe.level_count(),
        probe.sizes().max_roughness,
        dims[0].0,
        dims[0].1,
        dims[dims.len() - 1].0,
        dims[dims.len() - 1].1,
        probe.texel_count(),
        probe.bytes() as f64 / 1e6,
        probe.sizes().samples,
        probe_ms
    );
    for variant in variants {
        let label = variant.label(&scene.name);
        let mut g = GBuffer::render(scene, tracer, &camera, pool);
        let bounds = scene.bounds();
        variant.apply(&mut g, (bounds.min.x, bounds.max.x));
        let mask = glossy_mask(&g);
        let n_glossy = mask.iter().filter(|&&m| m).count();
        if n_glossy == 0 {
            let _ = writeln!(md, "- `{label}`: no glossy pixels in view, skipped");
            continue;
        }
        let direct = crate::render::direct_image(&shader, &g, pool);
        let truth_t = timed(|| {
            crate::render::reference_masked(&shader, &g, sizes.truth_samples, &mask, pool)
        });
        let half = crate::render::reference_masked(
            &shader,
            &g,
            (sizes.truth_samples / 2).max(1),
            &mask,
            pool,
        );
        let truth_final = composite(&g, &direct, &truth_t.value);
        let half_final = composite(&g, &direct, &half);
        let noise = compare(&truth_final, &half_final, &mask);
        // The difference of independent estimates at N and N/2 samples has
        // variance 3 sigma_N^2: the N-sample noise is about MAD / sqrt(3).
        let _ = writeln!(
            md,
            "- `{label}`: {n_glossy} glossy pixels; converged reference {} spp ({:.0} ms); its difference to \
             {} spp: MAD {:.3}/255, PSNR {:.1} dB, so its own noise is about {:.3}/255",
            sizes.truth_samples,
            truth_t.ms,
            sizes.truth_samples / 2,
            noise.mean_abs,
            noise.psnr,
            noise.mean_abs / 3f64.sqrt()
        );
        crate::render::save_png(
            &images.join(format!("{label}_reference.png")),
            g.width(),
            g.height(),
            &truth_final,
        )
        .map_err(|e| e.to_string())?;

        // Glossy pixels whose mirror ray's true hit is visible in the depth
        // buffer: what screen space can answer at all (the rest is bias of
        // every screen-space method, reported separately).
        let rays = reflection_rays(scene, tracer, &shader, &g, pool);
        let mut visible = vec![false; g.len()];
        for k in 0..rays.len() {
            let i = rays.pixel[k] as usize;
            visible[i] = mask[i] && rays.visible[k];
        }
        let n_visible = visible.iter().filter(|&&v| v).count();
        let _ = writeln!(
            md,
            "  - {n_visible} of them ({:.1}%) have a mirror ray whose true hit is visible on screen",
            100.0 * n_visible as f64 / n_glossy as f64
        );
        let visible_err = |fin: &[Vec3]| compare(&truth_final, fin, &visible).mean_abs;
        let mut ref_points = Vec::new();
        for &spp in reference_counts(sizes.quick) {
            let (img, ms) = median_ms(sizes.runs, || {
                timed(|| crate::render::reference_masked(&shader, &g, spp, &mask, pool))
            });
            let fin = composite(&g, &direct, &img);
            let err = compare(&truth_final, &fin, &mask);
            ref_points.push((err.mean_abs, ms));
            rows.push(row(
                &label,
                "reference",
                &format!("glossy_spp={spp}"),
                threads,
                ms,
                truth_t.ms,
                1.0,
                &err,
                vec![
                    ("glossy_pixels".into(), n_glossy.to_string()),
                    (
                        "mean_abs_255_visible".into(),
                        format!("{:.4}", visible_err(&fin)),
                    ),
                ],
            ));
        }

        // (method name, (method, setting), unfiltered fallback)
        let mut settings = Vec::new();
        if methods.0 {
            let cones = cone_settings(sizes.quick);
            let best = if sizes.quick {
                "circles=16;normalize"
            } else {
                "circles=8;normalize;visibility=off"
            };
            let unfiltered = cones
                .iter()
                .find(|(_, s)| s == best)
                .map(|(m, s)| (*m, format!("{s};fallback=unfiltered")));
            // The unfiltered row right after its probe row (same cache and
            // load conditions for the timing).
            for s in cones {
                let is_best = s.1 == best;
                settings.push(("cone", s, false));
                if is_best {
                    settings.extend(unfiltered.clone().map(|s| ("cone", s, true)));
                }
            }
        }
        if methods.1 {
            settings.extend(
                multiray_settings(sizes.quick)
                    .into_iter()
                    .map(|s| ("multiray", s, false)),
            );
        }
        if settings.is_empty() {
            continue;
        }
        let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY)
            .map_err(|e| e.to_string())?;
        let image = depth.image().map_err(|e| e.to_string())?;
        let mut buffers = GlossyBuffers::new(g.width(), g.height()).map_err(|e| e.to_string())?;
        // The reference time on the same pixels: the converged one, scaled
        // per sample (reported as the reference_ms of every row).
        let truth_ms = truth_t.ms;
        for (name, (method, setting), unfiltered) in settings {
            // The unfiltered rows (and roughness 0, not a glossy pixel) take
            // the analytic environment.
            let fallback = |d: Vec3, r: f32| {
                if unfiltered || !(r > 0.0) {
                    env_map(d)
                } else {
                    probe.sample(d, r)
                }
            };
            let mut times = Vec::new();
            let mut first = None;
            for _ in 0..sizes.runs.max(1) {
                let t = run(
                    method,
                    &g,
                    &direct,
                    &image,
                    &mask,
                    fallback,
                    &mut buffers,
                    pool,
                )
                .map_err(|e| format!("{label} {name} {setting}: {e}"))?;
                times.push(t.ms);
                first.get_or_insert(t.value);
            }
            let ms = crate::render::median(times);
            let (img, stats) = first.ok_or("no run")?;
            let fin = composite(&g, &direct, &img);
            let err = compare(&truth_final, &fin, &mask);
            let eq = reference_ms_at_error(&ref_points, err.mean_abs);
            let mut extra = vec![
                ("glossy_pixels".into(), n_glossy.to_string()),
                (
                    "mean_abs_255_visible".into(),
                    format!("{:.4}", visible_err(&fin)),
                ),
                (
                    "bytes_per_pixel".into(),
                    format!("{:.2}", method.bytes_per_pixel(g.width(), g.height())),
                ),
                (
                    "ref_ms_at_equal_error".into(),
                    eq.map_or("-".into(), |t| format!("{t:.2}")),
                ),
                (
                    "speedup_at_equal_error".into(),
                    eq.map_or("-".into(), |t| format!("{:.2}", t / ms)),
                ),
            ];
            match method {
                GlossyMethod::Cone { .. } => {
                    extra.push((
                        "axis_hit_share".into(),
                        format!("{:.4}", stats.hits as f64 / stats.pixels.max(1) as f64),
                    ));
                    extra.push((
                        "mean_coverage".into(),
                        format!("{:.4}", stats.coverage_sum / stats.hits.max(1) as f64),
                    ));
                    extra.push((
                        "circles_per_hit".into(),
                        format!("{:.2}", stats.work as f64 / stats.hits.max(1) as f64),
                    ));
                }
                GlossyMethod::MultiRay { .. } => {
                    extra.push((
                        "ray_hit_share".into(),
                        format!("{:.4}", stats.hits as f64 / stats.coverage_sum.max(1.0)),
                    ));
                }
            }
            rows.push(row(
                &label, name, &setting, threads, ms, truth_ms, 1.0, &err, extra,
            ));
            let stem = format!(
                "{label}_{name}_{}",
                setting.replace(['=', ';', '/', '+'], "-")
            );
            crate::render::save_png(
                &images.join(format!("{stem}.png")),
                g.width(),
                g.height(),
                &fin,
            )
            .map_err(|e| e.to_string())?;
            let diff: Vec<Vec3> = (0..fin.len())
                .map(|i| {
                    if mask[i] {
                        ((truth_final[i] - fin[i]).abs() * 8.0).min(Vec3::ONE)
                    } else {
                        Vec3::ZERO
                    }
                })
                .collect();
            crate::render::save_png(
                &images.join(format!("{stem}_diff.png")),
                g.width(),
                g.height(),
                &diff,
            )
            .map_err(|e| e.to_string())?;
        }
    }
    md.push_str(
        "\n`speedup_at_equal_error`: the reference's time at the cone's (or multi-ray's) error, interpolated \
         in log-log between the `reference` rows (extrapolated with time ~ error^-2), over the method's time. \
         Images: `<variant>_reference.png`, `<variant>_<method>_<setting>.png` and `_diff.png` (8x).\n",
    );
    Ok((rows, md))
}
