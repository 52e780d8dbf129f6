//! Shared helpers of the tests of the passes that run on the mirror pass's
//! results (`tests/bounce.rs`, `tests/extrapolate.rs`,
//! `tests/upsample.rs`; included with `#[path]` next to
//! `common/gbuffer.rs`): byte images, the mirror pass's texels through C
//! and through refl-core, bit patterns to compare them, sentinel outputs
//! and the refusal check (status, last-error message, nothing written, no
//! allocation).
#![allow(dead_code)]

use crate::common::{color_mut, Frame, H, W};
use refl::*;
use refl_core::{ImageViewMut, MirrorOptions, MirrorPass, MirrorTexel};

pub const N: usize = (W * H) as usize;

/// The byte every output is filled with before a call that must fail.
pub const SENTINEL: u8 = 0xA5;

/// A value of sentinel bytes: plain-old-data `T` only (floats, integers
/// and `#[repr(C)]` structs of them, every bit pattern valid).
pub fn sentinel<T: Copy>() -> T {
    // SAFETY: `T` is plain old data (callers' contract), so the bytes are
    // a valid value; read unaligned from a byte buffer.
    unsafe { core::ptr::read_unaligned(vec![SENTINEL; core::mem::size_of::<T>()].as_ptr().cast()) }
}

/// A float of sentinel bytes.
pub fn sentinel_f32() -> f32 {
    f32::from_bits(u32::from_ne_bytes([SENTINEL; 4]))
}

/// A `u32` of sentinel bytes.
pub fn sentinel_u32() -> u32 {
    u32::from_ne_bytes([SENTINEL; 4])
}

pub fn img_u8(d: &[u8]) -> refl_image_u8 {
    refl_image_u8 {
        data: d.as_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

pub fn u8_mut(d: &mut [u8]) -> refl_image_u8_mut {
    refl_image_u8_mut {
        data: d.as_mut_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

pub fn no_u8_mut() -> refl_image_u8_mut {
    refl_image_u8_mut {
        data: core::ptr::null_mut(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

pub fn no_vec3() -> refl_image_vec3 {
    refl_image_vec3 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

/// A `w x h` image of mirror-pass texels.
pub fn ssr_texels(d: &[refl_ssr_texel], w: u32, h: u32) -> refl_image_ssr_texel {
    refl_image_ssr_texel {
        data: d.as_ptr(),
        len: d.len(),
        width: w,
        height: h,
        stride: w,
    }
}

/// The bits of a C texel, comparable with [`core_bits`].
pub fn bits(t: &refl_ssr_texel) -> [u32; 5] {
    [
        t.status,
        t.pixel.x.to_bits(),
        t.pixel.y.to_bits(),
        t.t.to_bits(),
        t.confidence.to_bits(),
    ]
}

/// The bits of a refl-core texel.
pub fn core_bits(t: &MirrorTexel) -> [u32; 5] {
    [
        t.status as u32,
        t.pixel.x.to_bits(),
        t.pixel.y.to_bits(),
        t.t.to_bits(),
        t.confidence.to_bits(),
    ]
}

pub fn color_bits(c: &[f32; 3]) -> [u32; 3] {
    c.map(f32::to_bits)
}

/// A texel of sentinel bytes.
pub fn sentinel_texel() -> refl_ssr_texel {
    sentinel()
}

/// The mirror pass (stepping, the defaults) through C over the whole
/// frame: its texels and colors.
pub fn c_mirror(g: &refl_gbuffer) -> (Vec<refl_ssr_texel>, Vec<[f32; 3]>) {
    let mut texels = vec![refl_ssr_texel::default(); N];
    let mut color = vec![[0.0f32; 3]; N];
    let mut st = refl_ssr_stats::default();
    let o = refl_ssr_options_default();
    // SAFETY: valid buffers of the stated lengths.
    let s = unsafe {
        refl_ssr_trace_rows(
            &mut st,
            texels.as_mut_ptr(),
            N,
            color_mut(&mut color),
            core::ptr::null_mut(),
            0,
            g,
            &o,
            core::ptr::null(),
            0,
            refl_row_range { begin: 0, end: H },
        )
    };
    assert_eq!(s, refl_status::Ok);
    (texels, color)
}

/// The same pass through refl-core.
pub fn core_mirror<'a>(f: &'a Frame) -> MirrorPass<'a> {
    MirrorPass::try_new(f.gbuffer(false), MirrorOptions::default(), None).unwrap()
}

/// The core pass's texels and colors over the whole frame.
pub fn core_mirror_run(p: &MirrorPass<'_>) -> (Vec<MirrorTexel>, Vec<[f32; 3]>) {
    let mut texels = vec![MirrorTexel::default(); N];
    let mut color = vec![[0.0f32; 3]; N];
    p.try_run(
        &mut ImageViewMut::try_new(&mut texels, W, H, W).unwrap(),
        Some(&mut ImageViewMut::try_new(&mut color, W, H, W).unwrap()),
        &mut [],
    )
    .unwrap();
    (texels, color)
}

/// The last-error message.
pub fn message() -> String {
    with_last_error_message(|m| m.to_owned())
}

/// Checks a call that had to fail with `want`: `call` returns its status,
/// a snapshot of every output's bytes taken after it, and the allocations
/// the call itself made; `before` is the snapshot of the untouched
/// outputs. Asserts the status, a last-error message that starts with
/// `name` and holds `says`, every output byte as it was, and no
/// allocation.
#[track_caller]
pub fn refused(
    name: &str,
    want: refl_status,
    says: &str,
    before: &[u8],
    call: impl FnOnce() -> (refl_status, Vec<u8>, u64),
) {
    let (s, after, allocs) = call();
    assert_eq!(s, want, "{name}: {says}: {}", message());
    let m = message();
    assert!(m.starts_with(&format!("{name}: ")), "{m}");
    assert!(m.contains(says), "{m:?} lacks {says:?}");
    assert_eq!(allocs, 0, "{name}: allocations on the error path ({says})");
    assert!(after == before, "{name}: an output changed ({says})");
}

/// The bytes of a slice of plain-old-data values.
pub fn bytes<T: Copy>(v: &[T]) -> Vec<u8> {
    // SAFETY: the tests use this on float, integer and `#[repr(C)]` struct
    // slices without padding (`refl_ssr_texel`, stats, `[f32; 3]`).
    unsafe { core::slice::from_raw_parts(v.as_ptr().cast::<u8>(), core::mem::size_of_val(v)) }
        .to_vec()
}
