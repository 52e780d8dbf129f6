//! The screen-space mirror pass with seed 004's temporal filtering (Sec.
//! 4.6.5, `refl_core::temporal`) along a camera path, against the
//! ray-traced reference frame by frame.
//!
//! Per frame of a dense sequence along the scene's camera path (the TCRR
//! study's frames, [`crate::tcrr::path_cameras`]): the G-buffer and the
//! reference (every perfect-mirror pixel traced, [`crate::tcrr`]'s rule;
//! not timed as the method), then refl-core's mirror pass with Hi-Z
//! (reversed-Z, infinite far plane, the report's default `hiz` setting;
//! timed with its pyramid build). A pixel the pass answers takes its color
//! (the lit color at a hit, the environment for a ray that leaves to the
//! sky); a pixel the pass hands to the host takes the environment in its
//! mirror direction (what an engine without a ray tracer shows: the
//! `off` setting). With filtering, refl-core's temporal pass then blends
//! the answered pixels into the history re-projected from the last frame
//! (through the reflector's surface point as the seed does, or through
//! the reflection's virtual point with the pass's hit distances) and
//! recovers the failed ones from it (timed, added to the pass).
//!
//! Measured per setting, over the mirror pixels: the error of the
//! composited frame against the reference's (mean over frames and the
//! worst frame), the share of pixels answered this frame or recovered, and
//! the flicker: the mean absolute change of a pixel's composited color
//! from one frame to the next (pixels that are mirror pixels in both
//! frames, 0..255), next to the reference's own.

use crate::gbuffer::GBuffer;
use crate::render::{compare, composite, direct_image, save_png, timed};
use crate::report::accum::{Accum, Extra};
use crate::report_out::Row;
use crate::screen::{self, DepthBuffer, PassImages, ScreenMethod};
use crate::shade::{env_map, reflection_dir, Shader};
use crate::tcrr::{handled_mask, trace_all};
use glam::Vec3;
use rayon::prelude::*;
use refl_core::hiz::HiZOptions;
use refl_core::temporal::{
    History, HistoryTexel, TemporalOptions, TemporalPass, TemporalStats, TemporalStatus,
};
use refl_core::{Camera, DepthConvention, ImageView, ImageViewMut, MirrorStatus, RowRange};
use std::path::Path;

/// Rows per band of the temporal pass (the pool's threads take bands).
const BAND: u32 = 16;

/// One setting of the study: the filter's options, or `None` for the pass
/// alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setting {
    /// The filter's options; `None`: no filtering (failed pixels show the
    /// environment).
    pub filter: Option<TemporalOptions>,
    /// Re-project through the reflection's virtual point (the pass's hit
    /// distances, [`TemporalPass::try_with_distance`]) rather than the
    /// reflector's surface point (the seed's).
    pub distances: bool,
}

impl Setting {
    /// The report's setting label.
    pub fn label(&self) -> String {
        match self.filter {
            None => "temporal=off".into(),
            Some(o) => {
                let mut s = format!(
                    "temporal=on;reproject={};max_frames={}",
                    if self.distances { "virtual" } else { "surface" },
                    o.max_frames
                );
                if o.normal_cos <= -1.0 {
                    s.push_str(";normals=off");
                }
                if !o.recover {
                    s.push_str(";recover=off");
                }
                s
            }
        }
    }
}

/// Per-setting sums along the path: the columns every method has
/// ([`Accum`]) and the study's own.
#[derive(Default)]
struct Totals {
    base: Accum,
    frames: usize,
    handled: usize,
    answered: usize,
    worst_frame: f64,
    flicker_sum: f64,
    flicker_frames: usize,
    rays: u64,
    stats: TemporalStats,
}

impl Totals {
    fn row(&self, scene: &str, setting: &Setting, threads: usize, ref_flicker: f64) -> Row {
        let frames = self.frames.max(1) as f64;
        let s = &self.stats;
        let mut row = self
            .base
            .row(scene, "hiz-temporal", &setting.label(), threads);
        row.extra.extend([
            (
                "worst_frame_mean_abs_255".into(),
                format!("{:.4}", self.worst_frame),
            ),
            (
                "answered_share".into(),
                format!("{:.4}", self.answered as f64 / self.handled.max(1) as f64),
            ),
            (
                "flicker_255".into(),
                format!(
                    "{:.4}",
                    self.flicker_sum / self.flicker_frames.max(1) as f64
                ),
            ),
            ("reference_flicker_255".into(), format!("{ref_flicker:.4}")),
            (
                "rays_per_frame".into(),
                format!("{:.0}", self.rays as f64 / frames),
            ),
            ("recovered".into(), s.recovered.to_string()),
            ("rejected".into(), (s.rejected + s.off_screen).to_string()),
            (
                "bytes_per_pixel".into(),
                // Two history buffers (read, write) of 36 bytes, the
                // answered mask and the distances.
                if setting.filter.is_some() { "77" } else { "0" }.into(),
            ),
        ]);
        row
    }
}

/// Per-setting state along the path.
struct State {
    setting: Setting,
    history: Option<(Camera, Vec<HistoryTexel>)>,
    last_final: Option<(Vec<Vec3>, Vec<bool>)>,
    totals: Totals,
    per_frame: Vec<f64>,
}

/// What [`run_path`] returns.
pub struct PathOutcome {
    /// One row per setting.
    pub rows: Vec<Row>,
    /// Per setting label, the error of each frame (mean abs, 0..255).
    pub per_frame: Vec<(String, Vec<f64>)>,
    /// The reference's own flicker (0..255).
    pub reference_flicker: f64,
}

/// Mean absolute change (0..255, per channel) between two composited frames
/// over the pixels `mask` holds in both, or `None` without such pixels.
fn flicker(a: &[Vec3], am: &[bool], b: &[Vec3], bm: &[bool]) -> Option<f64> {
    let both: Vec<bool> = am.iter().zip(bm).map(|(x, y)| *x && *y).collect();
    let e = compare(a, b, &both);
    (e.pixels > 0).then_some(e.mean_abs)
}

/// The temporal filter over one frame on `pool`, in bands: the next history
/// with every pixel's [`TemporalStatus`] byte, and the summed counts.
#[allow(clippy::type_complexity)]
fn filter_frame(
    pass: &TemporalPass<'_>,
    w: u32,
    h: u32,
    pool: &rayon::ThreadPool,
) -> Result<((Vec<HistoryTexel>, Vec<u8>), TemporalStats), refl_core::Error> {
    let n = w as usize * h as usize;
    let (mut next, mut status) = (vec![HistoryTexel::default(); n], vec![0u8; n]);
    let band = BAND as usize * w as usize;
    let stats = pool.install(|| {
        next.par_chunks_mut(band)
            .zip(status.par_chunks_mut(band))
            .enumerate()
            .map(|(k, (t, st))| {
                let y0 = k as u32 * BAND;
                let rows = RowRange::try_new(y0, (y0 + BAND).min(h), h)?;
                let mut st = ImageViewMut::try_band(st, w, h, w, rows)?;
                pass.try_run(
                    &mut ImageViewMut::try_band(t, w, h, w, rows)?,
                    Some(&mut st),
                )
            })
            .try_reduce(TemporalStats::default, |a, b| {
                Ok(TemporalStats {
                    blended: a.blended + b.blended,
                    reset: a.reset + b.reset,
                    recovered: a.recovered + b.recovered,
                    unanswered: a.unanswered + b.unanswered,
                    off_screen: a.off_screen + b.off_screen,
                    rejected: a.rejected + b.rejected,
                })
            })
    })?;
    Ok(((next, status), stats))
}

/// Runs every setting over the frame cameras; the composite of the last
/// frame of the first filtered setting and of `off` go to `images` as
/// `<label>_temporal.png` and `<label>_temporal_off.png`.
///
/// # Errors
/// A kernel's error (a bug: the inputs are built here) or an image write
/// failure, as a message.
pub fn run_path(
    shader: &Shader,
    label: &str,
    cameras: &[Camera],
    settings: &[Setting],
    threads: usize,
    pool: &rayon::ThreadPool,
    images: Option<&Path>,
) -> Result<PathOutcome, String> {
    let scene = shader.scene;
    let err = |e: refl_core::Error| format!("{label}: temporal: {e}");
    let mut states: Vec<State> = settings
        .iter()
        .map(|s| State {
            setting: *s,
            history: None,
            last_final: None,
            totals: Totals::default(),
            per_frame: Vec::new(),
        })
        .collect();
    let (mut ref_last, mut ref_flicker, mut ref_flicker_n) =
        (None::<(Vec<Vec3>, Vec<bool>)>, 0.0, 0);
    let method = ScreenMethod::HiZ(HiZOptions::default());
    for (f, cam) in cameras.iter().enumerate() {
        let g = GBuffer::render(scene, shader.tracer, cam, pool);
        let handled = handled_mask(&g);
        let n_handled = handled.iter().filter(|&&x| x).count();
        let n_reflective = (0..g.len()).filter(|&i| g.is_reflective(i)).count();
        let full = timed(|| trace_all(shader, &g, &handled, pool));
        let direct = direct_image(shader, &g, pool);
        let truth = crate::render::ReflectionImage {
            width: g.width(),
            height: g.height(),
            rgb: full.value.0.clone(),
            handled: handled.clone(),
        };
        let truth_final = composite(&g, &direct, &truth);
        if let Some((last, lm)) = &ref_last {
            if let Some(d) = flicker(last, lm, &truth_final, &handled) {
                ref_flicker += d;
                ref_flicker_n += 1;
            }
        }
        ref_last = Some((truth_final.clone(), handled.clone()));

        // The pass, once per frame (every setting starts from its output).
        let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY).map_err(err)?;
        let depth_image = depth.image().map_err(err)?;
        let pass_images = PassImages::new(&g, Some(&direct));
        let run = screen::run(method, true, &depth_image, &pass_images, pool).map_err(err)?;
        let (w, h) = (g.width(), g.height());
        let mut current = vec![[0.0f32; 3]; g.len()];
        let mut answered = vec![0u8; g.len()];
        let mut distance = vec![0.0f32; g.len()];
        for i in 0..g.len() {
            if !g.is_reflective(i) {
                continue;
            }
            let t = &run.value.texels[i];
            current[i] = match t.status {
                MirrorStatus::Hit => {
                    answered[i] = 1;
                    distance[i] = t.t;
                    run.value.color[i]
                }
                _ => {
                    answered[i] = u8::from(t.status == MirrorStatus::Sky);
                    if t.status == MirrorStatus::Sky {
                        distance[i] = f32::INFINITY;
                    }
                    let view = -g.primary_ray(i).dir;
                    env_map(reflection_dir(view, g.normal[i], g.geo_normal[i])).to_array()
                }
            };
        }
        let rays = u64::from(run.value.stats.traced);
        let last_frame = f + 1 == cameras.len();
        let mut saved_filtered = false;
        for st in &mut states {
            let (rgb, answered_n, time) = match st.setting.filter {
                None => {
                    let n = (0..g.len())
                        .filter(|&i| handled[i] && answered[i] != 0)
                        .count();
                    (current.clone(), n, run.ms)
                }
                Some(opts) => {
                    let gb = pass_images.gbuffer(depth_image).map_err(err)?;
                    let hist = match &st.history {
                        Some((c, t)) => Some(
                            History::try_new(*c, ImageView::try_new(t, w, h, w).map_err(err)?)
                                .map_err(err)?,
                        ),
                        None => None,
                    };
                    let mut pass = TemporalPass::try_new(
                        gb,
                        ImageView::try_new(&current, w, h, w).map_err(err)?,
                        ImageView::try_new(&answered, w, h, w).map_err(err)?,
                        hist,
                        opts,
                    )
                    .map_err(err)?;
                    if st.setting.distances {
                        pass = pass
                            .try_with_distance(ImageView::try_new(&distance, w, h, w).map_err(err)?)
                            .map_err(err)?;
                    }
                    let filtered = timed(|| filter_frame(&pass, w, h, pool));
                    let (next, stats) = filtered.value.map_err(err)?;
                    let (next, status) = next;
                    let n = handled
                        .iter()
                        .zip(&status)
                        .filter(|(h, s)| {
                            **h && [
                                TemporalStatus::Blended as u8,
                                TemporalStatus::Reset as u8,
                                TemporalStatus::Recovered as u8,
                            ]
                            .contains(s)
                        })
                        .count();
                    let s = &mut st.totals.stats;
                    s.blended += stats.blended;
                    s.reset += stats.reset;
                    s.recovered += stats.recovered;
                    s.unanswered += stats.unanswered;
                    s.off_screen += stats.off_screen;
                    s.rejected += stats.rejected;
                    let rgb = next.iter().map(|t| t.color).collect();
                    st.history = Some((depth.camera, next));
                    (rgb, n, run.ms + filtered.ms)
                }
            };
            let img = crate::render::ReflectionImage {
                width: w,
                height: h,
                rgb: rgb
                    .iter()
                    .map(|c: &[f32; 3]| Vec3::from_array(*c))
                    .collect(),
                handled: handled.clone(),
            };
            let fin = composite(&g, &direct, &img);
            let e = compare(&truth_final, &fin, &handled);
            if let Some((last, lm)) = &st.last_final {
                if let Some(d) = flicker(last, lm, &fin, &handled) {
                    st.totals.flicker_sum += d;
                    st.totals.flicker_frames += 1;
                }
            }
            if last_frame {
                if let Some(dir) = images {
                    let name = match st.setting.filter {
                        None => Some(format!("{label}_temporal_off.png")),
                        Some(_) if !saved_filtered => {
                            saved_filtered = true;
                            Some(format!("{label}_temporal.png"))
                        }
                        Some(_) => None,
                    };
                    if let Some(name) = name {
                        save_png(&dir.join(&name), w, h, &fin)
                            .map_err(|e| format!("{name}: {e}"))?;
                    }
                }
            }
            st.last_final = Some((fin, handled.clone()));
            let t = &mut st.totals;
            t.base.add(time, full.ms, n_reflective, &e, &Extra::None);
            t.frames += 1;
            t.handled += n_handled;
            t.answered += answered_n;
            t.rays += rays;
            t.worst_frame = t.worst_frame.max(e.mean_abs);
            st.per_frame.push(e.mean_abs);
        }
    }
    let reference_flicker = ref_flicker / ref_flicker_n.max(1) as f64;
    Ok(PathOutcome {
        rows: states
            .iter()
            .map(|s| s.totals.row(label, &s.setting, threads, reference_flicker))
            .collect(),
        per_frame: states
            .into_iter()
            .map(|s| (s.setting.label(), s.per_frame))
            .collect(),
        reference_flicker,
    })
}
