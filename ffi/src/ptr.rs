//! Checked access to caller pointers.
//!
//! Inputs are copied out by value at the start of a call and outputs are
//! written once at the end, so no Rust reference into caller memory outlives
//! a single read or write: an output may alias an input (e.g. a camera
//! mirrored in place) without undefined behavior.

use core::mem::size_of;
use refl_core::Error;

/// Reads `*p`: `NullPointer` if `p` is null, `InvalidArgument` if it is
/// misaligned.
///
/// # Safety
/// A non-null, aligned `p` must point to a readable, initialized `T`.
/// Only used with plain-old-data `T` (floats and integers), for which every
/// bit pattern is a valid value.
#[inline]
pub(crate) unsafe fn read<T: Copy>(p: *const T) -> Result<T, Error> {
    if p.is_null() {
        return Err(Error::NullPointer);
    }
    if !p.is_aligned() {
        return Err(Error::InvalidArgument);
    }
    // SAFETY: non-null and aligned checked above; readability is the
    // caller's contract.
    Ok(unsafe { p.read() })
}

/// A checked output pointer: non-null and aligned. Writing through it is
/// the last thing a function does, so an output is written only on success.
pub(crate) struct Out<T>(*mut T);

impl<T> Out<T> {
    /// Checks `p`: `NullPointer` if null, `InvalidArgument` if misaligned.
    #[inline]
    pub(crate) fn new(p: *mut T) -> Result<Self, Error> {
        if p.is_null() {
            return Err(Error::NullPointer);
        }
        if !p.is_aligned() {
            return Err(Error::InvalidArgument);
        }
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

/// `true` if the byte ranges `[a, a + a_len)` and `[b, b + b_len)` overlap.
#[inline]
pub(crate) fn overlaps(a: usize, a_len: usize, b: usize, b_len: usize) -> bool {
    a_len > 0 && b_len > 0 && a < b + b_len && b < a + a_len
}
