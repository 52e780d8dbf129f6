//! The camera of one cluster (seed 003 Sec. 3.3, Eq. 1; the widened frame
//! of glossy clusters, Sec. 3.5): the eye from the reflected rays, the
//! image plane and frustum fitted to the cluster, the clip plane, or a
//! [`ClusterFallback`] reason.

use super::{ClusterInput, Surfaces};
use crate::{Camera, Error};
use glam::{DVec3, Vec2, Vec3};

/// Cluster camera parameters (seed 003 Sec. 3.3 and 3.5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterCameraOptions {
    /// `D`: distance from the image plane to the far plane; the scene
    /// diameter for mirrors, nearer for glossy clusters (Sec. 3.5).
    pub far_distance: f32,
    /// Half-angle (radians, `[0, pi/2)`) of the glossy cone: the image
    /// frame grows to hold it (Sec. 3.5 item 1). 0 for mirrors.
    pub cone_half_angle: f32,
    /// The far plane of a glossy cluster comes nearer by glossiness (Sec.
    /// 3.5 item 2: "For surfaces that are more matte, the far plane can be
    /// closer to the near plane"): the cluster pass gives a cluster whose
    /// lobe samples several rays `D_g = min(D, r / tan(max_angle))`, the
    /// distance at which the lobe's cone has spread over a disc of this
    /// radius `r` (world units; the seed gives no formula: the report
    /// sweeps `r`). `> 0`; `+inf` (the default) keeps `D`.
    pub glossy_blur_radius: f32,
    /// Multiplier of the resolution from the cluster's pixel spacing
    /// (Sec. 3.3 step 5; Table 5 sweeps 1/2, 1, 2).
    pub resolution_scale: f32,
    /// Largest width or height of the depth image; a larger frame is
    /// rendered at this size (coarser texels).
    pub max_resolution: u32,
    /// Clusters with fewer pixels fall back ([`ClusterFallback::TooFewPixels`]),
    /// at least 2 (one pixel has no pixel spacing).
    pub min_pixels: u32,
    /// Upper bound of `f` (Eq. 1); also the value used when `d_F <= d_n`
    /// (the far endpoints spread no more than the near ones: nearly
    /// parallel rays, best seen from far away).
    pub max_f: f32,
}

impl Default for ClusterCameraOptions {
    /// `D = 100`, mirror, no nearer glossy far plane, resolution 1x, at
    /// most 2048 texels a side, clusters of at least 4 pixels, `f <= 16`.
    fn default() -> Self {
        Self {
            far_distance: 100.0,
            cone_half_angle: 0.0,
            glossy_blur_radius: f32::INFINITY,
            resolution_scale: 1.0,
            max_resolution: 2048,
            min_pixels: 4,
            max_f: 16.0,
        }
    }
}

impl ClusterCameraOptions {
    pub(super) fn validate(&self) -> Result<(), Error> {
        let ok = self.far_distance > 0.0
            && self.far_distance.is_finite()
            && self.glossy_blur_radius > 0.0
            && self.cone_half_angle >= 0.0
            && self.cone_half_angle < 1.5
            && self.resolution_scale > 0.0
            && self.resolution_scale.is_finite()
            && self.max_resolution > 0
            && self.min_pixels >= 2
            && self.max_f >= 1.0
            && self.max_f.is_finite();
        if !ok {
            return Err(Error::InvalidArgument);
        }
        Ok(())
    }
}

/// An oriented plane through `point` with unit `normal`: the side the
/// normal points to is "in front".
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipPlane {
    /// A point of the plane.
    pub point: Vec3,
    /// Unit normal toward the kept side.
    pub normal: Vec3,
}

impl ClipPlane {
    /// Signed distance of `p` (positive in front).
    pub fn signed_distance(&self, p: Vec3) -> f32 {
        (p - self.point).dot(self.normal)
    }
}

/// A cluster's camera (seed 003 Sec. 3.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterCamera {
    /// The pinhole camera to render the cluster depth image with: eye at
    /// `e_c`, a symmetric frustum around the direction to the image frame's
    /// center holding the whole frame, square texels at the cluster's
    /// pixel spacing.
    pub camera: Camera,
    /// Keep only geometry strictly in front of this plane when rendering
    /// (parallel to the image plane, through the cluster point farthest in
    /// front of it, so the reflector's own cluster surface is not drawn).
    pub clip: ClipPlane,
    /// Centroid `P_c` of the cluster's surface points (step 1a).
    pub centroid: Vec3,
    /// Unit mean normal `n_c` (step 1b), oriented toward the eye.
    pub normal: Vec3,
    /// The mirrored eye `e_0` (step 3a).
    pub eye0: Vec3,
    /// `f` of Eq. 1 after the guards (exactly 1 for planar clusters).
    pub f: f32,
    /// Diagonals of Eq. 1: `d_n`, `d_f` (from `e_0`) and `d_F`.
    pub diagonals: [f32; 3],
    /// `true` if every pixel lies on the image plane with the mean normal
    /// (within 1e-5 relative): the camera is exactly the mirrored camera's
    /// eye and every reflected ray projects to one point.
    pub planar: bool,
    /// `true` if the cluster is concave (seed 003 Sec. 4.4: "detect that a
    /// cluster is concave, by testing whether the center of a cluster is
    /// behind the image plane"): its surface, fitted as a paraboloid of
    /// revolution about the mean normal through the centroid
    /// ([`center_height`]), has its center behind the image plane (away
    /// from the eye) by more than [`CONCAVE_TOLERANCE`] of the cluster's
    /// extent. Never for a planar cluster. A concave cluster's reflected
    /// rays may meet the cluster again, which its depth image (clipped
    /// at the cluster's front) does not hold: the cluster pass's
    /// [`second_intersection`](super::ClusterPassOptions::second_intersection)
    /// traces them against the reflector itself.
    pub concave: bool,
    /// `D`, the far plane's distance from the image plane.
    pub far_distance: f32,
    /// Pixels used (those whose reflected ray leaves the image plane toward
    /// the far plane).
    pub pixels_used: u32,
}

/// Why a cluster gets no camera: its pixels fall back to the environment
/// (seed 003 Sec. 4.1.1: small clusters are looked up in an environment
/// map).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ClusterFallback {
    /// Fewer than [`ClusterCameraOptions::min_pixels`] pixels.
    TooFewPixels,
    /// The normals cancel out, or their mean faces away from the eye (the
    /// eye is not in front of the image plane).
    FacesAway,
    /// No reflected ray of the cluster reaches the far plane (all run along
    /// or behind the image plane).
    NoRays,
    /// The endpoints span more than a pinhole frustum of half-angle
    /// `atan(MAX_TAN)` holds.
    TooWide,
    /// The camera is not representable (coordinates overflowing f32, a
    /// degenerate frustum): [`try_cluster_camera`]'s
    /// [`Error::DegenerateGeometry`], which the cluster pass
    /// ([`ClusterPass::try_plan`](super::ClusterPass::try_plan)) records as this fallback rather than
    /// failing the frame.
    Degenerate,
}

/// Least depth of a concave cluster's center behind its image plane,
/// relative to the cluster's extent (the largest distance of a pixel's
/// point from the centroid): a shallower cup (a radius of curvature above
/// about 2,500 extents) counts as flat ([`ClusterCamera::concave`]).
pub const CONCAVE_TOLERANCE: f32 = 1e-4;

/// The height above the image plane (through `centroid` with unit normal
/// `normal`, positive toward the eye) of the center of the paraboloid of
/// revolution `s = a + k rho^2` fitted by least squares to the `points`
/// (`s` a point's height, `rho` its distance from the normal's axis
/// through the centroid), in f64: `a` of the fit, the seed 003 Sec. 4.4
/// "center of a cluster" relative to "the image plane of the camera
/// cluster" (the seed tests one point; the fit uses every pixel, so one
/// noisy normal or depth does not decide). `None` if the points do not
/// determine a slope (fewer than two distinct `rho^2`, e.g. a ring).
/// Negative for a cup opening toward the eye (concave), positive for a
/// dome (convex), 0 for a plane.
pub fn center_height(
    points: impl Iterator<Item = Vec3> + Clone,
    centroid: Vec3,
    normal: Vec3,
) -> Option<f64> {
    let (c, n) = (centroid.as_dvec3(), normal.as_dvec3());
    let sample = |p: Vec3| {
        let d = p.as_dvec3() - c;
        let s = d.dot(n);
        (s, (d.length_squared() - s * s).max(0.0))
    };
    let (mut count, mut ms, mut mr) = (0.0f64, 0.0f64, 0.0f64);
    for p in points.clone() {
        let (s, r2) = sample(p);
        count += 1.0;
        ms += s;
        mr += r2;
    }
    if count < 2.0 {
        return None;
    }
    (ms, mr) = (ms / count, mr / count);
    let (mut cov, mut var) = (0.0f64, 0.0f64);
    for p in points {
        let (s, r2) = sample(p);
        cov += (s - ms) * (r2 - mr);
        var += (r2 - mr) * (r2 - mr);
    }
    if !(var > 1e-10 * mr * mr) {
        return None;
    }
    let k = cov / var;
    Some(ms - k * mr)
}

/// Largest tangent of the half field of view of a cluster camera (about
/// 87 degrees); wider clusters fall back ([`ClusterFallback::TooWide`]).
pub const MAX_TAN: f32 = 20.0;

/// A cluster camera or the reason there is none.
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)] // returned by value once per cluster
pub enum ClusterView {
    /// Render the depth image with this camera.
    Camera(ClusterCamera),
    /// Fall back for every pixel of the cluster.
    Fallback(ClusterFallback),
}

/// A 2D axis-aligned box.
#[derive(Clone, Copy, Debug)]
struct Box2 {
    lo: Vec2,
    hi: Vec2,
}

impl Box2 {
    const EMPTY: Box2 = Box2 {
        lo: Vec2::splat(f32::INFINITY),
        hi: Vec2::splat(f32::NEG_INFINITY),
    };
    fn grow(&mut self, p: Vec2) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }
    fn diagonal(&self) -> f32 {
        if self.lo.x > self.hi.x {
            0.0
        } else {
            (self.hi - self.lo).length()
        }
    }
}

/// The unit mirror direction of the view ray `eye -> p` at normal `n`
/// (turned toward the eye): the mirror pass's ray generation
/// (`crate::ssr`, module docs, steps 2 and 3), shared by every pass.
#[inline]
pub(super) fn reflected(eye: Vec3, p: Vec3, n: Vec3) -> Option<Vec3> {
    crate::ssr::reflect_view(eye, p, n).map(|(_, dir)| dir)
}

/// Image-plane frame: origin `P_c`, unit normal `n`, in-plane axes `u, v`.
#[derive(Clone, Copy, Debug)]
struct Frame {
    c: Vec3,
    n: Vec3,
    u: Vec3,
    v: Vec3,
}

impl Frame {
    fn height(&self, p: Vec3) -> f32 {
        (p - self.c).dot(self.n)
    }
    fn coords(&self, p: Vec3) -> Vec2 {
        let d = p - self.c;
        Vec2::new(d.dot(self.u), d.dot(self.v))
    }
    /// The central projection from `e` (below the plane, height `-he < 0`)
    /// of `p` onto the plane, in plane coordinates; `None` when `p` is not
    /// above the eye.
    fn project_from(&self, e: Vec3, he: f32, p: Vec3) -> Option<Vec2> {
        let hp = self.height(p);
        let denom = hp + he;
        if !(denom > 1e-12 * he.max(1.0)) {
            return None;
        }
        let s = he / denom;
        Some(self.coords(e + (p - e) * s))
    }
}

/// The cone-boundary directions of half-angle `alpha` around `r`, scaled
/// out by `1 / cos(pi / 8)` so that the octagon they span circumscribes
/// the cone's circle.
fn cone_octagon(r: Vec3, alpha: f32) -> [Vec3; 8] {
    let (t, b) = r.any_orthonormal_pair();
    let radius = libm::tanf(alpha) / libm::cosf(core::f32::consts::PI / 8.0);
    let mut out = [r; 8];
    for (k, o) in out.iter_mut().enumerate() {
        let a = k as f32 * core::f32::consts::FRAC_PI_4;
        *o = (r + (t * libm::cosf(a) + b * libm::sinf(a)) * radius).normalize();
    }
    out
}

/// The cluster camera of seed 003 Sec. 3.3 for the pixels `pixels`
/// (indices `y * width + x` into `input`, e.g. one range of
/// [`try_cluster_ranges`](super::try_cluster_ranges)) seen from `eye`.
///
/// 1. Image plane through the centroid `P_c` with the normalized mean
///    normal `n_c` (steps 1a, 1b).
/// 2. Far plane parallel to it at distance `D` on the eye's side (step 2).
/// 3. `e_0` = `eye` mirrored over the image plane (step 3a); `e_c = P_c +
///    f (e_0 - P_c)` (step 3b). Erratum (design.md): the seed prints
///    `e_c = e_0 + (P_c - e_0) f`, which puts the eye on the cluster for
///    `f = 1`; the text ("f becomes 1, which implies that e_c is set to
///    e_0", "0 < f < 1 moves e_c from e_0 towards P_c") fixes the form used
///    here. `f = d_n (d_F - d_f) / (d_f (d_F - d_n))` (Eq. 1) with `d_n`,
///    `d_f` the diagonals of the boxes of the near (surface points) and far
///    (far-plane) ray endpoints projected from `e_0` onto the image plane
///    and `d_F` that of the far endpoints themselves. Under the model the
///    equation assumes (the far box scales with `h / (h + D)` for an eye at
///    height `h` below the plane) this makes the far box as large as the
///    near one.
/// 4. The image frame holds the near and far endpoints seen from `e_c`
///    (glossy cones widened, Sec. 3.5 item 1). [`Camera`] is a symmetric
///    pinhole, so the frame is the smallest symmetric frustum that holds
///    every endpoint, in the cheaper (fewer texels) of two orientations:
///    (A) around the mean direction from `e_c` to the endpoints, rows
///    aligned with the output image's rows (ideal for planar clusters: the
///    mirrored view); (B) looking along `n_c` through the image plane, the
///    seed's image plane made symmetric about the eye's foot point, which
///    holds any frame however wide (clusters whose eye lies close to the
///    plane). Near endpoints below the clip plane are replaced by the ray's
///    crossing of it (the depth image holds nothing below).
/// 5. The texel size (in tangent units) is the mean distance between the
///    projections of horizontally adjacent cluster pixels' points, or of
///    their mirror rays' far endpoints if those are closer (diverging rays
///    of convex clusters), (if no pixels are adjacent: the frame's area per
///    pixel), divided by
///    [`ClusterCameraOptions::resolution_scale`]; at most
///    [`ClusterCameraOptions::max_resolution`] texels a side.
///
/// The clip plane ([`ClusterCamera::clip`]) is the image plane for a planar
/// cluster, else the parallel plane through the cluster point farthest in
/// front of it, so that the reflector's own cluster surface is not drawn.
///
/// Defined outcomes of the degenerate cases:
/// * fewer than `min_pixels` pixels (one-pixel clusters among them):
///   [`ClusterFallback::TooFewPixels`];
/// * mean normal zero or facing away from the eye, or the eye on the image
///   plane: [`ClusterFallback::FacesAway`];
/// * planar cluster (every point on the plane and every normal equal to
///   `n_c`, within 1e-5): `f = 1` exactly and the camera eye is `e_0`
///   exactly (Eq. 1 is 0/0 there);
/// * `d_f = 0` (the far endpoints project to one point) or
///   `|d_f - d_n| <= 1e-6 d_f`: `f = 1`;
/// * `d_F <= d_n` (Eq. 1's denominator not positive): `f = max_f`;
/// * otherwise `f` is clamped to `[1 / max_f, max_f]`;
/// * pixels whose reflected ray does not rise above the image plane are
///   left out of steps 3-5; if none remain: [`ClusterFallback::NoRays`];
/// * endpoints beyond a half field of view of `atan(`[`MAX_TAN`]`)` in
///   orientation A and of `atan(`[`MAX_TAN_PLANE`]`)` in B:
///   [`ClusterFallback::TooWide`].
///
/// # Errors
/// [`Error::InvalidArgument`] for invalid `options`, a non-finite `eye`,
/// mismatched input views, a pixel index outside the image, or a listed
/// pixel with a non-finite position or a normal that is not unit length
/// (within 1e-2); [`Error::DegenerateGeometry`] if the resulting camera is
/// not representable (e.g. coordinates overflowing f32).
///
/// # Panics
/// Never.
pub fn try_cluster_camera(
    input: &ClusterInput<'_>,
    pixels: &[u32],
    eye: Vec3,
    options: &ClusterCameraOptions,
) -> Result<ClusterView, Error> {
    options.validate()?;
    if !eye.is_finite() {
        return Err(Error::InvalidArgument);
    }
    input.validate(pixels)?;
    cluster_camera(input, pixels, eye, options)
}

/// [`try_cluster_camera`] after its checks, over any [`Surfaces`] (the
/// cluster pass reads its G-buffer).
pub(crate) fn cluster_camera(
    input: &impl Surfaces,
    pixels: &[u32],
    eye: Vec3,
    options: &ClusterCameraOptions,
) -> Result<ClusterView, Error> {
    if (pixels.len() as u64) < u64::from(options.min_pixels) {
        return Ok(ClusterView::Fallback(ClusterFallback::TooFewPixels));
    }
    // Step 1, in f64 (sums over many pixels).
    let (mut sp, mut sn) = (DVec3::ZERO, DVec3::ZERO);
    for &p in pixels {
        let (pos, n) = input.at(p).ok_or(Error::InvalidArgument)?;
        sp += pos.as_dvec3();
        sn += n.as_dvec3();
    }
    let count = pixels.len() as f64;
    let pc_d = sp / count;
    let Some(nc_d) = sn.try_normalize() else {
        return Ok(ClusterView::Fallback(ClusterFallback::FacesAway));
    };
    let eye_d = eye.as_dvec3();
    let h_eye = (eye_d - pc_d).dot(nc_d);
    let scale = (eye_d - pc_d).length().max(1e-30);
    if !(h_eye > 1e-6 * scale) {
        return Ok(ClusterView::Fallback(ClusterFallback::FacesAway));
    }
    // Step 3a: e_0 = e - 2 h n (f64, rounded once).
    let e0_d = eye_d - 2.0 * h_eye * nc_d;
    let (pc, nc, e0) = (pc_d.as_vec3(), nc_d.as_vec3(), e0_d.as_vec3());
    let (u, v) = nc.any_orthonormal_pair();
    let frame = Frame { c: pc, n: nc, u, v };
    let d_far = options.far_distance;

    // Planarity and the near/far boxes from e_0.
    let tol = 1e-5f32;
    let mut extent = 0.0f32;
    for &p in pixels {
        let (pos, _) = input.at(p).ok_or(Error::InvalidArgument)?;
        extent = extent.max((pos - pc).length());
    }
    let (mut box_n, mut box_f, mut box_big_f) = (Box2::EMPTY, Box2::EMPTY, Box2::EMPTY);
    let (mut planar, mut used) = (true, 0u32);
    let mut s_max = f32::NEG_INFINITY;
    let h0 = h_eye as f32;
    for &p in pixels {
        let (pos, n) = input.at(p).ok_or(Error::InvalidArgument)?;
        let s = frame.height(pos);
        if !(s.abs() <= tol * extent.max(1e-30) && (n - nc).length() <= tol) {
            planar = false;
        }
        let Some(r) = reflected(eye, pos, n) else {
            continue;
        };
        let rn = r.dot(nc);
        if !(rn > 1e-6) || !(s < d_far) {
            continue;
        }
        let q = pos + r * ((d_far - s) / rn);
        let (Some(pn), Some(pf)) = (
            frame.project_from(e0, h0, pos),
            frame.project_from(e0, h0, q),
        ) else {
            continue;
        };
        box_n.grow(pn);
        box_f.grow(pf);
        box_big_f.grow(frame.coords(q));
        s_max = s_max.max(s);
        used += 1;
    }
    if used == 0 {
        return Ok(ClusterView::Fallback(ClusterFallback::NoRays));
    }
    let (d_n, d_f, d_big_f) = (box_n.diagonal(), box_f.diagonal(), box_big_f.diagonal());
    let f = if planar || !(d_f > 0.0) || (d_f - d_n).abs() <= 1e-6 * d_f {
        1.0
    } else if !(d_big_f - d_n > 0.0) {
        options.max_f
    } else {
        let f =
            f64::from(d_n) * f64::from(d_big_f - d_f) / (f64::from(d_f) * f64::from(d_big_f - d_n));
        (f as f32).clamp(1.0 / options.max_f, options.max_f)
    };
    let e_c = if f == 1.0 {
        e0
    } else {
        (pc_d + f64::from(f) * (e0_d - pc_d)).as_vec3()
    };
    let h_c = -frame.height(e_c);
    if !(h_c > 0.0) {
        return Err(Error::DegenerateGeometry);
    }

    // Step 4: the frame. Our Camera is a symmetric pinhole, so the frame is
    // the smallest symmetric frustum around the mean direction from e_c to
    // the near and far ray endpoints (glossy cones included) that holds
    // every endpoint; its rows follow the output image's rows (the mean
    // direction of the lower rows minus that of the upper rows is "down").
    let alpha = options.cone_half_angle;
    let s_clip = if planar { 0.0 } else { s_max.max(0.0) };
    let visit = |visit_point: &mut dyn FnMut(Vec3)| {
        for &p in pixels {
            let Some((pos, n)) = input.at(p) else {
                continue;
            };
            let s = frame.height(pos);
            let Some(r) = reflected(eye, pos, n) else {
                continue;
            };
            let rn = r.dot(nc);
            if !(rn > 1e-6) || !(s < d_far) {
                continue;
            }
            // The near endpoint: where the ray crosses the clip plane (the
            // depth image holds nothing below it), or the point itself.
            let lift = s_clip - s;
            visit_point(if lift > 0.0 {
                pos + r * (lift / rn)
            } else {
                pos
            });
            let far_point = |d: Vec3| {
                let dn = d.dot(nc);
                (dn > 1e-6).then(|| pos + d * ((d_far - s) / dn))
            };
            if let Some(q) = far_point(r) {
                visit_point(q);
            }
            if alpha > 0.0 {
                for d in cone_octagon(r, alpha) {
                    // A cone direction that does not rise above the image
                    // plane sees nothing the depth image keeps.
                    if let Some(q) = far_point(d) {
                        visit_point(q);
                    }
                }
            }
        }
    };
    let mut mean_dir = DVec3::ZERO;
    visit(&mut |q: Vec3| {
        if let Some(d) = (q - e_c).try_normalize() {
            mean_dir += d.as_dvec3();
        }
    });
    let Some(axis) = mean_dir.try_normalize().map(|d| d.as_vec3()) else {
        return Ok(ClusterView::Fallback(ClusterFallback::NoRays));
    };
    let width = input.width();
    let mean_y = pixels.iter().map(|&p| f64::from(p / width)).sum::<f64>() / count;
    let mut down = DVec3::ZERO;
    for &p in pixels {
        if let Some((pos, _)) = input.at(p) {
            if let Some(d) = (pos - e_c).try_normalize() {
                down += d.as_dvec3() * (f64::from(p / width) - mean_y);
            }
        }
    }
    let down = down.as_vec3();
    let up_raw = -(down - axis * down.dot(axis));
    let up = if up_raw.length_squared() > 1e-12 * down.length_squared().max(1e-30) {
        up_raw.normalize()
    } else if v.cross(axis).length_squared() > 1e-6 {
        v
    } else {
        u
    };
    // Two orientations: (A) around the mean direction, rows along the
    // output's rows; (B) looking along the mean normal through the image
    // plane, the frame centered on the eye's foot point (the seed's image
    // plane, made symmetric): B holds any frame, however wide, and suits
    // clusters whose eye is close to the plane. The one with fewer texels
    // wins.
    let up_b = {
        let t = up - nc * up.dot(nc);
        if t.length_squared() > 1e-6 {
            t.normalize()
        } else {
            v
        }
    };
    let fa = fit(&visit, input, pixels, eye, e_c, up, axis, MAX_TAN, options)?;
    let fb = fit(
        &visit,
        input,
        pixels,
        eye,
        e_c,
        up_b,
        nc,
        MAX_TAN_PLANE,
        options,
    )?;
    let chosen = match (fa, fb) {
        (Some(a), Some(b)) => {
            if a.texels() <= b.texels() {
                a
            } else {
                b
            }
        }
        (Some(a), None) => a,
        (None, Some(b)) => b,
        (None, None) => return Ok(ClusterView::Fallback(ClusterFallback::TooWide)),
    };
    let Fit {
        probe,
        tx,
        ty,
        zmin,
        zmax,
        texel,
    } = chosen;
    // A frame of one direction grows to one texel.
    let (tx, ty) = (tx.max(0.5 * texel), ty.max(0.5 * texel));
    let max_res = options.max_resolution as f32;
    let res = |t: f32| libm::ceilf((2.0 * t / texel).min(max_res)).max(1.0);
    let (wf, hf) = (res(tx), res(ty));
    let tan_y = ty.max(tx * hf / wf);
    let fov_y = 2.0 * libm::atanf(tan_y);
    let near = 0.5 * zmin;
    let far = (zmax * 1.001).max(near * 2.0);
    let camera = Camera::try_new(probe.view(), fov_y, near, far, wf as u32, hf as u32)
        .map_err(|_| Error::DegenerateGeometry)?;
    let clip = ClipPlane {
        normal: nc,
        point: pc + nc * s_clip,
    };
    // Sec. 4.4: the cluster's center behind its image plane.
    let points = pixels
        .iter()
        .filter_map(|&p| input.at(p).map(|(pos, _)| pos));
    let concave = !planar
        && center_height(points, pc, nc)
            .is_some_and(|a| a < -f64::from(CONCAVE_TOLERANCE) * f64::from(extent));
    Ok(ClusterView::Camera(ClusterCamera {
        camera,
        clip,
        centroid: pc,
        normal: nc,
        eye0: e0,
        f,
        diagonals: [d_n, d_f, d_big_f],
        planar,
        concave,
        far_distance: d_far,
        pixels_used: used,
    }))
}

/// Calls its argument with every ray endpoint a cluster frame must hold.
type Visitor<'a> = dyn Fn(&mut dyn FnMut(Vec3)) + 'a;

/// A candidate frustum: orientation, tangent half-extents, depth range of
/// the endpoints and texel size (tangent units).
#[derive(Clone, Copy, Debug)]
struct Fit {
    probe: Camera,
    tx: f32,
    ty: f32,
    zmin: f32,
    zmax: f32,
    texel: f32,
}

impl Fit {
    fn texels(&self) -> f32 {
        let t = self.texel.max(1e-30);
        (2.0 * self.tx / t).max(1.0) * (2.0 * self.ty / t).max(1.0)
    }
}

/// Widest half field of view (tangent) of a frustum looking along the
/// cluster normal (orientation B of [`try_cluster_camera`]).
pub const MAX_TAN_PLANE: f32 = 1000.0;

/// The frustum from `e_c` along `axis` (with `up`) holding every endpoint
/// `visit` yields, and the texel size of step 5: the mean distance between
/// the projections of horizontally adjacent cluster pixels' points and that
/// of their mirror rays' far endpoints, the smaller of the two (the far
/// endpoints of a convex cluster spread faster), divided by the resolution
/// scale. `None` if an endpoint is behind the eye or beyond `max_tan`.
#[allow(clippy::too_many_arguments)]
fn fit(
    visit: &Visitor<'_>,
    input: &impl Surfaces,
    pixels: &[u32],
    eye: Vec3,
    e_c: Vec3,
    up: Vec3,
    axis: Vec3,
    max_tan: f32,
    options: &ClusterCameraOptions,
) -> Result<Option<Fit>, Error> {
    let up = if up.cross(axis).length_squared() > 1e-8 {
        up
    } else {
        axis.any_orthonormal_vector()
    };
    let probe = Camera::try_look_at(e_c, e_c + axis, up, 1.0, 1.0, 2.0, 1, 1)
        .map_err(|_| Error::DegenerateGeometry)?;
    let (mut tx, mut ty, mut zmin, mut zmax) = (0.0f32, 0.0f32, f32::INFINITY, 0.0f32);
    let mut behind = false;
    visit(&mut |q: Vec3| {
        let c = probe.world_to_view(q);
        let z = -c.z;
        if !(z > 0.0) {
            behind = true;
            return;
        }
        tx = tx.max((c.x / z).abs());
        ty = ty.max((c.y / z).abs());
        zmin = zmin.min(z);
        zmax = zmax.max(z);
    });
    if behind || !(tx <= max_tan && ty <= max_tan) || !(zmin <= zmax) {
        return Ok(None);
    }
    let tangent = |q: Vec3| {
        let c = probe.world_to_view(q);
        Vec2::new(c.x, c.y) / (-c.z)
    };
    let width = input.width();
    let far_end = |pos: Vec3, n: Vec3| -> Option<Vec3> {
        let r = reflected(eye, pos, n)?;
        (r.dot(axis) > 1e-6).then_some(pos + r * options.far_distance)
    };
    let (mut near_sp, mut far_sp) = ((0.0f64, 0u32), (0.0f64, 0u32));
    for pair in pixels.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        if a + 1 != b || b % width == 0 {
            continue;
        }
        let (Some((pa, na)), Some((pb, nb))) = (input.at(a), input.at(b)) else {
            continue;
        };
        let d = (tangent(pb) - tangent(pa)).length();
        if d.is_finite() && d > 0.0 {
            near_sp.0 += f64::from(d);
            near_sp.1 += 1;
        }
        if let (Some(qa), Some(qb)) = (far_end(pa, na), far_end(pb, nb)) {
            let (ta, tb) = (tangent(qa), tangent(qb));
            let d = (tb - ta).length();
            if d.is_finite()
                && d > 0.0
                && (probe.world_to_view(qa).z < 0.0)
                && (probe.world_to_view(qb).z < 0.0)
            {
                far_sp.0 += f64::from(d);
                far_sp.1 += 1;
            }
        }
    }
    let mean = |s: (f64, u32)| (s.1 > 0).then(|| (s.0 / f64::from(s.1)) as f32);
    let texel = match (mean(near_sp), mean(far_sp)) {
        (Some(a), Some(b)) => a.min(b),
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => {
            libm::sqrtf((2.0 * tx).max(1e-30) * (2.0 * ty).max(1e-30) / pixels.len() as f32)
        }
    };
    Ok(Some(Fit {
        probe,
        tx,
        ty,
        zmin,
        zmax,
        texel: (texel / options.resolution_scale).max(1e-30),
    }))
}
