//! Issue 12 part 4 through the C ABI: every refusal names the call, and
//! (for a sample in every family) the argument and why, in the thread-local
//! last-error message; prepared structures used with the wrong camera are
//! errors; `refl_mirror_reflect` refuses a zero normal.

use core::ptr::{null, null_mut};
use refl::*;
use refl_core::{Camera, DepthConvention};

#[path = "common/wall.rs"]
mod wall;
use wall::{core_pyramid, depth_image_c, hiz_c, look, no_image};

/// The message as C sees it, through `refl_last_error_message`.
fn message() -> String {
    // SAFETY: NULL with length 0 is allowed.
    let n = unsafe { refl_last_error_message(null_mut(), 0) };
    let mut buf = vec![0x7fu8; n + 1];
    // SAFETY: buf is writable for n + 1 bytes.
    let m = unsafe { refl_last_error_message(buf.as_mut_ptr().cast(), buf.len()) };
    assert_eq!(m, n);
    assert_eq!(buf[n], 0, "NUL-terminated");
    let s = String::from_utf8(buf[..n].to_vec()).unwrap();
    with_last_error_message(|m| assert_eq!(s, m));
    s
}

/// `status` is `want` and the message starts with `call` and holds every
/// part of `says`.
#[track_caller]
fn refused(status: refl_status, want: refl_status, call: &str, says: &[&str]) {
    assert_eq!(status, want, "{call}");
    let m = message();
    assert!(m.starts_with(&format!("{call}: ")), "{m}");
    for s in says {
        assert!(m.contains(s), "{m:?} lacks {s:?}");
    }
}

fn v3(x: f32, y: f32, z: f32) -> refl_vec3 {
    refl_vec3 { x, y, z }
}

#[test]
fn success_clears_the_message_and_statusless_calls_keep_it() {
    let mut c = core::mem::MaybeUninit::<refl_camera>::uninit();
    // SAFETY: valid output.
    let s = unsafe {
        refl_camera_look_at(
            c.as_mut_ptr(),
            v3(0.0, 0.0, 5.0),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 1.0, 0.0),
            0.0,
            0.1,
            10.0,
            4,
            4,
        )
    };
    refused(s, refl_status::InvalidArgument, "refl_camera_look_at", &[]);
    let _ = refl_status_string(3);
    let _ = refl_version();
    assert!(!message().is_empty());
    // SAFETY: valid output.
    let s = unsafe {
        refl_camera_look_at(
            c.as_mut_ptr(),
            v3(0.0, 0.0, 5.0),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 1.0, 0.0),
            1.0,
            0.1,
            10.0,
            4,
            4,
        )
    };
    assert_eq!(s, refl_status::Ok);
    assert_eq!(message(), "");
    // Per thread.
    // SAFETY: NULL output is reported, not written.
    let s = unsafe { refl_tcrr_frame_bytes(null_mut(), 4, 4) };
    assert_eq!(s, refl_status::NullPointer);
    std::thread::spawn(|| with_last_error_message(|m| assert_eq!(m, "")))
        .join()
        .unwrap();
}

#[test]
fn camera_and_mirror_refusals_name_the_argument() {
    let cam = look(8, 6, 0.5);
    let mut bad: refl_camera = (&cam).into();
    bad.fov_y = 4.0;
    let mut p = refl_projection::default();
    // SAFETY: valid pointers.
    let s = unsafe { refl_camera_project(&mut p, &bad, v3(0.0, 0.0, -3.0)) };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_camera_project",
        &["`camera`", "fov_y"],
    );
    bad = (&cam).into();
    bad.view.m[0] = 2.0;
    // SAFETY: valid pointers.
    let s = unsafe { refl_camera_project(&mut p, &bad, v3(0.0, 0.0, -3.0)) };
    refused(
        s,
        refl_status::DegenerateGeometry,
        "refl_camera_project",
        &["`camera`", "rigid"],
    );
    let good: refl_camera = (&cam).into();
    // SAFETY: NULL output is reported.
    let s = unsafe { refl_camera_project(null_mut(), &good, v3(0.0, 0.0, -3.0)) };
    refused(
        s,
        refl_status::NullPointer,
        "refl_camera_project",
        &["`out` is NULL"],
    );
    let mut m = refl_mat4 { m: [0.0; 16] };
    // SAFETY: `to` NULL is reported.
    let s = unsafe { refl_camera_reprojection_matrix(&mut m, &good, null(), 0) };
    refused(
        s,
        refl_status::NullPointer,
        "refl_camera_reprojection_matrix",
        &["`to` is NULL"],
    );

    // refl_mirror_reflect: a zero normal is degenerate, not -v.
    let sentinel = v3(7.0, 7.0, 7.0);
    let mut r = sentinel;
    // SAFETY: valid output.
    let s = unsafe { refl_mirror_reflect(&mut r, v3(1.0, 1.0, 0.0), v3(0.0, 0.0, 0.0)) };
    refused(
        s,
        refl_status::DegenerateGeometry,
        "refl_mirror_reflect",
        &["`n` is the zero vector"],
    );
    assert_eq!(r, sentinel);
    // SAFETY: valid output.
    let s = unsafe { refl_mirror_reflect(&mut r, v3(1.0, 1.0, 0.0), v3(0.0, 2.0, 0.0)) };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_mirror_reflect",
        &["`n` is not unit length"],
    );
    assert_eq!(r, sentinel);
    // SAFETY: valid output.
    let s = unsafe { refl_mirror_reflect(&mut r, v3(f32::NAN, 1.0, 0.0), v3(0.0, 1.0, 0.0)) };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_mirror_reflect",
        &["`v` is not finite"],
    );
    // SAFETY: valid output.
    let s = unsafe { refl_mirror_reflect(&mut r, v3(1.0, 1.0, 0.0), v3(0.0, 1.0, 0.0)) };
    assert_eq!(s, refl_status::Ok);
    assert_eq!(r, v3(-1.0, 1.0, 0.0));

    let mut c = good;
    // SAFETY: `plane` NULL is reported.
    let s = unsafe { refl_mirror_camera(&mut c, &good, null()) };
    refused(
        s,
        refl_status::NullPointer,
        "refl_mirror_camera",
        &["`plane` is NULL"],
    );
    let plane = refl_plane {
        normal: v3(0.0, 0.0, 0.0),
        d: 0.0,
    };
    // SAFETY: valid pointers.
    let s = unsafe { refl_mirror_camera(&mut c, &good, &plane) };
    refused(
        s,
        refl_status::DegenerateGeometry,
        "refl_mirror_camera",
        &["`plane`"],
    );
}

#[test]
fn image_and_step_refusals_name_the_argument() {
    let cam = look(8, 6, 0.5);
    let src = [0.5f32; 48];
    let mut dst = vec![0.0f32; 48];
    let s_img = wall::image_c(&src, 8, 6);
    let d_img = refl_image_f32_mut {
        data: dst.as_mut_ptr(),
        len: 48,
        width: 8,
        height: 6,
        stride: 8,
    };
    let c: refl_camera = (&cam).into();
    // SAFETY: `camera` NULL is reported.
    let s = unsafe {
        refl_image_convert_depth(
            d_img,
            s_img,
            null(),
            0,
            2,
            refl_row_range { begin: 0, end: 6 },
        )
    };
    refused(
        s,
        refl_status::NullPointer,
        "refl_image_convert_depth",
        &["`camera` is NULL"],
    );
    // SAFETY: valid buffers.
    let s = unsafe {
        refl_image_convert_depth(d_img, s_img, &c, 0, 9, refl_row_range { begin: 0, end: 6 })
    };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_image_convert_depth",
        &[],
    );

    let mut out = core::mem::MaybeUninit::<refl_trace_result>::uninit();
    let th = refl_trace_thickness {
        constant: 1.0,
        back_faces: no_image(),
    };
    let ray = refl_ray {
        origin: v3(0.0, 1.0, 2.0),
        dir: v3(0.0, 0.0, -1.0),
    };
    // SAFETY: `image` NULL is reported.
    let s = unsafe { refl_step_ray(out.as_mut_ptr(), null(), &th, ray, 10.0, null()) };
    refused(s, refl_status::NullPointer, "refl_step_ray", &["is NULL"]);
}

/// The depth convention of the Hi-Z pyramid tests.
const HIZ_CONV: DepthConvention = DepthConvention::ReversedZ;

/// A 512x384 view of a wall at depth 8: the camera and its depth image.
fn big_wall() -> (Camera, Vec<f32>) {
    let big = look(512, 384, 0.5);
    let depth = vec![big.encode_depth(8.0, HIZ_CONV); 512 * 384];
    (big, depth)
}

/// The texel count of a 512x384 Hi-Z pyramid, through the C ABI (checked
/// to succeed).
fn hiz_len_512x384() -> usize {
    let (mut n, mut levels) = (0usize, 0u32);
    // SAFETY: valid outputs.
    assert_eq!(
        unsafe { refl_hiz_len(&mut n, &mut levels, 512, 384) },
        refl_status::Ok
    );
    n
}

/// The Hi-Z pyramid of [`big_wall`] built through the C ABI.
fn big_wall_pyramid() -> (Camera, Vec<refl_vec2>) {
    let (big, depth) = big_wall();
    let img = depth_image_c(&big, &depth, HIZ_CONV);
    let n = hiz_len_512x384();
    let mut pyr = vec![refl_vec2::default(); n];
    // SAFETY: pyr is writable for n texels.
    assert_eq!(
        unsafe { refl_hiz_build(pyr.as_mut_ptr(), n, &img) },
        refl_status::Ok
    );
    (big, pyr)
}

#[test]
fn hiz_build_names_the_length_a_short_pyramid_needs() {
    let (big, depth) = big_wall();
    let img = depth_image_c(&big, &depth, HIZ_CONV);
    let n = hiz_len_512x384();
    let mut pyr = vec![refl_vec2::default(); n];
    // Too short by the stamp: refused, naming the length needed.
    // SAFETY: pyr is writable for n - 1 texels.
    let s = unsafe { refl_hiz_build(pyr.as_mut_ptr(), n - 1, &img) };
    refused(
        s,
        refl_status::InsufficientSize,
        "refl_hiz_build",
        &["`dst_len`", &format!("{n}")],
    );
}

#[test]
fn hiz_build_equals_core_stamp_included() {
    let (big, depth) = big_wall();
    let (_, pyr) = big_wall_pyramid();
    // Bit for bit the core build, stamp included.
    let core_pyr = core_pyramid(&big, &depth, HIZ_CONV);
    assert!(pyr
        .iter()
        .zip(&core_pyr)
        .all(|(a, b)| a.x.to_bits() == b[0].to_bits() && a.y.to_bits() == b[1].to_bits()));
}

/// A unit thickness, the default options and a ray at the wall: the trace
/// inputs of the Hi-Z pyramid tests.
fn wall_trace() -> (refl_trace_thickness, refl_hiz_options, refl_ray) {
    let th = refl_trace_thickness {
        constant: 1.0,
        back_faces: no_image(),
    };
    let opts = refl_hiz_options_default();
    let ray = refl_ray {
        origin: v3(0.5, 1.5, 3.0),
        dir: v3(0.0, 0.0, -1.0),
    };
    (th, opts, ray)
}

/// A trace result no export writes.
fn trace_sentinel() -> refl_trace_result {
    refl_trace_result {
        pixel: refl_vec2 { x: -9.0, y: -9.0 },
        t: -9.0,
        depth: -9.0,
        surface_depth: -9.0,
        miss: 77,
        steps: 1,
        fetches: 2,
        iterations: 3,
    }
}

/// The case: a pyramid built for 512x384 traced with a 256x192
/// camera was OK with every ray missing.
#[test]
fn hiz_pyramid_of_another_size_or_camera_is_refused() {
    let (small, moved) = (look(256, 192, 0.5), look(512, 384, 0.6));
    let (big, pyr) = big_wall_pyramid();
    let (th, opts, ray) = wall_trace();
    let sentinel = trace_sentinel();
    for (cam, says) in [
        (small, "built for 512x384, the camera is 256x192"),
        (moved, "another camera of the same size"),
    ] {
        let hz = hiz_c(&cam, &pyr, HIZ_CONV);
        let mut out = sentinel;
        // SAFETY: valid pointers; pyr readable for its length.
        let s = unsafe { refl_hiz_trace_ray(&mut out, &hz, &th, ray, f32::INFINITY, &opts) };
        refused(
            s,
            refl_status::InvalidArgument,
            "refl_hiz_trace_ray",
            &["`hiz`", says],
        );
        assert_eq!(out, sentinel);
    }
    // The right camera traces and hits the wall.
    let hz = hiz_c(&big, &pyr, HIZ_CONV);
    let mut out = sentinel;
    // SAFETY: valid pointers.
    let s = unsafe { refl_hiz_trace_ray(&mut out, &hz, &th, ray, f32::INFINITY, &opts) };
    assert_eq!(s, refl_status::Ok);
    assert_eq!(out.miss, 0, "REFL_TRACE_MISS_NONE: a hit");
    assert_eq!(message(), "");
}

#[test]
fn hiz_pyramid_never_built_is_refused() {
    let big = look(512, 384, 0.5);
    let (th, opts, ray) = wall_trace();
    let n = hiz_len_512x384();
    let blank = vec![refl_vec2::default(); n];
    let hz = hiz_c(&big, &blank, HIZ_CONV);
    let mut out = trace_sentinel();
    // SAFETY: valid pointers.
    let s = unsafe { refl_hiz_trace_ray(&mut out, &hz, &th, ray, f32::INFINITY, &opts) };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_hiz_trace_ray",
        &["no pyramid stamp"],
    );
}

#[test]
fn every_family_names_a_null_argument() {
    let ray = refl_ray {
        origin: v3(0.0, 1.0, 2.0),
        dir: v3(0.0, 0.0, -1.0),
    };
    let mut lr = core::mem::MaybeUninit::<refl_layered_result>::uninit();
    let lp = refl_layered_options_default();
    // SAFETY: `map` NULL is reported.
    let s = unsafe { refl_layered_trace_ray(lr.as_mut_ptr(), null(), ray, 1.0, &lp) };
    refused(
        s,
        refl_status::NullPointer,
        "refl_layered_trace_ray",
        &["`map` is NULL"],
    );

    let mut cr = core::mem::MaybeUninit::<refl_cone_result>::uninit();
    let co = refl_cone_options_default();
    // SAFETY: `pyramids` NULL is reported.
    let s = unsafe { refl_cone_trace(cr.as_mut_ptr(), null(), null(), v3(0.0, 0.0, 0.0), &co) };
    refused(
        s,
        refl_status::NullPointer,
        "refl_cone_trace",
        &["`pyramids` is NULL"],
    );

    let mut bins = 0u32;
    // SAFETY: `options` NULL is reported.
    let s = unsafe { refl_cluster_bins_max(&mut bins, 3, null()) };
    refused(
        s,
        refl_status::NullPointer,
        "refl_cluster_bins_max",
        &["`options` is NULL"],
    );

    // SAFETY: `out_bytes` NULL is reported.
    let s = unsafe { refl_tcrr_frame_bytes(null_mut(), 4, 4) };
    refused(
        s,
        refl_status::NullPointer,
        "refl_tcrr_frame_bytes",
        &["`out_bytes` is NULL"],
    );
    let mut bytes = 0usize;
    // SAFETY: valid output.
    let s = unsafe { refl_tcrr_frame_bytes(&mut bytes, 0, 4) };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_tcrr_frame_bytes",
        &[],
    );

    // SAFETY: `out_len` NULL is reported.
    let s = unsafe { refl_epipolar_scratch_len(null_mut(), 4, 4) };
    refused(
        s,
        refl_status::NullPointer,
        "refl_epipolar_scratch_len",
        &["`out_len` is NULL"],
    );
}

/// A 4x4 wall G-buffer (linear depth 4, normals toward the camera, a lit
/// color) for the passes of issue 18.
struct Wall4 {
    cam: Camera,
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    color: Vec<[f32; 3]>,
}

impl Wall4 {
    fn new() -> Self {
        Self {
            cam: look(4, 4, 0.0),
            depth: vec![4.0; 16],
            normals: vec![[0.0, 0.0, 1.0]; 16],
            color: vec![[0.5; 3]; 16],
        }
    }

    fn vec3(d: &[[f32; 3]]) -> refl_image_vec3 {
        refl_image_vec3 {
            data: d.as_ptr().cast(),
            len: d.len(),
            width: 4,
            height: 4,
            stride: 4,
        }
    }

    fn gbuffer(&self) -> refl_gbuffer {
        refl_gbuffer {
            depth: depth_image_c(&self.cam, &self.depth, DepthConvention::Linear),
            normals: Self::vec3(&self.normals),
            normal_space: refl_normal_space::World as u32,
            mask: refl_image_u8 {
                data: null(),
                len: 0,
                width: 0,
                height: 0,
                stride: 0,
            },
            roughness: no_image(),
            color: Self::vec3(&self.color),
            back_depth: no_image(),
        }
    }
}

#[test]
fn bounce_extrapolate_and_upsample_refusals_name_the_argument() {
    let w = Wall4::new();
    let g = w.gbuffer();
    let mut out = vec![[0.0f32; 3]; 16];
    let out_c = refl_image_vec3_mut {
        data: out.as_mut_ptr().cast(),
        len: 16,
        width: 4,
        height: 4,
        stride: 4,
    };
    let no_u8 = refl_image_u8_mut {
        data: null_mut(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    };
    let rows = refl_row_range { begin: 0, end: 4 };

    // Bounces: a previous color of another size, an attenuation above 1.
    let prev_color = [[0.25f32; 3]; 12];
    let prev = refl_bounce_previous {
        depth: depth_image_c(&w.cam, &w.depth, DepthConvention::Linear),
        color: refl_image_vec3 {
            data: prev_color.as_ptr().cast(),
            len: 12,
            width: 4,
            height: 3,
            stride: 4,
        },
    };
    let bo = refl_bounce_options_default();
    let mut bs = refl_bounce_stats::default();
    // SAFETY: valid buffers of the stated lengths.
    let s = unsafe { refl_bounce_source_rows(&mut bs, out_c, no_u8, &g, &prev, &bo, rows) };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_bounce_source_rows",
        &["`previous.color` is 4x3", "4x4"],
    );
    let bad = refl_bounce_options {
        attenuation: 1.5,
        ..bo
    };
    // SAFETY: as above.
    let s = unsafe { refl_bounce_source_rows(&mut bs, out_c, no_u8, &g, &prev, &bad, rows) };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_bounce_source_rows",
        &["`options.attenuation` is 1.5, not in [0, 1]"],
    );
    // SAFETY: `previous` NULL is reported.
    let s = unsafe { refl_bounce_source_rows(&mut bs, out_c, no_u8, &g, null(), &bo, rows) };
    refused(
        s,
        refl_status::NullPointer,
        "refl_bounce_source_rows",
        &["`previous` is NULL"],
    );

    // Extrapolation: a radius past the largest, a texel status out of range.
    let mut texels = vec![refl_ssr_texel::default(); 16];
    let tex = refl_image_ssr_texel {
        data: texels.as_ptr(),
        len: 16,
        width: 4,
        height: 4,
        stride: 4,
    };
    let eo = refl_extrapolate_options_default();
    let mut es = refl_extrapolate_stats::default();
    let big = refl_extrapolate_options {
        radius: REFL_EXTRAPOLATE_MAX_RADIUS + 1,
        ..eo
    };
    let color = Wall4::vec3(&w.color);
    // SAFETY: valid buffers of the stated lengths.
    let s = unsafe {
        refl_extrapolate_fill_rows(
            &mut es,
            out_c,
            no_u8,
            null_mut(),
            0,
            &g,
            tex,
            color,
            &big,
            rows,
        )
    };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_extrapolate_fill_rows",
        &["`options.radius` is 17"],
    );
    texels[5].status = 10;
    let tex = refl_image_ssr_texel {
        data: texels.as_ptr(),
        ..tex
    };
    // SAFETY: as above.
    let s = unsafe {
        refl_extrapolate_fill_rows(
            &mut es,
            out_c,
            no_u8,
            null_mut(),
            0,
            &g,
            tex,
            color,
            &eo,
            rows,
        )
    };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_extrapolate_fill_rows",
        &["`texels` texel 5 has status 10, not a refl_ssr_status"],
    );

    // Upsampling: a zero size, half texels of the full size, an unknown
    // pattern.
    let (mut hw, mut hh) = (0u32, 0u32);
    // SAFETY: valid outputs.
    let s = unsafe { refl_upsample_half_size(&mut hw, &mut hh, 0, 3) };
    refused(
        s,
        refl_status::InvalidArgument,
        "refl_upsample_half_size",
        &["0x3"],
    );
    let so = refl_ssr_options_default();
    let sub = refl_upsample_subsample::default();
    let texels = vec![refl_ssr_texel::default(); 16];
    let mut full = vec![refl_ssr_texel::default(); 16];
    let mut us = refl_upsample_stats::default();
    let uo = refl_upsample_options_default();
    let call = |sub: &refl_upsample_subsample, full: &mut [refl_ssr_texel], us| {
        // SAFETY: valid buffers of the stated lengths.
        unsafe {
            refl_upsample_resolve_rows(
                us,
                full.as_mut_ptr(),
                16,
                refl_image_vec3_mut {
                    data: null_mut(),
                    len: 0,
                    width: 0,
                    height: 0,
                    stride: 0,
                },
                no_u8,
                null_mut(),
                0,
                &g,
                &so,
                null(),
                0,
                sub,
                refl_image_ssr_texel {
                    data: texels.as_ptr(),
                    len: 16,
                    width: 4,
                    height: 4,
                    stride: 4,
                },
                refl_image_vec3 {
                    data: null(),
                    len: 0,
                    width: 0,
                    height: 0,
                    stride: 0,
                },
                &uo,
                rows,
            )
        }
    };
    refused(
        call(&sub, &mut full, &mut us),
        refl_status::InvalidArgument,
        "refl_upsample_resolve_rows",
        &["`half` is 4x4, not the half size 2x2 of the 4x4 G-buffer"],
    );
    let bad_sub = refl_upsample_subsample {
        pattern: 2,
        frame: 0,
    };
    refused(
        call(&bad_sub, &mut full, &mut us),
        refl_status::InvalidArgument,
        "refl_upsample_resolve_rows",
        &["`subsample.pattern` is 2, not a refl_upsample_pattern"],
    );
}
