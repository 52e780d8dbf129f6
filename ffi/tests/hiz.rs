//! refl_hiz_*: sizes and layout equal refl-core's, builds (whole and by row
//! bands from several threads) are bit-identical to refl-core's, traces
//! equal refl-core's, and every error path returns its documented status
//! and leaves outputs untouched.

use core::mem::MaybeUninit;
use refl::*;
use refl_core::glam::Vec3;
use refl_core::{
    try_hiz_len, try_trace_hiz, Camera, DepthConvention, HiZ, HiZLayout, HiZOptions, ImageView,
    Ray, Thickness,
};

#[path = "common/wall.rs"]
mod wall;
use wall::{core_pyramid, depth_image_c, hiz_c, no_image, texels_c};

const W: u32 = 37;
const H: u32 = 23;

/// A wall at depth 8, a box at depth 3 with back faces at 4, a NaN hole.
const SCENE: wall::Scene = wall::Scene {
    width: W,
    height: H,
    box_x: 12..25,
    box_y: 8..16,
    hole_y: 4,
    hole_x: 30..34,
};

fn bits(p: &[refl_vec2]) -> Vec<[u32; 2]> {
    p.iter().map(|t| [t.x.to_bits(), t.y.to_bits()]).collect()
}

fn rays() -> Vec<refl_ray> {
    let mut v = Vec::new();
    for k in 0..24 {
        let a = k as f32 * 0.27;
        let d = Vec3::new(a.cos() * 0.5, a.sin() * 0.3, -1.0).normalize();
        let o = Vec3::new(0.5, 1.5, 2.0) + Vec3::new(0.0, 0.0, -(k % 5) as f32);
        v.push(Ray { origin: o, dir: d }.into());
    }
    // Toward the camera from behind the wall's depth.
    v.push(
        Ray {
            origin: Vec3::new(0.2, 0.8, -4.0),
            dir: Vec3::new(0.0, 0.1, 1.0).normalize(),
        }
        .into(),
    );
    v
}

#[test]
fn len_and_level_match_core() {
    for (w, h) in [(1, 1), (3, 5), (640, 480), (1, 1000)] {
        let (mut n, mut c) = (0usize, 0u32);
        // SAFETY: valid outputs.
        assert_eq!(
            unsafe { refl_hiz_len(&mut n, &mut c, w, h) },
            refl_status::Ok
        );
        let l = HiZLayout::try_new(w, h).unwrap();
        assert_eq!((n, c), (try_hiz_len(w, h).unwrap(), l.level_count()));
        assert_eq!(n, l.len() + refl_core::HIZ_STAMP_TEXELS);
        for i in 0..c {
            let mut info = refl_hiz_level_info::default();
            // SAFETY: valid output.
            assert_eq!(
                unsafe { refl_hiz_level(&mut info, w, h, i) },
                refl_status::Ok
            );
            let lv = l.level(i).unwrap();
            assert_eq!(
                (info.offset, info.width, info.height),
                (lv.offset, lv.width, lv.height)
            );
        }
        let mut info = refl_hiz_level_info {
            offset: 7,
            width: 7,
            height: 7,
        };
        // SAFETY: valid output.
        assert_eq!(
            unsafe { refl_hiz_level(&mut info, w, h, c) },
            refl_status::InvalidArgument
        );
        assert_eq!(info.offset, 7);
    }
}

#[test]
fn len_and_level_refuse_bad_sizes_and_null_outputs() {
    let (mut n, mut c) = (5usize, 5u32);
    // SAFETY: valid or null outputs.
    unsafe {
        assert_eq!(
            refl_hiz_len(&mut n, &mut c, 0, 4),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_hiz_len(core::ptr::null_mut(), &mut c, 4, 4),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_hiz_len(&mut n, core::ptr::null_mut(), 4, 4),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_hiz_level(core::ptr::null_mut(), 4, 4, 0),
            refl_status::NullPointer
        );
    }
    assert_eq!((n, c), (5, 5));
}

#[test]
fn options_default_is_cores() {
    let o = refl_hiz_options_default();
    assert_eq!(HiZOptions::from(o), HiZOptions::default());
}

#[test]
fn whole_build_equals_core_bit_for_bit() {
    let cam = SCENE.camera();
    for conv in DepthConvention::ALL {
        let (front, _) = SCENE.images(&cam, conv);
        let want_c = texels_c(&core_pyramid(&cam, &front, conv));
        let img = depth_image_c(&cam, &front, conv);
        let n = want_c.len();
        let mut whole = vec![refl_vec2::default(); n];
        // SAFETY: valid buffers.
        assert_eq!(
            unsafe { refl_hiz_build(whole.as_mut_ptr(), n, &img) },
            refl_status::Ok
        );
        assert_eq!(bits(&whole), bits(&want_c));
    }
}

#[test]
fn build_by_row_bands_from_threads_equals_core_bit_for_bit() {
    let cam = SCENE.camera();
    for conv in DepthConvention::ALL {
        let (front, _) = SCENE.images(&cam, conv);
        let want_c = texels_c(&core_pyramid(&cam, &front, conv));
        let img = depth_image_c(&cam, &front, conv);
        let n = want_c.len();
        // Each level in 3 bands on 3 threads, one level at a time.
        let mut banded = vec![refl_vec2::default(); n];
        let layout = HiZLayout::try_new(W, H).unwrap();
        let base = banded.as_mut_ptr() as usize;
        for level in 0..layout.level_count() {
            let h = layout.level(level).unwrap().height;
            std::thread::scope(|s| {
                for b in 0..3u32 {
                    let (r0, r1) = (h * b / 3, h * (b + 1) / 3);
                    if r0 == r1 {
                        continue;
                    }
                    let img_addr = &img as *const refl_depth_image as usize;
                    s.spawn(move || {
                        let img = img_addr as *const refl_depth_image;
                        // SAFETY: disjoint row bands of one level; the finer
                        // level is complete and only read.
                        let st = unsafe {
                            refl_hiz_build_rows(
                                base as *mut refl_vec2,
                                n,
                                img,
                                level,
                                refl_row_range { begin: r0, end: r1 },
                            )
                        };
                        assert_eq!(st, refl_status::Ok);
                    });
                }
            });
        }
        assert_eq!(bits(&banded), bits(&want_c));
    }
}

/// The depth convention of the build error tests.
const BUILD_CONV: DepthConvention = DepthConvention::ReversedZ;

/// The front depth image in [`BUILD_CONV`] (and the buffer it points into).
fn build_input() -> (Vec<f32>, refl_depth_image) {
    let cam = SCENE.camera();
    let (front, _) = SCENE.images(&cam, BUILD_CONV);
    let img = depth_image_c(&cam, &front, BUILD_CONV);
    (front, img)
}

#[test]
fn build_errors_leave_dst_untouched() {
    let (_front, img) = build_input();
    let n = try_hiz_len(W, H).unwrap();
    let sentinel = refl_vec2 { x: 5.0, y: 6.0 };
    let mut dst = vec![sentinel; n];
    let p = dst.as_mut_ptr();
    // SAFETY: valid or null pointers; lengths as stated.
    unsafe {
        assert_eq!(
            refl_hiz_build(p, n - 1, &img),
            refl_status::InsufficientSize
        );
        assert_eq!(
            refl_hiz_build(core::ptr::null_mut(), n, &img),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_hiz_build(p, n, core::ptr::null()),
            refl_status::NullPointer
        );
        let bad_conv = refl_depth_image {
            convention: 9,
            ..img
        };
        assert_eq!(
            refl_hiz_build(p, n, &bad_conv),
            refl_status::InvalidArgument
        );
        let mut bad_cam = img;
        bad_cam.camera.fov_y = f32::NAN;
        assert_eq!(refl_hiz_build(p, n, &bad_cam), refl_status::InvalidArgument);
        let short = refl_depth_image {
            depth: refl_image_f32 {
                len: 10,
                ..img.depth
            },
            ..img
        };
        assert_eq!(refl_hiz_build(p, n, &short), refl_status::InsufficientSize);
        let null_data = refl_depth_image {
            depth: refl_image_f32 {
                data: core::ptr::null(),
                ..img.depth
            },
            ..img
        };
        assert_eq!(refl_hiz_build(p, n, &null_data), refl_status::NullPointer);
        let mis = (p as *mut u8).add(1) as *mut refl_vec2;
        assert_eq!(
            refl_hiz_build(mis, n - 1, &img),
            refl_status::InvalidArgument
        );
    }
    assert!(dst.iter().all(|t| *t == sentinel));
}

#[test]
fn build_rows_errors_leave_dst_untouched() {
    let (_front, img) = build_input();
    let n = try_hiz_len(W, H).unwrap();
    let sentinel = refl_vec2 { x: 5.0, y: 6.0 };
    let mut dst = vec![sentinel; n];
    let p = dst.as_mut_ptr();
    // SAFETY: valid or null pointers; lengths as stated.
    unsafe {
        // Bad level, empty or reversed rows, rows past the level.
        assert_eq!(
            refl_hiz_build_rows(p, n, &img, 99, refl_row_range { begin: 0, end: 1 }),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_hiz_build_rows(p, n, &img, 0, refl_row_range { begin: 3, end: 3 }),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_hiz_build_rows(p, n, &img, 0, refl_row_range { begin: 4, end: 2 }),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_hiz_build_rows(p, n, &img, 1, refl_row_range { begin: 0, end: H }),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_hiz_build_rows(p, n - 1, &img, 0, refl_row_range { begin: 0, end: 1 }),
            refl_status::InsufficientSize
        );
        assert_eq!(
            refl_hiz_build_rows(
                core::ptr::null_mut(),
                n,
                &img,
                0,
                refl_row_range { begin: 0, end: 1 }
            ),
            refl_status::NullPointer
        );
    }
    assert!(dst.iter().all(|t| *t == sentinel));
}

#[test]
fn build_into_its_own_depth_image_is_refused() {
    let cam = SCENE.camera();
    let (front, _) = SCENE.images(&cam, BUILD_CONV);
    let n = try_hiz_len(W, H).unwrap();
    let mut shared = vec![0.0f32; 4 * n + front.len()];
    shared[..front.len()].copy_from_slice(&front);
    let img2 = depth_image_c(&cam, &shared[..front.len()], BUILD_CONV);
    let before = shared.clone();
    // SAFETY: the pointer covers `shared`, which holds 2n floats from index 2.
    let st = unsafe { refl_hiz_build(shared.as_mut_ptr().add(2) as *mut refl_vec2, n, &img2) };
    assert_eq!(st, refl_status::InvalidArgument);
    assert_eq!(
        shared.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        before.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
}

/// Runs `check(hz, th_core, h, th_c, o)` on the scene's pyramid in every
/// convention, with the constant thickness 0.5 and the back-face image,
/// under the default options and a coarse stop level without prologue.
fn for_each_trace_case(
    mut check: impl FnMut(&HiZ, Thickness, &refl_hiz, &refl_trace_thickness, HiZOptions),
) {
    let cam = SCENE.camera();
    for conv in DepthConvention::ALL {
        let (front, back) = SCENE.images(&cam, conv);
        let want = core_pyramid(&cam, &front, conv);
        let pyr_c = texels_c(&want);
        let hz = HiZ::try_new(&want, cam, conv).unwrap();
        let h = hiz_c(&cam, &pyr_c, conv);
        let bv = ImageView::try_new(&back, W, H, W).unwrap();
        let opts_list = [
            HiZOptions::default(),
            HiZOptions {
                stop_level: 2,
                prologue_steps: 0,
                ..Default::default()
            },
        ];
        for (th_core, th_c) in [
            (
                Thickness::Constant(0.5),
                refl_trace_thickness {
                    constant: 0.5,
                    back_faces: no_image(),
                },
            ),
            (
                Thickness::BackFaces(bv),
                refl_trace_thickness {
                    constant: 0.0,
                    back_faces: SCENE.image_c(&back),
                },
            ),
        ] {
            for o in opts_list {
                check(&hz, th_core, &h, &th_c, o);
            }
        }
    }
}

/// refl-core's trace of the C ray `r`.
fn core_trace(
    hz: &HiZ,
    th: Thickness,
    r: &refl_ray,
    t_max: f32,
    o: &HiZOptions,
) -> refl_trace_result {
    let ray = Ray {
        origin: r.origin.into(),
        dir: r.dir.into(),
    };
    refl_trace_result::from(try_trace_hiz(hz, th, ray, t_max, o).unwrap())
}

#[test]
fn trace_ray_equals_core() {
    for_each_trace_case(|hz, th_core, h, th_c, o| {
        let oc: refl_hiz_options = o.into();
        let rs = rays();
        let mut hits = 0;
        for r in &rs {
            let want = core_trace(hz, th_core, r, 30.0, &o);
            hits += (want.miss == 0) as usize;
            let mut got = MaybeUninit::<refl_trace_result>::uninit();
            // SAFETY: valid pointers.
            let st = unsafe { refl_hiz_trace_ray(got.as_mut_ptr(), h, th_c, *r, 30.0, &oc) };
            assert_eq!(st, refl_status::Ok);
            // SAFETY: written on success.
            assert_eq!(unsafe { got.assume_init() }, want);
        }
        assert!(hits >= rs.len() / 2, "{hits} hits");
    });
}

#[test]
fn trace_rays_equals_core_and_writes_only_its_rays() {
    for_each_trace_case(|hz, th_core, h, th_c, o| {
        let oc: refl_hiz_options = o.into();
        let rs = rays();
        let mut out = vec![refl_trace_result::default(); rs.len() + 1];
        let tm = [30.0f32];
        // SAFETY: valid pointers and lengths.
        let st = unsafe {
            refl_hiz_trace_rays(
                out.as_mut_ptr(),
                out.len(),
                h,
                th_c,
                rs.as_ptr(),
                rs.len(),
                tm.as_ptr(),
                1,
                &oc,
            )
        };
        assert_eq!(st, refl_status::Ok);
        for (i, r) in rs.iter().enumerate() {
            let want = core_trace(hz, th_core, r, 30.0, &o);
            assert_eq!(out[i], want);
        }
        assert_eq!(out[rs.len()], refl_trace_result::default());
    });
}

/// The inputs of the trace error tests: the scene's camera and its
/// ZeroToOne pyramid.
fn zero_to_one_pyramid() -> (Camera, Vec<refl_vec2>) {
    let cam = SCENE.camera();
    let conv = DepthConvention::ZeroToOne;
    let (front, _) = SCENE.images(&cam, conv);
    (cam, texels_c(&core_pyramid(&cam, &front, conv)))
}

/// A trace result no export writes.
fn trace_sentinel() -> refl_trace_result {
    refl_trace_result {
        miss: 77,
        steps: 77,
        ..Default::default()
    }
}

#[test]
fn trace_ray_errors_leave_the_output_untouched() {
    let (cam, pyr) = zero_to_one_pyramid();
    let h = hiz_c(&cam, &pyr, DepthConvention::ZeroToOne);
    let th = refl_trace_thickness {
        constant: 0.5,
        back_faces: no_image(),
    };
    let o: refl_hiz_options = HiZOptions::default().into();
    let good = rays()[0];
    let sentinel = trace_sentinel();
    let mut out = sentinel;
    // SAFETY: valid or null pointers.
    unsafe {
        assert_eq!(
            refl_hiz_trace_ray(core::ptr::null_mut(), &h, &th, good, 1.0, &o),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_hiz_trace_ray(&mut out, core::ptr::null(), &th, good, 1.0, &o),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_hiz_trace_ray(&mut out, &h, core::ptr::null(), good, 1.0, &o),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_hiz_trace_ray(&mut out, &h, &th, good, 1.0, core::ptr::null()),
            refl_status::NullPointer
        );
        let hn = refl_hiz {
            data: core::ptr::null(),
            ..h
        };
        assert_eq!(
            refl_hiz_trace_ray(&mut out, &hn, &th, good, 1.0, &o),
            refl_status::NullPointer
        );
        let hs = refl_hiz {
            len: h.len - 1,
            ..h
        };
        assert_eq!(
            refl_hiz_trace_ray(&mut out, &hs, &th, good, 1.0, &o),
            refl_status::InsufficientSize
        );
        let hc = refl_hiz { convention: 3, ..h };
        assert_eq!(
            refl_hiz_trace_ray(&mut out, &hc, &th, good, 1.0, &o),
            refl_status::InvalidArgument
        );
        let mut hb = h;
        hb.camera.width = 0;
        assert_eq!(
            refl_hiz_trace_ray(&mut out, &hb, &th, good, 1.0, &o),
            refl_status::InvalidArgument
        );
        let mut bad = good;
        bad.dir.x = f32::NAN;
        assert_eq!(
            refl_hiz_trace_ray(&mut out, &h, &th, bad, 1.0, &o),
            refl_status::InvalidArgument
        );
        bad = good;
        bad.origin.y = f32::INFINITY;
        assert_eq!(
            refl_hiz_trace_ray(&mut out, &h, &th, bad, 1.0, &o),
            refl_status::InvalidArgument
        );
        for tm in [f32::NAN, 0.0, -1.0] {
            assert_eq!(
                refl_hiz_trace_ray(&mut out, &h, &th, good, tm, &o),
                refl_status::InvalidArgument
            );
        }
        let tn = refl_trace_thickness {
            constant: f32::NAN,
            ..th
        };
        assert_eq!(
            refl_hiz_trace_ray(&mut out, &h, &tn, good, 1.0, &o),
            refl_status::InvalidArgument
        );
        let small = [0.0f32; 4];
        let tb = refl_trace_thickness {
            constant: 0.0,
            back_faces: wall::image_c(&small, 2, 2),
        };
        assert_eq!(
            refl_hiz_trace_ray(&mut out, &h, &tb, good, 1.0, &o),
            refl_status::InvalidArgument
        );
    }
    assert_eq!(out, sentinel);
}

#[test]
fn trace_rays_errors_leave_the_outputs_untouched() {
    let (cam, pyr) = zero_to_one_pyramid();
    let h = hiz_c(&cam, &pyr, DepthConvention::ZeroToOne);
    let th = refl_trace_thickness {
        constant: 0.5,
        back_faces: no_image(),
    };
    let o: refl_hiz_options = HiZOptions::default().into();
    let sentinel = trace_sentinel();
    let rs = rays();
    let mut outs = vec![sentinel; rs.len()];
    let tm = [10.0f32, f32::NAN];
    // SAFETY: valid or null pointers, lengths as stated.
    unsafe {
        let p = outs.as_mut_ptr();
        assert_eq!(
            refl_hiz_trace_rays(
                p,
                rs.len() - 1,
                &h,
                &th,
                rs.as_ptr(),
                rs.len(),
                tm.as_ptr(),
                1,
                &o
            ),
            refl_status::InsufficientSize
        );
        assert_eq!(
            refl_hiz_trace_rays(
                p,
                rs.len(),
                &h,
                &th,
                rs.as_ptr(),
                rs.len(),
                tm.as_ptr(),
                2,
                &o
            ),
            refl_status::InsufficientSize
        );
        assert_eq!(
            refl_hiz_trace_rays(
                p,
                rs.len(),
                &h,
                &th,
                rs.as_ptr(),
                rs.len(),
                tm.as_ptr(),
                0,
                &o
            ),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_hiz_trace_rays(p, rs.len(), &h, &th, rs.as_ptr(), 2, tm.as_ptr(), 2, &o),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_hiz_trace_rays(
                core::ptr::null_mut(),
                rs.len(),
                &h,
                &th,
                rs.as_ptr(),
                rs.len(),
                tm.as_ptr(),
                1,
                &o
            ),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_hiz_trace_rays(
                p,
                rs.len(),
                &h,
                &th,
                core::ptr::null(),
                rs.len(),
                tm.as_ptr(),
                1,
                &o
            ),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_hiz_trace_rays(
                p,
                rs.len(),
                &h,
                &th,
                rs.as_ptr(),
                rs.len(),
                core::ptr::null(),
                1,
                &o
            ),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_hiz_trace_rays(
                p,
                rs.len(),
                core::ptr::null(),
                &th,
                rs.as_ptr(),
                rs.len(),
                tm.as_ptr(),
                1,
                &o
            ),
            refl_status::NullPointer
        );
    }
    assert!(outs.iter().all(|r| *r == sentinel));
}
