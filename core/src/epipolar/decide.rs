//! The rendering phase's per-pixel decisions (seed 002 Alg. 2, Sec. 3.3;
//! regular resampling of Sec. 4.3, shifted ray origin of Sec. 5.3): test
//! the reprojected object only, or full traversal for the host's tracer.

use super::{AipEntry, EpipolarOptions, BACKGROUND_OBJECT, INVALID_OBJECT};
use crate::{Error, RowRange};

/// Why a pixel takes the path its [`Decision`] names (seed 002 Fig. 6
/// colors in brackets).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Reason {
    /// Reprojection predicts the object: one ray/object test (red).
    Reprojected = 0,
    /// Too few points reached the pixel (`cnt < m_cnt`) or none (green).
    Failed = 1,
    /// Regular resampling picked the pixel this frame (white).
    Resampled = 2,
    /// A point near the pixel was discarded by the abrupt-motion test
    /// (blue).
    Abrupt = 3,
    /// No reprojection this frame (first frame, view-frustum check).
    Unavailable = 4,
}

/// The rendering-phase decision for one pixel (seed 002 Alg. 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Decision {
    /// The one object to test, or [`INVALID_OBJECT`] for full traversal.
    /// [`BACKGROUND_OBJECT`] means the pixel is background. If the test of
    /// a scene object finds no hit in `[0, tmax)`, the host falls back to
    /// full traversal from `tmin` (and counts the pixel as a failed
    /// reprojection).
    pub object: u32,
    /// End of the interval of the one-object test: the depth guard
    /// `t_other * (1 - guard_margin)` ([`AipEntry::t_other`],
    /// [`EpipolarOptions::guard_margin`]) with [`EpipolarOptions::depth_guard`], else `+inf`.
    pub tmax: f32,
    /// Ray distance at which a full traversal of this pixel may start:
    /// 0, or with [`EpipolarOptions::shift_origin`] the AIP distance minus epsilon
    /// (Sec. 5.3).
    pub tmin: f32,
    /// Why.
    pub reason: Reason,
}

/// The regular-resampling slot of pixel `(x, y)` for period `n` (seed 002
/// Sec. 4.3): the pixel is computed by the ORSA in frame `k` when
/// `resample_slot(x, y, n) == k mod n`, so the `n` frames use disjoint pixel
/// sets that cover the image.
///
/// For `n = 9` the slots tile the image with a 3x3 window in which
/// consecutive slots are a knight's move or more apart (the paper's Fig. 5
/// pattern is not reproduced in its text; this is our low-discrepancy
/// choice, every 3x3 window holding each slot once). For other `n` the slot
/// is the rank-1 lattice `(x + s y) mod n` with `s` the integer nearest
/// `0.618 n` that is coprime with `n` (so every run of `n` pixels in a row
/// holds each slot once). `n = 0` has no slots (returns `u32::MAX`).
pub fn resample_slot(x: u32, y: u32, n: u32) -> u32 {
    const PATTERN: [u32; 9] = [0, 6, 3, 4, 1, 7, 8, 5, 2];
    match n {
        0 => u32::MAX,
        1 => 0,
        9 => PATTERN[((y % 3) * 3 + x % 3) as usize],
        _ => {
            let mut s = libm::roundf(n as f32 * 0.618) as u32;
            while gcd(s, n) != 1 {
                s -= 1;
            }
            ((u64::from(x) + u64::from(s) * u64::from(y)) % u64::from(n)) as u32
        }
    }
}

fn gcd(mut a: u32, mut b: u32) -> u32 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// The rendering-phase decision of seed 002 Alg. 2 for pixel `(x, y)` of
/// frame `frame` with AIP entry `aip`:
///
/// 1. no reprojection this frame ([`AipEntry::NO_REPROJECTION`]):
///    full traversal ([`Reason::Unavailable`]);
/// 2. the pixel's regular-resampling slot is `frame mod N`: full traversal
///    ([`Reason::Resampled`]);
/// 3. a point near the pixel was dropped by the abrupt-motion test: full
///    traversal ([`Reason::Abrupt`]);
/// 4. `cnt >= m_cnt`: test `aip.object` only, on `[0, tmax)` with `tmax`
///    the depth guard ([`Reason::Reprojected`]); when the guard is on, a
///    background prediction with another object's point in its splat
///    (finite `t_other`) and any prediction whose points do not surround
///    the pixel center ([`AipEntry::SURROUNDED`]) take full traversal
///    instead;
/// 5. otherwise full traversal ([`Reason::Failed`]).
///
/// With [`EpipolarOptions::shift_origin`], a full traversal of a pixel whose entry
/// holds a scene object starts at `max(0, aip.t - shift_epsilon)` (Sec. 5.3).
/// The paper's argument is that no hit lies nearer than the nearest
/// reprojected point; that holds only where the reprojection is complete
/// (a newly disoccluded object nearer than `aip.t` would be skipped), which
/// is why it is off by default. Background entries never shift.
pub fn decide(aip: &AipEntry, x: u32, y: u32, frame: u32, options: &EpipolarOptions) -> Decision {
    let traverse = |reason| {
        let tmin = if options.shift_origin
            && aip.object != INVALID_OBJECT
            && aip.object != BACKGROUND_OBJECT
            && aip.t.is_finite()
        {
            (aip.t - options.shift_epsilon).max(0.0)
        } else {
            0.0
        };
        Decision {
            object: INVALID_OBJECT,
            tmin,
            tmax: f32::INFINITY,
            reason,
        }
    };
    if aip.flags & AipEntry::NO_REPROJECTION != 0 {
        return Decision {
            object: INVALID_OBJECT,
            tmin: 0.0,
            tmax: f32::INFINITY,
            reason: Reason::Unavailable,
        };
    }
    let n = options.resample_period;
    if n > 0 && resample_slot(x, y, n) == frame % n {
        return traverse(Reason::Resampled);
    }
    // Fig. 6 (blue): pixels near a point dropped for abrupt motion take the
    // ORSA. Dropping the near point alone would leave the farther points
    // around it unchallenged: they would win the pixel and the one-object
    // test would hit them through the object that was dropped.
    if aip.flags & AipEntry::ABRUPT_REJECTED != 0 {
        return traverse(Reason::Abrupt);
    }
    if aip.object != INVALID_OBJECT && aip.cnt >= options.m_cnt {
        let tmax = if options.depth_guard {
            aip.t_other * (1.0 - options.guard_margin)
        } else {
            f32::INFINITY
        };
        // A background decision has no ray/object test to bound: with the
        // depth guard, any other object's point in the splat sends the pixel
        // to full traversal.
        if aip.object == BACKGROUND_OBJECT && options.depth_guard && aip.t_other.is_finite() {
            return traverse(Reason::Failed);
        }
        // Just outside the object's silhouette (its points on one side of
        // the center only) the pixel may show a surface never sampled.
        if options.depth_guard && aip.flags & AipEntry::SURROUNDED != AipEntry::SURROUNDED {
            return traverse(Reason::Failed);
        }
        return Decision {
            object: aip.object,
            tmin: 0.0,
            tmax,
            reason: Reason::Reprojected,
        };
    }
    traverse(Reason::Failed)
}

/// [`decide`] for the rows `rows` of a `width`-wide image: `out[i]` for
/// pixel index `i = y * width + x` (only the rows in `rows` are written).
/// [`try_decide_band`] writes a band-sized buffer instead.
///
/// # Errors
/// [`Error::InvalidArgument`] for a zero width or invalid `options`;
/// [`Error::InsufficientSize`] if `aip` or `out` is shorter than
/// `rows.end() * width`. Nothing is written on error.
pub fn try_decide_rows(
    out: &mut [Decision],
    aip: &[AipEntry],
    width: u32,
    rows: RowRange,
    frame: u32,
    options: &EpipolarOptions,
) -> Result<(), Error> {
    let (start, end) = (
        rows.start() as usize * width as usize,
        rows.end() as usize * width as usize,
    );
    check_decide(width, options)?;
    let band = out.get_mut(start..end).ok_or(Error::InsufficientSize)?;
    try_decide_band(band, aip, width, rows, frame, options)
}

/// The checks shared by [`try_decide_rows`] and [`try_decide_band`].
fn check_decide(width: u32, options: &EpipolarOptions) -> Result<(), Error> {
    options.try_validate()?;
    if width == 0 {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

/// [`decide`] for the rows `rows` of a `width`-wide image into the band
/// `band`: `band[i - rows.start() * width]` for pixel index
/// `i = y * width + x`, so that threads deciding disjoint bands each hold
/// only their rows. `band` holds [`Decision`]s or any type made from one
/// (`From<Decision>`, the C ABI's record).
///
/// # Errors
/// [`Error::InvalidArgument`] for a zero width or invalid `options`;
/// [`Error::InsufficientSize`] if `aip` is shorter than
/// `rows.end() * width` or `band` than `rows.len() * width`. Nothing is
/// written on error.
pub fn try_decide_band<O: From<Decision>>(
    band: &mut [O],
    aip: &[AipEntry],
    width: u32,
    rows: RowRange,
    frame: u32,
    options: &EpipolarOptions,
) -> Result<(), Error> {
    check_decide(width, options)?;
    let w = width as usize;
    if aip.len() < rows.end() as usize * w || band.len() < rows.len() as usize * w {
        return Err(Error::InsufficientSize);
    }
    for (o, y) in band.chunks_exact_mut(w).zip(rows.rows()) {
        let row = y as usize * w;
        for (x, o) in (0..width).zip(o) {
            *o = decide(&aip[row + x as usize], x, y, frame, options).into();
        }
    }
    Ok(())
}
