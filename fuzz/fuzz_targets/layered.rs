//! Layered depth cube maps and the PRR test (seed 001): `refl_layered_len`,
//! `refl_layered_options_default`, `refl_layered_face_ray`,
//! `refl_layered_clear`, `refl_layered_fill_column`,
//! `refl_layered_fill_face`, `refl_layered_build_bounds`,
//! `refl_layered_trace_ray`, `refl_layered_trace_rays`, `refl_layered_prr_classify`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

fn check_len(b: &mut Bytes) {
    let res = match b.u8() % 4 {
        0 => b.u32(),
        _ => b.below(70),
    };
    let layers = match b.u8() % 4 {
        0 => b.u32(),
        _ => b.below(9),
    };
    let mut o = out1::<refl_layered_sizes>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_layered_len(o.ptr(), res, layers) };
    null_rules(s, o.is_null(), o.is_null(), "refl_layered_len");
    on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_layered_len");
    if !o.usable() {
        return;
    }
    let (r, l) = (u128::from(res), u128::from(layers));
    let texels = 6 * r * r * l;
    let mut bounds = 0u128;
    let mut lv = 1;
    while res > 1 && lv <= 33 && (1u128 << (lv - 1)) < r {
        let cells = r.div_ceil(1u128 << lv);
        bounds += 6 * cells * cells * 2 * l;
        lv += 1;
    }
    let fits = |v: u128| v <= usize::MAX as u128;
    if res == 0 || layers == 0 || !fits(texels) || !fits(bounds) {
        assert_eq!(s, refl_status::InvalidArgument, "refl_layered_len({res}, {layers})");
        return;
    }
    assert_eq!(s, refl_status::Ok, "refl_layered_len({res}, {layers})");
    let z = o.get(0);
    assert_eq!(z.depth_len as u128, texels);
    assert_eq!(z.payload_len as u128, texels);
    // Counts: one per texel, then the words of the map's stamp (the grid
    // it was cleared for), if any.
    assert!(z.counts_len as u128 >= 6 * r * r && z.counts_len as u128 <= 6 * r * r + 64, "counts {} of res {res}", z.counts_len);
    assert_eq!(z.bounds_len as u128, bounds, "bounds of refl_layered_len({res}, {layers})");
}

fn grid(b: &mut Bytes) -> refl_layered_grid {
    let min = if b.chance(16) { b.vec3_in(-3.0, 3.0) } else { v3(-1.0, -1.0, -1.0) };
    let max = if b.chance(16) { b.vec3_in(-3.0, 3.0) } else { v3(1.0, b.f32_fine(0.2, 2.0), 1.0) };
    let mut m = identity();
    match b.u8() % 16 {
        0 => m.m[b.below(16) as usize] = b.f32_any(),
        1 => {
            m.m[12] = b.f32_in(-5.0, 5.0);
            m.m[13] = b.f32_in(-5.0, 5.0);
        }
        2 => {
            // A rotation about y.
            let a = b.f32_fine(0.0, 6.28);
            m.m[0] = a.cos();
            m.m[2] = -a.sin();
            m.m[8] = a.sin();
            m.m[10] = a.cos();
        }
        _ => {}
    }
    refl_layered_grid {
        min,
        max,
        face_res: match b.u8() % 16 {
            0 => 0,
            1 => b.u32(),
            _ => 1 + b.below(12),
        },
        layers: match b.u8() % 16 {
            0 => 0,
            1 => b.u32(),
            _ => 1 + b.below(4),
        },
        world_from_local: m,
    }
}

fn map(b: &mut Bytes, g: refl_layered_grid) -> Map {
    let z = sizes(g.face_res, g.layers).unwrap_or_default();
    let cap = 1usize << 15;
    let k = |b: &mut Bytes| if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid };
    let l = |b: &mut Bytes, n: usize| if b.chance(16) { b.len_for(n.min(cap)) } else { n.min(cap) };
    let (kd, kp, kc, kb) = (k(b), k(b), k(b), k(b));
    let (ld, lp, lc, lb) = (l(b, z.depth_len), l(b, z.payload_len), l(b, z.counts_len), l(b, z.bounds_len));
    Map {
        grid: g,
        depth: Buf::sentinel(ld, kd),
        payload: Buf::sentinel(lp, kp),
        counts: Buf::sentinel(lc, kc),
        bounds: Buf::sentinel(lb, kb),
    }
}

fn clear(m: &mut Map) -> refl_status {
    let d = m.desc_mut();
    let snap = m.snap();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_layered_clear(&d) };
    null_rules_m(s, m.any_null(), m.any_null(), m.any_misaligned(), "refl_layered_clear");
    on_error_untouched(s, &[("map", m.same(&snap))], "refl_layered_clear");
    if s == refl_status::Ok {
        let z = sizes(m.grid.face_res, m.grid.layers).expect("sizes of a cleared map");
        assert!(grid_ok(&m.grid) && m.usable(&z), "refl_layered_clear accepted a bad map");
        let texels = 6 * (m.grid.face_res as usize) * (m.grid.face_res as usize);
        for i in 0..texels {
            assert_eq!(m.counts.get(i), 0, "cleared count");
        }
        for i in 0..z.depth_len {
            assert_eq!(m.depth.get(i), f32::INFINITY, "cleared depth");
            assert_eq!(m.payload.get(i), u32::MAX, "cleared payload");
        }
        for i in 0..z.bounds_len {
            // F8 (the header corrected): bounds are cleared to (+inf, -inf)
            // pairs.
            let want = if i % 2 == 1 { f32::NEG_INFINITY } else { f32::INFINITY };
            assert_eq!(m.bounds.get(i), want, "cleared bound {i}");
        }
    }
    s
}

fn hits(b: &mut Bytes, t_max: f32) -> Vec<refl_layered_layer_hit> {
    let n = b.below(7) as usize;
    (0..n)
        .map(|_| refl_layered_layer_hit {
            t: if b.chance(16) { b.f32_special() } else { b.f32_fine(-0.2, t_max * 1.2) },
            id: b.u32(),
            front: b.u8() & 1 == 1,
        })
        .collect()
}

fn face_ray(g: &refl_layered_grid, f: u32, i: u32, j: u32) -> Option<refl_layered_column_ray> {
    let mut r = refl_layered_column_ray::default();
    // SAFETY: pointers valid.
    (unsafe { refl_layered_face_ray(&mut r, g, f, i, j) } == refl_status::Ok).then_some(r)
}

/// The key of a crossing (its padding bytes are not compared).
fn hit_key(h: &refl_layered_layer_hit) -> (u32, u32, bool) {
    (h.t.to_bits(), h.id, h.front)
}

/// `hb` holds `hs` unchanged (a failed fill leaves the caller's scratch
/// alone).
fn same_hits(hb: &Buf<refl_layered_layer_hit>, hs: &[refl_layered_layer_hit]) -> bool {
    hs.iter().enumerate().all(|(i, h)| hit_key(&hb.get(i)) == hit_key(h))
}

/// `hb` holds `hs` reordered (the fills sort the caller's crossings in
/// place).
fn is_permutation(hb: &Buf<refl_layered_layer_hit>, hs: &[refl_layered_layer_hit]) -> bool {
    let mut a: Vec<_> = (0..hs.len()).map(|i| hit_key(&hb.get(i))).collect();
    let mut b: Vec<_> = hs.iter().map(hit_key).collect();
    a.sort_unstable();
    b.sort_unstable();
    a == b
}

fn texel_index(res: u32, face: u32, i: u32, j: u32) -> usize {
    ((face * res + j) * res + i) as usize
}

fn fill_column(b: &mut Bytes, m: &mut Map) {
    let res = m.grid.face_res;
    let face = if b.chance(16) { 6 + b.below(4) } else { b.below(6) };
    let (i, j) = (b.below(res.saturating_add(1).min(64)), b.below(res.saturating_add(1).min(64)));
    let tm = face_ray(&m.grid, face.min(5), i.min(res.max(1) - 1), j.min(res.max(1) - 1)).map_or(2.0, |r| r.t_max);
    let hs = hits(b, tm);
    let mut hb = Buf::from_slice(&hs, if hs.is_empty() || !b.chance(16) { PtrKind::Valid } else { b.ptr_kind() });
    let mut out = out1::<refl_layered_column_fill>(b.ptr_kind());
    let d = m.desc_mut();
    let snap = m.snap();
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_layered_fill_column(out.ptr(), &d, face, i, j, hb.ptr(), hs.len()) };
    let null = out.is_null() || m.any_null() || (hb.is_null() && !hs.is_empty());
    null_rules_m(s, out.is_null(), null, out.kind() == PtrKind::Misaligned, "refl_layered_fill_column");
    let hits_kept = !hb.usable() || same_hits(&hb, &hs);
    on_error_untouched(s, &[("map", m.same(&snap)), ("out", out.is_sentinel(0)), ("hits", hits_kept)], "refl_layered_fill_column");
    if s != refl_status::Ok {
        return;
    }
    assert!(face < 6 && i < res && j < res, "fill_column accepted face {face} texel ({i}, {j}) of res {res}");
    assert!(hs.iter().all(|h| h.t.is_finite()), "fill_column accepted a bad hit");
    assert!(hs.is_empty() || is_permutation(&hb, &hs), "fill_column changed the hits beyond reordering them");
    let f = out.get(0);
    let layers = m.grid.layers;
    assert_eq!(f.stored, f.intervals.min(layers), "fill result {f:?}");
    // Only the column's texel on `face` and on its opposite changed
    // (depth, payload, counts).
    let opp = face ^ 1;
    let l = layers as usize;
    for idx in 0..m.counts.len().min(6 * (res as usize) * (res as usize)) {
        let changed = m.counts.bytes()[idx * 4..idx * 4 + 4] != snap[2][idx * 4..idx * 4 + 4]
            || m.depth.bytes()[idx * l * 4..(idx + 1) * l * 4] != snap[0][idx * l * 4..(idx + 1) * l * 4]
            || m.payload.bytes()[idx * l * 4..(idx + 1) * l * 4] != snap[1][idx * l * 4..(idx + 1) * l * 4];
        if changed {
            let fi = (idx / (res as usize * res as usize)) as u32;
            assert!(fi == face || fi == opp, "fill_column({face}, {i}, {j}) changed texel {idx} of face {fi}");
        }
        let c = m.counts.get(idx);
        assert!(c <= layers || m.counts.is_sentinel(idx), "count {c} above {layers} layers");
    }
    let me = texel_index(res, face, i, j);
    assert_eq!(m.counts.get(me), f.stored, "count of the filled texel");
    for k in 0..f.stored as usize {
        let dv = m.depth.get(me * l + k);
        assert!((0.0..=1.0).contains(&dv), "stored depth {dv} outside [0, 1]");
    }
}

fn fill_face(b: &mut Bytes, m: &mut Map) -> bool {
    let res = m.grid.face_res.min(64);
    let face = if b.chance(16) { 6 + b.below(4) } else { b.below(6) };
    let cols = (res * res) as usize;
    let mut all = Vec::new();
    let mut offsets = vec![0usize];
    for c in 0..cols {
        let tm = face_ray(&m.grid, face.min(5), c as u32 % res.max(1), c as u32 / res.max(1)).map_or(2.0, |r| r.t_max);
        if b.is_empty() {
            offsets.push(all.len());
            continue;
        }
        let hs = hits(b, tm);
        all.extend(hs);
        offsets.push(all.len());
    }
    if b.chance(8) && !offsets.is_empty() {
        let k = b.below(offsets.len() as u32) as usize;
        offsets[k] = b.below(all.len() as u32 + 3) as usize;
    }
    let off_count = if b.chance(16) { b.len_for(offsets.len()) } else { offsets.len() };
    let ob = Buf::from_fn(off_count, if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid }, |i| offsets.get(i).copied().unwrap_or(0));
    let mut hb = Buf::from_slice(&all, PtrKind::Valid);
    let mut out = out1::<u32>(match b.u8() % 8 {
        0 => PtrKind::Null,
        1 => PtrKind::Misaligned,
        _ => PtrKind::Valid,
    });
    // The reference: the same columns one by one, then all bounds.
    let mut reference = Map {
        grid: m.grid,
        depth: Buf::from_slice(&m.depth.to_vec(), PtrKind::Valid),
        payload: Buf::from_slice(&m.payload.to_vec(), PtrKind::Valid),
        counts: Buf::from_slice(&m.counts.to_vec(), PtrKind::Valid),
        bounds: Buf::from_slice(&m.bounds.to_vec(), PtrKind::Valid),
    };
    let d = m.desc_mut();
    let snap = m.snap();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_layered_fill_face(out.ptr(), &d, face, hb.ptr(), all.len(), ob.cptr(), off_count) };
    let null = m.any_null() || ob.is_null();
    // F1's rule: a bad face may be reported rather than a NULL `offsets`.
    let f1 = face >= 6 && s == refl_status::InvalidArgument;
    null_rules_m(s, null && !f1, null || out.is_null(), out.kind() == PtrKind::Misaligned || m.any_misaligned(), "refl_layered_fill_face");
    on_error_untouched(s, &[("map", m.same(&snap)), ("out", out.is_sentinel(0)), ("hits", same_hits(&hb, &all))], "refl_layered_fill_face");
    if s != refl_status::Ok {
        return false;
    }
    assert!(face < 6 && off_count > cols && offsets.windows(2).all(|w| w[0] <= w[1]), "fill_face accepted bad input");
    let mut approx = 0;
    for c in 0..cols {
        let (i, j) = (c as u32 % res, c as u32 / res);
        let mut col = all[offsets[c]..offsets[c + 1]].to_vec();
        let mut f = refl_layered_column_fill::default();
        let rd = reference.desc_mut();
        // SAFETY: valid pointers.
        let s1 = unsafe { refl_layered_fill_column(&mut f, &rd, face, i, j, col.as_mut_ptr(), col.len()) };
        assert_eq!(s1, refl_status::Ok, "fill_column refuses a column fill_face accepted");
        approx += u32::from(f.stored < f.intervals);
    }
    let rd = reference.desc_mut();
    // SAFETY: valid pointers.
    assert_eq!(unsafe { refl_layered_build_bounds(&rd) }, refl_status::Ok);
    if out.usable() {
        assert_eq!(out.get(0), approx, "fill_face approximate columns");
    }
    let z = sizes(m.grid.face_res, m.grid.layers).unwrap();
    let eq = |a: &Buf<f32>, r: &Buf<f32>, n: usize, what: &str| {
        for i in 0..n {
            assert!(same_f32(a.get(i), r.get(i)), "fill_face {what} {i}: {} vs columns {} (face {face}, res {}, layers {}, {} bounds, offsets {offsets:?}, hits {all:?})", a.get(i), r.get(i), m.grid.face_res, m.grid.layers, z.bounds_len);
        }
    };
    eq(&m.depth, &reference.depth, z.depth_len, "depth");
    for i in 0..z.payload_len {
        assert_eq!(m.payload.get(i), reference.payload.get(i), "fill_face payload {i}");
    }
    for i in 0..z.counts_len {
        assert_eq!(m.counts.get(i), reference.counts.get(i), "fill_face count {i}");
    }
    // Bounds: fill_face rebuilds those of `face` and its opposite (the
    // reference's build_bounds rebuilt all six); the other faces' are as
    // before.
    let per_face = z.bounds_len / 6;
    for i in 0..z.bounds_len {
        let f = (i / per_face.max(1)) as u32;
        if f == face || f == face ^ 1 {
            assert!(same_f32(m.bounds.get(i), reference.bounds.get(i)), "fill_face bound {i} (face {f}): {} vs columns + build_bounds {}", m.bounds.get(i), reference.bounds.get(i));
        } else {
            m.bounds.assert_texel_unchanged(&snap[3], i, "fill_face bound of another face");
        }
    }
    true
}

fn params(b: &mut Bytes) -> refl_layered_options {
    let mut p = refl_layered_options_default();
    if b.chance(48) {
        match b.u8() % 6 {
            0 => p.step_texels = b.f32_any(),
            1 => p.max_steps = b.pick(&[0, 1, 3, u32::MAX]),
            2 => p.binary_steps = b.pick(&[0, 1, 64, 65, u32::MAX]),
            3 => p.texel_fraction = b.f32_any(),
            4 => p.early_stop_texels = b.f32_any(),
            _ => p.smooth_texels = b.f32_any(),
        }
    }
    p
}

fn world_box(g: &refl_layered_grid) -> ([f32; 3], [f32; 3]) {
    let m = &g.world_from_local.m;
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for c in 0..8 {
        let p = [
            if c & 1 == 0 { g.min.x } else { g.max.x },
            if c & 2 == 0 { g.min.y } else { g.max.y },
            if c & 4 == 0 { g.min.z } else { g.max.z },
        ];
        for a in 0..3 {
            let v = m[a] * p[0] + m[4 + a] * p[1] + m[8 + a] * p[2] + m[12 + a];
            lo[a] = lo[a].min(v);
            hi[a] = hi[a].max(v);
        }
    }
    (lo, hi)
}

fn check_result(r: &refl_layered_result, ray: &refl_ray, tm: f32, m: &Map, what: &str) {
    assert!(r.miss <= 5 && r.hit == (r.miss == 0), "{what}: hit {} miss {}", r.hit, r.miss);
    if !r.hit {
        assert!(r.t == 0.0 && r.position == v3(0.0, 0.0, 0.0) && r.mismatch == 0.0, "{what}: miss with hit fields {r:?}");
        return;
    }
    let g = &m.grid;
    assert!(r.t.is_finite() && r.t >= 0.0 && r.t <= tm, "{what}: t {} outside [0, {tm}]", r.t);
    assert!(finite3(r.position), "{what}: position {:?}", r.position);
    assert!(r.face < 6 && r.texel_x < g.face_res && r.texel_y < g.face_res && r.layer < g.layers, "{what}: {r:?}");
    let want = v3(ray.origin.x + r.t * ray.dir.x, ray.origin.y + r.t * ray.dir.y, ray.origin.z + r.t * ray.dir.z);
    let scale = 1.0 + max_abs3(ray.origin) + r.t;
    let d = [r.position.x - want.x, r.position.y - want.y, r.position.z - want.z];
    assert!(d.iter().all(|v| v.abs() <= 1e-3 * scale), "{what}: position {:?} is not origin + t dir {want:?}", r.position);
    let (lo, hi) = world_box(g);
    let pad = 1e-3 * (1.0 + hi.iter().chain(lo.iter()).fold(0f32, |a, v| a.max(v.abs())));
    let p = [r.position.x, r.position.y, r.position.z];
    assert!((0..3).all(|a| p[a] >= lo[a] - pad && p[a] <= hi[a] + pad), "{what}: hit {p:?} outside the box {lo:?}..{hi:?}");
    let c = m.counts.get(texel_index(g.face_res, r.face, r.texel_x, r.texel_y));
    assert!(r.layer < c, "{what}: hit layer {} of a texel with {c} layers", r.layer);
}

fn trace(b: &mut Bytes, m: &Map) {
    let ray = refl_ray {
        origin: if b.chance(200) { v3(b.f32_fine(-3.0, 3.0), b.f32_fine(-3.0, 3.0), b.f32_fine(2.0, 5.0)) } else { b.vec3_in(-5.0, 5.0) },
        dir: if b.chance(160) {
            let t = v3(b.f32_fine(-0.8, 0.8), b.f32_fine(-0.8, 0.8), -1.0);
            let l = len3(t) as f32;
            v3(t.x / l, t.y / l, t.z / l)
        } else {
            b.dir3()
        },
    };
    let tm = t_max(b);
    let p = params(b);
    let mut out = out1::<refl_layered_result>(b.ptr_kind());
    let md = m.desc();
    let pb = Buf::from_slice(&[p], b.ptr_kind());
    let snap = m.snap();
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_layered_trace_ray(out.ptr(), &md, ray, tm, pb.cptr()) };
    assert!(m.same(&snap), "refl_layered_trace_ray wrote its map");
    let null = out.is_null() || pb.is_null() || m.any_null();
    null_rules_m(s, out.is_null() || pb.is_null(), null, out.kind() == PtrKind::Misaligned || pb.kind() == PtrKind::Misaligned, "refl_layered_trace_ray");
    on_error_untouched(s, &[("out", out.is_sentinel(0))], "refl_layered_trace_ray");
    if s == refl_status::Ok {
        assert!(ray_valid(&ray, tm) != Some(false), "refl_layered_trace_ray accepted ray {ray:?} / {tm}");
        check_result(&out.get(0), &ray, tm, m, "refl_layered_trace_ray");
    }
    // Batches: equal to single traces; out overlapping the rays refused.
    let n = b.below(4) as usize;
    let rays: Vec<refl_ray> = (0..n).map(|k| if k == 0 { ray } else { refl_ray { origin: ray.origin, dir: b.dir3() } }).collect();
    let out_len = b.len_for(n);
    let mut outs = Buf::<refl_layered_result>::sentinel(out_len, if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid });
    let rb = Buf::from_slice(&rays, PtrKind::Valid);
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_layered_trace_rays(outs.ptr(), out_len, &md, rb.cptr(), n, tm, &p) };
    null_rules_m(s, false, outs.is_null() || m.any_null(), outs.kind() == PtrKind::Misaligned, "refl_layered_trace_rays");
    let untouched = (0..out_len).all(|i| outs.is_sentinel(i));
    on_error_untouched(s, &[("out", untouched)], "refl_layered_trace_rays");
    for i in n..out_len {
        assert!(outs.is_sentinel(i), "refl_layered_trace_rays wrote out[{i}] past {n}");
    }
    if s == refl_status::Ok && n > 0 {
        for (k, r) in rays.iter().enumerate() {
            let mut one = refl_layered_result::default();
            // SAFETY: valid pointers.
            let s1 = unsafe { refl_layered_trace_ray(&mut one, &md, *r, tm, &p) };
            assert_eq!(s1, refl_status::Ok, "batch accepted ray {k} that refl_layered_trace_ray refuses");
            let o = outs.get(k);
            assert!(o.hit == one.hit && o.miss == one.miss && o.t.to_bits() == one.t.to_bits() && o.payload == one.payload, "batch result {k} differs");
        }
        // out overlapping the rays: refused, nothing written.
        let mut mem = vec![0u64; (n * core::mem::size_of::<refl_layered_result>()).div_ceil(8)];
        // SAFETY: mem holds n rays.
        unsafe { core::ptr::copy_nonoverlapping(rays.as_ptr(), mem.as_mut_ptr().cast::<refl_ray>(), n) };
        let before = mem.clone();
        let pm = mem.as_mut_ptr();
        // SAFETY: valid (overlapping) pointers.
        let s2 = unsafe { refl_layered_trace_rays(pm.cast(), n, &md, pm.cast::<refl_ray>().cast_const(), n, tm, &p) };
        assert_eq!(s2, refl_status::InvalidArgument, "refl_layered_trace_rays with out overlapping rays");
        assert!(mem == before, "refused overlapping batch wrote");
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    if b.chance(32) {
        check_len(&mut b);
    }
    if b.chance(16) {
        let eye = b.vec3_in(-5.0, 5.0);
        let c = b.vec3_in(-5.0, 5.0);
        let r = b.f32_in(-0.5, 3.0);
        let (p0, p1, p2) = (b.vec3_in(-3.0, 3.0), b.vec3_in(-3.0, 3.0), b.vec3_in(-3.0, 3.0));
        let mut o = out1::<u32>(b.ptr_kind());
        // SAFETY: NULL, misaligned or valid.
        let s = unsafe { refl_layered_prr_classify(o.ptr(), eye, c, r, p0, p1, p2) };
        null_rules(s, o.is_null(), o.is_null(), "refl_layered_prr_classify");
        on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_layered_prr_classify");
        if s == refl_status::Ok {
            assert!(o.get(0) <= 5, "PRR class {}", o.get(0));
            assert!(r > 0.0 && [eye, c, p0, p1, p2].iter().all(|v| finite3(*v)), "PRR accepted bad input");
        } else if o.usable() && (!(r > 0.0) || ![eye, c, p0, p1, p2].iter().all(|v| finite3(*v))) {
            assert_eq!(s, refl_status::InvalidArgument, "PRR of bad input");
        }
    }
    let g = grid(&mut b);
    // Face rays of the grid.
    for _ in 0..2 {
        let f = if b.chance(16) { 6 + b.below(3) } else { b.below(6) };
        let (i, j) = (b.below(g.face_res.saturating_add(1).min(64)), b.below(g.face_res.saturating_add(1).min(64)));
        let gb = Buf::from_slice(&[g], b.ptr_kind());
        let mut o = out1::<refl_layered_column_ray>(b.ptr_kind());
        // SAFETY: NULL, misaligned or valid.
        let s = unsafe { refl_layered_face_ray(o.ptr(), gb.cptr(), f, i, j) };
        let null = o.is_null() || gb.is_null();
        null_rules_m(s, null, null, o.kind() == PtrKind::Misaligned || gb.kind() == PtrKind::Misaligned, "refl_layered_face_ray");
        on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_layered_face_ray");
        if s == refl_status::Ok {
            assert!(f < 6 && i < g.face_res && j < g.face_res && grid_ok(&g), "face_ray accepted bad input");
            let r = o.get(0);
            assert!(finite3(r.origin) && finite3(r.dir) && r.t_max.is_finite() && r.t_max > 0.0, "face ray {r:?}");
            // F10, fixed: the length is taken in f64, so even a nearly
            // singular transform (an axis scaled by ~1e-22) gives a unit
            // direction.
            assert!((len3(r.dir) - 1.0).abs() < 1e-4, "face ray direction not unit: {r:?} grid {g:?} face {f} ({i}, {j})");
            let (lo, hi) = world_box(&g);
            let pad = 1e-3 * (1.0 + lo.iter().chain(hi.iter()).fold(0f32, |a, v| a.max(v.abs())));
            for p in [r.origin, v3(r.origin.x + r.t_max * r.dir.x, r.origin.y + r.t_max * r.dir.y, r.origin.z + r.t_max * r.dir.z)] {
                let q = [p.x, p.y, p.z];
                assert!((0..3).all(|a| q[a] >= lo[a] - pad && q[a] <= hi[a] + pad), "face ray point {q:?} outside the box");
            }
        }
    }
    let mut m = map(&mut b, g);
    let cleared = clear(&mut m) == refl_status::Ok;
    if !cleared {
        return;
    }
    for _ in 0..4 {
        if b.is_empty() {
            break;
        }
        match b.u8() % 5 {
            0 => fill_column(&mut b, &mut m),
            1 => {
                fill_face(&mut b, &mut m);
            }
            2 => {
                let d = m.desc_mut();
                let snap = m.snap();
                // SAFETY: valid pointers.
                let s = unsafe { refl_layered_build_bounds(&d) };
                null_rules(s, false, false, "refl_layered_build_bounds");
                assert_eq!(s, refl_status::Ok, "build_bounds of a cleared map");
                assert!(
                    m.depth.bytes() == &snap[0][..] && m.payload.bytes() == &snap[1][..] && m.counts.bytes() == &snap[2][..],
                    "build_bounds changed a texel"
                );
            }
            _ => trace(&mut b, &m),
        }
    }
});
