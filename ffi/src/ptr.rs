//! Checked access to caller pointers.
//!
//! Small inputs (cameras, descriptors, options) are copied out by value at
//! the start of a call and single-value outputs are written once at the
//! end, so such an output may alias an input (e.g. a camera mirrored in
//! place). Arrays are borrowed in place as slices, never copied (refl-ffi
//! allocates nothing): an output array is borrowed mutably only after every
//! check of the call and only if it overlaps no input (`no_overlap`).

use crate::status::fail;
use core::mem::size_of;
use refl_core::Error;

/// `NullPointer` if `p` is null, `InvalidArgument` if it is misaligned;
/// the last-error detail names the argument `name`.
#[inline]
pub(crate) fn check_pointer<T>(p: *const T, name: &str) -> Result<(), Error> {
    if p.is_null() {
        return Err(fail(Error::NullPointer, format_args!("`{name}` is NULL")));
    }
    if !p.is_aligned() {
        return Err(fail(
            Error::InvalidArgument,
            format_args!(
                "`{name}` is misaligned (needs {}-byte alignment)",
                core::mem::align_of::<T>()
            ),
        ));
    }
    Ok(())
}

/// `NullPointer` naming the first argument whose flag is `true` (each
/// flag is `pointer.is_null()`), checked in the order given.
#[inline]
pub(crate) fn no_nulls(args: &[(bool, &str)]) -> Result<(), Error> {
    match args.iter().find(|(null, _)| *null) {
        Some((_, name)) => Err(fail(Error::NullPointer, format_args!("`{name}` is NULL"))),
        None => Ok(()),
    }
}

/// Reads `*p`: `NullPointer` if `p` is null, `InvalidArgument` if it is
/// misaligned (the last-error detail names `name`).
///
/// # Safety
/// A non-null, aligned `p` must point to a readable, initialized `T`.
/// Only used with plain-old-data `T` (floats and integers), for which every
/// bit pattern is a valid value.
#[inline]
pub(crate) unsafe fn read<T: Copy>(p: *const T, name: &str) -> Result<T, Error> {
    check_pointer(p, name)?;
    // SAFETY: non-null and aligned checked above; readability is the
    // caller's contract.
    Ok(unsafe { p.read() })
}

/// A checked output pointer: non-null and aligned. Writing through it is
/// the last thing a function does, so an output is written only on success.
pub(crate) struct Out<T>(*mut T);

impl<T> Out<T> {
    /// An optional output: `None` for NULL, else checked as [`Out::new`].
    /// Check it before the work it reports on, so that a misaligned one is
    /// refused before any other output is written.
    #[inline]
    pub(crate) fn optional(p: *mut T, name: &str) -> Result<Option<Self>, Error> {
        if p.is_null() {
            Ok(None)
        } else {
            Self::new(p, name).map(Some)
        }
    }

    /// Checks `p`: `NullPointer` if null, `InvalidArgument` if misaligned.
    #[inline]
    pub(crate) fn new(p: *mut T, name: &str) -> Result<Self, Error> {
        check_pointer(p.cast_const(), name)?;
        Ok(Self(p))
    }

    /// Writes `value` without reading or dropping the old contents.
    ///
    /// # Safety
    /// The pointer given to [`Out::new`] must be writable for one `T`.
    #[inline]
    pub(crate) unsafe fn write(self, value: T) {
        // SAFETY: non-null and aligned (checked in `new`); writability is
        // the caller's contract.
        unsafe { self.0.write(value) }
    }
}

/// The number of bytes of `count` elements of `T`, if a slice that long
/// may exist (`<= isize::MAX` bytes) and does not wrap the address space
/// from `addr`.
#[inline]
pub(crate) fn byte_len<T>(addr: usize, count: usize) -> Result<usize, Error> {
    let bytes = count
        .checked_mul(size_of::<T>())
        .filter(|b| *b <= isize::MAX as usize)
        .ok_or(Error::InvalidArgument)?;
    addr.checked_add(bytes).ok_or(Error::InvalidArgument)?;
    Ok(bytes)
}

/// Checks that no output range overlaps another output or an input
/// (`(address, bytes)` pairs): `InvalidArgument` naming the clash.
pub(crate) fn disjoint(outs: &[(usize, usize)], ins: &[(usize, usize)]) -> Result<(), Error> {
    for (k, a) in outs.iter().enumerate() {
        let clash = outs[k + 1..]
            .iter()
            .chain(ins.iter())
            .any(|b| overlaps(a.0, a.1, b.0, b.1));
        if clash {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("the outputs overlap each other or an input"),
            ));
        }
    }
    Ok(())
}

/// `true` if the byte ranges `[a, a + a_len)` and `[b, b + b_len)` overlap.
#[inline]
pub(crate) fn overlaps(a: usize, a_len: usize, b: usize, b_len: usize) -> bool {
    a_len > 0 && b_len > 0 && a < b + b_len && b < a + a_len
}

/// Checks a caller buffer pointer for `count` values of `T`: `NullPointer`
/// if NULL, `InvalidArgument` if misaligned or impossibly long; returns its
/// byte length.
pub(crate) fn check_buffer<T>(p: *const T, count: usize, name: &str) -> Result<usize, Error> {
    check_pointer(p, name)?;
    byte_len::<T>(p as usize, count).map_err(|e| {
        fail(
            e,
            format_args!("`{name}`: {count} elements do not fit in memory"),
        )
    })
}

/// Borrows `count` caller values as a slice: `NullPointer` if `p` is NULL,
/// `InvalidArgument` if misaligned or impossibly long ([`check_buffer`]).
///
/// # Safety
/// A non-null, aligned `p` must be readable for `count` values of `T` for
/// `'a`, and not be written meanwhile.
pub(crate) unsafe fn slice<'a, T>(p: *const T, count: usize, name: &str) -> Result<&'a [T], Error> {
    check_buffer(p, count, name)?;
    // SAFETY: non-null, aligned, length fits isize (checked above);
    // readability and no writer for 'a are the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts(p, count) })
}

/// [`slice`] for an optional array: an empty one (`count == 0`) may be
/// NULL.
///
/// # Safety
/// As [`slice`].
pub(crate) unsafe fn slice_or_empty<'a, T>(
    p: *const T,
    count: usize,
    name: &str,
) -> Result<&'a [T], Error> {
    if count == 0 {
        return Ok(&[]);
    }
    // SAFETY: forwarded contract.
    unsafe { slice(p, count, name) }
}

/// Borrows `count` caller values as a mutable slice (checked as
/// [`slice`]). Create it after every check of the call, just before the
/// kernel that writes it, and only for memory that overlaps no other
/// argument of the call (`overlaps`).
///
/// # Safety
/// A non-null, aligned `p` must be readable and writable for `count` values
/// of `T` for `'a`, and not be accessed through another pointer meanwhile.
pub(crate) unsafe fn slice_mut<'a, T>(
    p: *mut T,
    count: usize,
    name: &str,
) -> Result<&'a mut [T], Error> {
    check_buffer(p.cast_const(), count, name)?;
    // SAFETY: as in `slice`, plus exclusivity by contract.
    Ok(unsafe { core::slice::from_raw_parts_mut(p, count) })
}

/// [`slice_mut`] for an optional array: an empty one (`count == 0`) may be
/// NULL.
///
/// # Safety
/// As [`slice_mut`].
pub(crate) unsafe fn slice_mut_or_empty<'a, T>(
    p: *mut T,
    count: usize,
    name: &str,
) -> Result<&'a mut [T], Error> {
    if count == 0 {
        return Ok(&mut []);
    }
    // SAFETY: forwarded contract.
    unsafe { slice_mut(p, count, name) }
}

/// The byte range `(address, bytes)` of `count` values of `T` at `p`,
/// saturating (for overlap tests of pointers already checked or about to
/// be refused).
#[inline]
pub(crate) fn range<T>(p: *const T, count: usize) -> (usize, usize) {
    (p as usize, count.saturating_mul(size_of::<T>()))
}

/// `InvalidArgument` naming `name` if the output bytes `out` overlap one of
/// the input ranges `inputs` (an output array is written in place, so it
/// must not share memory with what the call reads).
pub(crate) fn no_overlap(
    out: (usize, usize),
    inputs: &[(usize, usize)],
    name: &str,
) -> Result<(), Error> {
    if inputs.iter().any(|&(a, l)| overlaps(out.0, out.1, a, l)) {
        return Err(fail(
            Error::InvalidArgument,
            format_args!("`{name}` overlaps an input of the call"),
        ));
    }
    Ok(())
}

/// A band of pyramid rows to write, the finer level to read (none for level
/// 0) and the band's rows: what [`pyramid_band`] returns.
#[cfg(feature = "hiz")]
pub(crate) type PyramidBand<'a, T> = (&'a mut [T], Option<&'a [T]>, refl_core::RowRange);

/// The rows `rows` of level `level` of a pyramid laid out as
/// `layout` in the caller buffer `dst` of `dst_len` texels (checked with
/// [`check_buffer`]), and for `level > 0` the whole finer level they are
/// built from ([`refl_core::HiZLayout::try_band`]): the slices of every
/// `*_build_*_rows` export (Hi-Z, color, visibility). Only those texels
/// are borrowed, so threads building disjoint bands never alias.
///
/// # Errors
/// `InvalidArgument` for a level past the last or empty, reversed or
/// out-of-level rows; `InsufficientSize` if `dst_len` is below
/// `layout.len()`.
///
/// # Safety
/// `dst` writable for `dst_len` texels; during `'a` no other thread
/// touches the returned rows and none writes the finer level.
#[cfg(feature = "hiz")]
pub(crate) unsafe fn pyramid_band<'a, T>(
    dst: *mut T,
    dst_len: usize,
    layout: &refl_core::hiz::HiZLayout,
    level: u32,
    rows: crate::image::refl_row_range,
) -> Result<PyramidBand<'a, T>, Error> {
    let lv = layout.level(level).ok_or(Error::InvalidArgument)?;
    let rows = refl_core::RowRange::try_new(rows.begin, rows.end, lv.height)?;
    let b = layout.try_band(level, rows, dst_len)?;
    // SAFETY: `b.band` lies within the first layout.len() <= dst_len
    // texels, writable by contract and not touched by other threads.
    let out = unsafe { core::slice::from_raw_parts_mut(dst.add(b.band.start), b.band.len()) };
    let finer = b.finer.map(|f| {
        // SAFETY: the finer level lies before the band in the buffer
        // (disjoint from `out`), within dst_len, and is only read meanwhile
        // (contract).
        unsafe { core::slice::from_raw_parts(dst.add(f.start).cast_const(), f.len()) }
    });
    Ok((out, finer, rows))
}
