//! The temporal filter (issue 18): `refl_temporal_options_default`,
//! `refl_temporal_resolve_rows`.
//!
//! A fuzzed G-buffer (`fuzz/src/gbuffer.rs`, shared with `ssr`: its corpus
//! seeds this one), this frame's reflection colors (sometimes NaN, Inf or
//! huge), answered flags (any byte), optional reflection distances (hits,
//! sky, 0, negative, NaN), a history (none, the output of a first call on
//! the same G-buffer, bound to the G-buffer's camera, a moved one or one of
//! another size, sometimes with texels tampered with: frames beyond
//! `max_frames`, NaN, negative depths, non-unit normals; or fuzzed texels
//! of any size), fuzzed options, row bands and output buffers (other sizes,
//! strides, short, NULL, misaligned; outputs aliasing the history, the
//! answered flags or each other). Checked: the NULL and error rules
//! (nothing written on error, inputs never written, the last-error
//! message), accepted input valid and valid input accepted; on OK only the
//! band's texels and statuses are written, statuses in range and equal to
//! the stats, every texel against its status (frames in [0, max_frames],
//! skipped texels empty with the current color, reset and unanswered ones
//! with the current color, blended and reset ones with this frame's
//! distance, colors finite where the current color is, unit normals and
//! positive depths where there is a surface, masked pixels skipped, no
//! history without a history), two bands equal one call, the history's own
//! buffer as `next` and a history of another size refused.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const SKIPPED: u8 = 0;
const BLENDED: u8 = 1;
const RESET: u8 = 2;
const RECOVERED: u8 = 3;
const UNANSWERED: u8 = 4;

fn options(b: &mut Bytes) -> refl_temporal_options {
    let mut o = refl_temporal_options_default();
    if b.chance(64) {
        o.max_frames = b.pick(&[1.0, 2.0, 4.0, 16.0, f32::INFINITY, 0.5, 0.0, -1.0, f32::NAN, f32::NEG_INFINITY, 1e30]);
    }
    if b.chance(48) {
        o.depth_tolerance = b.f32_in(-0.01, 0.3);
    }
    if b.chance(48) {
        o.normal_cos = b.f32_in(-1.2, 1.2);
    }
    if b.chance(48) {
        o.recover = b.bool();
    }
    if b.chance(48) {
        o.clamp_history = b.bool();
    }
    o
}

fn options_ok(o: &refl_temporal_options) -> bool {
    o.max_frames >= 1.0 && o.depth_tolerance >= 0.0 && o.depth_tolerance.is_finite() && (-1.0..=1.0).contains(&o.normal_cos)
}

fn texel_img(i: &Img<refl_temporal_texel>) -> refl_image_temporal_texel {
    refl_image_temporal_texel { data: i.buf.cptr(), len: i.buf.len(), width: i.w, height: i.h, stride: i.stride }
}

fn texel_mut(i: &mut Img<refl_temporal_texel>) -> refl_image_temporal_texel_mut {
    refl_image_temporal_texel_mut { data: i.buf.ptr(), len: i.buf.len(), width: i.w, height: i.h, stride: i.stride }
}

fn no_texels() -> refl_image_temporal_texel {
    refl_image_temporal_texel { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 }
}

fn texel_bits(t: &refl_temporal_texel) -> [u32; 9] {
    let (c, n) = (bits3(t.color), bits3(t.normal));
    [c[0], c[1], c[2], t.frames.to_bits(), n[0], n[1], n[2], t.depth.to_bits(), t.distance.to_bits()]
}

fn stats_of(s: &refl_temporal_stats) -> [u32; 6] {
    [s.blended, s.reset, s.recovered, s.unanswered, s.off_screen, s.rejected]
}

/// One call into fresh, valid outputs of `w x h` (stride `w`) over
/// `rows`: status, texels, statuses and stats.
#[allow(clippy::too_many_arguments)]
fn run(
    g: &refl_gbuffer,
    cur: refl_image_vec3,
    ans: refl_image_u8,
    dist: refl_image_f32,
    hist: &refl_temporal_history,
    o: &refl_temporal_options,
    w: u32,
    h: u32,
    rows: refl_row_range,
) -> (refl_status, Vec<refl_temporal_texel>, Vec<u8>, refl_temporal_stats) {
    let n = w as usize * h as usize;
    let mut next = Buf::<refl_temporal_texel>::sentinel(n, PtrKind::Valid);
    let mut status = Buf::<u8>::sentinel(n, PtrKind::Valid);
    let mut st = refl_temporal_stats::default();
    let nm = refl_image_temporal_texel_mut { data: next.ptr(), len: n, width: w, height: h, stride: w };
    let sm = refl_image_u8_mut { data: status.ptr(), len: n, width: w, height: h, stride: w };
    // SAFETY: valid outputs of the stated lengths; the inputs as fuzzed.
    let s = unsafe { refl_temporal_resolve_rows(&mut st, nm, sm, g, cur, ans, dist, hist, o, rows) };
    no_panic(s, "refl_temporal_resolve_rows");
    (s, next.to_vec(), status.to_vec(), st)
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);

    // Defaults: the documented values.
    let d = refl_temporal_options_default();
    assert!(options_ok(&d), "defaults out of range: {d:?}");
    assert!(d.max_frames == 8.0 && d.depth_tolerance == 0.02 && d.normal_cos == 0.9 && d.recover, "defaults {d:?}");

    let fg = FuzzGBuffer::new(&mut b, [96; 4]);
    let (w, h) = (fg.img.width, fg.img.height);
    let cam = fg.img.cam;
    let g = fg.desc();
    let n = w as usize * h as usize;

    // This frame's inputs.
    let cseed = b.u32();
    let chostile = b.u8();
    let cur = Img::<refl_vec3>::new(
        &mut b,
        w,
        h,
        |x, y| {
            let k = hash(x, y, cseed);
            if chostile > 200 && k % 13 == 0 {
                v3(hostile(k >> 8), 0.5, 0.5)
            } else {
                v3((k & 255) as f32 / 255.0, ((k >> 8) & 255) as f32 / 255.0, ((k >> 16) & 255) as f32 / 255.0)
            }
        },
        v3(-9.0, -9.0, -9.0),
    );
    let aseed = b.u32();
    let afail = b.u8() % 8;
    let ans = Img::<u8>::new(&mut b, w, h, |x, y| {
        let k = hash(x, y, aseed);
        if (k % 8) < u32::from(afail) { 0 } else { 1 + (k >> 8) as u8 % 255 }
    }, 0x77);
    let dseed = b.u32();
    let dist = if b.chance(128) {
        None
    } else {
        Some(Img::<f32>::new(&mut b, w, h, |x, y| {
            let k = hash(x, y, dseed);
            match k % 16 {
                0 => f32::INFINITY,
                1 => 0.0,
                2 => f32::NAN,
                3 => -1.0,
                4 => 1e30,
                _ => 0.05 + (k >> 8) as f32 / 16_777_216.0 * 8.0,
            }
        }, f32::NAN))
    };
    let dist_desc = dist.as_ref().map_or(img_f32(&Buf::sentinel(0, PtrKind::Null), 0, 0, 0), |i| img_f32(&i.buf, i.w, i.h, i.stride));
    // A NULL `data` is no distance image, whatever its other fields say.
    let dist = dist.filter(|i| !i.buf.is_null());
    let o = options(&mut b);

    // A first frame on the same G-buffer (valid outputs, default options,
    // no history): whether refl takes the G-buffer, and a history.
    let none = refl_temporal_history { camera: zero_camera(), texels: no_texels() };
    let first = if n > 0 && n <= 1 << 16 && cur.valid(w, h) && ans.valid(w, h) {
        let all = refl_row_range { begin: 0, end: h };
        let (s, t, _, _) = run(&g, vec3_img(&cur), u8_img(&ans), img_f32(&Buf::sentinel(0, PtrKind::Null), 0, 0, 0), &none, &d, w, h, all);
        check_last_error(s, "refl_temporal_resolve_rows");
        (s == refl_status::Ok).then_some(t)
    } else {
        None
    };
    if first.is_some() {
        fg.assert_accepted("refl_temporal_resolve_rows (first frame)");
    }
    let gb_ok = first.is_some();

    // The history.
    let hmode = b.u8();
    let (hcam, texels): (refl_camera, Option<Img<refl_temporal_texel>>) = match (hmode % 8, &first) {
        (0, _) => (camera(&mut b, w, h), None),
        (1..=5, Some(t)) => {
            let c = match hmode % 8 {
                1 | 2 => cam,
                3 | 4 => camera(&mut b, w, h),
                _ => {
                    let (cw, ch) = (b.side(MAX_SIDE), b.side(MAX_SIDE));
                    camera(&mut b, cw, ch)
                }
            };
            let mut t = t.clone();
            if b.chance(96) {
                // Tamper with some texels.
                let tseed = b.u32();
                let frames = b.pick(&[1e30, f32::INFINITY, f32::NAN, -1.0, 0.5, 1e3, 9.0, f32::MAX]);
                for (i, v) in t.iter_mut().enumerate() {
                    let k = hash(i as u32, 7, tseed);
                    match k % 11 {
                        0 => v.frames = frames,
                        1 => v.color = v3(hostile(k >> 4), 0.0, 1.0),
                        2 => v.depth = [f32::NAN, -1.0, 0.0, 1e30][(k >> 4) as usize % 4],
                        3 => v.normal = v3(3.0, 0.0, f32::NAN),
                        4 => v.distance = [f32::NAN, -2.0, f32::INFINITY, 1e35][(k >> 4) as usize % 4],
                        _ => {}
                    }
                }
            }
            let kind = if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid };
            let len = if b.chance(16) { b.len_for(n) } else { n };
            let buf = Buf::from_fn(len, kind, |i| t.get(i).copied().unwrap_or_default());
            (c, Some(Img { buf, w, h, stride: w }))
        }
        _ => {
            let c = if b.chance(128) { cam } else { camera(&mut b, w, h) };
            let tseed = b.u32();
            let img = Img::<refl_temporal_texel>::new(
                &mut b,
                c.width,
                c.height,
                |x, y| {
                    let k = hash(x, y, tseed);
                    refl_temporal_texel {
                        color: v3((k & 255) as f32 / 255.0, 0.5, if k % 29 == 0 { hostile(k >> 9) } else { 0.25 }),
                        frames: [0.0, 1.0, 2.0, 8.0, 0.5, 1e30, f32::NAN, -1.0][(k >> 3) as usize % 8],
                        normal: if k % 5 == 0 { v3(0.0, 0.0, 1.0) } else { v3(0.0, 1.0, 0.0) },
                        depth: 0.5 + ((k >> 12) & 1023) as f32 / 64.0,
                        distance: [0.0, 1.0, 3.0, f32::INFINITY, f32::NAN][(k >> 22) as usize % 5],
                    }
                },
                refl_temporal_texel::default(),
            );
            (c, Some(img))
        }
    };
    let hist = refl_temporal_history { camera: hcam, texels: texels.as_ref().map_or(no_texels(), texel_img) };
    // NULL texels are no history, whatever the descriptor's other fields
    // and the camera say.
    let texels = texels.filter(|t| !t.buf.is_null());
    let hist_snap = texels.as_ref().map(|t| t.buf.snapshot());

    // The outputs and the call.
    let rows = b.rows(h);
    let mut next = Img::<refl_temporal_texel>::output(&mut b, w, h);
    let mut status = if b.chance(64) {
        Img { buf: Buf::sentinel(0, PtrKind::Null), w: b.side(MAX_SIDE), h: b.side(MAX_SIDE), stride: 0 }
    } else {
        Img::<u8>::output(&mut b, w, h)
    };
    let with_status = !status.buf.is_null();
    let mut st = out1::<refl_temporal_stats>(b.ptr_kind());
    let gbp = Buf::from_slice(&[g], b.ptr_kind());
    let hp = Buf::from_slice(&[hist], b.ptr_kind());
    let op = Buf::from_slice(&[o], b.ptr_kind());
    let mut nm = texel_mut(&mut next);
    let mut sm = u8_mut(&mut status);
    let mut stp = st.ptr();
    // Outputs aliasing an input or each other.
    let alias = b.u8() % 32;
    let aliased = match alias {
        0 if texels.as_ref().is_some_and(|t| t.buf.usable() && !t.buf.is_empty()) => {
            nm.data = hist.texels.data.cast_mut();
            nm.len = nm.len.min(hist.texels.len);
            true
        }
        1 if ans.buf.usable() && !ans.buf.is_empty() => {
            sm.data = ans.buf.cptr().cast_mut();
            sm.len = sm.len.max(1).min(ans.buf.len());
            true
        }
        2 if next.buf.usable() && next.buf.len() * 36 >= 24 => {
            stp = nm.data.cast();
            true
        }
        3 if next.buf.usable() && !next.buf.is_empty() => {
            sm.data = nm.data.cast();
            sm.len = sm.len.max(1).min(next.buf.len() * 36);
            true
        }
        _ => false,
    };
    let cur_snap = cur.buf.snapshot();
    let ans_snap = ans.buf.snapshot();
    let dist_snap = dist.as_ref().map(|i| i.buf.snapshot());
    // SAFETY: pointers NULL, misaligned or valid for their lengths (an
    // aliased output within the buffer it aliases).
    let s = unsafe {
        refl_temporal_resolve_rows(stp, nm, sm, gbp.cptr(), vec3_img(&cur), u8_img(&ans), dist_desc, hp.cptr(), op.cptr(), rows)
    };
    let what = "refl_temporal_resolve_rows";
    // The pointers as passed (an aliased output points into another
    // buffer).
    let req_null = stp.is_null()
        || nm.data.is_null()
        || gbp.is_null()
        || cur.buf.is_null()
        || ans.buf.is_null()
        || hp.is_null()
        || op.is_null()
        || fg.img.buf.is_null()
        || fg.normals.0.is_null();
    let mis = [gbp.kind(), hp.kind(), op.kind(), cur.buf.kind(), fg.img.buf.kind(), fg.normals.0.kind(), fg.roughness.0.kind(), fg.color.0.kind(), fg.back.0.kind()]
        .contains(&PtrKind::Misaligned)
        || (stp as usize) % 4 != 0
        || (nm.data as usize) % 4 != 0
        || dist.as_ref().is_some_and(|i| i.buf.kind() == PtrKind::Misaligned)
        || texels.as_ref().is_some_and(|i| i.buf.kind() == PtrKind::Misaligned);
    null_rules_m(s, req_null, req_null, mis, what);
    // Nothing is written on error, wherever the outputs point.
    on_error_untouched(
        s,
        &[
            ("out_stats", st.is_sentinel(0)),
            ("next", (0..next.buf.len()).all(|i| next.buf.is_sentinel(i))),
            ("status", (0..status.buf.len()).all(|i| status.buf.is_sentinel(i))),
        ],
        what,
    );
    // Inputs never written (an aliased one included, when refused).
    fg.assert_unchanged(what);
    cur.buf.assert_unchanged(&cur_snap, "current");
    ans.buf.assert_unchanged(&ans_snap, "answered");
    if let (Some(i), Some(sn)) = (&dist, &dist_snap) {
        i.buf.assert_unchanged(sn, "distance");
    }
    if let (Some(t), Some(sn)) = (&texels, &hist_snap) {
        t.buf.assert_unchanged(sn, "history.texels");
    }

    // Whether every argument is valid (the G-buffer by the first frame).
    let hist_ok = texels.as_ref().is_none_or(|t| camera_ok(&hcam) && hcam.width == w && hcam.height == h && t.valid(w, h));
    let rows_ok = rows.begin < rows.end && rows.end <= h;
    let dist_ok = dist.as_ref().is_none_or(|i| i.valid(w, h));
    let status_ok = !with_status || (status.w == w && status.h == h && required_len(w, h, status.stride).is_some_and(|k| status.buf.len() >= k));
    let args_ok = options_ok(&o)
        && rows_ok
        && cur.valid(w, h)
        && ans.valid(w, h)
        && dist_ok
        && hist_ok
        && next.valid(w, h)
        && status_ok
        && [st.kind(), gbp.kind(), hp.kind(), op.kind()].iter().all(|k| *k == PtrKind::Valid);
    if s == refl_status::Ok {
        assert!(!aliased, "{what} accepted an output aliasing an input or another output (mode {alias})");
        assert!(options_ok(&o), "{what} accepted options {o:?}");
        fg.assert_accepted(what);
        assert!(rows_ok, "{what} accepted rows {rows:?} of {h}");
        assert!(cur.valid(w, h) && ans.valid(w, h) && dist_ok, "{what} accepted an input image not of {w}x{h}");
        assert!(hist_ok, "{what} accepted a history of {}x{} (camera {}x{})", hist.texels.width, hist.texels.height, hcam.width, hcam.height);
        assert!(next.valid(w, h) && status_ok, "{what} accepted an output not of {w}x{h}");
    } else if gb_ok && args_ok && !aliased {
        panic!("{what} refused valid input: {s:?} {}", last_error());
    }
    if s != refl_status::Ok {
        return;
    }

    // The written texels and statuses.
    let stats = st.get(0);
    let mut counts = [0u32; 5];
    let mask_fn = |x: u32, y: u32| fg.masked(x, y);
    let mf = o.max_frames;
    for y in 0..h {
        for x in 0..w {
            let i = y as usize * next.stride as usize + x as usize;
            let j = y as usize * status.stride as usize + x as usize;
            if y < rows.begin || y >= rows.end {
                assert!(next.buf.is_sentinel(i), "texel ({x}, {y}) outside rows {rows:?} written");
                if with_status {
                    assert!(status.buf.is_sentinel(j), "status ({x}, {y}) outside rows {rows:?} written");
                }
                continue;
            }
            let t = next.buf.get(i);
            let c = cur.at(x, y);
            let answered = ans.at(x, y) != 0 && finite3(c);
            let sv = if with_status { status.buf.get(j) } else { u8::MAX };
            if with_status {
                assert!(sv <= UNANSWERED, "status {sv} at ({x}, {y})");
            }
            assert!(t.frames.is_finite() && t.frames >= 0.0 && t.frames <= mf, "({x}, {y}): frames {} outside [0, {mf}] (status {sv}): {t:?}", t.frames);
            if finite3(c) {
                assert!(finite3(t.color), "({x}, {y}): color {:?} not finite for a finite current color {c:?} (status {sv})", t.color);
            }
            if mask_fn(x, y) && with_status {
                assert_eq!(sv, SKIPPED, "masked ({x}, {y}) not skipped");
            }
            if with_status {
                counts[sv as usize] += 1;
                let same_color = bits3(t.color) == bits3(c);
                let this_distance = dist.as_ref().map_or(0.0, |i| {
                    let v = i.at(x, y);
                    if v > 0.0 { v } else { 0.0 }
                });
                match sv {
                    SKIPPED => {
                        assert!(same_color && t.frames == 0.0 && bits3(t.normal) == [0; 3] && t.depth.to_bits() == 0 && t.distance.to_bits() == 0, "skipped ({x}, {y}): {t:?}");
                    }
                    BLENDED | RESET => {
                        assert!(answered, "({x}, {y}) status {sv} but not answered ({c:?}, flag {})", ans.at(x, y));
                        assert_eq!(t.distance.to_bits(), this_distance.to_bits(), "({x}, {y}) status {sv}: distance");
                        if sv == RESET {
                            assert!(same_color && t.frames == 1.0, "reset ({x}, {y}): {t:?}");
                        } else {
                            assert!(texels.is_some() && t.frames >= 1.0, "blended ({x}, {y}): {t:?}");
                        }
                    }
                    RECOVERED => {
                        assert!(!answered && o.recover && texels.is_some(), "recovered ({x}, {y}): answered {answered}, recover {}", o.recover);
                        assert!(t.frames > 0.0 && t.distance >= 0.0, "recovered ({x}, {y}): {t:?}");
                        if dist.is_none() {
                            assert_eq!(t.distance.to_bits(), 0, "recovered ({x}, {y}) without distances: {t:?}");
                        }
                    }
                    _ => {
                        assert!(!answered, "unanswered ({x}, {y}) but answered");
                        assert!(same_color && t.frames == 0.0 && t.distance.to_bits() == 0, "unanswered ({x}, {y}): {t:?}");
                    }
                }
                if sv != SKIPPED {
                    assert!(t.depth > 0.0 && t.depth.is_finite(), "({x}, {y}) status {sv}: depth {}", t.depth);
                    assert!((len3(t.normal) - 1.0).abs() < 1e-3, "({x}, {y}) status {sv}: normal {:?}", t.normal);
                }
            }
        }
    }
    // Padding and texels past the image untouched.
    let band_texel = |i: usize, stride: u32| {
        let (x, y) = ((i % stride.max(1) as usize) as u32, (i / stride.max(1) as usize) as u32);
        x < w && y >= rows.begin && y < rows.end
    };
    for i in 0..next.buf.len() {
        if !band_texel(i, next.stride) {
            assert!(next.buf.is_sentinel(i), "texel {i} (padding or past the image) written");
        }
    }
    if with_status {
        for i in 0..status.buf.len() {
            if !band_texel(i, status.stride) {
                assert!(status.buf.is_sentinel(i), "status byte {i} (padding or past the image) written");
            }
        }
        assert_eq!([stats.blended, stats.reset, stats.recovered, stats.unanswered], [counts[1], counts[2], counts[3], counts[4]], "stats {stats:?}");
    }
    assert!(stats.off_screen + stats.rejected <= stats.reset + stats.unanswered, "stats {stats:?}");
    if texels.is_none() {
        assert_eq!((stats.blended, stats.recovered, stats.off_screen, stats.rejected), (0, 0, 0, 0), "history without a history: {stats:?}");
    }
    let band_pixels = (rows.end - rows.begin) as u64 * u64::from(w);
    assert!(u64::from(stats.blended + stats.reset + stats.recovered + stats.unanswered) <= band_pixels, "stats {stats:?}");

    // Two bands equal one call.
    let dist_for_bands = dist_desc;
    if b.chance(96) && h >= 2 && n <= (MAX_SIDE * MAX_SIDE) as usize {
        let all = refl_row_range { begin: 0, end: h };
        let k = 1 + b.below(h - 1);
        let (s1, t1, v1, st1) = run(&g, vec3_img(&cur), u8_img(&ans), dist_for_bands, &hist, &o, w, h, all);
        let (s2, t2, v2, st2) = run(&g, vec3_img(&cur), u8_img(&ans), dist_for_bands, &hist, &o, w, h, refl_row_range { begin: 0, end: k });
        let (s3, t3, v3_, st3) = run(&g, vec3_img(&cur), u8_img(&ans), dist_for_bands, &hist, &o, w, h, refl_row_range { begin: k, end: h });
        assert!(s1 == refl_status::Ok && s2 == refl_status::Ok && s3 == refl_status::Ok, "bands refused: {s1:?} {s2:?} {s3:?} (k {k} of {h}): {}", last_error());
        let split = (k * w) as usize;
        for i in 0..n {
            let (pt, pv) = if i < split { (&t2[i], v2[i]) } else { (&t3[i], v3_[i]) };
            assert_eq!(texel_bits(&t1[i]), texel_bits(pt), "texel {i} differs between one call and two bands (k {k})");
            assert_eq!(v1[i], pv, "status {i} differs between one call and two bands");
        }
        let sum: Vec<u32> = stats_of(&st2).iter().zip(stats_of(&st3)).map(|(a, c)| a + c).collect();
        assert_eq!(stats_of(&st1).to_vec(), sum, "stats of two bands");
    }

    // The history's own buffer as `next`: refused, the history untouched.
    if let (Some(t), Some(sn)) = (&texels, &hist_snap) {
        if b.chance(64) && t.buf.usable() && !t.buf.is_empty() {
            let nm2 = refl_image_temporal_texel_mut { data: t.buf.cptr().cast_mut(), len: t.buf.len(), width: w, height: h, stride: t.stride };
            let mut st2 = refl_temporal_stats::default();
            // SAFETY: refused before any write (the output overlaps the history).
            let s = unsafe {
                refl_temporal_resolve_rows(&mut st2, nm2, refl_image_u8_mut { data: core::ptr::null_mut(), len: 0, width: 0, height: 0, stride: 0 }, &g, vec3_img(&cur), u8_img(&ans), dist_desc, &hist, &o, rows)
            };
            null_rules(s, false, false, what);
            assert_eq!(s, refl_status::InvalidArgument, "{what} wrote the next history over the one it reads");
            assert!(last_error().contains("overlaps"), "{}", last_error());
            t.buf.assert_unchanged(sn, "history.texels (in place)");
        }
        // A history of another size (camera and texels agreeing): refused.
        if b.chance(64) && h >= 2 {
            let mut h2 = hist;
            h2.camera.height = h - 1;
            h2.texels.height = h - 1;
            if camera_ok(&h2.camera) {
                let (s, ..) = run(&g, vec3_img(&cur), u8_img(&ans), dist_desc, &h2, &o, w, h, rows);
                check_last_error(s, what);
                assert_eq!(s, refl_status::InvalidArgument, "{what} accepted a history of {w}x{} for a {w}x{h} G-buffer", h - 1);
            }
        }
    }
});
