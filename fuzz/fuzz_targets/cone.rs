//! Glossy cone tracing (seed 004): `refl_cone_angle_from_phong`,
//! `refl_cone_angle_from_roughness`, `refl_cone_pyramid_len`,
//! `refl_cone_build_color(_rows)`, `refl_cone_build_visibility(_rows)`,
//! `refl_cone_options_default`, `refl_cone_multiray_options_default`, `refl_cone_trace`, `refl_cone_fade`,
//! `refl_cone_multiray`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const HALF_PI: f32 = core::f32::consts::FRAC_PI_2;

fn hiz_layout(w: u32, h: u32) -> Option<(usize, u32)> {
    let (mut n, mut l) = (0usize, 0u32);
    // SAFETY: pointers valid.
    (unsafe { refl_hiz_len(&mut n, &mut l, w, h) } == refl_status::Ok).then_some((n, l))
}

fn level(w: u32, h: u32, l: u32) -> Option<refl_hiz_level_info> {
    let mut o = refl_hiz_level_info::default();
    // SAFETY: pointer valid.
    (unsafe { refl_hiz_level(&mut o, w, h, l) } == refl_status::Ok).then_some(o)
}

/// (color texels, visibility floats) of a `w x h` frame's pyramids.
fn pyramid_len(w: u32, h: u32) -> Option<(usize, usize)> {
    let (mut c, mut v) = (0usize, 0usize);
    // SAFETY: pointers valid.
    (unsafe { refl_cone_pyramid_len(&mut c, &mut v, w, h) } == refl_status::Ok).then_some((c, v))
}

fn angles(b: &mut Bytes) {
    let p = match b.u8() % 4 {
        0 => b.f32_special(),
        1 => f32::INFINITY,
        _ => b.f32_fine(0.0, 3000.0),
    };
    let mut o = out1::<f32>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_cone_angle_from_phong(o.ptr(), p) };
    null_rules(s, o.is_null(), o.is_null(), "refl_cone_angle_from_phong");
    on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_cone_angle_from_phong");
    if o.usable() {
        assert_eq!(s == refl_status::Ok, p >= 0.0, "angle_from_phong({p}): {s:?}");
    }
    if s == refl_status::Ok {
        let a = o.get(0);
        assert!(a.is_finite() && (0.0..HALF_PI).contains(&a), "angle_from_phong({p}) = {a}");
        if p == f32::INFINITY {
            assert_eq!(a, 0.0);
        }
        // Non-increasing in the power.
        let mut a2 = 0.0f32;
        let p2 = p * 2.0 + 1.0;
        // SAFETY: pointer valid.
        assert_eq!(unsafe { refl_cone_angle_from_phong(&mut a2, p2) }, refl_status::Ok);
        assert!(a2 <= a + 1e-6, "angle_from_phong not monotone: {p} -> {a}, {p2} -> {a2}");
    }
    let r = b.f32_in(-0.1, 1.1);
    let mut o = out1::<f32>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_cone_angle_from_roughness(o.ptr(), r) };
    null_rules(s, o.is_null(), o.is_null(), "refl_cone_angle_from_roughness");
    on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_cone_angle_from_roughness");
    if o.usable() {
        assert_eq!(s == refl_status::Ok, (0.0..=1.0).contains(&r), "angle_from_roughness({r}): {s:?}");
    }
    if s == refl_status::Ok {
        let a = o.get(0);
        assert!(a.is_finite() && (0.0..HALF_PI).contains(&a), "angle_from_roughness({r}) = {a}");
    }
}

fn fade(b: &mut Bytes) {
    let range = |b: &mut Bytes| {
        let s = b.f32_in(-1.0, 2.0);
        let end = if b.chance(16) { b.f32_any() } else { s + b.f32_fine(0.01, 2.0) };
        refl_cone_fade_range { enabled: b.u8() & 1 == 1, start: s, end }
    };
    let f = refl_cone_fades { toward_camera: range(b), border: range(b), travel: range(b) };
    let (r, e) = (b.dir3(), b.dir3());
    let (w, h) = (b.side(MAX_SIDE), b.side(MAX_SIDE));
    let hit = b.vec2_in(-2.0, MAX_SIDE as f32 + 2.0);
    let t = b.f32_in(0.0, 20.0);
    let fb = Buf::from_slice(&[f], b.ptr_kind());
    let mut o = out1::<f32>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_cone_fade(o.ptr(), fb.cptr(), r, e, hit, w, h, t) };
    let null = o.is_null() || fb.is_null();
    null_rules_m(s, null, null, o.kind() == PtrKind::Misaligned || fb.kind() == PtrKind::Misaligned, "refl_cone_fade");
    on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_cone_fade");
    if s == refl_status::Ok {
        for rg in [f.toward_camera, f.border, f.travel] {
            if rg.enabled {
                assert!(rg.start.is_finite() && rg.end.is_finite() && rg.end > rg.start, "fade accepted range {rg:?}");
            }
        }
        let v = o.get(0);
        assert!((0.0..=1.0).contains(&v), "fade factor {v}");
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    if b.chance(32) {
        angles(&mut b);
        fade(&mut b);
    }
    // Pyramid sizes: the Hi-Z layout's levels.
    {
        let (w, h) = (b.side(300), b.side(300));
        let mut o = out1::<usize>(b.ptr_kind());
        let mut ov = out1::<usize>(b.ptr_kind());
        // SAFETY: NULL, misaligned or valid.
        let s = unsafe { refl_cone_pyramid_len(o.ptr(), ov.ptr(), w, h) };
        let null = o.is_null() || ov.is_null();
        null_rules_m(s, null, null, o.kind() == PtrKind::Misaligned || ov.kind() == PtrKind::Misaligned, "refl_cone_pyramid_len");
        on_error_untouched(s, &[("out_color_len", o.is_sentinel(0)), ("out_visibility_len", ov.is_sentinel(0))], "refl_cone_pyramid_len");
        if s == refl_status::Ok {
            // The Hi-Z layout's levels, then the stamp.
            let (_, lv) = hiz_layout(w, h).expect("hiz_len of a cone pyramid size");
            let end = level(w, h, lv - 1).unwrap().offset + 1;
            assert_eq!(o.get(0), end + REFL_CONE_COLOR_STAMP_TEXELS, "color pyramid length");
            assert_eq!(ov.get(0), end + REFL_CONE_VISIBILITY_STAMP_LEN, "visibility pyramid length");
        } else if o.usable() && ov.usable() && w > 0 && h > 0 && w < 1 << 20 && h < 1 << 20 {
            panic!("refl_cone_pyramid_len({w}, {h}) refused: {s:?}");
        }
    }
    let img = depth_image(&mut b);
    let (w, h) = (img.width, img.height);
    if !img.valid() {
        return;
    }
    // Hi-Z of the image.
    let (hl, levels) = hiz_layout(w, h).unwrap();
    let mut hz = Buf::<refl_vec2>::sentinel(hl, PtrKind::Valid);
    let desc = img.desc();
    // SAFETY: valid pointers.
    assert_eq!(unsafe { refl_hiz_build(hz.ptr(), hl, &desc) }, refl_status::Ok);
    let hiz = refl_hiz { data: hz.cptr(), len: hl, camera: img.cam, convention: img.conv };
    let (pl, pvl) = pyramid_len(w, h).unwrap();
    // Texels of the levels (the stamp follows).
    let lend = level(w, h, levels - 1).unwrap().offset + 1;

    // Color pyramid.
    let cmode = b.u8();
    let stride = if b.chance(32) { b.stride(w) } else { w };
    let cimg = image_buf(&mut b, w, h, stride, |x, y| {
        if cmode < 8 { v3(f32::NAN, 0.0, 0.0) } else { v3((x % 5) as f32 * 0.2, (y % 3) as f32 * 0.3, 0.5) }
    }, v3(9.0, 9.0, 9.0));
    let ci = refl_image_vec3 { data: cimg.cptr(), len: cimg.len(), width: w, height: h, stride };
    let sigma = if b.chance(16) { b.f32_any() } else { b.f32_fine(0.3, 2.0) };
    let dl = b.len_for(pl);
    let mut color = Buf::<refl_vec3>::sentinel(dl, b.ptr_kind());
    let cb = Buf::from_slice(&[ci], b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_cone_build_color(color.ptr(), dl, cb.cptr(), sigma) };
    let null = color.is_null() || cb.is_null() || cimg.is_null();
    null_rules_m(s, null, null, [color.kind(), cb.kind(), cimg.kind()].contains(&PtrKind::Misaligned), "refl_cone_build_color");
    on_error_untouched(s, &[("dst", (0..dl).all(|i| color.is_sentinel(i)))], "refl_cone_build_color");
    let color_ok = s == refl_status::Ok;
    if color_ok {
        assert!(sigma > 0.0 && sigma.is_finite() && dl >= pl, "build_color accepted sigma {sigma} / len {dl}");
        for i in pl..dl {
            assert!(color.is_sentinel(i), "build_color wrote past the pyramid");
        }
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for y in 0..h {
            for x in 0..w {
                let t = cimg.get((y * stride + x) as usize);
                let c = color.get((y * w + x) as usize);
                assert!(c == t, "color level 0 ({x}, {y}) {c:?} is not the image's {t:?}");
                for (a, v) in [t.x, t.y, t.z].iter().enumerate() {
                    lo[a] = lo[a].min(*v);
                    hi[a] = hi[a].max(*v);
                }
            }
        }
        // Normalized blurs stay within the image's range.
        for i in (w * h) as usize..lend {
            let c = color.get(i);
            for (a, v) in [c.x, c.y, c.z].iter().enumerate() {
                assert!(*v >= lo[a] - 1e-4 && *v <= hi[a] + 1e-4, "color texel {i} channel {a} = {v} outside [{}, {}]", lo[a], hi[a]);
            }
        }
        // Level by level in bands: the same pyramid.
        if b.chance(64) {
            let mut rows = Buf::<refl_vec3>::sentinel(pl, PtrKind::Valid);
            for k in 0..levels {
                let lv = level(w, h, k).unwrap();
                let mut y = 0;
                while y < lv.height {
                    let n = 1 + b.below(lv.height - y);
                    // SAFETY: valid pointers.
                    let s = unsafe { refl_cone_build_color_rows(rows.ptr(), pl, &ci, k, refl_row_range { begin: y, end: y + n }, sigma) };
                    assert_eq!(s, refl_status::Ok, "build_color_rows(level {k}, {y}..{})", y + n);
                    y += n;
                }
            }
            assert!(rows.bytes() == color.bytes().get(..pl * 12).unwrap(), "banded color pyramid differs");
        }
    } else if !null && color.usable() && cb.usable() && cimg.usable() && cmode >= 8 && sigma > 0.0 && sigma.is_finite() && dl >= pl
        && required_len(w, h, stride).is_some_and(|n| cimg.len() >= n)
    {
        panic!("refl_cone_build_color refused valid input: {s:?}");
    }

    // Visibility pyramid.
    let vl = b.len_for(pvl);
    let mut vis = Buf::<f32>::sentinel(vl, b.ptr_kind());
    let hb = Buf::from_slice(&[hiz], b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_cone_build_visibility(vis.ptr(), vl, hb.cptr()) };
    let null = vis.is_null() || hb.is_null();
    null_rules_m(s, null, null, vis.kind() == PtrKind::Misaligned || hb.kind() == PtrKind::Misaligned, "refl_cone_build_visibility");
    on_error_untouched(s, &[("dst", (0..vl).all(|i| vis.is_sentinel(i)))], "refl_cone_build_visibility");
    let vis_ok = s == refl_status::Ok;
    if vis_ok {
        assert!(vl >= pvl);
        for i in 0..lend {
            let v = vis.get(i);
            assert!((0.0..=1.0).contains(&v), "visibility texel {i} = {v}");
            if i < (w * h) as usize {
                assert!(v == 0.0 || v == 1.0, "visibility level 0 texel {i} = {v}");
                if hz.get(i).x.is_nan() {
                    assert_eq!(v, 0.0, "visibility 1 where the Hi-Z has no surface");
                }
            }
        }
        for i in pvl..vl {
            assert!(vis.is_sentinel(i), "build_visibility wrote past the pyramid");
        }
        if b.chance(64) {
            let mut rows = Buf::<f32>::sentinel(pvl, PtrKind::Valid);
            for k in 0..levels {
                let lv = level(w, h, k).unwrap();
                let mut y = 0;
                while y < lv.height {
                    let n = 1 + b.below(lv.height - y);
                    // SAFETY: valid pointers.
                    let s = unsafe { refl_cone_build_visibility_rows(rows.ptr(), pvl, &hiz, k, refl_row_range { begin: y, end: y + n }) };
                    assert_eq!(s, refl_status::Ok);
                    y += n;
                }
            }
            for i in 0..pvl {
                let (a, c) = (rows.get(i), vis.get(i));
                let same = if i < lend { same_f32(a, c) } else { a.to_bits() == c.to_bits() };
                assert!(same, "banded visibility texel {i} differs: {a} vs {c}");
            }
        }
    } else if vis.usable() && hb.usable() && vl >= pvl {
        panic!("refl_cone_build_visibility refused a built Hi-Z: {s:?}");
    }
    if !(color_ok && vis_ok) {
        return;
    }
    let pyr = refl_cone_pyramids { hiz, color: color.cptr(), color_len: dl, visibility: vis.cptr(), visibility_len: vl };

    // Cone trace.
    let mut opts = refl_cone_options_default();
    if b.chance(64) {
        match b.u8() % 6 {
            0 => opts.max_circles = b.pick(&[0, 1, 64, 65, u32::MAX]),
            1 => opts.level_bias = b.f32_any(),
            2 => opts.use_visibility = b.u8() & 1 == 1,
            3 => opts.max_stretch = b.f32_any(),
            4 => opts.depth_tolerance = b.f32_any(),
            _ => opts.normalize = b.u8() & 1 == 1,
        }
    }
    let (wf, hf) = (w as f32, h as f32);
    let cone = refl_cone {
        apex: b.vec2_in(0.0, wf.max(hf)),
        apex_depth: b.f32_in(0.1, 20.0),
        hit: b.vec2_in(0.0, wf.max(hf)),
        hit_depth: b.f32_in(0.1, 20.0),
        theta: b.f32_in(0.0, 1.7),
        n_dot_v: b.f32_in(0.0, 1.0),
        travel: b.f32_in(0.0, 10.0),
    };
    let fallback = if b.chance(16) { v3(b.f32_any(), 0.0, 0.0) } else { v3(0.1, 0.2, 0.3) };
    let mut o = out1::<refl_cone_result>(b.ptr_kind());
    let cb = Buf::from_slice(&[cone], b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_cone_trace(o.ptr(), &pyr, cb.cptr(), fallback, &opts) };
    let null = o.is_null() || cb.is_null();
    null_rules_m(s, null, null, o.kind() == PtrKind::Misaligned || cb.kind() == PtrKind::Misaligned, "refl_cone_trace");
    on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_cone_trace");
    if s == refl_status::Ok {
        let r = o.get(0);
        assert!(cone.theta >= 0.0 && cone.theta < HALF_PI && cone.apex_depth > 0.0 && cone.hit_depth > 0.0, "cone_trace accepted {cone:?}");
        assert!(finite3(fallback), "cone_trace accepted fallback {fallback:?}");
        assert!((0.0..=1.0).contains(&r.coverage), "coverage {}", r.coverage);
        assert!(finite3(r.color), "cone color {:?}", r.color);
        assert!(r.circles <= opts.max_circles.min(64), "{} circles, max {}", r.circles, opts.max_circles);
    }

    // Multi-ray.
    let th = thickness(&mut b, &img);
    let ray = ray_for(&mut b, &img);
    let tm = t_max(&mut b);
    let normal = if b.chance(16) { b.vec3_in(-1.0, 1.0) } else { v3(0.0, 1.0, 0.0) };
    let theta = b.f32_in(0.0, 1.6);
    let power = b.f32_in(0.0, 100.0);
    // The documented defaults: 8 rays, no rotation, the Hi-Z defaults.
    let md = refl_cone_multiray_options_default();
    let hd = refl_hiz_options_default();
    assert!(
        md.rays == 8
            && md.rotation.x == 0.0
            && md.rotation.y == 0.0
            && [md.hiz.start_level, md.hiz.stop_level, md.hiz.max_iterations, md.hiz.prologue_steps]
                == [hd.start_level, hd.stop_level, hd.max_iterations, hd.prologue_steps],
        "multi-ray defaults {md:?}"
    );
    let mo = if b.chance(32) {
        md
    } else {
        refl_cone_multiray_options {
            rays: if b.chance(16) { b.pick(&[0, 65, 200]) } else { 1 + b.below(12) },
            rotation: b.vec2_in(0.0, 1.0),
            hiz: refl_hiz_options {
                start_level: b.below(6),
                stop_level: b.below(3),
                max_iterations: if b.chance(16) { b.below(4) } else { 1024 },
                prologue_steps: b.below(8),
            },
        }
    };
    let mut o = out1::<refl_cone_multiray_result>(b.ptr_kind());
    let mb = Buf::from_slice(&[mo], b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_cone_multiray(o.ptr(), &pyr, &th.desc, ray, normal, tm, theta, power, mb.cptr(), fallback) };
    let null = o.is_null() || mb.is_null();
    null_rules_m(s, null, null, o.kind() == PtrKind::Misaligned || mb.kind() == PtrKind::Misaligned, "refl_cone_multiray");
    on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_cone_multiray");
    if s == refl_status::Ok {
        let r = o.get(0);
        assert!(mo.rays > 0 && theta >= 0.0 && theta < HALF_PI && power >= 0.0, "multiray accepted bad input");
        assert!(r.traced <= mo.rays && r.hits <= r.traced, "multiray counts {r:?}");
        assert!(finite3(r.color), "multiray color {:?}", r.color);
    }
});
