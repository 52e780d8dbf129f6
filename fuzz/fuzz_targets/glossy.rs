//! The glossy pass (issue 13): `refl_glossy_options_default`,
//! `refl_glossy_scratch_len`, `refl_glossy_prepare`,
//! `refl_glossy_trace_rows`, cone tracing and multi-ray.
//!
//! The G-buffer of [`FuzzGBuffer`] (color and roughness mostly present),
//! fuzzed options, scratch, outputs and bands. Checked: the NULL and error
//! rules (nothing written on error, inputs never written); accepted options
//! lie in their documented ranges; on OK only the band's rows are written,
//! pixels outside the roughness range or masked are skipped with zero
//! fields and black color, handled pixels have coverage, fade and probe
//! weight in [0, 1] and a unit direction, axis hits lie in the image at a
//! distance within [t_min, t_max], colors are finite and within the lit
//! color's range, the stats count the texels, the host list holds the
//! first host pixels in row-major order with their statuses; two bands
//! give the same bytes as one call.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const SKIPPED: u32 = 0;
const NO_SURFACE: u32 = 1;
const HIT: u32 = 2;
const SKY: u32 = 3;
const LAST_STATUS: u32 = 9;

fn fade(b: &mut Bytes) -> refl_glossy_fade {
    if !b.chance(24) {
        return refl_glossy_fade { enabled: false, start: 0.0, end: 1.0 };
    }
    let start = b.f32_in(-1.0, 2.0);
    let end = if b.chance(16) { b.f32_any() } else { start + b.f32_fine(0.01, 3.0) };
    refl_glossy_fade { enabled: true, start, end }
}

fn options(b: &mut Bytes) -> refl_glossy_options {
    let mut o = refl_glossy_options_default();
    o.method = if b.chance(24) { b.pick(&[2, 7, 0xFFFF_FFFF]) } else { u32::from(b.bool()) };
    if b.chance(48) {
        o.max_circles = b.pick(&[0, 1, 4, 16, 64, 65, u32::MAX]);
    }
    if b.chance(32) {
        o.level_bias = b.f32_in(-2.0, 2.0);
    }
    o.use_visibility = b.chance(64);
    if b.chance(32) {
        o.max_stretch = b.f32_in(0.5, 8.0);
    }
    if b.chance(32) {
        o.depth_tolerance = b.f32_in(-0.01, 0.1);
    }
    if b.chance(48) {
        o.normalize = b.bool();
        o.view_space = b.bool();
    }
    if b.chance(32) {
        o.fade_toward_camera = fade(b);
        o.fade_border = fade(b);
        o.fade_travel = fade(b);
    }
    if b.chance(32) {
        o.sigma = b.f32_in(-0.5, 3.0);
    }
    if b.chance(48) {
        o.rays = b.pick(&[0, 1, 3, 8, 16]);
    }
    if b.chance(16) {
        o.hiz.max_iterations = b.pick(&[0, 1, 3, 64]);
    }
    if b.chance(32) {
        o.thickness = b.f32_in(0.0, 1.5);
        o.start_pixels = b.f32_in(0.0, 4.0);
    }
    if b.chance(32) {
        o.t_min = b.f32_in(0.0, 2.0);
        o.t_max = t_max(b);
    }
    if b.chance(48) {
        o.min_roughness = b.f32_in(-0.2, 0.6);
        o.max_roughness = b.f32_in(0.0, 1.2);
    }
    if b.chance(48) {
        o.refine = b.bool();
        o.reject_back_faces = b.bool();
        o.reject_hidden_hits = b.bool();
    }
    o
}

fn fade_ok(f: &refl_glossy_fade) -> bool {
    !f.enabled || (f.start.is_finite() && f.end.is_finite() && f.end > f.start)
}

/// The pass's documented ranges (the Hi-Z settings are the hiz target's).
fn options_in_range(o: &refl_glossy_options) -> bool {
    o.method <= 1
        && o.level_bias.is_finite()
        && o.max_stretch.is_finite()
        && o.max_stretch >= 1.0
        && o.depth_tolerance.is_finite()
        && o.depth_tolerance >= 0.0
        && [o.fade_toward_camera, o.fade_border, o.fade_travel].iter().all(fade_ok)
        && o.sigma.is_finite()
        && o.sigma > 0.0
        && (o.method == 0 || o.rays > 0)
        && o.thickness.is_finite()
        && o.thickness >= 0.0
        && o.start_pixels.is_finite()
        && o.start_pixels >= 0.0
        && o.t_min.is_finite()
        && o.t_min >= 0.0
        && o.t_max > o.t_min
        && !o.min_roughness.is_nan()
        && !o.max_roughness.is_nan()
        && o.min_roughness < o.max_roughness
}

fn texel_bits(t: &refl_glossy_texel) -> [u32; 10] {
    [
        t.status,
        t.pixel.x.to_bits(),
        t.pixel.y.to_bits(),
        t.t.to_bits(),
        t.coverage.to_bits(),
        t.fade.to_bits(),
        t.fallback_weight.to_bits(),
        t.dir.x.to_bits(),
        t.dir.y.to_bits(),
        t.dir.z.to_bits(),
    ]
}

/// One call over `rows` into fresh valid buffers (with a color output).
fn run(
    g: &refl_gbuffer,
    o: &refl_glossy_options,
    scratch: &Buf<f32>,
    rows: refl_row_range,
) -> (refl_status, refl_glossy_stats, Vec<refl_glossy_texel>, Vec<refl_vec3>, Vec<refl_host_ray>) {
    let (w, h) = (g.depth.camera.width, g.depth.camera.height);
    let n = w as usize * h as usize;
    let mut out = Buf::<refl_glossy_texel>::sentinel(n, PtrKind::Valid);
    let mut col = Buf::<refl_vec3>::sentinel(n, PtrKind::Valid);
    let mut host = Buf::<refl_host_ray>::sentinel(n, PtrKind::Valid);
    let cm = refl_image_vec3_mut { data: col.ptr(), len: n, width: w, height: h, stride: w };
    let mut st = refl_glossy_stats::default();
    // SAFETY: buffers valid for their lengths; the G-buffer accepted before.
    let s = unsafe { refl_glossy_trace_rows(&mut st, out.ptr(), n, cm, host.ptr(), n, g, o, scratch.cptr(), scratch.len(), rows) };
    (s, st, out.to_vec(), col.to_vec(), host.to_vec())
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let d = refl_glossy_options_default();
    assert!(options_in_range(&d), "defaults out of range: {d:?}");

    let fg = FuzzGBuffer::new(&mut b, [96, 8, 8, 96]);
    let img = &fg.img;
    let (w, h) = (img.width, img.height);

    let g = fg.desc();
    let o = options(&mut b);
    let gb = Buf::from_slice(&[g], b.ptr_kind());
    let ob = Buf::from_slice(&[o], b.ptr_kind());
    let args_misaligned = gb.kind() == PtrKind::Misaligned || ob.kind() == PtrKind::Misaligned;

    // 1. The size query.
    let mut lo = out1::<usize>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_glossy_scratch_len(lo.ptr(), gb.cptr(), ob.cptr()) };
    let null = lo.is_null() || gb.is_null() || ob.is_null();
    null_rules_m(s, null, null, args_misaligned || lo.kind() == PtrKind::Misaligned, "refl_glossy_scratch_len");
    on_error_untouched(s, &[("out_len", lo.is_sentinel(0))], "refl_glossy_scratch_len");
    let mut need = 0usize;
    // SAFETY: pointers valid.
    let qs = unsafe { refl_glossy_scratch_len(&mut need, &g, &o) };
    if s == refl_status::Ok {
        assert_eq!(lo.get(0), need, "scratch_len differs between calls");
    }
    if qs == refl_status::Ok {
        assert!(o.method <= 1 && need > 0, "scratch_len accepted method {} ({need})", o.method);
    }

    // 2. Prepare (capped: a valid camera of a huge size needs huge pyramids).
    let slen = if qs == refl_status::Ok && need <= 1 << 18 { b.len_for(need) } else { b.below(64) as usize };
    let mut scratch = Buf::<f32>::sentinel(slen, b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_glossy_prepare(scratch.ptr(), slen, gb.cptr(), ob.cptr()) };
    let req_null = gb.is_null() || ob.is_null() || (scratch.is_null() && qs == refl_status::Ok);
    null_rules_m(s, req_null, req_null || scratch.is_null() || fg.normals.0.is_null() || img.buf.is_null(), true, "refl_glossy_prepare");
    on_error_untouched(s, &[("scratch", (0..slen).all(|i| scratch.is_sentinel(i)))], "refl_glossy_prepare");
    fg.assert_unchanged("refl_glossy_prepare");
    if s != refl_status::Ok {
        return;
    }
    assert_eq!(qs, refl_status::Ok, "prepare accepted what scratch_len refused");
    assert!(options_in_range(&o), "prepare accepted options {o:?}");
    fg.assert_accepted("prepare");
    assert!(fg.has_color() && fg.roughness_at(0, 0).is_some(), "prepare accepted a G-buffer without color or roughness");
    assert!(slen >= need, "prepare accepted {slen} scratch floats of {need}");
    for i in need..slen {
        assert!(scratch.is_sentinel(i), "prepare wrote past the scratch it needs");
    }
    let n = w as usize * h as usize;

    // 3. A band with fuzzed buffers.
    let rows = b.rows(h);
    let out_len = b.len_for(n);
    let mut out = Buf::<refl_glossy_texel>::sentinel(out_len, b.ptr_kind());
    let want_color = b.chance(200);
    let col_len = if want_color { b.len_for(n) } else { 0 };
    let mut col = Buf::<refl_vec3>::sentinel(col_len, if want_color { b.ptr_kind() } else { PtrKind::Null });
    let cm = refl_image_vec3_mut { data: col.ptr(), len: col_len, width: w, height: h, stride: w };
    let want_color = want_color && !col.is_null();
    let host_len = match b.u8() % 4 {
        0 => 0,
        1 => b.below(4) as usize,
        _ => n,
    };
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, if host_len == 0 && b.bool() { PtrKind::Null } else { b.ptr_kind() });
    let mut st = out1::<refl_glossy_stats>(b.ptr_kind());
    let scratch_snap = scratch.snapshot();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe {
        refl_glossy_trace_rows(st.ptr(), out.ptr(), out_len, cm, host.ptr(), host_len, gb.cptr(), ob.cptr(), scratch.cptr(), slen, rows)
    };
    let req_null = st.is_null() || out.is_null() || gb.is_null() || ob.is_null() || scratch.is_null() || (host.is_null() && host_len > 0);
    let mis = [out.kind(), col.kind(), host.kind(), st.kind(), scratch.kind()].contains(&PtrKind::Misaligned) || args_misaligned;
    null_rules_m(s, req_null, req_null || col.is_null() || host.is_null(), mis, "refl_glossy_trace_rows");
    on_error_untouched(
        s,
        &[
            ("out_stats", st.is_sentinel(0)),
            ("out", (0..out_len).all(|i| out.is_sentinel(i))),
            ("color", (0..col_len).all(|i| col.is_sentinel(i))),
            ("host", (0..host_len).all(|i| host.is_sentinel(i))),
        ],
        "refl_glossy_trace_rows",
    );
    fg.assert_unchanged("refl_glossy_trace_rows");
    scratch.assert_unchanged(&scratch_snap, "refl_glossy_trace_rows scratch");
    if s != refl_status::Ok {
        return;
    }
    assert!(rows.begin < rows.end && rows.end <= h, "trace_rows accepted rows {rows:?} of {h}");
    assert!(out_len >= n && (!want_color || col_len >= n), "trace_rows accepted short outputs");
    let stats = st.get(0);
    let (mut hits, mut sky, mut hostc, mut traced) = (0u32, 0u32, 0u32, 0u32);
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
            let r = fg.roughness_at(x, y).unwrap();
            let handled = !fg.masked(x, y) && r > o.min_roughness && r <= o.max_roughness;
            if !handled {
                assert_eq!(t.status, SKIPPED, "({x}, {y}) roughness {r} masked {}: {t:?}", fg.masked(x, y));
            }
            if t.status == SKIPPED || t.status == NO_SURFACE {
                assert!(t.fallback_weight == 0.0 && t.dir == v3(0.0, 0.0, 0.0), "unhandled ({x}, {y}) {t:?}");
            } else {
                traced += 1;
                for (name, v) in [("coverage", t.coverage), ("fade", t.fade), ("fallback_weight", t.fallback_weight)] {
                    assert!((0.0..=1.0).contains(&v), "({x}, {y}) {name} {v}: {t:?}");
                }
                assert!((len3(t.dir) - 1.0).abs() < 1e-3, "({x}, {y}) dir {:?}", t.dir);
            }
            if t.status == HIT {
                hits += 1;
                let p = t.pixel;
                assert!(p.x >= 0.0 && p.y >= 0.0 && p.x <= w as f32 && p.y <= h as f32, "axis hit {p:?} outside {w}x{h}");
                assert!(t.t.is_finite() && t.t >= o.t_min && t.t <= o.t_max, "axis hit t {} outside [{}, {}]", t.t, o.t_min, o.t_max);
            } else {
                assert!(t.pixel.x == 0.0 && t.pixel.y == 0.0 && t.t == 0.0, "({x}, {y}) status {} with a hit: {t:?}", t.status);
            }
            if t.status == SKY {
                sky += 1;
            }
            if t.status >= 4 {
                hostc += 1;
            }
            if want_color {
                let c = col.get(i);
                let hi = (w.max(h) as f32).max(1.0) + 1e-3;
                for v in [c.x, c.y, c.z] {
                    assert!(v.is_finite() && (-1e-3..=hi).contains(&v), "color ({x}, {y}) {c:?} outside the lit range (status {})", t.status);
                }
                if t.status == SKIPPED || t.status == NO_SURFACE {
                    assert!(c == v3(0.0, 0.0, 0.0), "unhandled ({x}, {y}) color {c:?}");
                }
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
        assert!(finite3(r.origin) && (len3(r.dir) - 1.0).abs() < 1e-3, "host ray {r:?}");
        assert!(r.t_min.to_bits() == o.t_min.to_bits() && r.t_max.to_bits() == o.t_max.to_bits(), "host ray range");
    }

    // 4. Two bands: the same bytes as one call (row calls refuse an empty
    // band).
    if b.chance(64) && h >= 2 {
        let k = 1 + b.below(h - 1);
        let (s1, st1, t1, c1, h1) = run(&g, &o, &scratch, refl_row_range { begin: 0, end: h });
        let (s2, st2, t2, c2, h2) = run(&g, &o, &scratch, refl_row_range { begin: 0, end: k });
        let (s3, st3, t3, c3, h3) = run(&g, &o, &scratch, refl_row_range { begin: k, end: h });
        assert!(s1 == refl_status::Ok && s2 == refl_status::Ok && s3 == refl_status::Ok, "bands refused: {}", last_error());
        let split = (k * w) as usize;
        for i in 0..n {
            let (tp, cp) = if i < split { (&t2[i], c2[i]) } else { (&t3[i], c3[i]) };
            assert!(texel_bits(&t1[i]) == texel_bits(tp), "texel {i} differs between one call and two bands");
            assert!([c1[i].x, c1[i].y, c1[i].z].map(f32::to_bits) == [cp.x, cp.y, cp.z].map(f32::to_bits), "color {i} differs");
        }
        assert_eq!((st1.hits, st1.host_rays, st1.circles), (st2.hits + st3.hits, st2.host_rays + st3.host_rays, st2.circles + st3.circles));
        let joined: Vec<_> = h2[..st2.host_rays_written as usize].iter().chain(&h3[..st3.host_rays_written as usize]).collect();
        assert_eq!(joined.len(), st1.host_rays_written as usize);
        for (a, c) in h1.iter().zip(joined) {
            assert!(host_bits(a) == host_bits(c), "host list differs between one call and two bands");
        }
    }
});
