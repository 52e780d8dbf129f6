//! The temporal filter (`refl_core::temporal`, seed 004 Sec. 4.6.4-4.6.5):
//! a history buffer in caller memory accumulates each pixel's reflection
//! over frames; every frame re-projects the current pixel into the last
//! frame, rejects history of another surface (depth, normal), blends this
//! frame's reflection into the history that survives and lets pixels whose
//! ray failed take the history where it is valid.
//!
//! A frame takes one call per row band after the reflection pass:
//! `refl_temporal_options_default` (or your own options), then
//! `refl_temporal_resolve_rows` from any number of threads, reading this
//! frame's G-buffer, reflection colors and the last frame's history
//! (`refl_temporal_history`: texels and the camera they were written
//! with) and writing the next history. The host keeps two history buffers
//! and swaps them every frame; the texels' `color` is the filtered
//! reflection to composite.

use crate::gbuffer::{gbuffer, gbuffer_ranges, refl_gbuffer};
use crate::image::{
    refl_image_f32, refl_image_temporal_texel, refl_image_temporal_texel_mut, refl_image_u8,
    refl_image_u8_mut, refl_image_vec3, refl_row_range,
};
use crate::ptr::{no_nulls, overlaps, range, read, Out};
use crate::status::{fail, guard, refl_status};
use crate::types::{camera_named, refl_camera, refl_vec3};
use refl_core::image::try_required_len;
use refl_core::temporal::{
    History, HistoryTexel, TemporalOptions, TemporalPass, TemporalStats, TemporalStatus,
};
use refl_core::Error;

/// One texel of a history buffer (refl-core's `temporal::HistoryTexel`, 36
/// bytes): the accumulated reflection of the surface the pixel showed, with
/// that surface's depth and normal and the reflection's distance, which the
/// next frame's re-projection and rejection tests read. A buffer of zero
/// bytes is an empty history.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_temporal_texel {
    /// Accumulated reflection color (linear RGB): this frame's filtered
    /// reflection, the color to composite.
    pub color: refl_vec3,
    /// Frames accumulated into `color`, in [0, `max_frames`]; 0 marks a
    /// texel without history (skipped or unanswered pixels).
    pub frames: f32,
    /// Unit world-space normal of the pixel's surface; 0 for a skipped
    /// pixel.
    pub normal: refl_vec3,
    /// Linear depth of the pixel's surface in the camera the texel was
    /// written with (positive); 0 for a skipped pixel.
    pub depth: f32,
    /// Distance from the surface to what it reflects (this frame's
    /// `distance`, +infinity for the sky); 0 where unknown (no distance
    /// image, a skipped or unanswered pixel). A recovered pixel stores the
    /// distance its re-projection used.
    pub distance: f32,
}

const _: () = {
    use core::mem::{align_of, offset_of, size_of};
    assert!(size_of::<refl_temporal_texel>() == size_of::<HistoryTexel>());
    assert!(align_of::<refl_temporal_texel>() == align_of::<HistoryTexel>());
    assert!(size_of::<refl_temporal_texel>() == 36);
    assert!(offset_of!(refl_temporal_texel, color) == offset_of!(HistoryTexel, color));
    assert!(offset_of!(refl_temporal_texel, frames) == offset_of!(HistoryTexel, frames));
    assert!(offset_of!(refl_temporal_texel, normal) == offset_of!(HistoryTexel, normal));
    assert!(offset_of!(refl_temporal_texel, depth) == offset_of!(HistoryTexel, depth));
    assert!(offset_of!(refl_temporal_texel, distance) == offset_of!(HistoryTexel, distance));
};

fn vec3(a: [f32; 3]) -> refl_vec3 {
    refl_vec3 {
        x: a[0],
        y: a[1],
        z: a[2],
    }
}

fn array3(v: refl_vec3) -> [f32; 3] {
    [v.x, v.y, v.z]
}

impl From<HistoryTexel> for refl_temporal_texel {
    fn from(t: HistoryTexel) -> Self {
        Self {
            color: vec3(t.color),
            frames: t.frames,
            normal: vec3(t.normal),
            depth: t.depth,
            distance: t.distance,
        }
    }
}

impl From<refl_temporal_texel> for HistoryTexel {
    fn from(t: refl_temporal_texel) -> Self {
        Self {
            color: array3(t.color),
            frames: t.frames,
            normal: array3(t.normal),
            depth: t.depth,
            distance: t.distance,
        }
    }
}

/// The last frame's history: its texels and the camera they were written
/// with.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_temporal_history {
    /// The camera the texels were written with: the last frame's G-buffer
    /// camera. It may differ from this frame's in pose, field of view and
    /// planes (that is the re-projection), not in size: the texels and this
    /// camera must have the G-buffer's size. Ignored when `texels.data` is
    /// NULL.
    pub camera: refl_camera,
    /// The texels the last `refl_temporal_resolve_rows` calls wrote to
    /// `next`; `data` NULL: no history (the first frame, or after a cut),
    /// every pixel then starts anew.
    pub texels: refl_image_temporal_texel,
}

/// Settings of the temporal filter; `refl_temporal_options_default` gives
/// the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_temporal_options {
    /// Most frames the history averages, >= 1 (+infinity: the running mean
    /// of every frame; not NaN). 1 turns the blend off (recovery remains).
    /// Default 8.
    pub max_frames: f32,
    /// Relative tolerance of the rejection test, finite, >= 0: a history
    /// texel is kept when its surface point lies within `depth_tolerance`
    /// times the point's depth of the current surface's tangent plane.
    /// Default 0.02.
    pub depth_tolerance: f32,
    /// Least cosine between a history texel's normal and the current one,
    /// in [-1, 1]; -1 tests depth only (as the seed's demo does). Default
    /// 0.9 (about 25 degrees).
    pub normal_cos: f32,
    /// Pixels whose ray failed this frame take the history where it is
    /// valid. Default true.
    pub recover: bool,
    /// Clamps an answered pixel's history color to the range of this
    /// frame's answered colors in its 3x3 neighborhood before the blend
    /// (the neighborhood clamp of temporal anti-aliasing; lowers ghosting
    /// where the history shows another reflection). Default true.
    pub clamp_history: bool,
}

impl From<TemporalOptions> for refl_temporal_options {
    fn from(o: TemporalOptions) -> Self {
        Self {
            max_frames: o.max_frames,
            depth_tolerance: o.depth_tolerance,
            normal_cos: o.normal_cos,
            recover: o.recover,
            clamp_history: o.clamp_history,
        }
    }
}

impl From<refl_temporal_options> for TemporalOptions {
    fn from(o: refl_temporal_options) -> Self {
        Self {
            max_frames: o.max_frames,
            depth_tolerance: o.depth_tolerance,
            normal_cos: o.normal_cos,
            recover: o.recover,
            clamp_history: o.clamp_history,
        }
    }
}

/// What the filter did at a pixel (the bytes of
/// `refl_temporal_resolve_rows`'s `status`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_temporal_status {
    /// No usable surface (sky, NaN depth, zero or non-finite normal) or
    /// mask 0: the texel is emptied (`frames` 0) and its color is
    /// `current`'s, unchanged.
    Skipped = 0,
    /// Answered this frame and blended with the history.
    Blended = 1,
    /// Answered this frame without usable history (first frame, off
    /// screen, disoccluded): the current color alone, `frames` 1.
    Reset = 2,
    /// Not answered this frame; the history's color and frame count (the
    /// count capped at `max_frames`).
    Recovered = 3,
    /// Not answered and no history: the current (fallback) color, `frames`
    /// 0 so that no later frame takes it for history.
    Unanswered = 4,
}

impl From<TemporalStatus> for refl_temporal_status {
    fn from(s: TemporalStatus) -> Self {
        match s {
            TemporalStatus::Skipped => Self::Skipped,
            TemporalStatus::Blended => Self::Blended,
            TemporalStatus::Reset => Self::Reset,
            TemporalStatus::Recovered => Self::Recovered,
            TemporalStatus::Unanswered => Self::Unanswered,
        }
    }
}

const _: () = {
    assert!(refl_temporal_status::Skipped as u32 == TemporalStatus::Skipped as u32);
    assert!(refl_temporal_status::Blended as u32 == TemporalStatus::Blended as u32);
    assert!(refl_temporal_status::Reset as u32 == TemporalStatus::Reset as u32);
    assert!(refl_temporal_status::Recovered as u32 == TemporalStatus::Recovered as u32);
    assert!(refl_temporal_status::Unanswered as u32 == TemporalStatus::Unanswered as u32);
};

/// Counts of one `refl_temporal_resolve_rows` call over its band.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_temporal_stats {
    /// Pixels answered and blended with history (`BLENDED`).
    pub blended: u32,
    /// Pixels answered without usable history (`RESET`).
    pub reset: u32,
    /// Failed pixels recovered from history (`RECOVERED`).
    pub recovered: u32,
    /// Failed pixels without history (`UNANSWERED`).
    pub unanswered: u32,
    /// Pixels with a surface whose re-projected point lies behind the
    /// history's camera or outside its image (with a history).
    pub off_screen: u32,
    /// Pixels whose re-projected history texels were all rejected (depth,
    /// normal, empty) although the point lies in the history's image.
    pub rejected: u32,
}

impl From<TemporalStats> for refl_temporal_stats {
    fn from(s: TemporalStats) -> Self {
        Self {
            blended: s.blended,
            reset: s.reset,
            recovered: s.recovered,
            unanswered: s.unanswered,
            off_screen: s.off_screen,
            rejected: s.rejected,
        }
    }
}

/// The filter's defaults: up to 8 frames averaged, history kept within 2%
/// of its depth of the current surface's tangent plane and within about 25
/// degrees of its normal (cosine 0.9), failed pixels recovered.
#[no_mangle]
pub extern "C" fn refl_temporal_options_default() -> refl_temporal_options {
    TemporalOptions::default().into()
}

/// The refl-core options of `o`, each field checked against its range
/// (the last-error message names the first one out of it).
fn options(o: &refl_temporal_options) -> Result<TemporalOptions, Error> {
    let bad = |field: &str, v: f32, range: &str| {
        fail(
            Error::InvalidArgument,
            format_args!("`options.{field}` is {v}, not {range}"),
        )
    };
    if !(o.max_frames >= 1.0) {
        return Err(bad("max_frames", o.max_frames, ">= 1"));
    }
    if !(o.depth_tolerance >= 0.0 && o.depth_tolerance.is_finite()) {
        return Err(bad("depth_tolerance", o.depth_tolerance, "finite and >= 0"));
    }
    if !(-1.0..=1.0).contains(&o.normal_cos) {
        return Err(bad("normal_cos", o.normal_cos, "in [-1, 1]"));
    }
    let t = TemporalOptions::from(*o);
    t.try_validate()
        .map_err(|e| fail(e, format_args!("`options` has a value out of range")))?;
    Ok(t)
}

/// The last-error detail of an image descriptor `name` that its view
/// refused (`e`; its NULL `data` is checked before, with the name).
pub(crate) fn image_error(
    e: Error,
    name: &str,
    len: usize,
    width: u32,
    height: u32,
    stride: u32,
) -> Error {
    match (e, try_required_len(width, height, stride)) {
        (Error::InsufficientSize, Ok(need)) => fail(
            e,
            format_args!("`{name}.len` is {len}, a {width}x{height} image of stride {stride} needs {need}"),
        ),
        (Error::InvalidArgument, Err(_)) => fail(
            e,
            format_args!(
                "`{name}` is {width}x{height} with stride {stride} (a zero size, a stride below the width, or too many texels)"
            ),
        ),
        _ => fail(
            e,
            format_args!("`{name}.data` is misaligned, or `{name}` does not fit in memory"),
        ),
    }
}

/// `InvalidArgument` naming `name` unless `(width, height)` is the
/// G-buffer's `(w, h)`.
pub(crate) fn same_size(name: &str, width: u32, height: u32, w: u32, h: u32) -> Result<(), Error> {
    if width == w && height == h {
        return Ok(());
    }
    Err(fail(
        Error::InvalidArgument,
        format_args!("`{name}` is {width}x{height}, the G-buffer is {w}x{h}"),
    ))
}

/// The byte range of an optional image (`(0, 0)` when its `data` is NULL).
pub(crate) fn image_range<T>(data: *const T, len: usize) -> (usize, usize) {
    if data.is_null() {
        (0, 0)
    } else {
        range(data, len)
    }
}

/// `InvalidArgument` naming the first output that overlaps a later output
/// or an input (`(name, (address, bytes))`).
pub(crate) fn named_disjoint(
    outs: &[(&str, (usize, usize))],
    ins: &[(&str, (usize, usize))],
) -> Result<(), Error> {
    for (k, (name, a)) in outs.iter().enumerate() {
        let clash = outs[k + 1..]
            .iter()
            .chain(ins.iter())
            .find(|(_, b)| overlaps(a.0, a.1, b.0, b.1));
        if let Some((other, _)) = clash {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`{name}` overlaps `{other}`"),
            ));
        }
    }
    Ok(())
}

/// Runs the temporal filter over the rows `rows` of the G-buffer: for each
/// pixel of those rows writes its next history texel to `next` (its
/// `color` is this frame's filtered reflection) and, if `status.data` is
/// not NULL, its `refl_temporal_status` as a byte to `status`; only the
/// band's rows of `next` and `status` are written. The counts go to
/// `*out_stats`. Per pixel (refl-core's `temporal` documents each step):
/// the pixel's world point is projected into `history`'s camera, the 2x2
/// history texels around it are kept if they hold history, lie on the
/// current surface's tangent plane (`depth_tolerance`) and face its way
/// (`normal_cos`); an answered pixel with history blends into it (the
/// running mean up to `max_frames` frames), one without starts anew; a
/// failed pixel takes the history's color where at least half of the
/// bilinear footprint survives (`recover`), or keeps `current`'s fallback.
///
/// Inputs, each the G-buffer's size: `current`, this frame's reflection
/// colors (linear RGB; e.g. `refl_ssr_trace_rows`'s color with the host's
/// traced rays filled in, and the host's fallback where a ray failed);
/// `answered`, nonzero where this frame's reflection is known (a hit, the
/// sky, a host ray the host traced), 0 where the ray failed (a non-finite
/// `current` counts as failed); `distance`, optional (`data` NULL: the
/// seed's re-projection of the surface point), each answered pixel's
/// reflection distance (a hit's `t`, +infinity for the sky; 0, negative or
/// NaN where unknown), with which the history is re-projected through the
/// reflection's virtual point (no lag behind reflections that move against
/// their mirror); `history`, the last frame's texels and camera (texels
/// `data` NULL: none). `next` must not be the history's buffer: keep two
/// and swap them every frame. Bands are independent: split the rows
/// (`refl_image_row_band`) across threads.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `next.data`,
/// `gbuffer`, `current.data`, `answered.data`, `history`, `options` or a
/// required G-buffer image is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if an
/// image's `len` is too small; `REFL_STATUS_INVALID_ARGUMENT` for an option
/// out of range (NaN included), rows reversed, empty or beyond the height,
/// an image (`next`, `status`, `current`, `answered`, `distance`, the
/// history's texels) not of the G-buffer's size, history texels not of
/// their camera's size, a zero size or a stride below the width, a
/// misaligned pointer, outputs overlapping each other or an input (`next`
/// the history's own buffer included), an unknown convention or normal
/// space; the camera's status if the G-buffer's or the history's camera is
/// invalid. The last-error message names the argument. Nothing is written
/// on error.
///
/// # Safety
/// `out_stats` NULL or writable; `next.data` NULL or writable for
/// `next.len` texels and `status.data` for `status.len` bytes; `gbuffer`,
/// `history` and `options` NULL or readable; every other image readable for
/// its `len` texels and not written during the call. No other thread
/// accesses the rows of `next` and `status` this call writes.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_temporal_resolve_rows(
    out_stats: *mut refl_temporal_stats,
    next: refl_image_temporal_texel_mut,
    status: refl_image_u8_mut,
    gbuffer: *const refl_gbuffer,
    current: refl_image_vec3,
    answered: refl_image_u8,
    distance: refl_image_f32,
    history: *const refl_temporal_history,
    options: *const refl_temporal_options,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_temporal_resolve_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        // Every required pointer before any size: NULL is reported first.
        no_nulls(&[
            (next.data.is_null(), "next.data"),
            (gbuffer.is_null(), "gbuffer"),
            (current.data.is_null(), "current.data"),
            (answered.data.is_null(), "answered.data"),
            (history.is_null(), "history"),
            (options.is_null(), "options"),
        ])?;
        // SAFETY: caller contract.
        let (g, hist, o) = unsafe {
            (
                read(gbuffer, "gbuffer")?,
                read(history, "history")?,
                read(options, "options")?,
            )
        };
        no_nulls(&[
            (g.depth.depth.data.is_null(), "gbuffer.depth.depth.data"),
            (g.normals.data.is_null(), "gbuffer.normals.data"),
        ])?;
        let opts = self::options(&o)?;
        // SAFETY: caller contract.
        let gb = unsafe { self::gbuffer(&g) }?;
        let (w, h) = (gb.width(), gb.height());
        let rows = rows.within(h)?;

        // The inputs, each of the G-buffer's size.
        // SAFETY: caller contract.
        let cur = unsafe { current.view() }.map_err(|e| {
            image_error(
                e,
                "current",
                current.len,
                current.width,
                current.height,
                current.stride,
            )
        })?;
        same_size("current", cur.width(), cur.height(), w, h)?;
        // SAFETY: caller contract.
        let ans = unsafe { answered.view() }.map_err(|e| {
            let a = &answered;
            image_error(e, "answered", a.len, a.width, a.height, a.stride)
        })?;
        same_size("answered", ans.width(), ans.height(), w, h)?;
        let dist = if distance.data.is_null() {
            None
        } else {
            // SAFETY: caller contract.
            let d = unsafe { distance.view() }.map_err(|e| {
                let d = &distance;
                image_error(e, "distance", d.len, d.width, d.height, d.stride)
            })?;
            same_size("distance", d.width(), d.height(), w, h)?;
            Some(d)
        };
        let texels = hist.texels;
        let past = if texels.data.is_null() {
            None
        } else {
            let cam = camera_named(&hist.camera, "history.camera")?;
            // SAFETY: caller contract.
            let t = unsafe { texels.view() }.map_err(|e| {
                image_error(
                    e,
                    "history.texels",
                    texels.len,
                    texels.width,
                    texels.height,
                    texels.stride,
                )
            })?;
            if t.width() != cam.width() || t.height() != cam.height() {
                return Err(fail(
                    Error::InvalidArgument,
                    format_args!(
                        "`history.texels` is {}x{}, `history.camera` is {}x{}",
                        t.width(),
                        t.height(),
                        cam.width(),
                        cam.height()
                    ),
                ));
            }
            same_size("history", cam.width(), cam.height(), w, h)?;
            Some(History::try_new(cam, t)?)
        };

        // The outputs: the G-buffer's size, disjoint from each other and
        // from every input.
        same_size("next", next.width, next.height, w, h)?;
        if !status.data.is_null() {
            same_size("status", status.width, status.height, w, h)?;
        }
        let gr = gbuffer_ranges(&g);
        let ins = [
            ("gbuffer.depth", gr[0]),
            ("gbuffer.normals", gr[1]),
            ("gbuffer.mask", gr[2]),
            ("gbuffer.roughness", gr[3]),
            ("gbuffer.color", gr[4]),
            ("gbuffer.back_depth", gr[5]),
            ("current", range(current.data, current.len)),
            ("answered", range(answered.data, answered.len)),
            ("distance", image_range(distance.data, distance.len)),
            ("history.texels", image_range(texels.data, texels.len)),
        ];
        let outs = [
            ("next", range(next.data.cast_const(), next.len)),
            ("status", image_range(status.data.cast_const(), status.len)),
            ("out_stats", range(out_stats.cast_const(), 1)),
        ];
        named_disjoint(&outs, &ins)?;
        // SAFETY: caller contract (the band's rows writable, not accessed
        // by others during the call); disjoint from every input (checked).
        let mut next_v = unsafe { next.band_mut(rows) }
            .map_err(|e| image_error(e, "next", next.len, next.width, next.height, next.stride))?;
        let mut status_v = if status.data.is_null() {
            None
        } else {
            // SAFETY: as `next`.
            Some(unsafe { status.band_mut(rows) }.map_err(|e| {
                image_error(
                    e,
                    "status",
                    status.len,
                    status.width,
                    status.height,
                    status.stride,
                )
            })?)
        };

        let mut pass = TemporalPass::try_new(gb, cur, ans, past, opts)?;
        if let Some(d) = dist {
            pass = pass.try_with_distance(d)?;
        }
        let stats = pass.try_run(&mut next_v, status_v.as_mut())?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(stats.into()) };
        Ok(())
    })
}
