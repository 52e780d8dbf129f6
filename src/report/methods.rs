//! The per-frame methods of the report: each one implementation of
//! [`Method`], whose settings are [`Setting`]s that render one frame.
//!
//! A method says which settings it runs on a scene from the scene's
//! [`Content`] (or why it cannot run there); a setting renders one frame's
//! reflections through the method's renderer and hands back the image, the
//! pass time and its own columns. Everything else (the reference on the
//! same pixels, the error, the images, the pooling over frames) is the
//! report loop's, the same for every method.

use super::accum::{ClusterAccum, Extra, LayeredLookups, ScreenAccum};
use super::content::Content;
use super::{Level, Sizes};
use crate::gbuffer::GBuffer;
use crate::layered_render::{LayeredFrame, LayeredScene, LayeredShading};
use crate::render::{self, median, timed, ReflectionImage, Timed};
use crate::scene::Scene;
use crate::screen::{self, RayStats, ScreenFrame, ScreenMethod};
use crate::shade::Shader;
use crate::tracer::Tracer;
use glam::Vec3;
use refl_core::hiz::HiZOptions;
use refl_core::{DepthConvention, StepOptions};
use std::fmt::Write as _;
use std::path::Path;

/// One frame as the methods see it: the scene, its tracer and shader, the
/// G-buffer of one camera pose and its direct light, the pools, and the
/// state a method keeps across settings and frames of one scene.
pub struct Frame<'a> {
    /// Scene label (file names, messages).
    pub label: &'a str,
    /// The scene.
    pub scene: &'a Scene,
    /// Its tracer.
    pub tracer: &'a Tracer,
    /// Its shader.
    pub shader: &'a Shader<'a>,
    /// The frame's G-buffer.
    pub g: &'a GBuffer,
    /// The frame's direct light.
    pub direct: &'a [Vec3],
    /// Frame number within the scene (images are saved for frame 0).
    pub index: usize,
    /// Sizes of the run (timed repetitions).
    pub sizes: &'a Sizes,
    /// Every timed pass's pool.
    pub pool: &'a rayon::ThreadPool,
    /// A one-thread pool (per-ray costs).
    pub pool_1t: &'a rayon::ThreadPool,
    /// The images folder.
    pub images: &'a Path,
    /// Scene notes of `summary.md`.
    pub notes: &'a mut String,
    /// Layered maps built for this scene, per (face resolution, layers):
    /// the reflected objects are static, so the maps are built once.
    pub layered_maps: &'a mut Vec<((u32, u32), LayeredScene)>,
    /// Reflection rays, reference hits and obvhs timings of this frame,
    /// made when the first screen-space setting runs.
    screen: Option<ScreenFrame>,
    /// What the `planned` settings of this frame share.
    pub(super) planned: super::planned::Cache,
}

impl<'a> Frame<'a> {
    /// A frame with no screen-space state yet.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        label: &'a str,
        scene: &'a Scene,
        tracer: &'a Tracer,
        shader: &'a Shader<'a>,
        g: &'a GBuffer,
        direct: &'a [Vec3],
        index: usize,
        sizes: &'a Sizes,
        pools: (&'a rayon::ThreadPool, &'a rayon::ThreadPool),
        images: &'a Path,
        notes: &'a mut String,
        layered_maps: &'a mut Vec<((u32, u32), LayeredScene)>,
    ) -> Self {
        Frame {
            label,
            scene,
            tracer,
            shader,
            g,
            direct,
            index,
            sizes,
            pool: pools.0,
            pool_1t: pools.1,
            images,
            notes,
            layered_maps,
            screen: None,
            planned: super::planned::Cache::default(),
        }
    }

    /// The frame's reflection rays and reference timings, made on first use.
    pub(super) fn screen(&mut self) -> &mut ScreenFrame {
        let (scene, tracer, shader, g, direct) =
            (self.scene, self.tracer, self.shader, self.g, self.direct);
        let (pool, pool_1t, runs) = (self.pool, self.pool_1t, self.sizes.runs);
        self.screen.get_or_insert_with(|| {
            ScreenFrame::new(scene, tracer, shader, g, direct, pool, pool_1t, runs)
        })
    }

    /// Saves `rgb` as `images/{label}_{suffix}.png`.
    pub fn save(&self, suffix: &str, rgb: &[Vec3]) -> Result<(), String> {
        save(
            &self.images.join(format!("{}_{suffix}.png", self.label)),
            self.g,
            rgb,
        )
    }
}

/// What one setting rendered on one frame.
pub struct FrameRun {
    /// The reflection image (the pixels it handles).
    pub image: ReflectionImage,
    /// Time of the reflection pass, ms (median of the timed runs).
    pub ms: f64,
    /// The method's own figures, pooled over frames into its columns.
    pub extra: Extra,
}

/// One setting of a method, ready to render a frame.
pub trait Setting {
    /// The setting's label (the `setting` column; file names).
    fn label(&self) -> &str;
    /// Renders `frame`'s reflections at this setting.
    ///
    /// # Errors
    /// A message naming the scene and what failed.
    fn run(&self, frame: &mut Frame<'_>) -> Result<FrameRun, String>;
}

/// A per-frame method of the report.
pub trait Method {
    /// The method's name (`--method`, the `method` column).
    fn name(&self) -> &'static str;
    /// The settings run on a scene with `content` at `sizes`, or why the
    /// method cannot run on it (written to `summary.md`).
    ///
    /// # Errors
    /// The reason the scene's content rules the method out.
    fn settings(&self, sizes: &Sizes, content: &Content) -> Result<Vec<Box<dyn Setting>>, String>;
}

/// Every per-frame method, in report order.
pub fn all() -> Vec<Box<dyn Method>> {
    vec![
        Box::new(Reference),
        Box::new(EnvMap),
        Box::new(PlanarMirror),
        Box::new(Step),
        Box::new(HiZ),
        Box::new(Layered),
        Box::new(Cluster),
        Box::new(super::planned::PlannedMethod),
    ]
}

/// Runs `f` `runs` times (at least once) and returns its first result and
/// the median time.
pub fn median_run<T, E>(
    runs: usize,
    mut f: impl FnMut() -> Result<Timed<T>, E>,
) -> Result<(T, f64), E> {
    let mut first = None;
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs.max(1) {
        let t = f()?;
        times.push(t.ms);
        first.get_or_insert(t.value);
    }
    Ok((first.expect("runs >= 1"), median(times)))
}

/// Saves `rgb` (the size of `g`) as a PNG at `path`.
pub fn save(path: &Path, g: &GBuffer, rgb: &[Vec3]) -> Result<(), String> {
    render::save_png(path, g.width(), g.height(), rgb)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The skip reason of a method that needs reflective pixels.
fn need_reflective(content: &Content) -> Result<(), String> {
    if content.reflective_pixels == 0 {
        Err("no reflective pixels in view".into())
    } else {
        Ok(())
    }
}

// ------------------------------------------------ image methods (render.rs)

/// A setting of one of [`render::Method`]'s renderers.
struct ImageSetting {
    method: render::Method,
    label: String,
}

impl Setting for ImageSetting {
    fn label(&self) -> &str {
        &self.label
    }

    fn run(&self, f: &mut Frame<'_>) -> Result<FrameRun, String> {
        let (image, ms) = median_run(f.sizes.runs, || self.method.run(f.shader, f.g, f.pool))
            .map_err(|e| format!("{}: {}: {e}", f.label, self.method.name()))?;
        Ok(FrameRun {
            image,
            ms,
            extra: Extra::None,
        })
    }
}

fn image_settings(v: impl IntoIterator<Item = (render::Method, String)>) -> Vec<Box<dyn Setting>> {
    v.into_iter()
        .map(|(method, label)| Box::new(ImageSetting { method, label }) as Box<dyn Setting>)
        .collect()
}

/// The ray-traced reference (obvhs) at several glossy sample counts.
struct Reference;

impl Method for Reference {
    fn name(&self) -> &'static str {
        "reference"
    }

    fn settings(&self, sizes: &Sizes, content: &Content) -> Result<Vec<Box<dyn Setting>>, String> {
        // Mirror pixels trace one ray whatever the sample count: without
        // glossy pixels one row says all there is.
        Ok(if content.glossy_pixels == 0 {
            image_settings([(
                render::Method::Reference { samples: 1 },
                "mirror_rays".into(),
            )])
        } else {
            image_settings(sizes.reference_samples.iter().map(|&s| {
                (
                    render::Method::Reference { samples: s },
                    format!("glossy_spp={s}"),
                )
            }))
        })
    }
}

/// The analytic environment in the reflected direction (no visibility).
struct EnvMap;

impl Method for EnvMap {
    fn name(&self) -> &'static str {
        "envmap"
    }

    fn settings(&self, _: &Sizes, _: &Content) -> Result<Vec<Box<dyn Setting>>, String> {
        Ok(image_settings([(
            render::Method::EnvMap,
            "analytic".into(),
        )]))
    }
}

/// Planar mirrors rendered through the mirrored camera.
struct PlanarMirror;

impl Method for PlanarMirror {
    fn name(&self) -> &'static str {
        "planar-mirror"
    }

    fn settings(&self, _: &Sizes, content: &Content) -> Result<Vec<Box<dyn Setting>>, String> {
        if content.planar_mirror_pixels == 0 {
            return Err("no planar mirror in view".into());
        }
        Ok(image_settings([1, 2, 4].into_iter().map(|scale| {
            (
                render::Method::PlanarMirror { scale },
                format!("resolution=1/{scale}"),
            )
        })))
    }
}

// ------------------------------------------- screen-space kernels (screen.rs)

/// A screen-space kernel traced against the primary view's depth buffer in
/// a depth convention, with or without the refinement.
struct ScreenSetting {
    kernel: ScreenMethod,
    convention: DepthConvention,
    refine: bool,
    label: String,
}

fn convention_name(c: DepthConvention) -> &'static str {
    match c {
        DepthConvention::Linear => "linear",
        DepthConvention::ZeroToOne => "zero-to-one",
        DepthConvention::ReversedZ => "reversed-z-inf",
    }
}

impl ScreenSetting {
    fn boxed(
        kernel: ScreenMethod,
        convention: DepthConvention,
        refine: bool,
        label: String,
    ) -> Box<dyn Setting> {
        Box::new(ScreenSetting {
            kernel,
            convention,
            refine,
            label,
        })
    }
}

impl Setting for ScreenSetting {
    fn label(&self) -> &str {
        &self.label
    }

    fn run(&self, f: &mut Frame<'_>) -> Result<FrameRun, String> {
        let (g, pool, pool_1t, runs, runs_1t) =
            (f.g, f.pool, f.pool_1t, f.sizes.runs, f.sizes.runs_1t);
        let (kernel, refine) = (self.kernel, self.refine);
        let sf = f.screen();
        sf.prepare_depth(g, self.convention)
            .map_err(|e| e.to_string())?;
        let sf = &*sf;
        let depth = sf.depth(self.convention).ok_or("depth buffer")?;
        let image = depth.image().map_err(|e| e.to_string())?;
        let (out, ms) = median_run(runs, || {
            screen::run(kernel, refine, &image, &sf.images, pool)
        })
        .map_err(|e| e.to_string())?;
        let (_, ms_1t) = median_run(runs_1t, || {
            screen::run(kernel, refine, &image, &sf.images, pool_1t)
        })
        .map_err(|e| e.to_string())?;
        let (fetches, steps, iterations) =
            screen::kernel_work(kernel, &image, &sf.images, &sf.rays, pool)
                .map_err(|e| e.to_string())?;
        let stats = RayStats {
            fetches,
            steps,
            iterations,
            ..screen::evaluate(&sf.rays, &out.texels)
        };
        Ok(FrameRun {
            image: screen::shade(g, &out),
            ms,
            extra: Extra::Screen(ScreenAccum {
                stats,
                kernel_ms: ms,
                kernel_ms_1t: ms_1t,
                obvhs_ms: sf.obvhs_ms,
                obvhs_ms_1t: sf.obvhs_ms_1t,
                bytes_per_pixel: kernel.bytes_per_pixel(g.width(), g.height()),
                layered: false,
                layered_lookups: None,
            }),
        })
    }
}

/// Linear stepping (seed 003 Sec. 3.4) at several strides and caps;
/// `--long` also traces linear and `[0, 1]` depth (their rows equal
/// reversed-Z's up to rounding: `core/tests/hiz.rs` and `core/tests/ssr.rs`
/// trace every convention against one oracle).
struct Step;

impl Method for Step {
    fn name(&self) -> &'static str {
        "step"
    }

    fn settings(&self, sizes: &Sizes, content: &Content) -> Result<Vec<Box<dyn Setting>>, String> {
        need_reflective(content)?;
        let rz = DepthConvention::ReversedZ;
        let mut out = Vec::new();
        // Stride 16 with `--long` only (default-run time; its rows were
        // within a few percent of stride 4's in error and time).
        let strides: &[(u32, u32)] = if sizes.level == Level::Long {
            &[(1, u32::MAX), (4, u32::MAX), (16, u32::MAX), (1, 64)]
        } else {
            &[(1, u32::MAX), (4, u32::MAX), (1, 64)]
        };
        for &(stride, max_steps) in strides {
            let cap = if max_steps == u32::MAX {
                String::new()
            } else {
                format!(";max_steps={max_steps}")
            };
            out.push(ScreenSetting::boxed(
                ScreenMethod::Step(StepOptions { stride, max_steps }),
                rz,
                true,
                format!("stride={stride}{cap}"),
            ));
        }
        let base = ScreenMethod::Step(StepOptions::default());
        out.push(ScreenSetting::boxed(
            base,
            rz,
            false,
            "stride=1;refine=off".into(),
        ));
        if sizes.level == Level::Long {
            for c in [DepthConvention::Linear, DepthConvention::ZeroToOne] {
                out.push(ScreenSetting::boxed(
                    base,
                    c,
                    true,
                    format!("stride=1;depth={}", convention_name(c)),
                ));
            }
        }
        Ok(out)
    }
}

/// Hi-Z traversal (seed 004) at several start, stop, prologue and
/// iteration settings, and at the default setting one ray per 2x2 block
/// with the reconstructions of [`super::half`]; `--long` also traces
/// linear and `[0, 1]` depth.
struct HiZ;

impl Method for HiZ {
    fn name(&self) -> &'static str {
        "hiz"
    }

    fn settings(&self, sizes: &Sizes, content: &Content) -> Result<Vec<Box<dyn Setting>>, String> {
        need_reflective(content)?;
        let rz = DepthConvention::ReversedZ;
        let label = |o: HiZOptions| {
            format!(
                "start={};stop={};prologue={};max_iter={}",
                o.start_level, o.stop_level, o.prologue_steps, o.max_iterations
            )
        };
        let base = HiZOptions::default();
        let mut variants = vec![
            base,
            HiZOptions {
                prologue_steps: 0,
                ..base
            },
            HiZOptions {
                start_level: 0,
                ..base
            },
            HiZOptions {
                stop_level: 2,
                ..base
            },
            HiZOptions {
                max_iterations: 48,
                ..base
            },
        ];
        // A prologue of 16 with `--long` only (default-run time).
        if sizes.level == Level::Long {
            variants.insert(
                2,
                HiZOptions {
                    prologue_steps: 16,
                    ..base
                },
            );
        }
        let mut out: Vec<Box<dyn Setting>> = variants
            .into_iter()
            .map(|o| ScreenSetting::boxed(ScreenMethod::HiZ(o), rz, true, label(o)))
            .collect();
        out.push(ScreenSetting::boxed(
            ScreenMethod::HiZ(base),
            rz,
            false,
            format!("{};refine=off", label(base)),
        ));
        if sizes.level == Level::Long {
            for c in [DepthConvention::Linear, DepthConvention::ZeroToOne] {
                out.push(ScreenSetting::boxed(
                    ScreenMethod::HiZ(base),
                    c,
                    true,
                    format!("{};depth={}", label(base), convention_name(c)),
                ));
            }
        }
        // Fewer rays (seed 004 Sec. 4.7.3-4.7.4): one ray per 2x2 block.
        out.extend(super::half::settings(sizes, ScreenMethod::HiZ(base)));
        // Extrapolation of surfaces (seed 004 Sec. 4.6.2).
        out.extend(super::extrapolate::settings(sizes, ScreenMethod::HiZ(base)));
        Ok(out)
    }
}

// ------------------------------------------ layered maps (layered_render.rs)

/// Layered depth cube maps of the reflected objects (seed 001).
struct Layered;

/// One face resolution and layer count of the layered maps.
struct LayeredSetting {
    face_res: u32,
    layers: u32,
    shading: crate::layered_render::LayeredShading,
    label: String,
}

impl Method for Layered {
    fn name(&self) -> &'static str {
        "layered"
    }

    fn settings(&self, sizes: &Sizes, content: &Content) -> Result<Vec<Box<dyn Setting>>, String> {
        if content.reflected_objects == 0 {
            return Err("no compact non-reflective object to map".into());
        }
        need_reflective(content)?;
        let res: &[u32] = if sizes.quick() {
            &[32, 64]
        } else {
            &[32, 64, 128]
        };
        let top = res[res.len() - 1];
        Ok(res
            .iter()
            .map(|&r| (r, 4))
            .chain(std::iter::once((top, 1)))
            // Layers per object by its depth complexity (seed 001 Table 1).
            .chain(std::iter::once((top, 0)))
            .map(|(face_res, layers)| (face_res, layers, LayeredShading::Texel))
            // Diagnostic: shaded from the primitive the texel names.
            .chain(std::iter::once((top, 4, LayeredShading::PrimitiveId)))
            .map(|(face_res, layers, shading)| {
                let l = if layers == 0 {
                    "auto".to_string()
                } else {
                    layers.to_string()
                };
                let diag = match shading {
                    LayeredShading::Texel => "",
                    LayeredShading::PrimitiveId => ";shade=primitive_id",
                };
                Box::new(LayeredSetting {
                    face_res,
                    layers,
                    shading,
                    label: format!("face_res={face_res};layers={l}{diag}"),
                }) as Box<dyn Setting>
            })
            .collect())
    }
}

impl Setting for LayeredSetting {
    fn label(&self) -> &str {
        &self.label
    }

    fn run(&self, f: &mut Frame<'_>) -> Result<FrameRun, String> {
        let (g, pool, pool_1t, runs, runs_1t) =
            (f.g, f.pool, f.pool_1t, f.sizes.runs, f.sizes.runs_1t);
        let key = (self.face_res, self.layers);
        if !f.layered_maps.iter().any(|(k, _)| *k == key) {
            let mut ls = LayeredScene::build(f.scene, self.face_res, self.layers, pool)
                .map_err(|e| format!("{}: layered maps: {e}", f.label))?;
            // The colors the texels store (seed 001), part of the build.
            let shade_start = std::time::Instant::now();
            ls.shade_samples(f.shader, pool);
            ls.build_ms += shade_start.elapsed().as_secs_f64() * 1e3;
            // The global environment (seed 001 Sec. 4.1) depends on the
            // scene only: built with the first maps, shared by the others.
            ls.surroundings = Some(match f.layered_maps.first() {
                Some((_, other)) if other.surroundings.is_some() => {
                    other.surroundings.clone().expect("checked")
                }
                _ => {
                    let env = crate::layered_render::Surroundings::build(f.shader, pool);
                    let _ = writeln!(
                        f.notes,
                        "  - layered surroundings (the global environment of rays leaving every map): \
                         256x128 table from ({:.2}, {:.2}, {:.2}), {:.1} ms build, {:.2} MiB",
                        env.center.x,
                        env.center.y,
                        env.center.z,
                        env.build_ms,
                        env.bytes() as f64 / (1024.0 * 1024.0)
                    );
                    std::sync::Arc::new(env)
                }
            });
            let _ = writeln!(
                f.notes,
                "  - layered maps {}: {} objects (layers {:?}), {:.1} ms build, {:.1} MiB",
                self.label,
                ls.objects.len(),
                ls.objects
                    .iter()
                    .map(|o| o.grid.layers())
                    .collect::<Vec<_>>(),
                ls.build_ms,
                ls.bytes() as f64 / (1024.0 * 1024.0)
            );
            f.layered_maps.push((key, ls));
        }
        let (scene, shader) = (f.scene, f.shader);
        let (obvhs_ms, obvhs_ms_1t) = {
            let sf = f.screen();
            (sf.obvhs_ms, sf.obvhs_ms_1t)
        };
        let sf = f.screen.as_ref().ok_or("screen frame")?;
        let ls = &f
            .layered_maps
            .iter()
            .find(|(k, _)| *k == key)
            .ok_or("layered maps")?
            .1;
        let params = refl_core::layered::LayeredOptions::default();
        let lf = LayeredFrame::new(g);
        let trace = |p: &rayon::ThreadPool| {
            let t = timed(|| ls.trace(g, &lf, &params, p));
            t.value.map(|v| Timed { value: v, ms: t.ms })
        };
        let (traces, ms) = median_run(runs, || trace(pool)).map_err(|e| e.to_string())?;
        let (_, ms_1t) = median_run(runs_1t, || trace(pool_1t)).map_err(|e| e.to_string())?;
        let ls_stats = crate::layered_render::evaluate(scene, ls, &sf.rays, &traces);
        let pixels = f64::from(g.width()) * f64::from(g.height());
        Ok(FrameRun {
            image: crate::layered_render::shade(
                shader,
                g,
                ls,
                &traces,
                self.shading,
                ls.surroundings.as_deref(),
            ),
            ms,
            extra: Extra::Screen(ScreenAccum {
                stats: RayStats {
                    rays: ls_stats.rays,
                    visible: ls_stats.to_objects,
                    found: ls_stats.agree,
                    false_hits: ls_stats.false_hits,
                    err_px_sum: ls_stats.err_texels_sum,
                    err_px_count: ls_stats.err_count,
                    fetches: ls_stats.fetches,
                    ..RayStats::default()
                },
                kernel_ms: ms,
                kernel_ms_1t: ms_1t,
                obvhs_ms,
                obvhs_ms_1t,
                bytes_per_pixel: ls.bytes() as f64 / pixels,
                layered: true,
                layered_lookups: Some(LayeredLookups {
                    traced: u64::from(traces.stats.traced),
                    without_prr: traces.stats.kernel_traces
                        + traces.stats.sphere_culled
                        + traces.stats.prr_skipped,
                    prr_skipped: traces.stats.prr_skipped,
                    mask_pairs: traces.prr.map_or(0, |p| p.pairs),
                    mask_set: traces.prr.map_or(0, |p| p.may_reflect),
                }),
            }),
        })
    }
}

// ------------------------------------------------- clusters (cluster.rs)

/// Seed 003's normal-bin clusters, cluster cameras and depth images.
struct Cluster;

/// One cluster-method setting.
struct ClusterSetting {
    settings: crate::cluster::ClusterSettings,
    label: String,
}

impl Method for Cluster {
    fn name(&self) -> &'static str {
        "cluster"
    }

    /// The cluster-count knob (bin gain, the error-vs-time points of seed
    /// 003 Table 3); on scenes with glossy pixels the default and long runs
    /// `--long` adds rays that follow the glossiness (Sec. 3.5 item 3) and
    /// the glossy far plane with its fade (item 2), two settings each; it
    /// also adds the depth-image resolution (Table 5) and
    /// 49 glossy rays (Sec. 3.5's upper end). Every run has the concave
    /// clusters' second intersection (Sec. 4.4) and, with glossy pixels,
    /// the single-ray glossy variant (Sec. 4.2.2) at the base gain.
    fn settings(&self, sizes: &Sizes, content: &Content) -> Result<Vec<Box<dyn Setting>>, String> {
        use crate::cluster::ClusterSettings;
        need_reflective(content)?;
        let base = ClusterSettings::default();
        // Seed 003 Sec. 4.4's second way for concave clusters, and Sec.
        // 4.2.2's single-ray glossy variant where there are glossy pixels:
        // one row each at the base gain, in every run.
        let mut variants = vec![ClusterSettings {
            second_intersection: true,
            ..base
        }];
        if content.glossy_pixels > 0 {
            variants.push(ClusterSettings {
                glossy_single_ray: true,
                ..base
            });
        }
        let v: Vec<ClusterSettings> = if sizes.quick() {
            let mut v = vec![ClusterSettings { gain: 16.0, ..base }, base];
            v.extend(variants);
            v
        } else {
            let mut v: Vec<ClusterSettings> = [1.0, 16.0, 64.0, 256.0]
                .into_iter()
                .map(|gain| ClusterSettings { gain, ..base })
                .collect();
            if content.glossy_pixels > 0 {
                // `--long` only (default-run time).
                let (sr, far): (&[f32], &[f32]) = if sizes.level == Level::Long {
                    (&[0.004, 0.001], &[0.01, 0.003])
                } else {
                    (&[], &[])
                };
                for &sr in sr {
                    v.push(ClusterSettings {
                        steradians_per_ray: Some(sr),
                        ..base
                    });
                }
                for &k in far {
                    v.push(ClusterSettings {
                        glossy_far: Some(k),
                        ..base
                    });
                }
            }
            v.extend(variants);
            if sizes.level != Level::Long {
                return Ok(boxed_cluster(v));
            }
            v.push(ClusterSettings {
                resolution_scale: 0.5,
                ..base
            });
            v.push(ClusterSettings {
                resolution_scale: 2.0,
                ..base
            });
            v.push(ClusterSettings {
                glossy_rays: 49,
                ..base
            });
            v
        };
        Ok(boxed_cluster(v))
    }
}

/// The cluster settings `v` (duplicates dropped) as [`Setting`]s.
fn boxed_cluster(mut v: Vec<crate::cluster::ClusterSettings>) -> Vec<Box<dyn Setting>> {
    v.dedup();
    v.into_iter()
        .map(|settings| {
            Box::new(ClusterSetting {
                label: settings.label(),
                settings,
            }) as Box<dyn Setting>
        })
        .collect()
}

impl Setting for ClusterSetting {
    fn label(&self) -> &str {
        &self.label
    }

    fn run(&self, f: &mut Frame<'_>) -> Result<FrameRun, String> {
        // The first run also marks disocclusions (ray traced, outside the
        // stage timers).
        let mut stage_runs = Vec::new();
        let mut first = None;
        for k in 0..f.sizes.runs.max(1) {
            let c = crate::cluster::run(f.shader, f.g, &self.settings, f.pool, k == 0)
                .map_err(|e| format!("{}: cluster: {e}", f.label))?;
            stage_runs.push(c.stages);
            first.get_or_insert(c);
        }
        let mut c = first.ok_or("cluster: no run")?;
        // The glossy fade's share of the surface's own color (the host's
        // lit image, outside the method's time).
        c.blend_remainder(f.direct);
        let stages = crate::cluster::StageMs::median_of(&stage_runs);
        let ms = median(stage_runs.iter().map(|s| s.total()).collect());
        if f.index == 0 {
            let stem = format!("cluster_{}", file_stem(&self.label));
            f.save(
                &format!("{stem}_clusters"),
                &crate::cluster::cluster_image(f.g, &c, false),
            )?;
            f.save(
                &format!("{stem}_disocclusion"),
                &crate::cluster::cluster_image(f.g, &c, true),
            )?;
        }
        let extra = Extra::Cluster(ClusterAccum::of(&c, stages));
        Ok(FrameRun {
            image: c.image,
            ms,
            extra,
        })
    }
}

/// A setting label as a file-name part (`=`, `;` and `/` become `-`).
pub fn file_stem(setting: &str) -> String {
    setting.replace(['=', ';', '/'], "-")
}
