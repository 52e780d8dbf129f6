//! The potential-reflection-region test of seed 001 Sec. 3.2 (Fig. 2):
//! whether a reflector triangle can show the reflection of an object's
//! bounding sphere ([`try_prr_classify`], [`PrrClass`]), and the reflector
//! triangle as a region of the layered pass's masks ([`PrrTriangle`]).

use crate::Error;
use glam::{DVec3, Vec3};

/// One reflector triangle as a *region* of the potential-reflection-region
/// masks of the layered pass (seed 001 Sec. 3.2, Fig. 2(a): the seed tests
/// each small planar reflector, a triangle, against the cone of each
/// reflected object; `crate::layered_pass` builds the masks): its world
/// corners and the vertex normals the G-buffer's shading normals
/// interpolate on it (`#[repr(C)]`: the C ABI's `refl_prr_triangle`).
///
/// The seed reflects about the triangle's plane; a G-buffer with
/// interpolated normals reflects about a normal up to the angle
/// [`PrrTriangle::normal_spread_sin`] away from it, which the masks allow
/// for (ours). For flat shading every vertex normal is the face normal
/// ([`PrrTriangle::flat`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct PrrTriangle {
    /// World corners.
    pub corners: [[f32; 3]; 3],
    /// Vertex normals (any non-zero length, consistently oriented; the
    /// sign of the whole triangle's normals is free: a reflection does not
    /// depend on it).
    pub normals: [[f32; 3]; 3],
}

impl PrrTriangle {
    /// A flat-shaded triangle: every vertex normal is the face normal
    /// `(b - a) x (c - a)` (zero for a degenerate triangle, which the masks
    /// then leave unrestricted).
    pub fn flat(corners: [Vec3; 3]) -> Self {
        let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        Self {
            corners: corners.map(|c| c.to_array()),
            normals: [n.to_array(); 3],
        }
    }

    /// `true` if every corner and normal is finite.
    pub fn is_finite(&self) -> bool {
        self.corners
            .iter()
            .chain(&self.normals)
            .all(|v| v.iter().all(|c| c.is_finite()))
    }

    /// The sine of the largest angle `delta` between the triangle's plane
    /// normal `f` and a shading normal on it, in f64, or `None` where no
    /// bound below 90 degrees exists (a degenerate triangle, a zero or
    /// non-finite normal, a vertex normal at 90 degrees or more from `f`).
    ///
    /// A shading normal interpolates the vertex normals `n_i` with weights
    /// `w_i >= 0`: `x = sum w_i n_i / |sum w_i n_i|`. With
    /// `c = min_i f . n_i / |n_i| > 0`, `f . x >= c sum w_i |n_i| /
    /// |sum w_i n_i| >= c` (the triangle inequality), so every shading
    /// normal lies within `acos c` of `f` and `sin delta = sqrt(1 - c^2)`.
    pub fn normal_spread_sin(&self) -> Option<f64> {
        let v = self.corners.map(|c| DVec3::from_array(c.map(f64::from)));
        let f = (v[1] - v[0]).cross(v[2] - v[0]);
        let f = f.try_normalize()?;
        let mut dots = [0.0f64; 3];
        for (d, n) in dots.iter_mut().zip(&self.normals) {
            let n = DVec3::from_array(n.map(f64::from)).try_normalize()?;
            *d = f.dot(n);
        }
        let s = if dots[0] + dots[1] + dots[2] >= 0.0 {
            1.0
        } else {
            -1.0
        };
        let c = dots.iter().fold(f64::INFINITY, |m, &d| m.min(s * d));
        (c > 0.0).then(|| libm::sqrt(((1.0 - c) * (1.0 + c)).max(0.0)))
    }
}

/// How a reflector triangle relates to the potential reflection region of
/// one reflected object (seed 001 Sec. 3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PrrClass {
    /// No reflection of the object's bounding sphere on the triangle.
    Outside,
    /// The mirrored bounding sphere lies entirely on the camera's side of
    /// the triangle's plane: the camera sees the plane from the side facing
    /// away from the object (or the object is behind the mirror), so no
    /// reflection is possible.
    WrongSide,
    /// The camera lies inside the mirrored bounding sphere: the cone is
    /// undefined; conservatively a potential reflection.
    CameraInside,
    /// Case 1 of the seed: a corner of the triangle lies inside the cone.
    Vertex,
    /// Case 2: an edge of the triangle crosses the cone.
    Edge,
    /// Case 3: the conic section of the cone with the triangle's plane
    /// lies entirely inside the triangle.
    Ellipse,
}

impl PrrClass {
    /// `true` for the classes on which a reflection may appear.
    pub const fn may_reflect(self) -> bool {
        matches!(
            self,
            PrrClass::CameraInside | PrrClass::Vertex | PrrClass::Edge | PrrClass::Ellipse
        )
    }
}

/// The potential-reflection-region test of seed 001 Sec. 3.2 for one
/// reflector triangle `tri`, a camera at `eye` and a reflected object with
/// bounding sphere (`center`, `radius`).
///
/// The sphere is mirrored about the triangle's plane (the virtual object of
/// the appendix); the cone has its apex at the camera C and is tangent to
/// the mirrored sphere (center O, radius r): axis `CO`, half-angle `theta`
/// with `cos theta = |CA| / |CO| = sqrt(|CO|^2 - r^2) / |CO|` (Fig. 2(a),
/// A a tangent point). A point P of the triangle's plane lies in the cone
/// exactly when the line of sight C -> P continues into the mirrored
/// sphere, i.e. the mirror ray at P can reach the real sphere. The seed's
/// three cases are tested in its order: a corner inside the cone, an edge
/// crossing the cone, the conic section (the seed's ellipse) inside the
/// triangle (tested with the point where the cone's axis meets the plane).
///
/// The seed bounds the cone by the plane of the tangent circle (center
/// O'); here the cone is unbounded and the side test [`PrrClass::WrongSide`]
/// replaces the bound: when the mirrored sphere lies on the far side of the
/// plane (the usual case), every cone point on the plane is in front of
/// the mirrored sphere, so the test is exact for the bounding sphere. When
/// the sphere straddles the plane (an object touching the reflector) the
/// result is conservative (may report a reflection that is not there).
/// The mirror is two-sided: no facing test is made.
///
/// # Errors
/// * [`Error::InvalidArgument`]: a non-finite input, a radius that is not
///   positive.
/// * [`Error::DegenerateGeometry`]: a zero-area (or numerically collinear)
///   triangle.
pub fn try_prr_classify(
    eye: Vec3,
    center: Vec3,
    radius: f32,
    tri: [Vec3; 3],
) -> Result<PrrClass, Error> {
    let finite = eye.is_finite() && center.is_finite() && tri.iter().all(|p| p.is_finite());
    if !(finite && radius > 0.0 && radius.is_finite()) {
        return Err(Error::InvalidArgument);
    }
    // Unit normal of the triangle, scale-free (edges rescaled first).
    let unit = |e: Vec3| {
        let m = e.abs().max_element();
        (m > 0.0 && m.is_finite()).then(|| (e / m).normalize())
    };
    let (Some(e1), Some(e2)) = (unit(tri[1] - tri[0]), unit(tri[2] - tri[0])) else {
        return Err(Error::DegenerateGeometry);
    };
    let nc = e1.cross(e2);
    let sin = nc.length();
    if !(sin > 8.0 * f32::EPSILON) {
        return Err(Error::DegenerateGeometry);
    }
    let n = nc / sin;
    let p0 = (tri[0] + tri[1] + tri[2]) / 3.0;
    // Mirrored sphere center (seed 001 appendix, unit normal).
    let dist_o = n.dot(center - p0);
    let o = center - 2.0 * dist_o * n;
    let dist_c = n.dot(eye - p0);
    let dist_m = -dist_o; // signed distance of the mirrored center
    if dist_c * dist_m > 0.0 && dist_m.abs() > radius {
        return Ok(PrrClass::WrongSide);
    }
    let co = o - eye;
    let l2 = co.length_squared();
    if !(l2 > radius * radius) {
        return Ok(PrrClass::CameraInside);
    }
    let l = libm::sqrtf(l2);
    let axis = co / l;
    // cos^2 theta = (|CO|^2 - r^2) / |CO|^2
    let cos2 = ((l - radius) * (l + radius)) / l2;
    let in_cone = |p: Vec3| {
        let w = p - eye;
        let wa = w.dot(axis);
        wa >= 0.0 && wa * wa >= cos2 * w.length_squared()
    };
    if tri.iter().any(|&p| in_cone(p)) {
        return Ok(PrrClass::Vertex);
    }
    // Case 2: f(s) = (v.a)^2 - cos^2 |v|^2 >= 0 with v.a >= 0 on the edge.
    for k in 0..3 {
        let (pa, pb) = (tri[k], tri[(k + 1) % 3]);
        let w = pa - eye;
        let e = pb - pa;
        let (wa, ea) = (w.dot(axis), e.dot(axis));
        // Sub-range of s in [0, 1] with (w + s e).a >= 0.
        let (mut lo, mut hi) = (0.0f32, 1.0f32);
        if ea == 0.0 {
            if wa < 0.0 {
                continue;
            }
        } else {
            let s0 = -wa / ea;
            if ea > 0.0 {
                lo = lo.max(s0);
            } else {
                hi = hi.min(s0);
            }
        }
        if !(lo <= hi) {
            continue;
        }
        let alpha = ea * ea - cos2 * e.length_squared();
        let beta = wa * ea - cos2 * w.dot(e);
        let gamma = wa * wa - cos2 * w.length_squared();
        let f = |s: f32| (alpha * s + 2.0 * beta) * s + gamma;
        let mut fmax = f(lo).max(f(hi));
        if alpha < 0.0 {
            let sv = -beta / alpha;
            if sv > lo && sv < hi {
                fmax = fmax.max(f(sv));
            }
        }
        if fmax >= 0.0 {
            return Ok(PrrClass::Edge);
        }
    }
    // Case 3: the point where the axis meets the plane, inside the triangle.
    let na = n.dot(axis);
    if na != 0.0 {
        let t = -dist_c / na;
        if t > 0.0 && t.is_finite() {
            let q = eye + axis * t;
            if point_in_triangle(q, tri, n) {
                return Ok(PrrClass::Ellipse);
            }
        }
    }
    Ok(PrrClass::Outside)
}

/// `true` if `q` (on the plane of `tri`, unit normal `n`) lies inside the
/// triangle (edges inclusive): same-side tests of the three edges.
fn point_in_triangle(q: Vec3, tri: [Vec3; 3], n: Vec3) -> bool {
    let s = |a: Vec3, b: Vec3| (b - a).cross(q - a).dot(n);
    let (s0, s1, s2) = (s(tri[0], tri[1]), s(tri[1], tri[2]), s(tri[2], tri[0]));
    (s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) || (s0 <= 0.0 && s1 <= 0.0 && s2 <= 0.0)
}
