//! Back-face depth images for the G-buffer (`refl_core::backface`): from
//! the host's second depth pass (back faces only) or from layered depth
//! cube maps, in the front depth's camera and convention, per row band.

use crate::image::{refl_image_f32, refl_image_f32_mut, refl_row_range};
#[cfg(feature = "layered")]
use crate::layered::refl_layered_map;
use crate::ptr::{byte_len, overlaps, read, Out};
use crate::status::{fail, guard, refl_status};
use crate::trace::{depth_image, refl_depth_image};
use refl_core::{BackDepthStats, Error};

/// Counts of one back-depth call.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_trace_back_depth_stats {
    /// Pixels with a front surface.
    pub surfaces: u32,
    /// Of those, pixels whose back value was NaN or in front of the front
    /// and was replaced by the front depth (`refl_trace_back_depth_rows`).
    pub clamped: u32,
    /// Of those, pixels whose back value is the cleared value: solid to
    /// the far plane (`refl_trace_back_depth_rows`).
    pub cleared: u32,
    /// Pixels where the layered map found the exit
    /// (`refl_trace_back_depth_layered_rows`).
    pub exits: u32,
}

impl From<BackDepthStats> for refl_trace_back_depth_stats {
    fn from(s: BackDepthStats) -> Self {
        Self {
            surfaces: s.surfaces,
            clamped: s.clamped,
            cleared: s.cleared,
            exits: s.exits,
        }
    }
}

/// The rows, checked against the front image's height, and `dst`'s band.
///
/// # Safety
/// `dst`'s band writable for the call and not accessed by others.
unsafe fn band<'a>(
    dst: &refl_image_f32_mut,
    h: u32,
    rows: refl_row_range,
) -> Result<refl_core::ImageViewMut<'a, f32>, Error> {
    // SAFETY: caller contract.
    unsafe { dst.band_mut(rows.within(h)?) }
}

fn dst_range(dst: &refl_image_f32_mut) -> Result<(usize, usize), Error> {
    Ok((
        dst.data as usize,
        byte_len::<f32>(dst.data as usize, dst.len)?,
    ))
}

fn refuse_overlap(outs: &[(usize, usize)], ins: &[(usize, usize)]) -> Result<(), Error> {
    for (k, a) in outs.iter().enumerate() {
        if outs[k + 1..]
            .iter()
            .chain(ins)
            .any(|b| overlaps(a.0, a.1, b.0, b.1))
        {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`dst` overlaps another output or an input"),
            ));
        }
    }
    Ok(())
}

/// Builds the G-buffer's back-face depth image from the host's back-face
/// pass `back` (the scene drawn again with front faces culled, same
/// camera, size and convention as `front`) over the rows `rows` of `dst`
/// (the whole image's descriptor; only those rows are written): per pixel
/// with a front surface, the back value if it lies at or behind the front
/// value (kept bit for bit, the cleared value included: a surface with
/// nothing behind it is solid to the far plane, as `refl_trace_thickness` reads
/// it), else (NaN or in front of the front) the front value; pixels
/// without a front surface get the back value as stored. Counts to
/// `*out_stats`. Bands are independent.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `front`, or an
/// image's `data` is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if an image's
/// `len` is too small; `REFL_STATUS_INVALID_ARGUMENT` for `dst` or `back`
/// not of the front's size, rows reversed or beyond the height, an
/// unknown convention, a misaligned pointer, or `dst` overlapping an
/// input or `out_stats`; the camera's status if it is invalid. Nothing is
/// written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `dst.data` writable for `dst.len` floats
/// (no other thread writes this call's rows); `front` NULL or readable,
/// its and `back`'s data readable for their `len` floats.
#[no_mangle]
pub unsafe extern "C" fn refl_trace_back_depth_rows(
    out_stats: *mut refl_trace_back_depth_stats,
    dst: refl_image_f32_mut,
    front: *const refl_depth_image,
    back: refl_image_f32,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_trace_back_depth_rows", || {
        let stats = Out::new(out_stats, "out_stats")?;
        // SAFETY: caller contract.
        let fc = unsafe { read(front, "front") }?;
        // SAFETY: caller contract.
        let f = unsafe { depth_image(&fc) }?;
        // SAFETY: caller contract.
        let b = unsafe { back.view() }?;
        if dst.data.is_null() {
            return Err(fail(Error::NullPointer, format_args!("`dst.data` is NULL")));
        }
        refuse_overlap(
            &[
                dst_range(&dst)?,
                (
                    out_stats as usize,
                    core::mem::size_of::<refl_trace_back_depth_stats>(),
                ),
            ],
            &[
                (fc.depth.data as usize, fc.depth.len.saturating_mul(4)),
                (back.data as usize, back.len.saturating_mul(4)),
            ],
        )?;
        if b.width() != f.width() || b.height() != f.height() {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`back` is not the front's size"),
            ));
        }
        if dst.width != f.width() || dst.height != f.height() {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`dst` is not the front's size"),
            ));
        }
        // SAFETY: caller contract.
        let mut d = unsafe { band(&dst, f.height(), rows) }?;
        let st = refl_core::try_back_depth(&mut d, &f, &b)?;
        // SAFETY: caller contract.
        unsafe { stats.write(st.into()) };
        Ok(())
    })
}

/// Writes into the rows `rows` of `dst` (which holds the result of
/// `refl_trace_back_depth_rows` or the cleared value), for every pixel
/// whose front surface lies on the object of the layered map `map` (the
/// primary ray enters it within `REFL_LAYERED_EXIT_ENTRY_TEXELS` map texels behind
/// the front point), the depth where the primary ray leaves that object
/// (`refl_core::LayeredMap::exit`), in the front's convention, where it is
/// nearer than the valid back depth already there (one that is not NaN
/// and not in front of the front); other pixels are left as they are.
/// Call it once per map: the image ends up with the nearest exit any map
/// (or the back-face pass) knows. Counts to `*out_stats`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `front`, `map`, a
/// map buffer or an image's `data` is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` for a short image or map buffer;
/// `REFL_STATUS_INVALID_ARGUMENT` for `dst` not of the front's size, rows
/// reversed or beyond the height, an invalid map grid or stamp, an
/// unknown convention, a misaligned pointer, or `dst` overlapping an
/// input or `out_stats`; `REFL_STATUS_DEGENERATE_GEOMETRY` for a
/// degenerate grid; the camera's status if it is invalid. Nothing is
/// written on error.
///
/// # Safety
/// As `refl_trace_back_depth_rows`, and `map` NULL or readable with
/// readable buffers.
#[cfg(feature = "layered")]
#[no_mangle]
pub unsafe extern "C" fn refl_trace_back_depth_layered_rows(
    out_stats: *mut refl_trace_back_depth_stats,
    dst: refl_image_f32_mut,
    front: *const refl_depth_image,
    map: *const refl_layered_map,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_trace_back_depth_layered_rows", || {
        let stats = Out::new(out_stats, "out_stats")?;
        // SAFETY: caller contract.
        let (fc, mc) = unsafe { (read(front, "front")?, read(map, "map")?) };
        // SAFETY: caller contract.
        let f = unsafe { depth_image(&fc) }?;
        // SAFETY: caller contract.
        let m = unsafe { mc.view() }?;
        if dst.data.is_null() {
            return Err(fail(Error::NullPointer, format_args!("`dst.data` is NULL")));
        }
        let mut ins = [(0usize, 0usize); 5];
        ins[0] = (fc.depth.data as usize, fc.depth.len.saturating_mul(4));
        ins[1..].copy_from_slice(&mc.ranges());
        refuse_overlap(
            &[
                dst_range(&dst)?,
                (
                    out_stats as usize,
                    core::mem::size_of::<refl_trace_back_depth_stats>(),
                ),
            ],
            &ins,
        )?;
        if dst.width != f.width() || dst.height != f.height() {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`dst` is not the front's size"),
            ));
        }
        // SAFETY: caller contract.
        let mut d = unsafe { band(&dst, f.height(), rows) }?;
        let st = refl_core::try_back_depth_layered(&mut d, &f, &m)?;
        // SAFETY: caller contract.
        unsafe { stats.write(st.into()) };
        Ok(())
    })
}

/// How many texels of a layered map (along the ray's dominant axis)
/// before the object's surface a G-buffer front point may lie and still
/// count as on the object (`refl_trace_back_depth_layered_rows`).
#[cfg(feature = "layered")]
pub const REFL_LAYERED_EXIT_ENTRY_TEXELS: f32 = 2.0;
// The header's constant is refl-core's.
#[cfg(feature = "layered")]
const _: () = assert!(REFL_LAYERED_EXIT_ENTRY_TEXELS == refl_core::EXIT_ENTRY_TEXELS);
