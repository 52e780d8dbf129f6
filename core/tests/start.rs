//! The ray start rule `trace::ray_start_t` against an f64 oracle that finds
//! the same parameter by bisection on the projected distance (no closed
//! form), and against `Camera::project`; `trace::RayStart`, the constants
//! a pass prepares once, gives the same starts.
#![cfg(any(feature = "depth-image", feature = "hiz"))]

use glam::{DVec3, Vec3};
use proptest::prelude::*;

mod common;
use refl_core::trace::{ray_start_t, RayStart};
use refl_core::{Camera, Ray};

/// f64 pixel position of a world point (the camera's formula, in f64), or
/// `None` behind the eye.
fn project64(cam: &Camera, p: DVec3) -> Option<(f64, f64)> {
    let v = cam.view().as_dmat4().transform_point3(p);
    let z = -v.z;
    if !(z > 0.0) {
        return None;
    }
    let (w, h) = (f64::from(cam.width()), f64::from(cam.height()));
    let ty = (f64::from(cam.fov_y()) * 0.5).tan();
    let tx = ty * w / h;
    Some((
        (v.x / (z * tx) + 1.0) * 0.5 * w,
        (1.0 - v.y / (z * ty)) * 0.5 * h,
    ))
}

/// Oracle: the smallest `t` whose projection lies `n` pixels from the
/// origin's, by doubling then bisection; `None` if none up to the eye plane
/// or `t = 1e12`.
fn oracle(cam: &Camera, o: DVec3, d: DVec3, n: f64) -> Option<f64> {
    let p0 = project64(cam, o)?;
    let dist = |t: f64| project64(cam, o + d * t).map(|p| (p.0 - p0.0).hypot(p.1 - p0.1));
    // Distance is increasing along the ray while in front of the eye; past
    // the eye plane (None) count it as "beyond".
    let beyond = |t: f64| dist(t).is_none_or(|x| x >= n);
    let mut hi = 1e-9;
    while !beyond(hi) {
        hi *= 2.0;
        if hi > 1e12 {
            return None;
        }
    }
    let mut lo = 0.0;
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if beyond(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    // A crossing of the eye plane is not a solution.
    dist(hi).map(|_| hi)
}

fn cam(eye: Vec3, target: Vec3, fov: f32, w: u32, h: u32) -> Camera {
    Camera::try_look_at(eye, target, Vec3::Y, fov, 0.05, 500.0, w, h).unwrap()
}

#[test]
fn receding_along_the_line_of_sight_never_moves() {
    let c = cam(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 1.0, 64, 48);
    let ray = Ray {
        origin: Vec3::ZERO,
        dir: Vec3::new(0.0, 0.0, -1.0),
    };
    assert_eq!(ray_start_t(&c, &ray, 1.0), None);
    // Slightly off the line of sight: the vanishing point is within a
    // pixel of the origin's projection until the offset grows.
    let ray = Ray {
        origin: Vec3::ZERO,
        dir: Vec3::new(1e-4, 0.0, -1.0).normalize(),
    };
    assert_eq!(ray_start_t(&c, &ray, 1.0), None);
    assert!(oracle(&c, DVec3::ZERO, ray.dir.as_dvec3(), 1.0).is_none());
}

#[test]
fn behind_the_eye_and_bad_input_are_none_and_zero_pixels_is_zero() {
    let c = cam(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 1.0, 64, 48);
    let behind = Ray {
        origin: Vec3::new(0.0, 0.0, 6.0),
        dir: Vec3::X,
    };
    assert_eq!(ray_start_t(&c, &behind, 1.0), None);
    let r = Ray {
        origin: Vec3::ZERO,
        dir: Vec3::X,
    };
    assert_eq!(ray_start_t(&c, &r, 0.0), Some(0.0));
    for bad in [-1.0, f32::NAN, f32::INFINITY] {
        assert_eq!(ray_start_t(&c, &r, bad), None, "{bad}");
    }
    let nan = Ray {
        origin: Vec3::new(f32::NAN, 0.0, 0.0),
        dir: Vec3::X,
    };
    assert_eq!(ray_start_t(&c, &nan, 1.0), None);
}

#[test]
fn toward_the_camera_always_moves_before_the_eye_plane() {
    let c = cam(Vec3::new(0.0, 1.0, 5.0), Vec3::ZERO, 1.0, 64, 48);
    let o = Vec3::new(0.3, 0.0, -2.0);
    let dir = (Vec3::new(0.0, 1.0, 5.0) - o).normalize();
    // Straight at the eye: the projection stays put until just before the
    // eye plane (in f32 the direction misses the eye by a rounding), so the
    // start, if any, is at the eye's distance.
    let dist = (Vec3::new(0.0, 1.0, 5.0) - o).length();
    if let Some(t) = ray_start_t(&c, &Ray { origin: o, dir }, 1.0) {
        assert!(
            t <= dist * 1.0001 && t > 0.99 * dist,
            "{t} vs eye at {dist}"
        );
    }
    let dir = (dir + Vec3::new(0.05, 0.0, 0.0)).normalize();
    let t = ray_start_t(&c, &Ray { origin: o, dir }, 1.0).unwrap();
    let want = oracle(&c, o.as_dvec3(), dir.as_dvec3(), 1.0).unwrap();
    assert!((f64::from(t) - want).abs() <= 1e-4 * want, "{t} vs {want}");
}

/// Grazing views over a floor at every scale: `t` scales with the scene
/// and matches the oracle; the start moves the projection one pixel.
#[test]
fn grazing_floor_rays_at_huge_and_tiny_scales() {
    for scale in [1e-4f32, 1e-2, 1.0, 1e2, 1e4] {
        for height in [0.01f32, 0.1, 1.0] {
            let c = cam(
                Vec3::new(0.0, height, 5.0) * scale,
                Vec3::new(0.0, 0.0, -5.0) * scale,
                1.0,
                256,
                192,
            );
            let c = Camera::try_new(c.view(), c.fov_y(), 0.05 * scale, 500.0 * scale, 256, 192)
                .unwrap();
            let o = Vec3::new(0.2, 0.0, 1.0) * scale;
            let view = (o - Vec3::new(0.0, height, 5.0) * scale).normalize();
            let dir = Vec3::new(view.x, -view.y, view.z);
            let t = ray_start_t(&c, &Ray { origin: o, dir }, 1.0);
            let want = oracle(&c, o.as_dvec3(), dir.as_dvec3(), 1.0);
            match (t, want) {
                (Some(t), Some(w)) => {
                    assert!(
                        (f64::from(t) - w).abs() <= 1e-4 * w,
                        "scale {scale} height {height}: {t} vs {w}"
                    );
                    let p0 = c.project(o).unwrap();
                    let p1 = c.project(o + dir * t).unwrap();
                    let moved = (p1.x - p0.x).hypot(p1.y - p0.y);
                    assert!((moved - 1.0).abs() < 2e-2, "scale {scale}: moved {moved}");
                }
                (None, None) => {}
                other => panic!("scale {scale} height {height}: {other:?}"),
            }
        }
    }
}

proptest! {
    #![proptest_config(common::proptest_config(256))]

    /// Random cameras and rays: the closed form equals the bisection oracle
    /// (or both find none).
    #[test]
    fn prop_start_matches_the_bisection_oracle(
        ex in -10.0f32..10.0, ey in 0.1f32..10.0, ez in -10.0f32..10.0,
        tx in -2.0f32..2.0, tz in -2.0f32..2.0,
        ox in -3.0f32..3.0, oy in -0.5f32..2.0, oz in -3.0f32..3.0,
        dx in -1.0f32..1.0, dy in -1.0f32..1.0, dz in -1.0f32..1.0,
        fov in 0.2f32..2.5, n in prop_oneof![Just(1.0f32), 0.25f32..4.0],
    ) {
        let eye = Vec3::new(ex, ey, ez);
        let target = Vec3::new(tx, 0.0, tz);
        prop_assume!((eye - target).length() > 0.5);
        let c = cam(eye, target, fov, 160, 90);
        let d = Vec3::new(dx, dy, dz);
        prop_assume!(d.length() > 0.1);
        let r = Ray { origin: Vec3::new(ox, oy, oz), dir: d.normalize() };
        let got = ray_start_t(&c, &r, n);
        // The prepared constants a pass keeps give the same start, also
        // when reused for another ray.
        let start = RayStart::new(&c);
        let back = Ray { origin: r.origin + r.dir, dir: -r.dir };
        prop_assert_eq!(start.t(&back, n).map(f32::to_bits), ray_start_t(&c, &back, n).map(f32::to_bits));
        prop_assert_eq!(start.t(&r, n).map(f32::to_bits), got.map(f32::to_bits));
        let want = oracle(&c, r.origin.as_dvec3(), r.dir.as_dvec3(), f64::from(n));
        match (got, want) {
            (Some(t), Some(w)) => prop_assert!((f64::from(t) - w).abs() <= 1e-4 * w.max(1e-3), "{t} vs {w}"),
            (None, None) => {}
            // Near the limit (the vanishing point ~n pixels away) the
            // oracle's search may stop at 1e12 or cross the eye plane.
            (Some(t), None) => prop_assert!(t > 1e6, "start {t}, oracle none"),
            (None, Some(w)) => prop_assert!(w > 1e6, "none, oracle {w}"),
        }
    }
}
