//! The glossy study (seed 004 cone tracing, seed 003 Sec. 3.5 multi-ray):
//! the report side of [`crate::cone`]. Per variant of a scene made glossy
//! ([`Glossiness`]), the converged Monte-Carlo reference, the `reference`
//! rows at low sample counts and the `cone` and `multiray` rows, all on the
//! glossy pixels.

use super::Level;
use crate::cone::{glossy_mask, run, Glossiness, GlossyBuffers, GlossyMethod, VARIANTS};
use crate::gbuffer::GBuffer;
use crate::probe::{PrefilteredEnv, ProbeSizes};
use crate::render::{compare, composite, timed, ImageError, Timed};
use crate::report_out::Row;
use crate::scene::Scene;
use crate::screen::{reflection_rays, DepthBuffer};
use crate::shade::{env_map, Shader};
use crate::tracer::Tracer;
use glam::Vec3;
use refl_core::cone::{ConeOptions, Fades};
use refl_core::DepthConvention;
use std::fmt::Write as _;
use std::path::Path;

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
    /// Quick: fewer settings and samples, one variant; default: every
    /// setting, one variant, two reference counts; long: everything.
    pub level: Level,
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

/// The multi-ray settings of the study (seed 003 Sec. 3.5: 8 to 49; quick:
/// 8, default: 8 and 16).
pub fn multiray_settings(level: Level) -> Vec<(GlossyMethod, String)> {
    let counts: &[u32] = match level {
        Level::Quick => &[8],
        Level::Default => &[8, 16],
        Level::Long => &[8, 16, 49],
    };
    counts
        .iter()
        .map(|&n| (GlossyMethod::MultiRay { rays: n }, format!("rays={n}")))
        .collect()
}

/// The reference sample counts of the study's `reference` rows.
pub fn reference_counts(level: Level) -> &'static [u32] {
    match level {
        Level::Quick => &[8],
        Level::Default => &[8, 32],
        Level::Long => &[8, 32, 64],
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

/// What the study's rows of one scene share.
struct Study<'a> {
    scene: &'a Scene,
    tracer: &'a Tracer,
    shader: Shader<'a>,
    sizes: StudySizes,
    threads: usize,
    pool: &'a rayon::ThreadPool,
    images: &'a Path,
    /// The cone's fallback: the environment pre-filtered per roughness.
    probe: PrefilteredEnv,
}

/// One variant of the scene made glossy, with its converged reference.
struct Variant {
    label: String,
    g: GBuffer,
    /// The glossy pixels (where every row's error is measured).
    mask: Vec<bool>,
    n_glossy: usize,
    direct: Vec<Vec3>,
    truth_final: Vec<Vec3>,
    truth_ms: f64,
    /// Glossy pixels whose mirror ray's true hit is visible on screen.
    visible: Vec<bool>,
    /// (error, time) of the `reference` rows, for the equal-error time.
    ref_points: Vec<(f64, f64)>,
}

/// A row of the study: method name, method, setting label, and whether the
/// fallback is the unfiltered environment.
type StudySetting = (&'static str, GlossyMethod, String, bool);

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
    let camera = scene
        .camera(0, sizes.width, sizes.height)
        .map_err(|e| format!("glossy study: camera: {e}"))?;
    let variants: &[Glossiness] = if sizes.level == Level::Long {
        &VARIANTS
    } else {
        &VARIANTS[..1]
    };
    // The cone's fallback: the environment pre-filtered per roughness, built
    // once per scene outside the timed passes (an engine prefilters its
    // probes at load).
    let probe_sizes = if sizes.level == Level::Quick {
        ProbeSizes::QUICK
    } else {
        ProbeSizes::DEFAULT
    };
    let probe_t = timed(|| pool.install(|| PrefilteredEnv::build(env_map, probe_sizes)));
    let study = Study {
        scene,
        tracer,
        shader: Shader::new(scene, tracer),
        sizes,
        threads,
        pool,
        images,
        probe: probe_t.value,
    };
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
    let probe = &study.probe;
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
        probe_t.ms
    );
    let settings = study_settings(sizes.level, methods);
    let mut rows = Vec::new();
    for glossiness in variants {
        let Some(v) = study.variant(&camera, glossiness, &mut rows, &mut md)? else {
            continue;
        };
        if settings.is_empty() {
            continue;
        }
        let depth = DepthBuffer::new(&v.g, DepthConvention::ReversedZ, f32::INFINITY)
            .map_err(|e| e.to_string())?;
        let image = depth.image().map_err(|e| e.to_string())?;
        let mut buffers =
            GlossyBuffers::new(v.g.width(), v.g.height()).map_err(|e| e.to_string())?;
        for setting in &settings {
            rows.push(study.setting_row(&v, &image, &mut buffers, setting)?);
        }
    }
    md.push_str(
        "\n`speedup_at_equal_error`: the reference's time at the cone's (or multi-ray's) error, interpolated \
         in log-log between the `reference` rows (extrapolated with time ~ error^-2), over the method's time. \
         Images: `<variant>_reference.png`, `<variant>_<method>_<setting>.png` and `_diff.png` (8x).\n",
    );
    Ok((rows, md))
}

/// The study's cone and multi-ray rows (`methods`: cone, multi-ray), the
/// best cone setting followed by the same with the unfiltered fallback
/// (same cache and load conditions for the timing).
fn study_settings(level: Level, methods: (bool, bool)) -> Vec<StudySetting> {
    let quick = level == Level::Quick;
    let mut settings = Vec::new();
    if methods.0 {
        let best = if quick {
            "circles=16;normalize"
        } else {
            "circles=8;normalize;visibility=off"
        };
        for (m, s) in cone_settings(quick) {
            let is_best = s == best;
            if is_best {
                settings.push(("cone", m, s.clone(), false));
                settings.push(("cone", m, format!("{s};fallback=unfiltered"), true));
            } else {
                settings.push(("cone", m, s, false));
            }
        }
    }
    if methods.1 {
        settings.extend(
            multiray_settings(level)
                .into_iter()
                .map(|(m, s)| ("multiray", m, s, false)),
        );
    }
    settings
}

impl Study<'_> {
    /// Renders variant `glossiness` at `camera`, its converged reference and
    /// the `reference` rows (pushed to `rows`, notes to `md`); `None` when
    /// it has no glossy pixels in view.
    fn variant(
        &self,
        camera: &refl_core::Camera,
        glossiness: &Glossiness,
        rows: &mut Vec<Row>,
        md: &mut String,
    ) -> Result<Option<Variant>, String> {
        let (scene, shader, pool, sizes) = (self.scene, &self.shader, self.pool, &self.sizes);
        let label = glossiness.label(&scene.name);
        let mut g = GBuffer::render(scene, self.tracer, camera, pool);
        let bounds = scene.bounds();
        glossiness.apply(&mut g, (bounds.min.x, bounds.max.x));
        let mask = glossy_mask(&g);
        let n_glossy = mask.iter().filter(|&&m| m).count();
        if n_glossy == 0 {
            let _ = writeln!(md, "- `{label}`: no glossy pixels in view, skipped");
            return Ok(None);
        }
        let direct = crate::render::direct_image(shader, &g, pool);
        let truth_t =
            timed(|| crate::render::reference_masked(shader, &g, sizes.truth_samples, &mask, pool));
        let half = crate::render::reference_masked(
            shader,
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
        save(self.images, &format!("{label}_reference"), &g, &truth_final)?;

        // Glossy pixels whose mirror ray's true hit is visible in the depth
        // buffer: what screen space can answer at all (the rest is bias of
        // every screen-space method, reported separately).
        let rays = reflection_rays(scene, self.tracer, shader, &g, pool);
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
        let mut v = Variant {
            label,
            g,
            mask,
            n_glossy,
            direct,
            truth_final,
            truth_ms: truth_t.ms,
            visible,
            ref_points: Vec::new(),
        };
        for &spp in reference_counts(sizes.level) {
            let (img, ms) = median_ms(sizes.runs, || {
                timed(|| crate::render::reference_masked(shader, &v.g, spp, &v.mask, pool))
            });
            let fin = composite(&v.g, &v.direct, &img);
            let err = compare(&v.truth_final, &fin, &v.mask);
            v.ref_points.push((err.mean_abs, ms));
            rows.push(row(
                &v.label,
                "reference",
                &format!("glossy_spp={spp}"),
                self.threads,
                ms,
                v.truth_ms,
                1.0,
                &err,
                vec![
                    ("glossy_pixels".into(), v.n_glossy.to_string()),
                    (
                        "mean_abs_255_visible".into(),
                        format!("{:.4}", v.visible_err(&fin)),
                    ),
                ],
            ));
        }
        Ok(Some(v))
    }

    /// Times one cone or multi-ray setting on variant `v` (median of the
    /// runs), saves its image and difference, and returns its row. The
    /// reference time of the row is the converged reference's.
    fn setting_row(
        &self,
        v: &Variant,
        image: &refl_core::DepthImage<'_>,
        buffers: &mut GlossyBuffers,
        (name, method, setting, unfiltered): &StudySetting,
    ) -> Result<Row, String> {
        let (g, method, unfiltered) = (&v.g, *method, *unfiltered);
        // The unfiltered rows (and roughness 0, not a glossy pixel) take the
        // analytic environment.
        let fallback = |d: Vec3, r: f32| {
            if unfiltered || !(r > 0.0) {
                env_map(d)
            } else {
                self.probe.sample(d, r)
            }
        };
        let mut times = Vec::new();
        let mut first = None;
        for _ in 0..self.sizes.runs.max(1) {
            let t = run(
                method, g, &v.direct, image, &v.mask, fallback, buffers, self.pool,
            )
            .map_err(|e| format!("{} {name} {setting}: {e}", v.label))?;
            times.push(t.ms);
            first.get_or_insert(t.value);
        }
        let ms = crate::render::median(times);
        let (img, stats) = first.ok_or("no run")?;
        let fin = composite(g, &v.direct, &img);
        let err = compare(&v.truth_final, &fin, &v.mask);
        let eq = reference_ms_at_error(&v.ref_points, err.mean_abs);
        let mut extra = vec![
            ("glossy_pixels".into(), v.n_glossy.to_string()),
            (
                "mean_abs_255_visible".into(),
                format!("{:.4}", v.visible_err(&fin)),
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
        let stem = format!(
            "{}_{name}_{}",
            v.label,
            setting.replace(['=', ';', '/', '+'], "-")
        );
        save(self.images, &stem, g, &fin)?;
        let diff: Vec<Vec3> = (0..fin.len())
            .map(|i| {
                if v.mask[i] {
                    ((v.truth_final[i] - fin[i]).abs() * 8.0).min(Vec3::ONE)
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        save(self.images, &format!("{stem}_diff"), g, &diff)?;
        Ok(row(
            &v.label,
            name,
            setting,
            self.threads,
            ms,
            v.truth_ms,
            1.0,
            &err,
            extra,
        ))
    }
}

impl Variant {
    /// The error of final image `fin` on the glossy pixels whose true hit is
    /// visible on screen.
    fn visible_err(&self, fin: &[Vec3]) -> f64 {
        compare(&self.truth_final, fin, &self.visible).mean_abs
    }
}

/// Saves `rgb` (the size of `g`) as `images/{stem}.png`.
fn save(images: &Path, stem: &str, g: &GBuffer, rgb: &[Vec3]) -> Result<(), String> {
    let path = images.join(format!("{stem}.png"));
    crate::render::save_png(&path, g.width(), g.height(), rgb)
        .map_err(|e| format!("{}: {e}", path.display()))
}
