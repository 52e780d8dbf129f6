//! The one error type of refl-core.
//!
//! Each variant maps 1:1 onto a `refl_status` value of the C ABI (see
//! `refl-ffi`); `0` is reserved there for success.

use core::fmt;

/// Why a refl-core function refused its input.
///
/// Functions that return `Result<_, Error>` leave every output untouched when
/// they return `Err`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Error {
    /// A required pointer was null (only produced at the C ABI boundary).
    NullPointer,
    /// A caller buffer is shorter than the function needs.
    InsufficientSize,
    /// A parameter is out of range: NaN or infinite where a finite value is
    /// needed, a zero size, a size whose element count overflows, a stride
    /// smaller than the width, an empty or reversed range.
    InvalidArgument,
    /// Geometry without a defined answer: a zero-area triangle, a zero normal,
    /// coincident camera positions, a singular matrix.
    DegenerateGeometry,
}

impl Error {
    /// A short, static, human-readable description.
    pub const fn as_str(self) -> &'static str {
        match self {
            Error::NullPointer => "a required pointer was null",
            Error::InsufficientSize => "a buffer is too small",
            Error::InvalidArgument => {
                "invalid argument (NaN/Inf, zero or overflowing size, bad range)"
            }
            Error::DegenerateGeometry => "degenerate geometry",
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl core::error::Error for Error {}
