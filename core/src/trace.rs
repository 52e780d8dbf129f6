//! Shared vocabulary of the ray / depth-image kernels: the depth image a ray
//! is traced against, surface thickness, the hit/miss result and the work
//! counters. Used by per-pixel stepping (the `step` module, feature
//! `depth-image`, seed 003 Sec. 3.4) and Hi-Z traversal (the `hiz` module,
//! feature `hiz`, seed 004 Sec. 4.4.1).
//!
//! Contract shared by every kernel that returns a [`Trace`]:
//! * the ray is a world-space [`Ray`] with a unit direction and a maximum
//!   distance `t_max` (`+inf` allowed: the far plane ends it);
//! * the depth image is the front-most surface seen by its camera, in one of
//!   the three [`DepthConvention`]s;
//! * a ray point "hits" texel `(x, y)` when its linear depth `z` lies in
//!   `[z_front, z_front + thickness]` (constant thickness) or in
//!   `[z_front, z_back]` (back-face image), where `z_front`/`z_back` are the
//!   texel's decoded linear depths;
//! * results are explicit: a [`DepthHit`] or a [`Miss`] with its reason,
//!   each with the [`Work`] spent, never a sentinel NaN.
//!
//! # Example
//! A hit of the stepping kernel (`step`, feature `depth-image`) refined to
//! sub-texel precision.
//! ```rust
//! # #[cfg(feature = "depth-image")] {
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::step::{try_step, StepOptions};
//! use refl_core::trace::refine_hit;
//! use refl_core::{Camera, DepthConvention, DepthImage, ImageView, Ray, Thickness, Trace};
//!
//! // A 16 x 16 [0, 1] depth image of the slanted wall z = -4 - x / 2 (the view
//! // ray (s_x, s_y, -1) meets it at linear depth 4 / (1 - s_x / 2)).
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 0.5, 100.0, 16, 16)?;
//! let wall = |s_x: f32| 4.0 / (1.0 - 0.5 * s_x);
//! let depth: Vec<f32> = (0..256)
//!     .map(|i| cam.encode_depth(wall(((i % 16) as f32 + 0.5) / 8.0 - 1.0), DepthConvention::ZeroToOne))
//!     .collect();
//! let image = DepthImage::try_new(ImageView::try_new(&depth, 16, 16, 16)?, cam, DepthConvention::ZeroToOne)?;
//! assert!((image.linear_at(0, 3).unwrap() - wall(-15.0 / 16.0)).abs() < 1e-4);
//!
//! // A ray toward the wall point Q seen through pixel position (5.2, 7.7).
//! let q = cam.unproject(Vec2::new(5.2, 7.7), wall(5.2 / 8.0 - 1.0), DepthConvention::Linear);
//! let origin = Vec3::new(1.0, 1.0, -1.0);
//! let ray = Ray { origin, dir: (q - origin).normalize() };
//! let opts = StepOptions { stride: 1, max_steps: 64 };
//! let Trace::Hit(hit) = try_step(&image, Thickness::Constant(0.2), ray, f32::INFINITY, opts)? else {
//!     panic!("the ray reaches the wall");
//! };
//! // Texels are flat plates; refinement fits the wall's plane and lands on Q.
//! let fine = refine_hit(&image, &ray, f32::INFINITY, &hit);
//! assert!((fine.pixel - Vec2::new(5.2, 7.7)).length() < 1e-2);
//! assert!((fine.t - (q - origin).length()).abs() < 1e-3);
//! assert!(fine.work.fetches > hit.work.fetches);
//! # }
//! # Ok::<(), refl_core::Error>(())
//! ```

use crate::{Camera, DepthConvention, Error, ImageView, Ray};
use glam::Vec2;

/// A depth image with the camera that rendered it and its convention.
///
/// The image size must equal the camera's; texel `(x, y)` holds the stored
/// depth of the surface seen through pixel center `(x + 0.5, y + 0.5)`.
#[derive(Clone, Copy, Debug)]
pub struct DepthImage<'a> {
    depth: ImageView<'a, f32>,
    camera: Camera,
    convention: DepthConvention,
}

impl<'a> DepthImage<'a> {
    /// Binds a depth view to its camera and convention.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if the view's size differs from the
    /// camera's.
    pub fn try_new(
        depth: ImageView<'a, f32>,
        camera: Camera,
        convention: DepthConvention,
    ) -> Result<Self, Error> {
        if depth.width() != camera.width() || depth.height() != camera.height() {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            depth,
            camera,
            convention,
        })
    }

    /// The stored depths.
    pub const fn depth(&self) -> &ImageView<'a, f32> {
        &self.depth
    }

    /// The camera that rendered the image.
    pub const fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The convention of the stored depths.
    pub const fn convention(&self) -> DepthConvention {
        self.convention
    }

    /// Width in pixels.
    pub const fn width(&self) -> u32 {
        self.depth.width()
    }

    /// Height in pixels.
    pub const fn height(&self) -> u32 {
        self.depth.height()
    }

    /// Linear depth of texel `(x, y)`, or `None` outside the image. A stored
    /// NaN decodes to NaN, which every kernel treats as "no surface".
    #[inline]
    pub fn linear_at(&self, x: u32, y: u32) -> Option<f32> {
        self.depth
            .get(x, y)
            .map(|d| self.camera.decode_depth(d, self.convention))
    }
}

/// How far behind the front-most surface a ray may pass and still hit it.
#[derive(Clone, Copy, Debug)]
pub enum Thickness<'a> {
    /// Every surface is this thick, in linear depth (world units along the
    /// view axis). `0` means an infinitely thin shell; `+inf` means
    /// everything behind a surface is solid.
    Constant(f32),
    /// A back-face depth image (same size, camera and convention as the
    /// front image): the ray hits where its depth lies between the two.
    /// A back texel that decodes behind its front texel is used as it
    /// decodes, the cleared value (far plane, `+inf`) included, so a
    /// surface with nothing behind it in the back-face pass (a one-sided
    /// floor or wall) is solid to the far plane; a NaN back texel, or one
    /// at or in front of its front texel, makes a zero-thick shell. Every
    /// kernel reads it so.
    BackFaces(ImageView<'a, f32>),
}

/// Work a kernel spent on one ray, for measuring cost in counts rather than
/// time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Work {
    /// Pixel (or cell) steps along the projected ray.
    pub steps: u32,
    /// Depth texels read, pyramids and back-face images included.
    pub fetches: u32,
    /// Loop iterations of a hierarchical traversal (0 for stepping).
    pub iterations: u32,
}

/// A ray / depth-image intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthHit {
    /// Sub-pixel position of the hit in the depth image (pixels, origin
    /// top-left; the texel hit is `pixel.floor()`).
    pub pixel: Vec2,
    /// Ray parameter of the hit (world distance from the origin).
    pub t: f32,
    /// Linear depth of the hit point on the ray.
    pub depth: f32,
    /// Linear depth stored in the image at the texel hit.
    pub surface_depth: f32,
    /// Work spent.
    pub work: Work,
}

/// Why a ray found no surface in the depth image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Miss {
    /// The projected ray left the image rectangle before hitting anything.
    LeftImage,
    /// The ray passed behind geometry (deeper than its thickness) and can no
    /// longer be resolved from this image: what it hits is not visible.
    BehindGeometry,
    /// The kernel's step or iteration cap was reached.
    OutOfSteps,
    /// The ray ended (`t_max` or the far plane) in front of every surface.
    EndOfRay,
    /// Nothing of the ray projects into the view: it lies entirely behind
    /// the near plane, or its clipped segment is empty.
    DegenerateProjection,
}

/// The result of tracing one ray against a depth image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Trace {
    /// The ray hit the depth image.
    Hit(DepthHit),
    /// The ray missed, and why.
    Miss {
        /// The reason.
        reason: Miss,
        /// Work spent before giving up.
        work: Work,
    },
}

impl Trace {
    /// The hit, if any.
    pub const fn hit(&self) -> Option<&DepthHit> {
        match self {
            Trace::Hit(h) => Some(h),
            Trace::Miss { .. } => None,
        }
    }

    /// The work spent, hit or miss.
    pub const fn work(&self) -> Work {
        match self {
            Trace::Hit(h) => h.work,
            Trace::Miss { work, .. } => *work,
        }
    }
}

/// Largest relative difference between a hit's depth from its screen
/// parameter (`1 / q(s)`, the interpolated inverse depth) and the depth the
/// texel test found (the boundary the ray crossed, or its depth at the
/// texel's entry) that the stepping and Hi-Z hits still take as resolved.
/// Rounding alone stays near `1e-6`; the difference grows as
/// `z (q_a - q_b) 2^-24` toward a vanishing point.
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub(crate) const RESOLVED_DEPTH: f32 = 1e-3;

/// Validates a ray and its maximum distance for a depth-image kernel.
///
/// # Errors
/// [`Error::InvalidArgument`] for a non-finite origin or direction, a
/// direction whose length differs from 1 by more than 1e-3, or a `t_max`
/// that is NaN or not positive (`+inf` is allowed).
pub fn try_validate_ray(ray: &Ray, t_max: f32) -> Result<(), Error> {
    if !ray.origin.is_finite()
        || !ray.dir.is_finite()
        || !((ray.dir.length_squared() - 1.0).abs() <= 2e-3)
        || !(t_max > 0.0)
    {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

/// Largest relative linear-depth jump between neighboring texels that
/// [`refine_hit`] still treats as one continuous surface.
pub const REFINE_CONTINUITY: f32 = 0.10;

/// Relative tolerance of the planarity test of [`refine_hit`]: neighbors
/// `a`, `b` on both sides of a texel `c` lie on one plane with it when
/// `|1/z_a + 1/z_b - 2/z_c| <= REFINE_PLANARITY |1/z_b - 1/z_a|`.
pub const REFINE_PLANARITY: f32 = 0.1;

/// Most plane fits [`refine_hit`] makes: when the ray meets a texel's plane
/// outside the 3x3 texels around it, the fit moves to the texel it met and
/// tries again.
pub const REFINE_ROUNDS: u32 = 4;

/// Sub-texel refinement of a hit: the kernels test the ray against each
/// texel as a flat plate at its center's depth, so on a surface seen at a
/// grazing angle the ray meets a plate up to half a texel's depth change
/// before (or after) the surface, which moves the hit along the ray by
/// several pixels. This fits the surface around the hit texel with the
/// plane through the texel's center point and one continuous neighbor per
/// axis (the world points of the texel centers, [`Camera::unproject`]) and
/// intersects the ray with it: seed 003 Sec. 3.4's intersection in a depth
/// measure that is linear in screen space, with the image's depth
/// interpolated between texel centers where the surface is continuous and
/// not across silhouettes (neighbors whose linear depth differs by more than
/// [`REFINE_CONTINUITY`] relative are not used).
///
/// The refined hit replaces `hit` only if it lies within `[0, t_max]` on
/// the ray and projects into the 3x3 texels around the texel whose plane it
/// came from (after at most [`REFINE_ROUNDS`] fits, each on a texel whose
/// depth continues the previous plane); otherwise (no continuous neighbor
/// on an axis, a ray parallel to the plane, a point leaving the image or
/// the surface) `hit` is returned unchanged. `work.fetches` grows by the
/// texels read (at most 5 per round).
pub fn refine_hit(image: &DepthImage<'_>, ray: &Ray, t_max: f32, hit: &DepthHit) -> DepthHit {
    let mut out = *hit;
    let (w, h) = (image.width(), image.height());
    if !(hit.pixel.x >= 0.0 && hit.pixel.y >= 0.0) {
        return out;
    }
    let cam = image.camera();
    let center = |x: u32, y: u32, z: f32| {
        cam.unproject(
            Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
            z,
            DepthConvention::Linear,
        )
    };
    let mut fetches = 0u32;
    let (mut x, mut y) = (hit.pixel.x as u32, hit.pixel.y as u32);
    let mut expect: Option<f32> = None;
    let mut result = None;
    for _ in 0..REFINE_ROUNDS {
        fetches += 1;
        let Some(z0) = image.linear_at(x, y) else {
            break;
        };
        if !(z0 > 0.0 && z0.is_finite()) {
            break;
        }
        // A later round must land on the same continuous surface.
        if let Some(e) = expect {
            if !((z0 - e).abs() <= REFINE_CONTINUITY * e) {
                break;
            }
        }
        // Per axis, the surface direction: both neighbors when they lie on
        // one plane with the center (1/z is linear in screen space on a
        // plane), else the neighbor closer in depth if within
        // REFINE_CONTINUITY. Decided on the depths alone; only the texel
        // centers a direction uses are unprojected.
        let (xi, yi) = (i64::from(x), i64::from(y));
        let mut pick = |cands: [(i64, i64); 2]| -> (Pick, [(u32, u32, f32); 2]) {
            let mut zs = [(0u32, 0u32, f32::NAN); 2];
            for (k, (nx, ny)) in cands.into_iter().enumerate() {
                if nx < 0 || ny < 0 || nx >= i64::from(w) || ny >= i64::from(h) {
                    continue;
                }
                let (nx, ny) = (nx as u32, ny as u32);
                fetches += 1;
                if let Some(z) = image.linear_at(nx, ny) {
                    if z > 0.0 && z.is_finite() {
                        zs[k] = (nx, ny, z);
                    }
                }
            }
            (pick_tangent(z0, zs[0].2, zs[1].2), zs)
        };
        let (px, nxs) = pick([(xi - 1, yi), (xi + 1, yi)]);
        let (py, nys) = pick([(xi, yi - 1), (xi, yi + 1)]);
        if px == Pick::None || py == Pick::None {
            break;
        }
        let p0 = center(x, y, z0);
        let tangent = |p: Pick, n: [(u32, u32, f32); 2]| {
            let at = |k: usize| center(n[k].0, n[k].1, n[k].2);
            match p {
                Pick::Both => at(1) - at(0),
                Pick::Before => p0 - at(0),
                Pick::After | Pick::None => at(1) - p0,
            }
        };
        let (tx, ty) = (tangent(px, nxs), tangent(py, nys));
        let n = tx.cross(ty);
        let denom = n.dot(ray.dir);
        if !(denom.abs() > 1e-6 * n.length()) {
            break;
        }
        let t = n.dot(p0 - ray.origin) / denom;
        if !(t >= 0.0 && t <= t_max) {
            break;
        }
        let Some(q) = cam.project(ray.at(t)) else {
            break;
        };
        let (fx, fy) = (x as f32, y as f32);
        if q.x >= fx - 1.0 && q.x < fx + 2.0 && q.y >= fy - 1.0 && q.y < fy + 2.0 {
            result = Some((t, q));
            break;
        }
        // The plane's intersection lies farther away: fit again there.
        if !(q.x >= 0.0 && q.y >= 0.0 && q.x < w as f32 && q.y < h as f32) {
            break;
        }
        (x, y) = (q.x as u32, q.y as u32);
        expect = Some(q.z);
    }
    out.work.fetches = out.work.fetches.saturating_add(fetches);
    if let Some((t, q)) = result {
        out.pixel = Vec2::new(q.x.clamp(0.0, below(w)), q.y.clamp(0.0, below(h)));
        out.t = t;
        out.depth = q.z;
    }
    out
}

/// Which texel centers give [`refine_hit`]'s surface direction along one
/// axis.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Pick {
    /// Both neighbors (on one plane with the center).
    Both,
    /// The neighbor before the center, and the center.
    Before,
    /// The center, and the neighbor after it.
    After,
    /// No continuous neighbor.
    None,
}

/// [`refine_hit`]'s choice along one axis from linear depths: `z0` at the
/// center, `za` and `zb` at the neighbors before and after it (NaN where
/// there is none or its depth is not positive and finite). Both when the
/// three lie on one plane (`|1/za + 1/zb - 2/z0| <= REFINE_PLANARITY |1/zb -
/// 1/za| + 1e-4/z0`), else the neighbor closer in depth within
/// [`REFINE_CONTINUITY`] (`before` on a tie).
#[inline(always)]
fn pick_tangent(z0: f32, za: f32, zb: f32) -> Pick {
    if !za.is_nan() && !zb.is_nan() {
        let (ia, ib, i0) = (1.0 / za, 1.0 / zb, 1.0 / z0);
        if (ia + ib - 2.0 * i0).abs() <= REFINE_PLANARITY * (ib - ia).abs() + 1e-4 * i0 {
            return Pick::Both;
        }
    }
    let limit = REFINE_CONTINUITY * z0;
    let (da, db) = ((za - z0).abs(), (zb - z0).abs());
    // NaN distances fail both comparisons.
    match (da <= limit, db <= limit) {
        (true, true) if db < da => Pick::After,
        (true, _) => Pick::Before,
        (false, true) => Pick::After,
        (false, false) => Pick::None,
    }
}

/// The largest f32 below `n` (pixel coordinates stay inside the image).
fn below(n: u32) -> f32 {
    let f = n as f32;
    f32::from_bits(f.to_bits() - 1)
}

/// The ray parameter where the projection of `ray` into `camera` has moved
/// `pixels` pixels (Euclidean) from the projection of its origin: where a
/// screen-space reflection ray leaving a surface should start, so that the
/// texels it starts in (its own surface's) are not reported as hits.
///
/// A depth texel stores one depth for its whole footprint; a ray leaving a
/// surface that recedes from the camera runs behind the next texels of that
/// surface for about half a texel, so a kernel starting at `t = 0` reports
/// the reflector itself (self-intersection). Starting once the projection
/// has left the origin's texel, `pixels = 1`, removes these hits whatever
/// the thickness or the viewing angle (issue 13: a depth-slope offset left
/// thousands of self-hits with a thick shell, this rule none).
///
/// Closed form (perspective projection of a line): with the origin at view
/// depth `w0 > 0`, the depth changing by `wd` per unit `t`, and `K` the norm
/// of `w0 (du, dv) - wd (u0, v0)` for the view-plane pixel coordinates `u =
/// fx x`, `v = fy y`, the projected distance is `t K / (w0 (w0 + t wd))`,
/// increasing in `t` while `w0 + t wd > 0`; it reaches `pixels` at
/// `t = pixels w0^2 / (K - pixels w0 wd)`. Computed in f64.
///
/// Returns `None` if the origin is not in front of the camera (`w0 <= 0`),
/// if the inputs are not finite or `pixels` is negative, or if the
/// projection never moves that far: a ray receding toward its vanishing
/// point closer than `pixels` to the origin's projection (`K <= pixels w0
/// wd`), e.g. a ray along the line of sight.
///
/// # Examples
/// ```
/// use refl_core::{trace::ray_start_t, Camera, Ray};
/// use refl_core::glam::Vec3;
/// let cam = Camera::try_look_at(Vec3::new(0.0, 1.0, 5.0), Vec3::ZERO, Vec3::Y,
///     1.0, 0.1, 100.0, 64, 48).unwrap();
/// // A ray leaving the floor under the camera's view, to the right.
/// let ray = Ray { origin: Vec3::ZERO, dir: Vec3::X };
/// let t = ray_start_t(&cam, &ray, 1.0).unwrap();
/// let (p0, p1) = (cam.project(ray.origin).unwrap(), cam.project(ray.at(t)).unwrap());
/// assert!(((p1.x - p0.x).hypot(p1.y - p0.y) - 1.0).abs() < 1e-3);
/// ```
pub fn ray_start_t(camera: &Camera, ray: &Ray, pixels: f32) -> Option<f32> {
    RayStart::new(camera).t(ray, pixels)
}

/// The per-camera part of [`ray_start_t`], computed once: the view matrix
/// in f64 and the view-plane scales `fx`, `fy` (the same f64 tangents as
/// [`Camera::project`]). A pass builds one when it is prepared and calls
/// [`RayStart::t`] per ray, which returns exactly what [`ray_start_t`]
/// returns (it is [`ray_start_t`]'s body).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayStart {
    view: glam::DMat4,
    fx: f64,
    fy: f64,
}

impl RayStart {
    /// The constants of `camera`.
    pub fn new(camera: &Camera) -> Self {
        let (w, h) = (f64::from(camera.width()), f64::from(camera.height()));
        let tan_y = libm::tan(f64::from(camera.fov_y()) * 0.5);
        let tan_x = tan_y * w / h;
        Self {
            view: camera.view().as_dmat4(),
            fx: 0.5 * w / tan_x,
            fy: 0.5 * h / tan_y,
        }
    }

    /// [`ray_start_t`] for the camera this was built from: the smallest `t`
    /// at which `ray`'s projection has moved `pixels` pixels from its
    /// origin's, or `None` in the cases listed there.
    #[inline]
    pub fn t(&self, ray: &Ray, pixels: f32) -> Option<f32> {
        if !(pixels >= 0.0 && pixels.is_finite() && ray.origin.is_finite() && ray.dir.is_finite()) {
            return None;
        }
        let o = self.view.transform_point3(ray.origin.as_dvec3());
        let d = self.view.transform_vector3(ray.dir.as_dvec3());
        let (fx, fy) = (self.fx, self.fy);
        let (w0, wd) = (-o.z, -d.z);
        if !(w0 > 0.0) {
            return None;
        }
        let n = f64::from(pixels);
        let ku = fx * (w0 * d.x - wd * o.x);
        let kv = fy * (w0 * d.y - wd * o.y);
        let k = libm::sqrt(ku * ku + kv * kv);
        let den = k - n * w0 * wd;
        if !(den > 0.0) {
            return None;
        }
        let t = n * w0 * w0 / den;
        let t32 = t as f32;
        t32.is_finite().then_some(t32)
    }
}
