//! `refl calibrate`: measures the planner's cost and error model
//! ([`crate::calibration`]) with the report's own machinery (scenes,
//! camera poses, G-buffers, ground truth, error measure and timing) and
//! writes the table with the command and commit that produced it.
//!
//! Per scene and frame: the report's ground truth; the reference tracer at
//! one ray on every reflective pixel (the time unit, median of the run's
//! repetitions); then the reflective pixels split by refl-core's summary
//! into kinds: mirror-class pixels of planar reflectors (the planner's
//! planar objects), mirror-class pixels of the others, and glossy-class
//! (and rough-class) pixels of any surface; on each kind, every candidate
//! technique ([`Technique::candidates`]) is run on exactly those pixels,
//! timed (median of [`CALIBRATION_RUNS`]) and compared with the ground truth. A row pools frames
//! and scenes: the sum of the technique's times over the sum of (unit time
//! per pixel x the kind's pixels) of the same frames, and the
//! pixel-weighted mean error.

use super::{frame_poses, methods::median_run, plan, Options, SceneInput, Sizes};
use crate::calibration::{class_name, surface_name, Calibration, CalibrationEntry, Technique};
use crate::gbuffer::GBuffer;
use crate::render::{self, compare, composite, direct_image, timed};
use crate::shade::Shader;
use crate::tracer::Tracer;
use refl_core::plan::Surface;
use refl_core::summary::RoughnessClass;
use std::path::PathBuf;

/// Timed repetitions of every measurement (the median is kept).
pub const CALIBRATION_RUNS: usize = 9;

/// Command-line options of `refl calibrate`.
#[derive(Clone, Debug, clap::Args)]
pub struct CalibrateArgs {
    /// The report's `--quick` sizes (for development; the checked-in table
    /// is measured at the default sizes).
    #[arg(long)]
    pub quick: bool,
    /// Scenes, as for `refl report` (default: the four built-in scenes).
    #[arg(long)]
    pub scene: Vec<String>,
    /// Where the table is written.
    #[arg(long, default_value = "calibration/default.csv")]
    pub out: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Triangle budget of the built-in scenes (default: the report's).
    #[arg(long)]
    pub tris: Option<usize>,
}

impl CalibrateArgs {
    /// The command line that reproduces this run.
    fn command(&self) -> String {
        let mut c = String::from("cargo run --release -- calibrate");
        if self.quick {
            c.push_str(" --quick");
        }
        for s in &self.scene {
            c.push_str(&format!(" --scene {s}"));
        }
        if self.out != std::path::Path::new("calibration/default.csv") {
            c.push_str(&format!(" --out {}", self.out.display()));
        }
        if let Some(t) = self.threads {
            c.push_str(&format!(" --threads {t}"));
        }
        if let Some(t) = self.tris {
            c.push_str(&format!(" --tris {t}"));
        }
        c
    }
}

/// Sums of one (technique, class, surface) over frames.
#[derive(Default)]
struct Sums {
    ms: f64,
    unit_ms: f64,
    abs: f64,
    pixels: u64,
    frames: u32,
}

/// One line of a command's output, or `unknown`.
fn output_of(cmd: &str, args: &[&str]) -> String {
    std::process::Command::new(cmd)
        .args(args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// The commit the working tree is on, `-dirty` when tracked files differ.
fn commit() -> String {
    let head = output_of("git", &["rev-parse", "HEAD"]);
    let dirty = std::process::Command::new("git")
        .args(["diff", "--quiet", "HEAD", "--", ".", ":!calibration"])
        .status()
        .map(|s| !s.success())
        .unwrap_or(false);
    if dirty {
        format!("{head}-dirty")
    } else {
        head
    }
}

/// The surface kind of a reflective pixel of `class` on object `object`.
fn kind_of(class: RoughnessClass, object: u32, planar: &[bool]) -> Surface {
    match class {
        RoughnessClass::Mirror if planar.get(object as usize).copied().unwrap_or(false) => {
            Surface::Planar
        }
        RoughnessClass::Mirror => Surface::Curved,
        _ => Surface::Any,
    }
}

/// Per reflective pixel of `g`, its class and surface kind (`None`: not
/// reflective), as the planner groups it.
pub fn pixel_kinds(g: &GBuffer, p: &plan::FramePlan) -> Vec<Option<(RoughnessClass, Surface)>> {
    (0..g.len())
        .map(|i| {
            g.is_reflective(i).then(|| {
                let class = p.options.class(g.roughness[i]);
                (class, kind_of(class, g.object[i], &p.planar_flags))
            })
        })
        .collect()
}

/// Runs the calibration and writes the table to `args.out`; returns the
/// table.
///
/// # Errors
/// Bad scene input (as `refl report`), refl-core's errors as text, and a
/// failure to write the table.
pub fn calibrate(args: &CalibrateArgs) -> Result<Calibration, String> {
    let opts = Options {
        quick: args.quick,
        scene: args.scene.clone(),
        tris: args.tris,
        ..Options::default()
    };
    let mut sizes = Sizes::of(&opts);
    // Every time is a median of this many runs (the report's 3 move by
    // +-15% on this shared machine; a calibration run is short).
    sizes.runs = sizes.runs.max(CALIBRATION_RUNS);
    // Without `--scene`: the four built-in scenes of the report's default
    // run, not the hall of mirrors, which a default report measures with
    // its bounce rows only (`DEFAULT_RUN_ONLY`; since the hall joined the
    // built-in scenes, an unfiltered default also calibrated on it).
    let mut scenes = super::scene_names(&opts)?;
    if args.scene.is_empty() {
        scenes.retain(|s| !super::DEFAULT_RUN_ONLY.iter().any(|(n, _)| n == s));
    }
    let input = SceneInput::of(&opts)?;
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| e.to_string())?;
    let start = std::time::Instant::now();
    let mut sums: Vec<((Technique, RoughnessClass, Surface), Sums)> = Vec::new();
    for name in &scenes {
        let scene = input.load(name, &sizes)?;
        let tracer = Tracer::new(&scene);
        let shader = Shader::new(&scene, &tracer);
        for pose in frame_poses(scene.camera_path.len(), sizes.frames) {
            eprintln!("calibrate: {} pose {pose}", scene.name);
            let camera = scene
                .camera(pose, sizes.width, sizes.height)
                .map_err(|e| format!("{}: camera: {e}", scene.name))?;
            let g = GBuffer::render(&scene, &tracer, &camera, &pool);
            let p = plan::plan_frame(&scene, &g, &plan::REPORT_HOST)?;
            let kinds = pixel_kinds(&g, &p);
            let reflective = kinds.iter().filter(|k| k.is_some()).count();
            if reflective == 0 {
                continue;
            }
            let truth = render::reference(&shader, &g, sizes.truth_samples, &pool);
            let direct = direct_image(&shader, &g, &pool);
            let truth_final = composite(&g, &direct, &truth);
            let all: Vec<bool> = kinds.iter().map(Option::is_some).collect();
            let (_, unit_ms) = median_run(sizes.runs, || {
                Ok::<_, String>(timed(|| {
                    render::reference_masked(&shader, &g, 1, &all, &pool)
                }))
            })?;
            let unit_per_pixel = unit_ms / reflective as f64;
            for class in [
                RoughnessClass::Mirror,
                RoughnessClass::Glossy,
                RoughnessClass::Rough,
            ] {
                for surface in [Surface::Planar, Surface::Curved, Surface::Any] {
                    let mask: Vec<bool> =
                        kinds.iter().map(|k| *k == Some((class, surface))).collect();
                    let pixels = mask.iter().filter(|&&m| m).count();
                    if pixels == 0 {
                        continue;
                    }
                    for t in Technique::candidates(class, surface) {
                        let (img, ms) =
                            median_run(sizes.runs, || t.run(&shader, &g, &direct, &mask, &pool))?;
                        let err = compare(&truth_final, &composite(&g, &direct, &img), &mask);
                        let key = (t, class, surface);
                        let i = match sums.iter().position(|(k, _)| *k == key) {
                            Some(i) => i,
                            None => {
                                sums.push((key, Sums::default()));
                                sums.len() - 1
                            }
                        };
                        let s = &mut sums[i].1;
                        s.ms += ms;
                        s.unit_ms += unit_per_pixel * pixels as f64;
                        s.abs += err.mean_abs * err.pixels as f64;
                        s.pixels += err.pixels as u64;
                        s.frames += 1;
                    }
                }
            }
        }
    }
    let entries = sums
        .iter()
        .map(|((technique, class, surface), s)| CalibrationEntry {
            technique: *technique,
            class: *class,
            surface: *surface,
            time_ratio: (s.ms / s.unit_ms.max(f64::MIN_POSITIVE)) as f32,
            error_255: (s.abs / s.pixels.max(1) as f64) as f32,
            pixels: s.pixels,
            frames: s.frames,
        })
        .collect();
    let cal = Calibration {
        command: args.command(),
        commit: commit(),
        notes: vec![
            format!("date: {}", output_of("date", &["-u", "+%Y-%m-%d %H:%M UTC"])),
            format!(
                "sizes: {}x{}, {} triangles, {} frame(s) per scene, ground truth {} glossy spp, median of {} runs, {} thread(s); scenes: {}; {:.0} s",
                sizes.width,
                sizes.height,
                sizes.tris,
                sizes.frames,
                sizes.truth_samples,
                sizes.runs,
                threads,
                scenes.join(", "),
                start.elapsed().as_secs_f64()
            ),
            "time_ratio: the technique's time on the pixels of its class and surface over the reference tracer's \
             time for one ray (obvhs, shaded) per pixel on the same pixels, same frames, same run"
                .into(),
            "error_255: mean absolute error on 0..255 (8-bit sRGB composites) against the report's ground truth on \
             those pixels; planar rows ray trace the pixels the planar render does not cover (inside time and error)"
                .into(),
        ],
        entries,
    };
    let text = cal.to_csv();
    // The table must read back.
    Calibration::parse(&text)?;
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    std::fs::write(&args.out, &text).map_err(|e| format!("{}: {e}", args.out.display()))?;
    Ok(cal)
}

/// The table as a Markdown table (what `refl calibrate` prints).
pub fn markdown(cal: &Calibration) -> String {
    let mut s = String::from("| method | setting | class | surface | time_ratio | error_255 | pixels |\n|---|---|---|---|---|---|---|\n");
    for e in &cal.entries {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.4} | {:.3} | {} |\n",
            e.technique.method(),
            e.technique.setting(),
            class_name(e.class),
            surface_name(e.surface),
            e.time_ratio,
            e.error_255,
            e.pixels
        ));
    }
    s
}
