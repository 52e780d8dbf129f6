//! Per-pixel stepping: `refl_step_options_default`, `refl_step_ray`, `refl_step_rays` (batches, `t_max`
//! per ray or shared, short outputs, the output aliasing the rays) and
//! `refl_trace_refine_hit` (real and fuzzed hits, output aliasing the hit).
#![no_main]

use core::mem::size_of;
use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

fn options(b: &mut Bytes) -> refl_step_options {
    // The documented defaults, and sometimes the options used.
    let d = refl_step_options_default();
    assert!(d.stride == 1 && d.max_steps == u32::MAX, "step defaults {d:?}");
    if b.chance(32) {
        return d;
    }
    refl_step_options {
        stride: match b.u8() {
            0..=7 => 0,
            8..=11 => u32::MAX,
            k => 1 + u32::from(k) % 6,
        },
        max_steps: match b.u8() {
            0..=7 => 0,
            8..=15 => b.below(8),
            16..=31 => b.u32(),
            _ => u32::MAX,
        },
    }
}

struct Setup {
    img: DepthImg,
    th: Thick,
    opts: refl_step_options,
}

impl Setup {
    /// Whether every input but the ray must be accepted.
    fn valid(&self) -> bool {
        self.img.valid() && self.th.valid(self.img.width, self.img.height) && self.opts.stride >= 1
    }
}

fn check_hit_surface(r: &refl_trace_result, s: &Setup, what: &str) {
    if r.miss != 0 || !s.img.valid() || s.th.back.is_some() {
        return;
    }
    // "Linear depth stored in the image at the texel hit."
    let (x, y) = (r.pixel.x as u32, r.pixel.y as u32);
    let stored = decode(&s.img.cam, s.img.texel(x, y), s.img.conv);
    if let Some(z) = stored {
        assert!(
            close(r.surface_depth, z, 1e-4),
            "{what}: surface_depth {} but texel ({x}, {y}) decodes to {z}",
            r.surface_depth
        );
    }
}

fn step_one(b: &mut Bytes, s: &Setup) -> Option<(refl_ray, f32, refl_trace_result)> {
    let ray = ray_for(b, &s.img);
    let tm = t_max(b);
    let mut out = out1::<refl_trace_result>(b.ptr_kind());
    let desc = s.img.desc();
    let image = Buf::from_slice(&[desc], b.ptr_kind());
    let th = Buf::from_slice(&[s.th.desc], b.ptr_kind());
    let opts = Buf::from_slice(&[s.opts], b.ptr_kind());
    let snap = s.img.buf.snapshot();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let st = unsafe { refl_step_ray(out.ptr(), image.cptr(), th.cptr(), ray, tm, opts.cptr()) };
    s.img.buf.assert_unchanged(&snap, "refl_step_ray: depth image");
    let null = out.is_null() || image.is_null() || th.is_null() || opts.is_null() || s.img.buf.is_null();
    let mis = [out.kind(), image.kind(), th.kind(), opts.kind(), s.img.buf.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(st, null, null, mis, "refl_step_ray");
    on_error_untouched(st, &[("out", out.is_sentinel(0))], "refl_step_ray");
    let ptrs_ok = [out.kind(), image.kind(), th.kind(), opts.kind()].iter().all(|k| *k == PtrKind::Valid);
    let rv = ray_valid(&ray, tm);
    if st != refl_status::Ok {
        if ptrs_ok && s.valid() && rv == Some(true) {
            panic!("refl_step_ray refused valid input: {st:?} ray {ray:?} t_max {tm}");
        }
        return None;
    }
    assert!(ptrs_ok && s.valid(), "refl_step_ray accepted an invalid image/thickness/options");
    assert!(rv != Some(false), "refl_step_ray accepted an invalid ray {ray:?} / t_max {tm}");
    let r = out.get(0);
    check_trace(&r, &ray, tm, &s.img.cam, false, "refl_step_ray");
    // "reaching it gives REFL_TRACE_MISS_OUT_OF_STEPS"
    assert!(r.steps <= s.opts.max_steps, "refl_step_ray took {} steps, cap {}", r.steps, s.opts.max_steps);
    check_hit_surface(&r, s, "refl_step_ray");
    if r.miss == 0 && s.th.back.is_none() && s.th.desc.constant.is_finite() && camera_moderate(&s.img.cam) {
        let th = s.th.desc.constant;
        let tol = 1e-3 * r.surface_depth.abs() + 1e-4;
        assert!(
            r.depth >= r.surface_depth - tol && r.depth <= r.surface_depth + th + tol,
            "refl_step_ray hit at depth {} outside [{}, {} + {th}]: ray {ray:?} t_max {tm} camera {:?} options {:?} result {r:?}",
            r.depth,
            r.surface_depth,
            r.surface_depth,
            s.img.cam,
            s.opts
        );
    }
    Some((ray, tm, r))
}

fn step_batch(b: &mut Bytes, s: &Setup) {
    let n = b.below(6) as usize;
    let rays: Vec<refl_ray> = (0..n).map(|_| ray_for(b, &s.img)).collect();
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
    let desc = s.img.desc();
    let image = Buf::from_slice(&[desc], b.ptr_kind());
    let th = Buf::from_slice(&[s.th.desc], b.ptr_kind());
    let opts = Buf::from_slice(&[s.opts], b.ptr_kind());
    let (rs, ts) = (rb.snapshot(), tb.snapshot());
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let st = unsafe {
        refl_step_rays(out.ptr(), out_len, image.cptr(), th.cptr(), rb.cptr(), n, tb.cptr(), tcount, opts.cptr())
    };
    rb.assert_unchanged(&rs, "refl_step_rays: rays");
    tb.assert_unchanged(&ts, "refl_step_rays: t_max");
    let null = [out.is_null(), rb.is_null(), tb.is_null(), image.is_null(), th.is_null(), opts.is_null(), s.img.buf.is_null()]
        .contains(&true);
    let mis = [out.kind(), rb.kind(), tb.kind(), image.kind(), th.kind(), opts.kind(), s.img.buf.kind()]
        .contains(&PtrKind::Misaligned);
    null_rules_m(st, null, null, mis, "refl_step_rays");
    let untouched = (0..out_len).all(|i| out.is_sentinel(i));
    on_error_untouched(st, &[("out", untouched)], "refl_step_rays");
    // "Elements of out past rays_len are never written."
    for i in n..out_len {
        assert!(out.is_sentinel(i), "refl_step_rays wrote out[{i}] past rays_len {n}");
    }
    let ptrs_ok = [out.kind(), rb.kind(), tb.kind(), image.kind(), th.kind(), opts.kind()]
        .iter()
        .all(|k| *k == PtrKind::Valid);
    let sizes_ok = out_len >= n && tcount != 0 && (tcount == 1 || tcount >= n);
    let rays_valid: Vec<Option<bool>> = (0..n)
        .map(|i| ray_valid(&rays[i], if tcount == 1 { tms[0] } else { tms.get(i).copied().unwrap_or(f32::NAN) }))
        .collect();
    if st != refl_status::Ok {
        if ptrs_ok && sizes_ok && s.valid() && rays_valid.iter().all(|v| *v == Some(true)) {
            panic!("refl_step_rays refused valid input: {st:?}");
        }
        if ptrs_ok && tcount == 0 && !null && s.valid() {
            assert!(
                matches!(st, refl_status::InvalidArgument | refl_status::InsufficientSize),
                "t_max_len 0: {st:?}"
            );
        }
        return;
    }
    assert!(ptrs_ok && sizes_ok && s.valid(), "refl_step_rays accepted invalid input");
    // Each result equals refl_step_ray's for that ray.
    for i in 0..n {
        let tm = if tcount == 1 { tms[0] } else { tms[i] };
        let mut one = sentinel_trace();
        // SAFETY: pointers valid.
        let s1 = unsafe { refl_step_ray(&mut one, &desc, &s.th.desc, rays[i], tm, &s.opts) };
        assert_eq!(s1, refl_status::Ok, "refl_step_rays accepted ray {i} that refl_step_ray refuses");
        assert!(same_trace(&one, &out.get(i)), "refl_step_rays result {i} differs from refl_step_ray");
    }
    // The output array must not overlap the rays (it is written in place):
    // refused, nothing written.
    if n > 0 && b.bool() {
        let bytes = (n * size_of::<refl_trace_result>()).max(n * size_of::<refl_ray>());
        let mut mem = vec![0u64; bytes.div_ceil(8)];
        // SAFETY: mem holds n rays.
        unsafe { core::ptr::copy_nonoverlapping(rays.as_ptr(), mem.as_mut_ptr().cast::<refl_ray>(), n) };
        let before = mem.clone();
        let p = mem.as_mut_ptr();
        // SAFETY: p is valid for n results and n rays (overlapping).
        let s2 = unsafe {
            refl_step_rays(p.cast(), n, &desc, &s.th.desc, p.cast::<refl_ray>().cast_const(), n, tms.as_ptr(), tcount, &s.opts)
        };
        assert_eq!(s2, refl_status::InvalidArgument, "refl_step_rays with out aliasing rays: {s2:?}");
        assert!(mem == before, "refl_step_rays refused aliasing rays but wrote");
    }
}

fn refine(b: &mut Bytes, s: &Setup, found: Option<(refl_ray, f32, refl_trace_result)>) {
    let (ray, tm, mut hit) = match found {
        Some(f) if b.chance(200) => f,
        _ => {
            let ray = ray_for(b, &s.img);
            let tm = t_max(b);
            let hit = refl_trace_result {
                miss: match b.u8() % 8 {
                    0 => b.u32(),
                    1..=2 => b.below(6),
                    _ => 0,
                },
                pixel: b.vec2_in(-2.0, MAX_SIDE as f32 + 2.0),
                t: b.f32_in(0.0, 20.0),
                depth: b.f32_in(0.0, 20.0),
                surface_depth: b.f32_in(0.0, 20.0),
                steps: b.u32(),
                fetches: b.u32(),
                iterations: b.u32(),
            };
            (ray, tm, hit)
        }
    };
    if b.chance(16) {
        hit.fetches = u32::MAX - b.below(4);
    }
    let mut out = out1::<refl_trace_result>(b.ptr_kind());
    let desc = s.img.desc();
    let image = Buf::from_slice(&[desc], b.ptr_kind());
    let hb = Buf::from_slice(&[hit], b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let st = unsafe { refl_trace_refine_hit(out.ptr(), image.cptr(), ray, tm, hb.cptr()) };
    let null = out.is_null() || image.is_null() || hb.is_null() || s.img.buf.is_null();
    let mis = [out.kind(), image.kind(), hb.kind(), s.img.buf.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(st, null, null, mis, "refl_trace_refine_hit");
    on_error_untouched(st, &[("out", out.is_sentinel(0))], "refl_trace_refine_hit");
    if st != refl_status::Ok {
        return;
    }
    assert!(s.img.valid(), "refl_trace_refine_hit accepted an invalid image");
    assert!(hit.miss <= 5, "refl_trace_refine_hit accepted miss value {}", hit.miss);
    let r = out.get(0);
    if hit.miss != 0 {
        assert!(same_trace(&r, &hit), "refl_trace_refine_hit changed a miss");
    } else {
        assert_eq!(r.miss, 0, "refl_trace_refine_hit turned a hit into a miss");
        assert!(r.t.is_finite() && r.pixel.x.is_finite() && r.pixel.y.is_finite() && r.depth.is_finite());
        assert!(
            r.t >= 0.0 && r.t <= tm || r.t.to_bits() == hit.t.to_bits(),
            "refined t {} outside [0, {tm}] (hit t {})",
            r.t,
            hit.t
        );
        assert!(r.steps == hit.steps && r.iterations == hit.iterations, "refine changed steps/iterations");
        assert!(r.fetches >= hit.fetches, "refine lowered fetches {} -> {}", hit.fetches, r.fetches);
    }
    // `out` may alias `hit`.
    let mut both = [hit];
    let p = both.as_mut_ptr();
    // SAFETY: valid pointers; out == hit.
    let s2 = unsafe { refl_trace_refine_hit(p, &desc, ray, tm, p) };
    assert_eq!(s2, refl_status::Ok, "refl_trace_refine_hit with out == hit");
    assert!(same_trace(&both[0], &r), "refl_trace_refine_hit aliased result differs");
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let img = depth_image(&mut b);
    let th = thickness(&mut b, &img);
    let opts = options(&mut b);
    let s = Setup { img, th, opts };
    for _ in 0..6 {
        if b.is_empty() {
            break;
        }
        match b.u8() % 4 {
            0 | 1 => {
                let f = step_one(&mut b, &s);
                if b.bool() {
                    refine(&mut b, &s, f);
                }
            }
            2 => step_batch(&mut b, &s),
            _ => refine(&mut b, &s, None),
        }
    }
});
