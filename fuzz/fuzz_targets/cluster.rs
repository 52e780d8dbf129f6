//! Second-order reflections (seed 003): `refl_cluster_options_default`,
//! `refl_cluster_camera_options_default`, `refl_cluster_bins_max`,
//! `refl_cluster_count_objects`, `refl_cluster_bin_layout`,
//! `refl_cluster_assign`, `refl_cluster_ranges`,
//! `refl_cluster_build_camera`, `refl_cluster_lobe_angle`, `refl_cluster_finalize`:
//! the per-frame pipeline over a fuzzed G-buffer.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const NONE: u32 = u32::MAX;

fn img_u32(buf: &Buf<u32>, w: u32, h: u32, stride: u32) -> refl_image_u32 {
    refl_image_u32 { data: buf.cptr(), len: buf.len(), width: w, height: h, stride }
}

fn img_v3(buf: &Buf<refl_vec3>, w: u32, h: u32, stride: u32) -> refl_image_vec3 {
    refl_image_vec3 { data: buf.cptr(), len: buf.len(), width: w, height: h, stride }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let mut p = refl_cluster_options_default();
    if b.chance(48) {
        match b.u8() % 3 {
            0 => p.max_theta_bins = b.pick(&[0, 1, 2, 1024, 1025, u32::MAX]),
            1 => p.max_phi_bins = b.pick(&[0, 1, 3, 1024, 1025]),
            _ => p.gain = b.f32_any(),
        }
    }
    let pvalid = (1..=1024).contains(&p.max_theta_bins) && (1..=1024).contains(&p.max_phi_bins) && p.gain.is_finite() && p.gain > 0.0;

    // bins_max
    let objects = match b.u8() % 4 {
        0 => b.u32(),
        _ => b.below(5),
    };
    {
        let mut o = out1::<u32>(b.ptr_kind());
        let pb = Buf::from_slice(&[p], b.ptr_kind());
        // SAFETY: NULL, misaligned or valid.
        let s = unsafe { refl_cluster_bins_max(o.ptr(), objects, pb.cptr()) };
        let null = o.is_null() || pb.is_null();
        null_rules_m(s, null, null, o.kind() == PtrKind::Misaligned || pb.kind() == PtrKind::Misaligned, "refl_cluster_bins_max");
        on_error_untouched(s, &[("out", o.is_sentinel(0))], "refl_cluster_bins_max");
        if o.usable() && pb.usable() {
            let n = u128::from(objects) * u128::from(p.max_theta_bins) * u128::from(p.max_phi_bins);
            let ok = pvalid && n <= u128::from(u32::MAX);
            assert_eq!(s == refl_status::Ok, ok, "bins_max({objects}, {p:?}): {s:?}");
            if ok {
                assert_eq!(u128::from(o.get(0)), n);
            }
        }
    }

    // The G-buffer: object ids, normals, positions (a floor seen by a
    // camera).
    let w = 1 + b.below(24);
    let h = 1 + b.below(24);
    let cam = camera(&mut b, w, h);
    let nobj = 1 + b.below(4);
    let n = (w * h) as usize;
    let mut positions = vec![v3(0.0, 0.0, 0.0); n];
    let mut normals = vec![v3(0.0, 1.0, 0.0); n];
    let mut ids = vec![NONE; n];
    let nmode = b.u8();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let mut r = refl_ray::default();
            // SAFETY: pointers valid.
            if unsafe { refl_camera_primary_ray(&mut r, &cam, refl_vec2 { x: x as f32 + 0.5, y: y as f32 + 0.5 }) } != refl_status::Ok {
                continue;
            }
            if r.dir.y < -1e-3 {
                let t = -r.origin.y / r.dir.y;
                positions[i] = v3(r.origin.x + t * r.dir.x, 0.0, r.origin.z + t * r.dir.z);
                ids[i] = (x * nobj / w.max(1)).min(nobj - 1);
                normals[i] = match nmode % 8 {
                    0 => b.vec3_in(-1.0, 1.0),
                    1 => {
                        let a = (x as f32) * 0.05;
                        v3(a.sin(), a.cos(), 0.0)
                    }
                    _ => v3(0.0, 1.0, 0.0),
                };
            }
        }
    }
    if b.chance(16) {
        for _ in 0..4 {
            let i = b.below(n as u32) as usize;
            ids[i] = b.u32();
        }
    }
    let stride = if b.chance(32) { b.stride(w) } else { w };
    let obj = image_buf(&mut b, w, h, stride, |x, y| ids[(y * w + x) as usize], 7);
    let nrm = image_buf(&mut b, w, h, stride, |x, y| normals[(y * w + x) as usize], v3(0.0, 1.0, 0.0));
    let pos = Buf::from_slice(&positions, PtrKind::Valid);
    let good = |bf_len: usize, kind: PtrKind| kind == PtrKind::Valid && required_len(w, h, stride).is_some_and(|k| bf_len >= k);
    let obj_ok = good(obj.len(), obj.kind());
    let nrm_ok = good(nrm.len(), nrm.kind());

    // count_objects (one band or the whole frame).
    let rows = b.rows(h);
    let counts_len = b.below(nobj + 2) as usize;
    let mut counts = Buf::<u32>::from_fn(counts_len, if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid }, |_| if b.chance(8) { u32::MAX - 1 } else { 0 });
    let before = counts.to_vec();
    let snap = counts.snapshot();
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_cluster_count_objects(counts.ptr(), counts_len, img_u32(&obj, w, h, stride), rows) };
    let null = (counts.is_null() && counts_len > 0) || obj.is_null();
    null_rules_m(s, null, null || counts.is_null(), counts.kind() == PtrKind::Misaligned || obj.kind() == PtrKind::Misaligned, "refl_cluster_count_objects");
    on_error_untouched(s, &[("counts", counts.bytes() == &snap[..])], "refl_cluster_count_objects");
    if s == refl_status::Ok {
        assert!(obj_ok && rows.begin <= rows.end && rows.end <= h, "count_objects accepted bad input");
        for (k, c0) in before.iter().enumerate() {
            let mut want = u64::from(*c0);
            for y in rows.begin..rows.end {
                for x in 0..w {
                    want += u64::from(obj.get((y * stride + x) as usize) == k as u32);
                }
            }
            assert_eq!(u64::from(counts.get(k)), want, "count of object {k}");
        }
    }

    // Whole-frame counts for the layout.
    let mut fc = vec![0u32; nobj as usize];
    for &i in &ids {
        if (i as usize) < fc.len() {
            fc[i as usize] += 1;
        }
    }
    let frame_pixels = if b.chance(16) { b.u64() % (2 * n as u64 + 1) } else { n as u64 };
    let out_len = b.len_for(fc.len());
    let mut layout = Buf::<refl_cluster_object_bins>::sentinel(out_len, if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid });
    let mut total = out1::<u32>(if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid });
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_cluster_bin_layout(total.ptr(), layout.ptr(), out_len, fc.as_ptr(), fc.len(), frame_pixels, &p) };
    let null = total.is_null() || layout.is_null();
    null_rules_m(s, null, null, total.kind() == PtrKind::Misaligned || layout.kind() == PtrKind::Misaligned, "refl_cluster_bin_layout");
    let lu = (0..out_len).all(|i| layout.is_sentinel(i));
    on_error_untouched(s, &[("out", lu), ("out_total", total.is_sentinel(0))], "refl_cluster_bin_layout");
    if s != refl_status::Ok {
        let sum: u64 = fc.iter().map(|c| u64::from(*c)).sum();
        if !null && layout.usable() && total.usable() && pvalid && frame_pixels > 0 && sum <= frame_pixels && out_len >= fc.len() {
            panic!("refl_cluster_bin_layout refused valid input: {s:?}");
        }
        return;
    }
    assert!(pvalid && frame_pixels > 0 && out_len >= fc.len(), "bin_layout accepted bad input");
    let lay: Vec<refl_cluster_object_bins> = (0..fc.len()).map(|k| layout.get(k)).collect();
    let mut next = 0u64;
    for (k, l) in lay.iter().enumerate() {
        assert!(l.theta_bins <= p.max_theta_bins && l.phi_bins <= p.max_phi_bins, "bins {l:?}");
        if fc[k] == 0 {
            assert!(l.theta_bins == 0 && l.phi_bins == 0, "invisible object {k} has bins {l:?}");
        }
        let nb = u64::from(l.theta_bins) * u64::from(l.phi_bins);
        if nb > 0 {
            assert_eq!(u64::from(l.first), next, "object {k} first id");
        }
        next += nb;
    }
    assert_eq!(u64::from(total.get(0)), next, "total cluster ids");
    for i in fc.len()..out_len {
        assert!(layout.is_sentinel(i), "bin_layout wrote past counts_len");
    }
    let clusters = total.get(0);

    // assign (a band or the whole frame)
    let rows = if b.chance(160) { refl_row_range { begin: 0, end: h } } else { b.rows(h) };
    let ids_stride = if b.chance(32) { b.stride(w) } else { w };
    let need = required_len(w, h, ids_stride).unwrap_or(4).min(1 << 14);
    let mut idbuf = Buf::<u32>::sentinel(if b.chance(16) { b.len_for(need) } else { need }, if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid });
    let snap = idbuf.snapshot();
    let lb = Buf::from_slice(&lay, PtrKind::Valid);
    let ids_desc = refl_image_u32_mut { data: idbuf.ptr(), len: idbuf.len(), width: w, height: h, stride: ids_stride };
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_cluster_assign(ids_desc, rows, img_v3(&nrm, w, h, stride), img_u32(&obj, w, h, stride), lb.cptr(), lay.len()) };
    let null = idbuf.is_null() || nrm.is_null() || obj.is_null();
    let mis = [idbuf.kind(), nrm.kind(), obj.kind()].contains(&PtrKind::Misaligned);
    // F1's rule: with another bad argument (a short input image, a bad
    // descriptor) the status may name that one rather than a NULL
    // `ids.data`.
    let f1 = !(obj_ok && nrm_ok) && s != refl_status::Ok;
    null_rules_m(s, null && !f1, null, mis, "refl_cluster_assign");
    on_error_untouched(s, &[("ids", idbuf.bytes() == &snap[..])], "refl_cluster_assign");
    if s != refl_status::Ok {
        return;
    }
    assert!(obj_ok && nrm_ok && rows.begin <= rows.end && rows.end <= h, "assign accepted bad input");
    let st = ids_stride as usize;
    for i in 0..idbuf.len() {
        let (x, y) = ((i % st) as u32, (i / st) as u32);
        if x >= w || y >= h || y < rows.begin || y >= rows.end {
            idbuf.assert_texel_unchanged(&snap, i, "refl_cluster_assign outside its band");
            continue;
        }
        let id = idbuf.get(i);
        let o = obj.get((y * stride + x) as usize);
        match lay.get(o as usize) {
            Some(l) if l.theta_bins * l.phi_bins > 0 => {
                assert!(
                    id == NONE || (id >= l.first && id < l.first + l.theta_bins * l.phi_bins),
                    "pixel ({x}, {y}) of object {o} got id {id}, object range {l:?}"
                );
            }
            _ => assert_eq!(id, NONE, "pixel ({x}, {y}) of an object without bins got id {id}"),
        }
    }
    if rows.begin != 0 || rows.end != h {
        return;
    }

    // ranges
    let ids_img = img_u32(&idbuf, w, h, ids_stride);
    let clustered = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).filter(|&(x, y)| idbuf.get((y * ids_stride + x) as usize) != NONE).count();
    let off_len = b.len_for(clusters as usize + 1);
    let ord_len = b.len_for(clustered);
    let mut offs = Buf::<u32>::sentinel(off_len, PtrKind::Valid);
    let mut order = Buf::<u32>::sentinel(ord_len, if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid });
    let mut tot = out1::<u32>(PtrKind::Valid);
    let cl = if b.chance(16) { clusters.saturating_sub(1) } else { clusters };
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_cluster_ranges(tot.ptr(), offs.ptr(), off_len, order.ptr(), ord_len, ids_img, cl) };
    null_rules_m(s, order.is_null(), order.is_null(), order.kind() == PtrKind::Misaligned, "refl_cluster_ranges");
    let untouched = (0..off_len).all(|i| offs.is_sentinel(i)) && (0..ord_len).all(|i| order.is_sentinel(i));
    on_error_untouched(s, &[("offsets/order", untouched), ("total", tot.is_sentinel(0))], "refl_cluster_ranges");
    if s != refl_status::Ok {
        return;
    }
    assert!(off_len > cl as usize && ord_len >= clustered, "ranges accepted short buffers");
    assert_eq!(tot.get(0) as usize, clustered, "clustered pixel count");
    assert_eq!(offs.get(0), 0);
    for c in 0..cl as usize {
        let (a, e) = (offs.get(c), offs.get(c + 1));
        assert!(a <= e, "offsets not monotone");
        let mut prev = None;
        for k in a..e {
            let px = order.get(k as usize);
            let (x, y) = (px % w, px / w);
            assert!(y < h && idbuf.get((y * ids_stride + x) as usize) == c as u32, "order entry {k} (pixel {px}) not in cluster {c}");
            assert!(prev.is_none_or(|q| q < px), "cluster {c} not in raster order");
            prev = Some(px);
        }
    }
    assert_eq!(offs.get(cl as usize) as usize, clustered, "last offset");
    for i in cl as usize + 1..off_len {
        assert!(offs.is_sentinel(i), "ranges wrote offsets past clusters + 1");
    }
    for i in clustered..ord_len {
        assert!(order.is_sentinel(i), "ranges wrote order past the count");
    }

    // Cluster camera of the first non-empty cluster.
    let Some(c) = (0..cl as usize).find(|&c| offs.get(c) < offs.get(c + 1)) else { return };
    let px: Vec<u32> = (offs.get(c)..offs.get(c + 1)).map(|k| order.get(k as usize)).collect();
    let mut cp = refl_cluster_camera_options_default();
    cp.max_resolution = 32;
    if b.chance(48) {
        match b.u8() % 7 {
            0 => cp.far_distance = b.f32_any(),
            1 => cp.cone_half_angle = b.f32_in(-0.1, 1.6),
            2 => cp.resolution_scale = b.f32_any(),
            3 => cp.max_resolution = b.pick(&[0, 1, 8]),
            4 => cp.min_pixels = b.pick(&[0, 1, 2, 50]),
            5 => cp.glossy_blur_radius = b.f32_any(),
            _ => cp.max_f = b.f32_in(0.0, 30.0),
        }
    }
    let eye = eye_of(&cam).unwrap_or(v3(0.0, 1.5, 4.0));
    let pixel_list: Vec<u32> = if b.chance(16) { px.iter().map(|p| if b.chance(32) { b.u32() } else { *p }).collect() } else { px.clone() };
    let posi = refl_image_vec3 { data: pos.cptr(), len: n, width: w, height: h, stride: w };
    let nb = Buf::from_slice(&normals, PtrKind::Valid);
    let nimg = refl_image_vec3 { data: nb.cptr(), len: n, width: w, height: h, stride: w };
    let mut cc = out1::<refl_cluster_camera>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_cluster_build_camera(cc.ptr(), posi, nimg, pixel_list.as_ptr(), pixel_list.len(), eye, &cp) };
    null_rules_m(s, cc.is_null(), cc.is_null(), cc.kind() == PtrKind::Misaligned, "refl_cluster_build_camera");
    on_error_untouched(s, &[("out", cc.is_sentinel(0))], "refl_cluster_build_camera");
    if s != refl_status::Ok {
        return;
    }
    assert!(pixel_list.iter().all(|&q| (q as usize) < n), "build_camera accepted a pixel outside the image");
    let camr = cc.get(0);
    assert!(camr.fallback <= 4, "fallback {}", camr.fallback);
    if camr.fallback != 0 {
        assert!(camr.camera.width == 0 && camr.f == 0.0 && camr.pixels_used == 0 && camr.normal == v3(0.0, 0.0, 0.0), "fallback record with fields {camr:?}");
        return;
    }
    assert!(camera_ok(&camr.camera), "cluster camera does not validate: {camr:?}");
    assert!((len3(camr.clip.normal) - 1.0).abs() < 1e-4 && (len3(camr.normal) - 1.0).abs() < 1e-4, "cluster normals {camr:?}");
    // Eq. 1's f after its guards: within [1 / max_f, max_f].
    let mf = cp.max_f.max(1.0);
    assert!(camr.f >= 1.0 / mf - 1e-6 && camr.f <= mf + 1e-4, "f = {} (max {})", camr.f, cp.max_f);
    if camr.planar {
        assert_eq!(camr.f, 1.0, "planar cluster f");
    }
    assert!(camr.pixels_used as usize <= pixel_list.len(), "pixels_used {}", camr.pixels_used);
    assert!(camr.camera.width <= cp.max_resolution && camr.camera.height <= cp.max_resolution, "cluster camera {}x{}", camr.camera.width, camr.camera.height);

    // Finalize against a depth image rendered through the cluster camera.
    let cw = camr.camera.width;
    let chh = camr.camera.height;
    let conv = b.convention();
    let dv = depth_values(&mut b, &camr.camera, conv.min(2), cw, chh);
    let db = Buf::from_slice(&dv, PtrKind::Valid);
    let colors = Buf::from_fn(dv.len(), PtrKind::Valid, |i| v3((i % 3) as f32 * 0.3, 0.5, 0.2));
    let dimg = refl_depth_image { depth: img_f32(&db, cw, chh, cw), camera: camr.camera, convention: conv };
    let lobe_rays = if b.chance(16) { b.pick(&[0, 65]) } else { 1 + b.below(4) };
    let fp = refl_cluster_finalize_input {
        thickness: refl_trace_thickness { constant: b.f32_in(0.0, 1.0), back_faces: refl_image_f32 { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 } },
        step: refl_step_options { stride: 1 + b.below(2), max_steps: 4096 },
        refine: b.bool(),
        lobe: refl_cluster_lobe { rays: lobe_rays, exponent: b.f32_in(0.0, 50.0), max_angle: b.f32_in(0.0, 1.6) },
        fade: b.bool(),
        seed: b.u32(),
        single_ray: b.chance(4),
    };
    let out_len = b.len_for(px.len());
    let mut shades = Buf::<refl_cluster_shade>::sentinel(out_len, PtrKind::Valid);
    let mut fb = out1::<u32>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe {
        refl_cluster_finalize(
            fb.ptr(), shades.ptr(), out_len, posi, nimg, px.as_ptr(), px.len(), eye, &camr, &dimg,
            refl_image_vec3 { data: colors.cptr(), len: colors.len(), width: cw, height: chh, stride: cw }, &fp,
        )
    };
    null_rules_m(s, fb.is_null(), fb.is_null(), fb.kind() == PtrKind::Misaligned, "refl_cluster_finalize");
    let su = (0..out_len).all(|i| shades.is_sentinel(i));
    on_error_untouched(s, &[("out", su), ("out_fallbacks", fb.is_sentinel(0))], "refl_cluster_finalize");
    if s != refl_status::Ok {
        return;
    }
    assert!(out_len >= px.len() && conv <= 2 && (1..=64).contains(&lobe_rays), "finalize accepted bad input");
    assert!(fb.get(0) as usize <= px.len(), "fallbacks {}", fb.get(0));
    for k in 0..px.len() {
        let sh = shades.get(k);
        assert!(sh.hits <= sh.rays && sh.rays >= 1, "shade {k}: {sh:?}");
        assert!(finite3(sh.rgb) && sh.hit_weight.is_finite() && sh.hit_weight >= 0.0, "shade {k}: {sh:?}");
        assert!((0.0..=1.0 + 1e-5).contains(&sh.env_weight), "env weight {}", sh.env_weight);
        assert!((len3(sh.mirror_dir) - 1.0).abs() < 1e-3, "mirror dir {:?}", sh.mirror_dir);
    }
    for i in px.len()..out_len {
        assert!(shades.is_sentinel(i), "finalize wrote past pixels_len");
    }
});
