//! The report's `planned` method (issue 15, part 4): per budget, refl-core's
//! planner ([`refl_core::plan::try_choose_methods`]) chooses from the
//! checked-in calibration table ([`crate::calibration`]) one technique per
//! reflector and roughness class of the frame; the row runs exactly those
//! techniques on exactly those pixels, each technique once on the union of
//! the groups that chose it (its time and error are measured, not
//! predicted), and prints the model's prediction next to them, with the
//! passes the choice runs and skips and the bytes of their buffers.

use super::accum::Extra;
use super::methods::{median_run, Frame, FrameRun, Method, Setting};
use super::plan::{self, FramePlan, REPORT_HOST};
use super::{content::Content, Sizes};
use crate::calibration::{class_name, Calibration, Technique};
use crate::gbuffer::GBuffer;
use crate::render::{self, timed, ReflectionImage};
use crate::scene::Scene;
use refl_core::plan::{
    choices_len, try_choose_methods, try_chosen_passes, Budget, BudgetPlan, Choice, ChoiceReason,
    CostEntry, HostCaps, PassPlan,
};
use refl_core::summary::{RoughnessClass, NO_OBJECT};
use std::fmt::Write as _;
use std::rc::Rc;

/// The budgets of the `planned` rows: the mirror target (0.5/255),
/// a looser error, and a time limit below one ray per reflective pixel.
pub const BUDGETS: [Budget; 3] = [
    Budget::MaxError(0.5),
    Budget::MaxError(4.0),
    Budget::MaxTime(0.5),
];

/// The budgets of `--max-error` and `--max-time` values (in that order).
///
/// # Errors
/// A message naming a value that is NaN, infinite or negative.
pub fn budgets_of(max_error: &[f32], max_time: &[f32]) -> Result<Vec<Budget>, String> {
    let check = |flag: &str, v: f32| {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(format!(
                "{flag} {v}: a budget must be a finite number at least 0"
            ))
        }
    };
    let mut out = Vec::new();
    for &v in max_error {
        check("--max-error", v)?;
        out.push(Budget::MaxError(v));
    }
    for &v in max_time {
        check("--max-time", v)?;
        out.push(Budget::MaxTime(v));
    }
    Ok(out)
}

/// A budget as a setting label (`max_error=0.5`, `max_time=0.5`).
pub fn budget_label(b: Budget) -> String {
    match b {
        Budget::MaxError(v) => format!("max_error={v}"),
        Budget::MaxTime(v) => format!("max_time={v}"),
    }
}

/// A technique's run on the groups that chose it: the technique and the
/// (object, class) of each group, in choice order.
type RunKey = (Technique, Vec<(u32, RoughnessClass)>);

/// What a frame's planned settings share: the time unit and the runs of
/// each technique on its groups, so that budgets choosing the same
/// technique for the same groups run it once per frame.
#[derive(Default)]
pub struct Cache {
    /// The reference tracer at one ray on every reflective pixel, ms
    /// (median).
    unit_ms: Option<f64>,
    /// (technique, groups) -> its image and time.
    runs: Vec<(RunKey, (ReflectionImage, f64))>,
}

/// A frame's choice for one budget: the plan, the choices and the passes.
pub struct Planned {
    /// The frame's summary and base plan.
    pub frame: FramePlan,
    /// The prediction.
    pub budget: BudgetPlan,
    /// One per group.
    pub choices: Vec<Choice>,
    /// The passes the choice runs and skips.
    pub passes: PassPlan,
}

/// Chooses the techniques of `g` (a frame of `scene`, a host with `caps`)
/// for `budget` from
/// `table` (the calibration's [`Calibration::cost_table`]).
///
/// # Errors
/// refl-core's refusal of the table or budget, as text.
pub fn choose(
    scene: &Scene,
    g: &GBuffer,
    caps: &HostCaps,
    table: &[CostEntry],
    budget: Budget,
) -> Result<Planned, String> {
    let frame = plan::plan_frame(scene, g, caps)?;
    let mut choices = vec![Choice::default(); choices_len(frame.objects.len())];
    let bp = try_choose_methods(
        &mut choices,
        &frame.frame,
        &frame.objects,
        &frame.planar_flags,
        &frame.hints,
        caps,
        table,
        budget,
    )
    .map_err(|e| format!("{}: planner ({}): {e}", scene.name, budget_label(budget)))?;
    choices.truncate(bp.groups);
    let passes = try_chosen_passes(&frame.plan, &choices, table, (g.width(), g.height()))
        .map_err(|e| format!("{}: planner: {e}", scene.name))?;
    Ok(Planned {
        frame,
        budget: bp,
        choices,
        passes,
    })
}

/// The name of a group's object.
fn object_name(scene: &Scene, object: u32) -> String {
    if object == NO_OBJECT {
        "unlisted objects".into()
    } else {
        scene
            .objects
            .get(object as usize)
            .map_or_else(|| format!("object {object}"), |o| o.name.clone())
    }
}

/// `label (time x, error/255)` of table entry `k`.
fn option_text(cal: &Calibration, k: usize) -> String {
    let e = &cal.entries[k];
    format!(
        "{} ({:.2}x, {:.2}/255)",
        e.technique.label(),
        e.time_ratio,
        e.error_255
    )
}

/// Why `ch` got its option, in words.
pub fn reason_text(cal: &Calibration, ch: &Choice) -> String {
    let mut s = match ch.reason {
        ChoiceReason::Fastest => "the fastest option on its front, and the budget holds".to_owned(),
        ChoiceReason::TradeOff => "the budget's trade-off".to_owned(),
        ChoiceReason::MostAccurate => {
            "the most accurate option on its front, within the budget".to_owned()
        }
        ChoiceReason::ErrorBudgetUnreachable => {
            "the error budget cannot be met: the most accurate option".to_owned()
        }
        ChoiceReason::TimeBudgetUnreachable => {
            "the time budget cannot be met: the fastest option".to_owned()
        }
        ChoiceReason::OnlyOption => "the only option on its front".to_owned(),
        ChoiceReason::NoOption => {
            "no calibrated option applies: its pixels are left out".to_owned()
        }
    };
    if let Some(f) = ch.faster {
        let _ = write!(s, "; the faster {} is not taken", option_text(cal, f));
    }
    if let Some(a) = ch.more_accurate {
        let _ = write!(
            s,
            "; the more accurate {} is not taken",
            option_text(cal, a)
        );
    }
    if ch.applicable > ch.front {
        let _ = write!(
            s,
            "; {} of {} options that apply are dominated",
            ch.applicable - ch.front,
            ch.applicable
        );
        if let Some(e) = ch.entry {
            let chosen = &cal.cost_table()[e];
            if chosen.is_ray_traced() {
                s.push_str(" (plain ray tracing is at least as fast and as accurate as them)");
            }
        }
    }
    s
}

/// One line per group: the object, its class, the chosen technique and
/// the reason.
pub fn describe_choices(scene: &Scene, cal: &Calibration, p: &Planned, indent: &str) -> String {
    let mut s = String::new();
    for ch in &p.choices {
        let g = ch.group;
        let _ = writeln!(
            s,
            "{indent}{} ({} pixels, {}{}): {}: {}",
            object_name(scene, g.object),
            g.pixels,
            class_name(g.class),
            if g.planar { ", planar" } else { "" },
            ch.entry
                .map_or_else(|| "nothing".to_owned(), |k| option_text(cal, k)),
            reason_text(cal, ch)
        );
    }
    s
}

/// One line: the prediction and the passes.
pub fn describe_budget(p: &Planned) -> String {
    let (run, skip) = p.passes.counts();
    let b = &p.budget;
    format!(
        "predicted {:.3}x the reference tracer's time for one ray per reflective pixel, {:.2}/255 over {} of {} \
         reflective pixels (budget {}); passes: {run} run, {skip} skipped; {:.2} MB of pyramids",
        b.time_ratio,
        b.error_255,
        b.covered,
        b.reflective,
        if b.met { "met" } else { "not met" },
        p.passes.bytes() as f64 / 1e6
    )
}

/// Sums over frames of a `planned` row.
#[derive(Clone, Debug, Default)]
pub struct PlannedAccum {
    frames: usize,
    /// The reference tracer at one ray per reflective pixel, ms.
    unit_ms: f64,
    /// The row's measured time, ms.
    ms: f64,
    /// Predicted time, ms (the predicted ratio times the frame's unit).
    predicted_ms: f64,
    /// Predicted error times covered pixels.
    predicted_abs: f64,
    covered: u64,
    met: usize,
    passes_run: usize,
    passes_skipped: usize,
    bytes: usize,
}

impl PlannedAccum {
    /// Adds `o`.
    pub fn add(&mut self, o: &PlannedAccum) {
        self.frames += o.frames;
        self.unit_ms += o.unit_ms;
        self.ms += o.ms;
        self.predicted_ms += o.predicted_ms;
        self.predicted_abs += o.predicted_abs;
        self.covered += o.covered;
        self.met += o.met;
        self.passes_run += o.passes_run;
        self.passes_skipped += o.passes_skipped;
        self.bytes += o.bytes;
    }

    /// Its columns.
    pub fn columns(&self) -> Vec<(String, String)> {
        let f = self.frames.max(1) as f64;
        let unit = self.unit_ms.max(f64::MIN_POSITIVE);
        vec![
            ("ray_ms".into(), format!("{:.4}", self.unit_ms / f)),
            ("time_x".into(), format!("{:.4}", self.ms / unit)),
            (
                "predicted_time_x".into(),
                format!("{:.4}", self.predicted_ms / unit),
            ),
            (
                "predicted_ms".into(),
                format!("{:.4}", self.predicted_ms / f),
            ),
            (
                "predicted_mean_abs_255".into(),
                format!("{:.4}", self.predicted_abs / self.covered.max(1) as f64),
            ),
            ("budget_met".into(), format!("{}/{}", self.met, self.frames)),
            (
                "passes_run".into(),
                format!("{:.1}", self.passes_run as f64 / f),
            ),
            (
                "passes_skipped".into(),
                format!("{:.1}", self.passes_skipped as f64 / f),
            ),
            (
                "pyramid_bytes".into(),
                format!("{:.0}", self.bytes as f64 / f),
            ),
        ]
    }
}

/// The `planned` method: one setting per budget of [`BUDGETS`].
pub struct PlannedMethod;

impl Method for PlannedMethod {
    fn name(&self) -> &'static str {
        "planned"
    }

    fn settings(&self, _: &Sizes, content: &Content) -> Result<Vec<Box<dyn Setting>>, String> {
        if content.reflective_pixels == 0 {
            return Err("no reflective pixels in view".into());
        }
        let cal = Rc::new(Calibration::builtin()?);
        Ok(BUDGETS
            .iter()
            .map(|&budget| {
                Box::new(PlannedSetting {
                    cal: Rc::clone(&cal),
                    budget,
                    label: budget_label(budget),
                }) as Box<dyn Setting>
            })
            .collect())
    }
}

/// One budget.
struct PlannedSetting {
    cal: Rc<Calibration>,
    budget: Budget,
    label: String,
}

impl Setting for PlannedSetting {
    fn label(&self) -> &str {
        &self.label
    }

    fn run(&self, f: &mut Frame<'_>) -> Result<FrameRun, String> {
        let (g, shader, pool, runs) = (f.g, f.shader, f.pool, f.sizes.runs);
        let table = self.cal.cost_table();
        let p = choose(f.scene, g, &REPORT_HOST, &table, self.budget)?;
        let _ = write!(
            f.notes,
            "  - frame {}, `planned` {}: {}\n{}",
            f.index,
            self.label,
            describe_budget(&p),
            describe_choices(f.scene, &self.cal, &p, "    - ")
        );
        let cache = &mut f.planned;
        let unit_ms = match cache.unit_ms {
            Some(ms) => ms,
            None => {
                let all = g.reflective_mask();
                let (_, ms) = median_run(runs, || {
                    Ok::<_, String>(timed(|| render::reference_masked(shader, g, 1, &all, pool)))
                })?;
                cache.unit_ms = Some(ms);
                ms
            }
        };
        let n_objects = p.frame.objects.len();
        let group_of = |i: usize| -> (u32, RoughnessClass) {
            let o = g.object[i];
            (
                if (o as usize) < n_objects {
                    o
                } else {
                    NO_OBJECT
                },
                p.frame.options.class(g.roughness[i]),
            )
        };
        // Each chosen technique runs once on the union of its groups'
        // pixels, as a host runs a pass once per frame (the planar pass
        // renders every chosen planar reflector in one call; one ray
        // tracing run covers every group that chose rays at that sample
        // count).
        let mut chosen: Vec<RunKey> = Vec::new();
        for ch in &p.choices {
            let Some(k) = ch.entry else { continue };
            let t = self.cal.entries[k].technique;
            let group = (ch.group.object, ch.group.class);
            match chosen.iter_mut().find(|(rt, _)| *rt == t) {
                Some((_, groups)) => groups.push(group),
                None => chosen.push((t, vec![group])),
            }
        }
        let mut image = ReflectionImage::empty(g.width(), g.height());
        let mut ms = 0.0;
        for key in chosen {
            let t = key.0;
            let mask: Vec<bool> = (0..g.len())
                .map(|i| g.is_reflective(i) && key.1.contains(&group_of(i)))
                .collect();
            let i = match cache.runs.iter().position(|(k, _)| *k == key) {
                Some(i) => i,
                None => {
                    let (img, ms) = median_run(runs, || t.run(shader, g, f.direct, &mask, pool))?;
                    cache.runs.push((key, (img, ms)));
                    cache.runs.len() - 1
                }
            };
            let (img, run_ms) = &cache.runs[i].1;
            ms += run_ms;
            for (j, &m) in mask.iter().enumerate() {
                if m && img.handled[j] {
                    image.rgb[j] = img.rgb[j];
                    image.handled[j] = true;
                }
            }
        }
        let (run, skipped) = p.passes.counts();
        let b = p.budget;
        let accum = PlannedAccum {
            frames: 1,
            unit_ms,
            ms,
            predicted_ms: b.time_ratio * unit_ms,
            predicted_abs: b.error_255 * b.covered as f64,
            covered: b.covered,
            met: usize::from(b.met),
            passes_run: run,
            passes_skipped: skipped,
            bytes: p.passes.bytes(),
        };
        Ok(FrameRun {
            image,
            ms,
            extra: Extra::Planned(accum),
        })
    }
}

/// The per-frame methods whose rows are measured on the same frames and
/// pixels as the `planned` rows (the studies run other frames: camera
/// paths, glossy variants, primary visibility).
pub const SAME_FRAMES: [&str; 7] = [
    "reference",
    "envmap",
    "planar-mirror",
    "step",
    "hiz",
    "layered",
    "cluster",
];

/// `summary.md`'s section: per scene, every row of a per-frame method
/// ([`SAME_FRAMES`]) that dominates a planned row (covers at least as many
/// reflective pixels, is faster and lower in error), by how much; or that
/// none does.
pub fn dominance_section(rows: &[crate::report_out::Row]) -> String {
    let planned: Vec<_> = rows.iter().filter(|r| r.method == "planned").collect();
    if planned.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\n## Planned rows against the other rows\n\nA row dominates a `planned` row when it covers at least as many \
         reflective pixels and is both faster and lower in error (`mean_abs_255`). Compared: the rows of the per-frame \
         methods (`reference`, `envmap`, `planar-mirror`, `step`, `hiz`, `layered`, `cluster`), measured on the \
         same frames and pixels; the studies' rows are measured on other frames. Predicted against measured: \
         `predicted_time_x` against `time_x` (time over the reference tracer's for one ray per reflective pixel, \
         `ray_ms`, same frames and run), `predicted_mean_abs_255` against `mean_abs_255`.\n\n",
    );
    let mut scene = "";
    for p in planned {
        if p.scene != scene {
            scene = &p.scene;
            let _ = writeln!(s, "- `{scene}`:");
        }
        let dom: Vec<String> = rows
            .iter()
            .filter(|r| {
                r.scene == p.scene
                    && SAME_FRAMES.contains(&r.method.as_str())
                    && r.coverage >= p.coverage - 1e-9
                    && r.time_ms < p.time_ms
                    && r.mean_abs_255 < p.mean_abs_255
            })
            .map(|r| {
                format!(
                    "`{} {}` ({:.2}x faster, {:.2}/255 lower)",
                    r.method,
                    r.setting,
                    p.time_ms / r.time_ms.max(f64::MIN_POSITIVE),
                    p.mean_abs_255 - r.mean_abs_255
                )
            })
            .collect();
        let _ = writeln!(
            s,
            "  - `planned {}` ({:.1} ms, {:.2}/255, coverage {:.3}): {}",
            p.setting,
            p.time_ms,
            p.mean_abs_255,
            p.coverage,
            if dom.is_empty() {
                "no row dominates it".to_owned()
            } else {
                format!("dominated by {}", dom.join(", "))
            }
        );
    }
    s
}
