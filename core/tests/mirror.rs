#![cfg(feature = "mirror")]
//! Reflection vector, planes, mirror matrix and mirrored camera against f64
//! oracles, including stiff and degenerate cases.

use glam::{DVec3, Vec2, Vec3};
use refl_core::{mirror_matrix, mirror_point, reflect, try_mirrored_camera, Camera, Error, Plane};

fn reflect64(v: DVec3, n: DVec3) -> DVec3 {
    2.0 * v.dot(n) * n - v
}

#[test]
fn reflect_matches_closed_form() {
    let n = Vec3::new(0.2, 1.0, -0.1).normalize();
    for v in [
        Vec3::new(0.3, 0.8, 0.1),
        Vec3::new(-1.0, 1e-4, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ] {
        let v = v.normalize();
        let r = reflect(v, n);
        let o = reflect64(v.as_dvec3(), n.as_dvec3());
        assert!(r.as_dvec3().distance(o) < 1e-6);
        assert!((r.length() - 1.0).abs() < 1e-6);
        // Equal angles on both sides of the normal; normal incidence returns v.
        assert!((r.dot(n) - v.dot(n)).abs() < 1e-6);
    }
    assert!(reflect(n, n).distance(n) < 1e-6);
}

#[test]
fn grazing_reflection_stays_on_the_front_side() {
    // v nearly in the plane: the reflection must not dip below it by more
    // than rounding.
    let n = Vec3::Y;
    for e in [1e-3f32, 1e-5, 1e-7] {
        let v = Vec3::new(1.0, e, 0.0).normalize();
        let r = reflect(v, n);
        assert!(r.y >= 0.0 && (r.y - v.y).abs() <= 2.0 * f32::EPSILON);
        assert!((r.x + v.x).abs() <= 2.0 * f32::EPSILON);
    }
}

#[test]
fn plane_from_triangle_is_unit_and_contains_vertices() {
    for s in [1e-3f32, 1.0, 1e4] {
        let (a, b, c) = (
            Vec3::new(1.0, 0.5, 0.2) * s,
            Vec3::new(2.0, 0.7, -0.3) * s,
            Vec3::new(0.4, 1.6, 0.1) * s,
        );
        let p = Plane::try_from_triangle(a, b, c).unwrap();
        assert!((p.normal().length() - 1.0).abs() < 1e-6);
        for v in [a, b, c] {
            assert!(
                p.signed_distance(v).abs() <= 4.0 * f32::EPSILON * s * 3.0,
                "scale {s}"
            );
        }
        // Orientation as printed in seed 001: (P1 - P2) x (P3 - P2).
        let n64 = (a - b).as_dvec3().cross((c - b).as_dvec3()).normalize();
        assert!(p.normal().as_dvec3().dot(n64) > 1.0 - 1e-6);
    }
}

#[test]
fn degenerate_triangles_are_rejected() {
    let a = Vec3::new(1.0, 2.0, 3.0);
    let d = Vec3::new(0.3, -0.1, 0.7);
    assert_eq!(
        Plane::try_from_triangle(a, a, a),
        Err(Error::DegenerateGeometry)
    );
    assert_eq!(
        Plane::try_from_triangle(a, a, a + d),
        Err(Error::DegenerateGeometry)
    );
    assert_eq!(
        Plane::try_from_triangle(a, a + d, a + 2.0 * d),
        Err(Error::DegenerateGeometry)
    );
    // A sliver whose angle is below f32 resolution.
    assert_eq!(
        Plane::try_from_triangle(a, a + d, a + 2.0 * d + Vec3::new(0.0, 1e-9, 0.0)),
        Err(Error::DegenerateGeometry)
    );
    assert_eq!(
        Plane::try_from_triangle(Vec3::NAN, a, a + d),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        Plane::try_from_triangle(Vec3::INFINITY, a, a + d),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        Plane::try_from_point_normal(a, Vec3::ZERO),
        Err(Error::DegenerateGeometry)
    );
    assert_eq!(
        Plane::try_from_point_normal(a, Vec3::new(f32::NAN, 1.0, 0.0)),
        Err(Error::InvalidArgument)
    );
    // Tiny but well-shaped triangles are fine.
    for s in [1e-20f32, 1e30] {
        let p = Plane::try_from_triangle(Vec3::ZERO, Vec3::X * s, Vec3::Y * s).unwrap();
        assert_eq!(p.normal(), -Vec3::Z, "scale {s}");
    }
}

#[test]
fn mirror_matrix_matches_closed_form_and_is_an_involution() {
    let plane =
        Plane::try_from_point_normal(Vec3::new(0.3, -1.0, 2.0), Vec3::new(0.1, 1.0, 0.3)).unwrap();
    let m = mirror_matrix(&plane);
    assert!((m.determinant() + 1.0).abs() < 1e-5);
    let mm = (m * m).to_cols_array();
    let id = glam::Mat4::IDENTITY.to_cols_array();
    assert!(mm.iter().zip(id).all(|(a, b)| (a - b).abs() < 1e-5));
    let n = plane.normal().as_dvec3();
    let d = plane.d() as f64;
    for p in [
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(-4.0, -1.0, 0.5),
        Vec3::ZERO,
    ] {
        let oracle = p.as_dvec3() - 2.0 * (n.dot(p.as_dvec3()) + d) * n;
        assert!(m.transform_point3(p).as_dvec3().distance(oracle) < 1e-5);
        assert!(mirror_point(&plane, p).as_dvec3().distance(oracle) < 1e-5);
        // Mirror image is equidistant on the other side.
        assert!(
            (plane.signed_distance(mirror_point(&plane, p)) + plane.signed_distance(p)).abs()
                < 1e-5
        );
    }
    // Orientation does not change the matrix.
    let mf = mirror_matrix(&plane.flipped()).to_cols_array();
    assert!(m
        .to_cols_array()
        .iter()
        .zip(mf)
        .all(|(a, b)| (a - b).abs() < 1e-6));
}

fn camera() -> Camera {
    Camera::try_look_at(
        Vec3::new(0.5, 3.0, 6.0),
        Vec3::new(0.0, -0.5, 0.0),
        Vec3::Y,
        1.0,
        0.1,
        200.0,
        320,
        240,
    )
    .unwrap()
}

/// The mirrored camera's rays are the reflected rays, pixel for pixel,
/// checked against an f64 reflection at the mirror hit point.
fn check_mirrored_rays(plane: Plane, cam: &Camera) {
    let m = try_mirrored_camera(cam, &plane).unwrap();
    assert!(m.is_mirrored() && !cam.is_mirrored());
    let n = plane.normal().as_dvec3();
    let mut checked = 0;
    for y in (0..cam.height()).step_by(7) {
        for x in (0..cam.width()).step_by(5) {
            let px = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let r = cam.primary_ray(px);
            let (o, dir) = (r.origin.as_dvec3(), r.dir.as_dvec3());
            let t = -(n.dot(o) + plane.d() as f64) / n.dot(dir);
            if !(t > 0.0) {
                continue;
            }
            let hit = o + dir * t;
            let want = reflect64(-dir, n);
            let mr = m.primary_ray(px);
            assert!(mr.dir.as_dvec3().distance(want) < 2e-6, "dir at {px}");
            // The mirrored ray passes through the mirror hit point.
            let to_hit = hit - mr.origin.as_dvec3();
            let miss = to_hit.cross(mr.dir.as_dvec3()).length();
            assert!(miss < 1e-5 * (1.0 + to_hit.length()), "miss {miss} at {px}");
            checked += 1;
        }
    }
    assert!(checked > 100);
}

#[test]
fn mirrored_camera_rays_are_reflected_rays() {
    check_mirrored_rays(
        Plane::try_from_point_normal(Vec3::ZERO, Vec3::Y).unwrap(),
        &camera(),
    );
    let tilted = Plane::try_from_triangle(
        Vec3::new(-1.0, -0.2, 0.0),
        Vec3::new(1.0, 0.1, 0.5),
        Vec3::new(0.0, 0.0, -2.0),
    )
    .unwrap();
    check_mirrored_rays(tilted, &camera());
}

#[test]
fn grazing_view_of_the_mirror() {
    // Eye 1e-3 above a floor mirror looking along it.
    let cam = Camera::try_look_at(
        Vec3::new(0.0, 1e-3, 5.0),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::Y,
        1.0,
        1e-4,
        100.0,
        160,
        120,
    )
    .unwrap();
    check_mirrored_rays(
        Plane::try_from_point_normal(Vec3::ZERO, Vec3::Y).unwrap(),
        &cam,
    );
}

#[test]
fn mirroring_twice_restores_the_camera() {
    let plane =
        Plane::try_from_point_normal(Vec3::new(0.0, -0.5, 0.0), Vec3::new(0.2, 1.0, 0.1)).unwrap();
    let cam = camera();
    let twice = try_mirrored_camera(&try_mirrored_camera(&cam, &plane).unwrap(), &plane).unwrap();
    let (a, b) = (cam.view().to_cols_array(), twice.view().to_cols_array());
    assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-5));
    assert!(!twice.is_mirrored());
    assert!(
        try_mirrored_camera(&cam, &plane)
            .unwrap()
            .eye()
            .distance(mirror_point(&plane, cam.eye()))
            < 1e-5
    );
}

#[test]
fn ray_plane_intersection() {
    let p = Plane::try_from_point_normal(Vec3::new(0.0, 1.0, 0.0), Vec3::Y).unwrap();
    assert_eq!(
        p.intersect_ray(Vec3::new(0.0, 3.0, 0.0), -Vec3::Y),
        Some(2.0)
    );
    assert_eq!(p.intersect_ray(Vec3::new(0.0, 3.0, 0.0), Vec3::X), None);
    assert_eq!(
        p.intersect_ray(Vec3::new(0.0, 3.0, 0.0), Vec3::Y),
        Some(-2.0)
    );
}

#[test]
fn plane_from_coefficients() {
    let p = Plane::try_new(Vec3::Y, -1.25).unwrap();
    assert_eq!((p.normal(), p.d()), (Vec3::Y, -1.25));
    let q = Plane::try_new(Vec3::new(0.0, 2.0, 0.0), -2.5).unwrap();
    assert_eq!((q.normal(), q.d()), (Vec3::Y, -1.25));
    assert_eq!(
        Plane::try_new(Vec3::ZERO, 1.0),
        Err(Error::DegenerateGeometry)
    );
    assert_eq!(
        Plane::try_new(Vec3::Y, f32::NAN),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        Plane::try_new(Vec3::new(f32::INFINITY, 0.0, 0.0), 0.0),
        Err(Error::InvalidArgument)
    );
}

/// Fuzz findings F2 and F4: finite non-zero normals whose squared length
/// under- or overflows f32 normalize (in f64); a plane whose `d` would
/// overflow f32 is refused instead of carrying `d = inf`.
#[test]
fn planes_at_extreme_scales() {
    for s in [1e-30f32, 1e-20, 1e20, 1e30] {
        let p = Plane::try_new(Vec3::new(0.0, s, 0.0), 2.0 * s).unwrap();
        assert_eq!(p.normal(), Vec3::Y);
        assert!((p.d() - 2.0).abs() < 1e-6);
        let q =
            Plane::try_from_point_normal(Vec3::new(1.0, 3.0, 0.0), Vec3::new(0.0, s, 0.0)).unwrap();
        assert_eq!(q.normal(), Vec3::Y);
        assert_eq!(q.d(), -3.0);
    }
    assert_eq!(
        Plane::try_new(Vec3::ZERO, 1.0),
        Err(Error::DegenerateGeometry)
    );
    let huge = Vec3::splat(f32::MAX * 0.9);
    assert_eq!(
        Plane::try_from_point_normal(huge, Vec3::ONE),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        Plane::try_from_triangle(
            huge + Vec3::new(1e37, 0.0, 0.0),
            huge + Vec3::new(0.0, 1e37, 0.0),
            huge + Vec3::new(0.0, 0.0, 1e37)
        ),
        Err(Error::InvalidArgument)
    );
}
