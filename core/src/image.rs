//! Image views over caller memory.
//!
//! An image is `width x height` texels stored row by row with a row stride
//! (in texels, `stride >= width`). The last row needs only `width` texels, so
//! the smallest valid buffer holds [`try_required_len`] texels. Construction
//! validates sizes in 64-bit arithmetic (no `u32 * u32` overflow) and every
//! accessor is bounds-checked, so a kernel can never read or write outside the
//! caller's slice.
//!
//! The texel type is generic; the C ABI instantiates it for `f32`,
//! `[f32; 2]`, `[f32; 3]`, `[f32; 4]`, `[u8; 4]` and `u32`.
//!
//! Whole-image passes take a [`RowRange`] so that a host can split an image
//! across its own threads; [`ImageViewMut::try_split_at_row`] hands out disjoint
//! mutable row bands that keep global row coordinates.
//!
//! # Example
//! ```rust
//! use refl_core::image::{try_convert_depth, try_required_len};
//! use refl_core::{glam::Vec3, Camera, DepthConvention, ImageView, ImageViewMut};
//!
//! // 3 x 2 texels, rows 4 texels apart: the last row needs only 3.
//! assert_eq!(try_required_len(3, 2, 4)?, 7);
//! let mut linear = vec![f32::NAN; 7];
//! let img = ImageViewMut::try_new(&mut linear, 3, 2, 4)?;
//! // Disjoint row bands for two threads, in global row coordinates.
//! let (mut top, mut bottom) = img.try_split_at_row(1).map_err(|(e, _)| e)?;
//! assert_eq!(bottom.owned_rows().map(|r| r.start()), Some(1));
//! assert!(top.get_mut(0, 1).is_none()); // row 1 belongs to `bottom`
//! std::thread::scope(|s| {
//!     s.spawn(move || top.fill(5.0));
//!     s.spawn(move || bottom.fill(20.0));
//! });
//! assert!(linear[3].is_nan()); // the padding is not touched
//!
//! // Linear depth to [0, 1] depth: d(z) = f (z - n) / (z (f - n)).
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 1.0, 101.0, 3, 2)?;
//! let src = ImageView::try_new(&linear, 3, 2, 4)?;
//! let mut stored = [0.0f32; 6];
//! let mut dst = ImageViewMut::try_new(&mut stored, 3, 2, 3)?;
//! try_convert_depth(&mut dst, &src, &cam, DepthConvention::Linear, DepthConvention::ZeroToOne)?;
//! assert!((stored[0] - 101.0 * 4.0 / (5.0 * 100.0)).abs() < 1e-6);
//! assert!((stored[5] - 101.0 * 19.0 / (20.0 * 100.0)).abs() < 1e-6);
//! # Ok::<(), refl_core::Error>(())
//! ```

use crate::{Camera, DepthConvention, Error};
use core::ops::Range;

/// Number of texels a buffer must hold for an image of `width x height` with
/// row stride `stride`: `(height - 1) * stride + width`.
///
/// # Errors
/// [`Error::InvalidArgument`] if `width` or `height` is zero, if
/// `stride < width`, or if the count does not fit in `usize`.
pub fn try_required_len(width: u32, height: u32, stride: u32) -> Result<usize, Error> {
    if width == 0 || height == 0 || stride < width {
        return Err(Error::InvalidArgument);
    }
    // (2^32-1)^2 + 2^32 < 2^64: cannot overflow u64.
    let len = (u64::from(height) - 1) * u64::from(stride) + u64::from(width);
    usize::try_from(len).map_err(|_| Error::InvalidArgument)
}

/// A half-open range of image rows `[start, end)`, validated against an image
/// height: `start < end <= height`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RowRange {
    start: u32,
    end: u32,
}

impl RowRange {
    /// The range `[start, end)` of an image `height` rows tall.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] unless `start < end <= height`.
    pub fn try_new(start: u32, end: u32, height: u32) -> Result<Self, Error> {
        if start < end && end <= height {
            Ok(Self { start, end })
        } else {
            Err(Error::InvalidArgument)
        }
    }

    /// All rows of an image `height` rows tall.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `height` is zero.
    pub fn try_all(height: u32) -> Result<Self, Error> {
        Self::try_new(0, height, height)
    }

    /// The `index`-th of `count` contiguous, near-equal bands of `self`
    /// (the first `len % count` bands get one extra row). Bands of an empty
    /// share (more bands than rows) are `None`.
    pub fn band(self, index: u32, count: u32) -> Option<Self> {
        if count == 0 || index >= count {
            return None;
        }
        let len = self.end - self.start;
        let (q, r) = (len / count, len % count);
        let start = self.start + index * q + index.min(r);
        let end = start + q + u32::from(index < r);
        (start < end).then_some(Self { start, end })
    }

    /// First row.
    pub const fn start(self) -> u32 {
        self.start
    }

    /// One past the last row.
    pub const fn end(self) -> u32 {
        self.end
    }

    /// Number of rows (at least one).
    pub const fn len(self) -> u32 {
        self.end - self.start
    }

    /// Always `false`: a validated range holds at least one row.
    pub const fn is_empty(self) -> bool {
        false
    }

    /// The rows as a `Range<u32>` for iteration.
    pub const fn rows(self) -> Range<u32> {
        self.start..self.end
    }
}

/// A read-only image over caller memory.
#[derive(Debug)]
pub struct ImageView<'a, T> {
    data: &'a [T],
    width: u32,
    height: u32,
    stride: u32,
}

impl<T> Clone for ImageView<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for ImageView<'_, T> {}

impl<'a, T: Copy> ImageView<'a, T> {
    /// A view of `width x height` texels with row stride `stride` (texels).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a zero size, `stride < width` or an
    /// overflowing texel count; [`Error::InsufficientSize`] if `data` holds
    /// fewer than [`try_required_len`] texels.
    pub fn try_new(data: &'a [T], width: u32, height: u32, stride: u32) -> Result<Self, Error> {
        let len = try_required_len(width, height, stride)?;
        if data.len() < len {
            return Err(Error::InsufficientSize);
        }
        Ok(Self {
            data,
            width,
            height,
            stride,
        })
    }

    /// Width in texels.
    pub const fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    pub const fn height(&self) -> u32 {
        self.height
    }

    /// Row stride in texels.
    pub const fn stride(&self) -> u32 {
        self.stride
    }

    /// The texels (at least [`try_required_len`] of them): texel `(x, y)` is
    /// `data()[y * stride + x]`.
    #[cfg(feature = "depth-image")]
    pub(crate) const fn data(&self) -> &'a [T] {
        self.data
    }

    /// All rows of the image.
    pub fn all_rows(&self) -> RowRange {
        RowRange {
            start: 0,
            end: self.height,
        }
    }

    /// The texel at `(x, y)`, or `None` outside the image.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Option<T> {
        if x < self.width && y < self.height {
            self.data
                .get(y as usize * self.stride as usize + x as usize)
                .copied()
        } else {
            None
        }
    }

    /// The texel at `(x, y)` with coordinates clamped to the image (edge
    /// extension), for filters and neighborhood searches.
    #[inline]
    pub fn get_clamped(&self, x: i64, y: i64) -> T {
        let x = x.clamp(0, i64::from(self.width) - 1) as usize;
        let y = y.clamp(0, i64::from(self.height) - 1) as usize;
        self.data[y * self.stride as usize + x]
    }

    /// Row `y` (exactly `width` texels), or `None` outside the image.
    #[inline]
    pub fn row(&self, y: u32) -> Option<&'a [T]> {
        if y < self.height {
            let start = y as usize * self.stride as usize;
            self.data.get(start..start + self.width as usize)
        } else {
            None
        }
    }
}

/// A mutable image over caller memory that owns a band of rows.
///
/// A view made by [`ImageViewMut::try_new`] owns every row; after
/// [`try_split_at_row`](ImageViewMut::try_split_at_row) each part owns a disjoint
/// band but keeps the image's global coordinates, so a kernel writes pixel
/// `(x, y)` the same way whichever band it was handed. Accessors return `None`
/// for rows the view does not own.
#[derive(Debug)]
pub struct ImageViewMut<'a, T> {
    /// Texels from the first owned row on.
    data: &'a mut [T],
    width: u32,
    height: u32,
    stride: u32,
    rows: Range<u32>,
}

/// The rows a pass's `try_run` writes: those `out` owns, after checking
/// that `out` and the optional per-pixel `status` image are `width` x
/// `height` and own the same band (`None` for an empty band).
///
/// # Errors
/// [`Error::InvalidArgument`] otherwise.
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub(crate) fn try_output_rows<T: Copy>(
    out: &ImageViewMut<'_, T>,
    status: Option<&ImageViewMut<'_, u8>>,
    width: u32,
    height: u32,
) -> Result<Option<RowRange>, Error> {
    let rows = out.owned_rows();
    let bad = out.width() != width
        || out.height() != height
        || status
            .is_some_and(|s| s.width() != width || s.height() != height || s.owned_rows() != rows);
    if bad {
        Err(Error::InvalidArgument)
    } else {
        Ok(rows)
    }
}

/// Writes pixel `(x, y)`'s `value` into `out` and its status byte into
/// `status` when given (outside their rows: nothing).
#[cfg(any(feature = "depth-image", feature = "hiz"))]
#[inline]
pub(crate) fn put_pixel<T: Copy>(
    out: &mut ImageViewMut<'_, T>,
    status: Option<&mut ImageViewMut<'_, u8>>,
    x: u32,
    y: u32,
    value: T,
    code: u8,
) {
    if let Some(p) = out.get_mut(x, y) {
        *p = value;
    }
    if let Some(p) = status.and_then(|s| s.get_mut(x, y)) {
        *p = code;
    }
}

impl<'a, T: Copy> ImageViewMut<'a, T> {
    /// A mutable view of `width x height` texels with row stride `stride`.
    ///
    /// # Errors
    /// As [`ImageView::try_new`].
    pub fn try_new(data: &'a mut [T], width: u32, height: u32, stride: u32) -> Result<Self, Error> {
        let len = try_required_len(width, height, stride)?;
        if data.len() < len {
            return Err(Error::InsufficientSize);
        }
        Ok(Self {
            data,
            width,
            height,
            stride,
            rows: 0..height,
        })
    }

    /// A mutable view owning only the rows `rows` of a `width x height`
    /// image with row stride `stride`, over memory that starts at the
    /// band's first row (`data[0]` is texel `(0, rows.start())`): what a
    /// host thread holds when it owns one band of a shared image (the FFI
    /// builds one per call, so threads never alias each other's rows).
    ///
    /// # Errors
    /// As [`ImageView::try_new`] for the whole image's size;
    /// [`Error::InvalidArgument`] if `rows` ends beyond `height`;
    /// [`Error::InsufficientSize`] if `data` is shorter than the band
    /// (`(rows.len() - 1) * stride + width` texels).
    pub fn try_band(
        data: &'a mut [T],
        width: u32,
        height: u32,
        stride: u32,
        rows: RowRange,
    ) -> Result<Self, Error> {
        try_required_len(width, height, stride)?;
        if rows.end() > height {
            return Err(Error::InvalidArgument);
        }
        if !rows.is_empty() {
            let need = try_required_len(width, rows.len(), stride)?;
            if data.len() < need {
                return Err(Error::InsufficientSize);
            }
        }
        Ok(Self {
            data,
            width,
            height,
            stride,
            rows: rows.start()..rows.end(),
        })
    }

    /// Width in texels.
    pub const fn width(&self) -> u32 {
        self.width
    }

    /// Height of the whole image in texels (not only the owned band).
    pub const fn height(&self) -> u32 {
        self.height
    }

    /// Row stride in texels.
    pub const fn stride(&self) -> u32 {
        self.stride
    }

    /// The band of rows this view may read and write, or `None` for an
    /// empty band (a split at the band's edge).
    pub fn owned_rows(&self) -> Option<RowRange> {
        (self.rows.start < self.rows.end).then_some(RowRange {
            start: self.rows.start,
            end: self.rows.end,
        })
    }

    #[inline]
    fn index(&self, x: u32, y: u32) -> Option<usize> {
        (x < self.width && self.rows.contains(&y))
            .then(|| (y - self.rows.start) as usize * self.stride as usize + x as usize)
    }

    /// The texel at `(x, y)`, or `None` outside the owned rows.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Option<T> {
        self.index(x, y).and_then(|i| self.data.get(i).copied())
    }

    /// A mutable reference to the texel at `(x, y)`, or `None` outside the
    /// owned rows.
    #[inline]
    pub fn get_mut(&mut self, x: u32, y: u32) -> Option<&mut T> {
        self.index(x, y).and_then(move |i| self.data.get_mut(i))
    }

    /// Row `y` (exactly `width` texels), or `None` outside the owned rows.
    pub fn row_mut(&mut self, y: u32) -> Option<&mut [T]> {
        let start = self.index(0, y)?;
        let end = start + self.width as usize;
        self.data.get_mut(start..end)
    }

    /// Writes `value` into every texel of the owned rows (padding between
    /// rows is left alone).
    pub fn fill(&mut self, value: T) {
        for y in self.rows.clone() {
            if let Some(row) = self.row_mut(y) {
                row.fill(value);
            }
        }
    }

    /// Splits the owned band at global row `y` into `[start, y)` and
    /// `[y, end)`, for handing disjoint bands to threads.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] unless `y` lies within the owned band
    /// (its ends included); `self` is returned unchanged in that case.
    pub fn try_split_at_row(self, y: u32) -> Result<(Self, Self), (Error, Self)> {
        if y < self.rows.start || y > self.rows.end {
            return Err((Error::InvalidArgument, self));
        }
        let Self {
            data,
            width,
            height,
            stride,
            rows,
        } = self;
        let at = ((y - rows.start) as usize * stride as usize).min(data.len());
        let (a, b) = data.split_at_mut(at);
        Ok((
            Self {
                data: a,
                width,
                height,
                stride,
                rows: rows.start..y,
            },
            Self {
                data: b,
                width,
                height,
                stride,
                rows: y..rows.end,
            },
        ))
    }

    /// A read-only view of the whole image, if this view owns every row.
    pub fn as_view(&self) -> Option<ImageView<'_, T>> {
        (self.rows.start == 0 && self.rows.end == self.height).then_some(ImageView {
            data: &*self.data,
            width: self.width,
            height: self.height,
            stride: self.stride,
        })
    }
}

/// Converts the depth texels of the rows `dst` owns from convention `from`
/// in `src` to convention `to` in `dst`: `dst = encode_to(decode_from(src))`
/// texel by texel ([`Camera::decode_depth`], [`Camera::encode_depth`]: only
/// the camera's near and far planes are used). A NaN texel converts to NaN;
/// rows `dst` does not own and the padding between rows are not touched.
/// Threads convert disjoint bands ([`ImageViewMut::try_split_at_row`]) of one
/// image at once. [`convert_depth_in_place`] converts an image in place.
///
/// # Errors
/// [`Error::InvalidArgument`] if `dst` and `src` differ in width or height
/// (strides may differ); `dst` is then untouched.
pub fn try_convert_depth(
    dst: &mut ImageViewMut<'_, f32>,
    src: &ImageView<'_, f32>,
    camera: &Camera,
    from: DepthConvention,
    to: DepthConvention,
) -> Result<(), Error> {
    if dst.width() != src.width() || dst.height() != src.height() {
        return Err(Error::InvalidArgument);
    }
    let Some(rows) = dst.owned_rows() else {
        return Ok(());
    };
    for y in rows.rows() {
        if let (Some(o), Some(i)) = (dst.row_mut(y), src.row(y)) {
            for (o, &i) in o.iter_mut().zip(i) {
                *o = camera.encode_depth(camera.decode_depth(i, from), to);
            }
        }
    }
    Ok(())
}

/// [`try_convert_depth`] in place: converts the texels of the rows `img`
/// owns from convention `from` to `to`.
pub fn convert_depth_in_place(
    img: &mut ImageViewMut<'_, f32>,
    camera: &Camera,
    from: DepthConvention,
    to: DepthConvention,
) {
    let Some(rows) = img.owned_rows() else {
        return;
    };
    for y in rows.rows() {
        if let Some(row) = img.row_mut(y) {
            for v in row {
                *v = camera.encode_depth(camera.decode_depth(*v, from), to);
            }
        }
    }
}
