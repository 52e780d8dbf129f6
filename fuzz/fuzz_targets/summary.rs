//! The frame summary and the pass plan (issue 15): `refl_summary_options_default`,
//! `refl_summary_rows`, `refl_summary_merge_frame`,
//! `refl_summary_merge_object`, `refl_summary_object_plane`,
//! `refl_plan_options_default`, `refl_plan_passes`.
//!
//! A fuzzed G-buffer (`fuzz/src/gbuffer.rs`, shared with `ssr`: its corpus
//! seeds this one), an object-id image (sometimes absent, of another size,
//! short, NULL or misaligned, ids past the list and `NO_OBJECT`), an object
//! list of 0 to 4 records (sometimes NULL or misaligned, or over the ids),
//! fuzzed options and row bands. Checked: the NULL and error rules (nothing
//! written on error, inputs never written), valid input accepted and
//! accepted input valid; on OK the counts add up (pixels of the band,
//! surfaces, reflective pixels per class, tiles of the band, objects'
//! pixels plus unlisted equal to the reflective count, per-object classes,
//! border pixels and rectangles in the image), the summary is the same as
//! two half bands merged, and the plane fit is finite with a unit normal
//! and a coherence in [0, 1] or `DEGENERATE_GEOMETRY` for an empty object.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const TILE: u32 = 8;
const NO_OBJECT: u32 = u32::MAX;

fn options(b: &mut Bytes) -> refl_summary_options {
    let mut o = refl_summary_options_default();
    if b.chance(48) {
        o.mirror_roughness = b.pick(&[0.0, 0.05, 0.3, -0.1, f32::NAN, f32::INFINITY]);
    }
    if b.chance(48) {
        o.glossy_roughness = b.pick(&[0.1, 0.5, 2.0, f32::INFINITY, f32::NAN, 0.0]);
    }
    if b.chance(32) {
        o.border_pixels = b.pick(&[0, 1, 8, 100, u32::MAX]);
    }
    if b.chance(32) {
        o.plane_tolerance = b.pick(&[0.0, 1e-3, 1.0, -1.0, f32::INFINITY, f32::NAN]);
    }
    if b.chance(32) {
        o.normal_cos = b.pick(&[0.0, 0.5, 0.99, 1.0, 1.5, -0.1, f32::NAN]);
    }
    o
}

fn options_ok(o: &refl_summary_options) -> bool {
    o.mirror_roughness >= 0.0
        && o.mirror_roughness.is_finite()
        && o.glossy_roughness >= o.mirror_roughness
        && o.plane_tolerance >= 0.0
        && o.plane_tolerance.is_finite()
        && (0.0..=1.0).contains(&o.normal_cos)
}

/// A band on tile rows (mostly), or a fuzzed one.
fn rows(b: &mut Bytes, h: u32) -> refl_row_range {
    if b.chance(200) {
        let tiles = h.div_ceil(TILE);
        let a = b.below(tiles.max(1));
        let e = a + 1 + b.below((tiles - a.min(tiles)).max(1));
        refl_row_range { begin: a.saturating_mul(TILE), end: e.saturating_mul(TILE).min(h) }
    } else {
        b.rows(h)
    }
}

fn rows_ok(r: refl_row_range, h: u32) -> bool {
    r.begin <= r.end && r.end <= h && r.begin % TILE == 0 && (r.end % TILE == 0 || r.end == h)
}

/// `refl_plan_passes` on a summary: the NULL and error rules, and on OK
/// the rules of `refl_core::plan` as the header states them.
fn check_plan(b: &mut Bytes, f: &refl_summary_frame, objs: &[refl_summary_object], so: &refl_summary_options, size: (u32, u32)) {
    let n = objs.len();
    let caps = refl_plan_host_caps { planar_views: b.bool(), ray_tracer: b.bool(), probe: b.bool() };
    let hints_len = match b.u8() % 4 {
        0 => 0,
        1 => n.saturating_sub(1),
        _ => n,
    };
    let hints: Vec<refl_plan_object_hints> =
        (0..hints_len).map(|_| refl_plan_object_hints { planar_mirror: b.bool(), layered_map: b.bool(), moving: b.chance(4) }).collect();
    let po = refl_plan_options {
        mirror_hiz: b.bool(),
        glossy_visibility: b.bool(),
        history: b.bool(),
        camera_still: b.bool(),
        scene_still: b.bool(),
    };
    let planar_len = if b.chance(16) { n.saturating_sub(1) } else { n };
    let mut planar = vec![true; planar_len.max(1)];
    let (w, h) = if b.chance(8) { (0, size.1) } else { size };
    let mut out = refl_plan { planar_objects: 99, ..Default::default() };
    // SAFETY: valid pointers for the stated lengths.
    let s = unsafe {
        refl_plan_passes(&mut out, planar.as_mut_ptr(), planar_len, f, objs.as_ptr(), n, if hints_len > 0 { hints.as_ptr() } else { core::ptr::null() }, hints_len, &caps, so, &po, w, h)
    };
    let what = "refl_plan_passes";
    null_rules_m(s, false, false, false, what);
    if s != refl_status::Ok {
        assert_eq!(out.planar_objects, 99, "{what}: wrote on error");
        assert!(planar.iter().all(|&p| p), "{what}: wrote planar on error");
        return;
    }
    assert!(hints_len == 0 || hints_len == n, "{what}: accepted {hints_len} hints for {n} objects");
    assert!(planar_len >= n && w > 0 && h > 0, "{what}: accepted planar_len {planar_len} or size {w}x{h}");
    let runs = |p: u32| out.passes[p as usize].reason == refl_plan_reason::Runs as u32;
    let mut planar_pixels = 0;
    for k in 0..n {
        let o = &objs[k];
        if planar[k] {
            assert!(caps.planar_views && o.pixels > 0 && o.classes[0] == o.pixels, "{what}: object {k} planar: {o:?}");
            planar_pixels += o.pixels;
        }
    }
    assert_eq!(out.planar_objects as usize, planar[..n].iter().filter(|&&p| p).count());
    for (k, d) in out.passes.iter().enumerate() {
        assert_eq!(d.pass as usize, k, "{what}: pass order");
        assert!(d.reason <= refl_plan_reason::MapsStale as u32, "{what}: reason {}", d.reason);
        assert!(d.reason == refl_plan_reason::Runs as u32 || d.bytes == 0, "{what}: bytes of a skipped pass");
    }
    // Nothing moved: every pass skipped as unchanged (every family is
    // built here), and only then.
    let unchanged = po.history && po.camera_still && po.scene_still && !hints.iter().any(|h| h.moving);
    for d in &out.passes {
        assert_eq!(d.reason == refl_plan_reason::Unchanged as u32, unchanged, "{what}: unchanged {po:?}");
    }
    if unchanged {
        return;
    }
    let listed_mirror: u64 = objs.iter().map(|o| o.classes[0]).sum();
    let want_mirror = listed_mirror - planar_pixels + f.classes[0].saturating_sub(listed_mirror);
    assert_eq!(out.mirror_pixels, want_mirror, "{what}: mirror pixels");
    assert_eq!(runs(refl_plan_pass::Mirror as u32), want_mirror > 0, "{what}: mirror pass");
    assert_eq!(runs(refl_plan_pass::Glossy as u32), f.classes[1] > 0, "{what}: glossy pass");
    assert_eq!(runs(refl_plan_pass::ColorPyramid as u32), f.classes[1] > 0, "{what}: color pyramid");
    assert_eq!(runs(refl_plan_pass::VisibilityPyramid as u32), f.classes[1] > 0 && po.glossy_visibility, "{what}: visibility pyramid");
    let glossy = runs(refl_plan_pass::Glossy as u32);
    let mirror = runs(refl_plan_pass::Mirror as u32);
    assert_eq!(runs(refl_plan_pass::Hiz as u32), glossy || (mirror && po.mirror_hiz), "{what}: Hi-Z");
    assert_eq!(runs(refl_plan_pass::Planar as u32), out.planar_objects > 0, "{what}: planar pass");
    assert_eq!(runs(refl_plan_pass::Probe as u32), f.classes[2] > 0 && caps.probe, "{what}: probe");
    if runs(refl_plan_pass::HostRays as u32) {
        assert!(caps.ray_tracer && (mirror || glossy || runs(refl_plan_pass::Layered as u32)), "{what}: host rays");
    }
    if runs(refl_plan_pass::Layered as u32) {
        assert!(hints.iter().any(|h| h.layered_map && !h.moving) && (mirror || glossy), "{what}: layered pass");
    }
    assert_eq!(runs(refl_plan_pass::Temporal as u32), po.history && mirror, "{what}: temporal pass");
}

fn summarize(
    g: &refl_gbuffer,
    ids: refl_image_u32,
    o: &refl_summary_options,
    n: usize,
    r: refl_row_range,
) -> (refl_status, refl_summary_frame, Vec<refl_summary_object>) {
    let mut f = refl_summary_frame::default();
    let mut objs = vec![refl_summary_object::default(); n.max(1)];
    // SAFETY: valid pointers; the G-buffer's images as fuzzed (accepted once).
    let s = unsafe { refl_summary_rows(&mut f, objs.as_mut_ptr(), n, g, ids, o, r) };
    (s, f, objs)
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);

    let d = refl_summary_options_default();
    assert!(options_ok(&d), "defaults out of range: {d:?}");
    assert!(d.mirror_roughness == 0.1 && d.glossy_roughness == 1.0 && d.border_pixels == TILE);

    let fg = FuzzGBuffer::new(&mut b, [96; 4]);
    let (w, h) = (fg.img.width, fg.img.height);
    let g = fg.desc();
    let o = options(&mut b);

    // Ids: absent, or an image (sometimes another size).
    let with_ids = !b.chance(48);
    let (iw, ih) = if b.chance(12) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    let istride = if b.chance(24) { b.stride(iw) } else { iw };
    let nobj = match b.u8() % 8 {
        0 => 0,
        k => 1 + usize::from(k % 4),
    };
    let iseed = b.u8();
    let ids = if with_ids {
        image_buf(
            &mut b,
            iw,
            ih,
            istride,
            |x, y| match (x.wrapping_mul(5) ^ y.wrapping_mul(3) ^ u32::from(iseed)) % 9 {
                0 => NO_OBJECT,
                1 => 7,
                k => k % 4,
            },
            NO_OBJECT,
        )
    } else {
        Buf::sentinel(0, PtrKind::Null)
    };
    let idesc = refl_image_u32 { data: ids.cptr(), len: ids.len(), width: iw, height: ih, stride: istride };
    let ids_snap = ids.snapshot();

    // Outputs: the frame (sometimes NULL / misaligned), the objects
    // (sometimes NULL, misaligned, or over the ids).
    // The summary adds to what they hold: zero, as a frame's first band.
    let mut frame = Buf::from_slice(&[refl_summary_frame::default()], b.ptr_kind());
    let okind = if nobj > 0 { b.ptr_kind() } else { PtrKind::Null };
    let mut objs = Buf::from_slice(&vec![refl_summary_object::default(); nobj], okind);
    let (frame_snap, objs_snap) = (frame.snapshot(), objs.snapshot());
    let alias = with_ids && nobj > 0 && ids.usable() && b.chance(10);
    let r = rows(&mut b, h);
    let gb = Buf::from_slice(&[g], b.ptr_kind());
    let ob = Buf::from_slice(&[o], b.ptr_kind());
    let optr = if alias { ids.cptr() as *mut refl_summary_object } else { objs.ptr() };
    // SAFETY: pointers NULL, misaligned or valid for their lengths (an
    // aliased list is refused before it is touched).
    let s = unsafe { refl_summary_rows(frame.ptr(), optr, nobj, gb.cptr(), if with_ids { idesc } else { refl_image_u32 { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 } }, ob.cptr(), r) };
    let what = "refl_summary_rows";
    let required_null = frame.is_null() || gb.is_null() || ob.is_null() || (nobj > 0 && optr.is_null());
    let nested_null = fg.normals.0.is_null() || fg.img.buf.is_null() || (with_ids && ids.is_null());
    let mis = [
        frame.kind(),
        objs.kind(),
        gb.kind(),
        ob.kind(),
        ids.kind(),
        fg.img.buf.kind(),
        fg.normals.0.kind(),
        fg.mask.0.kind(),
        fg.roughness.0.kind(),
        fg.color.0.kind(),
        fg.back.0.kind(),
    ]
    .contains(&PtrKind::Misaligned)
        || (optr as usize) % core::mem::align_of::<refl_summary_object>() != 0;
    let nested_null = nested_null || fg.mask.0.is_null() || fg.roughness.0.is_null() || fg.color.0.is_null() || fg.back.0.is_null();
    null_rules_m(s, required_null, required_null || nested_null, mis, what);
    on_error_untouched(
        s,
        &[("frame", frame.bytes() == &frame_snap[..]), ("objects", objs.bytes() == &objs_snap[..])],
        what,
    );
    fg.assert_unchanged(what);
    ids.assert_unchanged(&ids_snap, what);
    if alias {
        assert_ne!(s, refl_status::Ok, "{what}: accepted objects over the ids");
        return;
    }
    // A NULL `ids.data` is no id image, whatever its other fields say.
    let ids_present = with_ids && !ids.is_null();
    let ids_ok = !ids_present || (ids.usable() && iw == w && ih == h && istride >= iw && required_len(iw, ih, istride).is_some_and(|n| ids.len() >= n));
    let outs_ok = frame.usable() && (nobj > 0 && objs.usable()) && gb.usable() && ob.usable();
    if s != refl_status::Ok {
        // (The optional images' own checks are the G-buffer's: not modeled.)
        return;
    }
    assert!(options_ok(&o), "{what}: accepted options {o:?}");
    assert!(rows_ok(r, h), "{what}: accepted rows {r:?} of {h}");
    assert!(nobj > 0 && outs_ok, "{what}: accepted {nobj} objects");
    fg.assert_accepted(what);
    assert!(ids_ok, "{what}: accepted ids of {iw}x{ih} (stride {istride}) for {w}x{h}: kind {:?} len {}", ids.kind(), ids.len());
    let f = frame.get(0);
    let band = u64::from(w) * u64::from(r.end - r.begin);
    assert_eq!(f.pixels, band, "{what}: pixels of the band");
    assert!(f.surfaces <= f.pixels && f.reflective <= f.surfaces && f.border <= f.reflective, "{what}: {f:?}");
    assert_eq!(f.classes.iter().sum::<u64>(), f.reflective, "{what}: classes {f:?}");
    let tile_rows = u64::from((r.end - r.begin).div_ceil(TILE));
    assert_eq!(f.tiles.iter().sum::<u64>(), tile_rows * u64::from(w.div_ceil(TILE)), "{what}: tiles {f:?}");
    let mut in_objects = 0;
    for k in 0..nobj {
        let x = objs.get(k);
        in_objects += x.pixels;
        assert_eq!(x.classes.iter().sum::<u64>(), x.pixels, "{what}: object {k} {x:?}");
        assert!(x.border_pixels <= x.pixels);
        if x.pixels > 0 {
            let [x0, y0, x1, y1] = x.rect;
            assert!(x0 < x1 && x1 <= w && y0 < y1 && y1 <= h && y0 >= r.begin && y1 <= r.end, "{what}: rect {:?}", x.rect);
            assert!((x1 - x0) as u64 * (y1 - y0) as u64 >= x.pixels);
        } else {
            assert_eq!(x.rect, [0; 4]);
        }
        // The plane fit.
        let mut fit = refl_summary_plane_fit::default();
        // SAFETY: valid pointers.
        let ps = unsafe { refl_summary_object_plane(&mut fit, &x, &o) };
        no_panic(ps, "refl_summary_object_plane");
        if x.pixels == 0 {
            assert_eq!(ps, refl_status::DegenerateGeometry, "plane of nothing");
        }
        if ps == refl_status::Ok {
            let nl = fit.normal.iter().map(|v| v * v).sum::<f64>().sqrt();
            assert!((nl - 1.0).abs() < 1e-9, "plane normal {fit:?}");
            // (At most 1 up to the f32 rounding of the unit normals.)
            assert!(fit.coherence >= 0.0 && fit.coherence <= 1.0 + 1e-6, "coherence {fit:?}");
            assert!(fit.rms_distance >= 0.0 && !fit.rms_distance.is_nan(), "rms {fit:?}");
            if fit.planar {
                assert!(x.pixels >= 3 && fit.coherence >= f64::from(o.normal_cos));
            }
        }
    }
    assert_eq!(in_objects + f.unlisted, f.reflective, "{what}: objects {in_objects} + unlisted {} of {f:?}", f.unlisted);
    if !ids_present {
        assert_eq!(f.unlisted, 0);
    }

    check_plan(&mut b, &f, &objs.to_vec(), &o, (w, h));

    // Two half bands (on a tile row) merged give the same counts.
    if r.end - r.begin > TILE {
        let mid = r.begin + ((r.end - r.begin) / 2).div_ceil(TILE) * TILE;
        if mid < r.end {
            let ids_now = if with_ids { idesc } else { refl_image_u32 { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 } };
            let (s1, mut f1, mut o1) = summarize(&g, ids_now, &o, nobj, refl_row_range { begin: r.begin, end: mid });
            let (s2, f2, o2) = summarize(&g, ids_now, &o, nobj, refl_row_range { begin: mid, end: r.end });
            assert!(s1 == refl_status::Ok && s2 == refl_status::Ok, "halves refused: {}", last_error());
            // SAFETY: valid pointers.
            unsafe {
                assert_eq!(refl_summary_merge_frame(&mut f1, &f2), refl_status::Ok);
                for k in 0..nobj {
                    assert_eq!(refl_summary_merge_object(&mut o1[k], &o2[k]), refl_status::Ok);
                }
            }
            assert_eq!(f1, f, "merged halves differ from one call");
            for k in 0..nobj {
                let (a, c) = (o1[k], objs.get(k));
                assert_eq!((a.pixels, a.classes, a.border_pixels, a.rect), (c.pixels, c.classes, c.border_pixels, c.rect), "object {k}");
            }
        }
    }
});
