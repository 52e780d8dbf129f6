//! The one error type of refl-core.
//!
//! Each variant maps 1:1 onto a `refl_status` value of the C ABI (see
//! `refl-ffi`); `0` is reserved there for success.
//!
//! # Example
//! ```rust
//! use refl_core::{glam::Vec3, Camera, Error, ImageView};
//!
//! // A buffer one texel short of a 4 x 4 image.
//! let short = [0.0f32; 15];
//! assert_eq!(ImageView::try_new(&short, 4, 4, 4).unwrap_err(), Error::InsufficientSize);
//! // A zero-sized image, and a camera whose eye is its target.
//! assert_eq!(ImageView::try_new(&short, 0, 4, 4).unwrap_err(), Error::InvalidArgument);
//! let eye = Vec3::new(1.0, 2.0, 3.0);
//! let cam = Camera::try_look_at(eye, eye, Vec3::Y, 1.0, 0.1, 100.0, 4, 4);
//! assert_eq!(cam.unwrap_err(), Error::DegenerateGeometry);
//! // Errors propagate with `?` and print their description.
//! fn first_texel(data: &[f32]) -> Result<f32, Error> {
//!     Ok(ImageView::try_new(data, 4, 4, 4)?.get(0, 0).unwrap_or(0.0))
//! }
//! let err = first_texel(&short).unwrap_err();
//! assert_eq!(err.to_string(), "a buffer is too small");
//! ```

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
