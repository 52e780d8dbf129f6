//! Multiple bounces (issue 18): `refl_bounce_options_default`,
//! `refl_bounce_source_rows`.
//!
//! A fuzzed G-buffer (`fuzz/src/gbuffer.rs`; its lit color is required
//! here), the previous frame (the G-buffer's own depth image, or a fuzzed
//! one of any camera and size, with a final color of its size or another,
//! sometimes hostile: NaN, Inf, huge), fuzzed options, row bands and
//! outputs (other sizes, strides, short, NULL, misaligned; aliasing the lit
//! color, the previous color or each other). Checked: the NULL and error
//! rules (nothing written on error, inputs never written, the last-error
//! message), accepted input valid and valid input accepted; on OK only the
//! band's colors and statuses are written, statuses in range and equal to
//! the stats, every pixel that is not re-projected (and every pixel with
//! attenuation 0) the lit color bit for bit, re-projected pixels finite
//! where the lit color is, two bands equal one call.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const NO_SURFACE: u8 = 0;
const REPROJECTED: u8 = 1;

fn options(b: &mut Bytes) -> refl_bounce_options {
    let mut o = refl_bounce_options_default();
    if b.chance(64) {
        o.attenuation = b.pick(&[0.0, 0.25, 0.5, 1.0, 1.5, -0.1, f32::NAN, f32::INFINITY]);
    }
    if b.chance(48) {
        o.depth_tolerance = b.pick(&[0.0, 0.01, 0.1, 1.0, -0.01, f32::NAN, f32::INFINITY, 1e30]);
    }
    o
}

fn options_ok(o: &refl_bounce_options) -> bool {
    (0.0..=1.0).contains(&o.attenuation) && o.depth_tolerance >= 0.0 && o.depth_tolerance.is_finite()
}

/// One call into fresh, valid outputs of `w x h` over `rows`.
fn run(g: &refl_gbuffer, p: &refl_bounce_previous, o: &refl_bounce_options, w: u32, h: u32, rows: refl_row_range) -> (refl_status, Vec<refl_vec3>, Vec<u8>, refl_bounce_stats) {
    let n = w as usize * h as usize;
    let mut out = Buf::<refl_vec3>::sentinel(n, PtrKind::Valid);
    let mut status = Buf::<u8>::sentinel(n, PtrKind::Valid);
    let mut st = refl_bounce_stats::default();
    let om = refl_image_vec3_mut { data: out.ptr(), len: n, width: w, height: h, stride: w };
    let sm = refl_image_u8_mut { data: status.ptr(), len: n, width: w, height: h, stride: w };
    // SAFETY: valid outputs of the stated lengths; the inputs as fuzzed.
    let s = unsafe { refl_bounce_source_rows(&mut st, om, sm, g, p, o, rows) };
    no_panic(s, "refl_bounce_source_rows");
    (s, out.to_vec(), status.to_vec(), st)
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let d = refl_bounce_options_default();
    assert!(options_ok(&d) && d.attenuation == 1.0 && d.depth_tolerance == 0.02, "defaults {d:?}");

    let fg = FuzzGBuffer::new(&mut b, [96, 96, 8, 96]);
    let (w, h) = (fg.img.width, fg.img.height);
    let g = fg.desc();
    let n = w as usize * h as usize;

    // The previous frame: this G-buffer's depth (a static camera) or a
    // fuzzed depth image; a final color of its camera's size (mostly).
    let own = b.chance(128);
    let pimg = if own { None } else { Some(depth_image(&mut b)) };
    let pdesc = pimg.as_ref().map_or(fg.img.desc(), |i| i.desc());
    let pvalid = pimg.as_ref().map_or(fg.img.valid(), |i| i.valid());
    let (pw, ph) = (pdesc.camera.width, pdesc.camera.height);
    let cseed = b.u32();
    let chostile = b.u8();
    let pcolor = Img::<refl_vec3>::new(
        &mut b,
        pw.min(MAX_SIDE * 2),
        ph.min(MAX_SIDE * 2),
        |x, y| {
            let k = hash(x, y, cseed);
            if chostile > 200 && k % 11 == 0 {
                v3(hostile(k >> 8), 0.5, 0.5)
            } else {
                v3((k & 255) as f32 / 255.0, ((k >> 8) & 255) as f32 / 255.0, ((k >> 16) & 255) as f32 / 255.0)
            }
        },
        v3(-9.0, -9.0, -9.0),
    );
    let prev = refl_bounce_previous { depth: pdesc, color: vec3_img(&pcolor) };
    let o = options(&mut b);

    // Whether refl takes the G-buffer: a call with a valid previous frame
    // (its own depth and lit color) and valid outputs.
    let gb_ok = n > 0 && n <= 1 << 16 && fg.has_color() && {
        let own_prev = refl_bounce_previous { depth: g.depth, color: g.color };
        let (s, ..) = run(&g, &own_prev, &d, w, h, refl_row_range { begin: 0, end: h });
        check_last_error(s, "refl_bounce_source_rows");
        s == refl_status::Ok
    };
    if gb_ok {
        fg.assert_accepted("refl_bounce_source_rows (own previous frame)");
    }

    // The outputs and the call.
    let rows = b.rows(h);
    let mut out = Img::<refl_vec3>::output(&mut b, w, h);
    let mut status = if b.chance(64) { Img::absent(&mut b) } else { Img::<u8>::output(&mut b, w, h) };
    let with_status = !status.buf.is_null();
    let mut st = out1::<refl_bounce_stats>(b.ptr_kind());
    let gbp = Buf::from_slice(&[g], b.ptr_kind());
    let pp = Buf::from_slice(&[prev], b.ptr_kind());
    let op = Buf::from_slice(&[o], b.ptr_kind());
    let mut om = vec3_mut(&mut out);
    let mut sm = u8_mut(&mut status);
    let mut stp = st.ptr();
    let alias = b.u8() % 32;
    let aliased = match alias {
        0 if fg.color.0.usable() && !fg.color.0.is_empty() => {
            om.data = fg.color.0.cptr().cast_mut();
            om.len = om.len.min(fg.color.0.len());
            true
        }
        1 if pcolor.buf.usable() && !pcolor.buf.is_empty() => {
            om.data = pcolor.buf.cptr().cast_mut();
            om.len = om.len.min(pcolor.buf.len());
            true
        }
        2 if out.buf.usable() && out.buf.len() * 12 >= 16 => {
            stp = om.data.cast();
            true
        }
        3 if out.buf.usable() && !out.buf.is_empty() => {
            sm.data = om.data.cast();
            sm.len = sm.len.max(1).min(out.buf.len() * 12);
            true
        }
        _ => false,
    };
    let pcolor_snap = pcolor.buf.snapshot();
    let pdepth_snap = pimg.as_ref().map(|i| i.buf.snapshot());
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_bounce_source_rows(stp, om, sm, gbp.cptr(), pp.cptr(), op.cptr(), rows) };
    let what = "refl_bounce_source_rows";
    let pdepth_null = pimg.as_ref().map_or(fg.img.buf.is_null(), |i| i.buf.is_null());
    let req_null = stp.is_null() || om.data.is_null() || gbp.is_null() || pp.is_null() || op.is_null() || fg.img.buf.is_null() || fg.normals.0.is_null() || fg.color.0.is_null() || pdepth_null || pcolor.buf.is_null();
    let mis = [gbp.kind(), pp.kind(), op.kind(), pcolor.buf.kind(), fg.img.buf.kind(), fg.normals.0.kind(), fg.roughness.0.kind(), fg.color.0.kind(), fg.back.0.kind()].contains(&PtrKind::Misaligned)
        || pimg.as_ref().is_some_and(|i| i.buf.kind() == PtrKind::Misaligned)
        || (stp as usize) % 4 != 0
        || (om.data as usize) % 4 != 0;
    null_rules_m(s, req_null, req_null, mis, what);
    on_error_untouched(
        s,
        &[
            ("out_stats", st.is_sentinel(0)),
            ("out", (0..out.buf.len()).all(|i| out.buf.is_sentinel(i))),
            ("status", (0..status.buf.len()).all(|i| status.buf.is_sentinel(i))),
        ],
        what,
    );
    fg.assert_unchanged(what);
    pcolor.buf.assert_unchanged(&pcolor_snap, "previous.color");
    if let (Some(i), Some(sn)) = (&pimg, &pdepth_snap) {
        i.buf.assert_unchanged(sn, "previous.depth");
    }

    let prev_ok = pvalid && pcolor.valid(pw, ph);
    let rows_ok = rows.begin < rows.end && rows.end <= h;
    let status_ok = !with_status || (status.w == w && status.h == h && required_len(w, h, status.stride).is_some_and(|k| status.buf.len() >= k));
    let args_ok = options_ok(&o) && rows_ok && prev_ok && out.valid(w, h) && status_ok && [st.kind(), gbp.kind(), pp.kind(), op.kind()].iter().all(|k| *k == PtrKind::Valid);
    if s == refl_status::Ok {
        assert!(!aliased, "{what} accepted an output aliasing an input or another output (mode {alias})");
        assert!(options_ok(&o), "{what} accepted options {o:?}");
        fg.assert_accepted(what);
        assert!(fg.has_color(), "{what} accepted a G-buffer without a lit color");
        assert!(rows_ok, "{what} accepted rows {rows:?} of {h}");
        assert!(prev_ok, "{what} accepted an invalid previous frame (color {}x{}, camera {pw}x{ph})", pcolor.w, pcolor.h);
        assert!(out.valid(w, h) && status_ok, "{what} accepted an output not of {w}x{h}");
    } else if gb_ok && args_ok && !aliased {
        panic!("{what} refused valid input: {s:?} {}", last_error());
    }
    if s != refl_status::Ok {
        return;
    }

    // The written colors and statuses.
    assert!(out.untouched_outside(w, rows), "{what} wrote outside rows {rows:?}");
    if with_status {
        assert!(status.untouched_outside(w, rows), "{what} wrote statuses outside rows {rows:?}");
    }
    let stats = st.get(0);
    let mut counts = [0u32; 4];
    for y in rows.begin..rows.end {
        for x in 0..w {
            let c = out.at(x, y);
            let lit = fg.color_at(x, y);
            if with_status {
                let sv = status.at(x, y);
                assert!(sv <= 3, "status {sv} at ({x}, {y})");
                counts[sv as usize] += 1;
                if sv != REPROJECTED || o.attenuation == 0.0 {
                    assert_eq!(bits3(c), bits3(lit), "({x}, {y}) status {sv}: not the lit color");
                }
                if sv == REPROJECTED && finite3(lit) {
                    assert!(finite3(c), "({x}, {y}): re-projected color {c:?} not finite");
                }
                if sv == NO_SURFACE {
                    // No surface: the depth decodes to none or the normal is unusable.
                    continue;
                }
            } else if o.attenuation == 0.0 {
                assert_eq!(bits3(c), bits3(lit), "({x}, {y}): attenuation 0 but not the lit color");
            }
        }
    }
    if with_status {
        assert_eq!([stats.no_surface, stats.reprojected, stats.off_screen, stats.rejected], counts, "stats {stats:?}");
    }
    let band = u64::from(rows.end - rows.begin) * u64::from(w);
    assert_eq!(u64::from(stats.no_surface) + u64::from(stats.reprojected) + u64::from(stats.off_screen) + u64::from(stats.rejected), band, "stats {stats:?}");

    // Two bands equal one call.
    if b.chance(96) && h >= 2 && n <= (MAX_SIDE * MAX_SIDE) as usize && prev_ok {
        let k = 1 + b.below(h - 1);
        let (s1, c1, v1, st1) = run(&g, &prev, &o, w, h, refl_row_range { begin: 0, end: h });
        let (s2, c2, v2, st2) = run(&g, &prev, &o, w, h, refl_row_range { begin: 0, end: k });
        let (s3, c3, v3_, st3) = run(&g, &prev, &o, w, h, refl_row_range { begin: k, end: h });
        assert!(s1 == refl_status::Ok && s2 == refl_status::Ok && s3 == refl_status::Ok, "bands refused: {s1:?} {s2:?} {s3:?}: {}", last_error());
        let split = (k * w) as usize;
        for i in 0..n {
            let (pc, pv) = if i < split { (c2[i], v2[i]) } else { (c3[i], v3_[i]) };
            assert_eq!(bits3(c1[i]), bits3(pc), "color {i} differs between one call and two bands (k {k})");
            assert_eq!(v1[i], pv, "status {i} differs between one call and two bands");
        }
        let sum = [st2.reprojected + st3.reprojected, st2.rejected + st3.rejected, st2.off_screen + st3.off_screen, st2.no_surface + st3.no_surface];
        assert_eq!([st1.reprojected, st1.rejected, st1.off_screen, st1.no_surface], sum, "stats of two bands");
    }
});
