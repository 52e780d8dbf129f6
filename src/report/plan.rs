//! refl-core's frame planner ([`refl_core::plan`]) on a report frame: one
//! pass of [`refl_core::summary`] over the frame's G-buffer, then
//! [`refl_core::plan::try_plan_passes`] with what the report's host can do
//! (it rasterizes extra views, traces rays with obvhs and has an
//! environment probe) and what it knows of its objects (planar mirrors, the
//! objects with layered maps). `summary.md` lists each frame's passes run
//! and skipped with the reason; `refl plan` prints the same.

use crate::gbuffer::GBuffer;
use crate::scene::Scene;
use crate::screen::{DepthBuffer, PassImages};
use refl_core::plan::{
    try_plan_passes, FrameMotion, HostCaps, ObjectHints, Pass, PassPlan, PlanOptions, SkipReason,
};
use refl_core::summary::{try_summarize_rows, FrameSummary, ObjectSummary, SummaryOptions};
use refl_core::{DepthConvention, ImageView, RowRange};
use std::fmt::Write as _;

/// What the report's host offers the planner: extra views (the CPU
/// rasterizer), a ray tracer (obvhs) and a prefiltered probe.
pub const REPORT_HOST: HostCaps = HostCaps {
    planar_views: true,
    ray_tracer: true,
    probe: true,
};

/// A frame's summary and plan.
pub struct FramePlan {
    /// The frame summary.
    pub frame: FrameSummary,
    /// The plan.
    pub plan: PassPlan,
    /// Names of the objects sent to the planar pass.
    pub planar: Vec<String>,
    /// Per object (at least one entry), its summary.
    pub objects: Vec<ObjectSummary>,
    /// Per object, whether it goes to the planar pass (the planner's
    /// planar groups).
    pub planar_flags: Vec<bool>,
    /// Per object, what the report's host states about it.
    pub hints: Vec<ObjectHints>,
    /// The summary's options (its classes).
    pub options: SummaryOptions,
}

/// Summarizes `g` (a frame of `scene`) and plans its passes for a host
/// with `caps`.
///
/// # Errors
/// refl-core's errors, as text (never for a rendered G-buffer).
pub fn plan_frame(scene: &Scene, g: &GBuffer, caps: &HostCaps) -> Result<FramePlan, String> {
    plan_frame_moving(scene, g, caps, FrameMotion::default())
}

/// [`plan_frame`] for a host that states `motion` (what moved since the
/// last frame; the scenes' objects stand still).
///
/// # Errors
/// As [`plan_frame`].
pub fn plan_frame_moving(
    scene: &Scene,
    g: &GBuffer,
    caps: &HostCaps,
    motion: FrameMotion,
) -> Result<FramePlan, String> {
    let err = |e: refl_core::Error| format!("{}: plan: {e}", scene.name);
    let (w, h) = (g.width(), g.height());
    let depth = DepthBuffer::new(g, DepthConvention::ReversedZ, f32::INFINITY).map_err(err)?;
    let images = PassImages::new(g, None);
    let core_g = images
        .gbuffer(depth.image().map_err(err)?)
        .and_then(|cg| cg.try_with_roughness(ImageView::try_new(&g.roughness, w, h, w)?))
        .map_err(err)?;
    let ids = ImageView::try_new(&g.object, w, h, w).map_err(err)?;
    let n = scene.objects.len().max(1);
    let mut frame = FrameSummary::default();
    let mut objects = vec![ObjectSummary::default(); n];
    let options = SummaryOptions::default();
    try_summarize_rows(
        &mut frame,
        &mut objects,
        &core_g,
        Some(&ids),
        RowRange::try_all(h).map_err(err)?,
        &options,
    )
    .map_err(err)?;
    let mapped = crate::layered_render::reflected_objects(scene);
    let hints: Vec<ObjectHints> = (0..n)
        .map(|k| {
            let o = scene.objects.get(k);
            ObjectHints {
                planar_mirror: o.is_some_and(|o| {
                    o.planar.is_some() && scene.materials[o.material as usize].is_mirror()
                }),
                layered_map: mapped.contains(&(k as u32)),
                // The built-in and OBJ scenes are static: only the camera
                // moves along its path.
                moving: false,
            }
        })
        .collect();
    let mut planar = vec![false; n];
    let plan = try_plan_passes(
        &mut planar,
        &frame,
        &objects,
        &hints,
        caps,
        &options,
        &PlanOptions {
            motion,
            ..PlanOptions::default()
        },
        (w, h),
    )
    .map_err(err)?;
    let names = planar
        .iter()
        .enumerate()
        .filter(|(_, &p)| p)
        .map(|(k, _)| {
            scene
                .objects
                .get(k)
                .map_or_else(|| format!("object {k}"), |o| o.name.clone())
        })
        .collect();
    Ok(FramePlan {
        frame,
        plan,
        planar: names,
        objects,
        planar_flags: planar,
        hints,
        options,
    })
}

/// The name of `pass` as `summary.md` and `refl plan` print it.
pub fn pass_name(pass: Pass) -> &'static str {
    match pass {
        Pass::HiZ => "Hi-Z pyramid",
        Pass::Planar => "planar pass",
        Pass::Mirror => "mirror pass",
        Pass::ColorPyramid => "color pyramid",
        Pass::VisibilityPyramid => "visibility pyramid",
        Pass::Glossy => "glossy pass",
        Pass::Layered => "layered maps",
        Pass::HostRays => "host rays",
        Pass::Probe => "probe",
        Pass::Temporal => "temporal pass",
    }
}

/// Why a pass is skipped, in words.
pub fn reason_text(reason: SkipReason) -> &'static str {
    match reason {
        SkipReason::Runs => "runs",
        SkipReason::NotBuilt => "not built",
        SkipReason::NoPixels => "no pixels of its class",
        SkipReason::AllMirrorsPlanar => "every mirror pixel is on the planar pass",
        SkipReason::NoReader => "nothing reads it",
        SkipReason::NoHostSupport => "the host cannot",
        SkipReason::NoMaps => "no object has maps",
        SkipReason::NotUsed => "its setting leaves it out",
        SkipReason::Unchanged => "nothing moved: the last frame's reflections hold",
        SkipReason::MapsStale => "every mapped object moved: its maps are stale",
    }
}

/// One line: the passes run (with the bytes of the buffers they build), the
/// passes skipped with their reasons, the planar objects.
pub fn describe(p: &FramePlan) -> String {
    let mut runs = Vec::new();
    let mut skipped = Vec::new();
    for d in p.plan.passes {
        if d.runs() {
            runs.push(if d.bytes > 0 {
                format!("{} ({:.2} MB)", pass_name(d.pass), d.bytes as f64 / 1e6)
            } else {
                pass_name(d.pass).to_owned()
            });
        } else {
            skipped.push(format!("{} ({})", pass_name(d.pass), reason_text(d.reason)));
        }
    }
    let (run, skip) = p.plan.counts();
    let mut s = format!(
        "{run} passes run: {}; {skip} skipped: {}; {:.2} MB of pyramids",
        runs.join(", "),
        if skipped.is_empty() {
            "none".to_owned()
        } else {
            skipped.join(", ")
        },
        p.plan.bytes() as f64 / 1e6
    );
    if !p.planar.is_empty() {
        let _ = write!(s, "; planar pass for {}", p.planar.join(", "));
    }
    s
}
