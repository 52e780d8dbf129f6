//! Image views over caller memory and whole-image passes.
//!
//! An image is `width x height` texels stored row by row, `stride` texels
//! from one row start to the next (`stride >= width`). The buffer must hold
//! at least `(height - 1) * stride + width` texels (`refl_image_required_len`);
//! the caller states how many it holds in `len`, so a short buffer is
//! reported as `REFL_STATUS_INSUFFICIENT_SIZE` instead of being overrun.
//! `data` must be aligned for its texel type.

use crate::ptr::{byte_len, overlaps, read, Out};
use crate::status::{guard, refl_status};
#[cfg(feature = "tcrr")]
use crate::tcrr::refl_tcrr_surfel;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
use crate::temporal::refl_temporal_texel;
use crate::types::{convention, refl_camera, refl_rgba8, refl_vec2, refl_vec3, refl_vec4};
use refl_core::image::try_required_len;
use refl_core::{Error, ImageView, ImageViewMut, RowRange};

/// A read-only image of `float` texels (e.g. a depth buffer).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_f32 {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *const f32,
    /// Number of texels readable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A writable image of `float` texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_f32_mut {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *mut f32,
    /// Number of texels writable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A read-only image of two-float texels (e.g. motion vectors).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_vec2 {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *const refl_vec2,
    /// Number of texels readable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A writable image of two-float texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_vec2_mut {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *mut refl_vec2,
    /// Number of texels writable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A read-only image of three-float texels (e.g. positions or normals).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_vec3 {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *const refl_vec3,
    /// Number of texels readable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A writable image of three-float texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_vec3_mut {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *mut refl_vec3,
    /// Number of texels writable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A read-only image of four-float texels (e.g. HDR color).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_vec4 {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *const refl_vec4,
    /// Number of texels readable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A writable image of four-float texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_vec4_mut {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *mut refl_vec4,
    /// Number of texels writable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A read-only image of 8-bit RGBA texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_rgba8 {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *const refl_rgba8,
    /// Number of texels readable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A writable image of 8-bit RGBA texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_rgba8_mut {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *mut refl_rgba8,
    /// Number of texels writable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A read-only image of `uint32_t` texels (e.g. ids, masks, counts).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_u32 {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *const u32,
    /// Number of texels readable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A writable image of `uint32_t` texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_u32_mut {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *mut u32,
    /// Number of texels writable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A read-only image of `uint8_t` texels (e.g. a coverage or re-trace
/// mask).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_u8 {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *const u8,
    /// Number of texels readable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A writable image of `uint8_t` texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_image_u8_mut {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *mut u8,
    /// Number of texels writable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A read-only image of `refl_tcrr_surfel` texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[cfg(feature = "tcrr")]
pub struct refl_image_tcrr_surfel {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *const refl_tcrr_surfel,
    /// Number of texels readable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A writable image of `refl_tcrr_surfel` texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[cfg(feature = "tcrr")]
pub struct refl_image_tcrr_surfel_mut {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *mut refl_tcrr_surfel,
    /// Number of texels writable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A read-only image of `refl_temporal_texel` texels (a temporal history
/// buffer).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub struct refl_image_temporal_texel {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *const refl_temporal_texel,
    /// Number of texels readable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A writable image of `refl_temporal_texel` texels.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub struct refl_image_temporal_texel_mut {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *mut refl_temporal_texel,
    /// Number of texels writable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

/// A pixel of an image: column `x`, row `y` (an entry of the lists of
/// pixels a pass leaves to the host, `refl_extrapolate_fill_rows`'s `host`
/// and `refl_upsample_resolve_rows`'s `retrace`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_image_pixel {
    /// Pixel column.
    pub x: u32,
    /// Pixel row.
    pub y: u32,
}

const _: () = {
    use core::mem::{align_of, size_of};
    assert!(size_of::<refl_image_pixel>() == size_of::<[u32; 2]>());
    assert!(align_of::<refl_image_pixel>() == align_of::<[u32; 2]>());
};

/// The `[x, y]` pairs of `len` pixels at `p` (NULL with `len` 0: none),
/// checked as `check_buffer` does; the last-error message names `name`.
///
/// # Safety
/// `p` NULL or writable for `len` entries, not accessed otherwise during
/// `'a`.
pub(crate) unsafe fn pixel_list<'a>(
    p: *mut refl_image_pixel,
    len: usize,
    name: &str,
) -> Result<&'a mut [[u32; 2]], Error> {
    if len == 0 {
        return Ok(&mut []);
    }
    crate::ptr::check_buffer(p.cast_const(), len, name)?;
    // SAFETY: non-null, aligned, `len` entries writable (caller contract),
    // size fits isize (check_buffer); refl_image_pixel is [u32; 2].
    Ok(unsafe { core::slice::from_raw_parts_mut(p.cast::<[u32; 2]>(), len) })
}

/// A read-only image of `refl_ssr_texel` texels (the mirror pass's output
/// read back by a later pass). Every texel of the view (`(height - 1) *
/// stride + width` texels from `data`, stride padding included) must hold
/// a `refl_ssr_status`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub struct refl_image_ssr_texel {
    /// Texel (0, 0); texel (x, y) is `data[y * stride + x]`.
    pub data: *const crate::ssr::refl_ssr_texel,
    /// Number of texels readable from `data` on (the buffer length).
    pub len: usize,
    /// Width in texels, > 0.
    pub width: u32,
    /// Height in texels, > 0.
    pub height: u32,
    /// Row stride in texels, >= `width`.
    pub stride: u32,
}

#[cfg(any(feature = "depth-image", feature = "hiz"))]
const _: () = {
    use crate::ssr::refl_ssr_texel;
    use core::mem::{align_of, offset_of, size_of};
    use refl_core::MirrorTexel;
    assert!(size_of::<refl_ssr_texel>() == size_of::<MirrorTexel>());
    assert!(align_of::<refl_ssr_texel>() == align_of::<MirrorTexel>());
    assert!(offset_of!(refl_ssr_texel, status) == offset_of!(MirrorTexel, status));
    assert!(offset_of!(refl_ssr_texel, pixel) == offset_of!(MirrorTexel, pixel));
    assert!(offset_of!(refl_ssr_texel, t) == offset_of!(MirrorTexel, t));
    assert!(offset_of!(refl_ssr_texel, confidence) == offset_of!(MirrorTexel, confidence));
    use crate::ssr::refl_ssr_status as C;
    use refl_core::MirrorStatus as R;
    assert!(C::Skipped as u32 == R::Skipped as u32);
    assert!(C::NoSurface as u32 == R::NoSurface as u32);
    assert!(C::Hit as u32 == R::Hit as u32);
    assert!(C::Sky as u32 == R::Sky as u32);
    assert!(C::LeftImage as u32 == R::LeftImage as u32);
    assert!(C::BehindGeometry as u32 == R::BehindGeometry as u32);
    assert!(C::OutOfSteps as u32 == R::OutOfSteps as u32);
    assert!(C::NoProjection as u32 == R::NoProjection as u32);
    assert!(C::BackFace as u32 == R::BackFace as u32);
    assert!(C::Hidden as u32 == R::Hidden as u32);
};

// The in-place read of `refl_image_ssr_texel::view` takes the status
// byte at offset 0: the low byte of the `uint32_t` only on little-endian
// targets.
#[cfg(all(any(feature = "depth-image", feature = "hiz"), target_endian = "big"))]
compile_error!("refl_image_ssr_texel is read in place: little-endian targets only");

#[cfg(any(feature = "depth-image", feature = "hiz"))]
impl refl_image_ssr_texel {
    /// A refl-core view of this image: validated as the other images, then
    /// every texel's status checked (`InvalidArgument` naming `name` and
    /// the first texel that is not a `refl_ssr_status`) before the memory
    /// is read as refl-core's texels.
    ///
    /// # Safety
    /// `data` must be valid for reads of `len` texels for `'a`, and not be
    /// written through another pointer meanwhile.
    pub(crate) unsafe fn view<'a>(
        &self,
        name: &str,
    ) -> Result<ImageView<'a, refl_core::MirrorTexel>, Error> {
        let need = checked_len(self.data, self.len, self.width, self.height, self.stride)?;
        // SAFETY: non-null, aligned, `need <= len` texels readable by the
        // caller's contract, size fits isize (checked_len).
        let c = unsafe { core::slice::from_raw_parts(self.data, need) };
        if let Some(i) = c.iter().position(|t| t.status > 9) {
            return Err(crate::status::fail(
                Error::InvalidArgument,
                format_args!(
                    "`{name}` texel {i} has status {}, not a refl_ssr_status",
                    c[i].status
                ),
            ));
        }
        // SAFETY: the same memory; the layouts are identical (asserted
        // above) and every status is a `refl_ssr_status` (0..=9), whose
        // low byte, at offset 0 on the little-endian targets this builds
        // for, is the `MirrorStatus` of the same number (ssr.rs maps them
        // one to one); the rest is floats.
        let s = unsafe {
            core::slice::from_raw_parts(self.data.cast::<refl_core::MirrorTexel>(), need)
        };
        ImageView::try_new(s, self.width, self.height, self.stride)
    }
}

/// Validates an image descriptor and returns the number of texels the view
/// covers (`try_required_len`), which is also its slice length.
///
/// Order: `NullPointer`, then `InvalidArgument` (misaligned pointer, zero
/// size, `stride < width`, overflow), then `InsufficientSize`.
fn checked_len<T>(data: *const T, len: usize, w: u32, h: u32, stride: u32) -> Result<usize, Error> {
    crate::ptr::no_nulls(&[(data.is_null(), "data")])?;
    if !data.is_aligned() {
        return Err(Error::InvalidArgument);
    }
    let need = try_required_len(w, h, stride)?;
    if len < need {
        return Err(Error::InsufficientSize);
    }
    byte_len::<T>(data as usize, need)?;
    Ok(need)
}

/// The byte range `(start, length)` an image view covers.
fn byte_range<T>(data: *const T, need: usize) -> (usize, usize) {
    (data as usize, need * core::mem::size_of::<T>())
}

macro_rules! image_views {
    ($(($c:ident, $m:ident, $texel:ty)),* $(,)?) => {$(
        impl $c {
            /// A refl-core view of this image (validated as in the module
            /// docs).
            ///
            /// # Safety
            /// `data` must be valid for reads of `len` texels (the view reads
            /// at most `refl_image_required_len` of them) for `'a`, and not be
            /// written through another pointer meanwhile.
            pub unsafe fn view<'a>(&self) -> Result<ImageView<'a, $texel>, Error> {
                let need = checked_len(self.data, self.len, self.width, self.height, self.stride)?;
                // SAFETY: non-null, aligned, `need <= len` texels readable by
                // the caller's contract, size fits isize (checked_len). The
                // texel types are layout-identical (types.rs asserts).
                let s = unsafe { core::slice::from_raw_parts(self.data.cast::<$texel>(), need) };
                ImageView::try_new(s, self.width, self.height, self.stride)
            }
        }

        impl $m {
            /// A refl-core mutable view of this image.
            ///
            /// # Safety
            /// `data` must be valid for reads and writes of `len` texels for
            /// `'a` and not be accessed through another pointer meanwhile.
            pub unsafe fn view_mut<'a>(&self) -> Result<ImageViewMut<'a, $texel>, Error> {
                let need = checked_len(self.data.cast_const(), self.len, self.width, self.height, self.stride)?;
                // SAFETY: as in `view`, plus exclusivity by contract.
                let s = unsafe { core::slice::from_raw_parts_mut(self.data.cast::<$texel>(), need) };
                ImageViewMut::try_new(s, self.width, self.height, self.stride)
            }

            /// A refl-core mutable view owning only the rows `rows`, over
            /// the memory of those rows alone (so host threads holding
            /// disjoint bands of one image never alias each other).
            ///
            /// # Safety
            /// The band's texels must be valid for reads and writes for
            /// `'a` and not be accessed through another pointer meanwhile.
            pub unsafe fn band_mut<'a>(&self, rows: RowRange) -> Result<ImageViewMut<'a, $texel>, Error> {
                let need = checked_len(self.data.cast_const(), self.len, self.width, self.height, self.stride)?;
                if rows.end() > self.height {
                    return Err(Error::InvalidArgument);
                }
                let start = (rows.start() as usize * self.stride as usize).min(need);
                let end = if rows.is_empty() {
                    start
                } else {
                    (rows.end() as usize - 1) * self.stride as usize + self.width as usize
                };
                // SAFETY: `start <= end <= need <= len` texels from a
                // non-null, aligned pointer (checked_len); exclusivity of
                // the band by contract.
                let s = unsafe {
                    core::slice::from_raw_parts_mut(self.data.cast::<$texel>().add(start), end - start)
                };
                ImageViewMut::try_band(s, self.width, self.height, self.stride, rows)
            }

            /// The read-only descriptor of the same memory.
            pub fn as_const(&self) -> $c {
                $c {
                    data: self.data.cast_const(),
                    len: self.len,
                    width: self.width,
                    height: self.height,
                    stride: self.stride,
                }
            }
        }
    )*};
}

image_views!(
    (refl_image_f32, refl_image_f32_mut, f32),
    (refl_image_vec2, refl_image_vec2_mut, [f32; 2]),
    (refl_image_vec3, refl_image_vec3_mut, [f32; 3]),
    (refl_image_vec4, refl_image_vec4_mut, [f32; 4]),
    (refl_image_rgba8, refl_image_rgba8_mut, [u8; 4]),
    (refl_image_u32, refl_image_u32_mut, u32),
    (refl_image_u8, refl_image_u8_mut, u8),
);
#[cfg(feature = "tcrr")]
image_views!((
    refl_image_tcrr_surfel,
    refl_image_tcrr_surfel_mut,
    refl_core::tcrr::Surfel
),);

#[cfg(any(feature = "depth-image", feature = "hiz"))]
image_views!((
    refl_image_temporal_texel,
    refl_image_temporal_texel_mut,
    refl_core::temporal::HistoryTexel
),);

/// A half-open range of image rows `[begin, end)`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_row_range {
    /// First row.
    pub begin: u32,
    /// One past the last row; equal to `begin` for an empty band.
    pub end: u32,
}

impl refl_row_range {
    /// The range as refl-core's, checked against an image of `height`
    /// rows (`InvalidArgument`, with a last-error message naming `rows`,
    /// for a reversed range or one ending past the height).
    pub(crate) fn within(&self, height: u32) -> Result<RowRange, Error> {
        RowRange::try_new(self.begin, self.end, height).map_err(|e| {
            crate::status::fail(
                e,
                format_args!(
                    "`rows` [{}, {}) is not within [0, {height})",
                    self.begin, self.end
                ),
            )
        })
    }
}

/// Writes to `*out` the `index`-th of `count` contiguous, near-equal bands
/// of the rows `[0, height)` (the first `height % count` bands get one row
/// more), for splitting a whole-image pass such as `refl_image_convert_depth`
/// across `count` threads. When there are more bands than rows, the bands
/// past the last row are empty (`begin == end`): skip them.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` if `height` or `count` is zero or
/// `index >= count`.
///
/// # Safety
/// `out` must be NULL or point to a writable `refl_row_range`.
#[no_mangle]
pub unsafe extern "C" fn refl_image_row_band(
    out: *mut refl_row_range,
    height: u32,
    index: u32,
    count: u32,
) -> refl_status {
    guard("refl_image_row_band", || {
        let out = Out::new(out, "out")?;
        let all = RowRange::try_all(height)?;
        if count == 0 || index >= count {
            return Err(Error::InvalidArgument);
        }
        let band = all.band(index, count).map_or(
            refl_row_range {
                begin: height,
                end: height,
            },
            |b| refl_row_range {
                begin: b.start(),
                end: b.end(),
            },
        );
        // SAFETY: caller contract.
        unsafe { out.write(band) };
        Ok(())
    })
}

/// Writes to `*out_len` the number of texels an image of `width x height`
/// texels with row stride `stride` needs: `(height - 1) * stride + width`
/// (the last row needs no padding). Multiply by the texel size for bytes.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_len` is NULL,
/// `REFL_STATUS_INVALID_ARGUMENT` if `width` or `height` is zero, if
/// `stride < width`, or if the count does not fit in `size_t`.
///
/// # Safety
/// `out_len` must be NULL or point to a writable `size_t`.
#[no_mangle]
pub unsafe extern "C" fn refl_image_required_len(
    out_len: *mut usize,
    width: u32,
    height: u32,
    stride: u32,
) -> refl_status {
    guard("refl_image_required_len", || {
        let out = Out::new(out_len, "out_len")?;
        let len = try_required_len(width, height, stride)?;
        // SAFETY: checked by Out::new; writability is the caller's contract.
        unsafe { out.write(len) };
        Ok(())
    })
}

/// Converts the rows `rows` of the depth image `src`, stored in
/// convention `from`, to convention `to`, writing them to the same rows of
/// `dst`: `dst = encode_to(decode_from(src))` texel by texel, with the near
/// and far planes of `camera` (its view and image size are not used; the
/// camera is still validated). Texels outside the row range and the padding
/// between rows are not touched. A NaN texel converts to NaN.
///
/// `from` and `to` are `refl_depth_convention` values. `dst` and `src` must
/// have the same width and height (strides may differ). They may be the
/// same image (same `data` and `stride`: in-place conversion) but must not
/// otherwise overlap. Hosts can split an image into row bands and convert
/// them on their own threads.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `dst.data`, `src.data` or `camera`
/// is NULL; `REFL_STATUS_INVALID_ARGUMENT` for an unknown convention, a
/// zero or overflowing image size, `stride < width`, a misaligned `data`,
/// different image sizes, a row range that is empty, reversed or beyond
/// the height, or partially overlapping images;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `dst.len` or `src.len` is below
/// `refl_image_required_len`; the camera's status if it is invalid. On any
/// of these `dst` is untouched. After `REFL_STATUS_PANIC` (a bug) the rows
/// of `dst` in the range may be partially written.
///
/// # Safety
/// `camera` must be NULL or point to a readable `refl_camera`; `src.data`
/// must be readable for `src.len` floats and `dst.data` writable for
/// `dst.len` floats, for the duration of the call, and no other thread
/// may write them meanwhile.
#[no_mangle]
pub unsafe extern "C" fn refl_image_convert_depth(
    dst: refl_image_f32_mut,
    src: refl_image_f32,
    camera: *const refl_camera,
    from: u32,
    to: u32,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_image_convert_depth", || {
        crate::ptr::no_nulls(&[
            (dst.data.is_null(), "dst.data"),
            (src.data.is_null(), "src.data"),
        ])?;
        // SAFETY: caller contract.
        let cam_c = unsafe { read(camera, "camera") }?;
        let (from, to) = (convention(from)?, convention(to)?);
        let cam = crate::types::camera_named(&cam_c, "camera")?;
        let dst_need = checked_len(
            dst.data.cast_const(),
            dst.len,
            dst.width,
            dst.height,
            dst.stride,
        )?;
        let src_need = checked_len(src.data, src.len, src.width, src.height, src.stride)?;
        if dst.width != src.width || dst.height != src.height {
            return Err(Error::InvalidArgument);
        }
        let rows = RowRange::try_new(rows.begin, rows.end, dst.height)?;
        let (d0, dl) = byte_range(dst.data.cast_const(), dst_need);
        let (s0, sl) = byte_range(src.data, src_need);
        if overlaps(d0, dl, s0, sl) {
            if d0 != s0 || dst.stride != src.stride {
                return Err(Error::InvalidArgument);
            }
            // In place: one mutable view of the band, no aliasing read view.
            // SAFETY: caller contract; validated by checked_len.
            let mut band = unsafe { dst.band_mut(rows) }?;
            refl_core::image::convert_depth_in_place(&mut band, &cam, from, to);
        } else {
            // SAFETY: caller contract; the two byte ranges are disjoint, and
            // only the band's rows of `dst` are borrowed.
            let mut band = unsafe { dst.band_mut(rows) }?;
            // SAFETY: caller contract.
            let inp = unsafe { src.view() }?;
            refl_core::image::try_convert_depth(&mut band, &inp, &cam, from, to)?;
        }
        Ok(())
    })
}
