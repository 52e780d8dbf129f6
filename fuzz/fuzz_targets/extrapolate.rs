//! The extrapolation of surfaces (issue 18): `refl_extrapolate_options_default`,
//! `refl_extrapolate_fill_rows`.
//!
//! A fuzzed G-buffer (`fuzz/src/gbuffer.rs`), the mirror pass's texels over
//! it (`refl_ssr_trace_rows`'s, or fuzzed texels of any status, hostile
//! hit fields and statuses that are not a `refl_ssr_status`) and colors
//! (sometimes NaN, Inf, huge), fuzzed options, row bands, host lists (NULL,
//! short, misaligned) and outputs (other sizes, strides, short, NULL,
//! misaligned; aliasing the input colors, the texels or each other).
//! Checked: the NULL and error rules (nothing written on error, inputs
//! never written, the last-error message), accepted input valid and valid
//! input accepted; on OK only the band's colors and statuses are written,
//! statuses in range and equal to the stats, kept and host pixels keep the
//! input color bit for bit, holes only where the texel's status is a hole
//! (`LEFT_IMAGE`, or any host status with `all_host_rays`) and never
//! without a surface, filled colors finite, the host list exactly the
//! band's unfilled and too smooth pixels in row-major order as far as it
//! holds them (the rest untouched), two bands equal one call.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const KEPT: u8 = 0;
const FILLED: u8 = 1;
const LEFT_IMAGE: u32 = 4;

fn options(b: &mut Bytes) -> refl_extrapolate_options {
    let mut o = refl_extrapolate_options_default();
    if b.chance(64) {
        o.radius = b.pick(&[0, 1, 2, 3, 8, REFL_EXTRAPOLATE_MAX_RADIUS, REFL_EXTRAPOLATE_MAX_RADIUS + 1, u32::MAX]);
    }
    if b.chance(48) {
        o.spatial_sigma = b.pick(&[0.5, 1.0, 4.0, f32::INFINITY, 0.0, -1.0, f32::NAN, 1e-30]);
    }
    if b.chance(48) {
        o.depth_threshold = b.pick(&[0.01, 0.1, 1.0, f32::INFINITY, 0.0, f32::NAN, -0.5]);
    }
    if b.chance(48) {
        o.depth_sigma = b.pick(&[0.01, 0.05, 1.0, f32::INFINITY, 0.0, f32::NAN]);
    }
    if b.chance(48) {
        o.normal_power = b.pick(&[0.0, 1.0, 2.5, 8.0, 64.0, 1e9, -1.0, f32::NAN, f32::INFINITY]);
    }
    if b.chance(48) {
        o.min_roughness = b.pick(&[0.0, 0.2, 0.4, 1.0, -0.1, f32::NAN, f32::INFINITY]);
    }
    if b.chance(96) {
        o.all_host_rays = b.bool();
    }
    o
}

fn options_ok(o: &refl_extrapolate_options) -> bool {
    (1..=REFL_EXTRAPOLATE_MAX_RADIUS).contains(&o.radius)
        && o.spatial_sigma > 0.0
        && o.depth_threshold > 0.0
        && o.depth_sigma > 0.0
        && o.normal_power >= 0.0
        && o.normal_power.is_finite()
        && o.min_roughness >= 0.0
        && o.min_roughness.is_finite()
}

/// Whether a texel status makes a hole under `o`.
fn hole_status(status: u32, o: &refl_extrapolate_options) -> bool {
    if o.all_host_rays { status >= LEFT_IMAGE } else { status == LEFT_IMAGE }
}

/// One call into fresh, valid outputs of `w x h` over `rows` with a host
/// list of `n` entries.
fn run(g: &refl_gbuffer, t: refl_image_ssr_texel, c: refl_image_vec3, o: &refl_extrapolate_options, w: u32, h: u32, rows: refl_row_range) -> (refl_status, Vec<refl_vec3>, Vec<u8>, Vec<refl_image_pixel>, refl_extrapolate_stats) {
    let n = w as usize * h as usize;
    let mut out = Buf::<refl_vec3>::sentinel(n, PtrKind::Valid);
    let mut status = Buf::<u8>::sentinel(n, PtrKind::Valid);
    let mut host = Buf::<refl_image_pixel>::sentinel(n, PtrKind::Valid);
    let mut st = refl_extrapolate_stats::default();
    let om = refl_image_vec3_mut { data: out.ptr(), len: n, width: w, height: h, stride: w };
    let sm = refl_image_u8_mut { data: status.ptr(), len: n, width: w, height: h, stride: w };
    // SAFETY: valid outputs of the stated lengths; the inputs as fuzzed.
    let s = unsafe { refl_extrapolate_fill_rows(&mut st, om, sm, host.ptr(), n, g, t, c, o, rows) };
    no_panic(s, "refl_extrapolate_fill_rows");
    let mut list = host.to_vec();
    list.truncate(st.host_written as usize);
    (s, out.to_vec(), status.to_vec(), list, st)
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let d = refl_extrapolate_options_default();
    assert!(options_ok(&d) && d.radius == 4 && d.spatial_sigma == 2.0 && !d.all_host_rays, "defaults {d:?}");

    let fg = FuzzGBuffer::new(&mut b, [96, 96, 96, 96]);
    let (w, h) = (fg.img.width, fg.img.height);
    let g = fg.desc();
    let n = w as usize * h as usize;
    let small = n > 0 && n <= 1 << 16;

    // The mirror pass's texels and colors: the pass's own, or fuzzed.
    let traced = if small && b.chance(160) {
        let (s, t, c) = mirror_run(&g, &refl_ssr_options_default(), w, h, fg.has_color());
        (s == refl_status::Ok).then_some((t, c))
    } else {
        None
    };
    let tseed = b.u32();
    let tmode = b.u8();
    let texels = Img::<refl_ssr_texel>::new(
        &mut b,
        w.min(MAX_SIDE * 2),
        h.min(MAX_SIDE * 2),
        |x, y| {
            let k = hash(x, y, tseed);
            if let Some((t, _)) = &traced {
                if let Some(v) = t.get((y * w + x) as usize) {
                    return *v;
                }
            }
            let status = if tmode > 240 && k % 97 == 0 { [10, 255, 0x1_0000, u32::MAX][(k >> 8) as usize % 4] } else { k % 10 };
            refl_ssr_texel {
                status,
                pixel: refl_vec2 { x: (k >> 4 & 63) as f32, y: (k >> 10 & 63) as f32 },
                t: if k % 31 == 0 { f32::NAN } else { 1.0 },
                confidence: 1.0,
            }
        },
        refl_ssr_texel { status: 0xdead, ..Default::default() },
    );
    let cseed = b.u32();
    let chostile = b.u8();
    let color = Img::<refl_vec3>::new(
        &mut b,
        w.min(MAX_SIDE * 2),
        h.min(MAX_SIDE * 2),
        |x, y| {
            let k = hash(x, y, cseed);
            if let Some((_, c)) = &traced {
                if let Some(v) = c.get((y * w + x) as usize) {
                    return *v;
                }
            }
            if chostile > 200 && k % 11 == 0 { v3(hostile(k >> 8), 0.5, 0.5) } else { v3((k & 255) as f32 / 255.0, 0.25, 0.5) }
        },
        v3(-9.0, -9.0, -9.0),
    );
    let o = options(&mut b);

    // Whether refl takes the G-buffer: a call with valid texels (every
    // pixel skipped), a valid color and valid outputs.
    let gb_ok = small && {
        let t0 = vec![refl_ssr_texel::default(); n];
        let c0 = vec![v3(0.0, 0.0, 0.0); n];
        let ti = refl_image_ssr_texel { data: t0.as_ptr(), len: n, width: w, height: h, stride: w };
        let ci = refl_image_vec3 { data: c0.as_ptr(), len: n, width: w, height: h, stride: w };
        let (s, ..) = run(&g, ti, ci, &d, w, h, refl_row_range { begin: 0, end: h });
        check_last_error(s, "refl_extrapolate_fill_rows");
        s == refl_status::Ok
    };
    if gb_ok {
        fg.assert_accepted("refl_extrapolate_fill_rows (skipped texels)");
    }

    // The outputs and the call.
    let rows = b.rows(h);
    let mut out = Img::<refl_vec3>::output(&mut b, w, h);
    let mut status = if b.chance(64) { Img::absent(&mut b) } else { Img::<u8>::output(&mut b, w, h) };
    let with_status = !status.buf.is_null();
    let host_len = if b.chance(32) { 0 } else { b.len_for(n.min(1 << 12)) };
    let mut host = Buf::<refl_image_pixel>::sentinel(host_len, if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid });
    let mut st = out1::<refl_extrapolate_stats>(b.ptr_kind());
    let gbp = Buf::from_slice(&[g], b.ptr_kind());
    let op = Buf::from_slice(&[o], b.ptr_kind());
    let mut om = vec3_mut(&mut out);
    let mut sm = u8_mut(&mut status);
    let mut stp = st.ptr();
    let mut hp = host.ptr();
    let alias = b.u8() % 32;
    let aliased = match alias {
        0 if color.buf.usable() && !color.buf.is_empty() => {
            om.data = color.buf.cptr().cast_mut();
            om.len = om.len.min(color.buf.len());
            true
        }
        1 if texels.buf.usable() && !texels.buf.is_empty() => {
            sm.data = texels.buf.cptr().cast_mut().cast();
            sm.len = sm.len.max(1).min(texels.buf.len() * 20);
            true
        }
        2 if out.buf.usable() && out.buf.len() * 12 >= 20 => {
            stp = om.data.cast();
            true
        }
        3 if out.buf.usable() && out.buf.len() * 12 >= 8 && host_len > 0 => {
            hp = om.data.cast();
            true
        }
        _ => false,
    };
    let tsnap = texels.buf.snapshot();
    let csnap = color.buf.snapshot();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_extrapolate_fill_rows(stp, om, sm, hp, host_len.min(if alias == 3 && aliased { out.buf.len() * 12 / 8 } else { usize::MAX }), gbp.cptr(), ssr_texel_img(&texels), vec3_img(&color), op.cptr(), rows) };
    let what = "refl_extrapolate_fill_rows";
    let req_null = stp.is_null() || om.data.is_null() || (hp.is_null() && host_len > 0) || gbp.is_null() || texels.buf.is_null() || color.buf.is_null() || op.is_null() || fg.img.buf.is_null() || fg.normals.0.is_null();
    let any_null = req_null || sm.data.is_null() && !with_status;
    let mis = [gbp.kind(), op.kind(), texels.buf.kind(), color.buf.kind(), fg.img.buf.kind(), fg.normals.0.kind(), fg.mask.0.kind(), fg.roughness.0.kind(), fg.color.0.kind(), fg.back.0.kind(), host.kind()].contains(&PtrKind::Misaligned)
        || (stp as usize) % 4 != 0
        || (om.data as usize) % 4 != 0
        || (hp as usize) % 4 != 0;
    null_rules_m(s, req_null, any_null || req_null, mis, what);
    on_error_untouched(
        s,
        &[
            ("out_stats", st.is_sentinel(0)),
            ("out", (0..out.buf.len()).all(|i| out.buf.is_sentinel(i))),
            ("status", (0..status.buf.len()).all(|i| status.buf.is_sentinel(i))),
            ("host", (0..host.len()).all(|i| host.is_sentinel(i))),
        ],
        what,
    );
    fg.assert_unchanged(what);
    texels.buf.assert_unchanged(&tsnap, "texels");
    color.buf.assert_unchanged(&csnap, "color");

    let statuses_ok = required_len(texels.w, texels.h, texels.stride).is_some_and(|k| (0..k.min(texels.buf.len())).all(|i| texels.buf.get(i).status <= 9));
    let rows_ok = rows.begin < rows.end && rows.end <= h;
    let status_ok = !with_status || (status.w == w && status.h == h && required_len(w, h, status.stride).is_some_and(|k| status.buf.len() >= k));
    let args_ok = options_ok(&o)
        && rows_ok
        && texels.valid(w, h)
        && statuses_ok
        && color.valid(w, h)
        && out.valid(w, h)
        && status_ok
        && (host_len == 0 || host.kind() == PtrKind::Valid)
        && [st.kind(), gbp.kind(), op.kind()].iter().all(|k| *k == PtrKind::Valid);
    if s == refl_status::Ok {
        assert!(!aliased, "{what} accepted an output aliasing an input or another output (mode {alias})");
        assert!(options_ok(&o), "{what} accepted options {o:?}");
        fg.assert_accepted(what);
        assert!(rows_ok, "{what} accepted rows {rows:?} of {h}");
        assert!(texels.valid(w, h) && color.valid(w, h), "{what} accepted an input not of {w}x{h}");
        assert!(statuses_ok, "{what} accepted a texel status that is not a refl_ssr_status");
        assert!(out.valid(w, h) && status_ok, "{what} accepted an output not of {w}x{h}");
    } else if gb_ok && args_ok && !aliased {
        panic!("{what} refused valid input: {s:?} {}", last_error());
    }
    if s != refl_status::Ok {
        return;
    }

    assert!(out.untouched_outside(w, rows), "{what} wrote outside rows {rows:?}");
    if with_status {
        assert!(status.untouched_outside(w, rows), "{what} wrote statuses outside rows {rows:?}");
    }
    let stats = st.get(0);
    let mut counts = [0u32; 4];
    let mut listed = Vec::new();
    for y in rows.begin..rows.end {
        for x in 0..w {
            let c = out.at(x, y);
            let input = color.at(x, y);
            let t = texels.at(x, y);
            if !with_status {
                if !hole_status(t.status, &o) {
                    assert_eq!(bits3(c), bits3(input), "({x}, {y}): not a hole but not the input color");
                }
                continue;
            }
            let sv = status.at(x, y);
            assert!(sv <= 3, "status {sv} at ({x}, {y})");
            counts[sv as usize] += 1;
            if sv != KEPT {
                assert!(hole_status(t.status, &o), "({x}, {y}) status {sv} for texel status {}", t.status);
            }
            if sv == FILLED {
                assert!(finite3(c), "({x}, {y}): filled color {c:?} not finite");
            } else {
                assert_eq!(bits3(c), bits3(input), "({x}, {y}) status {sv}: not the input color");
            }
            if sv >= 2 {
                listed.push((x, y));
            }
        }
    }
    if with_status {
        assert_eq!([stats.filled, stats.unfilled, stats.too_smooth], [counts[1], counts[2], counts[3]], "stats {stats:?}");
        assert_eq!(stats.holes, counts[1] + counts[2] + counts[3], "stats {stats:?}");
        assert_eq!(stats.host_written as usize, listed.len().min(host_len), "stats {stats:?}");
        for (i, (x, y)) in listed.iter().take(host_len).enumerate() {
            let p = host.get(i);
            assert_eq!((p.x, p.y), (*x, *y), "host entry {i}");
        }
    }
    assert_eq!(stats.holes, stats.filled + stats.unfilled + stats.too_smooth, "stats {stats:?}");
    for i in stats.host_written as usize..host_len {
        assert!(host.is_sentinel(i), "host entry {i} past host_written written");
    }

    // Two bands equal one call.
    if b.chance(96) && h >= 2 && n <= (MAX_SIDE * MAX_SIDE) as usize {
        let k = 1 + b.below(h - 1);
        let (t, c) = (ssr_texel_img(&texels), vec3_img(&color));
        let (s1, c1, v1, l1, st1) = run(&g, t, c, &o, w, h, refl_row_range { begin: 0, end: h });
        let (s2, c2, v2, l2, st2) = run(&g, t, c, &o, w, h, refl_row_range { begin: 0, end: k });
        let (s3, c3, v3_, l3, st3) = run(&g, t, c, &o, w, h, refl_row_range { begin: k, end: h });
        assert!(s1 == refl_status::Ok && s2 == refl_status::Ok && s3 == refl_status::Ok, "bands refused: {s1:?} {s2:?} {s3:?}: {}", last_error());
        let split = (k * w) as usize;
        for i in 0..n {
            let (pc, pv) = if i < split { (c2[i], v2[i]) } else { (c3[i], v3_[i]) };
            assert_eq!(bits3(c1[i]), bits3(pc), "color {i} differs between one call and two bands (k {k})");
            assert_eq!(v1[i], pv, "status {i} differs between one call and two bands");
        }
        assert_eq!(l1, [l2, l3].concat(), "host lists of two bands");
        assert_eq!(st1.holes, st2.holes + st3.holes, "stats of two bands");
        assert_eq!(st1.filled, st2.filled + st3.filled, "stats of two bands");
    }
});
