//! `refl report`: every method at several settings on the built-in scenes,
//! as points of an error-vs-time curve measured against the ray-traced
//! reference (obvhs) in the same run, same threads.
//!
//! Per scene: build the BVH, render the G-buffer of the first camera pose,
//! compute the ground truth (the reference at [`Sizes::truth_samples`] glossy
//! samples), then time each method's reflection pass (median of
//! [`Sizes::runs`]) and measure its error on the pixels it handles. The
//! reference time of a row is the ground-truth pass restricted to the same
//! pixels (so a method that handles planar mirrors only is compared with
//! tracing those mirrors only).

use crate::render::{self, compare, composite, direct_image, Method, ReflectionImage};
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
            }
        } else {
            Sizes {
                width: 512,
                height: 384,
                tris: 150_000,
                truth_samples: 512,
                reference_samples: &[4, 16, 64, 256],
                runs: 3,
            }
        }
    }
}

/// Every method name the report knows, in report order.
pub const METHODS: [&str; 3] = ["reference", "envmap", "planar-mirror"];

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
        ["room", "concave", "walkthrough"]
            .map(String::from)
            .to_vec()
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

    // The length grows per scene once its frame says which passes it needs.
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .map_err(|e| e.to_string())?
            .progress_chars("=> "),
    );

    let mut rows = Vec::new();
    let mut notes = String::new();
    for scene_name in &scenes {
        bar.inc_length(2);
        bar.set_message(format!("{scene_name}: scene + BVH"));
        let scene = load_scene(scene_name, opts, &sizes)?;
        let label = scene.name.clone();
        let tracer = Tracer::new(&scene);
        let shader = Shader::new(&scene, &tracer);
        let camera = scene
            .camera(0, sizes.width, sizes.height)
            .map_err(|e| format!("{label}: camera: {e}"))?;
        let g = timed(|| GBuffer::render(&scene, &tracer, &camera, &pool));
        let (g, gbuffer_ms) = (g.value, g.ms);
        let reflective = g.reflective_mask();
        let n_reflective = reflective.iter().filter(|&&r| r).count();
        let n_glossy = (0..g.len())
            .filter(|&i| reflective[i] && g.roughness[i] > 0.0)
            .count();
        bar.inc(1);

        bar.set_message(format!(
            "{label}: ground truth ({} spp)",
            sizes.truth_samples
        ));
        let truth = Method::Reference {
            samples: sizes.truth_samples,
        };
        let truth_runs: Vec<_> = (0..sizes.runs)
            .map(|_| truth.run(&shader, &g, &pool))
            .collect::<Result<_, _>>()
            .map_err(|e| e.to_string())?;
        let truth_ms = median(truth_runs.iter().map(|t| t.ms).collect());
        let truth_img = truth_runs
            .into_iter()
            .next()
            .map(|t| t.value)
            .expect("runs >= 1");
        let direct = direct_image(&shader, &g, &pool);
        let truth_final = composite(&g, &direct, &truth_img);
        save(
            &images.join(format!("{label}_reference.png")),
            &g,
            &truth_final,
        )?;
        bar.inc(1);
        let _ = writeln!(
            notes,
            "- `{label}`: {} triangles, BVH build {:.1} ms, G-buffer {:.1} ms, {}x{} pixels, {} reflective ({} glossy); \
             ground truth: reference with {} glossy spp, {:.1} ms",
            scene.tri_count(),
            tracer.build_ms(),
            gbuffer_ms,
            g.width(),
            g.height(),
            n_reflective,
            n_glossy,
            sizes.truth_samples,
            truth_ms
        );

        let needs = FrameNeeds::of(&scene, &g);
        for method_name in &methods {
            let runs_of = match settings(method_name, &sizes, needs) {
                Ok(s) => s,
                Err(why) => {
                    let _ = writeln!(notes, "  - `{method_name}` skipped on `{label}`: {why}");
                    continue;
                }
            };
            bar.inc_length(runs_of.len() as u64);
            for (method, setting) in runs_of {
                bar.set_message(format!("{label}: {method_name} {setting}"));
                let runs: Vec<_> = (0..sizes.runs)
                    .map(|_| method.run(&shader, &g, &pool))
                    .collect::<Result<_, _>>()
                    .map_err(|e| e.to_string())?;
                let ms = median(runs.iter().map(|t| t.ms).collect());
                let img = runs.into_iter().next().map(|t| t.value).expect("runs >= 1");
                let handled = img.handled_count();
                // The reference on exactly the handled pixels, same threads.
                let reference_ms = if handled == n_reflective {
                    truth_ms
                } else {
                    median(
                        (0..sizes.runs)
                            .map(|_| {
                                timed(|| {
                                    render::reference_masked(
                                        &shader,
                                        &g,
                                        sizes.truth_samples,
                                        &img.handled,
                                        &pool,
                                    )
                                })
                                .ms
                            })
                            .collect(),
                    )
                };
                let method_final = composite(&g, &direct, &img);
                let err = compare(&truth_final, &method_final, &img.handled);
                let stem = format!(
                    "{label}_{method_name}_{}",
                    setting.replace(['=', ';', '/'], "-")
                );
                save(&images.join(format!("{stem}.png")), &g, &method_final)?;
                save(
                    &images.join(format!("{stem}_diff.png")),
                    &g,
                    &diff_image(&truth_final, &method_final, &img, &reflective),
                )?;
                rows.push(Row {
                    scene: label.clone(),
                    method: method_name.to_string(),
                    setting,
                    threads,
                    time_ms: ms,
                    reference_ms,
                    speedup: if ms > 0.0 {
                        reference_ms / ms
                    } else {
                        f64::INFINITY
                    },
                    coverage: if n_reflective > 0 {
                        handled as f64 / n_reflective as f64
                    } else {
                        0.0
                    },
                    mean_abs_255: err.mean_abs,
                    psnr_db: err.psnr,
                    share_over_8: err.share_over_8(),
                    extra: vec![("max_abs_255".into(), err.max_abs.to_string())],
                });
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();

    let csv = out.join("summary.csv");
    report_out::write_csv(&csv, &rows).map_err(|e| format!("{}: {e}", csv.display()))?;
    let plot = out.join("error_vs_time.png");
    report_out::plot_error_vs_time(&plot, &rows).map_err(|e| format!("{}: {e}", plot.display()))?;
    let md = format!(
        "# refl report\n\n{} run, {threads} thread(s). Time is the reflection pass only (median of {}); \
         `reference_ms` is the ray-traced reference (obvhs) on the same pixels in the same run. \
         Error is measured against the ground truth on the pixels each method handles \
         (mean absolute difference on 0..255 of 8-bit sRGB composites, PSNR, share of pixels over 8/255).\n\n\
         ## Scenes\n\n{notes}\n## Summary\n\n{}\n![error vs time](error_vs_time.png)\n",
        if opts.quick { "Quick" } else { "Default" },
        sizes.runs,
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
