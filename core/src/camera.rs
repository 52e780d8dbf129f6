//! Pinhole cameras, the three depth conventions, projection and
//! reprojection.
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::camera::{apply_reprojection, reproject, try_reprojection_matrix};
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::{Camera, DepthConvention};
//!
//! // At the origin looking down -Z, 90 degrees vertical field of view, 16 x 16.
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 0.5, 50.0, 16, 16)?;
//! // (1, 2, -4) has NDC (1/4, 2/4): pixel ((1 + 1/4) 8, (1 - 2/4) 8), depth 4.
//! let p = Vec3::new(1.0, 2.0, -4.0);
//! assert!((cam.project(p).unwrap() - Vec3::new(10.0, 4.0, 4.0)).length() < 1e-5);
//! // Reversed-Z stores n (f - z) / (z (f - n)); unproject inverts it.
//! let d = cam.encode_depth(4.0, DepthConvention::ReversedZ);
//! assert!((d - 0.5 * 46.0 / (4.0 * 49.5)).abs() < 1e-7);
//! let pixel = Vec2::new(10.0, 4.0);
//! assert!((cam.unproject(pixel, d, DepthConvention::ReversedZ) - p).length() < 1e-5);
//!
//! // The eye moves one unit right: the point is now straight ahead.
//! let moved = Camera::try_look_at(Vec3::X, Vec3::X - Vec3::Z, Vec3::Y, FRAC_PI_2, 0.5, 50.0, 16, 16)?;
//! let q = reproject(&cam, &moved, pixel, d, DepthConvention::ReversedZ).unwrap();
//! assert!((q - Vec3::new(8.0, 4.0, 4.0)).length() < 1e-4);
//! let m = try_reprojection_matrix(&cam, &moved, DepthConvention::ReversedZ)?;
//! let e = apply_reprojection(&m, pixel, d).unwrap();
//! assert!((e - Vec3::new(8.0, 4.0, d)).length() < 1e-4);
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! Conventions (design.md): right-handed world, view space looks down -Z,
//! linear depth `z` is the positive distance along -Z. Pixel `(x, y)` has its
//! center at `(x + 0.5, y + 0.5)`, origin top-left, y down. Normalized device
//! coordinates (NDC) have x right and y up in `[-1, 1]`; the pixel <-> NDC map
//! is `px = (ndc_x + 1) / 2 * width`, `py = (1 - ndc_y) / 2 * height`.
//!
//! Post-projection depth (the value a GPU writes to a depth buffer) for a
//! camera with near plane `n` and far plane `f` (`f` may be infinite):
//!
//! | convention | `d(z)` finite far | `d(z)` infinite far | near | far |
//! |---|---|---|---|---|
//! | [`DepthConvention::Linear`] | `z` | `z` | `n` | `f` |
//! | [`DepthConvention::ZeroToOne`] | `f (z - n) / (z (f - n))` | `1 - n / z` | 0 | 1 |
//! | [`DepthConvention::ReversedZ`] | `n (f - z) / (z (f - n))` | `n / z` | 1 | 0 |
//!
//! Both post-projection forms are affine in `1 / z`, hence linear in screen
//! space (seed 004 Sec. 4.4.3), which is what the screen-space kernels rely on.
//!
//! Matrices for a frame (view-projection, reprojection) are composed in f64
//! and rounded once to f32; per-pixel functions run in f32.

use crate::Error;
use glam::{DMat4, DVec4, Mat4, Vec2, Vec3, Vec4};

/// How a depth buffer encodes distance. Every depth-reading kernel takes the
/// convention explicitly.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DepthConvention {
    /// Linear view depth: the positive distance along the view's -Z axis.
    Linear,
    /// Post-projection depth in `[0, 1]`, near = 0, far = 1 (D3D / Vulkan /
    /// `glClipControl(.., GL_ZERO_TO_ONE)`).
    ZeroToOne,
    /// Reversed-Z post-projection depth, near = 1, far = 0; with an infinite
    /// far plane `d = n / z`.
    ReversedZ,
}

impl DepthConvention {
    /// All three conventions, for tests and tools that sweep them.
    pub const ALL: [DepthConvention; 3] = [Self::Linear, Self::ZeroToOne, Self::ReversedZ];

    /// `true` if a larger stored value means closer to the camera (reversed-Z).
    /// Min/max depth pyramids swap roles under this convention.
    pub const fn closer_is_greater(self) -> bool {
        matches!(self, Self::ReversedZ)
    }
}

/// A ray with a unit direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point, world space.
    pub origin: Vec3,
    /// Unit direction, world space.
    pub dir: Vec3,
}

impl Ray {
    /// The point at parameter `t` (distance, since `dir` is unit).
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// A pinhole camera: a view transform, a symmetric perspective projection
/// and an image size.
///
/// The view transform maps world to view space. Its 3x3 part must be
/// orthonormal (a rotation, or a rotation times a reflection for a mirrored
/// camera, see `mirror::try_mirrored_camera`, feature `mirror`), so that
/// view-space lengths are world-space lengths and linear depth is a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    view: Mat4,
    inv_view: Mat4,
    fov_y: f32,
    near: f32,
    far: f32,
    width: u32,
    height: u32,
    /// `tan(fov_y / 2)`.
    tan_half_y: f32,
    /// `tan(fov_y / 2) * width / height`.
    tan_half_x: f32,
}

/// Tolerance on the orthonormality of a view matrix's 3x3 part.
const ORTHONORMAL_TOL: f64 = 1e-4;

impl Camera {
    /// A camera from a world-to-view matrix, a vertical field of view
    /// (radians), near and far plane distances and an image size in pixels.
    /// The aspect ratio is `width / height`.
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: a zero size; `fov_y` not in `(0, pi)`;
    ///   `near` not finite and positive, or so small (subnormal) that
    ///   `1 / near` overflows f32; `far` not greater than `near` (it
    ///   may be `+inf`); a non-finite matrix; an eye (the inverse view's
    ///   translation) or a projection scale (`1 / tan(fov_y / 2)`, also
    ///   times the aspect ratio) that is not finite in f32.
    /// * [`Error::DegenerateGeometry`]: the view's 3x3 part is not
    ///   orthonormal within 1e-4, or its last row is not `(0, 0, 0, 1)`.
    pub fn try_new(
        view: Mat4,
        fov_y: f32,
        near: f32,
        far: f32,
        width: u32,
        height: u32,
    ) -> Result<Self, Error> {
        if width == 0
            || height == 0
            || !(fov_y > 0.0 && fov_y < core::f32::consts::PI)
            || !(near > 0.0 && near.is_finite() && (1.0 / near).is_finite())
            || !(far > near)
            || !view.is_finite()
        {
            return Err(Error::InvalidArgument);
        }
        let v = view.as_dmat4();
        if v.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
            return Err(Error::DegenerateGeometry);
        }
        let (x, y, z) = (
            v.x_axis.truncate(),
            v.y_axis.truncate(),
            v.z_axis.truncate(),
        );
        let ortho = [
            x.dot(x) - 1.0,
            y.dot(y) - 1.0,
            z.dot(z) - 1.0,
            x.dot(y),
            y.dot(z),
            z.dot(x),
        ];
        if ortho.iter().any(|e| libm::fabs(*e) > ORTHONORMAL_TOL) {
            return Err(Error::DegenerateGeometry);
        }
        // The exact inverse of [R | t], [R^-1 | -R^-1 t], in f64. R is
        // orthonormal only within ORTHONORMAL_TOL: its transpose would put
        // the eye up to 1e-4 |t| off the point the view maps to the origin,
        // so that a primary ray, `unproject` and `reproject` disagree with
        // `project` by pixels near the eye (fuzz finding F20: 2.5 px for a
        // point 1.3 near-plane distances away, a camera 9.7 from the
        // origin with a 2e-5 defect). R is well conditioned (|det R - 1| <
        // 2e-4), so the inverse is as accurate as the transpose.
        let r_inv = glam::DMat3::from_mat4(v).inverse();
        let t = v.w_axis.truncate();
        let inv = DMat4::from_cols(
            r_inv.x_axis.extend(0.0),
            r_inv.y_axis.extend(0.0),
            r_inv.z_axis.extend(0.0),
            (-(r_inv * t)).extend(1.0),
        );
        let tan_half_y = libm::tan(f64::from(fov_y) * 0.5);
        let aspect = f64::from(width) / f64::from(height);
        // Fuzz findings F3, F5: a camera whose eye (the inverse view's
        // translation) or whose projection (1 / tan(fov_y / 2), the
        // x and y scales) is not finite in f32 cannot be used by any
        // function: refuse it here rather than in each of them.
        let inv_f32 = inv.as_mat4();
        let scales_ok = [tan_half_y, tan_half_y * aspect]
            .iter()
            .all(|&t| (t as f32) > 0.0 && (t as f32).is_finite() && (1.0 / t as f32).is_finite());
        if !inv_f32.is_finite() || !scales_ok {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            view,
            inv_view: inv.as_mat4(),
            fov_y,
            near,
            far,
            width,
            height,
            tan_half_y: tan_half_y as f32,
            tan_half_x: (tan_half_y * aspect) as f32,
        })
    }

    /// A camera at `eye` looking at `target` with `up` as the approximate up
    /// direction (the right-handed look-at of `glam::camera::rh::view`).
    ///
    /// # Errors
    /// [`Error::DegenerateGeometry`] if `eye == target` or `up` is parallel to
    /// the view direction; otherwise as [`Camera::try_new`].
    #[allow(clippy::too_many_arguments)]
    pub fn try_look_at(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y: f32,
        near: f32,
        far: f32,
        width: u32,
        height: u32,
    ) -> Result<Self, Error> {
        if !(eye.is_finite() && target.is_finite() && up.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        let (eye_d, target_d, up_d) = (eye.as_dvec3(), target.as_dvec3(), up.as_dvec3());
        let f = (target_d - eye_d)
            .try_normalize()
            .ok_or(Error::DegenerateGeometry)?;
        let s = f
            .cross(up_d)
            .try_normalize()
            .ok_or(Error::DegenerateGeometry)?;
        if f.cross(up_d).length() < 1e-6 * up_d.length() {
            return Err(Error::DegenerateGeometry);
        }
        let u = s.cross(f);
        let view = DMat4::from_cols(
            DVec4::new(s.x, u.x, -f.x, 0.0),
            DVec4::new(s.y, u.y, -f.y, 0.0),
            DVec4::new(s.z, u.z, -f.z, 0.0),
            DVec4::new(-s.dot(eye_d), -u.dot(eye_d), f.dot(eye_d), 1.0),
        );
        Self::try_new(view.as_mat4(), fov_y, near, far, width, height)
    }
    /// A 32-bit fingerprint of everything that defines the camera (view
    /// matrix, field of view, near, far, width, height; FNV-1a over their
    /// bits): what a prepared structure (a Hi-Z pyramid) records about the
    /// camera it was built for, so that using it with another camera is an
    /// error rather than a silent miss. Equal cameras have equal
    /// fingerprints; different ones collide with probability about 2^-32.
    pub fn fingerprint(&self) -> u32 {
        let mut h: u32 = 0x811c_9dc5;
        let mut eat = |word: u32| {
            for b in word.to_le_bytes() {
                h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
            }
        };
        for v in self.view.to_cols_array() {
            eat(v.to_bits());
        }
        for v in [self.fov_y, self.near, self.far] {
            eat(v.to_bits());
        }
        eat(self.width);
        eat(self.height);
        h
    }

    /// World-to-view matrix.
    pub const fn view(&self) -> Mat4 {
        self.view
    }

    /// View-to-world matrix (computed in f64 at construction).
    pub const fn inverse_view(&self) -> Mat4 {
        self.inv_view
    }

    /// Vertical field of view in radians.
    pub const fn fov_y(&self) -> f32 {
        self.fov_y
    }

    /// Near plane distance.
    pub const fn near(&self) -> f32 {
        self.near
    }

    /// Far plane distance; may be `+inf`.
    pub const fn far(&self) -> f32 {
        self.far
    }

    /// Image width in pixels.
    pub const fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub const fn height(&self) -> u32 {
        self.height
    }

    /// `width / height`.
    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// The eye (center of projection), world space.
    pub fn eye(&self) -> Vec3 {
        self.inv_view.w_axis.truncate()
    }

    /// `true` if the view transform contains a reflection (determinant < 0),
    /// as a mirrored camera's does: triangles rasterized through it have
    /// their winding reversed, so front-face culling must be flipped.
    pub fn is_mirrored(&self) -> bool {
        // The 3x3 part in f64: the f32 4x4 determinant overflows to NaN
        // for translations near f32::MAX (fuzz finding F5).
        glam::DMat3::from_mat4(self.view.as_dmat4()).determinant() < 0.0
    }

    /// The primary ray through `pixel` (in pixels, e.g. `(x + 0.5, y + 0.5)`
    /// for the center of pixel `(x, y)`), starting at the eye.
    pub fn primary_ray(&self, pixel: Vec2) -> Ray {
        let dir_view = self.view_dir_through(pixel);
        Ray {
            origin: self.eye(),
            dir: self
                .inv_view
                .transform_vector3(dir_view)
                .normalize_or_zero(),
        }
    }

    /// World-space (not normalized) directions through the pixel centers,
    /// affine in the pixel index: the direction through the center of pixel
    /// `(x, y)` is `d0 + x dx + y dy`, scaled so that `eye + z (d0 + x dx +
    /// y dy)` is the point at linear depth `z` ([`Camera::unproject`] up to
    /// f32 rounding). Returns `(d0, dx, dy)`.
    #[cfg(feature = "tcrr")]
    pub(crate) fn pixel_center_rays(&self) -> (Vec3, Vec3, Vec3) {
        let (w, h) = (self.width as f32, self.height as f32);
        let d0 = self.view_dir_through(Vec2::new(0.5, 0.5));
        let dx = Vec3::new(2.0 * self.tan_half_x / w, 0.0, 0.0);
        let dy = Vec3::new(0.0, -2.0 * self.tan_half_y / h, 0.0);
        (
            self.inv_view.transform_vector3(d0),
            self.inv_view.transform_vector3(dx),
            self.inv_view.transform_vector3(dy),
        )
    }

    /// The (not normalized) view-space direction through `pixel` with
    /// `z = -1`: `(ndc_x tan_x, ndc_y tan_y, -1)`.
    #[inline]
    pub(crate) fn view_dir_through(&self, pixel: Vec2) -> Vec3 {
        let ndc_x = 2.0 * pixel.x / self.width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * pixel.y / self.height as f32;
        Vec3::new(ndc_x * self.tan_half_x, ndc_y * self.tan_half_y, -1.0)
    }

    /// World point to view space.
    #[inline]
    pub fn world_to_view(&self, p: Vec3) -> Vec3 {
        self.view.transform_point3(p)
    }

    /// Linear depth of a world point: its distance in front of the eye along
    /// the view axis (negative behind the eye).
    #[inline]
    pub fn linear_depth(&self, p: Vec3) -> f32 {
        -self.world_to_view(p).z
    }

    /// The six planes of the view frustum in world space, `(n, d)` with a
    /// unit `n` pointing inside: a point `p` lies in the frustum when
    /// `n . p + d >= 0` for all six, in the order left, right, bottom, top,
    /// near, far (for a host's object culling). Ours: the view-space
    /// half-spaces `|x| <= -z tan_x`, `|y| <= -z tan_y` and `near <= -z <=
    /// far` (the symmetric projection's frustum, `tan_x`, `tan_y` as
    /// [`Camera::project`] uses them), normalized, mapped to world space by
    /// `V^T` (a plane `P` of view space is `V^T P` of world space for the
    /// world-to-view matrix `V`), in f64. With an infinite far plane the
    /// last is `(0, 0, 0, 1)` (no bound).
    pub fn frustum_planes(&self) -> [Vec4; 6] {
        let (tx, ty) = (f64::from(self.tan_half_x), f64::from(self.tan_half_y));
        let far = if self.far.is_finite() {
            DVec4::new(0.0, 0.0, 1.0, f64::from(self.far))
        } else {
            DVec4::new(0.0, 0.0, 0.0, 1.0)
        };
        let view = [
            DVec4::new(1.0, 0.0, -tx, 0.0),
            DVec4::new(-1.0, 0.0, -tx, 0.0),
            DVec4::new(0.0, 1.0, -ty, 0.0),
            DVec4::new(0.0, -1.0, -ty, 0.0),
            DVec4::new(0.0, 0.0, -1.0, -f64::from(self.near)),
            far,
        ];
        let vt = self.view.as_dmat4().transpose();
        view.map(|p| {
            let w = vt * p;
            let len = w.truncate().length();
            if len > 0.0 {
                (w / len).as_vec4()
            } else {
                w.as_vec4()
            }
        })
    }

    /// Projects a world point to `(pixel x, pixel y, linear depth)`.
    ///
    /// Returns `None` for points at or behind the eye plane (`z <= 0`) and
    /// for non-finite results; such points have no image position
    /// (design.md erratum for seed 002: reprojected points with `t <= 0`
    /// are dropped). Points outside the image rectangle or outside the
    /// near/far range are still projected.
    pub fn project(&self, p: Vec3) -> Option<Vec3> {
        let v = self.world_to_view(p);
        let z = -v.z;
        if !(z > 0.0) {
            return None;
        }
        let ndc_x = v.x / (z * self.tan_half_x);
        let ndc_y = v.y / (z * self.tan_half_y);
        let out = Vec3::new(
            (ndc_x + 1.0) * 0.5 * self.width as f32,
            (1.0 - ndc_y) * 0.5 * self.height as f32,
            z,
        );
        out.is_finite().then_some(out)
    }

    /// Encodes linear depth `z` in convention `c` (table in the module docs).
    /// `z` outside `[near, far]` extrapolates the same formula.
    #[inline]
    pub fn encode_depth(&self, z: f32, c: DepthConvention) -> f32 {
        let (n, f) = (self.near, self.far);
        match c {
            DepthConvention::Linear => z,
            DepthConvention::ZeroToOne if f.is_infinite() => 1.0 - n / z,
            DepthConvention::ZeroToOne => f * (z - n) / (z * (f - n)),
            DepthConvention::ReversedZ if f.is_infinite() => n / z,
            DepthConvention::ReversedZ => n * (f - z) / (z * (f - n)),
        }
    }

    /// Decodes a stored depth `d` of convention `c` to linear depth: the
    /// inverse of [`Camera::encode_depth`]. The far plane at infinity decodes
    /// to `+inf`; the stored far plane of a finite one (`1` in
    /// [`DepthConvention::ZeroToOne`], `0` in [`DepthConvention::ReversedZ`],
    /// the value a cleared depth buffer holds) decodes to exactly `far`, so
    /// that every kernel's "no surface at or beyond the far plane" test
    /// (`z < far`) holds for the background (the formula alone rounds it
    /// to slightly less than `far`).
    #[inline]
    pub fn decode_depth(&self, d: f32, c: DepthConvention) -> f32 {
        let (n, f) = (self.near, self.far);
        match c {
            DepthConvention::Linear => d,
            DepthConvention::ZeroToOne if f.is_infinite() => n / (1.0 - d),
            DepthConvention::ZeroToOne if d == 1.0 => f,
            DepthConvention::ZeroToOne => n * f / (f - d * (f - n)),
            DepthConvention::ReversedZ if f.is_infinite() => n / d,
            DepthConvention::ReversedZ if d == 0.0 => f,
            DepthConvention::ReversedZ => n * f / (n + d * (f - n)),
        }
    }

    /// The world point seen through `pixel` at stored depth `depth` of
    /// convention `c`.
    pub fn unproject(&self, pixel: Vec2, depth: f32, c: DepthConvention) -> Vec3 {
        let z = self.decode_depth(depth, c);
        self.inv_view
            .transform_point3(self.view_dir_through(pixel) * z)
    }

    /// Projection matrix (view space to clip space) for a post-projection
    /// convention, in f64. `clip.w = -z_view`, `clip.z / clip.w` is the
    /// stored depth of the module's table.
    pub(crate) fn projection_f64(&self, c: DepthConvention) -> Result<DMat4, Error> {
        let (n, f) = (f64::from(self.near), f64::from(self.far));
        // clip.z = a * z_view + b
        let (a, b) = match c {
            DepthConvention::Linear => return Err(Error::InvalidArgument),
            DepthConvention::ZeroToOne if f.is_infinite() => (-1.0, -n),
            DepthConvention::ZeroToOne => (f / (n - f), n * f / (n - f)),
            DepthConvention::ReversedZ if f.is_infinite() => (0.0, n),
            DepthConvention::ReversedZ => (n / (f - n), n * f / (f - n)),
        };
        let ty = libm::tan(f64::from(self.fov_y) * 0.5);
        let tx = ty * f64::from(self.width) / f64::from(self.height);
        Ok(DMat4::from_cols(
            DVec4::new(1.0 / tx, 0.0, 0.0, 0.0),
            DVec4::new(0.0, 1.0 / ty, 0.0, 0.0),
            DVec4::new(0.0, 0.0, a, -1.0),
            DVec4::new(0.0, 0.0, b, 0.0),
        ))
    }

    /// NDC to pixel: `(px, py, d) = ((x + 1) w / 2, (1 - y) h / 2, z)`.
    fn viewport_f64(&self) -> DMat4 {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        DMat4::from_cols(
            DVec4::new(0.5 * w, 0.0, 0.0, 0.0),
            DVec4::new(0.0, -0.5 * h, 0.0, 0.0),
            DVec4::new(0.0, 0.0, 1.0, 0.0),
            DVec4::new(0.5 * w, 0.5 * h, 0.0, 1.0),
        )
    }

    /// World to pixel space in f64: homogeneous `(px w, py w, d w, w)`.
    fn world_to_pixel_f64(&self, c: DepthConvention) -> Result<DMat4, Error> {
        Ok(self.viewport_f64() * self.projection_f64(c)? * self.view.as_dmat4())
    }

    /// The projection matrix (view to clip space) for post-projection
    /// convention `c`, the matrix a rasterizer uses: `clip.w = -z_view` and
    /// `clip.z / clip.w` is the stored depth.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for [`DepthConvention::Linear`], which is
    /// not a projective coordinate.
    pub fn try_projection(&self, c: DepthConvention) -> Result<Mat4, Error> {
        self.projection_f64(c).map(|m| m.as_mat4())
    }

    /// World space to homogeneous pixel space: for a world point `p`,
    /// `m * (p, 1) = (px w, py w, d w, w)` with `(px, py)` its pixel position
    /// and `d` its stored depth in convention `c`.
    ///
    /// # Errors
    /// As [`Camera::try_projection`].
    pub fn try_world_to_pixel(&self, c: DepthConvention) -> Result<Mat4, Error> {
        self.world_to_pixel_f64(c).map(|m| m.as_mat4())
    }
}

/// The reprojection matrix from camera `from` to camera `to` (seed 004
/// Sec. 4.6.4: "the current inverted camera projection matrix and the
/// previous camera projection matrix", after [Nehab et al. 07]).
///
/// For a pixel position `(px, py)` of `from` with stored depth `d` of
/// convention `c`, `m * (px, py, d, 1) = (qx w, qy w, e w, w)` where
/// `(qx, qy)` is the same world point's pixel position in `to` and `e` its
/// stored depth there. A result with `w <= 0` lies behind `to`'s eye and must
/// be dropped. Composed in f64 (both cameras' view, projection and viewport
/// transforms) and rounded once.
///
/// # Errors
/// [`Error::InvalidArgument`] for [`DepthConvention::Linear`] (linear depth
/// is not projective: use [`reproject`]).
pub fn try_reprojection_matrix(
    from: &Camera,
    to: &Camera,
    c: DepthConvention,
) -> Result<Mat4, Error> {
    let to_m = to.world_to_pixel_f64(c)?;
    let from_m = from.world_to_pixel_f64(c)?;
    Ok((to_m * from_m.inverse()).as_mat4())
}

/// Reprojects pixel position `pixel` of `from` with stored depth `depth`
/// (convention `c`) into `to`: returns `(pixel x, pixel y, linear depth)` in
/// `to`, or `None` if the point lies at or behind `to`'s eye plane or the
/// depth decodes to a non-finite distance. Works for every convention.
pub fn reproject(
    from: &Camera,
    to: &Camera,
    pixel: Vec2,
    depth: f32,
    c: DepthConvention,
) -> Option<Vec3> {
    let p = from.unproject(pixel, depth, c);
    if !p.is_finite() {
        return None;
    }
    to.project(p)
}

/// Applies a reprojection matrix to `(px, py, d)`: `(qx, qy, e)` after the
/// homogeneous divide, or `None` when `w <= 0` (behind the target eye) or
/// the result is not finite.
#[inline]
pub fn apply_reprojection(m: &Mat4, pixel: Vec2, depth: f32) -> Option<Vec3> {
    let h: Vec4 = *m * Vec4::new(pixel.x, pixel.y, depth, 1.0);
    if !(h.w > 0.0) {
        return None;
    }
    let q = h.truncate() / h.w;
    q.is_finite().then_some(q)
}
