//! The screen-space mirror pass (issue 13): `refl_ssr_options_default`,
//! `refl_ssr_scratch_len`, `refl_ssr_prepare`, `refl_ssr_trace_rows`.
//!
//! A fuzzed G-buffer (depth with its camera and convention, normals in
//! either space, optional mask, roughness, lit color and back-face depth,
//! each sometimes of the wrong size, short, NULL or misaligned), fuzzed
//! options, scratch, output, color and host-list buffers and row bands.
//! Checked: the NULL and error rules (nothing written on error, inputs
//! never written); on OK only the band's rows are written, every texel's
//! status is known and its fields match it, the color is the G-buffer's lit
//! color at a hit's texel and black elsewhere, the stats count the texels,
//! the host list holds the first host pixels in row-major order with their
//! statuses, unit directions on the viewer's side of the surface and the
//! options' `t_min`/`t_max`; accepted options lie in their documented
//! ranges; two bands give the same bytes as one call; a Hi-Z pyramid built
//! for another camera is refused.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const SKIPPED: u32 = 0;
const NO_SURFACE: u32 = 1;
const HIT: u32 = 2;
const SKY: u32 = 3;
const LAST_STATUS: u32 = 9;

fn options(b: &mut Bytes) -> refl_ssr_options {
    let mut o = refl_ssr_options_default();
    if b.chance(40) {
        o.method = b.pick(&[0, 1, 2, 0xFFFF_FFFF]);
    } else {
        o.method = u32::from(b.bool());
    }
    if b.chance(64) {
        o.thickness = b.f32_in(0.0, 1.5);
    }
    if b.chance(48) {
        o.start_pixels = b.f32_in(0.0, 4.0);
    }
    if b.chance(48) {
        o.t_min = b.f32_in(0.0, 2.0);
    }
    if b.chance(64) {
        o.t_max = t_max(b);
    }
    if b.chance(32) {
        o.max_roughness = b.f32_in(-0.1, 1.1);
    }
    if b.chance(32) {
        o.border_fade = b.f32_in(-0.1, 0.6);
    }
    if b.chance(48) {
        o.refine = b.bool();
        o.reject_back_faces = b.bool();
        o.reject_hidden_hits = b.bool();
    }
    if b.chance(16) {
        o.step.stride = b.pick(&[0, 1, 2, 4, 8, u32::MAX]);
    }
    if b.chance(16) {
        o.hiz.max_iterations = b.pick(&[0, 1, 3, 64, u32::MAX]);
    }
    o
}

/// Whether the pass's own options are in their documented ranges (the
/// kernels' settings are the kernels' targets' business).
fn pass_options_in_range(o: &refl_ssr_options) -> bool {
    o.method <= 1
        && o.thickness.is_finite()
        && o.thickness >= 0.0
        && o.start_pixels.is_finite()
        && o.start_pixels >= 0.0
        && o.t_min.is_finite()
        && o.t_min >= 0.0
        && o.t_max > o.t_min
        && !o.max_roughness.is_nan()
        && (0.0..=0.5).contains(&o.border_fade)
}

fn same_texel(a: &refl_ssr_texel, b: &refl_ssr_texel) -> bool {
    a.status == b.status
        && a.pixel.x.to_bits() == b.pixel.x.to_bits()
        && a.pixel.y.to_bits() == b.pixel.y.to_bits()
        && a.t.to_bits() == b.t.to_bits()
        && a.confidence.to_bits() == b.confidence.to_bits()
}

/// One `refl_ssr_trace_rows` over `rows` into fresh valid buffers: the
/// status, texels, colors and host list.
#[allow(clippy::type_complexity)]
fn run(
    g: &refl_gbuffer,
    o: &refl_ssr_options,
    scratch: &Buf<refl_vec2>,
    with_color: bool,
    host_len: usize,
    rows: refl_row_range,
) -> (refl_status, refl_ssr_stats, Vec<refl_ssr_texel>, Vec<refl_vec3>, Vec<refl_host_ray>) {
    let (w, h) = (g.depth.camera.width, g.depth.camera.height);
    let n = w as usize * h as usize;
    let mut out = Buf::<refl_ssr_texel>::sentinel(n, PtrKind::Valid);
    let mut col = Buf::<refl_vec3>::sentinel(if with_color { n } else { 0 }, if with_color { PtrKind::Valid } else { PtrKind::Null });
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, if host_len > 0 { PtrKind::Valid } else { PtrKind::Null });
    let cm = refl_image_vec3_mut { data: col.ptr(), len: col.len(), width: w, height: h, stride: w };
    let mut st = refl_ssr_stats::default();
    // SAFETY: buffers valid for their lengths; the G-buffer's images as fuzzed (already accepted once).
    let s = unsafe {
        refl_ssr_trace_rows(&mut st, out.ptr(), n, cm, host.ptr(), host_len, g, o, scratch.cptr(), scratch.len(), rows)
    };
    (s, st, out.to_vec(), if with_color { col.to_vec() } else { Vec::new() }, host.to_vec())
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);

    // Defaults: the documented values.
    let d = refl_ssr_options_default();
    assert!(pass_options_in_range(&d), "defaults out of range: {d:?}");
    assert!(d.method == 0 && d.t_max == f32::INFINITY && d.refine && d.reject_back_faces && d.reject_hidden_hits);

    let fg = FuzzGBuffer::new(&mut b, [96; 4]);
    let img = &fg.img;
    let (w, h) = (img.width, img.height);
    let cam = img.cam;
    let g = fg.desc();
    let has_color = fg.has_color();
    let normal_space = fg.normal_space;
    let o = options(&mut b);
    let inputs_unchanged = |what: &str| fg.assert_unchanged(what);
    let gb = Buf::from_slice(&[g], b.ptr_kind());
    let ob = Buf::from_slice(&[o], b.ptr_kind());
    let args_misaligned = gb.kind() == PtrKind::Misaligned || ob.kind() == PtrKind::Misaligned;

    // 1. The size query.
    let mut lo = out1::<usize>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_ssr_scratch_len(lo.ptr(), gb.cptr(), ob.cptr()) };
    let null = lo.is_null() || gb.is_null() || ob.is_null();
    null_rules_m(s, null, null, args_misaligned || lo.kind() == PtrKind::Misaligned, "refl_ssr_scratch_len");
    on_error_untouched(s, &[("out_len", lo.is_sentinel(0))], "refl_ssr_scratch_len");
    // The query's own answer from valid pointers.
    let mut need = 0usize;
    // SAFETY: pointers valid.
    let qs = unsafe { refl_ssr_scratch_len(&mut need, &g, &o) };
    if s == refl_status::Ok {
        assert_eq!(lo.get(0), need, "scratch_len differs between calls");
    }
    if qs == refl_status::Ok {
        assert!(o.method <= 1, "scratch_len accepted method {}", o.method);
        if o.method == 0 {
            assert_eq!(need, 0, "stepping needs no scratch");
        } else {
            let (mut hl, mut lv) = (0usize, 0u32);
            // SAFETY: pointers valid.
            assert_eq!(unsafe { refl_hiz_len(&mut hl, &mut lv, cam.width, cam.height) }, refl_status::Ok);
            assert_eq!(need, hl, "Hi-Z scratch is the pyramid");
        }
    }

    // 2. Prepare.
    // Capped: a valid camera of a huge size has a huge pyramid (its depth
    // image is then short and refused anyway).
    let slen = if qs == refl_status::Ok && need <= 1 << 16 { b.len_for(need) } else { b.below(64) as usize };
    let skind = if o.method == 0 && b.chance(128) { PtrKind::Null } else { b.ptr_kind() };
    let mut scratch = Buf::<refl_vec2>::sentinel(slen, skind);
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_ssr_prepare(scratch.ptr(), slen, gb.cptr(), ob.cptr()) };
    let req_null = gb.is_null() || ob.is_null() || (o.method == 1 && scratch.is_null() && qs == refl_status::Ok);
    null_rules_m(s, req_null, req_null || scratch.is_null() || fg.normals.0.is_null() || img.buf.is_null(), true, "refl_ssr_prepare");
    on_error_untouched(s, &[("scratch", (0..slen).all(|i| scratch.is_sentinel(i)))], "refl_ssr_prepare");
    inputs_unchanged("refl_ssr_prepare");
    if s != refl_status::Ok {
        return;
    }
    assert_eq!(qs, refl_status::Ok, "prepare accepted what scratch_len refused");
    assert!(pass_options_in_range(&o), "prepare accepted options {o:?}");
    fg.assert_accepted("prepare");
    if o.method == 1 {
        assert!(slen >= need, "prepare accepted {slen} scratch texels of {need}");
        for i in need..slen {
            assert!(scratch.is_sentinel(i), "prepare wrote past the pyramid");
        }
    }
    let n = w as usize * h as usize;

    // 3. Trace a band with fuzzed buffers.
    let rows = b.rows(h);
    let out_len = b.len_for(n);
    let mut out = Buf::<refl_ssr_texel>::sentinel(out_len, b.ptr_kind());
    let want_color = b.chance(160);
    let (ocw, och) = if b.chance(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    // (Capped: a huge fuzzed size gets a short buffer, refused anyway.)
    let col_len = if want_color { b.len_for((ocw as usize * och as usize).min(1 << 16)) } else { 0 };
    let mut col = Buf::<refl_vec3>::sentinel(col_len, if want_color { b.ptr_kind() } else { PtrKind::Null });
    let cm = refl_image_vec3_mut { data: col.ptr(), len: col_len, width: ocw, height: och, stride: ocw };
    // A NULL color is no color output, whatever its other fields say.
    let want_color = want_color && !col.is_null();
    let host_len = match b.u8() % 4 {
        0 => 0,
        1 => b.below(4) as usize,
        _ => n,
    };
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, if host_len == 0 && b.bool() { PtrKind::Null } else { b.ptr_kind() });
    let mut st = out1::<refl_ssr_stats>(b.ptr_kind());
    let scratch_snap = scratch.snapshot();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe {
        refl_ssr_trace_rows(st.ptr(), out.ptr(), out_len, cm, host.ptr(), host_len, gb.cptr(), ob.cptr(), scratch.cptr(), slen, rows)
    };
    let req_null = st.is_null() || out.is_null() || gb.is_null() || ob.is_null() || (host.is_null() && host_len > 0);
    let mis = [out.kind(), col.kind(), host.kind(), st.kind(), scratch.kind()].contains(&PtrKind::Misaligned) || args_misaligned;
    null_rules_m(s, req_null, req_null || scratch.is_null() || col.is_null() || host.is_null(), mis, "refl_ssr_trace_rows");
    on_error_untouched(
        s,
        &[
            ("out_stats", (0..1).all(|i| st.is_sentinel(i))),
            ("out", (0..out_len).all(|i| out.is_sentinel(i))),
            ("color", (0..col_len).all(|i| col.is_sentinel(i))),
            ("host", (0..host_len).all(|i| host.is_sentinel(i))),
        ],
        "refl_ssr_trace_rows",
    );
    inputs_unchanged("refl_ssr_trace_rows");
    scratch.assert_unchanged(&scratch_snap, "refl_ssr_trace_rows scratch");
    if s == refl_status::Ok {
        assert!(rows.begin <= rows.end && rows.end <= h, "trace_rows accepted rows {rows:?} of {h}");
        assert!(out_len >= n, "trace_rows accepted out_len {out_len} < {n}");
        if want_color {
            assert!(has_color && ocw == w && och == h && col_len >= n, "trace_rows accepted a color output of {ocw}x{och} ({col_len})");
        }
        let stats = st.get(0);
        let (mut hits, mut sky, mut hostc, mut traced) = (0u32, 0u32, 0u32, 0u32);
        let eye = eye_of(&cam);
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                if y < rows.begin || y >= rows.end {
                    assert!(out.is_sentinel(i), "texel ({x}, {y}) outside rows {rows:?} written");
                    if want_color {
                        assert!(col.is_sentinel(i), "color ({x}, {y}) outside rows written");
                    }
                    continue;
                }
                let t = out.get(i);
                assert!(t.status <= LAST_STATUS, "texel ({x}, {y}) status {}", t.status);
                match t.status {
                    HIT => {
                        hits += 1;
                        let p = t.pixel;
                        assert!(p.x >= 0.0 && p.y >= 0.0 && p.x <= w as f32 && p.y <= h as f32, "hit pixel {p:?} outside {w}x{h}");
                        assert!(t.t.is_finite() && t.t >= o.t_min && t.t <= o.t_max, "hit t {} outside [{}, {}] at ({x}, {y}): {t:?}; options {o:?}; camera {cam:?}; convention {}; depth {}; stride {} image {:?}; normals {:?} space {normal_space}", t.t, o.t_min, o.t_max, img.conv, img.texel(x, y), img.stride, img.buf.to_vec(), fg.normals.0.to_vec());
                        assert!((0.0..=1.0).contains(&t.confidence), "confidence {}", t.confidence);
                    }
                    _ => {
                        assert!(
                            t.pixel.x == 0.0 && t.pixel.y == 0.0 && t.t == 0.0 && t.confidence == 0.0,
                            "texel ({x}, {y}) status {} with hit fields {t:?}",
                            t.status
                        );
                    }
                }
                if t.status == SKY {
                    sky += 1;
                }
                if t.status >= 4 {
                    hostc += 1;
                }
                if t.status != SKIPPED && t.status != NO_SURFACE {
                    traced += 1;
                }
                // Not reflective by the mask or the roughness: skipped.
                let masked = fg.masked(x, y);
                let rough = fg.roughness_at(x, y).is_some_and(|r| !(r <= o.max_roughness));
                if masked || rough {
                    assert_eq!(t.status, SKIPPED, "({x}, {y}) masked {masked} rough {rough}");
                }
                if want_color {
                    let c = col.get(i);
                    let want = if t.status == HIT && (t.pixel.x as u32) < w && (t.pixel.y as u32) < h {
                        fg.color_at(t.pixel.x as u32, t.pixel.y as u32)
                    } else {
                        v3(0.0, 0.0, 0.0)
                    };
                    assert!(
                        [c.x, c.y, c.z].map(f32::to_bits) == [want.x, want.y, want.z].map(f32::to_bits),
                        "color ({x}, {y}) {c:?}, want {want:?} (status {}; rows {rows:?} of {w}x{h}, color len {col_len} {:?})",
                        t.status,
                        col.kind()
                    );
                }
            }
        }
        assert_eq!((stats.hits, stats.sky, stats.host_rays, stats.traced), (hits, sky, hostc, traced), "stats {stats:?}");
        assert_eq!(stats.host_rays_written as usize, (hostc as usize).min(host_len), "host rays written");
        let mut last: Option<(u32, u32)> = None;
        for k in 0..host_len {
            if k >= stats.host_rays_written as usize {
                assert!(host.is_sentinel(k), "host entry {k} past the written ones");
                continue;
            }
            let r = host.get(k);
            assert!(r.y >= rows.begin && r.y < rows.end && r.x < w, "host ray at ({}, {})", r.x, r.y);
            assert!(last.is_none_or(|l| (r.y, r.x) > l), "host rays not in row-major order");
            last = Some((r.y, r.x));
            let t = out.get((r.y * w + r.x) as usize);
            assert!(t.status >= 4 && t.status == r.status, "host ray status {} vs texel {}", r.status, t.status);
            assert!(finite3(r.origin), "host ray origin {:?}", r.origin);
            assert!((len3(r.dir) - 1.0).abs() < 1e-3, "host ray dir {:?}", r.dir);
            assert!(r.t_min.to_bits() == o.t_min.to_bits() && r.t_max.to_bits() == o.t_max.to_bits(), "host ray range");
            // The reflected direction leaves on the viewer's side of the
            // surface (world-space normals).
            if let (0, Some(e)) = (normal_space, eye) {
                let nn = fg.normal_at(r.x, r.y);
                let v = [r.origin.x - e.x, r.origin.y - e.y, r.origin.z - e.z].map(f64::from);
                let (nd, dd) = (d3(nn), d3(r.dir));
                let vn = v[0] * nd[0] + v[1] * nd[1] + v[2] * nd[2];
                let dn = dd[0] * nd[0] + dd[1] * nd[1] + dd[2] * nd[2];
                let vl = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                let nl = len3(nn);
                if vl > 1e-3 * (1.0 + len3(r.origin)) && nl.is_finite() && nl > 0.0 {
                    assert!(vn * dn <= 1e-3 * vl * nl * nl, "host ray on the far side of its surface: v.n {vn}, d.n {dn}");
                }
            }
        }

        // 4. Bands: the same bytes as one call over the whole image.
        // (Row calls refuse an empty band: refl_image_row_band says to skip
        // them.)
        if b.chance(64) && n <= 48 * 48 && h >= 2 {
            let whole = refl_row_range { begin: 0, end: h };
            let k = 1 + b.below(h - 1);
            let (s1, st1, t1, c1, h1) = run(&g, &o, &scratch, has_color, n, whole);
            let (s2, st2, t2, c2, h2) = run(&g, &o, &scratch, has_color, n, refl_row_range { begin: 0, end: k });
            let (s3, st3, t3, c3, h3) = run(&g, &o, &scratch, has_color, n, refl_row_range { begin: k, end: h });
            assert!(s1 == refl_status::Ok && s2 == refl_status::Ok && s3 == refl_status::Ok, "bands refused: {s1:?} {s2:?} {s3:?} (k {k} of {h}): {}", last_error());
            let split = (k * w) as usize;
            for i in 0..n {
                let part = if i < split { &t2[i] } else { &t3[i] };
                assert!(same_texel(&t1[i], part), "texel {i} differs between one call and two bands");
                if has_color {
                    let p = if i < split { c2[i] } else { c3[i] };
                    assert!([c1[i].x, c1[i].y, c1[i].z].map(f32::to_bits) == [p.x, p.y, p.z].map(f32::to_bits), "color {i} differs");
                }
            }
            assert_eq!(st1.host_rays, st2.host_rays + st3.host_rays);
            assert_eq!(st1.hits, st2.hits + st3.hits);
            let joined: Vec<_> = h2[..st2.host_rays_written as usize].iter().chain(&h3[..st3.host_rays_written as usize]).collect();
            assert_eq!(joined.len(), st1.host_rays_written as usize);
            for (a, c) in h1.iter().zip(joined) {
                assert!(same_host(a, c), "host list differs between one call and two bands");
            }
        }

        // 5. A pyramid built for this camera, traced with another camera of
        // the same size: refused (stepping uses no pyramid).
        if o.method == 1 && b.chance(64) {
            let mut g2 = g;
            g2.depth.camera.fov_y = if cam.fov_y > 1.0 { cam.fov_y * 0.9 } else { cam.fov_y * 1.1 };
            // SAFETY: pointer valid.
            if unsafe { refl_camera_validate(&g2.depth.camera) } == refl_status::Ok {
                let (s, ..) = run(&g2, &o, &scratch, false, 0, refl_row_range { begin: 0, end: h });
                assert_eq!(s, refl_status::InvalidArgument, "a Hi-Z pyramid of another camera was accepted");
            }
        }
    }
});
