//! Fewer rays (issue 18): `refl_upsample_half_size`,
//! `refl_upsample_trace_rows`, `refl_upsample_options_default`,
//! `refl_upsample_resolve_rows`.
//!
//! A fuzzed G-buffer (`fuzz/src/gbuffer.rs`), the mirror pass's options
//! (stepping, sometimes Hi-Z without its pyramid or an unknown method), a
//! fuzzed subsample (both patterns, any frame, unknown patterns), the
//! half-resolution trace into fuzzed outputs (sizes, short, NULL,
//! misaligned), then the reconstruction from its samples (sometimes
//! tampered: statuses that are not a `refl_ssr_status`, NaN hit fields;
//! or fuzzed samples of any size), optional sample colors, fuzzed options,
//! row bands, re-trace lists and outputs (aliasing the samples or each
//! other). Checked: the NULL and error rules (nothing written on error,
//! inputs never written, the last-error message), accepted input valid and
//! valid input accepted; on OK of the trace: each block of the band equals
//! `refl_ssr_trace_rows` at its traced pixel (texel, color), host rays
//! exactly the band's traced pixels that need the host, nothing else
//! written; on OK of the reconstruction: statuses in range and equal to the
//! stats, copied pixels are their block's traced pixel with its sample bit
//! for bit, listed pixels empty and black and in the list in row-major
//! order, re-traced pixels equal the full pass, skipped pixels skipped or
//! without a surface, hits counted, nothing written outside the band, two
//! bands equal one call.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const COPIED: u8 = 1;
const RETRACE: u8 = 3;
const RETRACED: u8 = 4;

fn options(b: &mut Bytes) -> refl_upsample_options {
    let mut o = refl_upsample_options_default();
    if b.chance(48) {
        o.depth_threshold = b.pick(&[0.001, 0.01, 0.1, 1.0, f32::INFINITY, 0.0, -1.0, f32::NAN]);
    }
    if b.chance(48) {
        o.depth_sigma = b.pick(&[0.01, 0.05, 1.0, f32::INFINITY, 0.0, f32::NAN]);
    }
    if b.chance(48) {
        o.normal_power = b.pick(&[0.0, 1.0, 2.5, 8.0, 1e9, -1.0, f32::NAN, f32::INFINITY]);
    }
    if b.chance(96) {
        o.plane_depth = b.bool();
        o.shade_hits = b.bool();
        o.retrace = b.bool();
        o.retrace_mixed = b.bool();
    }
    o
}

fn options_ok(o: &refl_upsample_options) -> bool {
    o.depth_threshold > 0.0 && o.depth_sigma > 0.0 && o.normal_power >= 0.0 && o.normal_power.is_finite()
}

/// The full-resolution pixel block `(bx, by)` traces (refl-core's
/// `Subsample::traced_pixel`, restated).
fn traced_pixel(sub: &refl_upsample_subsample, bx: u32, by: u32, w: u32, h: u32) -> (u32, u32) {
    let cycle = [(0, 0), (1, 1), (1, 0), (0, 1)];
    let (mut sx, sy) = cycle[(sub.frame % 4) as usize];
    if sub.pattern == 1 {
        sx ^= by & 1;
    }
    ((2 * bx + sx).min(w - 1), (2 * by + sy).min(h - 1))
}

#[allow(clippy::too_many_arguments)]
fn resolve(
    g: &refl_gbuffer,
    so: &refl_ssr_options,
    sub: &refl_upsample_subsample,
    half: refl_image_ssr_texel,
    half_color: refl_image_vec3,
    o: &refl_upsample_options,
    w: u32,
    h: u32,
    rows: refl_row_range,
) -> (refl_status, Vec<refl_ssr_texel>, Vec<u8>, Vec<refl_image_pixel>, refl_upsample_stats) {
    let n = w as usize * h as usize;
    let mut out = Buf::<refl_ssr_texel>::sentinel(n, PtrKind::Valid);
    let mut status = Buf::<u8>::sentinel(n, PtrKind::Valid);
    let mut list = Buf::<refl_image_pixel>::sentinel(n, PtrKind::Valid);
    let mut st = refl_upsample_stats::default();
    let none = refl_image_vec3_mut { data: core::ptr::null_mut(), len: 0, width: 0, height: 0, stride: 0 };
    let sm = refl_image_u8_mut { data: status.ptr(), len: n, width: w, height: h, stride: w };
    // SAFETY: valid outputs of the stated lengths; the inputs as fuzzed.
    let s = unsafe {
        refl_upsample_resolve_rows(&mut st, out.ptr(), n, none, sm, list.ptr(), n, g, so, core::ptr::null(), 0, sub, half, half_color, o, rows)
    };
    no_panic(s, "refl_upsample_resolve_rows");
    let mut l = list.to_vec();
    l.truncate(st.retrace_written as usize);
    (s, out.to_vec(), status.to_vec(), l, st)
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let d = refl_upsample_options_default();
    assert!(options_ok(&d) && d.shade_hits && !d.retrace && !d.plane_depth, "defaults {d:?}");

    let fg = FuzzGBuffer::new(&mut b, [96, 96, 96, 96]);
    let (w, h) = (fg.img.width, fg.img.height);
    let g = fg.desc();
    let n = w as usize * h as usize;
    let small = n > 0 && n <= 1 << 16;

    // The half size.
    let (mut hw, mut hh) = (SENTINEL as u32, SENTINEL as u32);
    // SAFETY: valid outputs.
    let s = unsafe { refl_upsample_half_size(&mut hw, &mut hh, w, h) };
    check_last_error(s, "refl_upsample_half_size");
    if w == 0 || h == 0 {
        assert_eq!((s, hw, hh), (refl_status::InvalidArgument, SENTINEL as u32, SENTINEL as u32));
        return;
    }
    assert_eq!((s, hw, hh), (refl_status::Ok, w.div_ceil(2), h.div_ceil(2)));
    let hn = hw as usize * hh as usize;

    let mut so = refl_ssr_options_default();
    if b.chance(24) {
        so.method = b.pick(&[1, 2, u32::MAX]);
    }
    let sub = refl_upsample_subsample {
        pattern: if b.chance(16) { b.pick(&[2, 7, u32::MAX]) } else { u32::from(b.bool()) },
        frame: if b.chance(32) { b.u32() } else { u32::from(b.u8() % 4) },
    };
    let sub_ok = sub.pattern <= 1;
    let so_ok = so.method == 0;

    // The full pass (stepping): whether refl takes the G-buffer, and the
    // texels and colors each traced block must equal.
    let full = if small {
        let (s, t, c) = mirror_run(&g, &refl_ssr_options_default(), w, h, fg.has_color());
        (s == refl_status::Ok).then_some((t, c))
    } else {
        None
    };
    let gb_ok = full.is_some();
    if gb_ok {
        fg.assert_accepted("refl_ssr_trace_rows (full pass)");
    }

    // The half-resolution trace.
    let trows = b.rows(hh);
    // Buffers of at most 2^16 texels (a huge G-buffer needs more: short).
    let hn_cap = hn.min(1 << 16);
    let out_len = if b.chance(16) { b.len_for(hn_cap) } else { hn_cap };
    let mut half = Buf::<refl_ssr_texel>::sentinel(out_len, if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid });
    let mut hcolor = if fg.has_color() && b.chance(160) { Img::<refl_vec3>::output(&mut b, hw, hh) } else { Img::absent(&mut b) };
    let with_hcolor = !hcolor.buf.is_null();
    let host_len = if b.chance(32) { 0 } else { b.len_for(hn.min(1 << 12)) };
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, PtrKind::Valid);
    let mut tst = out1::<refl_ssr_stats>(b.ptr_kind());
    let subp = Buf::from_slice(&[sub], b.ptr_kind());
    let snap = fg.img.buf.snapshot();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe {
        refl_upsample_trace_rows(tst.ptr(), half.ptr(), out_len, vec3_mut(&mut hcolor), host.ptr(), host_len, &g, &so, core::ptr::null(), 0, subp.cptr(), trows)
    };
    let what = "refl_upsample_trace_rows";
    let req_null = tst.is_null() || half.is_null() || subp.is_null() || fg.img.buf.is_null() || fg.normals.0.is_null() || so.method == 1;
    let mis = [half.kind(), subp.kind(), tst.kind(), hcolor.buf.kind(), fg.img.buf.kind(), fg.normals.0.kind(), fg.mask.0.kind(), fg.roughness.0.kind(), fg.color.0.kind(), fg.back.0.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(s, req_null, req_null || !with_hcolor, mis, what);
    on_error_untouched(
        s,
        &[
            ("out_stats", tst.is_sentinel(0)),
            ("out", (0..half.len()).all(|i| half.is_sentinel(i))),
            ("color", (0..hcolor.buf.len()).all(|i| hcolor.buf.is_sentinel(i))),
            ("host", (0..host_len).all(|i| host.is_sentinel(i))),
        ],
        what,
    );
    fg.assert_unchanged(what);
    fg.img.buf.assert_unchanged(&snap, what);
    let trows_ok = trows.begin < trows.end && trows.end <= hh;
    let hcolor_ok = !with_hcolor || hcolor.valid(hw, hh);
    let targs_ok = so_ok && sub_ok && trows_ok && out_len >= hn && half.kind() == PtrKind::Valid && hcolor_ok && tst.kind() == PtrKind::Valid && subp.kind() == PtrKind::Valid;
    if s == refl_status::Ok {
        assert!(so_ok && sub_ok, "{what} accepted method {} pattern {}", so.method, sub.pattern);
        fg.assert_accepted(what);
        assert!(trows_ok && out_len >= hn && hcolor_ok, "{what} accepted rows {trows:?} of {hh}, out_len {out_len} of {hn}, or a color not of {hw}x{hh}");
    } else if gb_ok && targs_ok {
        panic!("{what} refused valid input: {s:?} {}", last_error());
    }
    let traced_ok = s == refl_status::Ok && trows.begin == 0 && trows.end == hh;
    if s == refl_status::Ok {
        let st = tst.get(0);
        let mut want_host = Vec::new();
        for i in 0..out_len {
            let (bx, by) = ((i % hw as usize) as u32, (i / hw as usize) as u32);
            if by < trows.begin || by >= trows.end || i >= hn {
                assert!(half.is_sentinel(i), "{what}: block {i} outside rows {trows:?} written");
                continue;
            }
            let (x, y) = traced_pixel(&sub, bx, by, w, h);
            let t = half.get(i);
            if let Some((ft, fc)) = &full {
                let j = (y * w + x) as usize;
                assert_eq!(ssr_bits(&t), ssr_bits(&ft[j]), "{what}: block ({bx}, {by}) is not the full pass at ({x}, {y})");
                if with_hcolor {
                    assert_eq!(bits3(hcolor.at(bx, by)), bits3(fc[j]), "{what}: block ({bx}, {by}) color");
                }
            }
            if t.status >= 4 {
                want_host.push((x, y));
            }
        }
        assert_eq!(st.host_rays as usize, want_host.len(), "{what}: stats {st:?}");
        assert_eq!(st.host_rays_written as usize, want_host.len().min(host_len), "{what}: stats {st:?}");
        for (k, (x, y)) in want_host.iter().take(host_len).enumerate() {
            let r = host.get(k);
            assert_eq!((r.x, r.y), (*x, *y), "{what}: host ray {k}");
        }
        for k in st.host_rays_written as usize..host_len {
            assert!(host.is_sentinel(k), "{what}: host ray {k} past the written ones");
        }
        if with_hcolor {
            assert!(hcolor.untouched_outside(hw, trows), "{what}: colors outside rows {trows:?} written");
        }
    }

    // The samples for the reconstruction: the trace's (sometimes
    // tampered), or fuzzed.
    let tamper = b.u8();
    let tseed = b.u32();
    let samples = if traced_ok && b.chance(200) {
        let mut v = half.to_vec();
        v.truncate(hn);
        if tamper > 230 {
            let k = hash(tseed, 1, 2) as usize % hn;
            v[k].status = [10, 0xFF, u32::MAX][tseed as usize % 3];
        } else if tamper > 200 {
            for (i, t) in v.iter_mut().enumerate() {
                if hash(i as u32, 3, tseed) % 7 == 0 {
                    t.pixel.x = f32::NAN;
                    t.t = f32::INFINITY;
                }
            }
        }
        Img { buf: Buf::from_slice(&v, PtrKind::Valid), w: hw, h: hh, stride: hw }
    } else {
        Img::<refl_ssr_texel>::new(
            &mut b,
            hw,
            hh,
            |x, y| {
                let k = hash(x, y, tseed);
                refl_ssr_texel { status: k % 10, pixel: refl_vec2 { x: (k >> 4 & 63) as f32 + 0.5, y: (k >> 10 & 63) as f32 + 0.5 }, t: 1.0 + (k >> 20 & 7) as f32, confidence: 1.0 }
            },
            refl_ssr_texel { status: 0xbeef, ..Default::default() },
        )
    };
    let samples_color = if b.chance(96) {
        let cseed = b.u32();
        Img::<refl_vec3>::new(&mut b, hw, hh, |x, y| { let k = hash(x, y, cseed); v3((k & 255) as f32 / 255.0, 0.5, if k % 17 == 0 { hostile(k) } else { 0.25 }) }, v3(-9.0, -9.0, -9.0))
    } else {
        Img::absent(&mut b)
    };
    let with_scolor = !samples_color.buf.is_null();
    let scolor_desc = if with_scolor { vec3_img(&samples_color) } else { refl_image_vec3 { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 } };
    let o = options(&mut b);

    let rows = b.rows(h);
    let out_len = if b.chance(16) { b.len_for(n.min(1 << 16)) } else { n.min(1 << 16) };
    let mut out = Buf::<refl_ssr_texel>::sentinel(out_len, if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid });
    let mut color = if b.chance(128) { Img::<refl_vec3>::output(&mut b, w, h) } else { Img::absent(&mut b) };
    let with_color = !color.buf.is_null();
    let mut status = if b.chance(128) { Img::<u8>::output(&mut b, w, h) } else { Img::absent(&mut b) };
    let with_status = !status.buf.is_null();
    let list_len = if b.chance(32) { 0 } else { b.len_for(n.min(1 << 12)) };
    let mut list = Buf::<refl_image_pixel>::sentinel(list_len, PtrKind::Valid);
    let mut ust = out1::<refl_upsample_stats>(b.ptr_kind());
    let op = Buf::from_slice(&[o], b.ptr_kind());
    let mut sm = u8_mut(&mut status);
    let alias = b.u8() % 16;
    let aliased = match alias {
        0 if samples.buf.usable() && !samples.buf.is_empty() => {
            sm.data = samples.buf.cptr().cast_mut().cast();
            sm.len = sm.len.max(1).min(samples.buf.len() * 20);
            true
        }
        1 if out.usable() && !out.is_empty() => {
            sm.data = out.ptr().cast();
            sm.len = sm.len.max(1).min(out.len() * 20);
            true
        }
        _ => false,
    };
    let ssnap = samples.buf.snapshot();
    let csnap = samples_color.buf.snapshot();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe {
        refl_upsample_resolve_rows(ust.ptr(), out.ptr(), out_len, vec3_mut(&mut color), sm, list.ptr(), list_len, &g, &so, core::ptr::null(), 0, subp.cptr(), ssr_texel_img(&samples), scolor_desc, op.cptr(), rows)
    };
    let what = "refl_upsample_resolve_rows";
    let req_null = ust.is_null() || out.is_null() || subp.is_null() || samples.buf.is_null() || op.is_null() || fg.img.buf.is_null() || fg.normals.0.is_null() || so.method == 1;
    let mis = [out.kind(), subp.kind(), ust.kind(), op.kind(), samples.buf.kind(), samples_color.buf.kind(), color.buf.kind(), status.buf.kind(), fg.img.buf.kind(), fg.normals.0.kind(), fg.mask.0.kind(), fg.roughness.0.kind(), fg.color.0.kind(), fg.back.0.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(s, req_null, true, mis, what);
    on_error_untouched(
        s,
        &[
            ("out_stats", ust.is_sentinel(0)),
            ("out", (0..out.len()).all(|i| out.is_sentinel(i))),
            ("color", (0..color.buf.len()).all(|i| color.buf.is_sentinel(i))),
            ("status", (0..status.buf.len()).all(|i| status.buf.is_sentinel(i))),
            ("retrace", (0..list_len).all(|i| list.is_sentinel(i))),
        ],
        what,
    );
    fg.assert_unchanged(what);
    samples.buf.assert_unchanged(&ssnap, "half");
    samples_color.buf.assert_unchanged(&csnap, "half_color");

    let statuses_ok = required_len(samples.w, samples.h, samples.stride).is_some_and(|k| (0..k.min(samples.buf.len())).all(|i| samples.buf.get(i).status <= 9));
    let rows_ok = rows.begin < rows.end && rows.end <= h;
    let color_ok = !with_color || (color.valid(w, h) && with_scolor && fg.has_color());
    let status_ok = !with_status || status.valid(w, h);
    let args_ok = so_ok && sub_ok && options_ok(&o) && rows_ok && samples.valid(hw, hh) && statuses_ok && (!with_scolor || samples_color.valid(hw, hh)) && out_len >= n && out.kind() == PtrKind::Valid && color_ok && status_ok && [ust.kind(), op.kind(), subp.kind()].iter().all(|k| *k == PtrKind::Valid);
    if s == refl_status::Ok {
        assert!(!aliased, "{what} accepted an output aliasing an input or another output (mode {alias})");
        assert!(so_ok && sub_ok && options_ok(&o), "{what} accepted options {o:?}, method {}, pattern {}", so.method, sub.pattern);
        fg.assert_accepted(what);
        assert!(rows_ok && out_len >= n, "{what} accepted rows {rows:?} of {h} or out_len {out_len} of {n}");
        assert!(samples.valid(hw, hh) && statuses_ok, "{what} accepted samples not of {hw}x{hh} or with a status that is not a refl_ssr_status");
        assert!(!with_scolor || samples_color.valid(hw, hh), "{what} accepted sample colors not of {hw}x{hh}");
        assert!(color_ok && status_ok, "{what} accepted an output not of {w}x{h} (or a color without sample colors)");
    } else if gb_ok && args_ok && !aliased {
        panic!("{what} refused valid input: {s:?} {}", last_error());
    }
    if s != refl_status::Ok {
        return;
    }

    let st = ust.get(0);
    let mut counts = [0u32; 5];
    let mut listed = Vec::new();
    let mut hits = 0u32;
    for i in 0..out_len {
        let (x, y) = ((i % w as usize) as u32, (i / w as usize) as u32);
        if y < rows.begin || y >= rows.end || i >= n {
            assert!(out.is_sentinel(i), "{what}: texel {i} outside rows {rows:?} written");
            continue;
        }
        let t = out.get(i);
        assert!(t.status <= 9, "{what}: ({x}, {y}) texel status {}", t.status);
        if t.status == 2 {
            hits += 1;
        }
        if !with_status {
            continue;
        }
        let sv = status.at(x, y);
        assert!(sv <= 4, "{what}: status {sv} at ({x}, {y})");
        counts[sv as usize] += 1;
        match sv {
            0 => assert!(t.status <= 1, "{what}: skipped ({x}, {y}) with texel status {}", t.status),
            COPIED => {
                let (bx, by) = (x / 2, y / 2);
                assert_eq!(traced_pixel(&sub, bx, by, w, h), (x, y), "{what}: ({x}, {y}) copied but not its block's traced pixel");
                assert_eq!(ssr_bits(&t), ssr_bits(&samples.at(bx, by)), "{what}: copied ({x}, {y}) is not its sample");
            }
            RETRACE => {
                assert_eq!(ssr_bits(&t), [0; 5], "{what}: listed ({x}, {y}) has a texel");
                if with_color {
                    assert_eq!(bits3(color.at(x, y)), [0; 3], "{what}: listed ({x}, {y}) has a color");
                }
                listed.push((x, y));
            }
            RETRACED => {
                assert!(o.retrace, "{what}: re-traced ({x}, {y}) without `retrace`");
                if let Some((ft, _)) = &full {
                    assert_eq!(ssr_bits(&t), ssr_bits(&ft[i]), "{what}: re-traced ({x}, {y}) is not the full pass");
                }
            }
            _ => {}
        }
    }
    assert_eq!(st.hits, hits, "{what}: stats {st:?}");
    if with_status {
        assert_eq!([st.copied, st.interpolated, st.retrace], [counts[1], counts[2], counts[3] + counts[4]], "{what}: stats {st:?}");
        assert_eq!(st.retraced, counts[4], "{what}: stats {st:?}");
        assert_eq!(st.retrace_written as usize, listed.len().min(list_len), "{what}: stats {st:?}");
        for (k, (x, y)) in listed.iter().take(list_len).enumerate() {
            let p = list.get(k);
            assert_eq!((p.x, p.y), (*x, *y), "{what}: re-trace entry {k}");
        }
        assert!(status.untouched_outside(w, rows), "{what}: statuses outside rows {rows:?} written");
    }
    for k in st.retrace_written as usize..list_len {
        assert!(list.is_sentinel(k), "{what}: re-trace entry {k} past the written ones");
    }
    if with_color {
        assert!(color.untouched_outside(w, rows), "{what}: colors outside rows {rows:?} written");
    }

    // Two bands equal one call.
    if b.chance(96) && h >= 2 && n <= (MAX_SIDE * MAX_SIDE) as usize {
        let k = 1 + b.below(h - 1);
        let (si, sc) = (ssr_texel_img(&samples), scolor_desc);
        let (s1, t1, v1, l1, st1) = resolve(&g, &so, &sub, si, sc, &o, w, h, refl_row_range { begin: 0, end: h });
        let (s2, t2, v2, l2, st2) = resolve(&g, &so, &sub, si, sc, &o, w, h, refl_row_range { begin: 0, end: k });
        let (s3, t3, v3_, l3, st3) = resolve(&g, &so, &sub, si, sc, &o, w, h, refl_row_range { begin: k, end: h });
        assert!(s1 == refl_status::Ok && s2 == refl_status::Ok && s3 == refl_status::Ok, "bands refused: {s1:?} {s2:?} {s3:?}: {}", last_error());
        let split = (k * w) as usize;
        for i in 0..n {
            let (pt, pv) = if i < split { (&t2[i], v2[i]) } else { (&t3[i], v3_[i]) };
            assert_eq!(ssr_bits(&t1[i]), ssr_bits(pt), "texel {i} differs between one call and two bands (k {k})");
            assert_eq!(v1[i], pv, "status {i} differs between one call and two bands");
        }
        assert_eq!(l1, [l2, l3].concat(), "re-trace lists of two bands");
        assert_eq!([st1.copied, st1.interpolated, st1.retrace, st1.hits], [st2.copied + st3.copied, st2.interpolated + st3.interpolated, st2.retrace + st3.retrace, st2.hits + st3.hits], "stats of two bands");
    }
});
