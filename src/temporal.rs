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
//! frames, 0..255), next to the reference's own. The flicker is split:
//! over the pixels the setting answered or recovered in both frames
//! (`flicker_kept_255`, next to the reference's over the same pixels,
//! `reference_flicker_kept_255`), and the rest, where the pixel showed the
//! environment fallback in one frame or both (churn of the answered set).

use crate::gbuffer::GBuffer;
use crate::render::{compare, composite, direct_image, mirror_env, save_png, timed};
use crate::report::accum::{Accum, Extra};
use crate::report_out::Row;
use crate::screen::{self, DepthBuffer, PassImages, ScreenMethod};
use crate::shade::Shader;
use crate::tcrr::{handled_mask, trace_all, PathRun};
use glam::Vec3;
use rayon::prelude::*;
use refl_core::hiz::HiZOptions;
use refl_core::temporal::{
    History, HistoryTexel, TemporalOptions, TemporalPass, TemporalStats, TemporalStatus,
};
use refl_core::upsample::{Subsample, UpsampleOptions, UpsampleStatus};
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
    /// Temporal super-sampling (seed 004 Sec. 4.7.4, `refl_core::upsample`
    /// module docs): each frame traces one pixel of every 2x2 block, the
    /// sub-pixel stepping through the four-frame cycle with the frame
    /// number, upsampled; only the traced pixels count as answered, so the
    /// filter recovers the other three from the history and the upsampled
    /// color stands in where the history is not valid. Needs `filter`.
    pub tss: bool,
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
                if !o.clamp_history {
                    s.push_str(";clamp=off");
                }
                if self.tss {
                    s.push_str(";half=tss");
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
    /// Sums over the pixels kept (answered or recovered) in both frames:
    /// the method's change, the reference's, and their count; the pixels
    /// compared overall.
    kept_flicker_sum: f64,
    kept_reference_sum: f64,
    kept_pixels: usize,
    flicker_pixels: usize,
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
                "flicker_kept_255".into(),
                format!(
                    "{:.4}",
                    self.kept_flicker_sum / self.kept_pixels.max(1) as f64
                ),
            ),
            (
                "reference_flicker_kept_255".into(),
                format!(
                    "{:.4}",
                    self.kept_reference_sum / self.kept_pixels.max(1) as f64
                ),
            ),
            (
                "kept_both_share".into(),
                format!(
                    "{:.4}",
                    self.kept_pixels as f64 / self.flicker_pixels.max(1) as f64
                ),
            ),
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

/// A setting's last frame (composite, mirror pixels, kept pixels,
/// reference composite), for the flicker.
type LastFrame = (Vec<Vec3>, Vec<bool>, Vec<bool>, Vec<Vec3>);

/// Per-setting state along the path.
struct State {
    setting: Setting,
    history: Option<(Camera, Vec<HistoryTexel>)>,
    /// The last frame: the composite, its mirror pixels, the pixels
    /// answered or recovered, the reference's composite.
    last_final: Option<LastFrame>,
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

/// The filter's inputs of one frame: colors, answered flags, distances,
/// the pass's time (ms) and its rays.
type FrameInputs = (Vec<[f32; 3]>, Vec<u8>, Vec<f32>, f64, u64);

/// A setting's frame: reflection colors, the mirror pixels answered or
/// recovered (mask), time (ms) and rays.
type Filtered = (Vec<[f32; 3]>, Vec<bool>, f64, u64);

/// One frame of the path: its G-buffer, the reference and the mirror
/// pass's output as the filter takes it.
struct PathFrame {
    g: GBuffer,
    handled: Vec<bool>,
    n_handled: usize,
    n_reflective: usize,
    direct: Vec<Vec3>,
    truth_final: Vec<Vec3>,
    reference_ms: f64,
    depth: DepthBuffer,
    images: PassImages,
    pass_ms: f64,
    rays: u64,
    /// The pass's color where it answered, the environment elsewhere.
    current: Vec<[f32; 3]>,
    answered: Vec<u8>,
    /// The hit distance, `+inf` for the sky, 0 where not answered.
    distance: Vec<f32>,
}

impl PathFrame {
    /// Renders the frame of `cam`, traces the reference and runs the Hi-Z
    /// mirror pass (module docs).
    fn new(
        shader: &Shader,
        cam: &Camera,
        pool: &rayon::ThreadPool,
    ) -> Result<Self, refl_core::Error> {
        let g = GBuffer::render(shader.scene, shader.tracer, cam, pool);
        let handled = handled_mask(&g);
        let full = timed(|| trace_all(shader, &g, &handled, pool));
        let direct = direct_image(shader, &g, pool);
        let truth = crate::render::ReflectionImage {
            width: g.width(),
            height: g.height(),
            rgb: full.value.0,
            handled: handled.clone(),
        };
        let truth_final = composite(&g, &direct, &truth);
        let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY)?;
        let images = PassImages::new(&g, Some(&direct));
        let method = ScreenMethod::HiZ(HiZOptions::default());
        let run = screen::run(method, true, &depth.image()?, &images, pool)?;
        let n = g.len();
        let (mut current, mut answered, mut distance) =
            (vec![[0.0f32; 3]; n], vec![0u8; n], vec![0.0f32; n]);
        for i in (0..n).filter(|&i| g.is_reflective(i)) {
            let t = &run.value.texels[i];
            (current[i], answered[i], distance[i]) = match t.status {
                MirrorStatus::Hit => (run.value.color[i], 1, t.t),
                st => {
                    let env = mirror_env(&g, i).to_array();
                    if st == MirrorStatus::Sky {
                        (env, 1, f32::INFINITY)
                    } else {
                        (env, 0, 0.0)
                    }
                }
            };
        }
        Ok(Self {
            n_handled: handled.iter().filter(|&&x| x).count(),
            n_reflective: (0..n).filter(|&i| g.is_reflective(i)).count(),
            g,
            handled,
            direct,
            truth_final,
            reference_ms: full.ms,
            depth,
            images,
            pass_ms: run.ms,
            rays: u64::from(run.value.stats.traced),
            current,
            answered,
            distance,
        })
    }

    /// The inputs of temporal super-sampling at frame `frame`
    /// ([`Setting::tss`]): the upsampled colors (the environment where the
    /// pixel has no hit), the pixels traced this frame that answered, their
    /// distances, the half pass's time and its rays.
    fn subsampled(
        &self,
        frame: u32,
        pool: &rayon::ThreadPool,
    ) -> Result<FrameInputs, refl_core::Error> {
        let setting = crate::upsample::FewerRays {
            subsample: Subsample::uniform(frame),
            options: UpsampleOptions::default(),
        };
        let method = ScreenMethod::HiZ(HiZOptions::default());
        let run = crate::upsample::run(
            method,
            true,
            &setting,
            &self.depth.image()?,
            &self.images,
            pool,
        )?;
        let out = &run.value;
        let n = self.g.len();
        let g = &self.g;
        let (mut current, mut answered, mut distance) =
            (vec![[0.0f32; 3]; n], vec![0u8; n], vec![0.0f32; n]);
        for i in (0..n).filter(|&i| g.is_reflective(i)) {
            let t = &out.pass.texels[i];
            // Traced this frame and answered (`UpsampleStatus::answers`;
            // the default options re-trace nothing).
            let traced = out.status[i] == UpsampleStatus::Copied as u8
                && matches!(t.status, MirrorStatus::Hit | MirrorStatus::Sky);
            current[i] = if t.status == MirrorStatus::Hit {
                out.pass.color[i]
            } else {
                mirror_env(g, i).to_array()
            };
            if traced {
                answered[i] = 1;
                distance[i] = if t.status == MirrorStatus::Hit {
                    t.t
                } else {
                    f32::INFINITY
                };
            }
        }
        Ok((
            current,
            answered,
            distance,
            run.ms,
            u64::from(out.pass.stats.traced),
        ))
    }

    /// The reflection colors of `setting` this frame, the mirror pixels it
    /// answered or recovered, its time and its rays; the setting's history
    /// moves on.
    fn filtered(
        &self,
        st: &mut State,
        pool: &rayon::ThreadPool,
    ) -> Result<Filtered, refl_core::Error> {
        let Some(opts) = st.setting.filter else {
            let kept = self
                .handled
                .iter()
                .zip(&self.answered)
                .map(|(h, a)| *h && *a != 0)
                .collect();
            return Ok((self.current.clone(), kept, self.pass_ms, self.rays));
        };
        let (w, h) = (self.g.width(), self.g.height());
        let sub = if st.setting.tss {
            Some(self.subsampled(st.per_frame.len() as u32, pool)?)
        } else {
            None
        };
        let (current, answered, distance, pass_ms, rays) = match &sub {
            Some((c, a, d, ms, rays)) => (c, a, d, *ms, *rays),
            None => (
                &self.current,
                &self.answered,
                &self.distance,
                self.pass_ms,
                self.rays,
            ),
        };
        let hist = match &st.history {
            Some((c, t)) => Some(History::try_new(*c, ImageView::try_new(t, w, h, w)?)?),
            None => None,
        };
        let mut pass = TemporalPass::try_new(
            self.images.gbuffer(self.depth.image()?)?,
            ImageView::try_new(current, w, h, w)?,
            ImageView::try_new(answered, w, h, w)?,
            hist,
            opts,
        )?;
        if st.setting.distances {
            pass = pass.try_with_distance(ImageView::try_new(distance, w, h, w)?)?;
        }
        let filtered = timed(|| filter_frame(&pass, w, h, pool));
        let ((next, status), stats) = filtered.value?;
        let kept = [
            TemporalStatus::Blended as u8,
            TemporalStatus::Reset as u8,
            TemporalStatus::Recovered as u8,
        ];
        let kept_mask = self
            .handled
            .iter()
            .zip(&status)
            .map(|(h, s)| *h && kept.contains(s))
            .collect();
        let s = &mut st.totals.stats;
        s.blended += stats.blended;
        s.reset += stats.reset;
        s.recovered += stats.recovered;
        s.unanswered += stats.unanswered;
        s.off_screen += stats.off_screen;
        s.rejected += stats.rejected;
        let rgb = next.iter().map(|t| t.color).collect();
        st.history = Some((self.depth.camera, next));
        Ok((rgb, kept_mask, pass_ms + filtered.ms, rays))
    }

    /// Runs `st`'s setting on this frame and adds the frame to its totals;
    /// returns the composited frame.
    fn step(
        &self,
        st: &mut State,
        pool: &rayon::ThreadPool,
    ) -> Result<Vec<Vec3>, refl_core::Error> {
        let (rgb, kept, time, rays) = self.filtered(st, pool)?;
        let img = crate::render::ReflectionImage {
            width: self.g.width(),
            height: self.g.height(),
            rgb: rgb.iter().map(|c| Vec3::from_array(*c)).collect(),
            handled: self.handled.clone(),
        };
        let fin = composite(&self.g, &self.direct, &img);
        let e = compare(&self.truth_final, &fin, &self.handled);
        let t = &mut st.totals;
        if let Some((last, lm, lk, lt)) = &st.last_final {
            if let Some(d) = flicker(last, lm, &fin, &self.handled) {
                t.flicker_sum += d;
                t.flicker_frames += 1;
            }
            let both: Vec<bool> = (0..kept.len()).map(|i| lk[i] && kept[i]).collect();
            let e = compare(last, &fin, &both);
            let r = compare(lt, &self.truth_final, &both);
            t.kept_flicker_sum += e.mean_abs * e.pixels as f64;
            t.kept_reference_sum += r.mean_abs * r.pixels as f64;
            t.kept_pixels += e.pixels;
            t.flicker_pixels += (0..kept.len())
                .filter(|&i| lm[i] && self.handled[i])
                .count();
        }
        let answered = kept.iter().filter(|&&k| k).count();
        st.last_final = Some((
            fin.clone(),
            self.handled.clone(),
            kept,
            self.truth_final.clone(),
        ));
        t.base
            .add(time, self.reference_ms, self.n_reflective, &e, &Extra::None);
        t.frames += 1;
        t.handled += self.n_handled;
        t.answered += answered;
        t.rays += rays;
        t.worst_frame = t.worst_frame.max(e.mean_abs);
        st.per_frame.push(e.mean_abs);
        Ok(fin)
    }
}

/// Runs every setting over the frame cameras; the composite of the last
/// frame of the first filtered setting and of `off` go to `images` as
/// `<label>_temporal.png` and `<label>_temporal_off.png`.
///
/// # Errors
/// A kernel's error (a bug: the inputs are built here) or an image write
/// failure, as a message.
pub fn run_path(
    run: &PathRun<'_>,
    settings: &[Setting],
    images: Option<&Path>,
) -> Result<PathOutcome, String> {
    let (label, cameras, pool) = (run.label, run.cameras, run.pool);
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
    let mut reference = (None::<(Vec<Vec3>, Vec<bool>)>, 0.0, 0usize);
    for (f, cam) in cameras.iter().enumerate() {
        let frame = PathFrame::new(run.shader, cam, pool).map_err(err)?;
        if let Some((last, lm)) = &reference.0 {
            if let Some(d) = flicker(last, lm, &frame.truth_final, &frame.handled) {
                reference.1 += d;
                reference.2 += 1;
            }
        }
        reference.0 = Some((frame.truth_final.clone(), frame.handled.clone()));
        let mut saved_filtered = false;
        for st in &mut states {
            let fin = frame.step(st, pool).map_err(err)?;
            let name = match st.setting.filter {
                None => Some(format!("{label}_temporal_off.png")),
                Some(_) if !saved_filtered => {
                    saved_filtered = true;
                    Some(format!("{label}_temporal.png"))
                }
                Some(_) => None,
            };
            if let (Some(dir), Some(name), true) = (images, name, f + 1 == cameras.len()) {
                let (w, h) = (frame.g.width(), frame.g.height());
                save_png(&dir.join(&name), w, h, &fin).map_err(|e| format!("{name}: {e}"))?;
            }
        }
    }
    let reference_flicker = reference.1 / reference.2.max(1) as f64;
    Ok(PathOutcome {
        rows: states
            .iter()
            .map(|s| {
                s.totals
                    .row(label, &s.setting, run.threads, reference_flicker)
            })
            .collect(),
        per_frame: states
            .into_iter()
            .map(|s| (s.setting.label(), s.per_frame))
            .collect(),
        reference_flicker,
    })
}
