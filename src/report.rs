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
use crate::shade::Shader;
use crate::tracer::Tracer;
use crate::{gbuffer::GBuffer, render::timed};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Command-line options of `refl report`.
#[derive(Clone, Debug, clap::Args)]
pub struct Options {
    /// Small sizes (about a minute on 2 cores); what the tests run.
    #[arg(long)]
    pub quick: bool,
    /// Scenes: `room`, `concave`, `walkthrough`, or a path to an `.obj`
    /// file (repeatable; default: the three built-in scenes).
    #[arg(long)]
    pub scene: Vec<String>,
    /// Methods: `reference`, `envmap`, `planar-mirror` (repeatable; default:
    /// all).
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
            }
        }
    }
}

/// The built-in scenes, in report order.
pub const BUILT_IN_SCENES: [&str; 3] = ["room", "concave", "walkthrough"];

/// Every method name the report knows, in report order.
pub const METHODS: [&str; 6] = [
    "reference",
    "envmap",
    "planar-mirror",
    // Primary visibility along the walkthrough path (seed 002), run once
    // per scene after its frames: see [`crate::epipolar`].
    "epipolar",
    "orsa",
    "irsa",
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
}

impl FrameNeeds {
    fn of(scene: &Scene, g: &GBuffer) -> Self {
        let planar_mirror: Vec<bool> = scene
            .objects
            .iter()
            .map(|o| o.planar.is_some() && scene.materials[o.material as usize].is_mirror())
            .collect();
        let (mut glossy_pixels, mut planar_mirror_pixels) = (0, 0);
        for i in 0..g.len() {
            if !g.is_reflective(i) {
                continue;
            }
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
        }
    }
}

/// The methods and settings run for method `name` on a frame, or why the
/// frame cannot use the method.
fn settings(
    name: &str,
    sizes: &Sizes,
    needs: FrameNeeds,
) -> Result<Vec<(Method, String)>, &'static str> {
    match name {
        // Mirror pixels trace one ray whatever the sample count: without
        // glossy pixels one row says all there is.
        "reference" if needs.glossy_pixels == 0 => Ok(vec![(
            Method::Reference { samples: 1 },
            "mirror_rays".into(),
        )]),
        "reference" => Ok(sizes
            .reference_samples
            .iter()
            .map(|&s| (Method::Reference { samples: s }, format!("glossy_spp={s}")))
            .collect()),
        "envmap" => Ok(vec![(Method::EnvMap, "analytic".into())]),
        "planar-mirror" if needs.planar_mirror_pixels == 0 => Err("no planar mirror in view"),
        "planar-mirror" => Ok([1, 2, 4]
            .into_iter()
            .map(|scale| {
                (
                    Method::PlanarMirror { scale },
                    format!("resolution=1/{scale}"),
                )
            })
            .collect()),
        _ => Err("unknown method"),
    }
}

fn load_scene(name: &str, opts: &Options, sizes: &Sizes) -> Result<Scene, String> {
    match name {
        "room" => Ok(Scene::room(sizes.tris)),
        "concave" => Ok(Scene::concave(sizes.tris)),
        "walkthrough" => Ok(Scene::walkthrough(sizes.tris)),
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
            "unknown scene '{other}' (room, concave, walkthrough or a .obj path)"
        )),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
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
            extra: vec![
                ("frames".into(), self.frames.to_string()),
                ("max_abs_255".into(), self.max_abs.to_string()),
            ],
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
            "unknown scene '{bad}' (room, concave, walkthrough or a .obj path)"
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
            },
            |a, (_, g, _)| {
                let n = FrameNeeds::of(&scene, g);
                FrameNeeds {
                    glossy_pixels: a.glossy_pixels + n.glossy_pixels,
                    planar_mirror_pixels: a.planar_mirror_pixels + n.planar_mirror_pixels,
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
        for (frame, (pose, g, gbuffer_ms)) in frames.iter().enumerate() {
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
                for (method, setting) in runs_of {
                    bar.set_message(format!("{label} pose {pose}: {method_name} {setting}"));
                    let (img, ms) = median_run(sizes.runs, || method.run(&shader, g, &pool))
                        .map_err(|e| e.to_string())?;
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
                    bar.inc(1);
                }
            }
        }
        rows.extend(
            accums
                .iter()
                .map(|((m, setting), a)| a.row(&label, m, setting, threads)),
        );
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
         ## Scenes\n\n{notes}\n## Summary\n\n{}\n![error vs time](error_vs_time.png)\n",
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
