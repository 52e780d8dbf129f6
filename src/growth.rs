//! Cost growth with scene size: the room at several triangle counts, the
//! depth-image kernels (stepping, Hi-Z, layered maps) against the reference
//! tracer on the same reflection rays, with the BVH build a dynamic scene
//! pays every frame. `refl report` writes it as `growth.csv` and a table in
//! `summary.md`.
//!
//! The screen-space kernels' cost excludes producing the depth buffer (an
//! engine rasterizes it anyway); the layered maps' build is reported
//! separately (static objects build once, a deforming object every frame).

use crate::gbuffer::GBuffer;
use crate::layered_render::LayeredScene;
use crate::render::{median, timed};
use crate::scene::Scene;
use crate::screen::{self, ScreenMethod};
use crate::shade::Shader;
use crate::tracer::Tracer;
use refl_core::hiz::HiZOptions;
use refl_core::{DepthConvention, StepOptions};
use std::fmt::Write as _;
use std::io;
use std::path::Path;

/// One scene size's measurements (all times in ms, one frame).
#[derive(Clone, Debug, PartialEq)]
pub struct GrowthRow {
    /// Triangles in the scene.
    pub triangles: usize,
    /// Reflection rays traced.
    pub rays: usize,
    /// BVH build (obvhs), ms.
    pub bvh_build_ms: f64,
    /// obvhs closest-hit trace of the rays, ms.
    pub obvhs_ms: f64,
    /// The mirror pass with per-pixel stepping (stride 1), ms.
    pub step_ms: f64,
    /// The mirror pass with Hi-Z (default options, pyramid build
    /// included), ms.
    pub hiz_ms: f64,
    /// Layered maps (64x64 faces, 4 layers) trace, ms.
    pub layered_ms: f64,
    /// Layered maps build, ms.
    pub layered_build_ms: f64,
    /// Hit rate of the stepping pass on visible hits.
    pub step_hit_rate: f64,
}

/// The room at one size of a cost-growth curve: the scene, the median
/// time of building its obvhs BVH (what a dynamic scene pays every frame),
/// the tracer and the G-buffer of camera pose 0.
pub struct RoomAt {
    /// The room with about `n` triangles.
    pub scene: Scene,
    /// Median BVH build time over the runs, ms.
    pub bvh_build_ms: f64,
    /// The reference tracer of `scene`.
    pub tracer: Tracer,
    /// The first pass of camera pose 0.
    pub g: GBuffer,
}

impl RoomAt {
    /// Builds the room with about `n` triangles and times its BVH build
    /// (median of `runs`), then renders the G-buffer of pose 0 at
    /// `width x height` on `pool`.
    ///
    /// # Errors
    /// A message for a camera error.
    pub fn new(
        n: usize,
        width: u32,
        height: u32,
        runs: usize,
        pool: &rayon::ThreadPool,
    ) -> Result<RoomAt, String> {
        let scene = Scene::room(n);
        let builds: Vec<f64> = (0..runs.max(1))
            .map(|_| timed(|| Tracer::new(&scene)).ms)
            .collect();
        let tracer = Tracer::new(&scene);
        let camera = scene.camera(0, width, height).map_err(|e| e.to_string())?;
        let g = GBuffer::render(&scene, &tracer, &camera, pool);
        Ok(RoomAt {
            scene,
            bvh_build_ms: median(builds),
            tracer,
            g,
        })
    }
}

/// Measures the room scene at each of `sizes` triangles (`width x height`
/// pixels, camera pose 0, median of `runs`) on `pool`.
///
/// # Errors
/// A message for a refl-core error.
pub fn measure(
    sizes: &[usize],
    width: u32,
    height: u32,
    runs: usize,
    pool: &rayon::ThreadPool,
) -> Result<Vec<GrowthRow>, String> {
    let mut rows = Vec::new();
    for &n in sizes {
        let RoomAt {
            scene,
            bvh_build_ms,
            tracer,
            g,
        } = RoomAt::new(n, width, height, runs, pool)?;
        let shader = Shader::new(&scene, &tracer);
        let rays = screen::reflection_rays(&scene, &tracer, &shader, &g, pool);
        let obvhs_ms = median(
            (0..runs.max(1))
                .map(|_| {
                    timed(|| screen::trace_reference(&tracer, &rays.ray, shader.epsilon, pool)).ms
                })
                .collect(),
        );
        let depth = screen::DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY)
            .map_err(|e| e.to_string())?;
        let image = depth.image().map_err(|e| e.to_string())?;
        let images = screen::PassImages::new(&g, None);
        let kernel = |m: ScreenMethod| -> Result<(f64, Vec<refl_core::MirrorTexel>), String> {
            let mut ms = Vec::new();
            let mut texels = Vec::new();
            for _ in 0..runs.max(1) {
                let t = screen::run(m, true, &image, &images, pool).map_err(|e| e.to_string())?;
                ms.push(t.ms);
                texels = t.value.texels;
            }
            Ok((median(ms), texels))
        };
        let (step_ms, step_traces) = kernel(ScreenMethod::Step(StepOptions::default()))?;
        let (hiz_ms, _) = kernel(ScreenMethod::HiZ(HiZOptions::default()))?;
        let ls = LayeredScene::build(&scene, 64, 4, pool).map_err(|e| e.to_string())?;
        let params = refl_core::layered::LayeredOptions::default();
        let lf = crate::layered_render::LayeredFrame::new(&g);
        let mut layered = Vec::new();
        for _ in 0..runs.max(1) {
            let t = timed(|| ls.trace(&g, &lf, &params, pool));
            t.value.map_err(|e| e.to_string())?;
            layered.push(t.ms);
        }
        rows.push(GrowthRow {
            triangles: scene.tri_count(),
            rays: rays.len(),
            bvh_build_ms,
            obvhs_ms,
            step_ms,
            hiz_ms,
            layered_ms: median(layered),
            layered_build_ms: ls.build_ms,
            step_hit_rate: screen::evaluate(&rays, &step_traces).hit_rate(),
        });
    }
    Ok(rows)
}

/// Writes `rows` as CSV.
///
/// # Errors
/// I/O errors.
pub fn write_csv(path: &Path, rows: &[GrowthRow]) -> io::Result<()> {
    let mut w = csv::Writer::from_path(path)?;
    w.write_record([
        "triangles",
        "rays",
        "bvh_build_ms",
        "obvhs_ms",
        "step_ms",
        "hiz_ms",
        "layered_ms",
        "layered_build_ms",
        "obvhs_with_build_ms",
        "step_hit_rate",
    ])?;
    for r in rows {
        w.write_record([
            r.triangles.to_string(),
            r.rays.to_string(),
            format!("{:.3}", r.bvh_build_ms),
            format!("{:.3}", r.obvhs_ms),
            format!("{:.3}", r.step_ms),
            format!("{:.3}", r.hiz_ms),
            format!("{:.3}", r.layered_ms),
            format!("{:.3}", r.layered_build_ms),
            format!("{:.3}", r.bvh_build_ms + r.obvhs_ms),
            format!("{:.4}", r.step_hit_rate),
        ])?;
    }
    w.flush()
}

/// The Markdown table of `rows`, with the ratios of the reference (trace,
/// and build + trace for a dynamic scene) to each kernel.
pub fn markdown(rows: &[GrowthRow]) -> String {
    let mut s = String::from(
        "| triangles | rays | BVH build ms | obvhs trace ms | step ms | Hi-Z ms | layered ms (build ms) | \
         obvhs/step | obvhs/Hi-Z | (build+obvhs)/Hi-Z | obvhs/layered |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} | {:.2} | {:.2} | {:.2} | {:.2} ({:.0}) | {:.2} | {:.2} | {:.2} | {:.2} |",
            r.triangles,
            r.rays,
            r.bvh_build_ms,
            r.obvhs_ms,
            r.step_ms,
            r.hiz_ms,
            r.layered_ms,
            r.layered_build_ms,
            r.obvhs_ms / r.step_ms,
            r.obvhs_ms / r.hiz_ms,
            (r.bvh_build_ms + r.obvhs_ms) / r.hiz_ms,
            r.obvhs_ms / r.layered_ms,
        );
    }
    s
}
