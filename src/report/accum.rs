//! Sums over the frames of one scene, method and setting, made into a
//! [`Row`] once every frame has run: the error and time columns every
//! method has, and the columns of the screen-space and cluster methods.

use crate::render::ImageError;
use crate::report_out::Row;
use crate::screen::RayStats;

/// A method's own figures of one frame, pooled over frames into its
/// columns.
#[derive(Clone, Debug)]
pub enum Extra {
    /// No columns of its own.
    None,
    /// Ray statistics and timings of a screen-space or layered method.
    Screen(ScreenAccum),
    /// The cluster method's per-frame figures.
    Cluster(ClusterAccum),
    /// A screen-space method that traces fewer rays than pixels (the
    /// `hiz` rows with `half=`, [`super::half`]): the screen columns and
    /// the shares of traced and re-traced pixels.
    Half(ScreenAccum, HalfAccum),
    /// The planner's row: its prediction, time unit, passes and bytes.
    Planned(super::planned::PlannedAccum),
}

/// Sums over frames of a method that traces fewer rays than pixels.
#[derive(Clone, Copy, Debug, Default)]
pub struct HalfAccum {
    /// Reflective pixels with a surface.
    pub pixels: usize,
    /// Of those, the ones the mirror pass traced (samples and re-traces).
    pub traced: usize,
    /// Of those, the ones no sample reached (re-traced or left out).
    pub retrace: usize,
}

impl HalfAccum {
    fn add(&mut self, o: &HalfAccum) {
        self.pixels += o.pixels;
        self.traced += o.traced;
        self.retrace += o.retrace;
    }

    fn columns(&self) -> Vec<(String, String)> {
        let p = self.pixels.max(1) as f64;
        vec![
            (
                "traced_share".into(),
                format!("{:.4}", self.traced as f64 / p),
            ),
            (
                "retrace_share".into(),
                format!("{:.4}", self.retrace as f64 / p),
            ),
        ]
    }
}

/// Sums over the frames of one scene x method x setting; a row is made
/// from it once every frame has run.
#[derive(Clone, Debug, Default)]
pub struct Accum {
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
    /// Traced and re-traced shares of a method tracing fewer rays.
    half: Option<HalfAccum>,
    /// The planner's prediction and passes.
    planned: Option<super::planned::PlannedAccum>,
}

/// Sums over frames of the cluster method (seed 003).
#[derive(Clone, Debug, Default)]
pub struct ClusterAccum {
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
    /// The figures of one cluster frame `f` with its median stage times.
    pub fn of(f: &crate::cluster::ClusterFrame, stages: crate::cluster::StageMs) -> Self {
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
pub struct ScreenAccum {
    pub stats: RayStats,
    pub kernel_ms: f64,
    pub kernel_ms_1t: f64,
    pub obvhs_ms: f64,
    pub obvhs_ms_1t: f64,
    pub bytes_per_pixel: f64,
    /// Layered rows: `visible` counts rays whose reference hits a mapped
    /// object, `found` those hit on the same object within a texel
    /// diagonal, the error is in texels.
    pub layered: bool,
    /// Layered rows: the map lookups with and without the potential
    /// reflection regions.
    pub layered_lookups: Option<LayeredLookups>,
}

/// Map lookups of the layered pass over the frames of a row: a lookup is
/// one (ray, map) pair the pass considers, a bounding-sphere test and, if
/// it passes, a kernel trace (refl-core `layered_pass`, module docs, step
/// 2). Seed 001 Sec. 3.2's regions decide per reflector triangle which maps
/// its pixels look up; conservative, they skip only lookups the sphere
/// test would have rejected, so the kernel traces and the hits are the same
/// with and without them.
#[derive(Clone, Copy, Debug, Default)]
pub struct LayeredLookups {
    /// Rays the pass traced.
    pub traced: u64,
    /// Lookups without regions: kernel traces, sphere culls and the
    /// lookups the regions skipped.
    pub without_prr: u64,
    /// Of those, the lookups the regions skipped.
    pub prr_skipped: u64,
    /// (reflector triangle, map) pairs the masks classified.
    pub mask_pairs: u64,
    /// Of those, the pairs that may reflect (bit set).
    pub mask_set: u64,
}

impl LayeredLookups {
    fn add(&mut self, o: &LayeredLookups) {
        self.traced += o.traced;
        self.without_prr += o.without_prr;
        self.prr_skipped += o.prr_skipped;
        self.mask_pairs += o.mask_pairs;
        self.mask_set += o.mask_set;
    }

    fn columns(&self) -> Vec<(String, String)> {
        let per_ray = |n: u64| format!("{:.3}", n as f64 / self.traced.max(1) as f64);
        vec![
            ("map_lookups_per_ray".into(), per_ray(self.without_prr)),
            (
                "map_lookups_prr_per_ray".into(),
                per_ray(self.without_prr - self.prr_skipped),
            ),
            ("prr_skipped".into(), self.prr_skipped.to_string()),
            (
                "prr_skipped_share".into(),
                format!(
                    "{:.4}",
                    self.prr_skipped as f64 / self.without_prr.max(1) as f64
                ),
            ),
            (
                "prr_region_share".into(),
                format!(
                    "{:.4}",
                    self.mask_set as f64 / self.mask_pairs.max(1) as f64
                ),
            ),
        ]
    }
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
        if let Some(l) = &o.layered_lookups {
            self.layered_lookups
                .get_or_insert_with(LayeredLookups::default)
                .add(l);
        }
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
        .into_iter()
        .chain(
            self.layered_lookups
                .iter()
                .flat_map(LayeredLookups::columns),
        )
        .collect()
    }
}

impl Accum {
    /// Adds one frame: the pass time `ms`, the reference's time on the same
    /// pixels, the frame's reflective pixel count, the error and the
    /// method's own figures.
    pub fn add(
        &mut self,
        ms: f64,
        reference_ms: f64,
        reflective: usize,
        err: &ImageError,
        extra: &Extra,
    ) {
        match extra {
            Extra::None => {}
            Extra::Screen(s) => self.screen.get_or_insert_with(ScreenAccum::default).add(s),
            Extra::Cluster(c) => self
                .cluster
                .get_or_insert_with(ClusterAccum::default)
                .add(c),
            Extra::Half(s, h) => {
                self.screen.get_or_insert_with(ScreenAccum::default).add(s);
                self.half.get_or_insert_with(HalfAccum::default).add(h);
            }
            Extra::Planned(p) => self.planned.get_or_insert_with(Default::default).add(p),
        }
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

    /// The row of `scene`, `method`, `setting` over the frames added.
    pub fn row(&self, scene: &str, method: &str, setting: &str, threads: usize) -> Row {
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
                if let Some(h) = &self.half {
                    e.extend(h.columns());
                }
                if let Some(p) = &self.planned {
                    e.extend(p.columns());
                }
                e
            },
        }
    }
}
