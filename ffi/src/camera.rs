//! Camera exports: construction, validation, rays, projection, depth
//! encoding and reprojection.
//!
//! Every function validates its camera(s) on every call (see
//! `refl_camera_validate`), checks pointers before anything else and writes
//! its output only when it returns `REFL_STATUS_OK`.

use crate::ptr::{read, Out};
use crate::status::{guard, refl_status};
use crate::types::{
    convention, refl_camera, refl_mat4, refl_projection, refl_ray, refl_vec2, refl_vec3,
};
use refl_core::camera::{apply_reprojection, try_reprojection_matrix};
use refl_core::glam::{Mat4, Vec2, Vec3};
use refl_core::{Camera, Error};

/// Reads and validates a camera pointer.
///
/// # Safety
/// `p` must be NULL or point to a readable `refl_camera`.
unsafe fn camera(p: *const refl_camera, name: &str) -> Result<Camera, Error> {
    // SAFETY: forwarded contract.
    let c = unsafe { read(p, name) }?;
    crate::types::camera_named(&c, name)
}

/// A finite pixel position, or `InvalidArgument`.
fn pixel(p: refl_vec2) -> Result<Vec2, Error> {
    let v = Vec2::from(p);
    v.is_finite().then_some(v).ok_or(Error::InvalidArgument)
}

/// A finite point or vector, or `InvalidArgument`.
pub(crate) fn finite3(p: refl_vec3) -> Result<Vec3, Error> {
    let v = Vec3::from(p);
    v.is_finite().then_some(v).ok_or(Error::InvalidArgument)
}

/// A finite matrix, or `DegenerateGeometry` (the result of composing valid
/// inputs overflowed or was singular).
pub(crate) fn finite_mat(m: Mat4) -> Result<refl_mat4, Error> {
    m.is_finite()
        .then(|| m.into())
        .ok_or(Error::DegenerateGeometry)
}

/// Builds in `*out` a camera at `eye` looking at `target`, with `up` as the
/// approximate up direction (right-handed look-at, view down -Z), a
/// vertical field of view `fov_y` in radians, near and far plane distances
/// and an image size in pixels. The view matrix is built in double
/// precision and rounded once.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a non-finite `eye`, `target` or `up`,
/// a zero `width` or `height`, `fov_y` outside (0, pi), `z_near` not finite
/// and positive, or `z_far <= z_near` (`z_far` may be +infinity);
/// `REFL_STATUS_DEGENERATE_GEOMETRY` if `eye == target` or `up` is
/// parallel to the view direction.
///
/// # Safety
/// `out` must be NULL or point to a writable `refl_camera`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_camera_look_at(
    out: *mut refl_camera,
    eye: refl_vec3,
    target: refl_vec3,
    up: refl_vec3,
    fov_y: f32,
    z_near: f32,
    z_far: f32,
    width: u32,
    height: u32,
) -> refl_status {
    guard("refl_camera_look_at", || {
        let out = Out::new(out, "out")?;
        let cam = Camera::try_look_at(
            eye.into(),
            target.into(),
            up.into(),
            fov_y,
            z_near,
            z_far,
            width,
            height,
        )?;
        // SAFETY: caller contract.
        unsafe { out.write((&cam).into()) };
        Ok(())
    })
}

/// Checks a camera filled in by hand. Returns `REFL_STATUS_OK` if every
/// other function will accept it.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `camera` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a zero size, `fov_y` outside (0, pi),
/// `z_near` not finite and positive (or so small that `1 / z_near`
/// overflows), `z_far <= z_near`, a non-finite
/// view matrix, or (checked last) a camera whose projection scales
/// (`tan(fov_y / 2)`, times the aspect, and their reciprocals) or whose eye
/// overflow f32 (a subnormal `fov_y`, a translation near `FLT_MAX`);
/// `REFL_STATUS_DEGENERATE_GEOMETRY` if the view's 3x3 part is
/// not orthonormal within 1e-4 or its last row is not (0, 0, 0, 1).
///
/// # Safety
/// `camera` must be NULL or point to a readable `refl_camera`.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_validate(camera: *const refl_camera) -> refl_status {
    guard("refl_camera_validate", || {
        // SAFETY: caller contract.
        unsafe { self::camera(camera, "camera") }.map(|_| ())
    })
}

/// Writes to `*out` the primary ray of `camera` through `pixel` (in pixels;
/// `(x + 0.5, y + 0.5)` is the center of pixel (x, y)): it starts at the eye
/// and has a unit direction.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `camera` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` if `pixel` is not finite or so far
/// outside the image that the direction overflows; the camera's status if
/// it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_primary_ray(
    out: *mut refl_ray,
    camera: *const refl_camera,
    pixel: refl_vec2,
) -> refl_status {
    guard("refl_camera_primary_ray", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        let ray = cam.primary_ray(self::pixel(pixel)?);
        if !(ray.dir.is_finite() && ray.dir != Vec3::ZERO && ray.origin.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: caller contract.
        unsafe { out.write(ray.into()) };
        Ok(())
    })
}

/// Projects the world point `point` through `camera`: writes to `*out` its
/// pixel position and linear depth, with `valid = true`; for a point at or
/// behind the eye plane (or a non-finite result) writes `valid = false` and
/// zeros. Points outside the image or the near/far range are still
/// projected.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `camera` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` if `point` is not finite; the camera's
/// status if it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_project(
    out: *mut refl_projection,
    camera: *const refl_camera,
    point: refl_vec3,
) -> refl_status {
    guard("refl_camera_project", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        let p = cam.project(finite3(point)?);
        // SAFETY: caller contract.
        unsafe { out.write(refl_projection::from_option(p)) };
        Ok(())
    })
}

/// Writes to `*out` the linear depth of the world point `point`: its
/// distance in front of the eye along the view axis (negative behind the
/// eye). Encode it with `refl_camera_encode_depth` for a depth buffer.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `camera` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` if `point` or the result is not finite;
/// the camera's status if it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_linear_depth(
    out: *mut f32,
    camera: *const refl_camera,
    point: refl_vec3,
) -> refl_status {
    guard("refl_camera_linear_depth", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        let z = cam.linear_depth(finite3(point)?);
        if !z.is_finite() {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: caller contract.
        unsafe { out.write(z) };
        Ok(())
    })
}

/// Writes to `*out` the world point seen through `pixel` at stored depth
/// `depth` of convention `convention` (a `refl_depth_convention`).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `camera` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an unknown convention, a non-finite
/// `pixel` or `depth`, or a depth that decodes to a non-finite point (the
/// far plane at infinity); the camera's status if it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_unproject(
    out: *mut refl_vec3,
    camera: *const refl_camera,
    pixel: refl_vec2,
    depth: f32,
    convention: u32,
) -> refl_status {
    guard("refl_camera_unproject", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        let c = self::convention(convention)?;
        let px = self::pixel(pixel)?;
        if !depth.is_finite() {
            return Err(Error::InvalidArgument);
        }
        let p = cam.unproject(px, depth, c);
        if !p.is_finite() {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: caller contract.
        unsafe { out.write(p.into()) };
        Ok(())
    })
}

/// Encodes the linear depth `linear_depth` in convention `convention`
/// (a `refl_depth_convention`) with the camera's near and far planes, and
/// writes it to `*out`. Depths outside [near, far] extrapolate the same
/// formula; `linear_depth = +infinity` is accepted when the result is
/// defined (an infinite far plane).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `camera` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an unknown convention, a NaN input or
/// a NaN result; the camera's status if it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_encode_depth(
    out: *mut f32,
    camera: *const refl_camera,
    linear_depth: f32,
    convention: u32,
) -> refl_status {
    guard("refl_camera_encode_depth", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        let c = self::convention(convention)?;
        let d = cam.encode_depth(linear_depth, c);
        if linear_depth.is_nan() || d.is_nan() {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: caller contract.
        unsafe { out.write(d) };
        Ok(())
    })
}

/// Decodes the stored depth `depth` of convention `convention` (a
/// `refl_depth_convention`) to linear depth and writes it to `*out`. The
/// far plane of an infinite-far camera decodes to +infinity.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `camera` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an unknown convention, a NaN input or
/// a NaN result; the camera's status if it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_decode_depth(
    out: *mut f32,
    camera: *const refl_camera,
    depth: f32,
    convention: u32,
) -> refl_status {
    guard("refl_camera_decode_depth", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        let c = self::convention(convention)?;
        let z = cam.decode_depth(depth, c);
        if depth.is_nan() || z.is_nan() {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: caller contract.
        unsafe { out.write(z) };
        Ok(())
    })
}

/// Writes to `*out` the projection matrix (view space to clip space) of
/// `camera` for the post-projection convention `convention`: `clip.w =
/// -z_view` and `clip.z / clip.w` is the stored depth. Composed in double
/// precision, rounded once.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `camera` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an unknown convention or
/// `REFL_DEPTH_CONVENTION_LINEAR` (linear depth is not projective); the
/// camera's status if it is invalid; `REFL_STATUS_DEGENERATE_GEOMETRY` if
/// an entry of the matrix is not representable in f32 (for the
/// world-to-pixel matrix: the focal length in pixels times the view's
/// translation beyond `FLT_MAX`, e.g. a translation near 1e30 with a
/// 2^16-pixel image).
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_projection_matrix(
    out: *mut refl_mat4,
    camera: *const refl_camera,
    convention: u32,
) -> refl_status {
    guard("refl_camera_projection_matrix", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        let m = finite_mat(cam.try_projection(self::convention(convention)?)?)?;
        // SAFETY: caller contract.
        unsafe { out.write(m) };
        Ok(())
    })
}

/// Writes to `*out` the matrix from world space to homogeneous pixel space:
/// for a world point p, `M (p, 1) = (px w, py w, d w, w)` with (px, py) its
/// pixel position and d its stored depth in `convention`.
///
/// Returns as `refl_camera_projection_matrix`.
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_world_to_pixel_matrix(
    out: *mut refl_mat4,
    camera: *const refl_camera,
    convention: u32,
) -> refl_status {
    guard("refl_camera_world_to_pixel_matrix", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        let m = finite_mat(cam.try_world_to_pixel(self::convention(convention)?)?)?;
        // SAFETY: caller contract.
        unsafe { out.write(m) };
        Ok(())
    })
}

/// Writes to `*out` the camera's view-to-world matrix (the inverse of its
/// view matrix, computed in double precision).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `camera` is NULL; the
/// camera's status if it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_inverse_view(
    out: *mut refl_mat4,
    camera: *const refl_camera,
) -> refl_status {
    guard("refl_camera_inverse_view", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        // SAFETY: caller contract.
        unsafe { out.write(cam.inverse_view().into()) };
        Ok(())
    })
}

/// Writes to `*out` the camera's eye (center of projection), world space.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `camera` is NULL; the
/// camera's status if it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_eye(
    out: *mut refl_vec3,
    camera: *const refl_camera,
) -> refl_status {
    guard("refl_camera_eye", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        // SAFETY: caller contract.
        unsafe { out.write(cam.eye().into()) };
        Ok(())
    })
}

/// Writes to `*out` whether the camera's view transform contains a
/// reflection (negative determinant), as a mirrored camera's does: a
/// rasterizer must then flip its front-face test.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `camera` is NULL; the
/// camera's status if it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `camera` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_is_mirrored(
    out: *mut bool,
    camera: *const refl_camera,
) -> refl_status {
    guard("refl_camera_is_mirrored", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let cam = unsafe { self::camera(camera, "camera") }?;
        // SAFETY: caller contract.
        unsafe { out.write(cam.is_mirrored()) };
        Ok(())
    })
}

/// Writes to `*out` the reprojection matrix from camera `from` to camera
/// `to` for the post-projection convention `convention` (seed 004 Sec.
/// 4.6.4): for a pixel position (px, py) of `from` with stored depth d,
/// `M (px, py, d, 1) = (qx w, qy w, e w, w)` with (qx, qy) the same world
/// point's pixel position in `to` and e its stored depth there; drop
/// results with w <= 0 (`refl_camera_apply_reprojection` does). Composed in double
/// precision, rounded once.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `from` or `to` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an unknown convention or
/// `REFL_DEPTH_CONVENTION_LINEAR` (use `refl_camera_reproject`); a camera's status
/// if one is invalid; `REFL_STATUS_DEGENERATE_GEOMETRY` if the composed
/// matrix is not finite.
///
/// # Safety
/// `out` must be NULL or writable; `from` and `to` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_reprojection_matrix(
    out: *mut refl_mat4,
    from: *const refl_camera,
    to: *const refl_camera,
    convention: u32,
) -> refl_status {
    guard("refl_camera_reprojection_matrix", || {
        let out = Out::new(out, "out")?;
        crate::ptr::no_nulls(&[(from.is_null(), "from"), (to.is_null(), "to")])?;
        // SAFETY: caller contract.
        let (from, to) = unsafe { (camera(from, "from")?, camera(to, "to")?) };
        let m = finite_mat(try_reprojection_matrix(
            &from,
            &to,
            self::convention(convention)?,
        )?)?;
        // SAFETY: caller contract.
        unsafe { out.write(m) };
        Ok(())
    })
}

/// Reprojects the pixel position `pixel` of camera `from` with stored depth
/// `depth` (convention `convention`) into camera `to`, writing to `*out`
/// its pixel position and linear depth in `to`, or `valid = false` if the
/// point lies at or behind `to`'s eye plane or the depth decodes to a
/// non-finite distance. Works for every convention.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `from` or `to` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an unknown convention or a
/// non-finite `pixel` or `depth`; a camera's status if one is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `from` and `to` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_reproject(
    out: *mut refl_projection,
    from: *const refl_camera,
    to: *const refl_camera,
    pixel: refl_vec2,
    depth: f32,
    convention: u32,
) -> refl_status {
    guard("refl_camera_reproject", || {
        let out = Out::new(out, "out")?;
        crate::ptr::no_nulls(&[(from.is_null(), "from"), (to.is_null(), "to")])?;
        // SAFETY: caller contract.
        let (from, to) = unsafe { (camera(from, "from")?, camera(to, "to")?) };
        let c = self::convention(convention)?;
        let px = self::pixel(pixel)?;
        if !depth.is_finite() {
            return Err(Error::InvalidArgument);
        }
        let p = refl_core::camera::reproject(&from, &to, px, depth, c);
        // SAFETY: caller contract.
        unsafe { out.write(refl_projection::from_option(p)) };
        Ok(())
    })
}

/// Applies a reprojection matrix (from `refl_camera_reprojection_matrix`) to the
/// pixel position `pixel` with stored depth `depth`: writes to `*out` the
/// pixel position and stored depth after the homogeneous divide, or
/// `valid = false` when w <= 0 (behind the target eye) or the result is not
/// finite.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `matrix` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` if the matrix, `pixel` or `depth` is not
/// finite.
///
/// # Safety
/// `out` must be NULL or writable; `matrix` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_camera_apply_reprojection(
    out: *mut refl_projection,
    matrix: *const refl_mat4,
    pixel: refl_vec2,
    depth: f32,
) -> refl_status {
    guard("refl_camera_apply_reprojection", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let m = Mat4::from(unsafe { read(matrix, "matrix") }?);
        let px = self::pixel(pixel)?;
        if !(m.is_finite() && depth.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        let p = apply_reprojection(&m, px, depth);
        // SAFETY: caller contract.
        unsafe { out.write(refl_projection::from_option(p)) };
        Ok(())
    })
}
