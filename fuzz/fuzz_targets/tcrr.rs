//! TCRR (seed 000): `refl_tcrr_options_default`, `refl_tcrr_frame_bytes`,
//! `refl_tcrr_reflection_distance`, `refl_tcrr_prepare`,
//! `refl_tcrr_reset_offsets`, `refl_tcrr_search`, `refl_tcrr_shift`,
//! `refl_tcrr_warp`, `refl_tcrr_retrace_list`, `refl_tcrr_compose`,
//! `refl_tcrr_fresnel_weight`, `refl_tcrr_needs_key_frame`: a small
//! mirror-floor frame pipeline with fuzzed buffers, descriptors, row bands,
//! parameters and optional (NULL or misaligned) stats pointers.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const SPECIAL_PAD: f32 = 0.25;

/// The key frame's buffers.
struct Key {
    cam: refl_camera,
    conv: u32,
    w: u32,
    h: u32,
    depth: Buf<f32>,
    normal: Buf<refl_vec3>,
    spec: Buf<f32>,
    color: Buf<refl_vec3>,
    dist: Buf<f32>,
}

impl Key {
    fn desc(&self, surfels: Option<&Buf<refl_tcrr_surfel>>) -> refl_tcrr_key {
        let (w, h) = (self.w, self.h);
        refl_tcrr_key {
            camera: self.cam,
            convention: self.conv,
            depth: img_f32(&self.depth, w, h, w),
            normal: refl_image_vec3 { data: self.normal.cptr(), len: self.normal.len(), width: w, height: h, stride: w },
            specular: img_f32(&self.spec, w, h, w),
            color: refl_image_vec3 { data: self.color.cptr(), len: self.color.len(), width: w, height: h, stride: w },
            distance: img_f32(&self.dist, w, h, w),
            surfels: match surfels {
                Some(s) => refl_image_tcrr_surfel { data: s.cptr(), len: s.len(), width: w, height: h, stride: w },
                None => refl_image_tcrr_surfel { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 },
            },
        }
    }

    fn any_null(&self) -> bool {
        [self.depth.is_null(), self.normal.is_null(), self.spec.is_null(), self.color.is_null(), self.dist.is_null()].contains(&true)
    }

    fn valid(&self) -> bool {
        let n = (self.w * self.h) as usize;
        camera_ok(&self.cam)
            && self.conv <= 2
            && self.cam.width == self.w
            && self.cam.height == self.h
            && [self.depth.usable(), self.normal.usable(), self.spec.usable(), self.color.usable(), self.dist.usable()]
                .iter()
                .all(|v| *v)
            && self.depth.len() >= n
            && self.normal.len() >= n
            && self.spec.len() >= n
            && self.color.len() >= n
            && self.dist.len() >= n
    }
}

fn key(b: &mut Bytes) -> Key {
    let w = 1 + b.below(24);
    let h = 1 + b.below(24);
    let cam = camera(b, w, h);
    let conv = b.convention();
    let depth = depth_values(b, &cam, conv.min(2), w, h);
    let n = (w * h) as usize;
    let mut kinds = [PtrKind::Valid; 5];
    let mut lens = [n; 5];
    for i in 0..5 {
        if b.chance(16) {
            kinds[i] = b.ptr_kind();
        }
        if b.chance(16) {
            lens[i] = b.len_for(n);
        }
    }
    let floor_spec = b.f32_in(0.0, 1.0);
    let spec_mode = b.u8();
    let dist_mode = b.u8();
    Key {
        cam,
        conv,
        w,
        h,
        depth: Buf::from_fn(lens[0], kinds[0], |i| depth.get(i).copied().unwrap_or(1.0)),
        normal: Buf::from_fn(lens[1], kinds[1], |i| {
            if spec_mode < 8 {
                v3(b.f32_any(), b.f32_any(), b.f32_any())
            } else if i % 7 == 3 {
                v3(0.1, 0.9, 0.0)
            } else {
                v3(0.0, 1.0, 0.0)
            }
        }),
        spec: Buf::from_fn(lens[2], kinds[2], |i| if (i / w as usize) * 2 >= h as usize { floor_spec } else { 0.0 }),
        color: Buf::from_fn(lens[3], kinds[3], |i| v3(0.5 + 0.3 * ((i % 5) as f32) / 5.0, 0.4, 0.3)),
        dist: Buf::from_fn(lens[4], kinds[4], |i| match dist_mode % 4 {
            0 => f32::INFINITY,
            1 => b.f32_any(),
            _ => 2.0 + (i % 3) as f32,
        }),
    }
}

fn params(b: &mut Bytes) -> refl_tcrr_options {
    let mut p = refl_tcrr_options_default();
    if b.chance(64) {
        match b.u8() % 6 {
            0 => p.max_iterations = b.pick(&[0, 1, 2, u32::MAX]),
            1 => p.magnification = b.f32_any(),
            2 => p.discontinuity = b.f32_any(),
            3 => p.reflected_discontinuity = b.f32_any(),
            4 => p.subpixel = b.u8() & 1 == 1,
            _ => p.retrace_contrast = b.f32_any(),
        }
    }
    p
}

/// An optional stats output: NULL (allowed), valid or misaligned.
fn stats<T: Copy>(b: &mut Bytes) -> Buf<T> {
    out1::<T>(match b.u8() % 8 {
        0 => PtrKind::Null,
        1 => PtrKind::Misaligned,
        _ => PtrKind::Valid,
    })
}

/// Checks the rows outside `rows` (and the padding) of an output image of
/// `w x h` with `stride` are untouched.
fn outside_untouched<T: Copy>(o: &Buf<T>, snap: &[u8], w: u32, h: u32, stride: u32, rows: refl_row_range, what: &str) {
    let st = stride.max(1) as usize;
    for i in 0..o.len() {
        let (x, y) = ((i % st) as u32, (i / st) as u32);
        let inside = x < w && y < h && y >= rows.begin && y < rows.end;
        if !inside {
            o.assert_texel_unchanged(snap, i, what);
        }
    }
}

struct Img<T: Copy> {
    buf: Buf<T>,
    w: u32,
    h: u32,
    stride: u32,
}

fn out_img<T: Copy>(b: &mut Bytes, w: u32, h: u32) -> Img<T> {
    let (w, h) = if b.chance(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    let stride = if b.chance(32) { b.stride(w) } else { w };
    let need = required_len(w, h, stride).unwrap_or(4).min(1 << 14);
    let len = if b.chance(16) { b.len_for(need) } else { need };
    let kind = if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid };
    Img { buf: Buf::sentinel(len, kind), w, h, stride }
}

impl<T: Copy> Img<T> {
    fn ok(&self, w: u32, h: u32) -> bool {
        self.buf.usable()
            && self.w == w
            && self.h == h
            && required_len(self.w, self.h, self.stride).is_some_and(|n| self.buf.len() >= n)
    }
}

fn rows_ok(r: refl_row_range, h: u32) -> bool {
    r.begin < r.end && r.end <= h
}

fn scalars(b: &mut Bytes) {
    match b.u8() % 4 {
        0 => {
            let (w, h) = (b.side(5000), b.side(5000));
            let mut o = out1::<usize>(b.ptr_kind());
            // SAFETY: NULL, misaligned or valid.
            let s = unsafe { refl_tcrr_frame_bytes(o.ptr(), w, h) };
            null_rules(s, o.is_null(), o.is_null(), "refl_tcrr_frame_bytes");
            on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_tcrr_frame_bytes");
            if o.usable() {
                let total = u128::from(w) * u128::from(h) * 110;
                if w == 0 || h == 0 || total > usize::MAX as u128 {
                    assert_eq!(s, refl_status::InvalidArgument);
                } else {
                    assert_eq!(s, refl_status::Ok);
                    assert_eq!(o.get(0) as u128, u128::from(w) * u128::from(h) * 110, "frame bytes");
                }
            }
        }
        1 => {
            let eye = b.vec3_in(-5.0, 5.0);
            let surface = b.vec3_in(-2.0, 2.0);
            let normal = if b.chance(16) { v3(0.0, 0.0, 0.0) } else { b.vec3_in(-1.0, 1.0) };
            let r = b.vec3_in(-6.0, 6.0);
            let kind = if b.chance(16) { b.u32() } else { b.below(2) };
            let mut o = out1::<f32>(b.ptr_kind());
            // SAFETY: NULL, misaligned or valid.
            let s = unsafe { refl_tcrr_reflection_distance(o.ptr(), eye, surface, normal, r, kind) };
            null_rules(s, o.is_null(), o.is_null(), "refl_tcrr_reflection_distance");
            on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_tcrr_reflection_distance");
            if s == refl_status::Ok {
                assert!(kind <= 1 && finite3(eye) && finite3(surface) && finite3(normal) && finite3(r));
                let d = o.get(0);
                assert!(d >= 0.0 && !d.is_nan(), "reflection distance {d}");
            } else if o.usable() && (kind > 1 || ![eye, surface, normal, r].iter().all(|v| finite3(*v))) {
                assert_eq!(s, refl_status::InvalidArgument, "reflection distance of bad input");
            }
        }
        2 => {
            let f = b.f32_any();
            let c = b.f32_any();
            let mode = if b.chance(16) { b.u32() } else { b.below(2) };
            let mut o = out1::<f32>(b.ptr_kind());
            // SAFETY: NULL, misaligned or valid.
            let s = unsafe { refl_tcrr_fresnel_weight(o.ptr(), f, c, mode) };
            null_rules(s, o.is_null(), o.is_null(), "refl_tcrr_fresnel_weight");
            on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_tcrr_fresnel_weight");
            if o.usable() {
                assert_eq!(s, if mode <= 1 { refl_status::Ok } else { refl_status::InvalidArgument });
            }
            if s == refl_status::Ok {
                let w = o.get(0);
                assert!((0.0..=1.0).contains(&w), "fresnel weight {w} for f {f} cos {c}");
                if !(f > 0.0) {
                    assert_eq!(w, 0.0, "fresnel weight of f = {f}");
                } else if mode == 0 {
                    assert_eq!(w, f.clamp(0.0, 1.0), "fresnel off");
                }
            }
        }
        _ => {
            let t = b.f32_in(-0.2, 1.2);
            let reflective = match b.u8() % 3 {
                0 => 0,
                1 => b.u64(),
                _ => u64::from(b.u16()),
            };
            let retrace = match b.u8() % 3 {
                0 => reflective.saturating_add(1),
                1 => b.u64(),
                _ => reflective / 2,
            };
            let mut o = out1::<bool>(b.ptr_kind());
            // SAFETY: NULL, misaligned or valid.
            let s = unsafe { refl_tcrr_needs_key_frame(o.ptr(), t, retrace, reflective) };
            null_rules(s, o.is_null(), o.is_null(), "refl_tcrr_needs_key_frame");
            on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_tcrr_needs_key_frame");
            if o.usable() {
                let bad = !(0.0..=1.0).contains(&t) || retrace > reflective;
                assert_eq!(s, if bad { refl_status::InvalidArgument } else { refl_status::Ok }, "needs_key_frame({t}, {retrace}, {reflective})");
            }
            if s == refl_status::Ok {
                // Written on success: a valid bool.
                let v = o.get(0);
                if reflective == 0 {
                    assert!(!v);
                }
                let share = retrace as f64 / reflective.max(1) as f64;
                if (share - f64::from(t)).abs() > 1e-6 && reflective > 0 {
                    assert_eq!(v, share > f64::from(t), "needs_key_frame({t}, {retrace}, {reflective})");
                }
            }
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    if b.chance(64) {
        for _ in 0..4 {
            scalars(&mut b);
        }
        return;
    }
    let k = key(&mut b);
    let (w, h) = (k.w, k.h);
    let p = params(&mut b);
    let pvalid = p.max_iterations >= 1
        && p.magnification.is_finite()
        && p.magnification >= 1.0
        && p.discontinuity.is_finite()
        && p.discontinuity > 0.0
        && p.reflected_discontinuity.is_finite()
        && p.reflected_discontinuity > 0.0
        && p.retrace_contrast > 0.0;

    // --- prepare
    let mut surf = out_img::<refl_tcrr_surfel>(&mut b, w, h);
    let mut refl_n = stats::<u32>(&mut b);
    let rows = b.rows(h);
    let kd = k.desc(None);
    let snap = surf.buf.snapshot();
    let sd = refl_image_tcrr_surfel_mut { data: surf.buf.ptr(), len: surf.buf.len(), width: surf.w, height: surf.h, stride: surf.stride };
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_tcrr_prepare(sd, refl_n.ptr(), &kd, rows) };
    null_rules_m(s, surf.buf.is_null(), surf.buf.is_null() || refl_n.is_null() || k.any_null(), refl_n.kind() == PtrKind::Misaligned, "refl_tcrr_prepare");
    let untouched = surf.buf.bytes() == &snap[..];
    // Known finding F7: an optional count/stats pointer that is misaligned
    // is refused only after the pass wrote its image.
    let f7 = !strict_for("F7") && refl_n.kind() == PtrKind::Misaligned;
    if !f7 {
        on_error_untouched(s, &[("surfels", untouched), ("out_reflective", refl_n.is_sentinel(0))], "refl_tcrr_prepare");
    }
    let prepared = s == refl_status::Ok && rows.begin == 0 && rows.end == h;
    if s == refl_status::Ok {
        assert!(k.valid() && surf.ok(w, h) && rows_ok(rows, h), "refl_tcrr_prepare accepted bad input");
        outside_untouched(&surf.buf, &snap, surf.w, surf.h, surf.stride, rows, "refl_tcrr_prepare outside its rows");
        let mut n = 0;
        for y in rows.begin..rows.end {
            for x in 0..w {
                let sf = surf.buf.get((y * surf.stride + x) as usize);
                assert!(sf.flags & !7 == 0, "surfel flags {:#x}", sf.flags);
                n += u32::from(sf.flags == 7);
            }
        }
        if refl_n.usable() {
            assert_eq!(refl_n.get(0), n, "refl_tcrr_prepare count vs surfels with all three flags");
        }
    } else if surf.ok(w, h) && k.valid() && rows_ok(rows, h) && refl_n.kind() != PtrKind::Misaligned {
        panic!("refl_tcrr_prepare refused valid input: {s:?}");
    }
    if !k.valid() {
        return;
    }
    let use_surfels = prepared && surf.stride == w && b.bool();

    // --- reset offsets
    let mut offs = out_img::<refl_vec2>(&mut b, w, h);
    let rows = b.rows(h);
    let snap = offs.buf.snapshot();
    let od = refl_image_vec2_mut { data: offs.buf.ptr(), len: offs.buf.len(), width: offs.w, height: offs.h, stride: offs.stride };
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_tcrr_reset_offsets(od, rows) };
    // F1's rule: a bad row range may be reported rather than a NULL data
    // pointer.
    let f1 = !rows_ok(rows, offs.h) && s == refl_status::InvalidArgument;
    null_rules(s, offs.buf.is_null() && !f1, offs.buf.is_null(), "refl_tcrr_reset_offsets");
    on_error_untouched(s, &[("offsets", offs.buf.bytes() == &snap[..])], "refl_tcrr_reset_offsets");
    if s == refl_status::Ok {
        assert!(rows_ok(rows, offs.h) && offs.buf.usable());
        outside_untouched(&offs.buf, &snap, offs.w, offs.h, offs.stride, rows, "refl_tcrr_reset_offsets outside its rows");
        for y in rows.begin..rows.end {
            for x in 0..offs.w {
                let o = offs.buf.get((y * offs.stride + x) as usize);
                assert!(o.x == f32::INFINITY && o.y == f32::INFINITY, "reset offset {o:?}");
            }
        }
    }
    if !(s == refl_status::Ok && rows.begin == 0 && rows.end == h && offs.ok(w, h) && offs.stride == w) {
        // Fill the offsets ourselves for the rest of the pipeline.
        offs = Img { buf: Buf::from_fn((w * h) as usize, PtrKind::Valid, |_| refl_vec2 { x: f32::INFINITY, y: f32::INFINITY }), w, h, stride: w };
    }

    // --- search
    let cur_cam = {
        let mut e = refl_vec3::default();
        // SAFETY: pointers valid.
        unsafe { refl_camera_eye(&mut e, &k.cam) };
        e
    };
    let eye = if b.chance(16) { b.vec3_in(-5.0, 5.0) } else { v3(cur_cam.x + b.f32_fine(-0.3, 0.3), cur_cam.y, cur_cam.z + b.f32_fine(-0.3, 0.3)) };
    let mut sst = stats::<refl_tcrr_search_stats>(&mut b);
    let rows = if b.chance(200) { refl_row_range { begin: 0, end: h } } else { b.rows(h) };
    let kd = k.desc(if use_surfels { Some(&surf.buf) } else { None });
    let snap = offs.buf.snapshot();
    let od = refl_image_vec2_mut { data: offs.buf.ptr(), len: offs.buf.len(), width: offs.w, height: offs.h, stride: offs.stride };
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_tcrr_search(od, sst.ptr(), &kd, eye, &p, rows) };
    null_rules_m(s, false, sst.is_null() || k.any_null(), sst.kind() == PtrKind::Misaligned, "refl_tcrr_search");
    let f7 = !strict_for("F7") && sst.kind() == PtrKind::Misaligned;
    if !f7 {
        on_error_untouched(s, &[("offsets", offs.buf.bytes() == &snap[..]), ("stats", sst.is_sentinel(0))], "refl_tcrr_search");
    }
    if s == refl_status::Ok {
        assert!(pvalid && finite3(eye) && rows_ok(rows, h), "refl_tcrr_search accepted bad input {p:?} {eye:?} {rows:?}");
        outside_untouched(&offs.buf, &snap, w, h, w, rows, "refl_tcrr_search outside its rows");
        if sst.usable() {
            let st = sst.get(0);
            let band = (rows.end - rows.begin) * w;
            assert!(st.matched + st.invalid <= st.reflective && st.reflective <= band, "search stats {st:?}");
        }
        if use_surfels {
            // "Same results" with the prepared surfels or without them.
            let mut again = Buf::from_slice(&offs.buf.to_vec(), PtrKind::Valid);
            let mut before = Buf::from_fn(0, PtrKind::Valid, |_| refl_vec2::default());
            let _ = &mut before;
            let snap_in: Vec<u8> = snap.clone();
            // Restart from the offsets the first search started from.
            for (i, c) in snap_in.chunks(8).enumerate() {
                again.set(i, refl_vec2 { x: f32::from_le_bytes([c[0], c[1], c[2], c[3]]), y: f32::from_le_bytes([c[4], c[5], c[6], c[7]]) });
            }
            let kd2 = k.desc(None);
            let od2 = refl_image_vec2_mut { data: again.ptr(), len: again.len(), width: w, height: h, stride: w };
            // SAFETY: valid pointers.
            let s2 = unsafe { refl_tcrr_search(od2, core::ptr::null_mut(), &kd2, eye, &p, rows) };
            assert_eq!(s2, refl_status::Ok, "search without surfels refused");
            assert!(again.bytes() == offs.buf.bytes(), "search with prepared surfels differs from on-the-fly");
        }
    } else if pvalid && finite3(eye) && rows_ok(rows, h) && sst.kind() != PtrKind::Misaligned {
        panic!("refl_tcrr_search refused valid input: {s:?}");
    }

    // --- shift
    let mut color = out_img::<refl_vec3>(&mut b, w, h);
    let mut depth = out_img::<f32>(&mut b, w, h);
    let mut cov = out_img::<u8>(&mut b, w, h);
    let mut shs = stats::<refl_tcrr_shift_stats>(&mut b);
    let rows = if b.chance(200) { refl_row_range { begin: 0, end: h } } else { b.rows(h) };
    let snaps = (color.buf.snapshot(), depth.buf.snapshot(), cov.buf.snapshot());
    let ov = refl_image_vec2 { data: offs.buf.cptr(), len: offs.buf.len(), width: w, height: h, stride: w };
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe {
        refl_tcrr_shift(
            refl_image_vec3_mut { data: color.buf.ptr(), len: color.buf.len(), width: color.w, height: color.h, stride: color.stride },
            refl_image_f32_mut { data: depth.buf.ptr(), len: depth.buf.len(), width: depth.w, height: depth.h, stride: depth.stride },
            refl_image_u8_mut { data: cov.buf.ptr(), len: cov.buf.len(), width: cov.w, height: cov.h, stride: cov.stride },
            shs.ptr(),
            &kd,
            ov,
            &p,
            rows,
        )
    };
    let null = color.buf.is_null() || depth.buf.is_null() || cov.buf.is_null();
    let mis = [color.buf.kind(), depth.buf.kind(), shs.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(s, null, null || shs.is_null() || k.any_null(), mis, "refl_tcrr_shift");
    let f7 = !strict_for("F7") && shs.kind() == PtrKind::Misaligned;
    if !f7 {
        on_error_untouched(
            s,
            &[
                ("color", color.buf.bytes() == &snaps.0[..]),
                ("depth", depth.buf.bytes() == &snaps.1[..]),
                ("coverage", cov.buf.bytes() == &snaps.2[..]),
                ("stats", shs.is_sentinel(0)),
            ],
            "refl_tcrr_shift",
        );
    }
    let shifted = s == refl_status::Ok;
    if shifted {
        assert!(pvalid && rows_ok(rows, h) && color.ok(w, h) && depth.ok(w, h) && cov.ok(w, h), "refl_tcrr_shift accepted bad input");
        outside_untouched(&color.buf, &snaps.0, w, h, color.stride, rows, "refl_tcrr_shift color outside its rows");
        outside_untouched(&depth.buf, &snaps.1, w, h, depth.stride, rows, "refl_tcrr_shift depth outside its rows");
        outside_untouched(&cov.buf, &snaps.2, w, h, cov.stride, rows, "refl_tcrr_shift coverage outside its rows");
        let mut covered = 0;
        for y in rows.begin..rows.end {
            let mut any = false;
            for x in 0..w {
                let c = cov.buf.get((y * cov.stride + x) as usize);
                assert!(c <= 2, "coverage value {c}");
                any |= c != 0;
                covered += u32::from(c != 0);
            }
            let _ = any;
        }
        if shs.usable() {
            let st = shs.get(0);
            assert!(st.covered <= (rows.end - rows.begin) * w, "shift stats {st:?}");
            assert_eq!(st.covered, covered, "shift stats covered vs coverage image");
        }
    } else if pvalid && rows_ok(rows, h) && color.ok(w, h) && depth.ok(w, h) && cov.ok(w, h) && shs.kind() != PtrKind::Misaligned {
        panic!("refl_tcrr_shift refused valid input: {s:?}");
    }

    // --- warp (current frame = key frame buffers, or a moved camera)
    let cur = refl_tcrr_current {
        camera: if b.chance(32) { camera(&mut b, w, h) } else { k.cam },
        convention: k.conv,
        depth: img_f32(&k.depth, w, h, w),
        specular: img_f32(&k.spec, w, h, w),
    };
    let src_ok = shifted && color.stride == w && depth.stride == w && cov.stride == w && rows.begin == 0 && rows.end == h;
    let (sc, sdp, scv) = if src_ok {
        (color.buf.to_vec(), depth.buf.to_vec(), cov.buf.to_vec())
    } else {
        let n = (w * h) as usize;
        (k.color.to_vec().into_iter().chain(core::iter::repeat(v3(0.0, 0.0, 0.0))).take(n).collect(), vec![3.0; n], vec![1u8; n])
    };
    let sc_b = Buf::from_slice(&sc, PtrKind::Valid);
    let sd_b = Buf::from_slice(&sdp, PtrKind::Valid);
    let scv_b = Buf::from_slice(&scv, PtrKind::Valid);
    let mut wc = out_img::<refl_vec3>(&mut b, w, h);
    let mut wm = out_img::<u8>(&mut b, w, h);
    let mut ws = stats::<refl_tcrr_warp_stats>(&mut b);
    let rows = if b.chance(200) { refl_row_range { begin: 0, end: h } } else { b.rows(h) };
    let snaps = (wc.buf.snapshot(), wm.buf.snapshot());
    let n = (w * h) as usize;
    let _ = SPECIAL_PAD;
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe {
        refl_tcrr_warp(
            refl_image_vec3_mut { data: wc.buf.ptr(), len: wc.buf.len(), width: wc.w, height: wc.h, stride: wc.stride },
            refl_image_u8_mut { data: wm.buf.ptr(), len: wm.buf.len(), width: wm.w, height: wm.h, stride: wm.stride },
            ws.ptr(),
            &cur,
            &kd,
            refl_image_vec3 { data: sc_b.cptr(), len: n.min(sc_b.len()), width: w, height: h, stride: w },
            refl_image_f32 { data: sd_b.cptr(), len: n.min(sd_b.len()), width: w, height: h, stride: w },
            refl_image_u8 { data: scv_b.cptr(), len: n.min(scv_b.len()), width: w, height: h, stride: w },
            &p,
            rows,
        )
    };
    let warp_err = last_error();
    let null = wc.buf.is_null() || wm.buf.is_null();
    let mis = [wc.buf.kind(), ws.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(s, null, null || ws.is_null() || k.any_null(), mis, "refl_tcrr_warp");
    let f7 = !strict_for("F7") && ws.kind() == PtrKind::Misaligned;
    if !f7 {
        on_error_untouched(
            s,
            &[("color", wc.buf.bytes() == &snaps.0[..]), ("mask", wm.buf.bytes() == &snaps.1[..]), ("stats", ws.is_sentinel(0))],
            "refl_tcrr_warp",
        );
    }
    if s == refl_status::Ok {
        assert!(pvalid && rows_ok(rows, h) && wc.ok(w, h) && wm.ok(w, h) && camera_ok(&cur.camera), "refl_tcrr_warp accepted bad input");
        outside_untouched(&wc.buf, &snaps.0, w, h, wc.stride, rows, "refl_tcrr_warp color outside its rows");
        outside_untouched(&wm.buf, &snaps.1, w, h, wm.stride, rows, "refl_tcrr_warp mask outside its rows");
        let (mut reused, mut retrace) = (0, 0);
        for y in rows.begin..rows.end {
            for x in 0..w {
                let m = wm.buf.get((y * wm.stride + x) as usize);
                assert!(m <= 2, "mask value {m}");
                reused += u32::from(m == 1);
                retrace += u32::from(m == 2);
            }
        }
        if ws.usable() {
            let st = ws.get(0);
            assert_eq!((st.reused, st.retrace), (reused, retrace), "warp stats vs mask");
            assert!(st.reused + st.retrace <= st.reflective, "warp stats {st:?}");
        }
        // --- retrace list over the mask (full frames only)
        if rows.begin == 0 && rows.end == h {
            let mk = refl_image_u8 { data: wm.buf.cptr(), len: wm.buf.len(), width: w, height: h, stride: wm.stride };
            let mut cnt = out1::<usize>(b.ptr_kind());
            let list_len = b.len_for(retrace as usize);
            let mut list = Buf::<u32>::sentinel(list_len, if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid });
            // SAFETY: NULL, misaligned or valid.
            let s = unsafe { refl_tcrr_retrace_list(list.ptr(), list_len, cnt.ptr(), mk) };
            null_rules_m(s, cnt.is_null(), cnt.is_null() || list.is_null(), list.kind() == PtrKind::Misaligned || cnt.kind() == PtrKind::Misaligned, "refl_tcrr_retrace_list");
            let lu = (0..list_len).all(|i| list.is_sentinel(i));
            on_error_untouched(s, &[("list", lu), ("count", cnt.is_sentinel(0))], "refl_tcrr_retrace_list");
            if s == refl_status::Ok {
                assert_eq!(cnt.get(0), retrace as usize, "retrace count");
                if !list.is_null() {
                    assert!(list_len >= retrace as usize, "short list accepted");
                    let mut prev = None;
                    for i in 0..retrace as usize {
                        let v = list.get(i);
                        let (x, y) = (v % w, v / w);
                        assert!(y < h && wm.buf.get((y * wm.stride + x) as usize) == 2, "listed pixel {v} is not RETRACE");
                        assert!(prev.is_none_or(|p| p < v), "retrace list not ascending");
                        prev = Some(v);
                    }
                    for i in retrace as usize..list_len {
                        assert!(list.is_sentinel(i), "retrace list wrote past its count");
                    }
                }
            } else if cnt.usable() && !list.is_null() && list.usable() {
                assert!(list_len < retrace as usize, "refl_tcrr_retrace_list refused: {s:?}");
                assert_eq!(s, refl_status::InsufficientSize);
            }
        }
    } else if pvalid && rows_ok(rows, h) && wc.ok(w, h) && wm.ok(w, h) && camera_ok(&cur.camera) && (cur.camera.width, cur.camera.height) == (w, h) && ws.kind() != PtrKind::Misaligned {
        panic!("refl_tcrr_warp refused valid input: {s:?}: {warp_err}");
    }

    // --- compose
    let mut out = out_img::<refl_vec3>(&mut b, w, h);
    let diffuse: Vec<refl_vec3> = (0..n).map(|i| v3(0.2, 0.2 + (i % 3) as f32 * 0.1, 0.1)).collect();
    let reflection: Vec<refl_vec3> = (0..n).map(|i| v3(0.9, 0.1, (i % 2) as f32)).collect();
    let db = Buf::from_slice(&diffuse, PtrKind::Valid);
    let rb = Buf::from_slice(&reflection, PtrKind::Valid);
    let fres = if b.chance(16) { b.u32() } else { b.below(2) };
    let rows = b.rows(h);
    let snap = out.buf.snapshot();
    let im = |bb: &Buf<refl_vec3>| refl_image_vec3 { data: bb.cptr(), len: bb.len(), width: w, height: h, stride: w };
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe {
        refl_tcrr_compose(
            refl_image_vec3_mut { data: out.buf.ptr(), len: out.buf.len(), width: out.w, height: out.h, stride: out.stride },
            im(&db),
            im(&rb),
            kd.normal,
            &cur,
            fres,
            rows,
        )
    };
    null_rules(s, out.buf.is_null(), out.buf.is_null() || k.any_null(), "refl_tcrr_compose");
    on_error_untouched(s, &[("out", out.buf.bytes() == &snap[..])], "refl_tcrr_compose");
    if s == refl_status::Ok {
        assert!(fres <= 1 && rows_ok(rows, h) && out.ok(w, h), "refl_tcrr_compose accepted bad input");
        outside_untouched(&out.buf, &snap, w, h, out.stride, rows, "refl_tcrr_compose outside its rows");
        for y in rows.begin..rows.end {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let o = out.buf.get((y * out.stride + x) as usize);
                let sp = k.spec.get(i);
                // F9 (the header corrected): the blend only where the
                // current depth holds a surface, diffuse elsewhere.
                let z = decode(&cur.camera, k.depth.get(i), cur.convention);
                let mut p = refl_vec3::default();
                let center = refl_vec2 { x: x as f32 + 0.5, y: y as f32 + 0.5 };
                // SAFETY: pointers valid.
                let point_ok = unsafe { refl_camera_unproject(&mut p, &cur.camera, center, k.depth.get(i), cur.convention) } == refl_status::Ok;
                let surface = point_ok && z.is_some_and(|z| z > 0.0 && z.is_finite() && z < cur.camera.z_far);
                if !surface || !(sp > 0.0) {
                    assert!(o == diffuse[i], "non-reflective pixel ({x}, {y}) composed to {o:?}");
                } else if fres == 0 {
                    let wgt = sp.clamp(0.0, 1.0);
                    let want = [
                        (1.0 - wgt) * diffuse[i].x + wgt * reflection[i].x,
                        (1.0 - wgt) * diffuse[i].y + wgt * reflection[i].y,
                        (1.0 - wgt) * diffuse[i].z + wgt * reflection[i].z,
                    ];
                    assert!(
                        close(o.x, want[0], 1e-5) && close(o.y, want[1], 1e-5) && close(o.z, want[2], 1e-5),
                        "composed ({x}, {y}) = {o:?}, want {want:?}"
                    );
                }
            }
        }
    }
});
