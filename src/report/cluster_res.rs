//! Seed 003's Table 4 counterpart: the cluster method's cost and error at
//! several output resolutions of the same view (`--long` only). The seed:
//! "for a bigger output image resolution ... the resolution of the depth
//! image for each cluster is higher ... However, the cost is not
//! proportional to the number of output image pixels ... the number of
//! clusters remains the same, each cluster grouping a larger number of
//! pixels."

use super::accum::{Accum, ClusterAccum, Extra};
use super::studies::SceneRun;
use crate::cluster::{run, ClusterSettings, StageMs};
use crate::gbuffer::GBuffer;
use crate::render::{compare, composite, direct_image, median, reference, timed};
use crate::report_out::Row;
use std::fmt::Write as _;

/// Output sizes as multiples of the run's image size.
pub const SCALES: [f32; 3] = [0.5, 1.0, 2.0];

/// The cluster method at the default setting on the scene's first pose at
/// each of [`SCALES`]: time (median of the run's repetitions), error
/// against the reference at that size, clusters and depth texels. Rows of
/// method `cluster` with setting `output=WxH`, and a note line.
///
/// # Errors
/// A message naming the scene and the failing step.
pub fn report_rows(s: &SceneRun<'_>) -> Result<(Vec<Row>, String), String> {
    let settings = ClusterSettings::default();
    let (mut rows, mut notes) = (Vec::new(), String::new());
    let mut line = Vec::new();
    for scale in SCALES {
        let w = ((s.sizes.width as f32 * scale).round() as u32).max(8);
        let h = ((s.sizes.height as f32 * scale).round() as u32).max(8);
        let err = |e: refl_core::Error| format!("{}: cluster output {w}x{h}: {e}", s.label);
        let cam = s.scene.camera(0, w, h).map_err(err)?;
        let g = GBuffer::render(s.scene, s.tracer, &cam, s.pool);
        let truth = timed(|| reference(s.shader, &g, s.sizes.truth_samples, s.pool));
        let direct = direct_image(s.shader, &g, s.pool);
        let truth_final = composite(&g, &direct, &truth.value);
        let mut stage_runs: Vec<StageMs> = Vec::new();
        let mut first = None;
        for _ in 0..s.sizes.runs.max(1) {
            let c = run(s.shader, &g, &settings, s.pool, false).map_err(err)?;
            stage_runs.push(c.stages);
            first.get_or_insert(c);
        }
        let c = first.ok_or("cluster: no run")?;
        let stages = StageMs::median_of(&stage_runs);
        let ms = median(stage_runs.iter().map(|s| s.total()).collect());
        let e = compare(
            &truth_final,
            &composite(&g, &direct, &c.image),
            &c.image.handled,
        );
        let mut acc = Accum::default();
        let extra = Extra::Cluster(ClusterAccum::of(&c, stages));
        acc.add(ms, truth.ms, c.reflective(), &e, &extra);
        rows.push(acc.row(s.label, "cluster", &format!("output={w}x{h}"), s.threads));
        line.push(format!(
            "{w}x{h}: {ms:.1} ms, {} clusters, {} depth texels, error {:.3}",
            c.clusters, c.texels, e.mean_abs
        ));
    }
    let _ = writeln!(
        notes,
        "  - cluster at output resolutions (seed 003 Table 4, default setting, pose 0): {}",
        line.join("; ")
    );
    Ok((rows, notes))
}
