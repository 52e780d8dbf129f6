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

pub mod accum;
pub mod bounce;
pub mod calibrate;
pub mod cluster_res;
pub mod content;
pub mod epipolar;
pub mod extrapolate;
pub mod glossy;
pub mod half;
pub mod methods;
pub mod plan;
pub mod planned;
pub mod studies;
pub mod tcrr;
pub mod temporal;

use crate::gbuffer::GBuffer;
use crate::render::{self, compare, composite, direct_image, timed, ReflectionImage};
use crate::report_out::{self, Row};
use crate::scene::Scene;
use crate::shade::Shader;
use crate::tracer::Tracer;
use accum::Accum;
use content::Content;
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use methods::{Frame, Setting};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use studies::{SceneRun, Study};

/// Command-line options of `refl report`.
/// Command-line options of `refl report`.
#[derive(Clone, Debug, clap::Args)]
pub struct Options {
    /// Small sizes (about a minute on 2 cores); what the tests run.
    #[arg(long)]
    pub quick: bool,
    /// The long study: converged references (512 glossy samples per pixel
    /// for the ground truth, 1024 for the glossy study), four frames per
    /// scene, the full walkthrough and cost growth to a million triangles
    /// (see the README for its run time).
    #[arg(long, conflicts_with = "quick")]
    pub long: bool,
    /// Scenes: `room`, `concave`, `walkthrough`, `stage`, `hall`, or a path
    /// to an `.obj` file (repeatable; default: the five built-in scenes,
    /// the hall with the multiple-bounce rows only unless `--long`).
    #[arg(long)]
    pub scene: Vec<String>,
    /// Methods: `reference`, `envmap`, `planar-mirror`, `epipolar`, `orsa`,
    /// `irsa`, `step`, `hiz`, `layered`, `cluster`, `tcrr`, `naive-warp`,
    /// `cone`, `multiray`, `hiz-temporal`, `hiz-bounce`, `planned`
    /// (repeatable; default: all).
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
    /// `--long`: 10000,100000,1000000, otherwise none); `0` skips it.
    #[arg(long, value_delimiter = ',')]
    pub growth: Vec<usize>,
    /// Reflective materials for an OBJ scene: `NAME:SPECULAR:ROUGHNESS`,
    /// matching object names containing NAME (repeatable).
    #[arg(long)]
    pub reflective: Vec<String>,
    /// A camera path replacing the scenes' own: one pose per line, `eye_x
    /// eye_y eye_z target_x target_y target_z [fov_y_degrees]` (see
    /// [`crate::scene::load_camera_path`]). An OBJ interior walked by such
    /// a path gets the epipolar walk.
    #[arg(long)]
    pub camera_path: Option<PathBuf>,
}

impl Default for Options {
    /// The default run: every built-in scene and method into `report/`.
    fn default() -> Self {
        Options {
            quick: false,
            long: false,
            scene: Vec::new(),
            method: Vec::new(),
            out: PathBuf::from("report"),
            threads: None,
            tris: None,
            growth: Vec::new(),
            reflective: Vec::new(),
            camera_path: None,
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
    /// Timed repetitions of the one-thread runs of the screen-space and
    /// layered methods (their `*_1t` columns): one in the default and
    /// quick runs, `runs` with `--long`.
    pub runs_1t: usize,
    /// Camera-path poses rendered per scene (spread over the path).
    pub frames: usize,
    /// Samples per pixel of the glossy study's converged reference.
    pub glossy_truth_samples: u32,
    /// The epipolar walkthrough's frames and image size.
    pub path: crate::epipolar::PathSizes,
    /// How much the studies measure; `Quick` also runs fewer per-frame
    /// settings.
    pub level: Level,
}

/// How much a report run measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// `--quick`: the tests' sizes, fewest settings.
    Quick,
    /// The default run: every method and scene, studies trimmed (one glossy
    /// variant at 128 samples per pixel, a 16-frame TCRR path, no epipolar
    /// ablations, the temporal filter at one history length),
    /// screen-space rows in reversed-Z only.
    Default,
    /// `--long`: converged references, every study setting, the
    /// screen-space rows in every depth convention.
    Long,
}

impl Sizes {
    /// The sizes of `--quick` runs (what the tests run).
    pub const QUICK: Sizes = Sizes {
        width: 256,
        height: 192,
        tris: 30_000,
        truth_samples: 64,
        reference_samples: &[4, 16],
        runs: 3,
        runs_1t: 1,
        frames: 2,
        glossy_truth_samples: 64,
        path: crate::epipolar::PathSizes::QUICK,
        level: Level::Quick,
    };

    /// The default run's sizes: every method and scene at 384x288, with
    /// references converged enough to rank the methods.
    pub const DEFAULT: Sizes = Sizes {
        width: 384,
        height: 288,
        tris: 150_000,
        truth_samples: 128,
        reference_samples: &[4, 16, 64],
        runs: 3,
        runs_1t: 1,
        frames: 2,
        glossy_truth_samples: 128,
        path: crate::epipolar::PathSizes::DEFAULT,
        level: Level::Default,
    };

    /// `--long`: converged references and more frames.
    pub const LONG: Sizes = Sizes {
        width: 512,
        height: 384,
        tris: 150_000,
        truth_samples: 512,
        reference_samples: &[4, 16, 64, 256],
        runs: 3,
        runs_1t: 3,
        frames: 4,
        glossy_truth_samples: 1024,
        path: crate::epipolar::PathSizes::LONG,
        level: Level::Long,
    };

    /// Whether this is a `--quick` run (fewer per-frame settings).
    pub fn quick(&self) -> bool {
        self.level == Level::Quick
    }

    /// The sizes `opts` asks for (`--quick`, `--long` or the default, with
    /// `--tris`).
    pub fn of(opts: &Options) -> Self {
        let mut s = if opts.quick {
            Sizes::QUICK
        } else if opts.long {
            Sizes::LONG
        } else {
            Sizes::DEFAULT
        };
        if let Some(tris) = opts.tris {
            s.tris = tris;
        }
        s
    }
}

/// The built-in scenes, in report order.
pub const BUILT_IN_SCENES: [&str; 5] = ["room", "concave", "walkthrough", "stage", "hall"];

/// Built-in scenes that a run without `--scene` measures with these
/// methods only, unless `--long`: the hall of mirrors is there for the
/// multiple-bounce rows (seed 004 Sec. 4.6.4), and every per-frame method
/// and path study on it would add about a sixth to the default run time
/// (`--scene hall` or `--long` runs them all).
pub const DEFAULT_RUN_ONLY: [(&str, &[&str]); 1] = [("hall", &["hiz-bounce"])];

/// The methods `selected` that run on scene `name` in a run of `opts`
/// ([`DEFAULT_RUN_ONLY`]).
fn scene_methods(opts: &Options, name: &str, selected: &[&'static str]) -> Vec<&'static str> {
    let only = DEFAULT_RUN_ONLY
        .iter()
        .find(|(n, _)| *n == name)
        .filter(|_| opts.scene.is_empty() && !opts.long);
    match only {
        Some((_, methods)) => selected
            .iter()
            .copied()
            .filter(|m| methods.contains(m))
            .collect(),
        None => selected.to_vec(),
    }
}

/// Every method name the report knows, in report order.
pub const METHODS: [&str; 17] = [
    "reference",
    "envmap",
    "planar-mirror",
    // Primary visibility along a camera path inside walls (seed
    // 002), a study run once per scene after its frames: see
    // [`studies`] and [`crate::epipolar`].
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
    // multi-ray), a study on the reflectors of scenes with glossy pixels,
    // made glossy: see [`studies`] and [`crate::cone`].
    "cone",
    "multiray",
    // Seed 004 Sec. 4.6.5: the Hi-Z mirror pass with temporal filtering
    // along the camera path, a study: see [`studies`] and
    // [`crate::temporal`].
    "hiz-temporal",
    // Seed 004 Sec. 4.6.4: the Hi-Z mirror pass reading the previous
    // frame's final image (multiple bounces) on a static camera, a study:
    // see [`studies`] and [`crate::bounce`].
    "hiz-bounce",
    // Issue 15: refl-core's planner choosing per reflector from the
    // calibration table, one row per budget: see [`planned`].
    "planned",
];

/// What the command line says about the scenes' input, checked before
/// anything is loaded or written.
struct SceneInput {
    /// `--reflective` flags: name part, specular, roughness.
    reflective: Vec<(String, f32, f32)>,
    /// `--camera-path`, read.
    camera_path: Option<Vec<crate::scene::CameraPose>>,
}

impl SceneInput {
    fn of(opts: &Options) -> Result<Self, String> {
        let mut reflective = Vec::new();
        for f in &opts.reflective {
            let parse = |s: &str, what: &str, max: f32| match s.parse::<f32>() {
                Ok(v) if (0.0..=max).contains(&v) => Ok(v),
                Ok(v) => Err(format!(
                    "--reflective {f}: {what} {v} is outside [0, {max}]"
                )),
                Err(e) => Err(format!("--reflective {f}: {what}: {e}")),
            };
            match f.split(':').collect::<Vec<&str>>().as_slice() {
                [n, s, r] => reflective.push((
                    n.to_string(),
                    parse(s, "specular", 1.0)?,
                    parse(r, "roughness", 1.0)?,
                )),
                _ => {
                    return Err(format!(
                        "--reflective {f}: expected NAME:SPECULAR:ROUGHNESS"
                    ))
                }
            }
        }
        let camera_path = opts
            .camera_path
            .as_deref()
            .map(crate::scene::load_camera_path)
            .transpose()?;
        Ok(SceneInput {
            reflective,
            camera_path,
        })
    }

    /// Scene `name` (built-in or an OBJ path) with the camera path, if
    /// given.
    fn load(&self, name: &str, sizes: &Sizes) -> Result<Scene, String> {
        let mut scene = match name {
            "room" => Scene::room(sizes.tris),
            "concave" => Scene::concave(sizes.tris),
            "walkthrough" => Scene::walkthrough(sizes.tris),
            "stage" => Scene::stage(sizes.tris),
            "hall" => Scene::hall(sizes.tris),
            path if path.ends_with(".obj") => {
                let flags: Vec<(&str, f32, f32)> = self
                    .reflective
                    .iter()
                    .map(|(n, s, r)| (n.as_str(), *s, *r))
                    .collect();
                // The error names the file.
                Scene::load_obj(Path::new(path), &flags).map_err(|e| e.to_string())?
            }
            other => {
                return Err(format!(
                "unknown scene '{other}' (room, concave, walkthrough, stage, hall or a .obj path)"
            ))
            }
        };
        if let Some(path) = &self.camera_path {
            scene.camera_path.clone_from(path);
        }
        Ok(scene)
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

/// Command-line options of `refl plan`.
#[derive(Clone, Debug, clap::Args)]
pub struct PlanArgs {
    /// Scenes, as for `refl report` (default: the five built-in scenes).
    #[arg(long)]
    pub scene: Vec<String>,
    /// Image width.
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    /// Image height.
    #[arg(long, default_value_t = 384)]
    pub height: u32,
    /// Triangle budget of the built-in scenes.
    #[arg(long, default_value_t = 30_000)]
    pub tris: usize,
    /// Reflective materials for an OBJ scene, as for `refl report`.
    #[arg(long)]
    pub reflective: Vec<String>,
    /// A camera path replacing the scenes' own, as for `refl report`.
    #[arg(long)]
    pub camera_path: Option<PathBuf>,
    /// The host has no ray tracer, no extra views, no probe (what is left
    /// for the screen-space passes alone).
    #[arg(long)]
    pub bare_host: bool,
    /// The host keeps the last frame's reflections: every pose after the
    /// first is planned knowing whether the camera moved since the pose
    /// before (the scene stands still), so a pose equal to the last one
    /// runs no pass and the others add the temporal pass.
    #[arg(long)]
    pub history: bool,
    /// Error budgets: the planner chooses a method per reflector and
    /// roughness class so that the frame's mean error (0..255) is at most
    /// this (repeatable; with neither `--max-error` nor `--max-time`, the
    /// report's `planned` budgets).
    #[arg(long)]
    pub max_error: Vec<f32>,
    /// Time budgets: at most this multiple of the reference tracer's time
    /// for one ray per reflective pixel (repeatable).
    #[arg(long)]
    pub max_time: Vec<f32>,
    /// The calibration table the planner reads (default: the checked-in
    /// `calibration/default.csv`, written by `refl calibrate`).
    #[arg(long)]
    pub calibration: Option<PathBuf>,
}

/// `refl plan`: per scene and camera pose, refl-core's frame summary and
/// plan (passes run and skipped with the reason, pyramid bytes, planar
/// objects), and per budget the method chosen for each reflector and
/// roughness class with the reason, the prediction and the passes, as
/// text.
///
/// # Errors
/// As [`run`] for bad scene input; a budget that is NaN, infinite or
/// negative; an unreadable or malformed calibration table; refl-core's
/// errors as text.
pub fn plans(args: &PlanArgs) -> Result<String, String> {
    let opts = Options {
        scene: args.scene.clone(),
        reflective: args.reflective.clone(),
        camera_path: args.camera_path.clone(),
        ..Options::default()
    };
    let scenes = scene_names(&opts)?;
    let input = SceneInput::of(&opts)?;
    let sizes = Sizes {
        width: args.width,
        height: args.height,
        tris: args.tris,
        ..Sizes::DEFAULT
    };
    let caps = if args.bare_host {
        refl_core::plan::HostCaps::default()
    } else {
        plan::REPORT_HOST
    };
    let mut budgets = planned::budgets_of(&args.max_error, &args.max_time)?;
    if budgets.is_empty() {
        budgets = planned::BUDGETS.to_vec();
    }
    let cal = match &args.calibration {
        Some(path) => {
            let text =
                std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
            crate::calibration::Calibration::parse(&text)
                .map_err(|e| format!("{}: {e}", path.display()))?
        }
        None => crate::calibration::Calibration::builtin()?,
    };
    let table = cal.cost_table();
    let pool = rayon::ThreadPoolBuilder::new()
        .build()
        .map_err(|e| e.to_string())?;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "calibration: {} (commit {}); budgets: {}",
        cal.command,
        cal.commit,
        budgets
            .iter()
            .map(|&b| planned::budget_label(b))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for name in &scenes {
        let scene = input.load(name, &sizes)?;
        let tracer = Tracer::new(&scene);
        let _ = writeln!(out, "{}: {} triangles", scene.name, scene.tri_count());
        for pose in 0..scene.camera_path.len() {
            let camera = scene
                .camera(pose, sizes.width, sizes.height)
                .map_err(|e| format!("{}: camera: {e}", scene.name))?;
            let g = GBuffer::render(&scene, &tracer, &camera, &pool);
            let motion = refl_core::plan::FrameMotion {
                history: args.history && pose > 0,
                camera_still: pose > 0
                    && scene.camera(pose - 1, sizes.width, sizes.height).ok() == Some(camera),
                scene_still: true,
            };
            let p = plan::plan_frame_moving(&scene, &g, &caps, motion)?;
            let f = &p.frame;
            let _ = writeln!(
                out,
                "  pose {pose}: {} reflective pixels ({} mirror, {} glossy, {} rough, {} near the border); {}",
                f.reflective,
                f.classes[0],
                f.classes[1],
                f.classes[2],
                f.border,
                plan::describe(&p)
            );
            for &budget in &budgets {
                let c = planned::choose(&scene, &g, &caps, &table, budget)?;
                let _ = write!(
                    out,
                    "    {}: {}\n{}",
                    planned::budget_label(budget),
                    planned::describe_budget(&c),
                    planned::describe_choices(&scene, &cal, &c, "      - ")
                );
            }
        }
    }
    Ok(out)
}

/// A scene loaded, its BVH built and its frames' G-buffers rendered: what
/// the report knows of it before any method runs.
struct Loaded {
    label: String,
    scene: Scene,
    tracer: Tracer,
    /// (camera pose, G-buffer, G-buffer time in ms) per frame.
    frames: Vec<(usize, GBuffer, f64)>,
    /// The settings each applicable per-frame method runs.
    plans: Vec<(&'static str, Vec<Box<dyn Setting>>)>,
    /// The studies that apply.
    studies: Vec<usize>,
    /// The methods selected on this scene ([`DEFAULT_RUN_ONLY`]).
    selected: Vec<&'static str>,
    /// Scene notes of `summary.md` so far.
    notes: String,
}

/// Everything the report writes, gathered over the scenes.
#[derive(Default)]
struct Gathered {
    rows: Vec<Row>,
    notes: String,
    sections: String,
}

/// The run's pools, threads and output folder.
struct Run<'a> {
    sizes: Sizes,
    threads: usize,
    pool: rayon::ThreadPool,
    pool_1t: rayon::ThreadPool,
    images: PathBuf,
    bar: &'a ProgressBar,
}

/// Runs the report and returns the folder it wrote.
///
/// Per scene, what runs is decided by the scene's content ([`Content`]):
/// every selected per-frame method ([`methods::Method`]) whose settings the
/// content allows, then every study ([`studies::Study`]) that applies; the
/// rest is listed in `summary.md` with the reason. The bar counts the
/// passes of every scene, known once all scenes are loaded, and estimates
/// the time left.
///
/// # Errors
/// A message for an unknown scene or method, an unreadable OBJ, or an I/O
/// failure while writing the report.
pub fn run(opts: &Options) -> Result<PathBuf, String> {
    let sizes = Sizes::of(opts);
    let scenes = scene_names(opts)?;
    let selected = selected_methods(opts)?;
    let input = SceneInput::of(opts)?;
    let threads = opts
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    let pool_of = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| e.to_string())
    };
    let out = opts.out.clone();
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{bar:30}] {pos}/{len} (about {eta} left) {msg}",
        )
        .map_err(|e| e.to_string())?
        .progress_chars("=> "),
    );
    let run = Run {
        sizes,
        threads,
        pool: pool_of(threads)?,
        pool_1t: pool_of(1)?,
        images: out.join("images"),
        bar: &bar,
    };
    std::fs::create_dir_all(&run.images).map_err(|e| format!("{}: {e}", run.images.display()))?;
    let methods: Vec<Box<dyn methods::Method>> = methods::all()
        .into_iter()
        .filter(|m| selected.contains(&m.name()))
        .collect();
    let studies: Vec<Box<dyn Study>> = studies::all()
        .into_iter()
        .filter(|s| s.methods().iter().any(|m| selected.contains(m)))
        .collect();

    // Every scene loaded first, so the bar knows the whole run.
    let mut loaded = Vec::with_capacity(scenes.len());
    for name in &scenes {
        let on_scene = scene_methods(opts, name, &selected);
        let restricted = on_scene.len() < selected.len();
        let mut l = load(name, &input, &run, &methods, &studies, on_scene)?;
        if restricted {
            let _ = writeln!(
                l.notes,
                "  - this run measures it with `{}` only (`--scene {name}` or `--long` runs every method)",
                l.selected.join("`, `")
            );
        }
        loaded.push(l);
    }
    bar.set_length(loaded.iter().map(work_of).sum());
    let mut gathered = Gathered::default();
    for l in &loaded {
        run_scene(l, &run, &studies, &l.selected, &mut gathered)?;
    }
    let long_md = long_sections(opts, &selected, &run, &out)?;
    bar.finish_and_clear();
    let elapsed = bar.elapsed().as_secs_f64();
    write(opts, &run, &out, &gathered, &long_md, elapsed)?;
    Ok(out)
}

/// The scenes of `opts` (default: the built-in ones), each known.
fn scene_names(opts: &Options) -> Result<Vec<String>, String> {
    let scenes: Vec<String> = if opts.scene.is_empty() {
        BUILT_IN_SCENES.map(String::from).to_vec()
    } else {
        opts.scene.clone()
    };
    if let Some(bad) = scenes
        .iter()
        .find(|s| !(BUILT_IN_SCENES.contains(&s.as_str()) || s.ends_with(".obj")))
    {
        return Err(format!(
            "unknown scene '{bad}' (room, concave, walkthrough, stage, hall or a .obj path)"
        ));
    }
    Ok(scenes)
}

/// The methods of `opts` (default: all), each known.
fn selected_methods(opts: &Options) -> Result<Vec<&'static str>, String> {
    if opts.method.is_empty() {
        return Ok(METHODS.to_vec());
    }
    opts.method
        .iter()
        .map(|name| {
            METHODS
                .iter()
                .find(|k| **k == name.as_str())
                .copied()
                .ok_or(format!(
                    "unknown method '{name}' (known: {})",
                    METHODS.join(", ")
                ))
        })
        .collect()
}

/// Loads scene `name`, builds its BVH, renders its frames' G-buffers and
/// decides from their content what runs on it (of the methods `selected`
/// on it).
fn load(
    name: &str,
    input: &SceneInput,
    run: &Run<'_>,
    methods: &[Box<dyn methods::Method>],
    studies: &[Box<dyn Study>],
    selected: Vec<&'static str>,
) -> Result<Loaded, String> {
    let sizes = &run.sizes;
    run.bar.set_message(format!("{name}: scene + BVH"));
    let scene = input.load(name, sizes)?;
    let label = scene.name.clone();
    let tracer = Tracer::new(&scene);
    let poses = frame_poses(scene.camera_path.len(), sizes.frames);
    let mut notes = String::new();
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
    for line in &scene.load_notes {
        let _ = writeln!(notes, "  - {line}");
    }
    // G-buffers of every frame first: which passes the scene needs is
    // decided over all its frames, so every row pools the same frames.
    let mut frames = Vec::with_capacity(poses.len());
    for &pose in &poses {
        let camera = scene
            .camera(pose, sizes.width, sizes.height)
            .map_err(|e| format!("{label}: camera: {e}"))?;
        let g = timed(|| GBuffer::render(&scene, &tracer, &camera, &run.pool));
        let p = plan::plan_frame(&scene, &g.value, &plan::REPORT_HOST)?;
        let _ = writeln!(
            notes,
            "  - pose {pose}, refl-core's plan (`refl plan`): {}",
            plan::describe(&p)
        );
        frames.push((pose, g.value, g.ms));
    }
    let content = Content::of_scene(&scene, &tracer, frames.iter().map(|f| &f.1));
    let _ = writeln!(
        notes,
        "  - content over the frames: {} reflective pixels ({} glossy, {} planar mirror), {} objects to map, \
         camera path of {} poses{}",
        content.reflective_pixels,
        content.glossy_pixels,
        content.planar_mirror_pixels,
        content.reflected_objects,
        content.path_poses,
        if content.interior {
            ", inside walls"
        } else {
            ""
        }
    );
    let mut plans = Vec::new();
    for m in methods.iter().filter(|m| selected.contains(&m.name())) {
        match m.settings(sizes, &content) {
            Ok(v) if !v.is_empty() => plans.push((m.name(), v)),
            Ok(_) => {}
            Err(why) => {
                let _ = writeln!(notes, "  - `{}` skipped: {why}", m.name());
            }
        }
    }
    let mut applicable = Vec::new();
    for (i, s) in studies.iter().enumerate() {
        if !s.methods().iter().any(|m| selected.contains(m)) {
            continue;
        }
        match s.applies(&content) {
            Ok(()) => applicable.push(i),
            Err(why) => {
                let _ = writeln!(notes, "  - {} skipped: {why}", s.name());
            }
        }
    }
    Ok(Loaded {
        label,
        scene,
        tracer,
        frames,
        plans,
        studies: applicable,
        selected,
        notes,
    })
}

/// The bar's units for scene `l`: per frame the ground truth and every
/// setting, and one per study.
fn work_of(l: &Loaded) -> u64 {
    let settings: usize = l.plans.iter().map(|(_, v)| v.len()).sum();
    let per_frame = if settings == 0 { 0 } else { 1 + settings };
    (l.frames.len() * per_frame + l.studies.len()) as u64
}

/// Runs every planned setting on every frame of `l`, then its studies.
fn run_scene(
    l: &Loaded,
    run: &Run<'_>,
    studies: &[Box<dyn Study>],
    selected: &[&str],
    gathered: &mut Gathered,
) -> Result<(), String> {
    let (label, scene, sizes) = (l.label.as_str(), &l.scene, &run.sizes);
    let start = std::time::Instant::now();
    let shader = Shader::new(scene, &l.tracer);
    let mut notes = l.notes.clone();
    // (method, setting) -> sums over frames, in first-seen order.
    let mut accums: Vec<((&str, String), Accum)> = Vec::new();
    // Layered maps are built once per scene and setting (static objects).
    let mut layered_maps = Vec::new();
    for (index, (pose, g, gbuffer_ms)) in l.frames.iter().enumerate() {
        if l.plans.is_empty() {
            break;
        }
        let pose = *pose;
        let frame_content = Content::of_frame(scene, g);
        let reflective = g.reflective_mask();
        let n_reflective = frame_content.reflective_pixels;
        run.bar.set_message(format!(
            "{label} pose {pose}: ground truth ({} spp)",
            sizes.truth_samples
        ));
        let truth = render::Method::Reference {
            samples: sizes.truth_samples,
        };
        let (truth_img, truth_ms) =
            methods::median_run(sizes.runs, || truth.run(&shader, g, &run.pool))
                .map_err(|e| e.to_string())?;
        let direct = direct_image(&shader, g, &run.pool);
        let truth_final = composite(g, &direct, &truth_img);
        let mut frame = Frame::new(
            label,
            scene,
            &l.tracer,
            &shader,
            g,
            &direct,
            index,
            sizes,
            (&run.pool, &run.pool_1t),
            &run.images,
            &mut notes,
            &mut layered_maps,
        );
        if index == 0 {
            frame.save("reference", &truth_final)?;
        }
        run.bar.inc(1);
        let _ = writeln!(
            frame.notes,
            "  - pose {pose}: G-buffer {gbuffer_ms:.1} ms, {n_reflective} reflective pixels ({} glossy, {} planar mirror); \
             ground truth {truth_ms:.1} ms",
            frame_content.glossy_pixels, frame_content.planar_mirror_pixels
        );
        for (method, settings) in &l.plans {
            for setting in settings {
                run.bar
                    .set_message(format!("{label} pose {pose}: {method} {}", setting.label()));
                let r = setting.run(&mut frame)?;
                // The reference on exactly the handled pixels, same threads.
                let reference_ms = if r.image.handled_count() == n_reflective {
                    truth_ms
                } else {
                    methods::median_run(sizes.runs, || {
                        Ok::<_, String>(timed(|| {
                            render::reference_masked(
                                &shader,
                                g,
                                sizes.truth_samples,
                                &r.image.handled,
                                &run.pool,
                            )
                        }))
                    })?
                    .1
                };
                let method_final = composite(g, &direct, &r.image);
                let err = compare(&truth_final, &method_final, &r.image.handled);
                if index == 0 {
                    let stem = format!("{method}_{}", methods::file_stem(setting.label()));
                    frame.save(&stem, &method_final)?;
                    frame.save(
                        &format!("{stem}_diff"),
                        &diff_image(&truth_final, &method_final, &r.image, &reflective),
                    )?;
                }
                let key = (*method, setting.label().to_owned());
                let i = match accums.iter().position(|(k, _)| *k == key) {
                    Some(i) => i,
                    None => {
                        accums.push((key, Accum::default()));
                        accums.len() - 1
                    }
                };
                accums[i]
                    .1
                    .add(r.ms, reference_ms, n_reflective, &err, &r.extra);
                run.bar.inc(1);
            }
        }
    }
    gathered.rows.extend(
        accums
            .iter()
            .map(|((m, setting), a)| a.row(label, m, setting, run.threads)),
    );
    let scene_run = SceneRun {
        label,
        scene,
        tracer: &l.tracer,
        shader: &shader,
        sizes,
        threads: run.threads,
        pool: &run.pool,
        images: &run.images,
    };
    let per_frame_s = start.elapsed().as_secs_f64();
    let mut study_s = Vec::new();
    for &i in &l.studies {
        let study = &studies[i];
        run.bar.set_message(format!("{label}: {}", study.name()));
        let t = std::time::Instant::now();
        let out = study.run(&scene_run, selected)?;
        let ran = !(out.rows.is_empty() && out.notes.is_empty() && out.section.is_empty());
        if !ran {
            // Nothing at this level (a `--long`-only study).
            run.bar.inc(1);
            continue;
        }
        study_s.push(format!(
            "{} {:.0} s",
            study.name(),
            t.elapsed().as_secs_f64()
        ));
        gathered.rows.extend(out.rows);
        notes.push_str(&out.notes);
        gathered.sections.push_str(&out.section);
        run.bar.inc(1);
    }
    let _ = writeln!(
        notes,
        "  - run time: per-frame methods {per_frame_s:.0} s{}{}",
        if study_s.is_empty() { "" } else { ", " },
        study_s.join(", ")
    );
    gathered.notes.push_str(&notes);
    Ok(())
}

/// The long study's sections (`--long`, or `--growth` given): cost growth of
/// the depth-image kernels and of the cluster method with the triangle
/// count (seed 003 Tables 3..7: the pipeline against ray tracing with a BVH
/// rebuild per frame).
fn long_sections(
    opts: &Options,
    selected: &[&str],
    run: &Run<'_>,
    out: &Path,
) -> Result<String, String> {
    let (sizes, threads, pool) = (&run.sizes, run.threads, &run.pool);
    let growth_sizes: Vec<usize> = if opts.growth.is_empty() {
        if opts.long {
            vec![10_000, 100_000, 1_000_000]
        } else {
            Vec::new()
        }
    } else {
        opts.growth.iter().copied().filter(|&n| n > 0).collect()
    };
    if growth_sizes.is_empty() {
        return Ok(String::new());
    }
    let mut md = String::new();
    if selected
        .iter()
        .any(|m| matches!(*m, "reference" | "step" | "hiz" | "layered"))
    {
        run.bar.set_message("cost growth");
        let rows =
            crate::growth::measure(&growth_sizes, sizes.width, sizes.height, sizes.runs, pool)?;
        let path = out.join("growth.csv");
        crate::growth::write_csv(&path, &rows).map_err(|e| format!("{}: {e}", path.display()))?;
        let _ = write!(
            md,
            "\n## Cost growth (room, camera pose 0, {threads} thread(s), reversed-Z)\n\nTimes per frame for all \
             reflection rays; the screen-space kernels exclude producing the depth buffer, `build+obvhs` is what a \
             dynamic scene pays per frame with a BVH. Also in `growth.csv`.\n\n{}",
            crate::growth::markdown(&rows)
        );
    }
    if selected.contains(&"cluster") {
        run.bar.set_message("cluster cost growth");
        let settings = crate::cluster::ClusterSettings::default();
        let rows = crate::cluster::growth(
            &growth_sizes,
            sizes.width,
            sizes.height,
            sizes.runs,
            &settings,
            pool,
        )?;
        let path = out.join("growth_cluster.csv");
        crate::cluster::write_growth_csv(&path, &rows)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        let table = crate::cluster::growth_markdown(&rows);
        print!("{table}");
        let _ = write!(
            md,
            "\n## Cluster method against ray tracing with a BVH rebuild (room, camera pose 0, {threads} thread(s), \
             `{}`)\n\nOne frame: the BVH build a dynamic scene pays every frame plus the ray-traced reflection pass \
             (obvhs, {} rays per glossy pixel), against the cluster pipeline's stages. Shadows are off in both, so \
             that shading needs no BVH. Error against the reference at 64 glossy samples. Also in \
             `growth_cluster.csv`.\n\n{table}",
            settings.label(),
            settings.glossy_rays
        );
    }
    Ok(md)
}

/// Writes `summary.csv`, the plot and `summary.md`, and prints the table.
fn write(
    opts: &Options,
    run: &Run<'_>,
    out: &Path,
    g: &Gathered,
    long_md: &str,
    elapsed_s: f64,
) -> Result<(), String> {
    let sizes = &run.sizes;
    let csv = out.join("summary.csv");
    report_out::write_csv(&csv, &g.rows).map_err(|e| format!("{}: {e}", csv.display()))?;
    let plot = out.join("error_vs_time.png");
    report_out::plot_error_vs_time(&plot, &g.rows)
        .map_err(|e| format!("{}: {e}", plot.display()))?;
    let md = format!(
        "# refl report\n\n{} run, {} thread(s), {} frame(s) per scene, {elapsed_s:.0} s in all. Time is the reflection pass only \
         (median of {} runs, mean over frames); `reference_ms` is the ray-traced reference (obvhs) on the same \
         pixels in the same run, same threads. Error is measured against the ground truth (the reference at {} \
         glossy samples per pixel) on the pixels each method handles, pooled over frames: mean absolute difference \
         on 0..255 of 8-bit sRGB composites, PSNR, share of pixels over 8/255. Images: the first frame. What runs \
         on a scene follows from its content (reflective, glossy and planar-mirror pixels, objects to map, a \
         camera path inside walls); what does not is listed with the reason.\n\n\
         ## Scenes\n\n{}\n## Summary\n\n{}\n![error vs time](error_vs_time.png)\n{}{}{long_md}",
        if opts.quick {
            "Quick"
        } else if opts.long {
            "Long"
        } else {
            "Default"
        },
        run.threads,
        sizes.frames,
        sizes.runs,
        sizes.truth_samples,
        g.notes,
        report_out::markdown_table(&g.rows),
        planned::dominance_section(&g.rows),
        g.sections,
    );
    let md_path = out.join("summary.md");
    std::fs::write(&md_path, md).map_err(|e| format!("{}: {e}", md_path.display()))?;
    print!("{}", report_out::markdown_table(&g.rows));
    Ok(())
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
