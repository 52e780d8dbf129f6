//! Planar reflection: the reflection vector, planes, the mirror matrix and
//! the mirrored (virtual) camera.
//!
//! Seed 001 (appendix) builds the "virtual object" of a planar reflector with
//! a mirror matrix; seed 004 Sec. 4.4.3 gives the reflection vector. Rendering
//! the scene through [`try_mirrored_camera`] produces, at each pixel of the
//! mirror, exactly what the reflected primary ray sees.
//!
//! # Example
//! ```rust
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::{mirror_point, try_mirrored_camera, Camera, Plane};
//!
//! // The floor y = 0, from one of its triangles.
//! let floor = Plane::try_from_triangle(Vec3::ZERO, Vec3::X, Vec3::Z)?;
//! assert_eq!(mirror_point(&floor, Vec3::new(1.0, 2.0, 3.0)), Vec3::new(1.0, -2.0, 3.0));
//!
//! // The virtual camera has its eye under the floor, and its ray through
//! // every pixel is the mirror image of the real camera's.
//! let cam = Camera::try_look_at(Vec3::new(0.0, 2.0, 5.0), Vec3::ZERO, Vec3::Y, 1.0, 0.1, 100.0, 8, 8)?;
//! let virt = try_mirrored_camera(&cam, &floor)?;
//! assert!(virt.is_mirrored() && !cam.is_mirrored());
//! assert!((virt.eye() - Vec3::new(0.0, -2.0, 5.0)).length() < 1e-5);
//! let (a, b) = (cam.primary_ray(Vec2::new(2.5, 6.5)), virt.primary_ray(Vec2::new(2.5, 6.5)));
//! assert!((b.dir - a.dir * Vec3::new(1.0, -1.0, 1.0)).length() < 1e-5);
//! # Ok::<(), refl_core::Error>(())
//! ```

use crate::{Camera, DepthConvention, Error};
use glam::{DMat4, DVec4, Mat4, Vec3};

/// The reflection of the unit vector `v` about the unit normal `n`:
/// `Reflect(V, N) = 2 (V . N) N - V` (seed 004 Sec. 4.4.3).
///
/// `v` points from the surface **toward** the viewer (the seed's view
/// vector); the result points away from the surface on the same side as `v`.
/// For an incident direction `d` (pointing at the surface) use `reflect(-d, n)`.
/// A unit `v` and `n` give a unit result.
#[inline]
pub fn reflect(v: Vec3, n: Vec3) -> Vec3 {
    2.0 * v.dot(n) * n - v
}

/// [`reflect`] with its contract checked (seed 004 Sec. 4.4.3): `v` and
/// `n` finite, `n` unit length (`|n|^2` within `2e-3` of 1, the tolerance
/// of ray directions), the result finite.
///
/// # Errors
/// * [`Error::DegenerateGeometry`]: `n` is zero (`|n|^2 < 1e-12`): there is
///   no mirror to reflect about. (Without the check the formula returns
///   `-v`, a plausible-looking wrong answer.)
/// * [`Error::InvalidArgument`]: `v` or `n` not finite, `n` not unit
///   length, or the result overflowed.
///
/// # Examples
/// ```
/// use refl_core::{glam::Vec3, try_reflect, Error};
/// let r = try_reflect(Vec3::new(1.0, 1.0, 0.0), Vec3::Y)?;
/// assert_eq!(r, Vec3::new(-1.0, 1.0, 0.0));
/// assert_eq!(try_reflect(Vec3::X, Vec3::ZERO), Err(Error::DegenerateGeometry));
/// # Ok::<(), Error>(())
/// ```
pub fn try_reflect(v: Vec3, n: Vec3) -> Result<Vec3, Error> {
    if !v.is_finite() || !n.is_finite() {
        return Err(Error::InvalidArgument);
    }
    let n2 = n.length_squared();
    if n2 < 1e-12 {
        return Err(Error::DegenerateGeometry);
    }
    if !((n2 - 1.0).abs() <= 2e-3) {
        return Err(Error::InvalidArgument);
    }
    let r = reflect(v, n);
    if !r.is_finite() {
        return Err(Error::InvalidArgument);
    }
    Ok(r)
}

/// `n / |n|` with the length taken in f64, so that finite non-zero normals
/// whose squared length under- or overflows f32 still normalize.
fn unit_normal(n: Vec3) -> Result<Vec3, Error> {
    let len = n.as_dvec3().length();
    if !(len > 0.0) {
        return Err(Error::DegenerateGeometry);
    }
    Ok((n.as_dvec3() / len).as_vec3())
}

/// An oriented plane `n . p + d = 0` with a unit normal `n`.
///
/// Built only through the validating constructors, so the normal is always
/// unit length and finite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    normal: Vec3,
    d: f32,
}

impl Plane {
    /// The plane of triangle `p1 p2 p3` (seed 001 appendix:
    /// `n = (P1 - P2) x (P3 - P2)`, `a x + b y + c z + d = 0`).
    ///
    /// Erratum (design.md): the appendix's cross product is not normalized,
    /// but its mirror matrix needs a unit normal; here `n` is normalized and
    /// `d = -n . centroid` (the centroid keeps `d` consistent with all three
    /// vertices to rounding). The orientation is the appendix's:
    /// `(P1 - P2) x (P3 - P2)` points toward the side from which `p1, p2, p3`
    /// appear **clockwise** (opposite to the usual counter-clockwise
    /// front-face normal); use [`Plane::flipped`] for the other orientation.
    /// The mirror matrix is the same for both orientations.
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: a non-finite vertex.
    /// * [`Error::DegenerateGeometry`]: a zero-area or numerically collinear
    ///   triangle: the sine of the angle at `p2` is at most `8 eps` (~1e-6),
    ///   measured scale-free on unit edge vectors.
    pub fn try_from_triangle(p1: Vec3, p2: Vec3, p3: Vec3) -> Result<Self, Error> {
        if !(p1.is_finite() && p2.is_finite() && p3.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        // Edges rescaled to unit length before the cross product, so that
        // neither tiny (1e-20) nor huge (1e30) triangles under- or overflow;
        // |u1 x u2| is then the sine of the angle at p2.
        let unit = |e: Vec3| {
            let m = e.abs().max_element();
            (m > 0.0 && m.is_finite()).then(|| (e / m).normalize())
        };
        let (Some(u1), Some(u2)) = (unit(p1 - p2), unit(p3 - p2)) else {
            return Err(Error::DegenerateGeometry);
        };
        let n = u1.cross(u2);
        let sin = n.length();
        if !(sin > 8.0 * f32::EPSILON) {
            return Err(Error::DegenerateGeometry);
        }
        let normal = n / sin;
        // The centroid in f64: (p1 + p2 + p3) overflows f32 near f32::MAX.
        let centroid = (p1.as_dvec3() + p2.as_dvec3() + p3.as_dvec3()) / 3.0;
        let d = -normal.as_dvec3().dot(centroid) as f32;
        if !d.is_finite() {
            // |d| beyond f32 (fuzz finding F4): no representable plane.
            return Err(Error::InvalidArgument);
        }
        Ok(Self { normal, d })
    }

    /// The plane through `point` with normal direction `normal` (normalized
    /// here).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for non-finite input;
    /// [`Error::DegenerateGeometry`] for a zero normal.
    pub fn try_from_point_normal(point: Vec3, normal: Vec3) -> Result<Self, Error> {
        if !(point.is_finite() && normal.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        let normal = unit_normal(normal)?;
        let d = -normal.as_dvec3().dot(point.as_dvec3()) as f32;
        if !d.is_finite() {
            // |d| beyond f32 (fuzz finding F4): no representable plane.
            return Err(Error::InvalidArgument);
        }
        Ok(Self { normal, d })
    }

    /// The plane `n . p + d = 0` from its coefficients. A non-unit `normal`
    /// is normalized and `d` divided by the same length, so the plane (and
    /// a unit normal's `d`, bit for bit) is kept.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for non-finite input;
    /// [`Error::DegenerateGeometry`] for a zero normal.
    pub fn try_new(normal: Vec3, d: f32) -> Result<Self, Error> {
        if !(normal.is_finite() && d.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        if normal.length() == 1.0 {
            return Ok(Self { normal, d });
        }
        // The length in f64: |n|^2 under- or overflows f32 for components
        // below ~1e-19 or above ~1e19 (fuzz finding F2), which are finite,
        // non-zero normals all the same.
        let len = normal.as_dvec3().length();
        if !(len > 0.0) {
            return Err(Error::DegenerateGeometry);
        }
        let d = (f64::from(d) / len) as f32;
        if !d.is_finite() {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            normal: (normal.as_dvec3() / len).as_vec3(),
            d,
        })
    }

    /// The unit normal `(a, b, c)`.
    pub const fn normal(&self) -> Vec3 {
        self.normal
    }

    /// The offset `d` of `a x + b y + c z + d = 0`.
    pub const fn d(&self) -> f32 {
        self.d
    }

    /// The same plane with the opposite orientation.
    pub fn flipped(&self) -> Self {
        Self {
            normal: -self.normal,
            d: -self.d,
        }
    }

    /// Signed distance of `p` from the plane (positive on the normal's side).
    #[inline]
    pub fn signed_distance(&self, p: Vec3) -> f32 {
        self.normal.dot(p) + self.d
    }

    /// Parameter `t` at which the ray `origin + t dir` meets the plane, or
    /// `None` if the ray is parallel to it (or the result is not finite).
    /// `t` may be negative.
    #[inline]
    pub fn intersect_ray(&self, origin: Vec3, dir: Vec3) -> Option<f32> {
        let denom = self.normal.dot(dir);
        let t = -self.signed_distance(origin) / denom;
        (denom != 0.0 && t.is_finite()).then_some(t)
    }

    fn mirror_matrix_f64(&self) -> DMat4 {
        let n = self.normal.as_dvec3();
        let d = f64::from(self.d);
        let (a, b, c) = (n.x, n.y, n.z);
        // Seed 001 appendix, rows as printed, stored by columns.
        DMat4::from_cols(
            DVec4::new(1.0 - 2.0 * a * a, -2.0 * a * b, -2.0 * a * c, 0.0),
            DVec4::new(-2.0 * a * b, 1.0 - 2.0 * b * b, -2.0 * b * c, 0.0),
            DVec4::new(-2.0 * a * c, -2.0 * b * c, 1.0 - 2.0 * c * c, 0.0),
            DVec4::new(-2.0 * a * d, -2.0 * b * d, -2.0 * c * d, 1.0),
        )
    }
}

/// The mirror matrix of `plane` (seed 001 appendix):
///
/// ```text
/// | 1-2a^2  -2ab    -2ac    -2ad |
/// | -2ab    1-2b^2  -2bc    -2bd |
/// | -2ac    -2bc    1-2c^2  -2cd |
/// | 0       0       0       1    |
/// ```
///
/// with the unit normal `(a, b, c)` and offset `d` of the plane (the
/// appendix's unnormalized normal is an erratum, see [`Plane::try_from_triangle`]).
/// It maps a world point to its mirror image, is its own inverse and has
/// determinant -1. Computed in f64, rounded once.
pub fn mirror_matrix(plane: &Plane) -> Mat4 {
    plane.mirror_matrix_f64().as_mat4()
}

/// The mirror image of `p` in `plane`: `p - 2 (n . p + d) n`.
#[inline]
pub fn mirror_point(plane: &Plane, p: Vec3) -> Vec3 {
    p - 2.0 * plane.signed_distance(p) * plane.normal
}

/// The mirrored (virtual) camera of `cam` for the planar reflector `plane`:
/// view matrix `V M` with `M` the [`mirror_matrix`], same projection and
/// image size.
///
/// Contract: its primary ray through pixel `p` starts at the mirrored eye and
/// is the mirror image of `cam`'s primary ray through `p`; beyond the plane
/// that ray runs along the reflected ray of `cam`'s ray at the mirror. So the
/// image rendered through it, restricted to the mirror's pixels and clipped to
/// the plane's front side (geometry behind the mirror must be excluded, e.g.
/// with a user clip plane or rays starting at the plane), is the exact planar
/// reflection, pixel for pixel.
///
/// Handedness: `V M` contains a reflection ([`Camera::is_mirrored`] is
/// true), so a rasterizer must flip its front-face test (or cull nothing).
/// The pixel grid is not flipped: pixel `p` of the virtual image belongs to
/// pixel `p` of the mirror.
///
/// # Errors
/// Never for a valid camera and plane in practice; forwards
/// [`Camera::try_new`]'s errors if the product is not finite (e.g. huge
/// coordinates overflowing f32).
pub fn try_mirrored_camera(cam: &Camera, plane: &Plane) -> Result<Camera, Error> {
    let view = (cam.view().as_dmat4() * plane.mirror_matrix_f64()).as_mat4();
    Camera::try_new(
        view,
        cam.fov_y(),
        cam.near(),
        cam.far(),
        cam.width(),
        cam.height(),
    )
}

/// The projection matrix of `cam` for post-projection convention `c` with
/// its near plane replaced by the world-space plane `clip` (an oblique near
/// plane, after E. Lengyel, "Oblique View Frustum Depth Projection and
/// Clipping", Journal of Game Development 1(2), 2005, Sec. 2-3), so that a
/// rasterizer drawing through a [`try_mirrored_camera`] discards everything
/// behind the mirror without a user clip plane.
///
/// Contract: x, y and w rows are those of [`Camera::try_projection`]; the depth
/// row is replaced so that stored depth is the near value (0, or 1 for
/// reversed-Z) exactly on `clip`, grows toward the far value on the side the
/// normal points to, reaches the far value (1, or 0 for reversed-Z) at the
/// far frustum corner opposite the plane (at infinity for an infinite far
/// plane), and leaves `[0, 1]` behind the plane, so depth clipping does the
/// plane clipping. The far plane tilts with the near one (it passes through
/// that far corner), so geometry near the original far plane on the other
/// side may be clipped early: keep `far` generous, or infinite. Depth is still affine in `1 / z` (linear in screen space)
/// but no longer a function of view distance alone: decode it with this
/// matrix's inverse, not with [`Camera::decode_depth`]. Orient `clip` toward
/// the real eye (the side the reflection shows) as [`Plane::flipped`] allows.
///
/// Derivation (f64): with `C` the plane in view space, `M4` the projection's
/// w row and `Q` the view-space far corner `(sgn(C.x) tan_x, sgn(C.y) tan_y,
/// -1) * far` (a direction with `w = 0` for an infinite far plane), the
/// depth row is `a C` for `[0, 1]` depth and `M4 - a C` for reversed-Z,
/// with `a = (M4 . Q) / (C . Q)`.
///
/// # Errors
/// * [`Error::InvalidArgument`] for [`DepthConvention::Linear`].
/// * [`Error::DegenerateGeometry`] if the eye is not strictly on the
///   negative side of `clip` (the plane would cut away the eye's side or
///   pass through the eye), or the plane does not cross the view direction's
///   far side (`C . Q <= 0`, nothing in front would be kept).
pub fn try_oblique_projection(
    cam: &Camera,
    clip: &Plane,
    c: DepthConvention,
) -> Result<Mat4, Error> {
    let proj = cam.projection_f64(c)?;
    // Planes transform with the inverse transpose: C_view^T = C_world^T V^-1.
    let world = DVec4::new(
        f64::from(clip.normal.x),
        f64::from(clip.normal.y),
        f64::from(clip.normal.z),
        f64::from(clip.d),
    );
    let inv_view = cam.inverse_view().as_dmat4();
    let cv = inv_view.transpose() * world;
    if !(cv.w < 0.0) {
        return Err(Error::DegenerateGeometry);
    }
    let sgn = |v: f64| {
        if v > 0.0 {
            1.0
        } else if v < 0.0 {
            -1.0
        } else {
            0.0
        }
    };
    let tan_y = 1.0 / proj.y_axis.y;
    let tan_x = 1.0 / proj.x_axis.x;
    let far = f64::from(cam.far());
    let dir = DVec4::new(sgn(cv.x) * tan_x, sgn(cv.y) * tan_y, -1.0, 0.0);
    let q = if far.is_finite() {
        (dir * far).with_w(1.0)
    } else {
        dir
    };
    let m4 = proj.row(3);
    let cq = cv.dot(q);
    if !(cq > 0.0) {
        return Err(Error::DegenerateGeometry);
    }
    let a = m4.dot(q) / cq;
    let row = match c {
        DepthConvention::ReversedZ => m4 - cv * a,
        _ => cv * a,
    };
    // Replace the third row (the depth row) of the column-major matrix.
    let mut m = proj;
    m.x_axis.z = row.x;
    m.y_axis.z = row.y;
    m.z_axis.z = row.z;
    m.w_axis.z = row.w;
    let out = m.as_mat4();
    if out.is_finite() {
        Ok(out)
    } else {
        Err(Error::DegenerateGeometry)
    }
}
