//! refl_step_ray / refl_step_rays: results equal refl-core's, every error
//! path returns its documented status and leaves outputs untouched.

use core::mem::MaybeUninit;
use refl::*;
use refl_core::glam::{Vec2, Vec3};
use refl_core::{try_step, Camera, DepthConvention, DepthImage, ImageView, Ray, Thickness, Trace};

#[path = "common/wall.rs"]
mod wall;
use wall::{depth_image_c, no_image};

const W: u32 = 48;
const H: u32 = 32;

/// A wall at depth 8 with a box at depth 3 (thickness 1 in the back-face
/// image) in the middle, and a hole of NaN texels.
const SCENE: wall::Scene = wall::Scene {
    width: W,
    height: H,
    box_x: 15..30,
    box_y: 10..20,
    hole_y: 5,
    hole_x: 40..44,
};

fn ray_c(r: &Ray) -> refl_ray {
    (*r).into()
}

/// Rays covering hits (wall, box, back faces), misses of every kind and
/// the planar case.
fn rays(cam: &Camera) -> Vec<(Ray, f32)> {
    let at = |x: f32, y: f32, z: f32| cam.unproject(Vec2::new(x, y), z, DepthConvention::Linear);
    let between = |a: Vec3, b: Vec3| Ray {
        origin: a,
        dir: (b - a).normalize(),
    };
    vec![
        (
            between(at(2.5, 2.5, 1.0), at(40.5, 25.5, 9.0)),
            f32::INFINITY,
        ),
        (
            between(at(5.5, 15.5, 2.0), at(25.5, 15.5, 3.5)),
            f32::INFINITY,
        ),
        (cam.primary_ray(Vec2::new(20.5, 12.5)), f32::INFINITY),
        (cam.primary_ray(Vec2::new(41.5, 5.5)), f32::INFINITY),
        (
            between(at(5.5, 15.5, 2.0), at(60.0, 15.5, 2.0)),
            f32::INFINITY,
        ),
        (between(at(5.5, 15.5, 2.0), at(40.5, 25.5, 9.0)), 0.5),
        (
            between(at(40.5, 15.5, 7.0), at(20.5, 15.5, 3.5)),
            f32::INFINITY,
        ),
        (between(at(20.5, 15.5, 5.0), at(2.5, 15.5, 5.0)), 0.3),
        (
            between(at(20.5, 15.5, -5.0), at(20.5, 15.5, -9.0)),
            f32::INFINITY,
        ),
    ]
}

fn default_options() -> refl_step_options {
    refl_step_options {
        stride: 1,
        max_steps: u32::MAX,
    }
}

fn call_one(
    img: &refl_depth_image,
    th: &refl_trace_thickness,
    ray: refl_ray,
    t_max: f32,
    opts: &refl_step_options,
) -> (refl_status, refl_trace_result) {
    let mut out = MaybeUninit::<refl_trace_result>::uninit();
    let s = unsafe { refl_step_ray(out.as_mut_ptr(), img, th, ray, t_max, opts) };
    // Only read on success.
    let r = if s == refl_status::Ok {
        unsafe { out.assume_init() }
    } else {
        refl_trace_result::default()
    };
    (s, r)
}

fn expect_same(c: &refl_trace_result, t: &Trace) {
    assert_eq!(*c, refl_trace_result::from(*t));
    match t {
        Trace::Hit(h) => {
            assert_eq!(c.miss, refl_trace_miss::None as u32);
            assert_eq!((c.pixel.x, c.pixel.y), (h.pixel.x, h.pixel.y));
            assert_eq!(
                (c.t, c.depth, c.surface_depth),
                (h.t, h.depth, h.surface_depth)
            );
        }
        Trace::Miss { reason, work } => {
            assert_eq!(c.miss, refl_trace_miss::from(*reason) as u32);
            assert_ne!(c.miss, 0);
            assert_eq!((c.steps, c.fetches), (work.steps, work.fetches));
            assert_eq!((c.t, c.depth), (0.0, 0.0));
        }
    }
}

/// The constant thickness `constant`, no back-face image.
fn constant(constant: f32) -> refl_trace_thickness {
    refl_trace_thickness {
        constant,
        back_faces: no_image(),
    }
}

#[test]
fn step_ray_matches_core_in_every_convention() {
    let cam = SCENE.camera();
    let mut reasons = std::collections::HashSet::new();
    for conv in DepthConvention::ALL {
        let (front, back) = SCENE.images(&cam, conv);
        let img = depth_image_c(&cam, &front, conv);
        let core_img =
            DepthImage::try_new(ImageView::try_new(&front, W, H, W).unwrap(), cam, conv).unwrap();
        let back_view = ImageView::try_new(&back, W, H, W).unwrap();
        for (stride, back_faces) in [(1, false), (4, true), (8, false)] {
            let opts = refl_step_options {
                stride,
                max_steps: 1000,
            };
            let th = refl_trace_thickness {
                constant: 0.5,
                back_faces: if back_faces {
                    SCENE.image_c(&back)
                } else {
                    no_image()
                },
            };
            let core_th = if back_faces {
                Thickness::BackFaces(back_view)
            } else {
                Thickness::Constant(0.5)
            };
            for (r, tm) in rays(&cam) {
                let (s, c) = call_one(&img, &th, ray_c(&r), tm, &opts);
                assert_eq!(s, refl_status::Ok);
                let t = try_step(&core_img, core_th, r, tm, opts.into()).unwrap();
                expect_same(&c, &t);
                reasons.insert(c.miss);
            }
        }
    }
    // Hits and four miss reasons were exercised.
    assert_eq!(reasons.len(), 5, "{reasons:?}");
}

#[test]
fn planar_ray_hits_the_box_in_one_step() {
    let cam = SCENE.camera();
    let planar = rays(&SCENE.camera())[2].0;
    let (front, _) = SCENE.images(&cam, DepthConvention::ReversedZ);
    let img = depth_image_c(&cam, &front, DepthConvention::ReversedZ);
    let th = constant(1.0);
    let (_, c) = call_one(&img, &th, ray_c(&planar), f32::INFINITY, &default_options());
    assert_eq!((c.miss, c.steps, c.fetches), (0, 1, 1));
    assert!((c.surface_depth - 3.0).abs() < 1e-4);
}

fn untouched_one(
    want: refl_status,
    img: *const refl_depth_image,
    th: *const refl_trace_thickness,
    ray: refl_ray,
    t_max: f32,
    opts: *const refl_step_options,
) {
    let mut out = [0xA5u8; core::mem::size_of::<refl_trace_result>() + 8];
    let p = out.as_mut_ptr().cast::<refl_trace_result>();
    // `out` is a byte array: align the pointer as the type needs.
    let off = p.align_offset(core::mem::align_of::<refl_trace_result>());
    let p = unsafe { out.as_mut_ptr().add(off) }.cast::<refl_trace_result>();
    let s = unsafe { refl_step_ray(p, img, th, ray, t_max, opts) };
    assert_eq!(s, want);
    assert!(out.iter().all(|b| *b == 0xA5), "output written on error");
    assert_eq!(
        unsafe { refl_step_ray(core::ptr::null_mut(), img, th, ray, t_max, opts) },
        refl_status::NullPointer
    );
}

/// The depth convention of the error tests.
const ERR_CONV: DepthConvention = DepthConvention::ZeroToOne;

#[test]
fn step_ray_refuses_null_pointers_and_bad_arguments_untouched() {
    let cam = SCENE.camera();
    let (front, _) = SCENE.images(&cam, ERR_CONV);
    let img = depth_image_c(&cam, &front, ERR_CONV);
    let th = constant(0.5);
    let opts = default_options();
    let good = ray_c(&rays(&cam)[0].0);
    use core::ptr::null;
    use refl_status::*;
    untouched_one(NullPointer, null(), &th, good, 1.0, &opts);
    untouched_one(NullPointer, &img, null(), good, 1.0, &opts);
    untouched_one(NullPointer, &img, &th, good, 1.0, null());
    let no_data = refl_depth_image {
        depth: no_image(),
        ..img
    };
    untouched_one(NullPointer, &no_data, &th, good, 1.0, &opts);
    for bad in [3u32, 7, u32::MAX] {
        let i = refl_depth_image {
            convention: bad,
            ..img
        };
        untouched_one(InvalidArgument, &i, &th, good, 1.0, &opts);
    }
    let mut nan = good;
    nan.origin.x = f32::NAN;
    untouched_one(InvalidArgument, &img, &th, nan, 1.0, &opts);
    let mut inf = good;
    inf.dir.y = f32::INFINITY;
    untouched_one(InvalidArgument, &img, &th, inf, 1.0, &opts);
    let mut long = good;
    long.dir.x *= 3.0;
    untouched_one(InvalidArgument, &img, &th, long, 1.0, &opts);
    for t in [f32::NAN, 0.0, -1.0] {
        untouched_one(InvalidArgument, &img, &th, good, t, &opts);
    }
    let zero_stride = refl_step_options { stride: 0, ..opts };
    untouched_one(InvalidArgument, &img, &th, good, 1.0, &zero_stride);
    for c in [f32::NAN, -1.0] {
        let t = refl_trace_thickness { constant: c, ..th };
        untouched_one(InvalidArgument, &img, &t, good, 1.0, &opts);
    }
}

#[test]
fn step_ray_refuses_bad_images_and_cameras_untouched() {
    let cam = SCENE.camera();
    let (front, back) = SCENE.images(&cam, ERR_CONV);
    let img = depth_image_c(&cam, &front, ERR_CONV);
    let th = constant(0.5);
    let opts = default_options();
    let good = ray_c(&rays(&cam)[0].0);
    use refl_status::*;
    // Back-face image of the wrong size, and too short.
    let small = refl_trace_thickness {
        back_faces: refl_image_f32 {
            width: W - 1,
            ..SCENE.image_c(&back)
        },
        ..th
    };
    untouched_one(InvalidArgument, &img, &small, good, 1.0, &opts);
    let short_back = refl_trace_thickness {
        back_faces: refl_image_f32 {
            len: back.len() - 1,
            ..SCENE.image_c(&back)
        },
        ..th
    };
    untouched_one(InsufficientSize, &img, &short_back, good, 1.0, &opts);
    let short = refl_depth_image {
        depth: refl_image_f32 {
            len: front.len() - 1,
            ..img.depth
        },
        ..img
    };
    untouched_one(InsufficientSize, &short, &th, good, 1.0, &opts);
    // Image size differs from the camera's; invalid camera.
    let mismatch = refl_depth_image {
        depth: refl_image_f32 {
            height: H - 1,
            ..img.depth
        },
        ..img
    };
    untouched_one(InvalidArgument, &mismatch, &th, good, 1.0, &opts);
    let mut bad_cam = img;
    bad_cam.camera.fov_y = f32::NAN;
    untouched_one(InvalidArgument, &bad_cam, &th, good, 1.0, &opts);
}

/// The depth convention of the batch tests.
const BATCH_CONV: DepthConvention = DepthConvention::ReversedZ;

/// The options of the batch tests.
const BATCH_OPTIONS: refl_step_options = refl_step_options {
    stride: 4,
    max_steps: 500,
};

/// `refl_step_rays` writing `out[..out_len]` for `rays` with the
/// `t_max` values `t` (their whole lengths).
fn step_rays(
    img: &refl_depth_image,
    th: &refl_trace_thickness,
    out: &mut [refl_trace_result],
    out_len: usize,
    rays: &[refl_ray],
    t: &[f32],
) -> refl_status {
    unsafe {
        refl_step_rays(
            out.as_mut_ptr(),
            out_len,
            img,
            th,
            rays.as_ptr(),
            rays.len(),
            t.as_ptr(),
            t.len(),
            &BATCH_OPTIONS,
        )
    }
}

/// The inputs of the batch tests: the depth image in [`BATCH_CONV`] (and
/// the buffer it points into), the test rays as C rays and their `t_max`.
fn batch_inputs() -> (Vec<f32>, refl_depth_image, Vec<refl_ray>, Vec<f32>) {
    let cam = SCENE.camera();
    let (front, _) = SCENE.images(&cam, BATCH_CONV);
    let img = depth_image_c(&cam, &front, BATCH_CONV);
    let (rs, tms): (Vec<Ray>, Vec<f32>) = rays(&cam).into_iter().unzip();
    (front, img, rs.iter().map(ray_c).collect(), tms)
}

/// A trace result no export writes.
fn batch_sentinel() -> refl_trace_result {
    refl_trace_result {
        miss: 77,
        ..Default::default()
    }
}

#[test]
fn step_rays_matches_step_ray_and_writes_only_its_rays() {
    let (_front, img, rc, tms) = batch_inputs();
    let (th, opts, sentinel) = (constant(0.5), BATCH_OPTIONS, batch_sentinel());
    let n = rc.len();
    let call = |out: &mut [refl_trace_result], out_len: usize, rays: &[refl_ray], t: &[f32]| {
        step_rays(&img, &th, out, out_len, rays, t)
    };
    let mut out = vec![sentinel; n + 1];
    assert_eq!(call(&mut out, n + 1, &rc, &tms), refl_status::Ok);
    for i in 0..n {
        let (s, one) = call_one(&img, &th, rc[i], tms[i], &opts);
        assert_eq!(s, refl_status::Ok);
        assert_eq!(out[i], one);
    }
    assert_eq!(out[n], sentinel);
    // One t_max for every ray.
    assert_eq!(call(&mut out, n, &rc, &[2.0]), refl_status::Ok);
    assert_eq!(out[1], call_one(&img, &th, rc[1], 2.0, &opts).1);
}

#[test]
fn step_rays_errors_leave_the_outputs_untouched() {
    let (_front, img, rc, tms) = batch_inputs();
    let (th, opts, sentinel) = (constant(0.5), BATCH_OPTIONS, batch_sentinel());
    let n = rc.len();
    let call = |out: &mut [refl_trace_result], out_len: usize, rays: &[refl_ray], t: &[f32]| {
        step_rays(&img, &th, out, out_len, rays, t)
    };
    let mut out = vec![sentinel; n];
    assert_eq!(
        call(&mut out, n - 1, &rc, &tms),
        refl_status::InsufficientSize
    );
    assert_eq!(
        call(&mut out, n, &rc, &tms[..n - 1]),
        refl_status::InsufficientSize
    );
    assert_eq!(call(&mut out, n, &rc, &[]), refl_status::InvalidArgument);
    let mut bad = rc.clone();
    bad[n - 1].dir.z = f32::NAN;
    assert_eq!(call(&mut out, n, &bad, &tms), refl_status::InvalidArgument);
    let mut bad_t = tms.clone();
    bad_t[3] = -1.0;
    assert_eq!(call(&mut out, n, &rc, &bad_t), refl_status::InvalidArgument);
    assert!(out.iter().all(|o| *o == sentinel));
    let s = unsafe {
        refl_step_rays(
            out.as_mut_ptr(),
            n,
            &img,
            &th,
            core::ptr::null(),
            n,
            tms.as_ptr(),
            n,
            &opts,
        )
    };
    assert_eq!(s, refl_status::NullPointer);
    let s = unsafe {
        refl_step_rays(
            core::ptr::null_mut(),
            n,
            &img,
            &th,
            rc.as_ptr(),
            n,
            tms.as_ptr(),
            n,
            &opts,
        )
    };
    assert_eq!(s, refl_status::NullPointer);
    assert!(out.iter().all(|o| *o == sentinel));
}

/// `refl_trace_refine_hit` equals `refl_core::trace::refine_hit` on every hit
/// of the ray set and passes misses through.
#[test]
fn refine_hit_matches_core() {
    let cam = SCENE.camera();
    for conv in DepthConvention::ALL {
        let (front, _) = SCENE.images(&cam, conv);
        let img_c = depth_image_c(&cam, &front, conv);
        let view = ImageView::try_new(&front, cam.width(), cam.height(), cam.width()).unwrap();
        let img = DepthImage::try_new(view, cam, conv).unwrap();
        let th = constant(0.5);
        let mut refined = 0;
        for (ray, t_max) in rays(&cam) {
            let (s, hit) = call_one(&img_c, &th, ray_c(&ray), t_max, &default_options());
            assert_eq!(s, refl_status::Ok);
            let mut out = MaybeUninit::<refl_trace_result>::uninit();
            let s = unsafe {
                refl_trace_refine_hit(out.as_mut_ptr(), &img_c, ray_c(&ray), t_max, &hit)
            };
            assert_eq!(s, refl_status::Ok);
            let out = unsafe { out.assume_init() };
            let core = try_step(
                &img,
                Thickness::Constant(0.5),
                ray,
                t_max,
                Default::default(),
            )
            .unwrap();
            match core {
                Trace::Hit(h) => {
                    let r = refl_core::trace::refine_hit(&img, &ray, t_max, &h);
                    expect_same(&out, &Trace::Hit(r));
                    refined += usize::from(r.t != h.t);
                }
                Trace::Miss { .. } => assert_eq!(out, hit),
            }
        }
        assert!(refined > 0, "{conv:?}: nothing refined");
    }
}

/// `refl_trace_refine_hit` leaves `out` untouched on error.
#[test]
fn refine_hit_errors_leave_the_output_untouched() {
    let cam = SCENE.camera();
    for conv in DepthConvention::ALL {
        let (front, _) = SCENE.images(&cam, conv);
        let img_c = depth_image_c(&cam, &front, conv);
        let sentinel = refl_trace_result {
            miss: 77,
            ..Default::default()
        };
        let mut out = sentinel;
        let bad = refl_trace_result {
            t: f32::NAN,
            ..Default::default()
        };
        let (ray, t_max) = rays(&cam)[0];
        let s = unsafe { refl_trace_refine_hit(&mut out, &img_c, ray_c(&ray), t_max, &bad) };
        assert_eq!(s, refl_status::InvalidArgument);
        assert_eq!(out, sentinel);
        let s =
            unsafe { refl_trace_refine_hit(&mut out, core::ptr::null(), ray_c(&ray), t_max, &bad) };
        assert_eq!(s, refl_status::NullPointer);
        assert_eq!(out, sentinel);
    }
}
