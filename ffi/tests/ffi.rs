//! The C ABI called from Rust: results agree with refl-core, every error
//! path returns its documented status and leaves outputs byte-identical.

use core::mem::{size_of, MaybeUninit};
use refl::*;
use refl_core::glam::{Mat4, Vec3};
use refl_core::{Camera, DepthConvention, Plane};
use std::ffi::CStr;

const SENTINEL: u8 = 0xA5;

#[repr(C, align(16))]
struct Scratch([u8; 256]);

/// Calls `f` with an output pointer into sentinel-filled memory, expects
/// status `expected` and that not one output byte changed.
fn untouched<T>(expected: refl_status, f: impl FnOnce(*mut T) -> refl_status) {
    assert!(size_of::<T>() <= 256);
    let mut buf = Scratch([SENTINEL; 256]);
    let s = f(buf.0.as_mut_ptr().cast());
    assert_eq!(s, expected);
    assert!(
        buf.0.iter().all(|b| *b == SENTINEL),
        "output written on error"
    );
}

/// Calls `f` with an output pointer, expects OK and returns the output.
fn ok<T>(f: impl FnOnce(*mut T) -> refl_status) -> T {
    let mut v = MaybeUninit::<T>::uninit();
    assert_eq!(f(v.as_mut_ptr()), refl_status::Ok);
    // SAFETY: the function returned OK, so it wrote the output.
    unsafe { v.assume_init() }
}

fn v3(x: f32, y: f32, z: f32) -> refl_vec3 {
    refl_vec3 { x, y, z }
}
fn v2(x: f32, y: f32) -> refl_vec2 {
    refl_vec2 { x, y }
}

/// A 640x480 camera at `eye` looking at (0, 0.5, 0).
fn camera_at(eye: refl_vec3) -> refl_camera {
    ok(|o| unsafe {
        refl_camera_look_at(
            o,
            eye,
            v3(0.0, 0.5, 0.0),
            v3(0.0, 1.0, 0.0),
            1.0,
            0.1,
            100.0,
            640,
            480,
        )
    })
}

fn camera() -> refl_camera {
    camera_at(v3(1.0, 2.0, 5.0))
}

fn camera_inf() -> refl_camera {
    refl_camera {
        z_far: f32::INFINITY,
        ..camera()
    }
}

fn core_camera(c: &refl_camera) -> Camera {
    Camera::try_from(c).unwrap()
}

fn floor_plane() -> refl_plane {
    ok(|o| unsafe { refl_plane_from_point_normal(o, v3(0.0, -1.0, 0.0), v3(0.0, 1.0, 0.0)) })
}

const CONVENTIONS: [u32; 3] = [0, 1, 2];

#[test]
fn status_strings_are_never_null() {
    for v in (0..64).chain([u32::MAX, u32::MAX - 1, 1 << 31]) {
        let p = refl_status_string(v);
        assert!(!p.is_null());
        // SAFETY: documented static NUL-terminated string.
        let s = unsafe { CStr::from_ptr(p) }.to_str().unwrap();
        assert!(!s.is_empty());
        if v > 5 {
            assert_eq!(s, "unknown refl_status value");
        }
    }
    // SAFETY: as above.
    let ok = unsafe { CStr::from_ptr(refl_status_string(0)) };
    assert_eq!(ok.to_str().unwrap(), "ok");
}

#[test]
fn version() {
    // SAFETY: static string.
    let v = unsafe { CStr::from_ptr(refl_version()) };
    assert_eq!(v.to_str().unwrap(), env!("CARGO_PKG_VERSION"));
    assert_eq!(
        refl_version_number(),
        (REFL_VERSION_MAJOR << 16) | (REFL_VERSION_MINOR << 8) | REFL_VERSION_PATCH
    );
}

#[test]
fn look_at_matches_core_and_the_camera_validates() {
    let c = camera();
    let core = Camera::try_look_at(
        Vec3::new(1.0, 2.0, 5.0),
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::Y,
        1.0,
        0.1,
        100.0,
        640,
        480,
    )
    .unwrap();
    assert_eq!(core_camera(&c), core);
    assert_eq!(unsafe { refl_camera_validate(&c) }, refl_status::Ok);
}

#[test]
fn look_at_refuses_bad_input_untouched() {
    let look = |eye: refl_vec3, target: refl_vec3, fov: f32, n: f32, f: f32, w: u32, h: u32| {
        move |o: *mut refl_camera| unsafe {
            refl_camera_look_at(o, eye, target, v3(0.0, 1.0, 0.0), fov, n, f, w, h)
        }
    };
    let (e, t) = (v3(0.0, 0.0, 5.0), v3(0.0, 0.0, 0.0));
    untouched(refl_status::NullPointer, |_: *mut refl_camera| {
        look(e, t, 1.0, 0.1, 10.0, 4, 4)(core::ptr::null_mut())
    });
    untouched(
        refl_status::InvalidArgument,
        look(v3(f32::NAN, 0.0, 0.0), t, 1.0, 0.1, 10.0, 4, 4),
    );
    untouched(
        refl_status::InvalidArgument,
        look(e, v3(0.0, f32::INFINITY, 0.0), 1.0, 0.1, 10.0, 4, 4),
    );
    untouched(
        refl_status::DegenerateGeometry,
        look(e, e, 1.0, 0.1, 10.0, 4, 4),
    );
    // up parallel to the view direction
    untouched(
        refl_status::DegenerateGeometry,
        look(v3(0.0, 5.0, 0.0), t, 1.0, 0.1, 10.0, 4, 4),
    );
    for (fov, n, f, w, h) in [
        (0.0, 0.1, 10.0, 4, 4),
        (3.2, 0.1, 10.0, 4, 4),
        (f32::NAN, 0.1, 10.0, 4, 4),
        (1.0, 0.0, 10.0, 4, 4),
        (1.0, -1.0, 10.0, 4, 4),
        (1.0, f32::INFINITY, f32::INFINITY, 4, 4),
        (1.0, 0.1, 0.1, 4, 4),
        (1.0, 0.1, f32::NAN, 4, 4),
        (1.0, 0.1, 10.0, 0, 4),
        (1.0, 0.1, 10.0, 4, 0),
    ] {
        untouched(refl_status::InvalidArgument, look(e, t, fov, n, f, w, h));
    }
}

#[test]
fn look_at_accepts_an_infinite_far_plane_and_huge_sizes() {
    ok(|o| unsafe {
        refl_camera_look_at(
            o,
            v3(0.0, 0.0, 5.0),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 1.0, 0.0),
            1.0,
            0.1,
            f32::INFINITY,
            u32::MAX,
            u32::MAX,
        )
    });
}

#[test]
fn validate_rejects_bad_cameras() {
    assert_eq!(
        unsafe { refl_camera_validate(core::ptr::null()) },
        refl_status::NullPointer
    );
    let mut c = camera();
    c.view.m[0] *= 1.01; // not orthonormal
    assert_eq!(
        unsafe { refl_camera_validate(&c) },
        refl_status::DegenerateGeometry
    );
    let mut c = camera();
    c.view.m[3] = 0.5; // last row not (0, 0, 0, 1)
    assert_eq!(
        unsafe { refl_camera_validate(&c) },
        refl_status::DegenerateGeometry
    );
    let mut c = camera();
    c.view.m[12] = f32::NAN;
    assert_eq!(
        unsafe { refl_camera_validate(&c) },
        refl_status::InvalidArgument
    );
    let c = refl_camera {
        width: 0,
        ..camera()
    };
    assert_eq!(
        unsafe { refl_camera_validate(&c) },
        refl_status::InvalidArgument
    );
    // Misaligned camera pointer.
    let mut buf = [0u8; size_of::<refl_camera>() + 8];
    let p = unsafe { buf.as_mut_ptr().add(1) }.cast::<refl_camera>();
    assert_eq!(
        unsafe { refl_camera_validate(p) },
        refl_status::InvalidArgument
    );
}

/// Every camera-taking function reports the invalid camera untouched.
#[test]
fn camera_taking_functions_refuse_an_invalid_camera_untouched() {
    let bad = refl_camera {
        fov_y: f32::NAN,
        ..camera()
    };
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_primary_ray(o, &bad, v2(1.0, 1.0))
    });
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_eye(o, &bad)
    });
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_mirror_camera(o, &bad, &floor_plane())
    });
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_reproject(o, &camera(), &bad, v2(1.0, 1.0), 0.5, 1)
    });
}

#[test]
fn primary_ray_matches_core() {
    let c = camera();
    let core = core_camera(&c);
    for p in [
        v2(0.5, 0.5),
        v2(320.0, 240.0),
        v2(639.5, 479.5),
        v2(-100.0, 1e4),
    ] {
        let r: refl_ray = ok(|o| unsafe { refl_camera_primary_ray(o, &c, p) });
        let e = core.primary_ray(p.into());
        assert_eq!(r, e.into());
    }
    untouched(refl_status::NullPointer, |_: *mut refl_ray| unsafe {
        refl_camera_primary_ray(core::ptr::null_mut(), &c, v2(0.0, 0.0))
    });
    untouched(refl_status::NullPointer, |o| unsafe {
        refl_camera_primary_ray(o, core::ptr::null(), v2(0.0, 0.0))
    });
    for p in [v2(f32::NAN, 0.0), v2(0.0, f32::INFINITY), v2(3e38, 3e38)] {
        untouched(refl_status::InvalidArgument, |o| unsafe {
            refl_camera_primary_ray(o, &c, p)
        });
    }
}

#[test]
fn project_unproject_round_trip_all_conventions() {
    for c in [camera(), camera_inf()] {
        let core = core_camera(&c);
        let p = v3(0.3, 0.7, -0.4);
        let pr: refl_projection = ok(|o| unsafe { refl_camera_project(o, &c, p) });
        assert!(pr.valid);
        let e = core.project(p.into()).unwrap();
        assert_eq!((pr.x, pr.y, pr.depth), (e.x, e.y, e.z));
        for conv in CONVENTIONS {
            let d: f32 = ok(|o| unsafe { refl_camera_encode_depth(o, &c, pr.depth, conv) });
            let z: f32 = ok(|o| unsafe { refl_camera_decode_depth(o, &c, d, conv) });
            assert!(
                (z - pr.depth).abs() < 1e-3 * pr.depth,
                "{conv}: {z} vs {}",
                pr.depth
            );
            let w: refl_vec3 =
                ok(|o| unsafe { refl_camera_unproject(o, &c, v2(pr.x, pr.y), d, conv) });
            let err = (Vec3::from(w) - Vec3::from(p)).length();
            assert!(err < 1e-3, "{conv}: {err}");
        }
    }
    let c = camera();
    // Behind the eye: valid = false, zeros; still OK.
    let eye: refl_vec3 = ok(|o| unsafe { refl_camera_eye(o, &c) });
    let behind = v3(eye.x * 2.0, eye.y * 2.0, eye.z * 2.0);
    let pr: refl_projection = ok(|o| unsafe { refl_camera_project(o, &c, behind) });
    assert_eq!(pr, refl_projection::default());
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_project(o, &c, v3(f32::NAN, 0.0, 0.0))
    });
    untouched(refl_status::NullPointer, |o| unsafe {
        refl_camera_project(o, core::ptr::null(), v3(0.0, 0.0, 0.0))
    });
    // Unproject errors.
    for (px, d, conv, want) in [
        (v2(1.0, 1.0), 0.5, 3, refl_status::InvalidArgument),
        (v2(1.0, 1.0), 0.5, u32::MAX, refl_status::InvalidArgument),
        (v2(f32::NAN, 1.0), 0.5, 1, refl_status::InvalidArgument),
        (v2(1.0, 1.0), f32::NAN, 1, refl_status::InvalidArgument),
        (v2(1.0, 1.0), f32::INFINITY, 0, refl_status::InvalidArgument),
    ] {
        untouched(want, |o| unsafe {
            refl_camera_unproject(o, &c, px, d, conv)
        });
    }
    // The far plane at infinity has no finite point.
    let ci = camera_inf();
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_unproject(o, &ci, v2(1.0, 1.0), 0.0, 2)
    });
    let z: f32 = ok(|o| unsafe { refl_camera_decode_depth(o, &ci, 0.0, 2) });
    assert_eq!(z, f32::INFINITY);
}

#[test]
fn encode_decode_match_core_and_validate() {
    let c = camera();
    let core = core_camera(&c);
    for conv in DepthConvention::ALL {
        let u = conv as u32;
        let d: f32 = ok(|o| unsafe { refl_camera_encode_depth(o, &c, 7.0, u) });
        assert_eq!(d, core.encode_depth(7.0, conv));
        let z: f32 = ok(|o| unsafe { refl_camera_decode_depth(o, &c, 0.25, u) });
        assert_eq!(z, core.decode_depth(0.25, conv));
        untouched(refl_status::InvalidArgument, |o| unsafe {
            refl_camera_encode_depth(o, &c, f32::NAN, u)
        });
        untouched(refl_status::InvalidArgument, |o| unsafe {
            refl_camera_decode_depth(o, &c, f32::NAN, u)
        });
    }
    for bad in [3, 4, 0x8000_0000, u32::MAX] {
        untouched(refl_status::InvalidArgument, |o| unsafe {
            refl_camera_encode_depth(o, &c, 1.0, bad)
        });
        untouched(refl_status::InvalidArgument, |o| unsafe {
            refl_camera_decode_depth(o, &c, 0.5, bad)
        });
    }
    // inf / inf is NaN for a finite far plane: rejected.
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_encode_depth(o, &c, f32::INFINITY, 1)
    });
    untouched(refl_status::NullPointer, |o| unsafe {
        refl_camera_encode_depth(o, core::ptr::null(), 1.0, 1)
    });
}

// DepthConvention as the C enum value.
trait AsU32 {
    fn to_c(self) -> u32;
}
impl AsU32 for DepthConvention {
    fn to_c(self) -> u32 {
        match self {
            DepthConvention::Linear => refl_depth_convention::Linear as u32,
            DepthConvention::ZeroToOne => refl_depth_convention::ZeroToOne as u32,
            DepthConvention::ReversedZ => refl_depth_convention::ReversedZ as u32,
        }
    }
}

#[test]
fn enum_values_are_stable() {
    for conv in DepthConvention::ALL {
        let c: refl_depth_convention = match conv.to_c() {
            0 => refl_depth_convention::Linear,
            1 => refl_depth_convention::ZeroToOne,
            _ => refl_depth_convention::ReversedZ,
        };
        assert_eq!(DepthConvention::from(c), conv);
    }
    assert_eq!(refl_status::Ok as u32, 0);
    assert_eq!(refl_status::Panic as u32, 5);
}

#[test]
fn matrices_match_core() {
    let (a, b) = (camera(), camera_inf());
    let (ca, cb) = (core_camera(&a), core_camera(&b));
    for conv in [DepthConvention::ZeroToOne, DepthConvention::ReversedZ] {
        let u = conv.to_c();
        let p: refl_mat4 = ok(|o| unsafe { refl_camera_projection_matrix(o, &a, u) });
        assert_eq!(Mat4::from(p), ca.try_projection(conv).unwrap());
        let w: refl_mat4 = ok(|o| unsafe { refl_camera_world_to_pixel_matrix(o, &b, u) });
        assert_eq!(Mat4::from(w), cb.try_world_to_pixel(conv).unwrap());
        let r: refl_mat4 = ok(|o| unsafe { refl_camera_reprojection_matrix(o, &a, &b, u) });
        assert_eq!(
            Mat4::from(r),
            refl_core::camera::try_reprojection_matrix(&ca, &cb, conv).unwrap()
        );
    }
    for conv in [0, 3, u32::MAX] {
        untouched(refl_status::InvalidArgument, |o| unsafe {
            refl_camera_projection_matrix(o, &a, conv)
        });
        untouched(refl_status::InvalidArgument, |o| unsafe {
            refl_camera_world_to_pixel_matrix(o, &a, conv)
        });
        untouched(refl_status::InvalidArgument, |o| unsafe {
            refl_camera_reprojection_matrix(o, &a, &b, conv)
        });
    }
    untouched(refl_status::NullPointer, |o| unsafe {
        refl_camera_reprojection_matrix(o, &a, core::ptr::null(), 1)
    });
    untouched(refl_status::NullPointer, |o| unsafe {
        refl_camera_reprojection_matrix(o, core::ptr::null(), &b, 1)
    });
    let iv: refl_mat4 = ok(|o| unsafe { refl_camera_inverse_view(o, &a) });
    assert_eq!(Mat4::from(iv), ca.inverse_view());
    let eye: refl_vec3 = ok(|o| unsafe { refl_camera_eye(o, &a) });
    assert_eq!(Vec3::from(eye), ca.eye());
    let m: bool = ok(|o| unsafe { refl_camera_is_mirrored(o, &a) });
    assert!(!m);
}

#[test]
fn reprojection_agrees_with_matrix() {
    let a = camera();
    let b = camera_at(v3(1.5, 2.0, 5.0));
    for conv in [1u32, 2] {
        let m: refl_mat4 = ok(|o| unsafe { refl_camera_reprojection_matrix(o, &a, &b, conv) });
        let d: f32 = ok(|o| unsafe { refl_camera_encode_depth(o, &a, 5.0, conv) });
        let px = v2(200.5, 300.5);
        let r1: refl_projection = ok(|o| unsafe { refl_camera_reproject(o, &a, &b, px, d, conv) });
        let r2: refl_projection = ok(|o| unsafe { refl_camera_apply_reprojection(o, &m, px, d) });
        assert!(r1.valid && r2.valid);
        assert!((r1.x - r2.x).abs() < 0.05 && (r1.y - r2.y).abs() < 0.05);
        let z: f32 = ok(|o| unsafe { refl_camera_decode_depth(o, &b, r2.depth, conv) });
        assert!((z - r1.depth).abs() < 1e-2 * z);
    }
    let m: refl_mat4 = ok(|o| unsafe { refl_camera_reprojection_matrix(o, &a, &b, 1) });
    let mut nan = m;
    nan.m[5] = f32::NAN;
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_apply_reprojection(o, &nan, v2(1.0, 1.0), 0.5)
    });
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_apply_reprojection(o, &m, v2(1.0, f32::NAN), 0.5)
    });
    untouched(refl_status::NullPointer, |o| unsafe {
        refl_camera_apply_reprojection(o, core::ptr::null(), v2(1.0, 1.0), 0.5)
    });
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_reproject(o, &a, &b, v2(1.0, 1.0), f32::INFINITY, 1)
    });
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_reproject(o, &a, &b, v2(1.0, 1.0), 0.5, 7)
    });
}

/// The non-unit plane 2y - 2 = 0, filled by hand.
fn hand_plane() -> refl_plane {
    refl_plane {
        normal: v3(0.0, 2.0, 0.0),
        d: -2.0,
    }
}

/// A ray straight down from (0, 5, 0).
fn down_ray() -> refl_ray {
    refl_ray {
        origin: v3(0.0, 5.0, 0.0),
        dir: v3(0.0, -1.0, 0.0),
    }
}

#[test]
fn plane_from_triangle_matches_core() {
    let t: refl_plane = ok(|o| unsafe {
        refl_plane_from_triangle(o, v3(0.0, 1.0, 0.0), v3(0.0, 1.0, 1.0), v3(1.0, 1.0, 0.0))
    });
    let core_t = Plane::try_from_triangle(
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 1.0),
        Vec3::new(1.0, 1.0, 0.0),
    )
    .unwrap();
    assert_eq!(t, refl_plane::from(&core_t));
}

#[test]
fn plane_and_mirror_functions_of_a_non_unit_plane_are_exact() {
    // Signed distance through a hand-filled, non-unit plane: 2y - 2 = 0.
    let hand = hand_plane();
    let s: f32 = ok(|o| unsafe { refl_plane_signed_distance(o, &hand, v3(5.0, 3.0, 1.0)) });
    assert_eq!(s, 2.0);
    let m: refl_vec3 = ok(|o| unsafe { refl_mirror_point(o, &hand, v3(5.0, 3.0, 1.0)) });
    assert_eq!(m, v3(5.0, -1.0, 1.0));
    let mm: refl_mat4 = ok(|o| unsafe { refl_mirror_matrix(o, &hand) });
    let mm = Mat4::from(mm);
    assert!((mm.determinant() + 1.0).abs() < 1e-6);
    assert!((mm * mm).abs_diff_eq(Mat4::IDENTITY, 1e-6));
    let r: refl_vec3 =
        ok(|o| unsafe { refl_mirror_reflect(o, v3(1.0, 1.0, 0.0), v3(0.0, 1.0, 0.0)) });
    assert_eq!(r, v3(-1.0, 1.0, 0.0));
    let th: f32 = ok(|o| unsafe { refl_plane_intersect_ray(o, &hand, down_ray()) });
    assert_eq!(th, 4.0);
}

#[test]
fn plane_constructors_refuse_degenerate_and_non_finite_input_untouched() {
    untouched(refl_status::DegenerateGeometry, |o| unsafe {
        refl_plane_from_triangle(o, v3(0.0, 0.0, 0.0), v3(1.0, 1.0, 1.0), v3(2.0, 2.0, 2.0))
    });
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_plane_from_triangle(
            o,
            v3(f32::NAN, 0.0, 0.0),
            v3(1.0, 1.0, 1.0),
            v3(2.0, 0.0, 2.0),
        )
    });
    untouched(refl_status::DegenerateGeometry, |o| unsafe {
        refl_plane_from_point_normal(o, v3(0.0, 0.0, 0.0), v3(0.0, 0.0, 0.0))
    });
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_plane_from_point_normal(o, v3(0.0, 0.0, f32::INFINITY), v3(0.0, 1.0, 0.0))
    });
}

#[test]
fn plane_taking_functions_refuse_a_zero_or_nan_plane_untouched() {
    let ray = down_ray();
    let zero = refl_plane::default();
    let nan = refl_plane {
        normal: v3(0.0, 1.0, 0.0),
        d: f32::NAN,
    };
    for (p, want) in [
        (&zero, refl_status::DegenerateGeometry),
        (&nan, refl_status::InvalidArgument),
    ] {
        untouched(want, |o| unsafe {
            refl_plane_signed_distance(o, p, v3(0.0, 0.0, 0.0))
        });
        untouched(want, |o| unsafe {
            refl_mirror_point(o, p, v3(0.0, 0.0, 0.0))
        });
        untouched(want, |o| unsafe { refl_mirror_matrix(o, p) });
        untouched(want, |o| unsafe { refl_plane_intersect_ray(o, p, ray) });
        untouched(want, |o| unsafe { refl_mirror_camera(o, &camera(), p) });
    }
}

#[test]
fn mirror_and_intersection_errors_leave_the_output_untouched() {
    let hand = hand_plane();
    untouched(refl_status::NullPointer, |o| unsafe {
        refl_mirror_matrix(o, core::ptr::null())
    });
    untouched(refl_status::NullPointer, |o| unsafe {
        refl_mirror_camera(o, core::ptr::null(), &hand)
    });
    untouched(refl_status::NullPointer, |o| unsafe {
        refl_mirror_camera(o, &camera(), core::ptr::null())
    });
    let parallel = refl_ray {
        origin: v3(0.0, 5.0, 0.0),
        dir: v3(1.0, 0.0, 0.0),
    };
    untouched(refl_status::DegenerateGeometry, |o| unsafe {
        refl_plane_intersect_ray(o, &hand, parallel)
    });
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_mirror_reflect(o, v3(f32::NAN, 0.0, 0.0), v3(0.0, 1.0, 0.0))
    });
    // Finite inputs whose result overflows.
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_mirror_reflect(o, v3(3e38, 3e38, 0.0), v3(1.0, 1.0, 0.0))
    });
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_mirror_point(o, &hand, v3(0.0, 3e38, 0.0))
    });
}

#[test]
fn mirrored_camera_matches_core_in_place() {
    let plane = floor_plane();
    let core_plane = Plane::try_from(&plane).unwrap();
    let c = camera();
    let expected = refl_core::try_mirrored_camera(&core_camera(&c), &core_plane).unwrap();
    let mut m = c;
    // Output aliases the input camera.
    assert_eq!(
        unsafe { refl_mirror_camera(&mut m, &m, &plane) },
        refl_status::Ok
    );
    assert_eq!(core_camera(&m), expected);
    let mirrored: bool = ok(|o| unsafe { refl_camera_is_mirrored(o, &m) });
    assert!(mirrored);
    // Its eye is the mirrored eye; its primary rays are mirrored rays.
    let eye: refl_vec3 = ok(|o| unsafe { refl_camera_eye(o, &m) });
    let eye0: refl_vec3 = ok(|o| unsafe { refl_camera_eye(o, &c) });
    let me: refl_vec3 = ok(|o| unsafe { refl_mirror_point(o, &plane, eye0) });
    assert!((Vec3::from(eye) - Vec3::from(me)).length() < 1e-5);
    let r0: refl_ray = ok(|o| unsafe { refl_camera_primary_ray(o, &c, v2(100.5, 400.5)) });
    let r1: refl_ray = ok(|o| unsafe { refl_camera_primary_ray(o, &m, v2(100.5, 400.5)) });
    let n = Vec3::Y;
    let d0 = Vec3::from(r0.dir);
    let mirrored_dir = d0 - 2.0 * d0.dot(n) * n;
    assert!((Vec3::from(r1.dir) - mirrored_dir).length() < 1e-5);
}

#[test]
fn plane_round_trip_is_exact() {
    let p: refl_plane =
        ok(|o| unsafe { refl_plane_from_point_normal(o, v3(3.0, -7.0, 2.0), v3(0.3, 0.9, -0.2)) });
    let back = refl_plane::from(&Plane::try_from(&p).unwrap());
    assert_eq!(Vec3::from(back.normal), Vec3::from(p.normal));
    assert_eq!(back.d, p.d);
}

#[test]
fn oblique_projection_matches_core() {
    let plane = floor_plane();
    let c = camera();
    let m: refl_camera = ok(|o| unsafe { refl_mirror_camera(o, &c, &plane) });
    for conv in [
        refl_depth_convention::ZeroToOne,
        refl_depth_convention::ReversedZ,
    ] {
        let got: refl_mat4 =
            ok(|o| unsafe { refl_mirror_oblique_projection(o, &m, &plane, conv as u32) });
        let want = refl_core::try_oblique_projection(
            &core_camera(&m),
            &Plane::try_from(&plane).unwrap(),
            if conv == refl_depth_convention::ReversedZ {
                DepthConvention::ReversedZ
            } else {
                DepthConvention::ZeroToOne
            },
        )
        .unwrap();
        assert_eq!(got.m, want.to_cols_array());
    }
    // The real camera's eye is on the kept side of the floor.
    untouched::<refl_mat4>(refl_status::DegenerateGeometry, |o| unsafe {
        refl_mirror_oblique_projection(o, &c, &plane, refl_depth_convention::ZeroToOne as u32)
    });
    untouched::<refl_mat4>(refl_status::InvalidArgument, |o| unsafe {
        refl_mirror_oblique_projection(o, &m, &plane, refl_depth_convention::Linear as u32)
    });
    untouched::<refl_mat4>(refl_status::NullPointer, |o| unsafe {
        refl_mirror_oblique_projection(
            o,
            &m,
            core::ptr::null(),
            refl_depth_convention::ZeroToOne as u32,
        )
    });
}

#[test]
fn required_len() {
    let n: usize = ok(|o| unsafe { refl_image_required_len(o, 4, 3, 6) });
    assert_eq!(n, 2 * 6 + 4);
    let big: usize = ok(|o| unsafe { refl_image_required_len(o, u32::MAX, u32::MAX, u32::MAX) });
    assert_eq!(
        big as u64,
        (u64::from(u32::MAX) - 1) * u64::from(u32::MAX) + u64::from(u32::MAX)
    );
    for (w, h, s) in [(0, 1, 1), (1, 0, 1), (4, 4, 3), (0, 0, 0)] {
        untouched(refl_status::InvalidArgument, |o| unsafe {
            refl_image_required_len(o, w, h, s)
        });
    }
    untouched(refl_status::NullPointer, |_: *mut usize| unsafe {
        refl_image_required_len(core::ptr::null_mut(), 4, 4, 4)
    });
}

fn img(data: &[f32], w: u32, h: u32, stride: u32) -> refl_image_f32 {
    refl_image_f32 {
        data: data.as_ptr(),
        len: data.len(),
        width: w,
        height: h,
        stride,
    }
}
fn img_mut(data: &mut [f32], w: u32, h: u32, stride: u32) -> refl_image_f32_mut {
    refl_image_f32_mut {
        data: data.as_mut_ptr(),
        len: data.len(),
        width: w,
        height: h,
        stride,
    }
}

#[test]
fn convert_depth_rows_and_padding() {
    let c = camera();
    let core = core_camera(&c);
    let (w, h, ss, ds) = (5u32, 4u32, 7u32, 6u32);
    let src: Vec<f32> = (0..(ss * h)).map(|i| 0.5 + i as f32 * 0.7).collect();
    let mut dst = vec![-1.0f32; (ds * h) as usize];
    let s = unsafe {
        refl_image_convert_depth(
            img_mut(&mut dst, w, h, ds),
            img(&src, w, h, ss),
            &c,
            0,
            2,
            refl_row_range { begin: 1, end: 3 },
        )
    };
    assert_eq!(s, refl_status::Ok);
    for y in 0..h {
        for x in 0..ds {
            let got = dst[(y * ds + x) as usize];
            if (1..3).contains(&y) && x < w {
                let z = src[(y * ss + x) as usize];
                assert_eq!(got, core.encode_depth(z, DepthConvention::ReversedZ));
            } else {
                assert_eq!(
                    got, -1.0,
                    "({x}, {y}) outside the rows or padding was written"
                );
            }
        }
    }
    // Round trip back, in place, whole image.
    let mut round = dst.clone();
    let r = img_mut(&mut round, w, h, ds);
    let s = unsafe {
        refl_image_convert_depth(
            r,
            r.as_const(),
            &c,
            2,
            0,
            refl_row_range { begin: 1, end: 3 },
        )
    };
    assert_eq!(s, refl_status::Ok);
    for y in 1..3 {
        for x in 0..w {
            let z = src[(y * ss + x) as usize];
            let back = round[(y * ds + x) as usize];
            assert!((back - z).abs() <= 1e-3 * z, "{back} vs {z}");
        }
    }
}

/// Calls `f` with a 4x4 destination image filled with -7, expects status
/// `want` and that not one destination texel changed.
fn convert_refused(want: refl_status, f: &dyn Fn(refl_image_f32_mut) -> refl_status) {
    let mut dst = vec![-7.0f32; 64];
    let d = img_mut(&mut dst, 4, 4, 4);
    assert_eq!(f(d), want);
    assert!(dst.iter().all(|v| *v == -7.0));
}

/// A 4x4 source image of ones.
fn ones() -> Vec<f32> {
    vec![1.0f32; 64]
}

#[test]
fn convert_depth_refuses_null_pointers_untouched() {
    let c = camera();
    let src = ones();
    let s44 = img(&src, 4, 4, 4);
    convert_refused(refl_status::NullPointer, &|d| unsafe {
        refl_image_convert_depth(
            d,
            s44,
            core::ptr::null(),
            0,
            1,
            refl_row_range { begin: 0, end: 4 },
        )
    });
    convert_refused(refl_status::NullPointer, &|d| unsafe {
        refl_image_convert_depth(
            d,
            refl_image_f32 {
                data: core::ptr::null(),
                ..s44
            },
            &c,
            0,
            1,
            refl_row_range { begin: 0, end: 4 },
        )
    });
    convert_refused(refl_status::NullPointer, &|d| unsafe {
        refl_image_convert_depth(
            refl_image_f32_mut {
                data: core::ptr::null_mut(),
                ..d
            },
            s44,
            &c,
            0,
            1,
            refl_row_range { begin: 0, end: 4 },
        )
    });
}

#[test]
fn convert_depth_refuses_bad_conventions_and_rows_untouched() {
    let c = camera();
    let src = ones();
    let s44 = img(&src, 4, 4, 4);
    for (from, to, b, e) in [
        (3, 1, 0, 4),
        (0, 9, 0, 4),
        (0, 1, 2, 2),
        (0, 1, 3, 2),
        (0, 1, 0, 5),
    ] {
        convert_refused(refl_status::InvalidArgument, &|d| unsafe {
            refl_image_convert_depth(d, s44, &c, from, to, refl_row_range { begin: b, end: e })
        });
    }
}

#[test]
fn convert_depth_refuses_bad_sizes_and_short_buffers_untouched() {
    let c = camera();
    let src = ones();
    let s44 = img(&src, 4, 4, 4);
    // Size mismatch, zero sizes, stride < width, overflowing sizes.
    for (w, h, st) in [
        (4, 3, 4),
        (0, 4, 4),
        (4, 0, 4),
        (4, 4, 3),
        (u32::MAX, u32::MAX, u32::MAX),
    ] {
        let s = refl_image_f32 {
            width: w,
            height: h,
            stride: st,
            len: usize::MAX,
            ..s44
        };
        convert_refused(refl_status::InvalidArgument, &|d| unsafe {
            refl_image_convert_depth(d, s, &c, 0, 1, refl_row_range { begin: 0, end: 4 })
        });
    }
    // Short buffers.
    convert_refused(refl_status::InsufficientSize, &|d| unsafe {
        refl_image_convert_depth(
            d,
            refl_image_f32 { len: 15, ..s44 },
            &c,
            0,
            1,
            refl_row_range { begin: 0, end: 4 },
        )
    });
    convert_refused(refl_status::InsufficientSize, &|d| unsafe {
        refl_image_convert_depth(
            refl_image_f32_mut { len: 15, ..d },
            s44,
            &c,
            0,
            1,
            refl_row_range { begin: 0, end: 4 },
        )
    });
}

#[test]
fn convert_depth_refuses_misaligned_and_overlapping_images_untouched() {
    let c = camera();
    let src = ones();
    let s44 = img(&src, 4, 4, 4);
    // Misaligned data.
    let bytes = Scratch([0u8; 256]);
    let mis = refl_image_f32 {
        data: unsafe { bytes.0.as_ptr().add(1) }.cast(),
        len: 16,
        ..s44
    };
    convert_refused(refl_status::InvalidArgument, &|d| unsafe {
        refl_image_convert_depth(d, mis, &c, 0, 1, refl_row_range { begin: 0, end: 4 })
    });
    // Partial overlap: src starts one texel into dst.
    let mut dst = vec![-7.0f32; 64];
    let d = img_mut(&mut dst, 4, 4, 4);
    let shifted = refl_image_f32 {
        data: unsafe { d.data.add(1) },
        len: 63,
        width: 4,
        height: 4,
        stride: 4,
    };
    assert_eq!(
        unsafe {
            refl_image_convert_depth(d, shifted, &c, 0, 1, refl_row_range { begin: 0, end: 4 })
        },
        refl_status::InvalidArgument
    );
    // Same pointer, different stride.
    let other = refl_image_f32 {
        data: d.data,
        len: 64,
        width: 4,
        height: 4,
        stride: 5,
    };
    assert_eq!(
        unsafe {
            refl_image_convert_depth(d, other, &c, 0, 1, refl_row_range { begin: 0, end: 4 })
        },
        refl_status::InvalidArgument
    );
    assert!(dst.iter().all(|v| *v == -7.0));
}

#[test]
fn convert_depth_refuses_an_invalid_camera_untouched() {
    let c = camera();
    let src = ones();
    let s44 = img(&src, 4, 4, 4);
    let bad = refl_camera { z_near: 0.0, ..c };
    convert_refused(refl_status::InvalidArgument, &|d| unsafe {
        refl_image_convert_depth(d, s44, &bad, 0, 1, refl_row_range { begin: 0, end: 4 })
    });
}

#[test]
fn image_views_of_every_texel_type() {
    let f = [0.0f32; 12];
    let v2s = [refl_vec2::default(); 12];
    let v3s = [refl_vec3::default(); 12];
    let mut v4s = [refl_vec4::default(); 12];
    let rgba = [refl_rgba8::default(); 12];
    let u = [0u32; 12];
    macro_rules! check {
        ($ty:ident, $buf:expr) => {{
            let ok = $ty {
                data: $buf.as_ptr(),
                len: 12,
                width: 3,
                height: 3,
                stride: 4,
            };
            let v = unsafe { ok.view() }.unwrap();
            assert_eq!((v.width(), v.height(), v.stride()), (3, 3, 4));
            assert_eq!(
                unsafe { $ty { len: 10, ..ok }.view() }.unwrap_err(),
                refl_core::Error::InsufficientSize
            );
            assert_eq!(
                unsafe { $ty { stride: 2, ..ok }.view() }.unwrap_err(),
                refl_core::Error::InvalidArgument
            );
            assert_eq!(
                unsafe { $ty { width: 0, ..ok }.view() }.unwrap_err(),
                refl_core::Error::InvalidArgument
            );
            assert_eq!(
                unsafe {
                    $ty {
                        data: core::ptr::null(),
                        ..ok
                    }
                    .view()
                }
                .unwrap_err(),
                refl_core::Error::NullPointer
            );
            assert_eq!(
                unsafe {
                    $ty {
                        width: u32::MAX,
                        height: u32::MAX,
                        stride: u32::MAX,
                        len: usize::MAX,
                        ..ok
                    }
                    .view()
                }
                .unwrap_err(),
                refl_core::Error::InvalidArgument
            );
        }};
    }
    check!(refl_image_f32, f);
    check!(refl_image_vec2, v2s);
    check!(refl_image_vec3, v3s);
    check!(refl_image_vec4, v4s);
    check!(refl_image_rgba8, rgba);
    check!(refl_image_u32, u);
    let m = refl_image_vec4_mut {
        data: v4s.as_mut_ptr(),
        len: 12,
        width: 3,
        height: 3,
        stride: 4,
    };
    let mut view = unsafe { m.view_mut() }.unwrap();
    *view.get_mut(2, 2).unwrap() = [1.0, 2.0, 3.0, 4.0];
    assert_eq!(
        v4s[10],
        refl_vec4 {
            x: 1.0,
            y: 2.0,
            z: 3.0,
            w: 4.0
        }
    );
}

#[test]
fn misaligned_outputs_are_rejected() {
    let c = camera();
    let mut buf = Scratch([SENTINEL; 256]);
    let p = unsafe { buf.0.as_mut_ptr().add(2) }.cast::<refl_vec3>();
    assert_eq!(
        unsafe { refl_camera_eye(p, &c) },
        refl_status::InvalidArgument
    );
    assert!(buf.0.iter().all(|b| *b == SENTINEL));
}

#[test]
fn linear_depth_matches_core() {
    let c = camera();
    let core = core_camera(&c);
    let p = v3(0.3, -0.2, 1.0);
    let z: f32 = ok(|o| unsafe { refl_camera_linear_depth(o, &c, p) });
    assert_eq!(z, core.linear_depth(p.into()));
    untouched(refl_status::InvalidArgument, |o| unsafe {
        refl_camera_linear_depth(o, &c, v3(0.0, f32::NAN, 0.0))
    });
    untouched(refl_status::NullPointer, |o| unsafe {
        refl_camera_linear_depth(o, core::ptr::null(), p)
    });
}

#[test]
fn row_bands_cover_the_image() {
    for (height, count) in [(1u32, 1u32), (7, 3), (10, 10), (3, 8), (480, 7)] {
        let mut next = 0;
        for index in 0..count {
            let b: refl_row_range = ok(|o| unsafe { refl_image_row_band(o, height, index, count) });
            if b.begin == b.end {
                assert_eq!(b.begin, height);
                continue;
            }
            assert_eq!(b.begin, next);
            assert!(b.end > b.begin && b.end - b.begin <= height.div_ceil(count));
            next = b.end;
        }
        assert_eq!(next, height);
    }
    for (h, i, c) in [(0, 0, 1), (4, 0, 0), (4, 2, 2), (4, u32::MAX, 3)] {
        untouched(refl_status::InvalidArgument, |o| unsafe {
            refl_image_row_band(o, h, i, c)
        });
    }
    untouched(refl_status::NullPointer, |_: *mut refl_row_range| unsafe {
        refl_image_row_band(core::ptr::null_mut(), 4, 0, 1)
    });
}
