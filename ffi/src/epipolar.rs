//! Reprojected ray casting exports (seed 002, Havran, Bittner, Seidel:
//! "Exploiting Temporal Coherence in Ray Casted Walkthroughs"): the POS and
//! AIP buffers, the reprojection phase (Alg. 1 with the view-frustum check
//! of Sec. 4.1, the epipolar occlusion check of Sec. 4.2 and the
//! abrupt-motion test of Sec. 4.3.1) and the per-pixel decision of the
//! rendering phase (Alg. 2: "test object O only" or "full traversal from
//! t"). The host traces; refl decides. See `refl_core::epipolar`.

use crate::image::refl_row_range;
use crate::ptr::{byte_len, overlaps, read, Out};
use crate::status::{guard, refl_status};
use crate::types::refl_camera;
use core::mem::size_of;
use refl_core::epipolar::{
    try_decide_band, try_reproject, try_scratch_len, AipEntry, Decision, EpipolarOptions, PosEntry,
    Reason, ReprojectStats, BACKGROUND_OBJECT, INVALID_OBJECT, MAX_SPLAT_RADIUS,
};
use refl_core::{Error, RowRange};

/// Object id meaning "no object": an unused POS entry (never reprojected)
/// or an AIP entry no point reached; in a decision, "full traversal".
pub const REFL_EPIPOLAR_INVALID_OBJECT: u32 = 0xFFFF_FFFF;

/// Object id of the background sphere (seed 002 Sec. 5.2): store it in the
/// POS entry of a pixel whose ray hit nothing, with the point at a fixed
/// distance (larger than any scene distance) along the ray. A decision to
/// test this object means the pixel is background.
pub const REFL_EPIPOLAR_BACKGROUND_OBJECT: u32 = 0xFFFF_FFFE;

/// Largest splat radius (`refl_epipolar_options.splat_radius`): 7x7.
pub const REFL_EPIPOLAR_MAX_SPLAT_RADIUS: u32 = 3;

/// AIP flag: no reprojection ran this frame (first frame, or the
/// view-frustum check failed); every pixel takes full traversal.
pub const REFL_EPIPOLAR_FLAG_NO_REPROJECTION: u32 = 1;
/// AIP flag: a point whose splat covers the pixel was discarded by the
/// occlusion check (Sec. 4.2).
pub const REFL_EPIPOLAR_FLAG_OCCLUSION_REJECTED: u32 = 2;
/// AIP flag: a point whose splat covers the pixel was discarded by the
/// abrupt-motion test (Sec. 4.3.1).
pub const REFL_EPIPOLAR_FLAG_ABRUPT_REJECTED: u32 = 4;
/// AIP flag: a splatted point of the entry's object landed above-left of
/// the pixel center; the next three bits (`<< 1`: above-right, `<< 2`:
/// below-left, `<< 3`: below-right) the other sides.
pub const REFL_EPIPOLAR_FLAG_SURROUND_UP_LEFT: u32 = 16;
/// AIP flags: all four surround bits. With the depth guard on, a pixel is
/// resolved by one ray/object test only when all four are set (the
/// object's points surround the pixel center).
pub const REFL_EPIPOLAR_FLAG_SURROUNDED: u32 = 0xF0;

/// One entry of the POS buffer (seed 002 Sec. 3.1): what the ray of one
/// pixel of the previous frame hit. Layout-identical to
/// `refl_core::epipolar::PosEntry`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_epipolar_pos_entry {
    /// World-space hit point (`eye + t * unit direction`).
    pub point: [f32; 3],
    /// Object id of the hit (the host's numbering, below
    /// `REFL_EPIPOLAR_BACKGROUND_OBJECT`); `REFL_EPIPOLAR_BACKGROUND_OBJECT`
    /// for a background-sphere point; `REFL_EPIPOLAR_INVALID_OBJECT` for
    /// "nothing stored" (skipped).
    pub object: u32,
    /// Signed distance from the eye to `point` along the ray.
    pub t: f32,
}

/// One entry of the AIP buffer (seed 002 Sec. 3.1, Alg. 1), written by
/// `refl_epipolar_reproject`. Before the first frame (no POS yet) fill it
/// with `{REFL_EPIPOLAR_INVALID_OBJECT, INFINITY, 0, INFINITY,
/// REFL_EPIPOLAR_FLAG_NO_REPROJECTION}`. Layout-identical to
/// `refl_core::epipolar::AipEntry`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_epipolar_aip_entry {
    /// Object reprojected to the pixel, or `REFL_EPIPOLAR_INVALID_OBJECT`.
    pub object: u32,
    /// Smallest signed distance from the new eye of the points splatted
    /// here; +infinity when none.
    pub t: f32,
    /// Number of points of `object` splatted here (`cnt` of Alg. 1).
    pub cnt: u32,
    /// Depth guard: the smallest signed distance of a point of another
    /// object splatted here; +infinity when none.
    pub t_other: f32,
    /// Bit set of `REFL_EPIPOLAR_FLAG_*`.
    pub flags: u32,
}

/// Settings of the reprojection and rendering phases
/// (`refl_epipolar_options_default` gives the defaults).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_epipolar_options {
    /// `m_cnt` of Sec. 3.3: a pixel is resolved by one ray/object test when
    /// at least this many points of its object reached it. >= 1; default 5.
    pub m_cnt: u32,
    /// Splat radius r: a (2r+1)^2 kernel; 1 (3x3, the paper's) by default;
    /// at most `REFL_EPIPOLAR_MAX_SPLAT_RADIUS`.
    pub splat_radius: u32,
    /// Depth guard (default on): the one-object test only accepts a hit
    /// nearer than `refl_epipolar_aip_entry.t_other`.
    pub depth_guard: bool,
    /// Relative margin of the depth guard, in [0, 1); default 0.01: the
    /// one-object test accepts hits nearer than `t_other * (1 - margin)`.
    pub guard_margin: f32,
    /// Guard window radius (default 3, at most
    /// `REFL_EPIPOLAR_MAX_SPLAT_RADIUS`, 0 off): after the splat each
    /// pixel's `t_other` is lowered to the `t` of the entries within this
    /// many pixels that hold another object.
    pub guard_window: u32,
    /// View-frustum check of Sec. 4.1 (default on).
    pub frustum_check: bool,
    /// Epipolar ordering and occlusion check of Sec. 4.2 (default on).
    pub occlusion_check: bool,
    /// N of regular resampling (Sec. 4.3); 0 turns it off. Default 9.
    pub resample_period: u32,
    /// N of the abrupt-motion test (Sec. 4.3.1); 0 turns it off. Default 9.
    pub abrupt_frames: u32,
    /// Shifted ray origin of Sec. 5.3 for fallback rays (default off).
    pub shift_origin: bool,
    /// The epsilon of Sec. 5.3, world units, finite and >= 0.
    pub shift_epsilon: f32,
}

/// Counts of one reprojection phase.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_epipolar_stats {
    /// POS entries holding a point.
    pub points: u32,
    /// Points splatted into the AIP.
    pub splatted: u32,
    /// Points at or behind the new eye plane (dropped).
    pub behind: u32,
    /// Points whose splat misses the new image.
    pub outside: u32,
    /// Points discarded by the occlusion check.
    pub occlusion_rejected: u32,
    /// Points discarded by the abrupt-motion test.
    pub abrupt_rejected: u32,
    /// The view-frustum check failed and nothing was reprojected.
    pub frustum_failed: bool,
    /// The eyes coincide (pure rotation; no occlusion check needed).
    pub no_baseline: bool,
}

/// Why a pixel takes the path its decision names (seed 002 Fig. 6).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum refl_epipolar_reason {
    /// Reprojection predicts the object: one ray/object test.
    Reprojected = 0,
    /// Too few points reached the pixel: full traversal.
    Failed = 1,
    /// Regular resampling picked the pixel this frame: full traversal.
    Resampled = 2,
    /// A point near the pixel was discarded for abrupt motion: full
    /// traversal.
    Abrupt = 3,
    /// No reprojection this frame: full traversal.
    Unavailable = 4,
}

/// The rendering-phase decision for one pixel (seed 002 Alg. 2).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_epipolar_decision {
    /// The one object to test, or `REFL_EPIPOLAR_INVALID_OBJECT` for full
    /// traversal; `REFL_EPIPOLAR_BACKGROUND_OBJECT` means background. When
    /// the test of a scene object finds no hit in `[0, tmax)`, fall back
    /// to full traversal from `tmin`.
    pub object: u32,
    /// End of the interval of the one-object test (the depth guard, or
    /// +infinity).
    pub tmax: f32,
    /// Ray distance at which a full traversal of this pixel may start
    /// (0, or with `shift_origin` the AIP distance minus epsilon).
    pub tmin: f32,
    /// A `refl_epipolar_reason` value.
    pub reason: u32,
}

const _: () = {
    use core::mem::{align_of, size_of};
    // The C constants are literals (cbindgen); they equal the core's.
    assert!(REFL_EPIPOLAR_INVALID_OBJECT == INVALID_OBJECT);
    assert!(REFL_EPIPOLAR_BACKGROUND_OBJECT == BACKGROUND_OBJECT);
    assert!(REFL_EPIPOLAR_MAX_SPLAT_RADIUS == MAX_SPLAT_RADIUS);
    assert!(REFL_EPIPOLAR_FLAG_NO_REPROJECTION == AipEntry::NO_REPROJECTION);
    assert!(REFL_EPIPOLAR_FLAG_OCCLUSION_REJECTED == AipEntry::OCCLUSION_REJECTED);
    assert!(REFL_EPIPOLAR_FLAG_ABRUPT_REJECTED == AipEntry::ABRUPT_REJECTED);
    assert!(REFL_EPIPOLAR_FLAG_SURROUND_UP_LEFT == AipEntry::SURROUND_UP_LEFT);
    assert!(REFL_EPIPOLAR_FLAG_SURROUNDED == AipEntry::SURROUNDED);
    assert!(size_of::<refl_epipolar_pos_entry>() == size_of::<PosEntry>());
    assert!(align_of::<refl_epipolar_pos_entry>() == align_of::<PosEntry>());
    assert!(size_of::<refl_epipolar_aip_entry>() == size_of::<AipEntry>());
    assert!(align_of::<refl_epipolar_aip_entry>() == align_of::<AipEntry>());
};

impl TryFrom<&refl_epipolar_options> for EpipolarOptions {
    type Error = Error;
    /// Validates the ranges (`EpipolarOptions::try_validate`).
    fn try_from(o: &refl_epipolar_options) -> Result<Self, Error> {
        let options = EpipolarOptions {
            m_cnt: o.m_cnt,
            splat_radius: o.splat_radius,
            depth_guard: o.depth_guard,
            guard_margin: o.guard_margin,
            guard_window: o.guard_window,
            frustum_check: o.frustum_check,
            occlusion_check: o.occlusion_check,
            resample_period: o.resample_period,
            abrupt_frames: o.abrupt_frames,
            shift_origin: o.shift_origin,
            shift_epsilon: o.shift_epsilon,
        };
        options.try_validate()?;
        Ok(options)
    }
}

impl From<&EpipolarOptions> for refl_epipolar_options {
    fn from(o: &EpipolarOptions) -> Self {
        Self {
            m_cnt: o.m_cnt,
            splat_radius: o.splat_radius,
            depth_guard: o.depth_guard,
            guard_margin: o.guard_margin,
            guard_window: o.guard_window,
            frustum_check: o.frustum_check,
            occlusion_check: o.occlusion_check,
            resample_period: o.resample_period,
            abrupt_frames: o.abrupt_frames,
            shift_origin: o.shift_origin,
            shift_epsilon: o.shift_epsilon,
        }
    }
}

impl From<Decision> for refl_epipolar_decision {
    fn from(d: Decision) -> Self {
        (&d).into()
    }
}

impl From<&Decision> for refl_epipolar_decision {
    fn from(d: &Decision) -> Self {
        Self {
            object: d.object,
            tmax: d.tmax,
            tmin: d.tmin,
            reason: match d.reason {
                Reason::Reprojected => refl_epipolar_reason::Reprojected,
                Reason::Failed => refl_epipolar_reason::Failed,
                Reason::Resampled => refl_epipolar_reason::Resampled,
                Reason::Abrupt => refl_epipolar_reason::Abrupt,
                Reason::Unavailable => refl_epipolar_reason::Unavailable,
            } as u32,
        }
    }
}

/// Checks a caller buffer of `len` elements of `T`: non-null, aligned,
/// addressable; returns its byte range.
fn buffer<T>(p: *const T, len: usize) -> Result<(usize, usize), Error> {
    if p.is_null() {
        return Err(Error::NullPointer);
    }
    if !p.is_aligned() {
        return Err(Error::InvalidArgument);
    }
    Ok((p as usize, byte_len::<T>(p as usize, len)?))
}

/// The defaults (m_cnt 5, 3x3 splat, depth guard, view-frustum and
/// occlusion checks on, N = 9 for resampling and the abrupt-motion test, no
/// shifted origin, epsilon 1e-3).
#[no_mangle]
pub extern "C" fn refl_epipolar_options_default() -> refl_epipolar_options {
    (&EpipolarOptions::default()).into()
}

/// Writes to `*out_len` the number of floats of scratch
/// `refl_epipolar_reproject` needs for a `width x height` image (the
/// occlusion check's epipolar-line records, then the guard window's ring of
/// row summaries; the larger of the two). The POS and AIP buffers hold
/// `width * height` entries each.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_len` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a zero size or a count that does not
/// fit in `size_t`.
///
/// # Safety
/// `out_len` must be NULL or point to a writable `size_t`.
#[no_mangle]
pub unsafe extern "C" fn refl_epipolar_scratch_len(
    out_len: *mut usize,
    width: u32,
    height: u32,
) -> refl_status {
    guard("refl_epipolar_scratch_len", || {
        let out = Out::new(out_len, "out_len")?;
        let n = try_scratch_len(width, height)?;
        // SAFETY: caller contract.
        unsafe { out.write(n) };
        Ok(())
    })
}

/// The reprojection phase (seed 002 Alg. 1 with Secs. 4.1, 4.2, 4.3.1):
/// fills `aip` (`current`'s `width * height` pixels, row-major) from `pos`
/// (`previous`'s pixels, row-major) and writes the counts to `*out_stats`.
/// If the view-frustum check is on and `current`'s eye is outside
/// `previous`'s view pyramid, every AIP entry gets
/// `REFL_EPIPOLAR_FLAG_NO_REPROJECTION`. The pass is sequential (the
/// epipolar order is); `refl_epipolar_decide_rows` then runs per row band.
///
/// Returns `REFL_STATUS_NULL_POINTER` if any pointer is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for invalid options (`m_cnt == 0`, a
/// splat radius above the maximum, a bad epsilon), cameras
/// of different sizes, a misaligned pointer or overlapping buffers;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `aip_len` or `pos_len` is below
/// `width * height` or `scratch_len` below `refl_epipolar_scratch_len`;
/// a camera's status if it is invalid. On error nothing is written.
///
/// # Safety
/// `aip` must be writable for `aip_len` entries, `scratch` for
/// `scratch_len` floats, `pos` readable for `pos_len` entries, the other
/// pointers NULL or valid for one value, for the duration of the call,
/// with no other thread accessing them.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_epipolar_reproject(
    aip: *mut refl_epipolar_aip_entry,
    aip_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    out_stats: *mut refl_epipolar_stats,
    pos: *const refl_epipolar_pos_entry,
    pos_len: usize,
    previous: *const refl_camera,
    current: *const refl_camera,
    options: *const refl_epipolar_options,
) -> refl_status {
    guard("refl_epipolar_reproject", || {
        crate::ptr::no_nulls(&[
            (aip.is_null(), "aip"),
            (scratch.is_null(), "scratch"),
            (pos.is_null(), "pos"),
            (previous.is_null(), "previous"),
            (current.is_null(), "current"),
            (options.is_null(), "options"),
        ])?;
        let out = Out::new(out_stats, "out_stats")?;
        // SAFETY: caller contract.
        let p = EpipolarOptions::try_from(&unsafe { read(options, "options") }?)?;
        // SAFETY: caller contract.
        let prev = crate::types::camera_named(&unsafe { read(previous, "previous") }?, "previous")?;
        // SAFETY: caller contract.
        let cur = crate::types::camera_named(&unsafe { read(current, "current") }?, "current")?;
        let a = buffer(aip.cast_const(), aip_len)?;
        let s = buffer(scratch.cast_const(), scratch_len)?;
        let q = buffer(pos, pos_len)?;
        if overlaps(a.0, a.1, s.0, s.1)
            || overlaps(a.0, a.1, q.0, q.1)
            || overlaps(s.0, s.1, q.0, q.1)
        {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: non-null, aligned, sizes checked by `buffer`; validity
        // and exclusivity are the caller's contract; the three ranges are
        // disjoint; the entry types are layout-identical (asserted above).
        let (aip, scratch, pos) = unsafe {
            (
                core::slice::from_raw_parts_mut(aip.cast::<AipEntry>(), aip_len),
                core::slice::from_raw_parts_mut(scratch, scratch_len),
                core::slice::from_raw_parts(pos.cast::<PosEntry>(), pos_len),
            )
        };
        let st: ReprojectStats = try_reproject(aip, scratch, pos, &prev, &cur, &p)?;
        // SAFETY: caller contract.
        unsafe {
            out.write(refl_epipolar_stats {
                points: st.points,
                splatted: st.splatted,
                behind: st.behind,
                outside: st.outside,
                occlusion_rejected: st.occlusion_rejected,
                abrupt_rejected: st.abrupt_rejected,
                frustum_failed: st.frustum_failed,
                no_baseline: st.no_baseline,
            })
        };
        Ok(())
    })
}

/// The rendering-phase decisions (seed 002 Alg. 2) of the rows `rows` of
/// frame `frame` of a `width`-wide image: `out[y * width + x]` from
/// `aip[y * width + x]` (other entries are not touched, and only the band's
/// entries of `out` are accessed). Hosts split the image into row bands
/// (`refl_image_row_band`) and decide and trace them on their own threads.
///
/// Per pixel: no reprojection -> full traversal (`UNAVAILABLE`); the
/// pixel's regular-resampling slot is `frame mod N` -> full traversal
/// (`RESAMPLED`); an abrupt-motion flag -> full traversal (`ABRUPT`);
/// `cnt >= m_cnt` -> test `object` on `[0, tmax)` (`REPROJECTED`), and
/// if that misses, full traversal from `tmin`; else full traversal
/// (`FAILED`).
///
/// Returns `REFL_STATUS_NULL_POINTER` if a pointer is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for invalid options, a zero width, an
/// empty or reversed row range, a misaligned pointer or overlapping
/// buffers; `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len` or `aip_len` is
/// below `rows.end * width`. On error nothing is written.
///
/// # Safety
/// `out` must be writable for `out_len` entries and `aip` readable for
/// `aip_len` entries, `options` NULL or readable, for the duration of the
/// call; no other thread may access the rows of `out` in the range.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_epipolar_decide_rows(
    out: *mut refl_epipolar_decision,
    out_len: usize,
    aip: *const refl_epipolar_aip_entry,
    aip_len: usize,
    width: u32,
    rows: refl_row_range,
    frame: u32,
    options: *const refl_epipolar_options,
) -> refl_status {
    guard("refl_epipolar_decide_rows", || {
        crate::ptr::no_nulls(&[
            (out.is_null(), "out"),
            (aip.is_null(), "aip"),
            (options.is_null(), "options"),
        ])?;
        // SAFETY: caller contract.
        let p = EpipolarOptions::try_from(&unsafe { read(options, "options") }?)?;
        if width == 0 || rows.end <= rows.begin {
            return Err(Error::InvalidArgument);
        }
        let r = RowRange::try_new(rows.begin, rows.end, rows.end)?;
        let w = width as usize;
        let need = (rows.end as usize)
            .checked_mul(w)
            .ok_or(Error::InvalidArgument)?;
        if out_len < need || aip_len < need {
            return Err(Error::InsufficientSize);
        }
        // Only the band's entries of `out` and the first `need` of `aip`
        // are touched.
        let start = rows.begin as usize * w;
        let o = buffer(out.cast_const(), need)?;
        let a = buffer(aip, need)?;
        if overlaps(
            o.0 + start * size_of::<refl_epipolar_decision>(),
            (need - start) * size_of::<refl_epipolar_decision>(),
            a.0,
            a.1,
        ) {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: checked above; layouts match (asserted above).
        let aip = unsafe { core::slice::from_raw_parts(aip.cast::<AipEntry>(), need) };
        // SAFETY: within `out_len` (checked), disjoint from `aip`; the
        // band's rows are this call's alone (contract).
        let band = unsafe { core::slice::from_raw_parts_mut(out.add(start), need - start) };
        try_decide_band(band, aip, width, r, frame, &p)
    })
}
