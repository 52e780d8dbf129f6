//! `refl report`: every method at several settings on the built-in scenes,
//! as points of an error-vs-time curve measured against the ray-traced
//! reference (obvhs) in the same run, same threads.
//!
//! Per scene: build the BVH; for [`Sizes::frames`] poses spread over the
//! camera path, render the G-buffer, compute the ground truth (the reference
//! at [`Sizes::truth_samples`] glossy samples), then time each method's
//! reflection pass (median of [`Sizes::runs`]) and measure its error on the
//! pixels it handles. A row pools the frames: mean time per frame, errors
//! over all handled pixels of all frames. The
//! reference time of a row is the ground-truth pass restricted to the same
//! pixels (so a method that handles planar mirrors only is compared with
//! tracing those mirrors only).

use crate::render::{
    self, compare, composite, direct_image, ImageError, Method, ReflectionImage, Timed,
};
use crate::report_out::{self, Row};
use crate::scene::Scene;
use crate::screen::{self, RayStats, ScreenMethod};
use crate::shade::Shader;
use crate::tracer::Tracer;
use crate::{
    gbuffer::GBuffer,
    render::{median, timed},
};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use refl_core::hiz::HiZOptions;
use refl_core::{DepthConvention, StepOptions};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Command-line options of `refl report`.
#[derive(Clone, Debug, clap::Args)]
pub struct Options {
    /// Small sizes (about a minute on 2 cores); what the tests run.
    #[arg(long)]
    pub quick: bool,
    /// Scenes: `room`, `concave`, `walkthrough`, `stage`, or a path to an
    /// `.obj` file (repeatable; default: the four built-in scenes).
    #[arg(long)]
    pub scene: Vec<String>,
    /// Methods: `reference`, `envmap`, `planar-mirror`, `epipolar`, `orsa`,
    /// `irsa`, `step`, `hiz`, `layered`, `cluster`, `tcrr`, `naive-warp`,
    /// `cone`, `multiray` (repeatable; default: all).
    #[arg(long)]
    pub method: Vec<String>,
    /// Output folder.
    #[arg(long, default_value = "report")]
    pub out: PathBuf,
    /// Worker threads for every timed pass, method and reference alike
    /// (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Triangle budget of the built-in scenes (default: 150000, quick:
    /// 30000), for cost-growth curves.
    #[arg(long)]
    pub tris: Option<usize>,
    /// Cost growth: the room at these triangle counts (comma-separated;
    /// default run: 10000,100000,1000000, `--quick`: none); `0` skips it.
    #[arg(long, value_delimiter = ',')]
    pub growth: Vec<usize>,
    /// Reflective materials for an OBJ scene: `NAME:SPECULAR:ROUGHNESS`,
    /// matching object names containing NAME (repeatable).
    #[arg(long)]
    pub reflective: Vec<String>,
}

impl Default for Options {
    /// The default run: every built-in scene and method into `report/`.
    fn default() -> Self {
        Options {
            quick: false,
            scene: Vec::new(),
            method: Vec::new(),
            out: PathBuf::from("report"),
            threads: None,
            tris: None,
            growth: Vec::new(),
            reflective: Vec::new(),
        }
    }
}

/// Image size, scene size and sample counts of one report run.
#[derive(Clone, Copy, Debug)]
pub struct Sizes {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Triangle budget of the built-in scenes.
    pub tris: usize,
    /// Glossy samples per pixel of the ground truth.
    pub truth_samples: u32,
    /// Glossy sample counts of the `reference` rows.
    pub reference_samples: &'static [u32],
    /// Timed repetitions; the median is reported.
    pub runs: usize,
    /// Camera-path poses rendered per scene (spread over the path).
    pub frames: usize,
    /// `--quick`: fewer settings.
    pub quick: bool,
}

impl Sizes {
    /// The sizes for `--quick` or the default run.
    pub fn new(quick: bool) -> Self {
        if quick {
            Sizes {
                width: 256,
                height: 192,
                tris: 30_000,
                truth_samples: 64,
                reference_samples: &[4, 16],
                runs: 3,
                frames: 2,
                quick: true,
            }
        } else {
            Sizes {
                width: 512,
                height: 384,
                tris: 150_000,
                truth_samples: 512,
                reference_samples: &[4, 16, 64, 256],
                runs: 3,
                frames: 4,
                quick: false,
            }
        }
    }
}

/// The built-in scenes, in report order.
pub const BUILT_IN_SCENES: [&str; 4] = ["room", "concave", "walkthrough", "stage"];

/// Every method name the report knows, in report order.
pub const METHODS: [&str; 14] = [
    "reference",
    "envmap",
    "planar-mirror",
    // Primary visibility along the walkthrough path (seed 002), run once
    // per scene after its frames: see [`crate::epipolar`].
    "epipolar",
    "orsa",
    "irsa",
    "step",
    "hiz",
    "layered",
    // Seed 003: normal-bin clusters, cluster cameras and depth images.
    "cluster",
    "tcrr",
    "naive-warp",
    // Glossy screen-space methods (seed 004 cone tracing, seed 003 Sec. 3.5
    // multi-ray), run on the room's glossy variants after its frames: see
    // [`crate::cone`].
    "cone",
    "multiray",
];

/// What one frame's reflective pixels can use: the report skips the passes
/// a frame has no pixels for (design: "a pipeline that skips passes a scene
/// cannot use") and says so in `summary.md`.
#[derive(Clone, Copy, Debug)]
struct FrameNeeds {
    /// Reflective pixels with roughness > 0.
    glossy_pixels: usize,
    /// Pixels of planar perfect mirrors.
    planar_mirror_pixels: usize,
    /// Reflective pixels.
    reflective_pixels: usize,
    /// Objects the layered method maps (scene-wide).
    reflected_objects: usize,
}

impl FrameNeeds {
    fn of(scene: &Scene, g: &GBuffer) -> Self {
        let planar_mirror: Vec<bool> = scene
            .objects
            .iter()
            .map(|o| o.planar.is_some() && scene.materials[o.material as usize].is_mirror())
            .collect();
        let (mut glossy_pixels, mut planar_mirror_pixels, mut reflective_pixels) = (0, 0, 0);
        for i in 0..g.len() {
            if !g.is_reflective(i) {
                continue;
            }
            reflective_pixels += 1;
            glossy_pixels += usize::from(g.roughness[i] > 0.0);
            planar_mirror_pixels += usize::from(
                planar_mirror
                    .get(g.object[i] as usize)
                    .copied()
                    .unwrap_or(false),
            );
        }
        FrameNeeds {
            glossy_pixels,
            planar_mirror_pixels,
            reflective_pixels,
            reflected_objects: crate::layered_render::reflected_objects(scene).len(),
        }
    }
}

/// One setting of a method: an image method of [`render`], or a
/// screen-space kernel traced against the primary view's depth buffer in a
/// depth convention.
#[derive(Clone, Copy, Debug)]
enum Setting {
    Image(Method),
    Screen(ScreenMethod, DepthConvention, bool),
    /// Layered depth cube maps of the reflected objects: face resolution,
    /// layers.
    Layered(u32, u32),
    /// Seed 003's clusters (crate::cluster).
    Cluster(crate::cluster::ClusterSettings),
}

/// The cluster method's settings: the cluster-count knob (bin gain) and the
/// depth-image resolution, the error-vs-time points of seed 003 Tables 3
/// and 5, and 49 glossy rays (Sec. 3.5's upper end).
fn cluster_settings(sizes: &Sizes) -> Vec<(Setting, String)> {
    use crate::cluster::ClusterSettings;
    let base = ClusterSettings::default();
    let mut v: Vec<ClusterSettings> = if sizes.quick {
        vec![ClusterSettings { gain: 16.0, ..base }, base]
    } else {
        let mut v: Vec<ClusterSettings> = [1.0, 16.0, 64.0, 256.0]
            .into_iter()
            .map(|gain| ClusterSettings { gain, ..base })
            .collect();
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
    v.dedup();
    v.into_iter()
        .map(|c| (Setting::Cluster(c), c.label()))
        .collect()
}

/// The screen-space settings of `name` (`None` if `name` is not a
/// screen-space method). Reversed-Z with an infinite far plane is the
/// report's convention; stride 1 and the default Hi-Z also run on linear
/// and `[0, 1]` depth (finite far plane) in the default run.
fn screen_settings(name: &str, sizes: &Sizes) -> Option<Vec<(Setting, String)>> {
    let rz = DepthConvention::ReversedZ;
    let conv_name = |c: DepthConvention| match c {
        DepthConvention::Linear => "linear",
        DepthConvention::ZeroToOne => "zero-to-one",
        DepthConvention::ReversedZ => "reversed-z-inf",
    };
    let mut out = Vec::new();
    match name {
        "step" => {
            for (stride, max_steps) in [(1, u32::MAX), (4, u32::MAX), (16, u32::MAX), (1, 64)] {
                let opts = StepOptions { stride, max_steps };
                let cap = if max_steps == u32::MAX {
                    String::new()
                } else {
                    format!(";max_steps={max_steps}")
                };
                out.push((
                    Setting::Screen(ScreenMethod::Step(opts), rz, true),
                    format!("stride={stride}{cap}"),
                ));
            }
            out.push((
                Setting::Screen(ScreenMethod::Step(StepOptions::default()), rz, false),
                "stride=1;refine=off".into(),
            ));
            if !sizes.quick {
                for c in [DepthConvention::Linear, DepthConvention::ZeroToOne] {
                    out.push((
                        Setting::Screen(ScreenMethod::Step(StepOptions::default()), c, true),
                        format!("stride=1;depth={}", conv_name(c)),
                    ));
                }
            }
        }
        "hiz" => {
            let base = HiZOptions::default();
            let variants = [
                base,
                HiZOptions {
                    prologue_steps: 0,
                    ..base
                },
                HiZOptions {
                    prologue_steps: 16,
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
            for o in variants {
                out.push((
                    Setting::Screen(ScreenMethod::HiZ(o), rz, true),
                    format!(
                        "start={};stop={};prologue={};max_iter={}",
                        o.start_level, o.stop_level, o.prologue_steps, o.max_iterations
                    ),
                ));
            }
            out.push((
                Setting::Screen(ScreenMethod::HiZ(base), rz, false),
                format!(
                    "start={};stop={};prologue={};max_iter={};refine=off",
                    base.start_level, base.stop_level, base.prologue_steps, base.max_iterations
                ),
            ));
            if !sizes.quick {
                for c in [DepthConvention::Linear, DepthConvention::ZeroToOne] {
                    out.push((
                        Setting::Screen(ScreenMethod::HiZ(base), c, true),
                        format!(
                            "start={};stop={};prologue={};max_iter={};depth={}",
                            base.start_level,
                            base.stop_level,
                            base.prologue_steps,
                            base.max_iterations,
                            conv_name(c)
                        ),
                    ));
                }
            }
        }
        _ => return None,
    }
    Some(out)
}

/// The methods and settings run for method `name` on a frame, or why the
/// frame cannot use the method.
fn settings(
    name: &str,
    sizes: &Sizes,
    needs: FrameNeeds,
) -> Result<Vec<(Setting, String)>, &'static str> {
    if name == "layered" {
        return if needs.reflected_objects == 0 {
            Err("no compact non-reflective object to map")
        } else if needs.reflective_pixels == 0 {
            Err("no reflective pixels in view")
        } else {
            let res: &[u32] = if sizes.quick {
                &[32, 64]
            } else {
                &[32, 64, 128]
            };
            Ok(res
                .iter()
                .map(|&r| (Setting::Layered(r, 4), format!("face_res={r};layers=4")))
                .chain(std::iter::once((
                    Setting::Layered(res[res.len() - 1], 1),
                    format!("face_res={};layers=1", res[res.len() - 1]),
                )))
                .collect())
        };
    }
    if name == "cluster" {
        return if needs.reflective_pixels == 0 {
            Err("no reflective pixels in view")
        } else {
            Ok(cluster_settings(sizes))
        };
    }
    if let Some(screen) = screen_settings(name, sizes) {
        return if needs.reflective_pixels == 0 {
            Err("no reflective pixels in view")
        } else {
            Ok(screen)
        };
    }
    let image =
        |v: Vec<(Method, String)>| v.into_iter().map(|(m, s)| (Setting::Image(m), s)).collect();
    match name {
        // Mirror pixels trace one ray whatever the sample count: without
        // glossy pixels one row says all there is.
        "reference" if needs.glossy_pixels == 0 => Ok(image(vec![(
            Method::Reference { samples: 1 },
            "mirror_rays".into(),
        )])),
        "reference" => Ok(image(
            sizes
                .reference_samples
                .iter()
                .map(|&s| (Method::Reference { samples: s }, format!("glossy_spp={s}")))
                .collect(),
        )),
        "envmap" => Ok(image(vec![(Method::EnvMap, "analytic".into())])),
        "planar-mirror" if needs.planar_mirror_pixels == 0 => Err("no planar mirror in view"),
        "planar-mirror" => Ok(image(
            [1, 2, 4]
                .into_iter()
                .map(|scale| {
                    (
                        Method::PlanarMirror { scale },
                        format!("resolution=1/{scale}"),
                    )
                })
                .collect(),
        )),
        // Whole camera-path runs, after the per-frame loop (crate::tcrr).
        "tcrr" | "naive-warp" => Ok(Vec::new()),
        // The glossy study on the room, after the per-frame loop (crate::cone).
        "cone" | "multiray" => Ok(Vec::new()),
        _ => Err("unknown method"),
    }
}

fn load_scene(name: &str, opts: &Options, sizes: &Sizes) -> Result<Scene, String> {
    match name {
        "room" => Ok(Scene::room(sizes.tris)),
        "concave" => Ok(Scene::concave(sizes.tris)),
        "walkthrough" => Ok(Scene::walkthrough(sizes.tris)),
        "stage" => Ok(Scene::stage(sizes.tris)),
        path if path.ends_with(".obj") => {
            let mut flags = Vec::new();
            for f in &opts.reflective {
                let parts: Vec<&str> = f.split(':').collect();
                let parse = |s: &str| {
                    s.parse::<f32>()
                        .map_err(|e| format!("--reflective {f}: {e}"))
                };
                match parts.as_slice() {
                    [n, s, r] => flags.push((n.to_string(), parse(s)?, parse(r)?)),
                    _ => {
                        return Err(format!(
                            "--reflective {f}: expected NAME:SPECULAR:ROUGHNESS"
                        ))
                    }
                }
            }
            let flags: Vec<(&str, f32, f32)> =
                flags.iter().map(|(n, s, r)| (n.as_str(), *s, *r)).collect();
            Scene::load_obj(Path::new(path), &flags).map_err(|e| format!("{path}: {e}"))
        }
        other => Err(format!(
            "unknown scene '{other}' (room, concave, walkthrough, stage or a .obj path)"
        )),
    }
}

/// Sums over the frames of one scene x method x setting; a row is made
/// from it once every frame has run.
#[derive(Clone, Debug, Default)]
struct Accum {
    frames: usize,
    time_ms: f64,
    reference_ms: f64,
    handled: usize,
    reflective: usize,
    /// Sum of absolute 8-bit channel differences.
    abs_sum: f64,
    /// Sum of squared 8-bit channel differences.
    sq_sum: f64,
    /// Handled pixels whose largest channel error exceeds 8.
    over_8: f64,
    max_abs: u8,
    /// Ray statistics and timings of a screen-space method.
    screen: Option<ScreenAccum>,
    /// The cluster method's per-frame figures.
    cluster: Option<ClusterAccum>,
}

/// Sums over frames of the cluster method (seed 003).
#[derive(Clone, Debug, Default)]
struct ClusterAccum {
    frames: usize,
    reflective: usize,
    disoccluded: usize,
    fallback: usize,
    wrong_fallback: usize,
    clusters: usize,
    cameras: usize,
    planar: usize,
    texels: u64,
    stages: crate::cluster::StageMs,
}

impl ClusterAccum {
    fn of(f: &crate::cluster::ClusterFrame, stages: crate::cluster::StageMs) -> Self {
        ClusterAccum {
            frames: 1,
            reflective: f.reflective(),
            disoccluded: f.disoccluded_count(),
            fallback: f.fallback_count(),
            wrong_fallback: f.wrong_fallback_count(),
            clusters: f.clusters,
            cameras: f.cameras,
            planar: f.planar,
            texels: f.texels,
            stages,
        }
    }

    fn add(&mut self, o: &ClusterAccum) {
        self.frames += o.frames;
        self.reflective += o.reflective;
        self.disoccluded += o.disoccluded;
        self.fallback += o.fallback;
        self.wrong_fallback += o.wrong_fallback;
        self.clusters += o.clusters;
        self.cameras += o.cameras;
        self.planar += o.planar;
        self.texels += o.texels;
        self.stages.clustering += o.stages.clustering;
        self.stages.cameras += o.stages.cameras;
        self.stages.depth_images += o.stages.depth_images;
        self.stages.intersection += o.stages.intersection;
    }

    fn columns(&self) -> Vec<(String, String)> {
        let f = self.frames.max(1) as f64;
        let r = self.reflective.max(1) as f64;
        vec![
            (
                "disocclusion_share".into(),
                format!("{:.4}", self.disoccluded as f64 / r),
            ),
            (
                "fallback_share".into(),
                format!("{:.4}", self.fallback as f64 / r),
            ),
            (
                "fallback_with_hit_share".into(),
                format!("{:.4}", self.wrong_fallback as f64 / r),
            ),
            (
                "clusters_per_frame".into(),
                format!("{:.1}", self.clusters as f64 / f),
            ),
            (
                "cameras_per_frame".into(),
                format!("{:.1}", self.cameras as f64 / f),
            ),
            (
                "planar_clusters_per_frame".into(),
                format!("{:.1}", self.planar as f64 / f),
            ),
            (
                "depth_texels_per_frame".into(),
                format!("{:.0}", self.texels as f64 / f),
            ),
            (
                "clustering_ms".into(),
                format!("{:.3}", self.stages.clustering / f),
            ),
            (
                "cameras_ms".into(),
                format!("{:.3}", self.stages.cameras / f),
            ),
            (
                "depth_images_ms".into(),
                format!("{:.3}", self.stages.depth_images / f),
            ),
            (
                "intersection_ms".into(),
                format!("{:.3}", self.stages.intersection / f),
            ),
        ]
    }
}

/// Sums over frames of a screen-space method's ray statistics and timings.
#[derive(Clone, Debug, Default)]
struct ScreenAccum {
    stats: RayStats,
    kernel_ms: f64,
    kernel_ms_1t: f64,
    obvhs_ms: f64,
    obvhs_ms_1t: f64,
    bytes_per_pixel: f64,
    /// Layered rows: `visible` counts rays whose reference hits a mapped
    /// object, `found` those hit on the same object within a texel
    /// diagonal, the error is in texels.
    layered: bool,
}

impl ScreenAccum {
    fn add(&mut self, o: &ScreenAccum) {
        self.stats.add(&o.stats);
        self.kernel_ms += o.kernel_ms;
        self.kernel_ms_1t += o.kernel_ms_1t;
        self.obvhs_ms += o.obvhs_ms;
        self.obvhs_ms_1t += o.obvhs_ms_1t;
        self.bytes_per_pixel = o.bytes_per_pixel;
        self.layered = o.layered;
    }

    /// The method-specific columns.
    fn columns(&self) -> Vec<(String, String)> {
        let s = &self.stats;
        let rays = s.rays.max(1) as f64;
        let ns = |ms: f64| ms * 1e6 / rays;
        let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::INFINITY };
        vec![
            ("rays".into(), s.rays.to_string()),
            (
                "visible_share".into(),
                format!("{:.4}", s.visible as f64 / rays),
            ),
            ("hit_rate".into(), format!("{:.4}", s.hit_rate())),
            (
                "visible_missed".into(),
                format!("{:.4}", s.missed as f64 / s.visible.max(1) as f64),
            ),
            (
                "visible_wrong".into(),
                format!("{:.4}", s.wrong as f64 / s.visible.max(1) as f64),
            ),
            (
                "false_hit_rate".into(),
                format!("{:.4}", s.false_hit_rate()),
            ),
            (
                if self.layered {
                    "mean_hit_err_texels"
                } else {
                    "mean_hit_err_px"
                }
                .into(),
                format!("{:.4}", s.mean_err_px()),
            ),
            ("ns_per_ray".into(), format!("{:.1}", ns(self.kernel_ms))),
            (
                "ns_per_ray_1t".into(),
                format!("{:.1}", ns(self.kernel_ms_1t)),
            ),
            (
                "obvhs_ns_per_ray".into(),
                format!("{:.1}", ns(self.obvhs_ms)),
            ),
            (
                "obvhs_ns_per_ray_1t".into(),
                format!("{:.1}", ns(self.obvhs_ms_1t)),
            ),
            (
                "vs_obvhs".into(),
                format!("{:.3}", ratio(self.obvhs_ms, self.kernel_ms)),
            ),
            (
                "vs_obvhs_1t".into(),
                format!("{:.3}", ratio(self.obvhs_ms_1t, self.kernel_ms_1t)),
            ),
            (
                "fetches_per_ray".into(),
                format!("{:.1}", s.fetches as f64 / rays),
            ),
            (
                "iterations_per_ray".into(),
                format!("{:.1}", s.iterations as f64 / rays),
            ),
            (
                "bytes_per_pixel".into(),
                format!("{:.2}", self.bytes_per_pixel),
            ),
        ]
    }
}

impl Accum {
    fn add(&mut self, ms: f64, reference_ms: f64, reflective: usize, err: &ImageError) {
        let channels = 3.0 * err.pixels as f64;
        self.frames += 1;
        self.time_ms += ms;
        self.reference_ms += reference_ms;
        self.handled += err.pixels;
        self.reflective += reflective;
        self.abs_sum += err.mean_abs * channels;
        // PSNR = 10 log10(255^2 / mse), +inf for mse = 0.
        self.sq_sum += if err.psnr.is_finite() {
            255.0 * 255.0 / 10f64.powf(err.psnr / 10.0) * channels
        } else {
            0.0
        };
        self.over_8 += err.share_over_8() * err.pixels as f64;
        self.max_abs = self.max_abs.max(err.max_abs);
    }

    fn row(&self, scene: &str, method: &str, setting: &str, threads: usize) -> Row {
        let frames = self.frames.max(1) as f64;
        let (time_ms, reference_ms) = (self.time_ms / frames, self.reference_ms / frames);
        let channels = 3.0 * self.handled.max(1) as f64;
        let mse = self.sq_sum / channels;
        Row {
            scene: scene.to_owned(),
            method: method.to_owned(),
            setting: setting.to_owned(),
            threads,
            time_ms,
            reference_ms,
            speedup: if time_ms > 0.0 {
                reference_ms / time_ms
            } else {
                f64::INFINITY
            },
            coverage: if self.reflective > 0 {
                self.handled as f64 / self.reflective as f64
            } else {
                0.0
            },
            mean_abs_255: self.abs_sum / channels,
            psnr_db: if mse > 0.0 {
                10.0 * (255.0 * 255.0 / mse).log10()
            } else {
                f64::INFINITY
            },
            share_over_8: self.over_8 / self.handled.max(1) as f64,
            extra: {
                let mut e = vec![
                    ("frames".into(), self.frames.to_string()),
                    ("max_abs_255".into(), self.max_abs.to_string()),
                ];
                if let Some(sc) = &self.screen {
                    e.extend(sc.columns());
                }
                if let Some(c) = &self.cluster {
                    e.extend(c.columns());
                }
                e
            },
        }
    }
}

/// The camera-path poses a run renders: `frames` poses spread evenly over
/// the path, the first pose always included.
fn frame_poses(path_len: usize, frames: usize) -> Vec<usize> {
    let frames = frames.clamp(1, path_len.max(1));
    let mut poses: Vec<usize> = (0..frames).map(|k| k * path_len / frames).collect();
    poses.dedup();
    poses
}

/// Runs the median of `runs` timings of `f`, returning the first result.
fn median_run<T, E>(
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

/// Runs the report and returns the folder it wrote.
///
/// # Errors
/// A message for an unknown scene or method, an unreadable OBJ, or an I/O
/// failure while writing the report.
pub fn run(opts: &Options) -> Result<PathBuf, String> {
    let mut sizes = Sizes::new(opts.quick);
    if let Some(tris) = opts.tris {
        sizes.tris = tris;
    }
    let scenes: Vec<String> = if opts.scene.is_empty() {
        BUILT_IN_SCENES.map(String::from).to_vec()
    } else {
        opts.scene.clone()
    };
    let methods: Vec<&str> = if opts.method.is_empty() {
        METHODS.to_vec()
    } else {
        let mut m = Vec::new();
        for name in &opts.method {
            let known = METHODS
                .iter()
                .find(|k| **k == name.as_str())
                .ok_or(format!(
                    "unknown method '{name}' (known: {})",
                    METHODS.join(", ")
                ))?;
            m.push(*known);
        }
        m
    };
    if let Some(bad) = scenes
        .iter()
        .find(|s| !(BUILT_IN_SCENES.contains(&s.as_str()) || s.ends_with(".obj")))
    {
        return Err(format!(
            "unknown scene '{bad}' (room, concave, walkthrough, stage or a .obj path)"
        ));
    }
    let threads = opts
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| e.to_string())?;
    let pool_1t = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| e.to_string())?;
    let out = opts.out.clone();
    let images = out.join("images");
    std::fs::create_dir_all(&images).map_err(|e| format!("{}: {e}", images.display()))?;

    // The length grows per frame once the frame says which passes it needs.
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .map_err(|e| e.to_string())?
            .progress_chars("=> "),
    );

    let mut rows = Vec::new();
    let mut notes = String::new();
    let mut glossy_md = String::new();
    for scene_name in &scenes {
        bar.set_message(format!("{scene_name}: scene + BVH"));
        let scene = load_scene(scene_name, opts, &sizes)?;
        let label = scene.name.clone();
        let tracer = Tracer::new(&scene);
        let shader = Shader::new(&scene, &tracer);
        let poses = frame_poses(scene.camera_path.len(), sizes.frames);
        let _ = writeln!(
            notes,
            "- `{label}`: {} triangles, BVH build {:.1} ms, {}x{} pixels, camera poses {:?} of {}",
            scene.tri_count(),
            tracer.build_ms(),
            sizes.width,
            sizes.height,
            poses,
            scene.camera_path.len()
        );
        // (method, setting) -> sums over frames, in first-seen order.
        let mut accums: Vec<((&str, String), Accum)> = Vec::new();
        // G-buffers of every frame first: which passes the scene needs is
        // decided over all its frames, so every row pools the same frames.
        bar.inc_length(poses.len() as u64);
        let mut frames = Vec::with_capacity(poses.len());
        for &pose in &poses {
            let camera = scene
                .camera(pose, sizes.width, sizes.height)
                .map_err(|e| format!("{label}: camera: {e}"))?;
            let g = timed(|| GBuffer::render(&scene, &tracer, &camera, &pool));
            frames.push((pose, g.value, g.ms));
            bar.inc(1);
        }
        let needs = frames.iter().fold(
            FrameNeeds {
                glossy_pixels: 0,
                planar_mirror_pixels: 0,
                reflective_pixels: 0,
                reflected_objects: 0,
            },
            |a, (_, g, _)| {
                let n = FrameNeeds::of(&scene, g);
                FrameNeeds {
                    glossy_pixels: a.glossy_pixels + n.glossy_pixels,
                    planar_mirror_pixels: a.planar_mirror_pixels + n.planar_mirror_pixels,
                    reflective_pixels: a.reflective_pixels + n.reflective_pixels,
                    reflected_objects: n.reflected_objects,
                }
            },
        );
        for (method_name, why) in methods
            .iter()
            .filter(|m| !crate::epipolar::is_path_method(m))
            .filter_map(|m| settings(m, &sizes, needs).err().map(|why| (m, why)))
        {
            let _ = writeln!(notes, "  - `{method_name}` skipped: {why}");
        }
        // Layered maps are built once per scene and setting (static objects).
        let mut layered_maps: Vec<((u32, u32), crate::layered_render::LayeredScene)> = Vec::new();
        // No per-frame method to run (e.g. only the glossy study or the path
        // methods): skip the frames' ground truth.
        let per_frame = methods
            .iter()
            .filter(|m| !crate::epipolar::is_path_method(m))
            .any(|m| settings(m, &sizes, needs).is_ok_and(|v| !v.is_empty()));
        for (frame, (pose, g, gbuffer_ms)) in frames.iter().enumerate().filter(|_| per_frame) {
            // Rays and reference timings of the screen-space methods, made
            // when the first of them runs on this frame.
            let mut screen_frame: Option<screen::ScreenFrame> = None;
            let (pose, gbuffer_ms) = (*pose, *gbuffer_ms);
            let frame_needs = FrameNeeds::of(&scene, g);
            let reflective = g.reflective_mask();
            let n_reflective = reflective.iter().filter(|&&r| r).count();
            bar.inc_length(1);

            bar.set_message(format!(
                "{label} pose {pose}: ground truth ({} spp)",
                sizes.truth_samples
            ));
            let truth = Method::Reference {
                samples: sizes.truth_samples,
            };
            let (truth_img, truth_ms) = median_run(sizes.runs, || truth.run(&shader, g, &pool))
                .map_err(|e| e.to_string())?;
            let direct = direct_image(&shader, g, &pool);
            let truth_final = composite(g, &direct, &truth_img);
            if frame == 0 {
                save(
                    &images.join(format!("{label}_reference.png")),
                    g,
                    &truth_final,
                )?;
            }
            bar.inc(1);
            let _ = writeln!(
                notes,
                "  - pose {pose}: G-buffer {gbuffer_ms:.1} ms, {n_reflective} reflective pixels ({} glossy, {} planar mirror); \
                 ground truth {truth_ms:.1} ms",
                frame_needs.glossy_pixels, frame_needs.planar_mirror_pixels
            );

            for method_name in methods
                .iter()
                .filter(|m| !crate::epipolar::is_path_method(m))
            {
                let Ok(runs_of) = settings(method_name, &sizes, needs) else {
                    continue;
                };
                bar.inc_length(runs_of.len() as u64);
                for (setting_v, setting) in runs_of {
                    bar.set_message(format!("{label} pose {pose}: {method_name} {setting}"));
                    let mut cluster_acc = None;
                    let (img, ms, screen_acc) = match setting_v {
                        Setting::Image(method) => {
                            let (img, ms) =
                                median_run(sizes.runs, || method.run(&shader, g, &pool))
                                    .map_err(|e| e.to_string())?;
                            (img, ms, None)
                        }
                        Setting::Cluster(cs) => {
                            // The first run also marks disocclusions (ray
                            // traced, outside the stage timers).
                            let mut stage_runs = Vec::new();
                            let mut first = None;
                            for k in 0..sizes.runs.max(1) {
                                let f = crate::cluster::run(&shader, g, &cs, &pool, k == 0)
                                    .map_err(|e| format!("{label}: cluster: {e}"))?;
                                stage_runs.push(f.stages);
                                first.get_or_insert(f);
                            }
                            let f = first.ok_or("cluster: no run")?;
                            let stages = crate::cluster::StageMs::median_of(&stage_runs);
                            let ms = median(stage_runs.iter().map(|s| s.total()).collect());
                            if frame == 0 {
                                let stem = format!(
                                    "{label}_cluster_{}",
                                    setting.replace(['=', ';', '/'], "-")
                                );
                                save(
                                    &images.join(format!("{stem}_clusters.png")),
                                    g,
                                    &crate::cluster::cluster_image(g, &f, false),
                                )?;
                                save(
                                    &images.join(format!("{stem}_disocclusion.png")),
                                    g,
                                    &crate::cluster::cluster_image(g, &f, true),
                                )?;
                            }
                            cluster_acc = Some(ClusterAccum::of(&f, stages));
                            (f.image, ms, None)
                        }
                        Setting::Screen(kernel, conv, refine) => {
                            let sf = screen_frame.get_or_insert_with(|| {
                                screen::ScreenFrame::new(
                                    &scene, &tracer, &shader, g, &direct, &pool, &pool_1t,
                                    sizes.runs,
                                )
                            });
                            let (obvhs_ms, obvhs_ms_1t) = (sf.obvhs_ms, sf.obvhs_ms_1t);
                            sf.prepare_depth(g, conv).map_err(|e| e.to_string())?;
                            let sf = &*sf;
                            let depth = sf.depth(conv).ok_or("depth buffer")?;
                            let image = depth.image().map_err(|e| e.to_string())?;
                            let rays = &sf.rays;
                            let (out, ms) = median_run(sizes.runs, || {
                                screen::run(kernel, refine, &image, &sf.images, &pool)
                            })
                            .map_err(|e| e.to_string())?;
                            let (_, ms_1t) = median_run(sizes.runs, || {
                                screen::run(kernel, refine, &image, &sf.images, &pool_1t)
                            })
                            .map_err(|e| e.to_string())?;
                            let (fetches, steps, iterations) =
                                screen::kernel_work(kernel, &image, &sf.images, rays, &pool)
                                    .map_err(|e| e.to_string())?;
                            let stats = RayStats {
                                fetches,
                                steps,
                                iterations,
                                ..screen::evaluate(rays, &out.texels)
                            };
                            let img = screen::shade(g, &out);
                            let acc = ScreenAccum {
                                stats,
                                kernel_ms: ms,
                                kernel_ms_1t: ms_1t,
                                obvhs_ms,
                                obvhs_ms_1t,
                                bytes_per_pixel: kernel.bytes_per_pixel(g.width(), g.height()),
                                layered: false,
                            };
                            (img, ms, Some(acc))
                        }
                        Setting::Layered(res, layers) => {
                            let sf = screen_frame.get_or_insert_with(|| {
                                screen::ScreenFrame::new(
                                    &scene, &tracer, &shader, g, &direct, &pool, &pool_1t,
                                    sizes.runs,
                                )
                            });
                            let sf = &*sf;
                            let key = (res, layers);
                            if !layered_maps.iter().any(|(k, _)| *k == key) {
                                let ls = crate::layered_render::LayeredScene::build(
                                    &scene, res, layers, &pool,
                                )
                                .map_err(|e| format!("{label}: layered maps: {e}"))?;
                                let _ = writeln!(
                                    notes,
                                    "  - layered maps {res}x{res}x{layers}: {} objects, {:.1} ms build, {:.1} MiB",
                                    ls.objects.len(),
                                    ls.build_ms,
                                    ls.bytes() as f64 / (1024.0 * 1024.0)
                                );
                                layered_maps.push((key, ls));
                            }
                            let ls = &layered_maps
                                .iter()
                                .find(|(k, _)| *k == key)
                                .ok_or("layered maps")?
                                .1;
                            let params = refl_core::layered::LayeredOptions::default();
                            let lf = crate::layered_render::LayeredFrame::new(g);
                            let trace = |p: &rayon::ThreadPool| {
                                let t = timed(|| ls.trace(g, &lf, &params, p));
                                t.value.map(|v| Timed { value: v, ms: t.ms })
                            };
                            let (traces, ms) = median_run(sizes.runs, || trace(&pool))
                                .map_err(|e| e.to_string())?;
                            let (_, ms_1t) = median_run(sizes.runs, || trace(&pool_1t))
                                .map_err(|e| e.to_string())?;
                            let ls_stats =
                                crate::layered_render::evaluate(&scene, ls, &sf.rays, &traces);
                            let img = crate::layered_render::shade(&shader, g, &traces);
                            let pixels = f64::from(g.width()) * f64::from(g.height());
                            let acc = ScreenAccum {
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
                                obvhs_ms: sf.obvhs_ms,
                                obvhs_ms_1t: sf.obvhs_ms_1t,
                                bytes_per_pixel: ls.bytes() as f64 / pixels,
                                layered: true,
                            };
                            (img, ms, Some(acc))
                        }
                    };
                    // The reference on exactly the handled pixels, same threads.
                    let reference_ms = if img.handled_count() == n_reflective {
                        truth_ms
                    } else {
                        median_run(sizes.runs, || {
                            Ok::<_, String>(timed(|| {
                                render::reference_masked(
                                    &shader,
                                    g,
                                    sizes.truth_samples,
                                    &img.handled,
                                    &pool,
                                )
                            }))
                        })?
                        .1
                    };
                    let method_final = composite(g, &direct, &img);
                    let err = compare(&truth_final, &method_final, &img.handled);
                    if frame == 0 {
                        let stem = format!(
                            "{label}_{method_name}_{}",
                            setting.replace(['=', ';', '/'], "-")
                        );
                        save(&images.join(format!("{stem}.png")), g, &method_final)?;
                        save(
                            &images.join(format!("{stem}_diff.png")),
                            g,
                            &diff_image(&truth_final, &method_final, &img, &reflective),
                        )?;
                    }
                    let key = (*method_name, setting);
                    let i = match accums.iter().position(|(k, _)| *k == key) {
                        Some(i) => i,
                        None => {
                            accums.push((key, Accum::default()));
                            accums.len() - 1
                        }
                    };
                    accums[i].1.add(ms, reference_ms, n_reflective, &err);
                    if let Some(acc) = screen_acc {
                        accums[i]
                            .1
                            .screen
                            .get_or_insert_with(ScreenAccum::default)
                            .add(&acc);
                    }
                    if let Some(acc) = cluster_acc {
                        accums[i]
                            .1
                            .cluster
                            .get_or_insert_with(ClusterAccum::default)
                            .add(&acc);
                    }
                    bar.inc(1);
                }
            }
        }
        rows.extend(
            accums
                .iter()
                .map(|((m, setting), a)| a.row(&label, m, setting, threads)),
        );
        let (use_tcrr, use_naive) = (methods.contains(&"tcrr"), methods.contains(&"naive-warp"));
        if use_tcrr || use_naive {
            bar.set_message(format!("{label}: tcrr camera path"));
            let (tcrr_rows, note) = crate::tcrr::report_rows(
                &shader,
                &label,
                opts.quick,
                sizes.width,
                sizes.height,
                use_tcrr,
                use_naive,
                threads,
                &pool,
                &images,
            )?;
            rows.extend(tcrr_rows);
            notes.push_str(&note);
        }
        // Glossy study on the room: cone tracing and multi-ray against the
        // Monte-Carlo reference at low sample counts (crate::cone).
        let (use_cone, use_multi) = (methods.contains(&"cone"), methods.contains(&"multiray"));
        if label == "room" && (use_cone || use_multi) {
            bar.set_message(format!("{label}: glossy study"));
            // --quick (CI): half the frame, 64-sample ground truth.
            let study = crate::cone::StudySizes {
                width: if opts.quick {
                    sizes.width / 2
                } else {
                    sizes.width
                },
                height: if opts.quick {
                    sizes.height / 2
                } else {
                    sizes.height
                },
                truth_samples: if opts.quick { 64 } else { 1024 },
                runs: sizes.runs,
                quick: opts.quick,
            };
            let (cone_rows, note) = crate::cone::report_rows(
                &scene,
                &tracer,
                study,
                (use_cone, use_multi),
                threads,
                &pool,
                &images,
            )?;
            rows.extend(cone_rows);
            glossy_md.push_str(&note);
        }
        // Seed 002 on the walkthrough: ORSA, the method, IRSA along the path.
        if label == "walkthrough" && methods.iter().any(|m| crate::epipolar::is_path_method(m)) {
            bar.set_message(format!("{label}: epipolar walkthrough"));
            let path = crate::epipolar::run(
                &scene,
                &tracer,
                &crate::epipolar::PathSizes::new(opts.quick),
                sizes.runs,
                &pool,
                threads,
                Some(&images),
            )?;
            notes.push_str(&path.notes);
            rows.extend(
                path.rows
                    .into_iter()
                    .filter(|r| methods.contains(&r.method.as_str())),
            );
        }
    }
    bar.finish_and_clear();

    let growth_sizes: Vec<usize> = if opts.growth.is_empty() {
        if opts.quick || !scenes.iter().any(|s| s == "room") {
            Vec::new()
        } else {
            vec![10_000, 100_000, 1_000_000]
        }
    } else {
        opts.growth.iter().copied().filter(|&n| n > 0).collect()
    };
    // The depth-image kernels' growth table runs when one of them is
    // selected; the cluster method has its own (seed 003 Tables 3..7: the
    // pipeline against ray tracing with a BVH rebuild per frame).
    let kernel_growth = methods
        .iter()
        .any(|m| matches!(*m, "reference" | "step" | "hiz" | "layered"));
    let cluster_growth_md = if growth_sizes.is_empty() || !methods.contains(&"cluster") {
        String::new()
    } else {
        bar.set_message("cluster cost growth");
        let settings = crate::cluster::ClusterSettings::default();
        let rows = crate::cluster::growth(
            &growth_sizes,
            sizes.width,
            sizes.height,
            sizes.runs,
            &settings,
            &pool,
        )?;
        let path = out.join("growth_cluster.csv");
        crate::cluster::write_growth_csv(&path, &rows)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        let table = crate::cluster::growth_markdown(&rows);
        print!("{table}");
        format!(
            "\n## Cluster method against ray tracing with a BVH rebuild (room, camera pose 0, {threads} thread(s), \
             `{}`)\n\nOne frame: the BVH build a dynamic scene pays every frame plus the ray-traced reflection pass \
             (obvhs, {} rays per glossy pixel), against the cluster pipeline's stages. Shadows are off in both, so \
             that shading needs no BVH. Error against the reference at 64 glossy samples. Also in \
             `growth_cluster.csv`.\n\n{table}",
            settings.label(),
            settings.glossy_rays
        )
    };
    let growth_md = if growth_sizes.is_empty() || !kernel_growth {
        String::new()
    } else {
        bar.set_message("cost growth");
        let rows =
            crate::growth::measure(&growth_sizes, sizes.width, sizes.height, sizes.runs, &pool)?;
        let path = out.join("growth.csv");
        crate::growth::write_csv(&path, &rows).map_err(|e| format!("{}: {e}", path.display()))?;
        format!(
            "\n## Cost growth (room, camera pose 0, {threads} thread(s), reversed-Z)\n\nTimes per frame for all \
             reflection rays; the screen-space kernels exclude producing the depth buffer, `build+obvhs` is what a \
             dynamic scene pays per frame with a BVH. Also in `growth.csv`.\n\n{}",
            crate::growth::markdown(&rows)
        )
    };
    let csv = out.join("summary.csv");
    report_out::write_csv(&csv, &rows).map_err(|e| format!("{}: {e}", csv.display()))?;
    let plot = out.join("error_vs_time.png");
    report_out::plot_error_vs_time(&plot, &rows).map_err(|e| format!("{}: {e}", plot.display()))?;
    let md = format!(
        "# refl report\n\n{} run, {threads} thread(s), {} frame(s) per scene. Time is the reflection pass only \
         (median of {} runs, mean over frames); `reference_ms` is the ray-traced reference (obvhs) on the same \
         pixels in the same run, same threads. Error is measured against the ground truth (the reference at {} \
         glossy samples per pixel) on the pixels each method handles, pooled over frames: mean absolute difference \
         on 0..255 of 8-bit sRGB composites, PSNR, share of pixels over 8/255. Images: the first frame.\n\n\
         ## Scenes\n\n{notes}\n## Summary\n\n{}\n![error vs time](error_vs_time.png)\n{glossy_md}{growth_md}{cluster_growth_md}",
        if opts.quick { "Quick" } else { "Default" },
        sizes.frames,
        sizes.runs,
        sizes.truth_samples,
        report_out::markdown_table(&rows)
    );
    let md_path = out.join("summary.md");
    std::fs::write(&md_path, md).map_err(|e| format!("{}: {e}", md_path.display()))?;
    print!("{}", report_out::markdown_table(&rows));
    Ok(out)
}

fn save(path: &Path, g: &GBuffer, rgb: &[Vec3]) -> Result<(), String> {
    render::save_png(path, g.width(), g.height(), rgb)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The absolute difference amplified 8x on handled pixels; reflective
/// pixels the method does not handle are shown dark blue, the rest black.
fn diff_image(
    truth: &[Vec3],
    method: &[Vec3],
    img: &ReflectionImage,
    reflective: &[bool],
) -> Vec<Vec3> {
    (0..truth.len())
        .map(|i| {
            if img.handled[i] {
                ((truth[i] - method[i]).abs() * 8.0).min(Vec3::ONE)
            } else if reflective[i] {
                Vec3::new(0.0, 0.0, 0.15)
            } else {
                Vec3::ZERO
            }
        })
        .collect()
}
