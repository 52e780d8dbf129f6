//! Image helpers and depth conversion: `refl_row_band`,
//! `refl_image_required_len` and `refl_convert_depth` with every pair of
//! conventions (and unknown ones), strides, short buffers, NULL and
//! misaligned data, row bands, and the destination aliasing the source (in
//! place, or overlapping it partially).
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

fn row_band(b: &mut Bytes) {
    let height = match b.u8() % 8 {
        0 => 0,
        1 => u32::MAX,
        2 => b.u32(),
        _ => b.below(200),
    };
    let count = match b.u8() % 8 {
        0 => 0,
        1 => u32::MAX,
        2 => b.u32(),
        _ => b.below(70),
    };
    let index = match b.u8() % 4 {
        0 => count,
        1 => b.u32(),
        _ => b.below(count.max(1)),
    };
    let mut out = out1::<refl_row_range>(b.ptr_kind());
    // SAFETY: NULL, misaligned or writable.
    let s = unsafe { refl_row_band(out.ptr(), height, index, count) };
    null_rules(s, out.is_null(), out.is_null(), "refl_row_band");
    on_error_untouched(s, &[("out", out.is_sentinel(0))], "refl_row_band");
    if out.kind() != PtrKind::Valid {
        assert!(s != refl_status::Ok);
        return;
    }
    let bad = height == 0 || count == 0 || index >= count;
    assert_eq!(
        s,
        if bad { refl_status::InvalidArgument } else { refl_status::Ok },
        "refl_row_band({height}, {index}, {count})"
    );
    if bad {
        return;
    }
    let r = out.get(0);
    // The index-th of `count` near-equal bands; the first height % count
    // get one row more; bands past the last row are empty at `height`.
    let (h, n, i) = (u64::from(height), u64::from(count), u64::from(index));
    let (q, rem) = (h / n, h % n);
    let begin = i * q + i.min(rem);
    let len = q + u64::from(i < rem);
    let (begin, end) = if len == 0 { (h, h) } else { (begin, begin + len) };
    assert_eq!(
        (u64::from(r.begin), u64::from(r.end)),
        (begin, end),
        "refl_row_band({height}, {index}, {count})"
    );
}

fn required_len_check(b: &mut Bytes) {
    let w = match b.u8() % 4 {
        0 => b.u32(),
        _ => b.below(100),
    };
    let h = match b.u8() % 4 {
        0 => b.u32(),
        _ => b.below(100),
    };
    let stride = match b.u8() % 4 {
        0 => b.u32(),
        1 => w.wrapping_sub(1),
        _ => w.saturating_add(b.below(4)),
    };
    let mut out = out1::<usize>(b.ptr_kind());
    // SAFETY: NULL, misaligned or writable.
    let s = unsafe { refl_image_required_len(out.ptr(), w, h, stride) };
    null_rules(s, out.is_null(), out.is_null(), "refl_image_required_len");
    on_error_untouched(s, &[("out", out.is_sentinel(0))], "refl_image_required_len");
    if out.kind() != PtrKind::Valid {
        assert!(s != refl_status::Ok);
        return;
    }
    match required_len(w, h, stride) {
        None => assert_eq!(s, refl_status::InvalidArgument, "required_len({w}, {h}, {stride})"),
        Some(n) => {
            assert_eq!(s, refl_status::Ok, "required_len({w}, {h}, {stride})");
            assert_eq!(out.get(0), n, "required_len({w}, {h}, {stride})");
        }
    }
}

fn convert(b: &mut Bytes) {
    let w = b.side(MAX_SIDE);
    let h = b.side(MAX_SIDE);
    let cam = camera(b, w, h);
    let from = b.convention();
    let to = b.convention();
    let src_stride = b.stride(w);
    let (dw, dh) = if b.chance(16) {
        (b.side(MAX_SIDE), b.side(MAX_SIDE))
    } else {
        (w, h)
    };
    let dst_stride = if b.chance(64) { b.stride(dw) } else { src_stride };
    let values = depth_values(b, &cam, from.min(2), w.min(MAX_SIDE), h.min(MAX_SIDE));
    let vw = w.min(MAX_SIDE) as usize;
    let src_val = |x: u32, y: u32| values.get(y as usize * vw + x as usize).copied().unwrap_or(0.5);
    // 0: separate buffers; 1: in place (same data and stride); 2: dst
    // shifted inside the source buffer (partial overlap); 3: dst is src with
    // another stride.
    let alias = match b.u8() {
        0..=159 => 0,
        160..=223 => 1,
        224..=239 => 2,
        _ => 3,
    };
    let mut src = image_buf(b, w, h, src_stride, src_val, f32::from_bits(0x7fc0_dead));
    let mut dst_own = image_buf(b, dw, dh, dst_stride, |_, _| f32::from_bits(0xA5A5_A5A5), f32::from_bits(0xA5A5_A5A5));
    let src_copy = src.to_vec();
    let k = 1 + b.below(4) as usize;
    let alias = if alias == 2 && (src.is_null() || src.len() <= k) { 0 } else { alias };
    let (dst_ptr, dst_len, dst_stride) = match alias {
        0 => (dst_own.ptr(), dst_own.len(), dst_stride),
        1 => (src.ptr(), src.len(), src_stride),
        // SAFETY: k < len: inside the source allocation.
        2 => (unsafe { src.ptr().add(k) }, src.len() - k, src_stride),
        _ => (src.ptr(), src.len(), dst_stride),
    };
    let (dst_w, dst_h) = (dw, dh);
    let in_place = alias == 1 || (alias == 3 && dst_stride == src_stride);
    // Mode 2 overlaps only where the destination's first texel lies inside
    // the source's texels (`refl_image_required_len`); a destination past
    // them (a one-row image narrower than the shift) is a disjoint image
    // (campaign finding on 47b5e36, target-side).
    let disjoint_shift = alias == 2 && required_len(w, h, src_stride).is_some_and(|n| k >= n);
    let alias_ok = alias == 0 || in_place || disjoint_shift;
    // Where texel i of `dst` lives in the buffer the target reads back.
    let out_off = if alias == 2 { k } else { 0 };
    let dst = refl_image_f32_mut {
        data: dst_ptr,
        len: dst_len,
        width: dst_w,
        height: dst_h,
        stride: dst_stride,
    };
    let srcd = img_f32(&src, w, h, src_stride);
    let cb = Buf::from_slice(&[cam], b.ptr_kind());
    let rows = b.rows(h);
    let dst_snap = dst_own.snapshot();
    let src_snap = src.snapshot();
    // SAFETY: every pointer is NULL, misaligned (refused) or valid for its
    // stated length; dst may alias src as described above.
    let s = unsafe { refl_convert_depth(dst, srcd, cb.cptr(), from, to, rows.begin, rows.end) };
    let null = dst.data.is_null() || srcd.data.is_null() || cb.is_null();
    null_rules(s, null, null, "refl_convert_depth");
    if alias != 0 || s != refl_status::Ok {
        dst_own.assert_unchanged(&dst_snap, "refl_convert_depth: untouched destination");
    }
    if alias == 0 {
        src.assert_unchanged(&src_snap, "refl_convert_depth: source");
    }
    if s != refl_status::Ok {
        no_panic(s, "refl_convert_depth");
        // On error dst is untouched; with aliasing the source too.
        if alias != 0 {
            src.assert_unchanged(&src_snap, "refl_convert_depth: aliased destination on error");
        }
        // Nothing else can fail when every documented requirement holds.
        let valid_desc = |len: usize, ww: u32, hh: u32, st: u32| required_len(ww, hh, st).is_some_and(|n| len >= n);
        let all_ok = !null
            && cb.usable()
            && camera_ok(&cam)
            && from <= 2
            && to <= 2
            && alias_ok
            && src.usable()
            && (alias != 0 || dst_own.usable())
            && valid_desc(srcd.len, w, h, src_stride)
            && valid_desc(dst.len, dst_w, dst_h, dst_stride)
            && (dst_w, dst_h) == (w, h)
            && rows.begin < rows.end
            && rows.end <= h;
        assert!(!all_ok, "refl_convert_depth refused valid input: {s:?}");
        return;
    }
    // Success: every documented requirement held.
    assert!(camera_ok(&cam) && cb.usable(), "converted with an invalid camera");
    assert!(from <= 2 && to <= 2, "converted with an unknown convention");
    assert!((dst_w, dst_h) == (w, h), "converted images of different sizes");
    assert!(rows.begin < rows.end && rows.end <= h, "converted an empty or bad row range");
    let need_src = required_len(w, h, src_stride).expect("bad source descriptor accepted");
    let need_dst = required_len(dst_w, dst_h, dst_stride).expect("bad destination descriptor accepted");
    assert!(srcd.len >= need_src && dst.len >= need_dst, "short buffer accepted");
    // The same image (same data and stride) converts in place; any other
    // overlap is refused.
    assert!(alias_ok, "partially overlapping images accepted (alias mode {alias})");
    // Expected texels: encode_to(decode_from(src)), NaN stays NaN.
    let expect = |v: f32| -> f32 {
        let Some(z) = decode(&cam, v, from) else {
            return f32::NAN;
        };
        let mut e = 0.0f32;
        // SAFETY: pointers valid.
        let se = unsafe { refl_camera_encode_depth(&mut e, &cam, z, to) };
        if se == refl_status::Ok {
            e
        } else {
            f32::NAN
        }
    };
    let out_buf: &Buf<f32> = if alias == 0 { &dst_own } else { &src };
    let st = dst_stride as usize;
    for i in 0..dst.len {
        let (x, y) = ((i % st) as u32, (i / st) as u32);
        let got = out_buf.get(i + out_off);
        let inside = x < w && y < h && y >= rows.begin && y < rows.end;
        if inside {
            let want = expect(src_copy[y as usize * src_stride as usize + x as usize]);
            assert!(
                same_f32(got, want),
                "convert {from}->{to} texel ({x}, {y}): got {got}, want {want} (alias {alias})"
            );
        } else if alias == 0 {
            assert!(out_buf.is_sentinel(i), "convert wrote texel ({x}, {y}) outside the band or padding");
        } else {
            let was = src_copy[i + out_off];
            assert!(same_f32(got, was) && got.to_bits() == was.to_bits(), "in-place convert changed texel ({x}, {y}) outside the band");
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    for _ in 0..8 {
        if b.is_empty() {
            break;
        }
        match b.u8() % 8 {
            0 => row_band(&mut b),
            1 => required_len_check(&mut b),
            _ => convert(&mut b),
        }
    }
});
