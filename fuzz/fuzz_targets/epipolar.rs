//! Reprojected ray casting (seed 002): `refl_epipolar_options_default`,
//! `refl_epipolar_scratch_len`, `refl_epipolar_reproject` (POS from a
//! previous camera into the AIP of a current one; fuzzed params, buffers,
//! cameras, overlaps) and `refl_epipolar_decide_rows`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const INVALID: u32 = REFL_EPIPOLAR_INVALID_OBJECT;
const ALL_FLAGS: u32 = 1 | 2 | 4 | 0xF0;

fn params(b: &mut Bytes) -> refl_epipolar_options {
    let mut p = refl_epipolar_options_default();
    for _ in 0..(b.u8() % 4) {
        match b.u8() % 11 {
            0 => p.m_cnt = b.pick(&[0, 1, 2, 5, 9, u32::MAX]),
            1 => p.splat_radius = b.below(5),
            2 => p.depth_guard = b.u8() & 1 == 1,
            3 => p.guard_margin = b.f32_in(-0.1, 1.1),
            4 => p.guard_window = b.below(5),
            5 => p.frustum_check = b.u8() & 1 == 1,
            6 => p.occlusion_check = b.u8() & 1 == 1,
            7 => p.resample_period = b.pick(&[0, 1, 2, 9, u32::MAX]),
            8 => p.abrupt_frames = b.pick(&[0, 1, 9, u32::MAX]),
            9 => p.shift_origin = b.u8() & 1 == 1,
            _ => p.shift_epsilon = b.f32_any(),
        }
    }
    p
}

fn params_valid(p: &refl_epipolar_options) -> bool {
    p.m_cnt >= 1
        && p.splat_radius <= 3
        && (0.0..1.0).contains(&p.guard_margin)
        && p.guard_window <= 3
        && p.shift_epsilon.is_finite()
        && p.shift_epsilon >= 0.0
}

fn pos_entries(b: &mut Bytes, prev: &refl_camera, n: usize) -> Vec<refl_epipolar_pos_entry> {
    let mode = b.u8() % 4;
    let (w, h) = (prev.width.max(1), prev.height.max(1));
    let floor_y = b.f32_in(-1.0, 0.5);
    let wall_z = b.f32_in(-12.0, -2.0);
    (0..n)
        .map(|i| {
            if mode == 0 || b.chance(8) {
                return refl_epipolar_pos_entry {
                    point: [b.f32_any(), b.f32_any(), b.f32_any()],
                    object: match b.u8() % 4 {
                        0 => INVALID,
                        1 => REFL_EPIPOLAR_BACKGROUND_OBJECT,
                        _ => b.below(4),
                    },
                    t: b.f32_any(),
                };
            }
            let (x, y) = ((i as u32 % w) as f32 + 0.5, (i as u32 / w).min(h - 1) as f32 + 0.5);
            let mut r = refl_ray::default();
            // SAFETY: pointers valid.
            let s = unsafe { refl_camera_primary_ray(&mut r, prev, refl_vec2 { x, y }) };
            match (s == refl_status::Ok).then(|| hit_scene(&r, floor_y, wall_z, [-1.0, -0.5, -3.0], 1.0)).flatten() {
                Some(t) => refl_epipolar_pos_entry {
                    point: [r.origin.x + t * r.dir.x, r.origin.y + t * r.dir.y, r.origin.z + t * r.dir.z],
                    object: (x as u32 + y as u32) % 3,
                    t,
                },
                None => refl_epipolar_pos_entry {
                    point: [r.origin.x + 1e3 * r.dir.x, r.origin.y + 1e3 * r.dir.y, r.origin.z + 1e3 * r.dir.z],
                    object: REFL_EPIPOLAR_BACKGROUND_OBJECT,
                    t: 1e3,
                },
            }
        })
        .collect()
}

fn scratch_len(w: u32, h: u32) -> Option<usize> {
    let mut n = 0usize;
    // SAFETY: pointer valid.
    (unsafe { refl_epipolar_scratch_len(&mut n, w, h) } == refl_status::Ok).then_some(n)
}

fn aip_init() -> refl_epipolar_aip_entry {
    refl_epipolar_aip_entry {
        object: INVALID,
        t: f32::INFINITY,
        cnt: 0,
        t_other: f32::INFINITY,
        flags: REFL_EPIPOLAR_FLAG_NO_REPROJECTION,
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    // Size query.
    {
        let (w, h) = (b.side(MAX_SIDE), b.side(MAX_SIDE));
        let mut o = out1::<usize>(b.ptr_kind());
        // SAFETY: NULL, misaligned or valid.
        let s = unsafe { refl_epipolar_scratch_len(o.ptr(), w, h) };
        null_rules(s, o.is_null(), o.is_null(), "refl_epipolar_scratch_len");
        on_error_untouched(s, &[("out_len", o.is_sentinel(0))], "refl_epipolar_scratch_len");
        if o.usable() && (w == 0 || h == 0) {
            assert_eq!(s, refl_status::InvalidArgument);
        }
    }
    let w = 1 + b.below(MAX_SIDE);
    let h = 1 + b.below(MAX_SIDE);
    let prev = camera(&mut b, w, h);
    let cur = if b.chance(64) {
        prev
    } else {
        // The previous camera moved a little (or a fuzzed one).
        let mut c = camera(&mut b, w, h);
        if b.chance(16) {
            c.width = b.side(MAX_SIDE);
        }
        c
    };
    let p = params(&mut b);
    // POS holds the previous camera's pixels (its size may be fuzzed).
    let n = (prev.width as usize).saturating_mul(prev.height as usize).clamp(1, 1 << 14);
    let pos = pos_entries(&mut b, &prev, n);
    let pos_len = b.len_for(n);
    let pb = Buf::from_fn(pos_len, b.ptr_kind(), |i| pos.get(i).copied().unwrap_or(pos[0]));
    let cn = (cur.width as usize).saturating_mul(cur.height as usize).min(1 << 14);
    let aip_len = b.len_for(cn);
    let mut aip = Buf::<refl_epipolar_aip_entry>::sentinel(aip_len, b.ptr_kind());
    let need_scratch = scratch_len(cur.width, cur.height).unwrap_or(16);
    let s_len = b.len_for(need_scratch.min(1 << 18));
    let mut scratch = Buf::<f32>::sentinel(s_len, b.ptr_kind());
    let mut stats = out1::<refl_epipolar_stats>(b.ptr_kind());
    let prev_b = Buf::from_slice(&[prev], b.ptr_kind());
    let cur_b = Buf::from_slice(&[cur], b.ptr_kind());
    let par_b = Buf::from_slice(&[p], b.ptr_kind());
    // Overlap: the scratch inside the AIP buffer (refused).
    let overlap = b.chance(8) && aip.usable() && aip_len >= 4;
    let (scr_ptr, scr_len) = if overlap {
        (aip.ptr().cast::<f32>(), s_len.min(aip_len * 5))
    } else {
        (scratch.ptr(), s_len)
    };
    let snaps = (aip.snapshot(), scratch.snapshot(), pb.snapshot());
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe {
        refl_epipolar_reproject(
            aip.ptr(),
            aip_len,
            scr_ptr,
            scr_len,
            stats.ptr(),
            pb.cptr(),
            pos_len,
            prev_b.cptr(),
            cur_b.cptr(),
            par_b.cptr(),
        )
    };
    pb.assert_unchanged(&snaps.2, "refl_epipolar_reproject: pos");
    let scr_kind = if overlap { PtrKind::Valid } else { scratch.kind() };
    let kinds = [aip.kind(), scr_kind, stats.kind(), pb.kind(), prev_b.kind(), cur_b.kind(), par_b.kind()];
    let null = kinds.contains(&PtrKind::Null);
    null_rules_m(s, null, null, kinds.contains(&PtrKind::Misaligned), "refl_epipolar_reproject");
    on_error_untouched(
        s,
        &[("aip", aip.bytes() == &snaps.0[..]), ("scratch", scratch.bytes() == &snaps.1[..]), ("stats", stats.is_sentinel(0))],
        "refl_epipolar_reproject",
    );
    let all_valid = !kinds.iter().any(|k| *k != PtrKind::Valid)
        && !overlap
        && params_valid(&p)
        && camera_ok(&prev)
        && camera_ok(&cur)
        && (prev.width, prev.height) == (cur.width, cur.height)
        && aip_len >= cn
        && pos_len >= (prev.width as usize) * (prev.height as usize)
        && s_len >= need_scratch;
    if s != refl_status::Ok {
        assert!(!all_valid, "refl_epipolar_reproject refused valid input: {s:?} (scratch {s_len} of {need_scratch}, aip {aip_len} of {cn}, pos {pos_len} of {n})");
        return;
    }
    assert!(all_valid, "refl_epipolar_reproject accepted invalid input ({p:?}, overlap {overlap})");
    let st = stats.get(0);
    let stored = pos[..n].iter().filter(|e| e.object != INVALID).count() as u32;
    assert!(st.points <= stored, "stats.points {} > stored {stored}", st.points);
    assert!(
        st.splatted as u64 + st.behind as u64 + st.outside as u64 + st.occlusion_rejected as u64 + st.abrupt_rejected as u64
            <= st.points as u64,
        "stats {st:?}"
    );
    let aips: Vec<refl_epipolar_aip_entry> = (0..cn).map(|i| aip.get(i)).collect();
    for (i, e) in aips.iter().enumerate() {
        assert!(e.flags & !ALL_FLAGS == 0, "AIP {i} flags {:#x}", e.flags);
        if st.frustum_failed {
            assert!(e.flags & REFL_EPIPOLAR_FLAG_NO_REPROJECTION != 0, "frustum failed but AIP {i} reprojected");
        }
        if e.object == INVALID {
            assert_eq!(e.cnt, 0, "AIP {i}: no object but cnt {}", e.cnt);
        } else {
            assert!(
                pos[..n].iter().any(|q| q.object == e.object),
                "AIP {i} object {} is in no POS entry",
                e.object
            );
        }
        assert!(!e.t.is_nan() && !e.t_other.is_nan(), "AIP {i} NaN distance {e:?}");
    }
    // AIP entries past the image are not written.
    for i in cn..aip_len {
        assert!(aip.is_sentinel(i), "refl_epipolar_reproject wrote AIP {i} past {cn}");
    }

    // Decide rows.
    let frame = b.u32();
    let rows = b.rows(h);
    let (rb, re) = (rows.begin, rows.end);
    let need = (re as usize) * (w as usize);
    let out_len = b.len_for(need.max(n).min(1 << 14));
    let mut out = Buf::<refl_epipolar_decision>::sentinel(out_len, b.ptr_kind());
    let mut ab = Buf::from_fn(cn, PtrKind::Valid, |i| if b.chance(8) { aip_init() } else { aips[i] });
    let alias = b.chance(8);
    let p2 = if b.chance(16) { params(&mut b) } else { p };
    let snap = out.snapshot();
    let (ap, al) = if alias {
        (out.ptr().cast::<refl_epipolar_aip_entry>().cast_const(), out_len.min(cn))
    } else {
        (ab.ptr().cast_const(), cn)
    };
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_epipolar_decide_rows(out.ptr(), out_len, ap, al, w, refl_row_range { begin: rb, end: re }, frame, &p2) };
    let null = out.is_null();
    null_rules_m(s, null, null, out.kind() == PtrKind::Misaligned, "refl_epipolar_decide_rows");
    on_error_untouched(s, &[("out", out.bytes() == &snap[..])], "refl_epipolar_decide_rows");
    if s != refl_status::Ok {
        if out.usable() && !alias && params_valid(&p2) && rb < re && out_len >= need && cn >= need {
            panic!("refl_epipolar_decide_rows refused valid input: {s:?}");
        }
        return;
    }
    assert!(!alias, "refl_epipolar_decide_rows accepted out overlapping aip");
    assert!(params_valid(&p2) && rb < re && out_len >= need && al >= need, "decide accepted bad input");
    for i in 0..out_len {
        let y = (i / w as usize) as u32;
        if y < rb || y >= re || i >= need {
            assert!(out.is_sentinel(i), "refl_epipolar_decide_rows wrote entry {i} outside rows {rb}..{re}");
            continue;
        }
        let d = out.get(i);
        let a = ab.get(i);
        assert!(d.reason <= 4, "decision reason {}", d.reason);
        assert!(!d.tmin.is_nan() && d.tmin >= 0.0 && !d.tmax.is_nan(), "decision {d:?}");
        let no_rep = a.flags & REFL_EPIPOLAR_FLAG_NO_REPROJECTION != 0;
        if no_rep {
            assert_eq!(d.reason, 4, "no reprojection but reason {} ({a:?})", d.reason);
        }
        if d.reason == 0 {
            assert_eq!(d.object, a.object, "REPROJECTED decision for another object");
            assert!(a.cnt >= p2.m_cnt, "REPROJECTED with cnt {} < m_cnt {}", a.cnt, p2.m_cnt);
        } else {
            assert_eq!(d.object, INVALID, "full traversal but object {} (reason {})", d.object, d.reason);
        }
    }
    let _ = &mut ab;
});
