//! Status codes, their strings, the library version and the panic boundary.

use core::ffi::c_char;
use core::ffi::CStr;
use refl_core::Error;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The result of every fallible refl function. `REFL_STATUS_OK` is zero;
/// every other value names why the call refused its input. A function that
/// returns anything but `REFL_STATUS_OK` has left all of its outputs
/// untouched (except after `REFL_STATUS_PANIC` from a whole-image pass, see
/// there).
///
/// The values other than `REFL_STATUS_OK` and `REFL_STATUS_PANIC` map 1:1
/// onto `refl_core::Error`.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum refl_status {
    /// Success.
    Ok = 0,
    /// A required pointer was null.
    NullPointer = 1,
    /// A caller buffer is shorter than the function needs.
    InsufficientSize = 2,
    /// A parameter is out of range: NaN or infinite where a finite value is
    /// needed, a zero size, a size whose element count overflows, a stride
    /// smaller than the width, an empty or reversed row range, an unknown
    /// enum value, a misaligned pointer, overlapping input and output images.
    InvalidArgument = 3,
    /// Geometry without a defined answer: a zero-area triangle, a zero
    /// normal, coincident camera positions, a view matrix that is not a
    /// rigid transform, a ray parallel to a plane.
    DegenerateGeometry = 4,
    /// A Rust panic was caught at the C boundary. This is a bug in refl;
    /// please report it. The library stays usable.
    Panic = 5,
}

impl From<Error> for refl_status {
    fn from(e: Error) -> Self {
        match e {
            Error::NullPointer => Self::NullPointer,
            Error::InsufficientSize => Self::InsufficientSize,
            Error::InvalidArgument => Self::InvalidArgument,
            Error::DegenerateGeometry => Self::DegenerateGeometry,
        }
    }
}

impl refl_status {
    /// The status as a `Result`: `Ok(())` for [`refl_status::Ok`], the core
    /// error for the four error statuses, and `Err(None)` for
    /// [`refl_status::Panic`].
    pub fn to_result(self) -> Result<(), Option<Error>> {
        match self {
            Self::Ok => Ok(()),
            Self::NullPointer => Err(Some(Error::NullPointer)),
            Self::InsufficientSize => Err(Some(Error::InsufficientSize)),
            Self::InvalidArgument => Err(Some(Error::InvalidArgument)),
            Self::DegenerateGeometry => Err(Some(Error::DegenerateGeometry)),
            Self::Panic => Err(None),
        }
    }

    /// The static description returned by [`refl_status_string`].
    pub const fn as_cstr(self) -> &'static CStr {
        match self {
            Self::Ok => c"ok",
            // The four error strings equal refl_core::Error::as_str (tested).
            Self::NullPointer => c"a required pointer was null",
            Self::InsufficientSize => c"a buffer is too small",
            Self::InvalidArgument => {
                c"invalid argument (NaN/Inf, zero or overflowing size, bad range)"
            }
            Self::DegenerateGeometry => c"degenerate geometry",
            Self::Panic => c"a panic was caught at the C boundary (a bug in refl)",
        }
    }

    /// The status with numeric value `v`, if there is one.
    pub const fn from_u32(v: u32) -> Option<Self> {
        Some(match v {
            0 => Self::Ok,
            1 => Self::NullPointer,
            2 => Self::InsufficientSize,
            3 => Self::InvalidArgument,
            4 => Self::DegenerateGeometry,
            5 => Self::Panic,
            _ => return None,
        })
    }
}

/// The string [`refl_status_string`] returns for values that are not a
/// `refl_status`.
pub const UNKNOWN_STATUS: &CStr = c"unknown refl_status value";

/// Major version of the header this library was built with; compare with
/// `refl_version_number()` at run time to detect a header/library mismatch.
pub const REFL_VERSION_MAJOR: u32 = 0;
/// Minor version of the header.
pub const REFL_VERSION_MINOR: u32 = 1;
/// Patch version of the header.
pub const REFL_VERSION_PATCH: u32 = 0;

/// A static, NUL-terminated English description of `status`.
///
/// Never returns NULL: values that are not a `refl_status` get the string
/// "unknown refl_status value". The string must not be freed.
#[no_mangle]
pub extern "C" fn refl_status_string(status: u32) -> *const c_char {
    match refl_status::from_u32(status) {
        Some(s) => s.as_cstr().as_ptr(),
        None => UNKNOWN_STATUS.as_ptr(),
    }
}

/// The library version as a static, NUL-terminated string such as
/// "0.1.0". Never NULL; must not be freed.
#[no_mangle]
pub extern "C" fn refl_version() -> *const c_char {
    const V: &CStr =
        match CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
            Ok(s) => s,
            Err(_) => panic!("package version contains a NUL byte"),
        };
    V.as_ptr()
}

/// The library version as `(major << 16) | (minor << 8) | patch`, to be
/// compared with the header's `REFL_VERSION_MAJOR`, `REFL_VERSION_MINOR`
/// and `REFL_VERSION_PATCH`.
#[no_mangle]
pub extern "C" fn refl_version_number() -> u32 {
    (REFL_VERSION_MAJOR << 16) | (REFL_VERSION_MINOR << 8) | REFL_VERSION_PATCH
}

/// Runs `f` behind the panic boundary: its `Result` becomes a status, and a
/// panic becomes [`refl_status::Panic`] instead of unwinding into C.
///
/// The panic payload is leaked rather than dropped: a payload whose `Drop`
/// panics again would otherwise unwind across the boundary.
pub(crate) fn guard<F: FnOnce() -> Result<(), Error>>(f: F) -> refl_status {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => refl_status::Ok,
        Ok(Err(e)) => e.into(),
        Err(payload) => {
            core::mem::forget(payload);
            refl_status::Panic
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_strings_match_core() {
        for e in [
            Error::NullPointer,
            Error::InsufficientSize,
            Error::InvalidArgument,
            Error::DegenerateGeometry,
        ] {
            let s = refl_status::from(e);
            assert_eq!(s.as_cstr().to_str().unwrap(), e.as_str());
            assert_eq!(s.to_result(), Err(Some(e)));
        }
    }

    #[test]
    fn guard_catches_panics() {
        let s = guard(|| panic!("boom"));
        assert_eq!(s, refl_status::Panic);
        assert_eq!(guard(|| Ok(())), refl_status::Ok);
        assert_eq!(
            guard(|| Err(Error::DegenerateGeometry)),
            refl_status::DegenerateGeometry
        );
    }

    #[test]
    fn version_constants_match_the_package() {
        assert_eq!(
            REFL_VERSION_MAJOR.to_string(),
            env!("CARGO_PKG_VERSION_MAJOR")
        );
        assert_eq!(
            REFL_VERSION_MINOR.to_string(),
            env!("CARGO_PKG_VERSION_MINOR")
        );
        assert_eq!(
            REFL_VERSION_PATCH.to_string(),
            env!("CARGO_PKG_VERSION_PATCH")
        );
    }
}
