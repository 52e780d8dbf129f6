//! Camera and planar-mirror exports: look-at, validation, rays, projection,
//! depth encoding, matrices, reprojection, reflect, planes, mirror matrix
//! and point, mirrored camera, oblique projection, status strings.
//!
//! The input is a sequence of operations on a small state (two cameras, two
//! planes); each operation calls one export with fuzzed arguments and
//! pointers (valid, NULL, misaligned, or an output aliasing an input) and
//! checks the header's contract.
#![no_main]

use core::ffi::CStr;
use core::mem::size_of;
use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

struct State {
    cams: [refl_camera; 2],
    planes: [refl_plane; 2],
}

/// Status epilogue of a call with one output `out` and pointer inputs whose
/// kinds are `ins`.
#[track_caller]
fn post<T: Copy>(s: refl_status, what: &str, out: &Buf<T>, ins: &[PtrKind]) {
    let null = out.is_null() || ins.contains(&PtrKind::Null);
    let mis = out.kind() == PtrKind::Misaligned || ins.contains(&PtrKind::Misaligned);
    null_rules_m(s, null, null, mis, what);
    if mis && !null {
        // A misaligned pointer is an invalid argument (or another error
        // found first), never a success.
        assert!(
            !matches!(s, refl_status::Ok | refl_status::NullPointer),
            "{what}: misaligned pointer gave {s:?}"
        );
    }
    on_error_untouched(s, &[("out", out.is_sentinel(0))], what);
}

/// Calls `f(out, input)` with `out` placed at the address of the input (a C
/// caller writing a result over its own argument) and checks it behaves as
/// the call `f(reference_out, copy)`: same status; on success the output's
/// first `significant` bytes equal the reference's, and the input's bytes
/// past the output are untouched; on error nothing changed.
fn alias<I: Copy, O: Copy>(
    input: I,
    significant: usize,
    what: &str,
    f: impl Fn(*mut O, *const I) -> refl_status,
) {
    let mut r = out1::<O>(PtrKind::Valid);
    let copy = Buf::from_slice(&[input], PtrKind::Valid);
    let s_ref = f(r.ptr(), copy.cptr());
    no_panic(s_ref, what);
    let n = size_of::<I>().max(size_of::<O>());
    let mut mem = vec![0u64; n.div_ceil(8)];
    // SAFETY: `mem` holds at least n bytes.
    let bytes = unsafe { core::slice::from_raw_parts_mut(mem.as_mut_ptr().cast::<u8>(), n) };
    bytes.fill(SENTINEL);
    // SAFETY: `mem` is 8-aligned and large enough for I.
    unsafe { mem.as_mut_ptr().cast::<I>().write(input) };
    // SAFETY: as above.
    let before = unsafe { core::slice::from_raw_parts(mem.as_ptr().cast::<u8>(), n) }.to_vec();
    let p = mem.as_mut_ptr();
    let s = f(p.cast::<O>(), p.cast::<I>().cast_const());
    no_panic(s, what);
    // SAFETY: as above.
    let after = unsafe { core::slice::from_raw_parts(mem.as_ptr().cast::<u8>(), n) };
    assert_eq!(s, s_ref, "{what}: aliased output changes the status");
    if s == refl_status::Ok {
        assert!(
            after[..significant] == r.bytes()[..significant],
            "{what}: aliased output differs from the separate one"
        );
        assert!(
            after[size_of::<O>()..] == before[size_of::<O>()..],
            "{what}: aliased call wrote past its output"
        );
    } else {
        assert!(after == &before[..], "{what}: aliased call failed but wrote");
    }
}


fn plane(b: &mut Bytes) -> refl_plane {
    match b.u8() % 4 {
        0 => refl_plane {
            normal: b.vec3_in(-2.0, 2.0),
            d: b.f32_any(),
        },
        _ => refl_plane {
            normal: b.dir3(),
            d: b.f32_in(-3.0, 3.0),
        },
    }
}

fn op_look_at(b: &mut Bytes, st: &mut State) {
    let eye = b.vec3_in(-10.0, 10.0);
    let target = if b.chance(8) { eye } else { b.vec3_in(-3.0, 3.0) };
    let up = if b.chance(48) {
        b.vec3_in(-1.0, 1.0)
    } else {
        v3(0.0, 1.0, 0.0)
    };
    let fov = b.f32_in(0.0, 3.2);
    let near = b.f32_in(0.0, 2.0);
    let far = match b.u8() % 4 {
        0 => f32::INFINITY,
        1 => b.f32_any(),
        _ => b.f32_in(0.0, 1000.0),
    };
    let (w, h) = (b.side(4096), b.side(4096));
    let mut out = out1::<refl_camera>(b.ptr_kind());
    // SAFETY: `out` is NULL, misaligned (refused) or writable.
    let s = unsafe { refl_camera_look_at(out.ptr(), eye, target, up, fov, near, far, w, h) };
    let err = last_error();
    post(s, "refl_camera_look_at", &out, &[]);
    if out.kind() != PtrKind::Valid {
        return;
    }
    let invalid = !(finite3(eye) && finite3(target) && finite3(up))
        || w == 0
        || h == 0
        || !(fov > 0.0 && fov < core::f32::consts::PI)
        || !(near > 0.0 && near.is_finite() && (1.0 / near).is_finite())
        || !(far > near);
    if invalid {
        assert!(s != refl_status::Ok, "refl_camera_look_at accepted invalid arguments");
    }
    if eye == target && finite3(eye) {
        assert!(s != refl_status::Ok, "refl_camera_look_at accepted eye == target");
    }
    if s != refl_status::Ok {
        assert!(
            matches!(s, refl_status::InvalidArgument | refl_status::DegenerateGeometry),
            "refl_camera_look_at: unexpected {s:?}"
        );
        // A field of view whose projection scale 1 / tan(fov / 2) is not
        // finite in f32 is refused as InvalidArgument (fixed F3).
        let t = (f64::from(fov) * 0.5).tan();
        let fov_ok = (t as f32) > 0.0 && (1.0 / t as f32).is_finite() && {
            let a = t * f64::from(w) / f64::from(h.max(1));
            (a as f32).is_finite() && (1.0 / a as f32).is_finite()
        };
        if !invalid && fov_ok && max_abs3(eye) < 1e18 && max_abs3(target) < 1e18 {
            // Only geometry can be at fault: eye == target or up parallel
            // to the view direction.
            assert_eq!(s, refl_status::DegenerateGeometry, "refl_camera_look_at({eye:?}, {target:?}, {up:?}, {fov}, {near}, {far}, {w}, {h}): {err}");
        }
        return;
    }
    let c = out.get(0);
    assert!(camera_ok(&c), "refl_camera_look_at made a camera refl_camera_validate refuses: {c:?}");
    assert!(
        c.fov_y == fov && c.z_near == near && c.z_far.to_bits() == far.to_bits() && c.width == w && c.height == h,
        "refl_camera_look_at changed a parameter"
    );
    let mut m = true;
    // SAFETY: pointers valid.
    assert_eq!(unsafe { refl_camera_is_mirrored(&mut m, &c) }, refl_status::Ok);
    assert!(!m, "a look-at camera is mirrored");
    if let Some(e) = eye_of(&c) {
        let tol = 1e-5 * (1.0 + max_abs3(eye)) + 1e-6 * max_abs3(target);
        let d = [e.x - eye.x, e.y - eye.y, e.z - eye.z];
        if max_abs3(eye) < 1e6 && max_abs3(target) < 1e6 {
            assert!(
                d.iter().all(|v| v.abs() <= tol * 4.0),
                "refl_camera_eye of a look-at camera is {e:?}, not {eye:?}"
            );
        }
    } else {
        panic!("refl_camera_eye refused a valid camera");
    }
    st.cams[b.below(2) as usize] = c;
}

fn op_validate(b: &mut Bytes, st: &mut State) {
    let c = if b.chance(128) {
        any_camera(b)
    } else {
        st.cams[b.below(2) as usize]
    };
    let cam = Buf::from_slice(&[c], b.ptr_kind());
    // SAFETY: NULL, misaligned or readable.
    let s = unsafe { refl_camera_validate(cam.cptr()) };
    null_rules(s, cam.is_null(), cam.is_null(), "refl_camera_validate");
    if cam.kind() != PtrKind::Valid {
        assert!(s != refl_status::Ok, "refl_camera_validate: bad pointer accepted");
        return;
    }
    let invalid = c.width == 0
        || c.height == 0
        || !(c.fov_y > 0.0 && c.fov_y < core::f32::consts::PI)
        || !(c.z_near > 0.0 && c.z_near.is_finite() && (1.0 / c.z_near).is_finite())
        || !(c.z_far > c.z_near)
        || !finite_mat(&c.view);
    if invalid {
        assert_eq!(s, refl_status::InvalidArgument, "refl_camera_validate({c:?})");
        return;
    }
    let last_row = [c.view.m[3], c.view.m[7], c.view.m[11], c.view.m[15]];
    if last_row != [0.0, 0.0, 0.0, 1.0] {
        assert_eq!(s, refl_status::DegenerateGeometry, "refl_camera_validate: last row");
        return;
    }
    // Fixed F3/F5: a camera whose projection scales (tan(fov_y / 2), its
    // aspect product, and their reciprocals) or whose eye (-R^-1 t, the
    // exact inverse since F20) are not finite in f32 is refused as
    // InvalidArgument, after the geometry check.
    let t = (f64::from(c.fov_y) * 0.5).tan();
    let a = t * f64::from(c.width) / f64::from(c.height);
    let scale_ok = [t, a].iter().all(|&v| (v as f32) > 0.0 && (v as f32).is_finite() && (1.0 / v as f32).is_finite());
    let eye_ok = eye_f64(&c.view.m).iter().all(|e| (*e as f32).is_finite());
    if s == refl_status::InvalidArgument {
        assert!(!(scale_ok && eye_ok), "refl_camera_validate({c:?}): InvalidArgument with finite scales and eye");
        return;
    }
    assert!(
        matches!(s, refl_status::Ok | refl_status::DegenerateGeometry),
        "refl_camera_validate: {s:?}"
    );
    if s == refl_status::Ok {
        assert!(scale_ok && eye_ok, "refl_camera_validate({c:?}) accepted a camera whose projection scale or eye overflows f32");
    }
    if s == refl_status::Ok {
        // "OK if every other function will accept it."
        let mut m4 = refl_mat4 { m: [0.0; 16] };
        let mut e = refl_vec3::default();
        let mut mi = false;
        // SAFETY: pointers valid.
        unsafe {
            assert_eq!(refl_camera_inverse_view(&mut m4, &c), refl_status::Ok);
            assert!(known_f5(&c) || finite_mat(&m4), "inverse view not finite: {c:?}");
            assert_eq!(refl_camera_eye(&mut e, &c), refl_status::Ok);
            assert!(known_f5(&c) || finite3(e), "eye not finite: {c:?}");
            assert_eq!(refl_camera_is_mirrored(&mut mi, &c), refl_status::Ok);
            for conv in [1, 2] {
                let s = refl_camera_projection_matrix(&mut m4, &c, conv);
                if s == refl_status::DegenerateGeometry && matrix_may_overflow(&c, false) {
                    continue;
                }
                assert_eq!(s, refl_status::Ok, "projection matrix of a valid camera {c:?}");
                assert!(finite_mat(&m4));
            }
        }
    }
}

fn cam_arg(b: &mut Bytes, st: &State) -> (refl_camera, Buf<refl_camera>) {
    let c = if b.chance(24) {
        any_camera(b)
    } else {
        st.cams[b.below(2) as usize]
    };
    let buf = Buf::from_slice(&[c], b.ptr_kind());
    (c, buf)
}

/// A pixel position: inside the image mostly, sometimes far outside or
/// hostile.
fn pixel(b: &mut Bytes, c: &refl_camera) -> refl_vec2 {
    let (w, h) = (c.width as f32, c.height as f32);
    if b.chance(24) {
        return refl_vec2 {
            x: b.f32_any(),
            y: b.f32_any(),
        };
    }
    refl_vec2 {
        x: b.f32_in(-0.5 * w, 1.5 * w),
        y: b.f32_in(-0.5 * h, 1.5 * h),
    }
}

fn op_primary_ray(b: &mut Bytes, st: &mut State) {
    let (c, cam) = cam_arg(b, st);
    let px = pixel(b, &c);
    let mut out = out1::<refl_ray>(b.ptr_kind());
    let snap = cam.snapshot();
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_camera_primary_ray(out.ptr(), cam.cptr(), px) };
    cam.assert_unchanged(&snap, "refl_camera_primary_ray input");
    post(s, "refl_camera_primary_ray", &out, &[cam.kind()]);
    if s != refl_status::Ok {
        if out.usable() && cam.usable() && camera_ok(&c) && px.x.is_finite() && px.y.is_finite() {
            assert_eq!(s, refl_status::InvalidArgument, "refl_camera_primary_ray");
        }
        return;
    }
    assert!(camera_ok(&c), "primary ray of an invalid camera");
    assert!(px.x.is_finite() && px.y.is_finite(), "primary ray through a non-finite pixel");
    let r = out.get(0);
    assert!(finite3(r.origin) && finite3(r.dir), "primary ray not finite: {r:?}");
    assert!((len3(r.dir) - 1.0).abs() < 1e-4, "primary ray direction not unit: {r:?}");
    let e = eye_of(&c).expect("eye");
    assert!(
        close(r.origin.x, e.x, 1e-5) && close(r.origin.y, e.y, 1e-5) && close(r.origin.z, e.z, 1e-5),
        "primary ray does not start at the eye"
    );
    if camera_moderate(&c) && px.x.abs() < 4.0 * c.width as f32 && px.y.abs() < 4.0 * c.height as f32 {
        let k = (2.0 * c.z_near).max(1.0);
        let p = v3(r.origin.x + k * r.dir.x, r.origin.y + k * r.dir.y, r.origin.z + k * r.dir.z);
        let q = project(&c, p).expect("a point on a primary ray is in front of the eye");
        let tol = 1e-3 * (px.x.abs() + px.y.abs()) + pixel_tol(&c, q.depth);
        assert!(
            (q.x - px.x).abs() <= tol && (q.y - px.y).abs() <= tol,
            "primary ray through {px:?} projects to ({}, {})",
            q.x,
            q.y
        );
    }
}

fn op_project(b: &mut Bytes, st: &mut State) {
    let (c, cam) = cam_arg(b, st);
    let p = b.vec3_in(-20.0, 20.0);
    let mut out = out1::<refl_projection>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_camera_project(out.ptr(), cam.cptr(), p) };
    post(s, "refl_camera_project", &out, &[cam.kind()]);
    let mut z = 0.0f32;
    let mut zo = out1::<f32>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let sz = unsafe { refl_camera_linear_depth(zo.ptr(), cam.cptr(), p) };
    post(sz, "refl_camera_linear_depth", &zo, &[cam.kind()]);
    if sz == refl_status::Ok {
        z = zo.get(0);
        assert!(z.is_finite(), "linear depth not finite");
    }
    if s != refl_status::Ok {
        if out.usable() && cam.usable() && camera_ok(&c) {
            assert!(!finite3(p), "refl_camera_project refused a finite point: {s:?}");
            assert_eq!(s, refl_status::InvalidArgument);
        }
        return;
    }
    assert!(finite3(p) && camera_ok(&c), "refl_camera_project accepted bad input");
    let valid = out.bytes()[12];
    assert!(valid <= 1, "refl_projection.valid byte {valid}");
    let o = out.get(0);
    if !o.valid {
        assert!(o.x == 0.0 && o.y == 0.0 && o.depth == 0.0, "invalid projection not zeroed");
    } else {
        assert!(o.x.is_finite() && o.y.is_finite() && o.depth.is_finite(), "projection not finite");
        assert!(o.depth > 0.0, "valid projection at depth {} (behind the eye)", o.depth);
        if sz == refl_status::Ok {
            assert!(close(o.depth, z, 1e-5), "projection depth {} vs linear depth {z}", o.depth);
        }
    }
}

fn op_unproject(b: &mut Bytes, st: &mut State) {
    let (c, cam) = cam_arg(b, st);
    let px = pixel(b, &c);
    let conv = b.convention();
    let depth = match conv {
        0 => b.f32_in(0.0, 200.0),
        _ => b.f32_in(0.0, 1.0),
    };
    let mut out = out1::<refl_vec3>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_camera_unproject(out.ptr(), cam.cptr(), px, depth, conv) };
    post(s, "refl_camera_unproject", &out, &[cam.kind()]);
    if s != refl_status::Ok {
        return;
    }
    assert!(conv <= 2 && depth.is_finite() && px.x.is_finite() && px.y.is_finite());
    let p = out.get(0);
    assert!(finite3(p), "unprojected point not finite");
    let z = decode(&c, depth, conv).expect("decode of an unprojectable depth");
    if camera_moderate(&c)
        && z > c.z_near * 0.5
        && z < 1e4
        && px.x.abs() < 4.0 * c.width as f32
        && px.y.abs() < 4.0 * c.height as f32
    {
        let q = project(&c, p).expect("unprojected point in front of the eye");
        let tol = 1e-3 * (px.x.abs() + px.y.abs()) + pixel_tol(&c, z);
        assert!(
            (q.x - px.x).abs() <= tol && (q.y - px.y).abs() <= tol,
            "unproject({px:?}) projects back to ({}, {})",
            q.x,
            q.y
        );
        assert!(close(q.depth, z, 1e-3), "unproject depth {z} projects back to {}", q.depth);
    }
}

fn op_depth(b: &mut Bytes, st: &mut State) {
    let (c, cam) = cam_arg(b, st);
    let conv = b.convention();
    let z = match b.u8() % 4 {
        0 => b.f32_any(),
        1 => f32::INFINITY,
        _ => b.f32_in(c.z_near, (c.z_near * 1000.0).min(c.z_far)),
    };
    let mut out = out1::<f32>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_camera_encode_depth(out.ptr(), cam.cptr(), z, conv) };
    post(s, "refl_camera_encode_depth", &out, &[cam.kind()]);
    if s == refl_status::Ok {
        assert!(conv <= 2 && !z.is_nan(), "encode accepted a bad input");
        let d = out.get(0);
        assert!(!d.is_nan(), "encoded depth is NaN");
        if conv == 0 {
            assert!(same_f32(d, z), "linear encoding is not the identity");
        }
        // Round trip: decode(encode(z)) ~ z where the encoding keeps
        // precision (z within 1000 near distances).
        if let Some(back) = decode(&c, d, conv) {
            if camera_moderate(&c) && z.is_finite() && z >= c.z_near && z <= c.z_near * 1000.0 && z <= c.z_far
            {
                assert!(close(back, z, 2e-3), "depth round trip {z} -> {d} -> {back} (conv {conv})");
            }
        } else if camera_moderate(&c) {
            panic!("decode refused the encoding {d} of {z} (conv {conv})");
        }
    } else if out.usable() && cam.usable() && camera_ok(&c) && conv <= 2 {
        assert!(z.is_nan() || s == refl_status::InvalidArgument, "encode: {s:?}");
    }
    // Decode side: encode(decode(d)) ~ d for stored depths in [0, 1].
    let d = match conv {
        0 => b.f32_in(0.0, 100.0),
        _ => b.f32_in(0.0, 1.0),
    };
    let mut out = out1::<f32>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_camera_decode_depth(out.ptr(), cam.cptr(), d, conv) };
    post(s, "refl_camera_decode_depth", &out, &[cam.kind()]);
    if s == refl_status::Ok {
        let zz = out.get(0);
        assert!(!zz.is_nan() && !d.is_nan() && conv <= 2);
        let mut e = 0.0f32;
        // SAFETY: pointers valid.
        let se = unsafe { refl_camera_encode_depth(&mut e, &c, zz, conv) };
        // (Extreme cameras, e.g. near = 1e-38, may decode to 0 whose
        // encoding is NaN: only moderate ones must round-trip.)
        if camera_moderate(&c) {
            assert_eq!(se, refl_status::Ok, "encode refused the decoding {zz} of {d} (conv {conv}) {c:?}");
        }
        if se == refl_status::Ok && camera_moderate(&c) && (0.0..=1.0).contains(&d) && conv != 0 {
            // The encoding's scale f / (f - n) amplifies rounding.
            let k = if c.z_far.is_finite() { (c.z_far / (c.z_far - c.z_near)).max(1.0) } else { 1.0 };
            assert!((e - d).abs() <= 1e-5 * k, "depth round trip {d} -> {zz} -> {e} (conv {conv})");
        }
    }
}

fn op_matrices(b: &mut Bytes, st: &mut State) {
    let (c, cam) = cam_arg(b, st);
    let conv = b.convention();
    let which = b.u8() % 3;
    let mut out = out1::<refl_mat4>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe {
        match which {
            0 => refl_camera_projection_matrix(out.ptr(), cam.cptr(), conv),
            1 => refl_camera_world_to_pixel_matrix(out.ptr(), cam.cptr(), conv),
            _ => refl_camera_inverse_view(out.ptr(), cam.cptr()),
        }
    };
    post(s, "camera matrix", &out, &[cam.kind()]);
    if s != refl_status::Ok {
        if which < 2 && out.usable() && cam.usable() && camera_ok(&c) && (conv == 1 || conv == 2) && !(s == refl_status::DegenerateGeometry && matrix_may_overflow(&c, which == 1)) {
            panic!("camera matrix {which} refused a valid camera: {s:?} {c:?}");
        }
        return;
    }
    let m = out.get(0);
    assert!(finite_mat(&m) || (which == 2 && known_f5(&c)), "camera matrix {which} not finite: {c:?}");
    if which < 2 {
        assert!(conv == 1 || conv == 2, "a matrix for convention {conv}");
    }
    if !camera_moderate(&c) {
        return;
    }
    match which {
        0 => {
            // clip.w = -z_view, clip.z / clip.w = stored depth.
            let z = b.f32_fine(c.z_near, (c.z_near * 100.0).min(c.z_far));
            let r = mat_mul4(&m, [0.0, 0.0, -f64::from(z), 1.0]);
            assert!((r[3] - f64::from(z)).abs() <= 1e-5 * f64::from(z), "clip.w != -z_view");
            let mut e = 0.0f32;
            // SAFETY: pointers valid.
            unsafe { refl_camera_encode_depth(&mut e, &c, z, conv) };
            assert!((r[2] / r[3] - f64::from(e)).abs() < 1e-4, "clip.z / clip.w {} vs stored depth {e}", r[2] / r[3]);
        }
        1 => {
            let mut ray = refl_ray::default();
            let px = refl_vec2 {
                x: b.f32_fine(0.0, c.width as f32),
                y: b.f32_fine(0.0, c.height as f32),
            };
            // SAFETY: pointers valid.
            if unsafe { refl_camera_primary_ray(&mut ray, &c, px) } != refl_status::Ok {
                return;
            }
            let k = b.f32_fine(c.z_near * 1.5, c.z_near * 50.0);
            let p = [
                f64::from(ray.origin.x) + f64::from(k * ray.dir.x),
                f64::from(ray.origin.y) + f64::from(k * ray.dir.y),
                f64::from(ray.origin.z) + f64::from(k * ray.dir.z),
            ];
            let r = mat_mul4(&m, [p[0], p[1], p[2], 1.0]);
            // f32 rounding of the eye and matrix scales with |eye| / k and
            // the focal length (`pixel_tol`).
            let tol = f64::from(c.width.max(c.height)) * 5e-3 + f64::from(pixel_tol(&c, k));
            assert!(
                (r[0] / r[3] - f64::from(px.x)).abs() <= tol && (r[1] / r[3] - f64::from(px.y)).abs() <= tol,
                "world-to-pixel maps a point on the ray through {px:?} to ({}, {}) {c:?} {m:?} {ray:?} {k}",
                r[0] / r[3],
                r[1] / r[3]
            );
        }
        _ => {
            let prod = mat_mul(&m, &c.view);
            let scale = 1.0 + c.view.m[12..15].iter().fold(0f64, |a, v| a.max(f64::from(v.abs())));
            for (k, v) in prod.iter().enumerate() {
                let want = if k % 5 == 0 { 1.0 } else { 0.0 };
                assert!((v - want).abs() <= 1e-4 * scale, "inverse_view * view != I at {k}: {v}");
            }
        }
    }
}

/// The eye of a view matrix (column-major `m`), `-R^-1 t` in f64 with the
/// exact inverse of the 3x3 part `R` (as `Camera::try_new` computes it).
fn eye_f64(m: &[f32; 16]) -> [f64; 3] {
    let r = |row: usize, col: usize| f64::from(m[4 * col + row]);
    let t = [f64::from(m[12]), f64::from(m[13]), f64::from(m[14])];
    // Inverse by the adjugate: inv[i][j] = cof[j][i] / det.
    let cof = |i: usize, j: usize| {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
        r(i1, j1) * r(i2, j2) - r(i1, j2) * r(i2, j1)
    };
    let det = r(0, 0) * cof(0, 0) + r(0, 1) * cof(0, 1) + r(0, 2) * cof(0, 2);
    let mut e = [0.0f64; 3];
    for (i, ei) in e.iter_mut().enumerate() {
        *ei = -(0..3).map(|j| cof(j, i) / det * t[j]).sum::<f64>();
    }
    e
}

fn op_eye_mirrored(b: &mut Bytes, st: &mut State) {
    let (c, cam) = cam_arg(b, st);
    let mut e = out1::<refl_vec3>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_camera_eye(e.ptr(), cam.cptr()) };
    post(s, "refl_camera_eye", &e, &[cam.kind()]);
    if s == refl_status::Ok && !known_f5(&c) {
        assert!(finite3(e.get(0)), "eye not finite: {c:?}");
    }
    let mut m = out1::<bool>(b.ptr_kind());
    // SAFETY: pointers NULL or valid (bool has alignment 1).
    let s2 = unsafe { refl_camera_is_mirrored(m.ptr(), cam.cptr()) };
    post(s2, "refl_camera_is_mirrored", &m, &[cam.kind()]);
    if s2 == refl_status::Ok {
        assert!(m.bytes()[0] <= 1, "is_mirrored wrote byte {}", m.bytes()[0]);
    }
    if cam.usable() && e.usable() && (s == refl_status::Ok) != camera_ok(&c) {
        panic!("refl_camera_eye {s:?} disagrees with refl_camera_validate");
    }
}

fn op_reprojection(b: &mut Bytes, st: &mut State) {
    let (from, fb) = cam_arg(b, st);
    let (to, tb) = cam_arg(b, st);
    let conv = b.convention();
    let mut m = out1::<refl_mat4>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_camera_reprojection_matrix(m.ptr(), fb.cptr(), tb.cptr(), conv) };
    post(s, "refl_camera_reprojection_matrix", &m, &[fb.kind(), tb.kind()]);
    let px = pixel(b, &from);
    let d = match conv {
        0 => b.f32_in(0.0, 100.0),
        _ => b.f32_in(0.0, 1.0),
    };
    let mut rp = out1::<refl_projection>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s2 = unsafe { refl_camera_reproject(rp.ptr(), fb.cptr(), tb.cptr(), px, d, conv) };
    post(s2, "refl_camera_reproject", &rp, &[fb.kind(), tb.kind()]);
    if s2 == refl_status::Ok {
        assert!(rp.bytes()[12] <= 1, "valid byte");
        let r = rp.get(0);
        if r.valid {
            assert!(r.x.is_finite() && r.y.is_finite() && r.depth.is_finite() && r.depth > 0.0, "reproject: {r:?}");
        } else {
            assert!(r.x == 0.0 && r.y == 0.0 && r.depth == 0.0, "invalid reprojection not zeroed");
        }
    } else if rp.usable() && fb.usable() && tb.usable() && camera_ok(&from) && camera_ok(&to) && conv <= 2 {
        assert!(!(px.x.is_finite() && px.y.is_finite() && d.is_finite()), "refl_camera_reproject refused: {s2:?}");
    }
    if s != refl_status::Ok {
        if conv == 0 {
            return;
        }
        return;
    }
    assert!(conv == 1 || conv == 2, "a reprojection matrix for convention {conv}");
    let mat = m.get(0);
    assert!(finite_mat(&mat), "reprojection matrix not finite");
    let mb = Buf::from_slice(&[mat], b.ptr_kind());
    let mut ap = out1::<refl_projection>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s3 = unsafe { refl_camera_apply_reprojection(ap.ptr(), mb.cptr(), px, d) };
    post(s3, "refl_camera_apply_reprojection", &ap, &[mb.kind()]);
    if s3 != refl_status::Ok {
        return;
    }
    assert!(ap.bytes()[12] <= 1, "valid byte");
    let a = ap.get(0);
    if !a.valid {
        assert!(a.x == 0.0 && a.y == 0.0 && a.depth == 0.0, "invalid projection not zeroed");
        return;
    }
    assert!(a.x.is_finite() && a.y.is_finite() && a.depth.is_finite());
    if s2 == refl_status::Ok && camera_moderate(&from) && camera_moderate(&to) {
        let r = rp.get(0);
        let z = decode(&from, d, conv).unwrap_or(f32::NAN);
        if r.valid && z.is_finite() && z > from.z_near && z < from.z_near * 100.0 && r.depth > to.z_near {
            let tol = 1e-2 * (to.width.max(to.height) as f32) + 1e-3 * (a.x.abs() + a.y.abs());
            if a.x.abs() < 1e4 && a.y.abs() < 1e4 {
                assert!(
                    (a.x - r.x).abs() <= tol && (a.y - r.y).abs() <= tol,
                    "reprojection matrix gives ({}, {}), refl_camera_reproject ({}, {})",
                    a.x,
                    a.y,
                    r.x,
                    r.y
                );
            }
        }
    }
}

fn op_reflect(b: &mut Bytes, _st: &mut State) {
    let v = if b.chance(64) { b.vec3_in(-1e3, 1e3) } else { b.dir3() };
    let n = match b.u8() {
        0..=15 => v3(0.0, 0.0, 0.0),
        16..=63 => b.vec3_in(-2.0, 2.0),
        _ => b.dir3(),
    };
    let mut out = out1::<refl_vec3>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_mirror_reflect(out.ptr(), v, n) };
    post(s, "refl_mirror_reflect", &out, &[]);
    if out.usable() && finite3(v) && n == v3(0.0, 0.0, 0.0) {
        assert_eq!(s, refl_status::DegenerateGeometry, "reflect about a zero normal");
    }
    if s != refl_status::Ok {
        return;
    }
    assert!(finite3(v) && finite3(n), "reflect accepted non-finite input");
    // A unit normal (|n|^2 within 2e-3 of 1).
    assert!((len3(n) * len3(n) - 1.0).abs() <= 2.1e-3, "reflect accepted the non-unit normal {n:?}");
    let r = out.get(0);
    assert!(finite3(r), "reflect result not finite");
    let [vx, vy, vz] = d3(v);
    let [nx, ny, nz] = d3(n);
    let k = 2.0 * (vx * nx + vy * ny + vz * nz);
    let want = [k * nx - vx, k * ny - vy, k * nz - vz];
    let scale = 1.0 + len3(v) * (1.0 + 2.0 * len3(n) * len3(n));
    for (a, w) in d3(r).iter().zip(want) {
        assert!((a - w).abs() <= 1e-5 * scale, "reflect({v:?}, {n:?}) = {r:?}, want {want:?}");
    }
}

/// Sine of the triangle's angle at p2 (f64): the f32 normal of a thin
/// triangle is accurate to about eps / sine.
fn sine_at_p2(p1: refl_vec3, p2: refl_vec3, p3: refl_vec3) -> f64 {
    let (a, b, c) = (d3(p1), d3(p2), d3(p3));
    let u = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let v = [c[0] - b[0], c[1] - b[1], c[2] - b[2]];
    let x = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let n = |w: [f64; 3]| (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    (n(x) / (n(u) * n(v))).max(1e-300)
}

fn op_planes(b: &mut Bytes, st: &mut State) {
    let p1 = b.vec3_in(-5.0, 5.0);
    let p2 = if b.chance(8) { p1 } else { b.vec3_in(-5.0, 5.0) };
    let p3 = b.vec3_in(-5.0, 5.0);
    let mut out = out1::<refl_plane>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_plane_from_triangle(out.ptr(), p1, p2, p3) };
    post(s, "refl_plane_from_triangle", &out, &[]);
    if out.usable() && !(finite3(p1) && finite3(p2) && finite3(p3)) {
        assert_eq!(s, refl_status::InvalidArgument, "plane_from_triangle with a non-finite vertex");
    }
    if out.usable() && p1 == p2 && finite3(p1) && finite3(p3) {
        assert_eq!(s, refl_status::DegenerateGeometry, "plane_from_triangle with p1 == p2");
    }
    if s == refl_status::Ok {
        let pl = out.get(0);
        // Known finding F4 also here (huge vertices overflow d).
        let big = max_abs3(p1).max(max_abs3(p2)).max(max_abs3(p3)) > 1e36;
        if !strict_for("F4") && !pl.d.is_finite() && big {
            return;
        }
        assert!(finite3(pl.normal) && pl.d.is_finite(), "plane_from_triangle({p1:?}, {p2:?}, {p3:?}) = {pl:?}: not finite");
        assert!((len3(pl.normal) - 1.0).abs() < 1e-5, "plane normal not unit");
        let scale = 1.0 + f64::from(max_abs3(p1).max(max_abs3(p2)).max(max_abs3(p3)));
        for p in [p1, p2, p3] {
            let [x, y, z] = d3(p);
            let [a, bb, c] = d3(pl.normal);
            let dist = a * x + bb * y + c * z + f64::from(pl.d);
            assert!(dist.abs() <= scale * (1e-4 + 4e-6 / sine_at_p2(p1, p2, p3)), "vertex {p:?} at distance {dist} from its plane");
        }
        st.planes[b.below(2) as usize] = pl;
    }
    let point = b.vec3_in(-5.0, 5.0);
    let normal = if b.chance(16) { v3(0.0, 0.0, 0.0) } else { b.vec3_in(-2.0, 2.0) };
    let mut out = out1::<refl_plane>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_plane_from_point_normal(out.ptr(), point, normal) };
    post(s, "refl_plane_from_point_normal", &out, &[]);
    if out.usable() {
        if !(finite3(point) && finite3(normal)) {
            assert_eq!(s, refl_status::InvalidArgument, "plane_from_point_normal: non-finite");
        } else if normal == v3(0.0, 0.0, 0.0) {
            assert_eq!(s, refl_status::DegenerateGeometry, "plane_from_point_normal: zero normal");
        }
    }
    if s == refl_status::Ok {
        let pl = out.get(0);
        // Known finding F4 (tolerated unless REFL_FUZZ_STRICT=1): with a
        // finite point near f32::MAX, d = -dot(n, point) overflows and the
        // call returns OK with d = +-inf.
        if !strict_for("F4") && !pl.d.is_finite() && max_abs3(point) > 1e36 {
            return;
        }
        assert!(finite3(pl.normal) && pl.d.is_finite(), "plane_from_point_normal({point:?}, {normal:?}) = {pl:?}: not finite");
        assert!((len3(pl.normal) - 1.0).abs() < 1e-5, "plane normal not unit");
        let [a, bb, c] = d3(pl.normal);
        let [x, y, z] = d3(normal);
        assert!(a * x + bb * y + c * z > 0.0, "plane normal flipped");
        let [px, py, pz] = d3(point);
        let dist = a * px + bb * py + c * pz + f64::from(pl.d);
        assert!(dist.abs() <= 1e-5 * (1.0 + f64::from(max_abs3(point))), "point off its plane");
        st.planes[b.below(2) as usize] = pl;
    }
}

fn plane_arg(b: &mut Bytes, st: &State) -> (refl_plane, Buf<refl_plane>) {
    let p = if b.chance(48) { plane(b) } else { st.planes[b.below(2) as usize] };
    let buf = Buf::from_slice(&[p], b.ptr_kind());
    (p, buf)
}

/// Whether the header calls `p` valid: a finite plane with a non-zero
/// normal. Known finding F2 (tolerated unless `REFL_FUZZ_STRICT=1`): refl
/// computes |normal| in f32, so a normal whose squared length under- or
/// overflows f32 (components below about 1e-19 or above about 1e19) is
/// refused as degenerate.
fn plane_ok(p: &refl_plane) -> bool {
    finite3(p.normal) && p.d.is_finite() && len3(p.normal) > 0.0 && plane_f2_safe(p)
}

/// F2 also costs precision: the f32 length of a normal whose squared
/// length is subnormal has few bits; accuracy checks skip such planes
/// unless `REFL_FUZZ_STRICT=1`.
fn plane_f2_safe(p: &refl_plane) -> bool {
    strict_for("F2") || (1e-18..=1e18).contains(&len3(p.normal))
}

#[allow(dead_code)]
fn plane_ok_header(p: &refl_plane) -> bool {
    let l = len3(p.normal);
    finite3(p.normal) && p.d.is_finite() && l > 0.0 && (strict_for("F2") || (1e-18..=1e18).contains(&l))
}

fn signed_distance(p: &refl_plane, x: refl_vec3) -> f64 {
    let n = d3(p.normal);
    let l = len3(p.normal);
    let [a, b, c] = d3(x);
    (n[0] * a + n[1] * b + n[2] * c + f64::from(p.d)) / l
}

fn op_plane_queries(b: &mut Bytes, st: &mut State) {
    let (p, pb) = plane_arg(b, st);
    let x = b.vec3_in(-10.0, 10.0);
    let mut out = out1::<f32>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_plane_signed_distance(out.ptr(), pb.cptr(), x) };
    post(s, "refl_plane_signed_distance", &out, &[pb.kind()]);
    if s == refl_status::Ok {
        let v = out.get(0);
        assert!(v.is_finite());
        let want = signed_distance(&p, x);
        let n = d3(p.normal);
        let scale = 1.0 + f64::from(max_abs3(x)) + f64::from(p.d.abs()) / len3(p.normal)
            + n.iter().map(|c| c.abs()).sum::<f64>() * 1e-30;
        if want.abs() < 1e30 && plane_f2_safe(&p) {
            assert!((f64::from(v) - want).abs() <= 1e-4 * scale, "signed distance {v} want {want}");
        }
    } else if out.usable() && pb.usable() && finite3(x) && plane_ok(&p) && signed_distance(&p, x).abs() < 1e30 {
        panic!("refl_plane_signed_distance refused a valid plane and point: {s:?}");
    }
    let ray = refl_ray {
        origin: b.vec3_in(-10.0, 10.0),
        dir: b.dir3(),
    };
    let mut t = out1::<f32>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_plane_intersect_ray(t.ptr(), pb.cptr(), ray) };
    post(s, "refl_plane_intersect_ray", &t, &[pb.kind()]);
    if s == refl_status::Ok {
        let tv = t.get(0);
        assert!(tv.is_finite(), "intersection t not finite");
        if tv.abs() < 1e4 && max_abs3(ray.origin) < 1e3 && (len3(ray.dir) - 1.0).abs() < 1e-3 {
            let q = v3(
                ray.origin.x + tv * ray.dir.x,
                ray.origin.y + tv * ray.dir.y,
                ray.origin.z + tv * ray.dir.z,
            );
            let dist = signed_distance(&p, q);
            let scale = 1.0 + f64::from(max_abs3(q)) + f64::from(tv.abs());
            assert!(dist.abs() <= 1e-3 * scale, "ray meets plane at t={tv} but is {dist} off");
        }
    }
    let mut m = out1::<refl_mat4>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_mirror_matrix(m.ptr(), pb.cptr()) };
    post(s, "refl_mirror_matrix", &m, &[pb.kind()]);
    if s == refl_status::Ok {
        let mm = m.get(0);
        assert!(finite_mat(&mm), "mirror matrix not finite");
        let dn = f64::from(p.d.abs()) / len3(p.normal);
        if dn < 1e3 && plane_f2_safe(&p) {
            let sq = mat_mul(&mm, &mm);
            for (k, v) in sq.iter().enumerate() {
                let want = if k % 5 == 0 { 1.0 } else { 0.0 };
                assert!((v - want).abs() <= 1e-4 * (1.0 + dn * dn), "mirror matrix squared != I");
            }
        }
    } else if m.usable() && pb.usable() && plane_ok(&p) && f64::from(p.d.abs()) / len3(p.normal) < 1e30 {
        panic!("refl_mirror_matrix refused a valid plane {p:?}: {s:?}");
    }
    let mut mp = out1::<refl_vec3>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_mirror_point(mp.ptr(), pb.cptr(), x) };
    post(s, "refl_mirror_point", &mp, &[pb.kind()]);
    if s == refl_status::Ok {
        let y = mp.get(0);
        assert!(finite3(y));
        let (dx, dy) = (signed_distance(&p, x), signed_distance(&p, y));
        let scale = 1.0 + f64::from(max_abs3(x)) + f64::from(p.d.abs()) / len3(p.normal);
        if scale < 1e6 && plane_f2_safe(&p) {
            assert!((dx + dy).abs() <= 1e-4 * scale, "mirror point not opposite: {dx} vs {dy}");
        }
    }
}

fn op_mirrored_camera(b: &mut Bytes, st: &mut State) {
    let (c, cb) = cam_arg(b, st);
    let (p, pb) = plane_arg(b, st);
    let mut out = out1::<refl_camera>(b.ptr_kind());
    let (sc, sp) = (cb.snapshot(), pb.snapshot());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_mirror_camera(out.ptr(), cb.cptr(), pb.cptr()) };
    cb.assert_unchanged(&sc, "refl_mirror_camera camera");
    pb.assert_unchanged(&sp, "refl_mirror_camera plane");
    post(s, "refl_mirror_camera", &out, &[cb.kind(), pb.kind()]);
    if s != refl_status::Ok {
        if out.usable() && cb.usable() && pb.usable() && camera_moderate(&c) && plane_ok(&p) && f64::from(p.d.abs()) / len3(p.normal) < 1e3 {
            panic!("refl_mirror_camera refused a valid camera and plane: {s:?} {c:?} {p:?}");
        }
        return;
    }
    let m = out.get(0);
    assert!(camera_ok(&m), "mirrored camera does not validate: {m:?}");
    assert!(
        m.fov_y == c.fov_y && m.z_near == c.z_near && m.z_far.to_bits() == c.z_far.to_bits() && m.width == c.width && m.height == c.height,
        "mirrored camera changed the projection or size"
    );
    let (mut a, mut bm) = (false, false);
    // SAFETY: pointers valid.
    unsafe {
        assert_eq!(refl_camera_is_mirrored(&mut a, &c), refl_status::Ok);
        assert_eq!(refl_camera_is_mirrored(&mut bm, &m), refl_status::Ok);
    }
    assert!(a != bm || known_f5(&c), "mirroring did not flip is_mirrored: {c:?} {p:?} -> {m:?}");
    if let (Some(e), Some(em)) = (eye_of(&c), eye_of(&m)) {
        let scale = 1.0 + f64::from(max_abs3(e)) + f64::from(p.d.abs()) / len3(p.normal);
        if scale < 1e4 && plane_f2_safe(&p) {
            let (de, dm) = (signed_distance(&p, e), signed_distance(&p, em));
            assert!((de + dm).abs() <= 1e-3 * scale, "mirrored eye not mirrored: {de} vs {dm}");
        }
    }
    // "out may equal camera."
    if b.bool() {
        alias::<refl_camera, refl_camera>(c, size_of::<refl_camera>(), "refl_mirror_camera alias", |o, i| {
            // SAFETY: valid pointers (o may equal i).
            unsafe { refl_mirror_camera(o, i, &p) }
        });
    }
    st.cams[b.below(2) as usize] = m;
}

fn op_oblique(b: &mut Bytes, st: &mut State) {
    let (c, cb) = cam_arg(b, st);
    let (p, pb) = plane_arg(b, st);
    let conv = b.convention();
    let mut out = out1::<refl_mat4>(b.ptr_kind());
    // SAFETY: NULL, misaligned or valid.
    let s = unsafe { refl_mirror_oblique_projection(out.ptr(), cb.cptr(), pb.cptr(), conv) };
    post(s, "refl_mirror_oblique_projection", &out, &[cb.kind(), pb.kind()]);
    if s != refl_status::Ok {
        return;
    }
    assert!(conv == 1 || conv == 2, "oblique projection for convention {conv}");
    let m = out.get(0);
    assert!(finite_mat(&m));
    // DEGENERATE unless the eye is strictly on the negative side of clip.
    let e = eye_of(&c).expect("eye");
    assert!(signed_distance(&p, e) < 1e-6 * (1.0 + f64::from(max_abs3(e))), "oblique projection with the eye in front of the clip plane");
    let mut pm = refl_mat4 { m: [0.0; 16] };
    // SAFETY: pointers valid.
    assert_eq!(unsafe { refl_camera_projection_matrix(&mut pm, &c, conv) }, refl_status::Ok);
    // The x, y and w rows are those of the projection matrix.
    for col in 0..4 {
        for row in [0, 1, 3] {
            let (a, bb) = (m.m[4 * col + row], pm.m[4 * col + row]);
            assert!(close(a, bb, 1e-5), "oblique projection row {row} col {col}: {a} vs {bb}");
        }
    }
}

fn op_strings(b: &mut Bytes, _st: &mut State) {
    let v = match b.u8() % 3 {
        0 => b.below(8),
        _ => b.u32(),
    };
    let p = refl_status_string(v);
    assert!(!p.is_null(), "refl_status_string returned NULL");
    // SAFETY: refl promises a static NUL-terminated string.
    let s = unsafe { CStr::from_ptr(p) }.to_str().expect("status string is UTF-8");
    assert!(!s.is_empty());
    if v > 5 {
        assert_eq!(s, "unknown refl_status value");
    } else {
        assert_ne!(s, "unknown refl_status value");
    }
    // SAFETY: static NUL-terminated string.
    let ver = unsafe { CStr::from_ptr(refl_version()) }.to_str().expect("version UTF-8");
    let n = refl_version_number();
    assert_eq!(ver, format!("{}.{}.{}", n >> 16, (n >> 8) & 0xFF, n & 0xFF));
}

fn op_alias(b: &mut Bytes, st: &mut State) {
    let c = if b.chance(64) { any_camera(b) } else { st.cams[b.below(2) as usize] };
    let p = if b.chance(64) { plane(b) } else { st.planes[b.below(2) as usize] };
    let conv = b.convention();
    let x = b.vec3_in(-5.0, 5.0);
    let px = pixel(b, &c);
    let d = b.f32_in(0.0, 1.0);
    // SAFETY (all closures): `o` and `i` point into one buffer large enough
    // for both types, aligned to 8.
    match b.u8() % 12 {
        0 => alias::<refl_camera, refl_mat4>(c, 64, "inverse_view alias", |o, i| unsafe { refl_camera_inverse_view(o, i) }),
        1 => alias::<refl_camera, refl_vec3>(c, 12, "eye alias", |o, i| unsafe { refl_camera_eye(o, i) }),
        2 => alias::<refl_camera, refl_mat4>(c, 64, "projection_matrix alias", |o, i| unsafe { refl_camera_projection_matrix(o, i, conv) }),
        3 => alias::<refl_camera, refl_projection>(c, 13, "project alias", |o, i| unsafe { refl_camera_project(o, i, x) }),
        4 => alias::<refl_camera, refl_ray>(c, 24, "primary_ray alias", |o, i| unsafe { refl_camera_primary_ray(o, i, px) }),
        5 => alias::<refl_plane, f32>(p, 4, "signed_distance alias", |o, i| unsafe { refl_plane_signed_distance(o, i, x) }),
        6 => alias::<refl_plane, refl_vec3>(p, 12, "mirror_point alias", |o, i| unsafe { refl_mirror_point(o, i, x) }),
        7 => alias::<refl_plane, refl_mat4>(p, 64, "mirror_matrix alias", |o, i| unsafe { refl_mirror_matrix(o, i) }),
        8 => alias::<refl_camera, refl_mat4>(c, 64, "reprojection_matrix alias", |o, i| unsafe { refl_camera_reprojection_matrix(o, i, &st.cams[1], conv) }),
        9 => alias::<refl_camera, refl_mat4>(c, 64, "oblique alias", |o, i| unsafe { refl_mirror_oblique_projection(o, i, &p, conv) }),
        10 => alias::<refl_plane, refl_mat4>(p, 64, "oblique plane alias", |o, i| unsafe { refl_mirror_oblique_projection(o, &c, i, conv) }),
        _ => {
            let m = {
                let mut m = refl_mat4 { m: [0.0; 16] };
                // SAFETY: pointers valid.
                unsafe { refl_camera_reprojection_matrix(&mut m, &c, &st.cams[1], 1) };
                m
            };
            alias::<refl_mat4, refl_projection>(m, 13, "apply_reprojection alias", |o, i| unsafe { refl_camera_apply_reprojection(o, i, px, d) })
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let mut st = State {
        cams: [default_camera(64, 48), default_camera(32, 32)],
        planes: [
            refl_plane {
                normal: v3(0.0, 1.0, 0.0),
                d: 0.0,
            },
            refl_plane {
                normal: v3(0.0, 0.0, 1.0),
                d: 3.0,
            },
        ],
    };
    st.cams[1] = camera(&mut b, 32, 24);
    let ops: [fn(&mut Bytes, &mut State); 17] = [
        op_look_at,
        op_validate,
        op_primary_ray,
        op_project,
        op_unproject,
        op_depth,
        op_matrices,
        op_eye_mirrored,
        op_reprojection,
        op_reflect,
        op_planes,
        op_plane_queries,
        op_mirrored_camera,
        op_oblique,
        op_strings,
        op_alias,
        op_depth,
    ];
    for _ in 0..32 {
        if b.is_empty() {
            break;
        }
        let k = b.below(ops.len() as u32) as usize;
        ops[k](&mut b, &mut st);
    }
});
