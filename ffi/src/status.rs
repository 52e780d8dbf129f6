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
pub const REFL_VERSION_MINOR: u32 = 3;
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
/// "0.3.0". Never NULL; must not be freed.
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

/// Capacity in bytes of the thread-local last-error message (longer
/// messages are cut at a character boundary).
pub const REFL_LAST_ERROR_CAPACITY: usize = 256;

/// A fixed-size UTF-8 message buffer (no allocation).
struct Message {
    len: usize,
    buf: [u8; REFL_LAST_ERROR_CAPACITY],
}

impl Message {
    const EMPTY: Self = Self {
        len: 0,
        buf: [0; REFL_LAST_ERROR_CAPACITY],
    };

    fn as_str(&self) -> &str {
        // Only whole characters are ever appended (`write_str`).
        core::str::from_utf8(&self.buf[..self.len]).unwrap_or("")
    }
}

impl core::fmt::Write for Message {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        // At most REFL_LAST_ERROR_CAPACITY - 1 bytes (a C copy adds the NUL).
        let room = REFL_LAST_ERROR_CAPACITY - 1 - self.len;
        let mut n = s.len().min(room);
        while !s.is_char_boundary(n) {
            n -= 1;
        }
        self.buf[self.len..self.len + n].copy_from_slice(&s.as_bytes()[..n]);
        self.len += n;
        Ok(())
    }
}

std::thread_local! {
    /// What the failing check of the current call said (empty: nothing).
    static DETAIL: core::cell::RefCell<Message> = const { core::cell::RefCell::new(Message::EMPTY) };
    /// The message of the last call made through [`guard`] on this thread.
    static LAST_ERROR: core::cell::RefCell<Message> = const { core::cell::RefCell::new(Message::EMPTY) };
}

/// Records why the current call fails (which argument, what was wrong) and
/// returns `e`, for `return Err(fail(..))` and `.map_err(|e| fail(..))`.
/// The first detail of a call wins: a check deeper down that already said
/// why is not overwritten by a caller's more general one.
pub(crate) fn fail(e: Error, why: core::fmt::Arguments<'_>) -> Error {
    use core::fmt::Write;
    DETAIL.with(|d| {
        if let Ok(mut d) = d.try_borrow_mut() {
            if d.len == 0 {
                let _ = d.write_fmt(why);
            }
        }
    });
    e
}

/// `fail` with a plain string.
pub(crate) fn fail_str(e: Error, why: &str) -> Error {
    fail(e, format_args!("{why}"))
}

/// Runs `f`, the body of the export `name`, behind the panic boundary: its
/// `Result` becomes a status, and a panic becomes [`refl_status::Panic`]
/// instead of unwinding into C. The thread-local last-error message is
/// cleared on entry and, on failure, set to `"<name>: <status string>:
/// <detail>"` (the detail from [`fail`], when a check gave one).
///
/// The panic payload is leaked rather than dropped: a payload whose `Drop`
/// panics again would otherwise unwind across the boundary.
pub(crate) fn guard<F: FnOnce() -> Result<(), Error>>(name: &str, f: F) -> refl_status {
    DETAIL.with(|d| {
        if let Ok(mut d) = d.try_borrow_mut() {
            d.len = 0;
        }
    });
    let status = match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => refl_status::Ok,
        Ok(Err(e)) => e.into(),
        Err(payload) => {
            core::mem::forget(payload);
            refl_status::Panic
        }
    };
    LAST_ERROR.with(|l| {
        let Ok(mut l) = l.try_borrow_mut() else {
            return;
        };
        l.len = 0;
        if status == refl_status::Ok {
            return;
        }
        use core::fmt::Write;
        let what = status.as_cstr().to_str().unwrap_or("");
        let _ = write!(l, "{name}: {what}");
        DETAIL.with(|d| {
            if let Ok(d) = d.try_borrow() {
                if d.len > 0 {
                    let _ = write!(l, ": {}", d.as_str());
                }
            }
        });
    });
    status
}

/// The message of the most recent call on this thread of a refl function
/// that returns a `refl_status`: empty if that call succeeded, else
/// `"<function>: <status string>"` followed, where the call can say, by
/// `": "` and which argument was refused and why (for example
/// `"refl_hiz_trace_ray: invalid argument (NaN/Inf, zero or overflowing
/// size, bad range): hiz: the pyramid was built for 512x384, the camera is
/// 256x192"`). This function and `refl_status_string`,
/// `refl_version` and `refl_version_number` do not change it. Like `errno`
/// it is per thread; unlike `errno` every status-returning call resets it.
///
/// Copies at most `dst_len - 1` bytes of the message and a terminating NUL
/// to `dst` (nothing when `dst` is NULL or `dst_len` is 0) and returns the
/// message's full length in bytes, without the NUL (as `snprintf` does): a
/// return value `>= dst_len` means the copy was cut. Messages are at most
/// `REFL_LAST_ERROR_CAPACITY - 1` bytes of UTF-8 (English, ASCII in
/// practice).
///
/// # Safety
/// `dst` must be NULL or writable for `dst_len` bytes.
#[no_mangle]
pub unsafe extern "C" fn refl_last_error_message(dst: *mut c_char, dst_len: usize) -> usize {
    let r = catch_unwind(AssertUnwindSafe(|| {
        LAST_ERROR.with(|l| {
            let Ok(l) = l.try_borrow() else {
                return 0;
            };
            let msg = &l.buf[..l.len];
            if !dst.is_null() && dst_len > 0 {
                let n = msg.len().min(dst_len - 1);
                // SAFETY: `dst` is writable for `dst_len > n` bytes (caller
                // contract); `msg` is a thread-local buffer, disjoint from
                // caller memory.
                unsafe {
                    core::ptr::copy_nonoverlapping(msg.as_ptr(), dst.cast::<u8>(), n);
                    dst.add(n).write(0);
                }
            }
            msg.len()
        })
    }));
    r.unwrap_or(0)
}

/// Calls `f` with the current thread's last-error message (for Rust
/// callers of the C ABI and tests; no copy, no allocation); see
/// [`refl_last_error_message`].
pub fn with_last_error_message<R>(f: impl FnOnce(&str) -> R) -> R {
    LAST_ERROR.with(|l| match l.try_borrow() {
        Ok(l) => f(l.as_str()),
        Err(_) => f(""),
    })
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

    fn last_error_message() -> std::string::String {
        with_last_error_message(|m| m.to_owned())
    }

    #[test]
    fn guard_catches_panics() {
        let s = guard("boom", || panic!("boom"));
        assert_eq!(s, refl_status::Panic);
        assert!(last_error_message().starts_with("boom: a panic was caught"));
        assert_eq!(guard("fine", || Ok(())), refl_status::Ok);
        assert_eq!(last_error_message(), "");
        assert_eq!(
            guard("f", || Err(Error::DegenerateGeometry)),
            refl_status::DegenerateGeometry
        );
        assert_eq!(last_error_message(), "f: degenerate geometry");
        assert_eq!(
            guard("g", || Err(fail(
                Error::InvalidArgument,
                format_args!("x is {}", 3)
            ))),
            refl_status::InvalidArgument
        );
        assert!(last_error_message().starts_with("g: invalid argument"));
        assert!(last_error_message().ends_with(": x is 3"));
    }

    #[test]
    fn long_messages_are_cut_at_a_character_boundary() {
        let long = "\u{e9}".repeat(400);
        guard("h", || Err(fail_str(Error::InvalidArgument, &long)));
        let m = last_error_message();
        assert!(m.len() < REFL_LAST_ERROR_CAPACITY && m.len() >= REFL_LAST_ERROR_CAPACITY - 2);
        let mut buf = [0x55u8; 8];
        // SAFETY: buf is writable for 8 bytes.
        let n = unsafe { refl_last_error_message(buf.as_mut_ptr().cast(), buf.len()) };
        assert_eq!(n, m.len());
        assert_eq!(&buf[..7], &m.as_bytes()[..7]);
        assert_eq!(buf[7], 0);
        // SAFETY: NULL is allowed.
        let n = unsafe { refl_last_error_message(core::ptr::null_mut(), 0) };
        assert_eq!(n, m.len());
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
