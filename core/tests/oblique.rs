#![cfg(feature = "mirror")]
//! Oblique near-plane projection against an f64 evaluation of the plane
//! side: depth clipping must do exactly the mirror-plane clipping.

use glam::{DVec4, Vec3};
use refl_core::{
    try_mirrored_camera, try_oblique_projection, Camera, DepthConvention, Error, Plane,
};

fn setup(far: f32) -> (Camera, Plane) {
    let cam = Camera::try_look_at(
        Vec3::new(0.5, 3.0, 6.0),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::Y,
        1.0,
        0.1,
        far,
        320,
        240,
    )
    .unwrap();
    // Floor mirror y = 0.25, oriented toward the real eye (normal +Y).
    let plane = Plane::try_from_point_normal(Vec3::new(0.0, 0.25, 0.0), Vec3::Y).unwrap();
    (try_mirrored_camera(&cam, &plane).unwrap(), plane)
}

/// Stored depth of world point `p` through view + oblique projection, in f64.
fn depth(m: &glam::Mat4, cam: &Camera, p: Vec3) -> (f64, f64) {
    let v = cam.view().as_dmat4() * DVec4::new(p.x as f64, p.y as f64, p.z as f64, 1.0);
    let clip = m.as_dmat4() * v;
    (clip.z / clip.w, clip.w)
}

fn points() -> Vec<Vec3> {
    // A deterministic cloud around the scene, both sides of the mirror.
    let mut s = 0x2545_f491u32;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        s as f32 / u32::MAX as f32
    };
    (0..4000)
        .map(|_| {
            Vec3::new(
                next() * 20.0 - 10.0,
                next() * 8.0 - 4.0,
                next() * -40.0 + 4.0,
            )
        })
        .collect()
}

#[test]
fn depth_clipping_is_mirror_plane_clipping() {
    for far in [60.0f32, f32::INFINITY] {
        let (cam, plane) = setup(far);
        for conv in [DepthConvention::ZeroToOne, DepthConvention::ReversedZ] {
            let m = try_oblique_projection(&cam, &plane, conv).unwrap();
            let std = cam.try_projection(conv).unwrap();
            // x, y and w rows are the standard projection's.
            for (a, b) in [
                (m.row(0), std.row(0)),
                (m.row(1), std.row(1)),
                (m.row(3), std.row(3)),
            ] {
                assert_eq!(a, b, "{conv:?}");
            }
            let (near_v, far_v) = if conv == DepthConvention::ReversedZ {
                (1.0, 0.0)
            } else {
                (0.0, 1.0)
            };
            // The near side of the depth range is the plane test. (The far
            // plane tilts too and may clip far geometry early: Lengyel's
            // known trade-off, not tested here.)
            let past_near = |d: f64| {
                if conv == DepthConvention::ReversedZ {
                    d < 1.0
                } else {
                    d > 0.0
                }
            };
            let (mut kept, mut clipped) = (0, 0);
            for p in points() {
                let (d, w) = depth(&m, &cam, p);
                if w <= 1e-3 {
                    continue; // behind the mirrored eye: clipped by w anyway
                }
                let side = plane.normal().as_dvec3().dot(p.as_dvec3()) + plane.d() as f64;
                // Stored depth on the plane side, with a margin for f32 rounding.
                if side > 1e-3 {
                    assert!(
                        past_near(d),
                        "{conv:?} far={far}: kept point {p} got depth {d}"
                    );
                    kept += 1;
                } else if side < -1e-3 {
                    assert!(
                        !past_near(d),
                        "{conv:?} far={far}: point {p} behind the mirror got depth {d}"
                    );
                    clipped += 1;
                }
            }
            assert!(kept > 200 && clipped > 200, "kept {kept} clipped {clipped}");
            // On the plane: the near value.
            for (x, z) in [(0.0, -1.0), (2.0, -3.0), (-1.5, 0.5)] {
                let (d, _) = depth(&m, &cam, Vec3::new(x, 0.25, z));
                assert!((d - near_v).abs() < 1e-5, "{conv:?}: plane point depth {d}");
            }
            // The far corner opposite the plane: the far value (finite far).
            if far.is_finite() {
                let cv = cam.inverse_view().as_dmat4().transpose()
                    * DVec4::new(0.0, plane.normal().y as f64, 0.0, plane.d() as f64);
                let ty = (cam.fov_y() as f64 * 0.5).tan();
                let tx = ty * cam.width() as f64 / cam.height() as f64;
                let q = DVec4::new(
                    cv.x.signum() * tx * far as f64,
                    cv.y.signum() * ty * far as f64,
                    -(far as f64),
                    1.0,
                );
                let clip = m.as_dmat4() * q;
                assert!(
                    (clip.z / clip.w - far_v).abs() < 1e-4,
                    "{conv:?}: far corner {}",
                    clip.z / clip.w
                );
            }
        }
    }
}

#[test]
fn oblique_projection_refuses_what_it_cannot_do() {
    let (cam, plane) = setup(100.0);
    assert_eq!(
        try_oblique_projection(&cam, &plane, DepthConvention::Linear),
        Err(Error::InvalidArgument)
    );
    // The eye on the kept side: wrong orientation.
    assert_eq!(
        try_oblique_projection(&cam, &plane.flipped(), DepthConvention::ZeroToOne),
        Err(Error::DegenerateGeometry)
    );
    // Through the eye.
    let through = Plane::try_from_point_normal(cam.eye(), Vec3::Y).unwrap();
    assert_eq!(
        try_oblique_projection(&cam, &through, DepthConvention::ReversedZ),
        Err(Error::DegenerateGeometry)
    );
}
