//! Hi-Z pyramid: `refl_hiz_len`, `refl_hiz_level`, `refl_hiz_options_default`,
//! `refl_hiz_build`, `refl_hiz_build_rows` (level by level in fuzzed bands),
//! `refl_hiz_trace_ray` and `refl_hiz_trace_rays` against built and fuzzed
//! pyramids, another camera, short buffers, aliasing.
//!
//! Sizes always come from `refl_hiz_len` / `refl_hiz_level`, so a pyramid
//! with trailing texels beyond its levels (e.g. a record of the camera it
//! was built for) is handled.
#![no_main]

use core::mem::size_of;
use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

fn layout(w: u32, h: u32) -> Option<(usize, u32)> {
    let (mut n, mut l) = (0usize, 0u32);
    // SAFETY: pointers valid.
    (unsafe { refl_hiz_len(&mut n, &mut l, w, h) } == refl_status::Ok).then_some((n, l))
}

fn level(w: u32, h: u32, l: u32) -> Option<refl_hiz_level_info> {
    let mut o = refl_hiz_level_info::default();
    // SAFETY: pointer valid.
    (unsafe { refl_hiz_level(&mut o, w, h, l) } == refl_status::Ok).then_some(o)
}

fn check_layout(b: &mut Bytes) {
    let w = match b.u8() % 4 {
        0 => b.u32(),
        _ => b.side(300),
    };
    let h = match b.u8() % 4 {
        0 => b.u32(),
        _ => b.side(300),
    };
    let mut n = out1::<usize>(b.ptr_kind());
    let mut l = out1::<u32>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_hiz_len(n.ptr(), l.ptr(), w, h) };
    let null = n.is_null() || l.is_null();
    let mis = n.kind() == PtrKind::Misaligned || l.kind() == PtrKind::Misaligned;
    null_rules_m(s, null, null, mis, "refl_hiz_len");
    on_error_untouched(s, &[("out_len", n.is_sentinel(0)), ("out_levels", l.is_sentinel(0))], "refl_hiz_len");
    if !(n.usable() && l.usable()) {
        assert!(s != refl_status::Ok);
        return;
    }
    if w == 0 || h == 0 {
        assert_eq!(s, refl_status::InvalidArgument, "refl_hiz_len({w}, {h})");
        return;
    }
    let levels_n = 32 - w.max(h).leading_zeros();
    let total: u128 = (0..levels_n).map(|k| u128::from((w >> k).max(1)) * u128::from((h >> k).max(1))).sum();
    if total > usize::MAX as u128 {
        assert_eq!(s, refl_status::InvalidArgument, "refl_hiz_len({w}, {h}): {total} texels");
        return;
    }
    assert_eq!(s, refl_status::Ok, "refl_hiz_len({w}, {h})");
    let (len, levels) = (n.get(0), l.get(0));
    // Levels halve (rounding down, at least 1) down to 1 x 1.
    let want_levels = 32 - w.max(h).leading_zeros();
    assert_eq!(levels, want_levels, "refl_hiz_len({w}, {h}) levels");
    let mut off = 0u128;
    for k in 0..levels.min(40) {
        let lv = level(w, h, k).unwrap_or_else(|| panic!("refl_hiz_level({w}, {h}, {k}) refused"));
        assert_eq!((lv.width, lv.height), ((w >> k).max(1), (h >> k).max(1)), "level {k} size");
        assert_eq!(lv.offset as u128, off, "level {k} offset");
        off += u128::from(lv.width) * u128::from(lv.height);
    }
    let last = level(w, h, levels - 1).expect("last level");
    assert_eq!((last.width, last.height), (1, 1), "last level is not 1x1");
    assert!(len as u128 >= off, "refl_hiz_len {len} below the levels' {off} texels");
    assert!(level(w, h, levels).is_none(), "refl_hiz_level past the last level accepted");
    let mut o = out1::<refl_hiz_level_info>(b.ptr_kind());
    let k = b.below(levels + 2);
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_hiz_level(o.ptr(), w, h, k) };
    null_rules(s, o.is_null(), o.is_null(), "refl_hiz_level");
    on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_hiz_level");
}

/// Hi-Z texels of a built pyramid: every texel bounds the texels under it.
fn check_pyramid(p: &[refl_vec2], img: &DepthImg) {
    let (w, h) = (img.width, img.height);
    let (_, levels) = layout(w, h).expect("layout");
    // Level 0: the decoded linear depth, NaN for no surface (NaN or <= 0).
    for y in 0..h {
        for x in 0..w {
            let t = p[(y * w + x) as usize];
            let want = decode(&img.cam, img.texel(x, y), img.conv).filter(|z| *z > 0.0);
            match want {
                Some(z) => assert!(
                    same_f32(t.x, z) && same_f32(t.y, z),
                    "Hi-Z level 0 texel ({x}, {y}) = {t:?}, depth decodes to {z}"
                ),
                None => assert!(t.x.is_nan() && t.y.is_nan(), "Hi-Z level 0 texel ({x}, {y}) = {t:?} has no surface"),
            }
        }
    }
    for k in 1..levels {
        let f = level(w, h, k - 1).unwrap();
        let c = level(w, h, k).unwrap();
        let mut covered = vec![false; (c.width * c.height) as usize];
        for y in 0..f.height {
            for x in 0..f.width {
                let child = p[f.offset + (y * f.width + x) as usize];
                let (px, py) = ((x / 2).min(c.width - 1), (y / 2).min(c.height - 1));
                let pi = (py * c.width + px) as usize;
                let parent = p[c.offset + pi];
                if child.x.is_nan() {
                    continue;
                }
                covered[pi] = true;
                assert!(
                    parent.x <= child.x && parent.y >= child.y,
                    "Hi-Z level {k} texel ({px}, {py}) = {parent:?} does not bound ({x}, {y}) = {child:?}"
                );
            }
        }
        for (i, cv) in covered.iter().enumerate() {
            let t = p[c.offset + i];
            if !cv {
                assert!(t.x.is_nan() && t.y.is_nan(), "Hi-Z level {k} texel {i} = {t:?} over no surface");
            } else {
                assert!(t.x <= t.y, "Hi-Z texel {t:?}: min above max");
            }
        }
    }
}

/// Builds with `refl_hiz_build`; returns the pyramid on success.
fn build(b: &mut Bytes, img: &DepthImg) -> Option<Vec<refl_vec2>> {
    // The buffer is capped at 2^14 texels; `real` is what refl needs (a
    // 1x65536 image needs more than the cap: a campaign finding on 47b5e36
    // whose refusal was right).
    let real = layout(img.width, img.height).map(|(n, _)| n);
    let need = real.unwrap_or(16).min(1 << 14);
    let len = b.len_for(need);
    let mut dst = Buf::<refl_vec2>::sentinel(len, b.ptr_kind());
    let desc = img.desc();
    let ib = Buf::from_slice(&[desc], b.ptr_kind());
    let snap = img.buf.snapshot();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_hiz_build(dst.ptr(), len, ib.cptr()) };
    img.buf.assert_unchanged(&snap, "refl_hiz_build: depth image");
    let null = dst.is_null() || ib.is_null() || img.buf.is_null();
    let mis = [dst.kind(), ib.kind(), img.buf.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(s, null, null, mis, "refl_hiz_build");
    let untouched = (0..len).all(|i| dst.is_sentinel(i));
    on_error_untouched(s, &[("dst", untouched)], "refl_hiz_build");
    let ptrs_ok = dst.usable() && ib.usable();
    if s != refl_status::Ok {
        if ptrs_ok && img.valid() && real.is_some_and(|r| len >= r) {
            panic!("refl_hiz_build refused a valid image: {s:?}");
        }
        return None;
    }
    assert!(ptrs_ok && img.valid(), "refl_hiz_build accepted an invalid image");
    assert!(len >= need, "refl_hiz_build accepted dst_len {len} < refl_hiz_len {need}");
    // Texels past refl_hiz_len are not written.
    for i in need..len {
        assert!(dst.is_sentinel(i), "refl_hiz_build wrote texel {i} past refl_hiz_len {need}");
    }
    let p = dst.to_vec();
    check_pyramid(&p, img);
    Some(p[..need].to_vec())
}

/// Builds level by level in fuzzed row bands with `refl_hiz_build_rows`
/// and compares with `refl_hiz_build`'s pyramid.
fn build_rows(b: &mut Bytes, img: &DepthImg, whole: &[refl_vec2]) {
    let Some((need, levels)) = layout(img.width, img.height) else { return };
    let mut dst = Buf::<refl_vec2>::sentinel(need, PtrKind::Valid);
    let desc = img.desc();
    for k in 0..levels {
        let lv = level(img.width, img.height, k).unwrap();
        let mut y = 0;
        while y < lv.height {
            let n = 1 + b.below(lv.height - y);
            // Sometimes a bad request first: nothing may change.
            if b.chance(24) {
                let snap = dst.snapshot();
                let (bk, r0, r1) = match b.u8() % 4 {
                    0 => (levels + b.below(3), 0, 1),
                    1 => (k, y + n, y),
                    2 => (k, y, y),
                    _ => (k, y, lv.height + 1 + b.below(3)),
                };
                // SAFETY: valid pointers.
                let s = unsafe { refl_hiz_build_rows(dst.ptr(), need, &desc, bk, refl_row_range { begin: r0, end: r1 }) };
                no_panic(s, "refl_hiz_build_rows");
                assert_eq!(s, refl_status::InvalidArgument, "refl_hiz_build_rows(level {bk}, {r0}..{r1})");
                dst.assert_unchanged(&snap, "refl_hiz_build_rows after an error");
            }
            let snap = dst.snapshot();
            // SAFETY: valid pointers.
            let s = unsafe { refl_hiz_build_rows(dst.ptr(), need, &desc, k, refl_row_range { begin: y, end: y + n }) };
            assert_eq!(s, refl_status::Ok, "refl_hiz_build_rows(level {k}, {y}..{})", y + n);
            // Only the band's texels changed (and, when the last level is
            // built, the texels after the levels: the pyramid's stamp).
            let band = lv.offset + (y * lv.width) as usize..lv.offset + ((y + n) * lv.width) as usize;
            let levels_end = level(img.width, img.height, levels - 1).unwrap().offset + 1;
            for i in 0..need {
                let stamp = k + 1 == levels && i >= levels_end;
                if !band.contains(&i) && !stamp {
                    dst.assert_texel_unchanged(&snap, i, &format!("refl_hiz_build_rows(level {k}, rows {y}..{}) of {}x{} outside its band {band:?}", y + n, img.width, img.height));
                }
            }
            y += n;
        }
    }
    // "The result equals refl_hiz_build's" (stamp texels bit for bit).
    let (_, lv) = layout(img.width, img.height).unwrap();
    let end = level(img.width, img.height, lv - 1).unwrap().offset + 1;
    for i in 0..need {
        let (a, c) = (dst.get(i), whole[i]);
        let same = if i < end {
            same_f32(a.x, c.x) && same_f32(a.y, c.y)
        } else {
            a.x.to_bits() == c.x.to_bits() && a.y.to_bits() == c.y.to_bits()
        };
        assert!(same, "banded build texel {i}: {a:?} vs {c:?}");
    }
}

fn hiz_options(b: &mut Bytes) -> refl_hiz_options {
    let mut o = refl_hiz_options_default();
    if b.chance(160) {
        o.start_level = match b.u8() % 4 {
            0 => b.u32(),
            _ => b.below(8),
        };
        o.stop_level = match b.u8() % 4 {
            0 => b.u32(),
            _ => b.below(8),
        };
        o.max_iterations = match b.u8() % 4 {
            0 => b.below(4),
            1 => u32::MAX,
            _ => 1 + b.below(4096),
        };
        o.prologue_steps = match b.u8() % 4 {
            0 => u32::MAX,
            _ => b.below(16),
        };
    }
    o
}

struct Trace<'a> {
    img: &'a DepthImg,
    th: &'a Thick,
    built: bool,
    data: Buf<refl_vec2>,
    hiz: refl_hiz,
}

fn trace_one(b: &mut Bytes, t: &Trace, opts: &refl_hiz_options) {
    let ray = ray_for(b, t.img);
    let tm = t_max(b);
    let mut out = out1::<refl_trace_result>(b.ptr_kind());
    let hb = Buf::from_slice(&[t.hiz], b.ptr_kind());
    let thb = Buf::from_slice(&[t.th.desc], b.ptr_kind());
    let ob = Buf::from_slice(&[*opts], b.ptr_kind());
    let snap = t.data.snapshot();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_hiz_trace_ray(out.ptr(), hb.cptr(), thb.cptr(), ray, tm, ob.cptr()) };
    t.data.assert_unchanged(&snap, "refl_hiz_trace_ray: pyramid");
    let null = [out.is_null(), hb.is_null(), thb.is_null(), ob.is_null(), t.data.is_null()].contains(&true);
    let mis = [out.kind(), hb.kind(), thb.kind(), ob.kind(), t.data.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(s, null, null, mis, "refl_hiz_trace_ray");
    on_error_untouched(s, &[("out", out.is_sentinel(0))], "refl_hiz_trace_ray");
    let ptrs_ok = [out.kind(), hb.kind(), thb.kind(), ob.kind()].iter().all(|k| *k == PtrKind::Valid);
    let same_cam = t.hiz.camera == t.img.cam && t.hiz.convention == t.img.conv;
    let must = ptrs_ok && t.built && same_cam && t.th.valid(t.img.width, t.img.height) && ray_valid(&ray, tm) == Some(true);
    if s != refl_status::Ok {
        assert!(!must, "refl_hiz_trace_ray refused valid input: {s:?} {ray:?} {tm}");
        return;
    }
    assert!(ptrs_ok && camera_ok(&t.hiz.camera) && t.hiz.convention <= 2, "refl_hiz_trace_ray accepted invalid input");
    assert!(ray_valid(&ray, tm) != Some(false), "refl_hiz_trace_ray accepted an invalid ray {ray:?} / {tm}");
    let r = out.get(0);
    check_trace(&r, &ray, tm, &t.hiz.camera, true, "refl_hiz_trace_ray");
    if !(t.built && same_cam) {
        return;
    }
    // "The first hit agrees with refl_step_ray within a pixel."
    let desc = t.img.desc();
    let so = refl_step_options {
        stride: 1,
        max_steps: u32::MAX,
    };
    let mut sr = sentinel_trace();
    // SAFETY: pointers valid.
    let ss = unsafe { refl_step_ray(&mut sr, &desc, &t.th.desc, ray, tm, &so) };
    assert_eq!(ss, refl_status::Ok, "refl_step_ray refuses what refl_hiz_trace_ray accepts");
    // Within a pixel where f32 resolves the scene to a pixel (the header's
    // condition): a moderate camera and ray origin (a camera 1.6e6 from the
    // origin with a 0.3 near plane put the two hits 3.4 px apart).
    let resolved = camera_moderate(&t.img.cam) && max_abs3(ray.origin) < 100.0;
    // Known finding F40 (not a refl bug, fuzz/README.md): a ray that
    // starts inside a texel's hit slab hits at t = 0 (self-intersection),
    // and when its origin projects within rounding of a pixel boundary the
    // two kernels may start in the two pixels on either side (the origin
    // 8e-7 px inside row 12, below f32's step there: stepping counts it in
    // row 12 and hits at t = 0, Hi-Z rounds it onto the boundary and
    // starts in row 11, the way the ray moves, to hit 3.3 px further on).
    let start_tie = (r.t == 0.0 || sr.t == 0.0)
        && project(&t.img.cam, ray.origin).is_some_and(|q| {
            let tol = pixel_tol(&t.img.cam, q.depth);
            (q.x - q.x.round()).abs() <= tol || (q.y - q.y.round()).abs() <= tol
        });
    if r.miss == 0 && sr.miss == 0 && resolved && !start_tie {
        if std::env::var_os("REFL_FUZZ_DUMP").is_some() {
            let texels: Vec<f32> = (0..t.img.buf.len()).map(|i| t.img.buf.get(i)).collect();
            eprintln!("stride {} texels {texels:?}", t.img.stride);
        }
        assert!(
            (r.pixel.x - sr.pixel.x).abs() <= 1.5 && (r.pixel.y - sr.pixel.y).abs() <= 1.5,
            "Hi-Z hit {r:?} vs stepping hit {sr:?}: ray {ray:?} t_max {tm} options {opts:?} image {}x{} conv {} camera {:?} thickness {:?}",
            t.img.width,
            t.img.height,
            t.img.conv,
            t.img.cam,
            t.th.desc
        );
    }
    // "Every setting returns the same first hit."
    let mut dflt = refl_hiz_options_default();
    dflt.max_iterations = u32::MAX;
    let mut d = sentinel_trace();
    // SAFETY: pointers valid.
    let sd = unsafe { refl_hiz_trace_ray(&mut d, &t.hiz, &t.th.desc, ray, tm, &dflt) };
    assert_eq!(sd, refl_status::Ok);
    if r.miss == 0 && d.miss == 0 {
        assert!(
            (r.pixel.x - d.pixel.x).abs() <= 1e-3 * (1.0 + r.pixel.x.abs()) && (r.pixel.y - d.pixel.y).abs() <= 1e-3 * (1.0 + r.pixel.y.abs()),
            "Hi-Z options {opts:?} hit {:?}, default options {:?}",
            r.pixel,
            d.pixel
        );
    }
}

fn trace_batch(b: &mut Bytes, t: &Trace, opts: &refl_hiz_options) {
    // Up to 4 rays, or (one input in two that asks for 4) 16 to 47: the
    // batch call walks batches of 8 and more in its AVX2 ray stream where
    // the CPU has AVX2, and each of its results must be the single-ray
    // call's, bit for bit.
    let mut n = b.below(5) as usize;
    if n == 4 && b.bool() {
        n = 16 + b.below(32) as usize;
    }
    let rays: Vec<refl_ray> = (0..n).map(|_| ray_for(b, t.img)).collect();
    let tcount = match b.u8() % 4 {
        0 => 1,
        1 => n.saturating_sub(1),
        2 => 0,
        _ => n,
    };
    let tms: Vec<f32> = (0..tcount).map(|_| t_max(b)).collect();
    let out_len = b.len_for(n);
    let mut out = Buf::<refl_trace_result>::sentinel(out_len, b.ptr_kind());
    let rb = Buf::from_slice(&rays, b.ptr_kind());
    let tb = Buf::from_slice(&tms, b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe {
        refl_hiz_trace_rays(out.ptr(), out_len, &t.hiz, &t.th.desc, rb.cptr(), n, tb.cptr(), tcount, opts)
    };
    let null = [out.is_null(), rb.is_null(), tb.is_null(), t.data.is_null()].contains(&true);
    let mis = [out.kind(), rb.kind(), tb.kind(), t.data.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(s, null, null, mis, "refl_hiz_trace_rays");
    let untouched = (0..out_len).all(|i| out.is_sentinel(i));
    on_error_untouched(s, &[("out", untouched)], "refl_hiz_trace_rays");
    for i in n..out_len {
        assert!(out.is_sentinel(i), "refl_hiz_trace_rays wrote out[{i}] past rays_len {n}");
    }
    if s != refl_status::Ok {
        return;
    }
    assert!(out_len >= n && tcount != 0 && (tcount == 1 || tcount >= n), "refl_hiz_trace_rays accepted bad counts");
    for i in 0..n {
        let tm = if tcount == 1 { tms[0] } else { tms[i] };
        let mut one = sentinel_trace();
        // SAFETY: pointers valid.
        let s1 = unsafe { refl_hiz_trace_ray(&mut one, &t.hiz, &t.th.desc, rays[i], tm, opts) };
        assert_eq!(s1, refl_status::Ok, "batch accepted ray {i} refl_hiz_trace_ray refuses");
        assert!(same_trace(&one, &out.get(i)), "refl_hiz_trace_rays result {i} differs from refl_hiz_trace_ray");
    }
    if n > 0 && b.bool() {
        let bytes = (n * size_of::<refl_trace_result>()).max(n * size_of::<refl_ray>());
        let mut mem = vec![0u64; bytes.div_ceil(8)];
        // SAFETY: mem holds n rays.
        unsafe { core::ptr::copy_nonoverlapping(rays.as_ptr(), mem.as_mut_ptr().cast::<refl_ray>(), n) };
        // The output array is written in place: overlapping the rays is
        // refused and nothing is written.
        let before = mem.clone();
        let p = mem.as_mut_ptr();
        // SAFETY: p valid for n results and n rays (overlapping).
        let s2 = unsafe {
            refl_hiz_trace_rays(p.cast(), n, &t.hiz, &t.th.desc, p.cast::<refl_ray>().cast_const(), n, tms.as_ptr(), tcount, opts)
        };
        assert_eq!(s2, refl_status::InvalidArgument, "refl_hiz_trace_rays with out aliasing rays");
        assert!(mem == before, "refl_hiz_trace_rays refused aliasing rays but wrote");
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    if b.chance(48) {
        check_layout(&mut b);
    }
    let img = depth_image(&mut b);
    let built = build(&mut b, &img);
    if let Some(p) = &built {
        if b.chance(64) {
            build_rows(&mut b, &img, p);
        }
    }
    let th = thickness(&mut b, &img);
    // The pyramid traced: the one built, or fuzzed texels; with the
    // image's camera or (sometimes) another one.
    let is_built = built.is_some() && !b.chance(24);
    let need = layout(img.cam.width, img.cam.height).map_or(16, |(n, _)| n).min(1 << 14);
    let data = match (&built, is_built) {
        (Some(p), true) => Buf::from_slice(p, b.ptr_kind()),
        _ => {
            let len = b.len_for(need);
            let kind = b.ptr_kind();
            Buf::from_fn(len, kind, |_| refl_vec2 {
                x: b.f32_any().abs(),
                y: b.f32_any().abs(),
            })
        }
    };
    let cam = if b.chance(16) { camera(&mut b, img.cam.width, img.cam.height) } else { img.cam };
    let conv = if b.chance(16) { b.convention() } else { img.conv };
    let hiz = refl_hiz {
        data: data.cptr(),
        len: data.len(),
        camera: cam,
        convention: conv,
    };
    let t = Trace {
        img: &img,
        th: &th,
        built: is_built && data.usable(),
        data,
        hiz,
    };
    for _ in 0..4 {
        if b.is_empty() {
            break;
        }
        let opts = hiz_options(&mut b);
        if b.u8() % 3 == 0 {
            trace_batch(&mut b, &t, &opts);
        } else {
            trace_one(&mut b, &t, &opts);
        }
    }
});
