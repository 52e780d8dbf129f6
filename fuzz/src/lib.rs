//! Shared helpers of refl's fuzz targets (`fuzz/fuzz_targets/*.rs`).
//!
//! Every target drives the C ABI through the `refl` rlib (the `extern "C"`
//! functions themselves, so the checks hold for a C caller too) from raw
//! fuzz bytes, in the shapes a C caller can pass: sizes and strides,
//! enum values (valid and not), floats with NaN, +-Inf, huge, tiny and -0,
//! short buffers, NULL and misaligned pointers, outputs aliasing inputs.
//!
//! The contract checked, from `include/refl.h`:
//!  * `REFL_STATUS_PANIC` never occurs (and any panic aborts the fuzzer:
//!    libfuzzer-sys installs an aborting panic hook, so even a caught panic
//!    inside refl is reported as a crash with its stack);
//!  * a status other than `REFL_STATUS_OK` leaves every output byte as it
//!    was (outputs are pre-filled with [`SENTINEL`]);
//!  * inputs are never written;
//!  * a NULL required pointer gives `REFL_STATUS_NULL_POINTER`, and
//!    `REFL_STATUS_NULL_POINTER` only comes with a NULL pointer;
//!  * on `REFL_STATUS_OK` the outputs satisfy what the header says of them
//!    (checked in each target).
//!
//! Buffers are allocated with exactly the length passed to refl, so
//! AddressSanitizer reports any access past a stated length.

#![allow(clippy::missing_safety_doc)]

pub use refl::*;

mod gbuffer;
pub use gbuffer::{bits3, host_bits, same_host, FuzzGBuffer};
mod img;
pub use img::{hash, hostile, mirror_run, ssr_bits, ssr_texel_img, u8_img, u8_mut, vec3_img, vec3_mut, Img};
pub mod layered;
pub use layered::{grid_ok, identity, sizes, Map};

use core::mem::{align_of, size_of, MaybeUninit};

/// The byte every output buffer is filled with before a call.
pub const SENTINEL: u8 = 0xA5;

/// Largest image side the targets build (keeps an execution cheap).
pub const MAX_SIDE: u32 = 48;

// ---------------------------------------------------------------------------
// Reading the fuzz input.

/// A cursor over the fuzz input; past its end every read returns zeros, so
/// any input is a complete test case.
pub struct Bytes<'a> {
    d: &'a [u8],
    i: usize,
}

impl<'a> Bytes<'a> {
    /// A cursor at the start of `d`.
    pub fn new(d: &'a [u8]) -> Self {
        Self { d, i: 0 }
    }

    /// Whether every byte has been read.
    pub fn is_empty(&self) -> bool {
        self.i >= self.d.len()
    }

    /// Bytes not yet read.
    pub fn remaining(&self) -> usize {
        self.d.len().saturating_sub(self.i)
    }

    /// One byte.
    pub fn u8(&mut self) -> u8 {
        let v = self.d.get(self.i).copied().unwrap_or(0);
        self.i += 1;
        v
    }

    /// A little-endian u16.
    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }

    /// A little-endian u32.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }

    /// A little-endian u64.
    pub fn u64(&mut self) -> u64 {
        u64::from(self.u32()) | (u64::from(self.u32()) << 32)
    }

    /// A boolean.
    pub fn bool(&mut self) -> bool {
        self.u8() & 1 == 1
    }

    /// A value in `0..n` (0 for `n == 0`).
    pub fn below(&mut self, n: u32) -> u32 {
        match n {
            0 => 0,
            1..=256 => u32::from(self.u8()) % n,
            _ => self.u32() % n,
        }
    }

    /// One of `xs`.
    pub fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[self.below(xs.len() as u32) as usize]
    }

    /// True with probability about `k / 256`.
    pub fn chance(&mut self, k: u8) -> bool {
        self.u8() < k
    }

    /// A hostile float: NaN, +-Inf, +-0, extremes, subnormals, raw bits.
    pub fn f32_special(&mut self) -> f32 {
        const S: [f32; 20] = [
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            -0.0,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
            1e30,
            -1e30,
            1e-30,
            1.0,
            -1.0,
            0.5,
            1e7,
            -1e7,
        ];
        let k = self.u8();
        if (k as usize) < S.len() {
            S[k as usize]
        } else {
            f32::from_bits(self.u32())
        }
    }

    /// A float in `[lo, hi]` most of the time, a hostile one otherwise.
    pub fn f32_in(&mut self, lo: f32, hi: f32) -> f32 {
        if self.chance(12) {
            return self.f32_special();
        }
        let t = f32::from(self.u16()) / 65535.0;
        lo + (hi - lo) * t
    }

    /// A float in `[lo, hi]`, never hostile (for the probes of the checks).
    pub fn f32_fine(&mut self, lo: f32, hi: f32) -> f32 {
        let t = f32::from(self.u16()) / 65535.0;
        (lo + (hi - lo) * t).clamp(lo.min(hi), hi.max(lo))
    }

    /// Any float: mostly moderate values, often hostile ones.
    pub fn f32_any(&mut self) -> f32 {
        if self.chance(64) {
            self.f32_special()
        } else {
            (f32::from(self.u16() as i16)) / 256.0
        }
    }

    /// A vector with components in `[lo, hi]` (sometimes hostile).
    pub fn vec3_in(&mut self, lo: f32, hi: f32) -> refl_vec3 {
        refl_vec3 {
            x: self.f32_in(lo, hi),
            y: self.f32_in(lo, hi),
            z: self.f32_in(lo, hi),
        }
    }

    /// A 2-vector with components in `[lo, hi]` (sometimes hostile).
    pub fn vec2_in(&mut self, lo: f32, hi: f32) -> refl_vec2 {
        refl_vec2 {
            x: self.f32_in(lo, hi),
            y: self.f32_in(lo, hi),
        }
    }

    /// A unit vector most of the time (sometimes zero, hostile or not unit).
    pub fn dir3(&mut self) -> refl_vec3 {
        let v = self.vec3_in(-1.0, 1.0);
        if self.chance(16) {
            return v;
        }
        let (x, y, z) = (f64::from(v.x), f64::from(v.y), f64::from(v.z));
        let l = (x * x + y * y + z * z).sqrt();
        if !(l.is_finite() && l > 1e-6) {
            return refl_vec3 {
                x: 0.0,
                y: -1.0,
                z: 0.0,
            };
        }
        refl_vec3 {
            x: (x / l) as f32,
            y: (y / l) as f32,
            z: (z / l) as f32,
        }
    }

    /// An image side: `1..=max` mostly, sometimes 0 or huge.
    pub fn side(&mut self, max: u32) -> u32 {
        let k = self.u8();
        match k {
            0..=3 => 0,
            4 => u32::MAX,
            5 => 1 << 16,
            6 => max + 1,
            _ => 1 + u32::from(k) % max,
        }
    }

    /// A stride for `width`: mostly `width` or a little more, sometimes less.
    pub fn stride(&mut self, width: u32) -> u32 {
        match self.u8() {
            0..=7 => width.saturating_sub(1),
            8..=9 => 0,
            10 => u32::MAX,
            11..=79 => width.saturating_add(u32::from(self.u8() % 5)),
            _ => width,
        }
    }

    /// A buffer length around `need`: mostly `need`, sometimes short,
    /// empty or longer.
    pub fn len_for(&mut self, need: usize) -> usize {
        match self.u8() {
            0..=7 => need.saturating_sub(1 + usize::from(self.u8() % 8)),
            8..=10 => 0,
            11..=30 => need + usize::from(self.u8() % 8),
            _ => need,
        }
    }

    /// How a pointer is passed.
    pub fn ptr_kind(&mut self) -> PtrKind {
        match self.u8() {
            0..=3 => PtrKind::Null,
            4..=7 => PtrKind::Misaligned,
            _ => PtrKind::Valid,
        }
    }

    /// A `refl_depth_convention` value, sometimes an unknown one.
    pub fn convention(&mut self) -> u32 {
        match self.u8() {
            0..=7 => self.pick(&[3, 4, 0xFFFF_FFFF, 0x8000_0000, 0x1_00]),
            k => u32::from(k) % 3,
        }
    }

    /// A row range of an image of `height` rows: mostly valid.
    pub fn rows(&mut self, height: u32) -> refl_row_range {
        match self.u8() {
            0..=11 => refl_row_range {
                begin: self.below(height.saturating_add(2)),
                end: self.below(height.saturating_add(2)),
            },
            12..=15 => refl_row_range {
                begin: 0,
                end: u32::MAX,
            },
            16..=127 => {
                let a = self.below(height.max(1));
                let b = a + 1 + self.below(height.saturating_sub(a).max(1));
                refl_row_range {
                    begin: a,
                    end: b.min(height),
                }
            }
            _ => refl_row_range {
                begin: 0,
                end: height,
            },
        }
    }
}

/// How a pointer argument is passed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PtrKind {
    /// A valid, aligned pointer.
    Valid,
    /// NULL.
    Null,
    /// One byte past an aligned address (for texels with alignment > 1).
    Misaligned,
}

// ---------------------------------------------------------------------------
// Caller buffers.

/// A caller buffer of `len` texels of `T`, allocated with exactly that
/// length (so ASan catches reads and writes past it), passed as a valid,
/// NULL or misaligned pointer. Bytes are kept as `MaybeUninit`, so any byte
/// pattern (the sentinel in a `bool`) is sound.
pub struct Buf<T: Copy> {
    v: Vec<MaybeUninit<T>>,
    raw: Vec<u8>,
    len: usize,
    kind: PtrKind,
}

impl<T: Copy> Buf<T> {
    fn alloc(len: usize, kind: PtrKind) -> Self {
        let kind = if kind == PtrKind::Misaligned && align_of::<T>() == 1 {
            PtrKind::Valid
        } else {
            kind
        };
        let mut v = Vec::with_capacity(len);
        // SAFETY: MaybeUninit needs no initialization.
        unsafe { v.set_len(len) };
        let raw = if kind == PtrKind::Misaligned {
            vec![SENTINEL; len * size_of::<T>() + 1]
        } else {
            Vec::new()
        };
        Self { v, raw, len, kind }
    }

    /// `len` texels of [`SENTINEL`] bytes (an output).
    pub fn sentinel(len: usize, kind: PtrKind) -> Self {
        let mut b = Self::alloc(len, kind);
        b.bytes_mut().fill(SENTINEL);
        b
    }

    /// `len` texels from `f` (an input).
    pub fn from_fn(len: usize, kind: PtrKind, mut f: impl FnMut(usize) -> T) -> Self {
        let mut b = Self::alloc(len, kind);
        b.bytes_mut().fill(SENTINEL);
        for i in 0..len {
            b.set(i, f(i));
        }
        b
    }

    /// A copy of `xs` (an input).
    pub fn from_slice(xs: &[T], kind: PtrKind) -> Self {
        Self::from_fn(xs.len(), kind, |i| xs[i])
    }

    /// The pointer to pass.
    pub fn ptr(&mut self) -> *mut T {
        match self.kind {
            PtrKind::Null => core::ptr::null_mut(),
            PtrKind::Valid => self.v.as_mut_ptr().cast(),
            // SAFETY: in bounds of `raw` (one extra byte).
            PtrKind::Misaligned => unsafe { self.raw.as_mut_ptr().add(1) }.cast(),
        }
    }

    /// The pointer to pass, read-only.
    pub fn cptr(&self) -> *const T {
        match self.kind {
            PtrKind::Null => core::ptr::null(),
            PtrKind::Valid => self.v.as_ptr().cast(),
            // SAFETY: in bounds of `raw` (one extra byte).
            PtrKind::Misaligned => unsafe { self.raw.as_ptr().add(1) }.cast(),
        }
    }

    /// The length in texels.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the buffer has no texels.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// How the pointer is passed.
    pub fn kind(&self) -> PtrKind {
        self.kind
    }

    /// Whether the pointer passed is NULL.
    pub fn is_null(&self) -> bool {
        self.kind == PtrKind::Null
    }

    /// Whether refl can use it: valid and aligned.
    pub fn usable(&self) -> bool {
        self.kind == PtrKind::Valid
    }

    /// The bytes behind the pointer.
    pub fn bytes(&self) -> &[u8] {
        let n = self.len * size_of::<T>();
        match self.kind {
            PtrKind::Misaligned => &self.raw[1..1 + n],
            // SAFETY: `v` holds `len` texels, `n` bytes, all initialized
            // (filled in the constructors).
            _ => unsafe { core::slice::from_raw_parts(self.v.as_ptr().cast::<u8>(), n) },
        }
    }

    fn bytes_mut(&mut self) -> &mut [u8] {
        let n = self.len * size_of::<T>();
        match self.kind {
            PtrKind::Misaligned => &mut self.raw[1..1 + n],
            // SAFETY: as in `bytes`; MaybeUninit bytes may be written.
            _ => unsafe { core::slice::from_raw_parts_mut(self.v.as_mut_ptr().cast::<u8>(), n) },
        }
    }

    /// Texel `i`, read as `T`. Only for plain-old-data `T` (every bit
    /// pattern valid) or texels refl wrote.
    pub fn get(&self, i: usize) -> T {
        let b = &self.bytes()[i * size_of::<T>()..(i + 1) * size_of::<T>()];
        // SAFETY: `b` holds size_of::<T>() bytes; unaligned read.
        unsafe { b.as_ptr().cast::<T>().read_unaligned() }
    }

    /// Writes texel `i`.
    pub fn set(&mut self, i: usize, v: T) {
        let b = &mut self.bytes_mut()[i * size_of::<T>()..(i + 1) * size_of::<T>()];
        // SAFETY: `b` holds size_of::<T>() bytes; unaligned write.
        unsafe { b.as_mut_ptr().cast::<T>().write_unaligned(v) }
    }

    /// Every texel as `T` (plain-old-data `T`).
    pub fn to_vec(&self) -> Vec<T> {
        (0..self.len).map(|i| self.get(i)).collect()
    }

    /// Whether texel `i` still holds the sentinel bytes.
    pub fn is_sentinel(&self, i: usize) -> bool {
        self.bytes()[i * size_of::<T>()..(i + 1) * size_of::<T>()]
            .iter()
            .all(|&b| b == SENTINEL)
    }

    /// A copy of the bytes, to compare with after a call.
    pub fn snapshot(&self) -> Vec<u8> {
        self.bytes().to_vec()
    }

    /// Asserts the bytes equal `snap` (taken before the call).
    #[track_caller]
    pub fn assert_unchanged(&self, snap: &[u8], what: &str) {
        if self.bytes() != snap {
            let i = self.bytes().iter().zip(snap).position(|(a, b)| a != b);
            panic!("{what}: buffer changed (first byte {i:?} of {})", snap.len());
        }
    }

    /// Asserts texel `i` is unchanged from `snap`.
    #[track_caller]
    pub fn assert_texel_unchanged(&self, snap: &[u8], i: usize, what: &str) {
        let r = i * size_of::<T>()..(i + 1) * size_of::<T>();
        assert!(
            self.bytes()[r.clone()] == snap[r],
            "{what}: texel {i} changed"
        );
    }
}

/// A one-value output filled with [`SENTINEL`] bytes, passed as a valid,
/// NULL or misaligned pointer.
pub fn out1<T: Copy>(kind: PtrKind) -> Buf<T> {
    Buf::sentinel(1, kind)
}

// ---------------------------------------------------------------------------
// Status checks.

/// Asserts the status is a known value and not `REFL_STATUS_PANIC`.
#[track_caller]
pub fn no_panic(s: refl_status, what: &str) {
    assert!(s != refl_status::Panic, "{what}: REFL_STATUS_PANIC");
    let v = s as u32;
    assert!(v <= 4, "{what}: unknown status {v}");
}

/// Whether the checks of known, reported contract violations are strict
/// (`REFL_FUZZ_STRICT=1`): by default a target tolerates them, so that it
/// keeps finding new ones; see `fuzz/README.md` ("Known findings").
pub fn strict() -> bool {
    strict_for("all")
}

/// Whether known finding `id` ("F1".."F7") is checked strictly:
/// `REFL_FUZZ_STRICT=1` (or `all`) makes every one strict, a list such as
/// `REFL_FUZZ_STRICT=F6,F7` only those.
pub fn strict_for(id: &str) -> bool {
    static S: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    let v = S.get_or_init(|| std::env::var("REFL_FUZZ_STRICT").unwrap_or_default());
    v == "1" || v == "all" || v.split(',').any(|x| x.trim() == id)
}

/// Known finding F5 (tolerated unless [`strict`]): `refl_camera_validate`
/// accepts a view translation near f32::MAX, whose eye (`-R^-1 t`, rounded
/// to f32) overflows: `refl_camera_eye` and `refl_camera_inverse_view`
/// then return OK with infinite components, and `refl_camera_is_mirrored`
/// (the sign of the f32 4x4 determinant, which overflows to NaN) answers
/// false for mirrored and unmirrored cameras alike.
pub fn known_f5(c: &refl_camera) -> bool {
    !strict_for("F5") && c.view.m[12..15].iter().any(|v| v.abs() > 1e37)
}

/// Whether the projection (`world == false`) or world-to-pixel matrix of a
/// valid camera may overflow f32 (the documented
/// `REFL_STATUS_DEGENERATE_GEOMETRY`): the projection's depth row holds
/// `f / (n - f)` and `n f / (n - f)` (reversed: `n / (f - n)`, `n f / (f -
/// n)`), which overflow for a huge near plane close to the far one; the
/// world-to-pixel matrix also scales the view by the focal length in
/// pixels and the image size. A refusal without this is a bug.
pub fn matrix_may_overflow(c: &refl_camera, world: bool) -> bool {
    let (n, f) = (f64::from(c.z_near), f64::from(c.z_far));
    let depth_row = if f.is_infinite() { n } else { (n * f / (f - n)).abs().max((f / (f - n)).abs()) };
    let focal = 1.0 / (f64::from(c.fov_y) * 0.5).tan();
    if !world {
        return depth_row > 1e37 || focal > 1e37;
    }
    let t = c.view.m[12..15].iter().fold(1f64, |a, v| a.max(f64::from(v.abs())));
    let side = f64::from(c.width.max(c.height));
    (focal + 1.0 + depth_row) * (side + 1.0) * t > 1e36
}

/// The NULL rules: with a NULL required pointer the status is
/// `REFL_STATUS_NULL_POINTER`; `REFL_STATUS_NULL_POINTER` needs some NULL
/// pointer (`any_null`, required or optional).
#[track_caller]
pub fn null_rules(s: refl_status, required_null: bool, any_null: bool, what: &str) {
    null_rules_m(s, required_null, any_null, false, what)
}

/// [`null_rules`] for a call where some pointer is misaligned
/// (`any_misaligned`). Since finding F1 the header's rule is that every
/// pointer is checked before it is read and `REFL_STATUS_NULL_POINTER`
/// comes only with a NULL, while which of several bad arguments is reported
/// is unspecified: a misaligned pointer checked before a NULL one may give
/// `REFL_STATUS_INVALID_ARGUMENT`.
#[track_caller]
pub fn null_rules_m(
    s: refl_status,
    required_null: bool,
    any_null: bool,
    any_misaligned: bool,
    what: &str,
) {
    no_panic(s, what);
    check_last_error(s, what);
    if required_null {
        let misaligned_first = any_misaligned && s == refl_status::InvalidArgument;
        if !misaligned_first {
            assert_eq!(s, refl_status::NullPointer, "{what}: NULL not reported first");
        }
    }
    if s == refl_status::NullPointer {
        assert!(any_null, "{what}: REFL_STATUS_NULL_POINTER without a NULL pointer");
    }
}

/// Checks `refl_last_error_message` right after a call that returned `s`
/// (`what` names the function when it is a bare `refl_*` identifier): the
/// message is empty after success and `"<function>: <status string>..."`
/// after an error; the snprintf-style copy (length returned, at most
/// `dst_len - 1` bytes and a NUL written, nothing past) and the query
/// itself do not change it.
#[track_caller]
pub fn check_last_error(s: refl_status, what: &str) {
    // SAFETY: NULL with length 0 is allowed.
    let n = unsafe { refl_last_error_message(core::ptr::null_mut(), 0) };
    assert!(n < REFL_LAST_ERROR_CAPACITY, "{what}: last-error message of {n} bytes");
    let mut full = vec![SENTINEL; REFL_LAST_ERROR_CAPACITY + 8];
    // SAFETY: `full` is writable for its length.
    let n2 = unsafe { refl_last_error_message(full.as_mut_ptr().cast(), full.len()) };
    assert_eq!(n, n2, "{what}: refl_last_error_message length changed between calls");
    assert_eq!(full[n], 0, "{what}: last-error message not NUL-terminated");
    assert!(full[n + 1..].iter().all(|&c| c == SENTINEL), "{what}: wrote past the message's NUL");
    let msg = core::str::from_utf8(&full[..n]).expect("last-error message is UTF-8");
    assert!(!msg.contains('\0'), "{what}: NUL inside the message");
    if s == refl_status::Ok {
        assert!(msg.is_empty(), "{what}: OK but last error is {msg:?}");
    } else {
        // SAFETY: static NUL-terminated string.
        let ss = unsafe { core::ffi::CStr::from_ptr(refl_status_string(s as u32)) }.to_str().unwrap();
        let bare = what.starts_with("refl_") && what.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'_');
        if bare {
            let want = format!("{what}: {ss}");
            assert!(msg.starts_with(&want), "{what}: status {s:?} but last error {msg:?}");
        } else {
            assert!(msg.starts_with("refl_") && msg.contains(ss), "{what}: status {s:?} but last error {msg:?}");
        }
    }
    // A cut copy: dst_len - 1 bytes and a NUL.
    let k = n / 2 + 1;
    let mut cut = vec![SENTINEL; k + 4];
    // SAFETY: `cut` is writable for k bytes.
    let n3 = unsafe { refl_last_error_message(cut.as_mut_ptr().cast(), k) };
    assert_eq!(n3, n, "{what}: cut copy returned another length");
    let c = (k - 1).min(n);
    assert!(cut[..c] == full[..c] && cut[c] == 0, "{what}: cut copy wrong");
    assert!(cut[c + 1..].iter().all(|&x| x == SENTINEL), "{what}: cut copy wrote past dst_len");
}

/// The standard epilogue: no panic, the NULL rules, and on an error status
/// every output unchanged (`outs` are `(name, was_untouched)` checks run
/// only on error).
#[track_caller]
pub fn on_error_untouched(s: refl_status, outs: &[(&str, bool)], what: &str) {
    no_panic(s, what);
    if s != refl_status::Ok {
        for (name, untouched) in outs {
            assert!(*untouched, "{what}: returned {s:?} but wrote output {name}");
        }
    }
}

// ---------------------------------------------------------------------------
// Small numeric helpers.

/// `|a - b| <= tol * max(1, |a|, |b|)`.
pub fn close(a: f32, b: f32, tol: f32) -> bool {
    let (a, b) = (f64::from(a), f64::from(b));
    (a - b).abs() <= f64::from(tol) * 1f64.max(a.abs()).max(b.abs())
}

/// Vector as f64 array.
pub fn d3(v: refl_vec3) -> [f64; 3] {
    [f64::from(v.x), f64::from(v.y), f64::from(v.z)]
}

/// Euclidean length (f64).
pub fn len3(v: refl_vec3) -> f64 {
    let [x, y, z] = d3(v);
    (x * x + y * y + z * z).sqrt()
}

/// Whether every component is finite.
pub fn finite3(v: refl_vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

/// Largest absolute component.
pub fn max_abs3(v: refl_vec3) -> f32 {
    v.x.abs().max(v.y.abs()).max(v.z.abs())
}

/// Whether every element is finite.
pub fn finite_mat(m: &refl_mat4) -> bool {
    m.m.iter().all(|v| v.is_finite())
}

/// `m * (x, y, z, w)` in f64 (column-major).
pub fn mat_mul4(m: &refl_mat4, v: [f64; 4]) -> [f64; 4] {
    let mut r = [0.0; 4];
    for (row, out) in r.iter_mut().enumerate() {
        *out = (0..4).map(|c| f64::from(m.m[4 * c + row]) * v[c]).sum();
    }
    r
}

/// `a * b` in f64 (column-major).
pub fn mat_mul(a: &refl_mat4, b: &refl_mat4) -> [f64; 16] {
    let mut r = [0.0; 16];
    for c in 0..4 {
        for row in 0..4 {
            r[4 * c + row] = (0..4)
                .map(|k| f64::from(a.m[4 * k + row]) * f64::from(b.m[4 * c + k]))
                .sum();
        }
    }
    r
}

/// Whether the f32 values are the same bits, or both NaN.
pub fn same_f32(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

// ---------------------------------------------------------------------------
// Cameras and images.

/// A fixed valid camera of `w x h` (looking at the origin from (0, 1.5, 4)).
pub fn default_camera(w: u32, h: u32) -> refl_camera {
    let mut c = zero_camera();
    // SAFETY: `c` is writable.
    let s = unsafe {
        refl_camera_look_at(
            &mut c,
            v3(0.0, 1.5, 4.0),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 1.0, 0.0),
            1.0,
            0.1,
            100.0,
            w.max(1),
            h.max(1),
        )
    };
    assert_eq!(s, refl_status::Ok, "default camera");
    c.width = w;
    c.height = h;
    c
}

/// An all-zero camera record.
pub fn zero_camera() -> refl_camera {
    refl_camera {
        view: refl_mat4 { m: [0.0; 16] },
        fov_y: 0.0,
        z_near: 0.0,
        z_far: 0.0,
        width: 0,
        height: 0,
    }
}

/// `refl_vec3 { x, y, z }`.
pub fn v3(x: f32, y: f32, z: f32) -> refl_vec3 {
    refl_vec3 { x, y, z }
}

/// Whether `refl_camera_validate` accepts `c`.
pub fn camera_ok(c: &refl_camera) -> bool {
    // SAFETY: `c` is readable.
    let s = unsafe { refl_camera_validate(c) };
    no_panic(s, "refl_camera_validate");
    s == refl_status::Ok
}

/// A camera of `w x h` from the fuzz input: mostly a look-at camera with
/// moderate parameters (near 0.01..1, far finite or infinite), sometimes
/// with one field perturbed, sometimes raw bytes.
pub fn camera(b: &mut Bytes, w: u32, h: u32) -> refl_camera {
    let mode = b.u8();
    if mode < 8 {
        let mut c = zero_camera();
        for m in c.view.m.iter_mut() {
            *m = b.f32_any();
        }
        c.fov_y = b.f32_any();
        c.z_near = b.f32_any();
        c.z_far = b.f32_any();
        c.width = w;
        c.height = h;
        return c;
    }
    let eye = v3(
        b.f32_in(-8.0, 8.0),
        b.f32_in(0.2, 6.0),
        b.f32_in(-8.0, 8.0),
    );
    let target = v3(
        b.f32_in(-2.0, 2.0),
        b.f32_in(-1.0, 1.0),
        b.f32_in(-2.0, 2.0),
    );
    let up = if b.chance(32) {
        b.vec3_in(-1.0, 1.0)
    } else {
        v3(0.0, 1.0, 0.0)
    };
    let fov = b.f32_in(0.2, 2.6);
    let near = b.f32_in(0.01, 1.0);
    let far = match b.u8() % 4 {
        0 => f32::INFINITY,
        1 => near * b.f32_in(1.01, 50.0),
        _ => b.f32_in(20.0, 500.0),
    };
    let mut c = zero_camera();
    // SAFETY: `c` is writable.
    let s = unsafe {
        refl_camera_look_at(
            &mut c,
            eye,
            target,
            up,
            fov,
            near,
            far,
            w.max(1),
            h.max(1),
        )
    };
    no_panic(s, "refl_camera_look_at");
    if s != refl_status::Ok {
        c = default_camera(w, h);
    }
    c.width = w;
    c.height = h;
    if mode < 24 {
        match b.u8() % 8 {
            0 => {
                let k = b.below(16) as usize;
                c.view.m[k] = b.f32_any();
            }
            1 => c.fov_y = b.f32_any(),
            2 => c.z_near = b.f32_any(),
            3 => c.z_far = b.f32_any(),
            4 => c.width = b.side(MAX_SIDE),
            5 => c.height = b.side(MAX_SIDE),
            6 => {
                let k = b.below(16) as usize;
                c.view.m[k] += b.f32_in(-1e-3, 1e-3);
            }
            _ => {
                // A mirrored camera (floor y = 0).
                let p = refl_plane {
                    normal: v3(0.0, 1.0, 0.0),
                    d: 0.0,
                };
                let mut m = c;
                // SAFETY: pointers valid.
                let s = unsafe { refl_mirror_camera(&mut m, &c, &p) };
                if s == refl_status::Ok {
                    c = m;
                }
            }
        }
    }
    c
}

/// A depth texel pattern of `w x h` for camera `c` in convention `conv`:
/// a floor and a wall seen through the camera, or noise, or hostile values.
pub fn depth_values(b: &mut Bytes, c: &refl_camera, conv: u32, w: u32, h: u32) -> Vec<f32> {
    let n = (w as usize) * (h as usize);
    let mode = b.u8() % 8;
    let mut out = vec![f32::NAN; n];
    match mode {
        0 => {
            for v in out.iter_mut() {
                *v = b.f32_any();
            }
        }
        1 => {
            let base = b.f32_in(0.05, 30.0);
            for v in out.iter_mut() {
                *v = base;
            }
        }
        _ => {
            // Ray-cast a floor y = floor_y and a wall z = wall_z (and a
            // box) through the camera's pixel centers, in linear depth.
            let floor_y = b.f32_in(-1.0, 0.5);
            let wall_z = b.f32_in(-12.0, -2.0);
            let bx = [b.f32_in(-2.0, 1.0), b.f32_in(-1.0, 0.5), b.f32_in(-3.0, 0.0)];
            let bs = b.f32_in(0.1, 2.0);
            let holes = b.u8();
            let cc = refl_camera {
                width: c.width.max(1),
                height: c.height.max(1),
                ..*c
            };
            for y in 0..h {
                for x in 0..w {
                    let mut r = refl_ray::default();
                    let px = refl_vec2 {
                        x: x as f32 + 0.5,
                        y: y as f32 + 0.5,
                    };
                    // SAFETY: pointers valid.
                    let s = unsafe { refl_camera_primary_ray(&mut r, &cc, px) };
                    if s != refl_status::Ok {
                        continue;
                    }
                    let t = hit_scene(&r, floor_y, wall_z, bx, bs);
                    let i = (y * w + x) as usize;
                    if holes > 200 && (x * 7 + y * 3) % 11 == 0 {
                        out[i] = if holes & 1 == 0 { f32::NAN } else { -1.0 };
                        continue;
                    }
                    let Some(t) = t else {
                        out[i] = match conv {
                            0 => f32::INFINITY,
                            1 => 1.0,
                            _ => 0.0,
                        };
                        continue;
                    };
                    let p = v3(
                        r.origin.x + t * r.dir.x,
                        r.origin.y + t * r.dir.y,
                        r.origin.z + t * r.dir.z,
                    );
                    let mut z = 0.0f32;
                    // SAFETY: pointers valid.
                    if unsafe { refl_camera_linear_depth(&mut z, &cc, p) } != refl_status::Ok {
                        continue;
                    }
                    let mut d = 0.0f32;
                    // SAFETY: pointers valid.
                    if unsafe { refl_camera_encode_depth(&mut d, &cc, z, conv) } == refl_status::Ok
                    {
                        out[i] = d;
                    }
                }
            }
            if mode == 7 {
                // A few hostile texels.
                for _ in 0..(b.u8() % 8) {
                    let i = b.below(n as u32) as usize;
                    if i < n {
                        out[i] = b.f32_special();
                    }
                }
            }
        }
    }
    out
}

/// Distance along `r` to the floor, wall or box of [`depth_values`].
pub fn hit_scene(r: &refl_ray, floor_y: f32, wall_z: f32, bmin: [f32; 3], bs: f32) -> Option<f32> {
    let o = d3(r.origin);
    let d = d3(r.dir);
    let mut best = f64::INFINITY;
    if d[1] < -1e-9 {
        let t = (f64::from(floor_y) - o[1]) / d[1];
        if t > 0.0 {
            best = best.min(t);
        }
    }
    if d[2] < -1e-9 {
        let t = (f64::from(wall_z) - o[2]) / d[2];
        if t > 0.0 {
            best = best.min(t);
        }
    }
    // Slab test of the box.
    let mut t0 = 0.0f64;
    let mut t1 = f64::INFINITY;
    let mut inside = true;
    for a in 0..3 {
        let lo = f64::from(bmin[a]);
        let hi = lo + f64::from(bs);
        if d[a].abs() < 1e-12 {
            if o[a] < lo || o[a] > hi {
                inside = false;
            }
            continue;
        }
        let (mut ta, mut tb) = ((lo - o[a]) / d[a], (hi - o[a]) / d[a]);
        if ta > tb {
            core::mem::swap(&mut ta, &mut tb);
        }
        t0 = t0.max(ta);
        t1 = t1.min(tb);
    }
    if inside && t0 <= t1 && t0 > 0.0 {
        best = best.min(t0);
    }
    (best.is_finite()).then_some(best as f32)
}

/// An f32 image descriptor over `buf` (`width`, `height`, `stride` as given).
pub fn img_f32(buf: &Buf<f32>, width: u32, height: u32, stride: u32) -> refl_image_f32 {
    refl_image_f32 {
        data: buf.cptr(),
        len: buf.len(),
        width,
        height,
        stride,
    }
}

/// `(height - 1) * stride + width`, or None for a descriptor refl rejects.
pub fn required_len(width: u32, height: u32, stride: u32) -> Option<usize> {
    if width == 0 || height == 0 || stride < width {
        return None;
    }
    let n = u128::from(height - 1) * u128::from(stride) + u128::from(width);
    usize::try_from(n).ok()
}

/// A texel buffer for an image of `width x height` with `stride`: its
/// length from [`Bytes::len_for`] around the required length (capped for
/// absurd descriptors), its texels from `f(x, y)` (padding from `pad`).
pub fn image_buf<T: Copy>(
    b: &mut Bytes,
    width: u32,
    height: u32,
    stride: u32,
    mut f: impl FnMut(u32, u32) -> T,
    pad: T,
) -> Buf<T> {
    let need = required_len(width, height, stride).unwrap_or(16).min(1 << 16);
    let len = b.len_for(need);
    let kind = b.ptr_kind();
    let st = stride.max(1) as usize;
    Buf::from_fn(len, kind, |i| {
        let (x, y) = ((i % st) as u32, (i / st) as u32);
        if x < width && y < height {
            f(x, y)
        } else {
            pad
        }
    })
}

/// Decodes a stored depth to linear depth through the C ABI (None on error).
pub fn decode(c: &refl_camera, d: f32, conv: u32) -> Option<f32> {
    let mut z = 0.0f32;
    // SAFETY: pointers valid.
    let s = unsafe { refl_camera_decode_depth(&mut z, c, d, conv) };
    no_panic(s, "refl_camera_decode_depth");
    (s == refl_status::Ok).then_some(z)
}

/// Projects a world point (None on error or invalid projection).
pub fn project(c: &refl_camera, p: refl_vec3) -> Option<refl_projection> {
    let mut o = refl_projection::default();
    // SAFETY: pointers valid.
    let s = unsafe { refl_camera_project(&mut o, c, p) };
    no_panic(s, "refl_camera_project");
    (s == refl_status::Ok && o.valid).then_some(o)
}

/// A camera with moderate numbers (eye within 100 units, near >= 1e-3,
/// far/near <= 1e5 or infinite, fov in [0.1, 3]): where float tolerances of
/// the round-trip checks are meaningful.
pub fn camera_moderate(c: &refl_camera) -> bool {
    if !camera_ok(c) {
        return false;
    }
    let mut e = refl_vec3::default();
    // SAFETY: pointers valid.
    if unsafe { refl_camera_eye(&mut e, c) } != refl_status::Ok {
        return false;
    }
    max_abs3(e) < 100.0
        && c.z_near >= 1e-3
        && c.z_near <= 1e3
        && (c.z_far.is_infinite() || c.z_far / c.z_near <= 1e5)
        && c.fov_y >= 0.1
        && c.fov_y <= 3.0
        && c.width <= 4096
        && c.height <= 4096
}

/// Pixel tolerance of a projection round trip for a point `dist` away from
/// the eye of `c`: f32 rounding of the eye and the matrices, an angle of
/// about 3e-4 |eye| / dist, in pixels the focal length (pixels per radian,
/// `height / (2 tan(fov_y / 2))`) times that, which exceeds the image side
/// for a narrow field of view. (Before F20 the eye itself was up to 1e-4
/// |eye| off for a view orthonormal only within 1e-4.)
pub fn pixel_tol(c: &refl_camera, dist: f32) -> f32 {
    let e = eye_of(c).map_or(0.0, max_abs3);
    let focal = c.height as f32 / (2.0 * (0.5 * c.fov_y).tan());
    let side = ((c.width + c.height) as f32).max(focal);
    (1e-3 + 3e-4 * (1.0 + e) / dist.abs().max(1e-6)) * side
}

/// The eye of `c` (None if refl refuses the camera).
pub fn eye_of(c: &refl_camera) -> Option<refl_vec3> {
    let mut e = refl_vec3::default();
    // SAFETY: pointers valid.
    (unsafe { refl_camera_eye(&mut e, c) } == refl_status::Ok).then_some(e)
}

/// A trace result filled with the sentinel byte pattern.
pub fn sentinel_trace() -> refl_trace_result {
    let w = u32::from_ne_bytes([SENTINEL; 4]);
    refl_trace_result {
        miss: w,
        pixel: refl_vec2 {
            x: f32::from_bits(w),
            y: f32::from_bits(w),
        },
        t: f32::from_bits(w),
        depth: f32::from_bits(w),
        surface_depth: f32::from_bits(w),
        steps: w,
        fetches: w,
        iterations: w,
    }
}

/// Bitwise equality of two trace results.
pub fn same_trace(a: &refl_trace_result, b: &refl_trace_result) -> bool {
    a.miss == b.miss
        && a.pixel.x.to_bits() == b.pixel.x.to_bits()
        && a.pixel.y.to_bits() == b.pixel.y.to_bits()
        && a.t.to_bits() == b.t.to_bits()
        && a.depth.to_bits() == b.depth.to_bits()
        && a.surface_depth.to_bits() == b.surface_depth.to_bits()
        && a.steps == b.steps
        && a.fetches == b.fetches
        && a.iterations == b.iterations
}

/// The header's promises of a `refl_trace_result` returned with
/// `REFL_STATUS_OK` for a ray traced over `[0, t_max]` in a `w x h` image
/// seen by `cam`: a known miss value; on a miss zeros; on a hit a texel
/// inside the image, `t` in `[0, t_max]`, finite depths, and the hit point
/// projecting near `pixel`.
#[track_caller]
pub fn check_trace(
    r: &refl_trace_result,
    ray: &refl_ray,
    t_max: f32,
    cam: &refl_camera,
    hierarchical: bool,
    what: &str,
) {
    assert!(r.miss <= 5, "{what}: miss value {} out of range", r.miss);
    if r.miss != 0 {
        assert!(
            r.pixel.x == 0.0
                && r.pixel.y == 0.0
                && r.t == 0.0
                && r.depth == 0.0
                && r.surface_depth == 0.0,
            "{what}: miss {} with non-zero hit fields {r:?}",
            r.miss
        );
    } else {
        let (w, h) = (cam.width as f32, cam.height as f32);
        assert!(
            r.pixel.x >= 0.0 && r.pixel.x < w && r.pixel.y >= 0.0 && r.pixel.y < h,
            "{what}: hit pixel ({}, {}) outside the {w}x{h} image",
            r.pixel.x,
            r.pixel.y
        );
        // Known finding F6 (tolerated unless `strict`): a ray that enters a
        // surface far beyond its start (front depth > 2^23 times the ray's
        // start depth, e.g. 8e8 with a 0.38 near plane) gets the entry
        // fraction rounded to 1 in the 1/z interpolation: a "hit" at the
        // segment's far end, t = depth = +inf.
        if !strict_for("F6") && r.t == f32::INFINITY && r.surface_depth > 1e6 * cam.z_near {
            return;
        }
        assert!(
            r.t.is_finite() && r.t >= 0.0 && r.t <= t_max,
            "{what}: hit t = {} outside [0, {t_max}]: {r:?} ray {ray:?} camera {cam:?}",
            r.t
        );
        assert!(
            r.depth.is_finite() && r.surface_depth.is_finite(),
            "{what}: non-finite hit depth {r:?} ray {ray:?} t_max {t_max} camera {cam:?}"
        );
        if camera_moderate(cam) && max_abs3(ray.origin) < 100.0 && r.t < 1e3 {
            let p = v3(
                ray.origin.x + r.t * ray.dir.x,
                ray.origin.y + r.t * ray.dir.y,
                ray.origin.z + r.t * ray.dir.z,
            );
            if let Some(q) = project(cam, p) {
                // "origin + t * dir projects to pixel up to rounding"
                let tol = 0.05 + pixel_tol(cam, q.depth);
                assert!(
                    (q.x - r.pixel.x).abs() <= tol && (q.y - r.pixel.y).abs() <= tol,
                    "{what}: hit point projects to ({}, {}), pixel is ({}, {})",
                    q.x,
                    q.y,
                    r.pixel.x,
                    r.pixel.y
                );
                assert!(
                    close(q.depth, r.depth, 1e-3),
                    "{what}: hit point depth {} but depth field {}",
                    q.depth,
                    r.depth
                );
            }
        }
    }
    if !hierarchical {
        assert_eq!(r.iterations, 0, "{what}: stepping reports iterations");
    }
}

/// A camera of fuzzed size ([`Bytes::side`]) from [`camera`].
pub fn any_camera(b: &mut Bytes) -> refl_camera {
    let w = b.side(MAX_SIDE);
    let h = b.side(MAX_SIDE);
    camera(b, w, h)
}

// ---------------------------------------------------------------------------
// Depth images, thickness and rays (step, Hi-Z, cone, cluster targets).

/// A fuzzed depth image with its camera, buffer and descriptor.
pub struct DepthImg {
    /// The camera (its size may differ from the image's).
    pub cam: refl_camera,
    /// The convention value passed (may be unknown).
    pub conv: u32,
    /// The texels.
    pub buf: Buf<f32>,
    /// Descriptor width.
    pub width: u32,
    /// Descriptor height.
    pub height: u32,
    /// Descriptor stride.
    pub stride: u32,
}

impl DepthImg {
    /// The `refl_depth_image` over the buffer.
    pub fn desc(&self) -> refl_depth_image {
        refl_depth_image {
            depth: img_f32(&self.buf, self.width, self.height, self.stride),
            camera: self.cam,
            convention: self.conv,
        }
    }

    /// Whether refl must accept the image: a valid camera of the image's
    /// size, a known convention, a valid descriptor and buffer.
    pub fn valid(&self) -> bool {
        camera_ok(&self.cam)
            && self.conv <= 2
            && self.buf.usable()
            && self.cam.width == self.width
            && self.cam.height == self.height
            && required_len(self.width, self.height, self.stride).is_some_and(|n| self.buf.len() >= n)
    }

    /// Texel (x, y) (inside the descriptor and buffer).
    pub fn texel(&self, x: u32, y: u32) -> f32 {
        self.buf.get(y as usize * self.stride as usize + x as usize)
    }
}

/// A depth image of at most [`MAX_SIDE`] a side from the fuzz input: mostly
/// valid (a scene of a floor, a wall and a box), sometimes with a wrong
/// size, stride, convention, short or misaligned buffer.
pub fn depth_image(b: &mut Bytes) -> DepthImg {
    let mut w = b.side(MAX_SIDE);
    let mut h = b.side(MAX_SIDE);
    if b.chance(200) {
        // Mostly sane sizes.
        w = w.clamp(1, MAX_SIDE);
        h = h.clamp(1, MAX_SIDE);
    }
    let cam = camera(b, w, h);
    let conv = b.convention();
    let stride = b.stride(w);
    let (vw, vh) = (w.min(MAX_SIDE), h.min(MAX_SIDE));
    let values = depth_values(b, &cam, conv.min(2), vw, vh);
    let buf = image_buf(
        b,
        w,
        h,
        stride,
        |x, y| values.get((y * vw + x) as usize).copied().unwrap_or(f32::NAN),
        f32::from_bits(0x7fc0_beef),
    );
    DepthImg {
        cam,
        conv,
        buf,
        width: w,
        height: h,
        stride,
    }
}

/// A fuzzed thickness: a constant (mostly in [0, 2], sometimes infinite,
/// NaN or negative) or a back-face image (the front image pushed back).
pub struct Thick {
    /// The back-face texels, if any.
    pub back: Option<Buf<f32>>,
    /// The descriptor passed.
    pub desc: refl_trace_thickness,
}

impl Thick {
    /// Whether refl must accept it for an image of `w x h`.
    pub fn valid(&self, w: u32, h: u32) -> bool {
        match &self.back {
            None => self.desc.constant >= 0.0,
            Some(buf) => {
                let d = &self.desc.back_faces;
                buf.usable()
                    && d.width == w
                    && d.height == h
                    && required_len(d.width, d.height, d.stride).is_some_and(|n| d.len >= n)
            }
        }
    }
}

/// A thickness for `img`.
pub fn thickness(b: &mut Bytes, img: &DepthImg) -> Thick {
    let constant = match b.u8() {
        0..=15 => b.f32_special(),
        16..=31 => f32::INFINITY,
        _ => b.f32_fine(0.0, 2.0),
    };
    if b.chance(200) {
        return Thick {
            back: None,
            desc: refl_trace_thickness {
                constant,
                back_faces: refl_image_f32 {
                    data: core::ptr::null(),
                    len: 0,
                    width: 0,
                    height: 0,
                    stride: 0,
                },
            },
        };
    }
    let (w, h) = if b.chance(16) {
        (b.side(MAX_SIDE), b.side(MAX_SIDE))
    } else {
        (img.width, img.height)
    };
    let stride = b.stride(w);
    let push = b.f32_in(0.0, 1.0);
    let conv = img.conv.min(2);
    let cam = img.cam;
    let front: Vec<f32> = (0..img.buf.len()).map(|i| img.buf.get(i)).collect();
    let is = img.stride.max(1) as usize;
    let mut buf = image_buf(
        b,
        w,
        h,
        stride,
        |x, y| {
            let v = front.get(y as usize * is + x as usize).copied().unwrap_or(f32::NAN);
            let z = decode(&cam, v, conv).unwrap_or(f32::NAN) + push;
            let mut e = f32::NAN;
            // SAFETY: pointers valid.
            unsafe { refl_camera_encode_depth(&mut e, &cam, z, conv) };
            e
        },
        f32::NAN,
    );
    // A NULL back-face image means "use the constant": make the pointer
    // valid or misaligned here (NULL is the constant case above).
    if buf.is_null() {
        buf = Buf::from_fn(buf.len(), PtrKind::Valid, |_| 1.0);
    }
    let desc = refl_trace_thickness {
        constant,
        back_faces: refl_image_f32 {
            data: buf.cptr(),
            len: buf.len(),
            width: w,
            height: h,
            stride,
        },
    };
    Thick {
        back: Some(buf),
        desc,
    }
}

/// A ray for `img`: from a surface point seen in the image (mirror
/// reflected about a fuzzed normal), from the eye, or arbitrary.
pub fn ray_for(b: &mut Bytes, img: &DepthImg) -> refl_ray {
    let mode = b.u8() % 8;
    if mode == 0 {
        return refl_ray {
            origin: b.vec3_in(-10.0, 10.0),
            dir: b.dir3(),
        };
    }
    let cam = refl_camera {
        width: img.cam.width.max(1),
        height: img.cam.height.max(1),
        ..img.cam
    };
    let px = refl_vec2 {
        x: b.f32_fine(0.0, cam.width as f32),
        y: b.f32_fine(0.0, cam.height as f32),
    };
    let mut pr = refl_ray::default();
    // SAFETY: pointers valid.
    if unsafe { refl_camera_primary_ray(&mut pr, &cam, px) } != refl_status::Ok {
        return refl_ray {
            origin: b.vec3_in(-10.0, 10.0),
            dir: b.dir3(),
        };
    }
    if mode == 1 {
        return pr;
    }
    let t = b.f32_fine(0.2, 12.0);
    let origin = v3(
        pr.origin.x + t * pr.dir.x,
        pr.origin.y + t * pr.dir.y,
        pr.origin.z + t * pr.dir.z,
    );
    let n = if b.chance(160) { v3(0.0, 1.0, 0.0) } else { b.dir3() };
    let mut dir = refl_vec3::default();
    let v = v3(-pr.dir.x, -pr.dir.y, -pr.dir.z);
    // SAFETY: pointer valid.
    unsafe { refl_mirror_reflect(&mut dir, v, n) };
    let l = len3(dir);
    let dir = if l.is_finite() && l > 1e-3 {
        v3((f64::from(dir.x) / l) as f32, (f64::from(dir.y) / l) as f32, (f64::from(dir.z) / l) as f32)
    } else {
        b.dir3()
    };
    let dir = if b.chance(8) {
        v3(dir.x * 1.01, dir.y, dir.z)
    } else {
        dir
    };
    refl_ray { origin, dir }
}

/// A `t_max`: mostly +inf or in [0.1, 50], sometimes hostile.
pub fn t_max(b: &mut Bytes) -> f32 {
    match b.u8() {
        0..=15 => b.f32_special(),
        16..=111 => f32::INFINITY,
        _ => b.f32_fine(0.1, 50.0),
    }
}

/// Whether refl must accept the ray and `t_max` (finite ray with a unit
/// direction, `t_max > 0`); None where |dir| sits on the 1e-3 tolerance.
pub fn ray_valid(r: &refl_ray, t_max: f32) -> Option<bool> {
    if !(finite3(r.origin) && finite3(r.dir)) || !(t_max > 0.0) {
        return Some(false);
    }
    let e = (len3(r.dir) - 1.0).abs();
    if (0.5e-3..=2e-3).contains(&e) {
        return None;
    }
    Some(e < 1e-3)
}

/// The current `refl_last_error_message` (for failure messages).
pub fn last_error() -> String {
    let mut buf = vec![0u8; REFL_LAST_ERROR_CAPACITY];
    // SAFETY: `buf` is writable for its length.
    let n = unsafe { refl_last_error_message(buf.as_mut_ptr().cast(), buf.len()) };
    String::from_utf8_lossy(&buf[..n.min(buf.len() - 1)]).into_owned()
}
