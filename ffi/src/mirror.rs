//! Planar reflection exports: reflection vector, planes, mirror matrix,
//! mirrored camera (seed 001 appendix, seed 004 Sec. 4.4.3).

use crate::camera::{finite3, finite_mat};
use crate::ptr::{read, Out};
use crate::status::{fail_str, guard, refl_status};
use crate::types::{convention, refl_camera, refl_mat4, refl_plane, refl_ray, refl_vec3};
use refl_core::glam::Vec3;
use refl_core::{Camera, Error, Plane};

/// Reads and validates a plane pointer.
///
/// # Safety
/// `p` must be NULL or point to a readable `refl_plane`.
unsafe fn plane(p: *const refl_plane, name: &str) -> Result<Plane, Error> {
    // SAFETY: forwarded contract.
    let p = unsafe { read(p, name) }?;
    Plane::try_from(&p).map_err(|e| {
        crate::status::fail(
            e,
            format_args!("`{name}` is not a plane (finite, unit normal)"),
        )
    })
}

/// Reads a camera and a plane, null checks first (both reported as
/// `NullPointer` before either is validated).
///
/// # Safety
/// Each pointer must be NULL or point to a readable value.
unsafe fn camera_and_plane(
    camera: *const refl_camera,
    plane: *const refl_plane,
) -> Result<(Camera, Plane), Error> {
    crate::ptr::no_nulls(&[(camera.is_null(), "camera"), (plane.is_null(), "plane")])?;
    // SAFETY: forwarded contract.
    let cam = crate::types::camera_named(&unsafe { read(camera, "camera") }?, "camera")?;
    // SAFETY: forwarded contract.
    let plane = unsafe { self::plane(plane, "plane") }?;
    Ok((cam, plane))
}

/// A finite result, or `InvalidArgument` (finite inputs overflowed f32).
fn finite_out(v: Vec3) -> Result<refl_vec3, Error> {
    v.is_finite()
        .then(|| v.into())
        .ok_or(Error::InvalidArgument)
}

/// Writes to `*out` the reflection of `v` about the unit normal `n`:
/// `2 dot(v, n) n - v` (seed 004 Sec. 4.4.3). `v` points from the surface
/// toward the viewer; the result points away from the surface on the same
/// side. For an incident direction d (pointing at the surface) pass `-d`.
/// A unit `v` gives a unit result; nothing is normalized here.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_DEGENERATE_GEOMETRY` for a zero normal (no mirror to
/// reflect about); `REFL_STATUS_INVALID_ARGUMENT` if an input or the
/// result is not finite, or `n` is not unit length (`|n|^2` within 2e-3 of
/// 1).
///
/// # Safety
/// `out` must be NULL or point to a writable `refl_vec3`.
#[no_mangle]
pub unsafe extern "C" fn refl_mirror_reflect(
    out: *mut refl_vec3,
    v: refl_vec3,
    n: refl_vec3,
) -> refl_status {
    guard("refl_mirror_reflect", || {
        let out = Out::new(out, "out")?;
        let r = refl_core::try_reflect(v.into(), n.into()).map_err(|e| {
            let why = match e {
                Error::DegenerateGeometry => "`n` is the zero vector",
                _ if !Vec3::from(v).is_finite() => "`v` is not finite",
                _ if !Vec3::from(n).is_finite() => "`n` is not finite",
                _ if !((Vec3::from(n).length_squared() - 1.0).abs() <= 2e-3) => {
                    "`n` is not unit length"
                }
                _ => "the result overflowed",
            };
            fail_str(e, why)
        })?;
        // SAFETY: caller contract.
        unsafe { out.write(r.into()) };
        Ok(())
    })
}

/// Writes to `*out` the plane of triangle `p1 p2 p3` (seed 001 appendix),
/// with unit normal `normalize((p1 - p2) x (p3 - p2))` and
/// `d = -dot(normal, centroid)`. The normal points toward the side from
/// which p1, p2, p3 appear clockwise (the appendix's orientation, opposite
/// to the usual counter-clockwise front face); the mirror matrix does not
/// depend on the orientation.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a non-finite vertex;
/// `REFL_STATUS_DEGENERATE_GEOMETRY` for a zero-area or numerically
/// collinear triangle (sine of the angle at p2 below about 1e-6).
///
/// # Safety
/// `out` must be NULL or point to a writable `refl_plane`.
#[no_mangle]
pub unsafe extern "C" fn refl_plane_from_triangle(
    out: *mut refl_plane,
    p1: refl_vec3,
    p2: refl_vec3,
    p3: refl_vec3,
) -> refl_status {
    guard("refl_plane_from_triangle", || {
        let out = Out::new(out, "out")?;
        let p = Plane::try_from_triangle(p1.into(), p2.into(), p3.into())?;
        // SAFETY: caller contract.
        unsafe { out.write((&p).into()) };
        Ok(())
    })
}

/// Writes to `*out` the plane through `point` with normal direction
/// `normal` (normalized here).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for non-finite input;
/// `REFL_STATUS_DEGENERATE_GEOMETRY` for a zero normal.
///
/// # Safety
/// `out` must be NULL or point to a writable `refl_plane`.
#[no_mangle]
pub unsafe extern "C" fn refl_plane_from_point_normal(
    out: *mut refl_plane,
    point: refl_vec3,
    normal: refl_vec3,
) -> refl_status {
    guard("refl_plane_from_point_normal", || {
        let out = Out::new(out, "out")?;
        let p = Plane::try_from_point_normal(point.into(), normal.into())?;
        // SAFETY: caller contract.
        unsafe { out.write((&p).into()) };
        Ok(())
    })
}

/// Writes to `*out` the signed distance of `point` from `plane` (positive
/// on the normal's side).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `plane` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a non-finite point, plane or result;
/// `REFL_STATUS_DEGENERATE_GEOMETRY` for a zero plane normal.
///
/// # Safety
/// `out` must be NULL or writable; `plane` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_plane_signed_distance(
    out: *mut f32,
    plane: *const refl_plane,
    point: refl_vec3,
) -> refl_status {
    guard("refl_plane_signed_distance", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let plane = unsafe { self::plane(plane, "plane") }?;
        let s = plane.signed_distance(finite3(point)?);
        if !s.is_finite() {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: caller contract.
        unsafe { out.write(s) };
        Ok(())
    })
}

/// Writes to `*out_t` the parameter t at which the ray `ray.origin + t
/// ray.dir` meets `plane` (t may be negative: the plane is behind the
/// origin). With a unit `ray.dir`, t is a distance.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_t` or `plane` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a non-finite ray or plane;
/// `REFL_STATUS_DEGENERATE_GEOMETRY` for a zero plane normal, a ray
/// parallel to the plane or a non-finite t.
///
/// # Safety
/// `out_t` must be NULL or writable; `plane` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_plane_intersect_ray(
    out_t: *mut f32,
    plane: *const refl_plane,
    ray: refl_ray,
) -> refl_status {
    guard("refl_plane_intersect_ray", || {
        let out = Out::new(out_t, "out_t")?;
        // SAFETY: caller contract.
        let plane = unsafe { self::plane(plane, "plane") }?;
        let (o, d) = (finite3(ray.origin)?, finite3(ray.dir)?);
        let t = plane.intersect_ray(o, d).ok_or(Error::DegenerateGeometry)?;
        // SAFETY: caller contract.
        unsafe { out.write(t) };
        Ok(())
    })
}

/// Writes to `*out` the mirror matrix of `plane` (seed 001 appendix, with
/// the normal normalized): it maps a world point to its mirror image, is its
/// own inverse and has determinant -1. Computed in double precision,
/// rounded once.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `plane` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a non-finite plane or result;
/// `REFL_STATUS_DEGENERATE_GEOMETRY` for a zero normal.
///
/// # Safety
/// `out` must be NULL or writable; `plane` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_mirror_matrix(
    out: *mut refl_mat4,
    plane: *const refl_plane,
) -> refl_status {
    guard("refl_mirror_matrix", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let plane = unsafe { self::plane(plane, "plane") }?;
        let m = refl_core::mirror_matrix(&plane);
        if !m.is_finite() {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: caller contract.
        unsafe { out.write(refl_mat4::from(m)) };
        Ok(())
    })
}

/// Writes to `*out` the mirror image of `point` in `plane`:
/// `point - 2 (dot(n, point) + d) n`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `plane` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a non-finite point, plane or result;
/// `REFL_STATUS_DEGENERATE_GEOMETRY` for a zero plane normal.
///
/// # Safety
/// `out` must be NULL or writable; `plane` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_mirror_point(
    out: *mut refl_vec3,
    plane: *const refl_plane,
    point: refl_vec3,
) -> refl_status {
    guard("refl_mirror_point", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let plane = unsafe { self::plane(plane, "plane") }?;
        let r = finite_out(refl_core::mirror_point(&plane, finite3(point)?))?;
        // SAFETY: caller contract.
        unsafe { out.write(r) };
        Ok(())
    })
}

/// Writes to `*out` the mirrored (virtual) camera of `camera` for the
/// planar reflector `plane`: view matrix `V M` with M the mirror matrix,
/// same projection and image size. Its primary ray through pixel p starts
/// at the mirrored eye and, beyond the plane, runs along the reflection of
/// `camera`'s primary ray through p; so rendering through it (restricted to
/// the mirror's pixels, geometry behind the mirror excluded, e.g. rays
/// starting at the plane) gives the exact planar reflection, pixel for
/// pixel. Its view contains a reflection (`refl_camera_is_mirrored`): a
/// rasterizer must flip its front-face test. `out` may equal `camera`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `camera` or `plane` is
/// NULL; the camera's or plane's status if one is invalid; the camera
/// status of the product if it is not a valid camera (e.g. huge
/// coordinates overflowing float).
///
/// # Safety
/// `out` must be NULL or writable; `camera` and `plane` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_mirror_camera(
    out: *mut refl_camera,
    camera: *const refl_camera,
    plane: *const refl_plane,
) -> refl_status {
    guard("refl_mirror_camera", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let (cam, plane) = unsafe { camera_and_plane(camera, plane) }?;
        let m = refl_core::try_mirrored_camera(&cam, &plane)?;
        // SAFETY: caller contract.
        unsafe { out.write(refl_camera::from(&m)) };
        Ok(())
    })
}

/// Writes to `*out` the projection matrix of `camera` for the
/// post-projection convention `convention` with its near plane replaced by
/// the world-space plane `clip` (an oblique near plane, Lengyel 2005): used
/// with a camera from `refl_mirror_camera` and the mirror plane oriented
/// toward the real eye, depth clipping discards everything behind the mirror
/// without a user clip plane. The x, y and w rows are those of
/// `refl_camera_projection_matrix`; stored depth is the near value exactly on
/// `clip` and leaves [0, 1] behind it. Such depth is not decodable with
/// `refl_camera_decode_depth`. Composed in double precision, rounded once.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `camera` or `clip` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an unknown convention or
/// `REFL_DEPTH_CONVENTION_LINEAR`; `REFL_STATUS_DEGENERATE_GEOMETRY` if the
/// eye is not strictly on the negative side of `clip` or the plane keeps
/// nothing of the frustum; the camera's or plane's status if invalid.
///
/// # Safety
/// `out` must be NULL or writable; `camera` and `clip` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_mirror_oblique_projection(
    out: *mut refl_mat4,
    camera: *const refl_camera,
    clip: *const refl_plane,
    convention: u32,
) -> refl_status {
    guard("refl_mirror_oblique_projection", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let (cam, clip) = unsafe { camera_and_plane(camera, clip) }?;
        let m = finite_mat(refl_core::try_oblique_projection(
            &cam,
            &clip,
            self::convention(convention)?,
        )?)?;
        // SAFETY: caller contract.
        unsafe { out.write(m) };
        Ok(())
    })
}
