//! Reprojected ray casting for walkthroughs of static scenes (seed 002,
//! Havran, Bittner, Seidel: "Exploiting Temporal Coherence in Ray Casted
//! Walkthroughs").
//!
//! Every hit of the last frame is kept in a `POS` buffer (point, object,
//! signed distance; Sec. 3.1). Before the next frame they are reprojected
//! into an `AIP` buffer (object, smallest signed distance, count; Sec. 3.2,
//! Alg. 1) with a `(2r+1) x (2r+1)` splat; where the count of the closest
//! object reaches `m_cnt` the pixel's ray is tested against that one object
//! only, otherwise (or when that test misses) the host's ordinary ray
//! shooting algorithm (ORSA: full traversal) runs (Sec. 3.3, Alg. 2).
//!
//! This module does no ray tracing: it produces, per pixel, a [`Decision`]
//! ("test object `O` only" or "full traversal from distance `t`"), so that
//! the host's own tracer (Embree, a BVH, a GPU) intersects. Reprojection
//! errors are handled as in the paper:
//!
//! * view-frustum error (Sec. 4.1): [`frustum_contains`]; when the new eye
//!   lies outside the previous view pyramid nothing is reprojected;
//! * occlusion error (Sec. 4.2): points are reprojected in the
//!   occlusion-compatible order of the two [`Epipole`]s (four quadrants of
//!   the previous image, see [`Quadrants`]) and a point whose distance from
//!   the new epipole breaks that order on its epipolar line (records per
//!   angular bin of the lines, [`line_bins`]) behind a point nearer the
//!   camera ([`OCCLUDER_GAP`]) is discarded;
//! * undersampling (Sec. 4.3): regular resampling ([`resample_slot`]) and
//!   the abrupt-motion test (Sec. 4.3.1, [`EpipolarOptions::abrupt_frames`]);
//! * background (Sec. 5.2): empty pixels store a point of a camera-centered
//!   sphere with the reserved object [`BACKGROUND_OBJECT`]
//!   ([`PosEntry::background`]);
//! * shifted ray origin (Sec. 5.3): fallback rays may start at the AIP
//!   distance minus epsilon ([`EpipolarOptions::shift_origin`]).
//!
//! The method is conservative but not a proof: exactness rests on the
//! samples of the last frame (an object thinner than a pixel that was missed
//! can stay missed until regular resampling finds it, and the angular bins
//! of the occlusion records approximate the epipolar lines). Hosts
//! should measure visibility against full traversal, as the root package's
//! report does.
//!
//! All buffers belong to the caller: `POS` ([`PosEntry`], one per pixel of
//! the previous frame), `AIP` ([`AipEntry`], one per pixel of the new
//! frame) and the reprojection scratch ([`try_scratch_len`] floats).
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::epipolar::{decide, try_reproject, try_scratch_len, AipEntry, EpipolarOptions};
//! use refl_core::epipolar::{PosEntry, Reason, INVALID_OBJECT};
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::Camera;
//!
//! // Last frame: 8 x 8 rays from the origin down -Z all hit object 3, the wall z = -10.
//! let look = |z: f32| {
//!     let eye = Vec3::new(0.0, 0.0, z);
//!     Camera::try_look_at(eye, eye - Vec3::Z, Vec3::Y, FRAC_PI_2, 0.1, 100.0, 8, 8)
//! };
//! let previous = look(0.0)?;
//! let pos: Vec<PosEntry> = (0..64)
//!     .map(|i| previous.primary_ray(Vec2::new((i % 8) as f32 + 0.5, (i / 8) as f32 + 0.5)))
//!     .map(|ray| PosEntry::hit(ray.origin, ray.dir, -10.0 / ray.dir.z, 3))
//!     .collect();
//!
//! // The eye moves 0.5 forward (less than t / 2 / 9 for every point: no abrupt motion).
//! let (current, options) = (look(-0.5)?, EpipolarOptions::default());
//! let mut aip = vec![AipEntry::EMPTY; 64];
//! let mut scratch = vec![0.0f32; try_scratch_len(8, 8)?];
//! let stats = try_reproject(&mut aip, &mut scratch, &pos, &previous, &current, &options)?;
//! assert_eq!((stats.points, stats.splatted), (64, 64));
//! // Pixel (4, 4) receives the 3 x 3 points around it; the nearest, (+-1.25, +-1.25, -10),
//! // lies at sqrt(2 1.25^2 + 9.5^2) from the new eye.
//! let entry = aip[4 * 8 + 4];
//! assert_eq!((entry.object, entry.cnt, entry.flags), (3, 9, AipEntry::SURROUNDED));
//! assert!((entry.t - (2.0 * 1.25f32.powi(2) + 9.5f32.powi(2)).sqrt()).abs() < 1e-4);
//! // 9 >= m_cnt = 5: one ray/object test of object 3, except in the frame whose
//! // regular-resampling slot is the pixel's (slot 1 of 9 for (4, 4)).
//! let d = decide(&entry, 4, 4, 0, &options);
//! assert_eq!((d.object, d.reason), (3, Reason::Reprojected));
//! assert_eq!(decide(&entry, 4, 4, 1, &options).reason, Reason::Resampled);
//!
//! // Stepping back takes the eye out of the last view pyramid: no reprojection.
//! let stats = try_reproject(&mut aip, &mut scratch, &pos, &previous, &look(0.5)?, &options)?;
//! let d = decide(&aip[4 * 8 + 4], 4, 4, 0, &options);
//! assert!(stats.frustum_failed && d.object == INVALID_OBJECT && d.reason == Reason::Unavailable);
//! # Ok::<(), refl_core::Error>(())
//! ```

use crate::{Camera, Error, RowRange};
use glam::{DVec3, Vec2, Vec3};

/// Object id meaning "no object" (an unused POS or AIP entry).
pub const INVALID_OBJECT: u32 = u32::MAX;

/// Object id of the background sphere (seed 002 Sec. 5.2): a pixel that saw
/// no scene object stores a point of a camera-centered sphere enclosing the
/// scene under this id, so that background is reprojected like any object.
/// A [`Decision`] to "test" this object means: the pixel is background (the
/// ray always hits the sphere).
pub const BACKGROUND_OBJECT: u32 = u32::MAX - 1;

/// Largest supported splat radius ([`EpipolarOptions::splat_radius`]): a 7x7 kernel.
pub const MAX_SPLAT_RADIUS: u32 = 3;

/// One entry of the `POS` buffer (seed 002 Sec. 3.1): the point `P` a
/// pixel's ray hit, the object `O` it belongs to and the signed distance
/// `t` from the center of projection along the (unit) ray.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PosEntry {
    /// World-space hit point.
    pub point: [f32; 3],
    /// Object id; [`INVALID_OBJECT`] for "nothing stored" (the entry is
    /// skipped), [`BACKGROUND_OBJECT`] for a background-sphere point.
    pub object: u32,
    /// Signed distance from the eye to `point` along the ray.
    pub t: f32,
}

impl PosEntry {
    /// An unused entry: never reprojected.
    pub const INVALID: PosEntry = PosEntry {
        point: [0.0; 3],
        object: INVALID_OBJECT,
        t: f32::INFINITY,
    };

    /// The entry of a ray `origin + t dir` (unit `dir`) that hit `object` at
    /// distance `t`.
    pub fn hit(origin: Vec3, dir: Vec3, t: f32, object: u32) -> PosEntry {
        PosEntry {
            point: (origin + dir * t).to_array(),
            object,
            t,
        }
    }

    /// The entry of a ray that hit nothing: the point at distance `radius`
    /// on the camera-centered background sphere (seed 002 Sec. 5.2). Choose
    /// `radius` larger than any distance from the eye to the scene.
    pub fn background(origin: Vec3, dir: Vec3, radius: f32) -> PosEntry {
        PosEntry::hit(origin, dir, radius, BACKGROUND_OBJECT)
    }

    /// The world point as a vector.
    pub fn point(&self) -> Vec3 {
        Vec3::from_array(self.point)
    }
}

/// One entry of the `AIP` buffer (seed 002 Sec. 3.1 and Alg. 1): the object
/// `O` reprojected to the pixel, the smallest signed distance `t` of the
/// points reprojected to it, the count `cnt` of points of `O` that reached
/// it through the splat, and flags saying why points near it were
/// discarded.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AipEntry {
    /// Object id, or [`INVALID_OBJECT`] when no point reached the pixel.
    pub object: u32,
    /// Smallest signed distance from the new eye of the points splatted
    /// here; `+inf` when none.
    pub t: f32,
    /// Number of points of `object` splatted here.
    pub cnt: u32,
    /// Depth guard (our addition to Alg. 1, see [`EpipolarOptions::depth_guard`]):
    /// the smallest signed distance of a point of another object splatted
    /// here, or discarded by the occlusion check with its splat covering
    /// this pixel (or of `object` itself before it became the nearest,
    /// which only makes the guard stricter); `+inf` when none.
    pub t_other: f32,
    /// Bit set of [`AipEntry::NO_REPROJECTION`],
    /// [`AipEntry::OCCLUSION_REJECTED`], [`AipEntry::ABRUPT_REJECTED`] and
    /// the four [`AipEntry::SURROUNDED`] bits.
    pub flags: u32,
}

impl AipEntry {
    /// No reprojection ran for this frame (first frame, or the view-frustum
    /// check of Sec. 4.1 failed): every pixel takes the ORSA.
    pub const NO_REPROJECTION: u32 = 1;
    /// A point whose splat covers this pixel was discarded by the occlusion
    /// check (Sec. 4.2).
    pub const OCCLUSION_REJECTED: u32 = 2;
    /// A point whose splat covers this pixel was discarded by the
    /// abrupt-motion test (Sec. 4.3.1).
    pub const ABRUPT_REJECTED: u32 = 4;
    /// First of the four surround bits (our addition to Alg. 1, used by
    /// [`EpipolarOptions::depth_guard`]): bit `SURROUND_UP_LEFT << q` is set when a
    /// splatted point of `object` landed in quadrant `q` around the pixel
    /// center (`q = (dx >= 0) + 2 (dy >= 0)` for the point's offset
    /// `(dx, dy)` from the center). The bits restart when a closer object
    /// overwrites the entry.
    pub const SURROUND_UP_LEFT: u32 = 16;
    /// All four surround bits: points of `object` landed on every side of
    /// the pixel center, so the center lies inside their hull (no
    /// silhouette of `object` passes between them and the center).
    pub const SURROUNDED: u32 = 0xF0;

    /// The initial entry of Alg. 1: no object, `t = inf`, `cnt = 0`.
    pub const EMPTY: AipEntry = AipEntry {
        object: INVALID_OBJECT,
        t: f32::INFINITY,
        cnt: 0,
        t_other: f32::INFINITY,
        flags: 0,
    };

    /// The entry of a frame without reprojection (see
    /// [`AipEntry::NO_REPROJECTION`]); what a host stores before its first
    /// frame.
    pub const UNAVAILABLE: AipEntry = AipEntry {
        object: INVALID_OBJECT,
        t: f32::INFINITY,
        cnt: 0,
        t_other: f32::INFINITY,
        flags: AipEntry::NO_REPROJECTION,
    };
}

/// Parameters of the reprojection and rendering phases.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EpipolarOptions {
    /// `m_cnt` of Sec. 3.3 / Alg. 2: a pixel is resolved by one ray/object
    /// test when at least this many points of its object reached it
    /// (`cnt >= m_cnt`). Default 5, "a majority from 9". At least 1.
    pub m_cnt: u32,
    /// Splat radius `r`: each reprojected point covers a `(2r+1)^2` kernel
    /// (Sec. 3.2 uses `r = 1`, 3x3). At most [`MAX_SPLAT_RADIUS`].
    pub splat_radius: u32,
    /// Depth guard (default on; not in the paper): the one-object test of a
    /// pixel only accepts a hit nearer than [`AipEntry::t_other`], the
    /// nearest reprojected point of another object in the splat. Without
    /// it, a pixel on the silhouette of an object standing on (or in front
    /// of) a larger one can be predicted as the larger one (its points are
    /// nearer and outnumber the others in the 3x3 neighborhood) and the
    /// ray, which hits the larger one behind the silhouette, is accepted:
    /// a visibility error, even under pure rotation.
    ///
    /// With the guard on, a prediction is also only trusted where the
    /// object's splatted points surround the pixel center
    /// ([`AipEntry::SURROUNDED`]). The splat spreads an object one pixel
    /// beyond its silhouette; a pixel just outside it (all the object's
    /// points on one side of its center) may show a surface the last frame
    /// never sampled: where a sphere passes through the edge of a wall, a
    /// 1-pixel sliver of the wall grows out from behind the sphere, none of
    /// the wall's points land near it, and the ray meets the sphere inside
    /// the wall behind the sliver. Such pixels take full traversal.
    pub depth_guard: bool,
    /// Relative margin of the depth guard (default 0.01, in `[0, 1)`):
    /// the one-object test accepts only hits nearer than
    /// `t_other * (1 - guard_margin)`. Where two objects meet or
    /// interpenetrate (a sphere through a wall, a pillar on the floor) the
    /// nearer surface switches along their intersection curve; the other
    /// object's points splatted next to that curve lie at almost the same
    /// distance as the predicted object's hit, and without a margin a pixel
    /// just across the curve accepts the predicted object a few millimeters
    /// behind the other one. Such pixels take full traversal instead.
    pub guard_margin: f32,
    /// Guard window radius `g` (default 3, at most [`MAX_SPLAT_RADIUS`];
    /// 0 turns it off; used with [`EpipolarOptions::depth_guard`]): after the splat,
    /// [`AipEntry::t_other`] of each pixel is lowered to the distance `t` of
    /// every entry within `g` pixels (Chebyshev) that holds another object.
    /// A sub-pixel sliver of an object growing out from behind another
    /// where the two meet can miss every splat of its own points, and the
    /// splat order decides which guards an entry sees; the window is
    /// order-independent. Where two surfaces touch almost tangentially (a
    /// sphere through the edge of a doorway wall, the wall's corner edge
    /// grazing the sphere) the visible part of the wall is a cusp that
    /// narrows below a pixel: its nearest sampled points can lie 3 pixels
    /// from a pixel center that the cusp now covers, at almost the
    /// sphere's distance. With `g = 3` and the margin, such a pixel's
    /// one-object test of the sphere is bounded below the wall and the pixel
    /// takes full traversal (the Embree walkthrough of `cpp_tests` had 7
    /// visibility errors there with `g = 2`, none with `g = 3`).
    pub guard_window: u32,
    /// The view-frustum check of Sec. 4.1 (default on). Off, reprojection
    /// also runs when the new eye left the previous view pyramid (moving
    /// backward or sideways); objects the previous frame never saw can then
    /// be missed. For experiments and for testing the epipolar order alone.
    pub frustum_check: bool,
    /// The epipolar ordering and occlusion check of Sec. 4.2 (default on).
    /// Off, points are reprojected in row order and none is discarded for
    /// occlusion: previously hidden objects can then be missed.
    pub occlusion_check: bool,
    /// `N` of Sec. 4.3: every pixel is computed by the ORSA once in `N`
    /// frames, a disjoint `1/N` of the pixels per frame ([`resample_slot`]);
    /// 0 turns regular resampling off. Default 9.
    pub resample_period: u32,
    /// `N` of the abrupt-motion test (Sec. 4.3.1): a point at signed
    /// distance `t` is discarded when the eye moved more than `t / 2 / N`;
    /// 0 turns the test off. Default 9 (the paper notes 4 sufficed in
    /// practice).
    pub abrupt_frames: u32,
    /// Shifted ray origin (Sec. 5.3): a fallback ray of a pixel with a
    /// reprojected scene object starts at `t - shift_epsilon` instead of 0.
    /// Default off (the paper's REPR1); see [`decide`] for the caveat.
    pub shift_origin: bool,
    /// The `epsilon` of Sec. 5.3 (world units, finite, >= 0).
    pub shift_epsilon: f32,
}

impl Default for EpipolarOptions {
    fn default() -> Self {
        EpipolarOptions {
            m_cnt: 5,
            splat_radius: 1,
            depth_guard: true,
            guard_margin: 0.01,
            guard_window: 3,
            frustum_check: true,
            occlusion_check: true,
            resample_period: 9,
            abrupt_frames: 9,
            shift_origin: false,
            shift_epsilon: 1e-3,
        }
    }
}

impl EpipolarOptions {
    /// Checks the ranges documented on the fields.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for `m_cnt == 0`, a splat radius above
    /// [`MAX_SPLAT_RADIUS`], a negative or non-finite `shift_epsilon` or a
    /// `guard_margin` outside `[0, 1)` or a `guard_window` above
    /// [`MAX_SPLAT_RADIUS`].
    pub fn try_validate(&self) -> Result<(), Error> {
        if self.m_cnt == 0
            || self.splat_radius > MAX_SPLAT_RADIUS
            || !(self.shift_epsilon >= 0.0 && self.shift_epsilon.is_finite())
            || !(self.guard_margin >= 0.0 && self.guard_margin < 1.0)
            || self.guard_window > MAX_SPLAT_RADIUS
        {
            return Err(Error::InvalidArgument);
        }
        Ok(())
    }
}

/// Per-frame coefficients of the reprojection (seed 002 Sec. 5.1): for a
/// world point `P` and `d = P - C` (`C` the eye), the pixel position is
/// `(A.d / N.d, B.d / N.d)` and the signed distance `|d|`, with `N` the unit
/// forward vector and `A`, `B` the image-plane rows with the principal point
/// folded in (composed in f64, rounded once). One point costs 3 subtractions,
/// 8 additions, 14 multiplications, 1 division, 1 square root and 1 branch
/// (the paper counts 12 multiplications and 2 branches with its
/// principal-component variant).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reprojector {
    eye: Vec3,
    a: Vec3,
    b: Vec3,
    n: Vec3,
}

impl Reprojector {
    /// The coefficients of `camera`.
    pub fn new(camera: &Camera) -> Reprojector {
        let view = camera.view().as_dmat4();
        let row = |i: usize| DVec3::new(view.x_axis[i], view.y_axis[i], view.z_axis[i]);
        let (r0, r1, r2) = (row(0), row(1), row(2));
        let w = f64::from(camera.width());
        let h = f64::from(camera.height());
        let tan_y = libm::tan(f64::from(camera.fov_y()) * 0.5);
        let tan_x = tan_y * w / h;
        let n = -r2;
        // px = (x_v / (z tan_x) + 1) w / 2, py = (1 - y_v / (z tan_y)) h / 2
        // with x_v = r0.d, y_v = r1.d, z = n.d.
        let a = r0 * (w / (2.0 * tan_x)) + n * (w * 0.5);
        let b = -r1 * (h / (2.0 * tan_y)) + n * (h * 0.5);
        Reprojector {
            eye: camera.inverse_view().w_axis.truncate(),
            a: a.as_vec3(),
            b: b.as_vec3(),
            n: n.as_vec3(),
        }
    }

    /// `(pixel x, pixel y, signed distance)` of `p`, or `None` when `p` is
    /// at or behind the eye plane (design.md erratum: points with `t <= 0`
    /// are dropped) or the result is not finite.
    #[inline]
    pub fn project(&self, p: Vec3) -> Option<(Vec2, f32)> {
        let d = p - self.eye;
        let z = self.n.dot(d);
        if !(z > 0.0) {
            return None;
        }
        let inv = 1.0 / z;
        let px = Vec2::new(self.a.dot(d) * inv, self.b.dot(d) * inv);
        let t = libm::sqrtf(d.dot(d));
        (px.is_finite() && t.is_finite()).then_some((px, t))
    }

    /// The eye the coefficients were made for.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }
}

/// Where one camera's eye appears in the other camera's image (seed 002
/// Sec. 4.2): the projection of the other center of projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epipole {
    /// Pixel position. An epipole at (or numerically near) infinity is
    /// represented by a point [`Epipole::FAR`] pixels from the image center
    /// in its direction, which gives the same traversal order.
    pub pixel: Vec2,
    /// `true` if the other eye lies in front of the camera's eye plane (or
    /// on it: an epipole at infinity); `false` if behind (moving backward).
    /// The occlusion-compatible order reverses with it.
    pub in_front: bool,
    /// `true` if the other eye lies on the eye plane (the camera moved
    /// parallel to its image plane): the epipole is at infinity.
    pub at_infinity: bool,
}

impl Epipole {
    /// Distance from the image center at which an epipole at infinity is
    /// placed (pixels); f32 still resolves 1/16 pixel there.
    pub const FAR: f32 = 1.0e6;

    /// The epipole of `other_eye` in `camera`'s image, or `None` when the
    /// eyes coincide (within `1e-6` of the distance from the origin, at
    /// least `1e-12`): no baseline, no epipolar geometry (pure rotation).
    pub fn of(camera: &Camera, other_eye: Vec3) -> Option<Epipole> {
        let eye = camera.inverse_view().w_axis.truncate().as_dvec3();
        let other = other_eye.as_dvec3();
        let base = other - eye;
        let len = base.length();
        if !(len > 1e-6 * eye.length().max(other.length()).max(1e-6)) {
            return None;
        }
        let view = camera.view().as_dmat4();
        let v = view.transform_vector3(base);
        let w = f64::from(camera.width());
        let h = f64::from(camera.height());
        let tan_y = libm::tan(f64::from(camera.fov_y()) * 0.5);
        let tan_x = tan_y * w / h;
        // Homogeneous pixel offset from the image center: (x_v w/(2 tan_x),
        // -y_v h/(2 tan_y)) over z = -z_v.
        let dir = glam::DVec2::new(v.x * w / (2.0 * tan_x), -v.y * h / (2.0 * tan_y));
        let z = -v.z;
        let center = glam::DVec2::new(w * 0.5, h * 0.5);
        let far = f64::from(Epipole::FAR);
        let at_infinity = libm::fabs(z) * far <= dir.length();
        let offset = if at_infinity {
            dir.normalize() * far
        } else {
            let o = dir / z;
            if o.length() > far {
                o.normalize() * far
            } else {
                o
            }
        };
        Some(Epipole {
            pixel: (center + offset).as_vec2(),
            in_front: at_infinity || z > 0.0,
            at_infinity,
        })
    }
}

/// The two epipoles of a frame pair (seed 002 Sec. 4.2): `previous` is the
/// new eye `C_i` projected into the previous image `VP_{i-1}` (it orders the
/// reprojection), `current` the previous eye `C_{i-1}` projected into the
/// new image `VP_i` (distances from it are checked).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epipoles {
    /// `E_{i-1}`: the new eye in the previous image.
    pub previous: Epipole,
    /// `E_i`: the previous eye in the new image.
    pub current: Epipole,
}

impl Epipoles {
    /// Both epipoles, or `None` for coincident eyes.
    ///
    /// An epipole at infinity is the limit of a far epipole in front on one
    /// side and behind on the other; both give the same order along the
    /// epipolar lines. `previous` is kept in front (on the side the eye
    /// moved to), `current` is taken behind, on the same side (the mirror
    /// of [`Epipole::of`]'s point), so that a sideways move is ordered like
    /// the forward moves it is the limit of (outward, increasing).
    pub fn of(previous: &Camera, current: &Camera) -> Option<Epipoles> {
        let mut cur = Epipole::of(current, previous.eye())?;
        if cur.at_infinity {
            let center = Vec2::new(current.width() as f32, current.height() as f32) * 0.5;
            cur.pixel = 2.0 * center - cur.pixel;
            cur.in_front = false;
        }
        Some(Epipoles {
            previous: Epipole::of(previous, current.eye())?,
            current: cur,
        })
    }

    /// Whether the previous image is traversed away from its epipole
    /// (`true`: the new eye is in front of the previous camera, e.g. moving
    /// forward) or toward it (`false`: moving backward, the order reverses).
    pub fn outward(&self) -> bool {
        self.previous.in_front
    }

    /// Whether distances from the new epipole must grow along the traversal
    /// (`true`: the previous eye is behind the new camera) or shrink
    /// (`false`: it is in front, as when moving backward).
    pub fn increasing(&self) -> bool {
        !self.current.in_front
    }
}

/// The four quadrants of an image around an epipole and their traversal
/// orders (seed 002 Sec. 4.2, Fig. 4, after Mark 1999 p. 62).
///
/// Column `c` is left of the epipole when `c + 0.5 < e.x`, row `r` above it
/// when `r + 0.5 < e.y`. Within a quadrant the rows are visited in order of
/// their distance from the epipole's row and, inside each row, the columns
/// in order of their distance from its column (outward), or both reversed
/// (inward). Every pixel is then visited after every pixel of its quadrant
/// that is nearer the epipole in both coordinates, in particular after the
/// pixels between it and the epipole on its epipolar line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quadrants {
    width: u32,
    height: u32,
    split_x: u32,
    split_y: u32,
    outward: bool,
}

/// One quadrant: a column range and a row range with their directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quadrant {
    /// Columns `[start, end)`.
    pub columns: (u32, u32),
    /// Rows `[start, end)`.
    pub rows: (u32, u32),
    /// `true`: columns are visited from `end - 1` down to `start`.
    pub columns_descending: bool,
    /// `true`: rows are visited from `end - 1` down to `start`.
    pub rows_descending: bool,
}

impl Quadrant {
    /// Number of pixels.
    pub fn len(&self) -> usize {
        (self.columns.1 - self.columns.0) as usize * (self.rows.1 - self.rows.0) as usize
    }

    /// `true` for an empty quadrant (epipole outside the image).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The `k`-th pixel of the traversal (`k < len`).
    #[inline]
    pub fn pixel(&self, k: usize) -> (u32, u32) {
        let w = (self.columns.1 - self.columns.0) as usize;
        let (r, c) = ((k / w) as u32, (k % w) as u32);
        let x = if self.columns_descending {
            self.columns.1 - 1 - c
        } else {
            self.columns.0 + c
        };
        let y = if self.rows_descending {
            self.rows.1 - 1 - r
        } else {
            self.rows.0 + r
        };
        (x, y)
    }
}

impl Quadrants {
    /// The quadrants of a `width x height` image around `epipole`,
    /// traversed outward (away from it) or inward.
    pub fn new(width: u32, height: u32, epipole: Vec2, outward: bool) -> Quadrants {
        // Number of columns c with c + 0.5 < e.x, clamped to [0, width].
        let split = |e: f32, n: u32| {
            let s = libm::ceilf(e - 0.5);
            if !(s > 0.0) {
                0
            } else if s >= n as f32 {
                n
            } else {
                s as u32
            }
        };
        Quadrants {
            width,
            height,
            split_x: split(epipole.x, width),
            split_y: split(epipole.y, height),
            outward,
        }
    }

    /// Quadrant `i` of 4: top-left, top-right, bottom-left, bottom-right.
    pub fn get(&self, i: usize) -> Quadrant {
        let left = i % 2 == 0;
        let top = i < 2;
        // Outward: left columns descend toward 0, right ones ascend.
        Quadrant {
            columns: if left {
                (0, self.split_x)
            } else {
                (self.split_x, self.width)
            },
            rows: if top {
                (0, self.split_y)
            } else {
                (self.split_y, self.height)
            },
            columns_descending: left == self.outward,
            rows_descending: top == self.outward,
        }
    }
}

/// Floats of reprojection scratch for a `width x height` new image, the
/// larger of two uses (one after the other):
/// * the occlusion check's `(distance, t)` records of
///   `w + h + 4 MAX_SPLAT_RADIUS` angular bins of the epipolar lines
///   ([`line_bins`]), about one bin per border pixel;
/// * the guard window's ring of `2 MAX_SPLAT_RADIUS + 1` rows of
///   row-window summaries, 3 floats per pixel ([`EpipolarOptions::guard_window`]).
///
/// # Errors
/// [`Error::InvalidArgument`] for a zero size or an overflowing count.
pub fn try_scratch_len(width: u32, height: u32) -> Result<usize, Error> {
    if width == 0 || height == 0 {
        return Err(Error::InvalidArgument);
    }
    let pad = 2 * u64::from(MAX_SPLAT_RADIUS);
    let lines = 2 * (u64::from(width) + pad) + 2 * (u64::from(height) + pad);
    let ring = GUARD_RING_ROWS * GUARD_SUMMARY_FLOATS * u64::from(width);
    usize::try_from(lines.max(ring)).map_err(|_| Error::InvalidArgument)
}

/// Angular bins of the occlusion check's epipolar-line records for a
/// `width x height` image: `w + h + 4 MAX_SPLAT_RADIUS`, about one per
/// border pixel of the padded image (each bin takes 2 floats of
/// [`try_scratch_len`]).
pub fn line_bin_count(width: u32, height: u32) -> usize {
    let pad = 2 * MAX_SPLAT_RADIUS as usize;
    width as usize + pad + height as usize + pad
}

/// Rows of row-window summaries the guard window keeps at once.
const GUARD_RING_ROWS: u64 = 2 * MAX_SPLAT_RADIUS as u64 + 1;
/// Floats per guard summary: nearest `t`, its object (bits), nearest `t`
/// of any other object.
const GUARD_SUMMARY_FLOATS: u64 = 3;

/// Counts of one reprojection phase.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReprojectStats {
    /// POS entries holding a point (object not [`INVALID_OBJECT`]).
    pub points: u32,
    /// Points splatted into the AIP.
    pub splatted: u32,
    /// Points at or behind the new eye plane (dropped).
    pub behind: u32,
    /// Points whose splat misses the new image entirely.
    pub outside: u32,
    /// Points discarded by the occlusion check (Sec. 4.2).
    pub occlusion_rejected: u32,
    /// Points discarded by the abrupt-motion test (Sec. 4.3.1).
    pub abrupt_rejected: u32,
    /// `true` if the view-frustum check (Sec. 4.1) failed and nothing was
    /// reprojected.
    pub frustum_failed: bool,
    /// `true` if the eyes coincide (pure rotation): no parallax, the
    /// occlusion check has nothing to order and is skipped.
    pub no_baseline: bool,
}

/// The view-frustum check of seed 002 Sec. 4.1: `true` if `eye` lies inside
/// the (infinite) view pyramid of `previous`, or coincides with its eye
/// (pure rotation cannot cause the view-frustum error). Outside, objects the
/// previous frame never saw can appear anywhere and reprojection must be
/// skipped. A NaN eye is outside.
pub fn frustum_contains(previous: &Camera, eye: Vec3) -> bool {
    if !eye.is_finite() {
        return false;
    }
    let Some(e) = Epipole::of(previous, eye) else {
        return true;
    };
    if e.at_infinity || !e.in_front {
        return false;
    }
    let (w, h) = (previous.width() as f32, previous.height() as f32);
    (0.0..=w).contains(&e.pixel.x) && (0.0..=h).contains(&e.pixel.y)
}

/// Reprojection phase (seed 002 Alg. 1 with Secs. 4.1, 4.2, 4.3.1): fills
/// `aip` (the `current` camera's `width x height` pixels, row-major) from
/// `pos` (the `previous` camera's pixels, row-major).
///
/// * With [`EpipolarOptions::frustum_check`], if `current`'s eye is outside
///   `previous`'s view pyramid ([`frustum_contains`]), every AIP entry becomes
///   [`AipEntry::UNAVAILABLE`].
/// * Otherwise every stored point is reprojected with the per-frame
///   [`Reprojector`]; points behind the new eye are dropped; with
///   [`EpipolarOptions::abrupt_frames`] `= N > 0` a point at signed distance `t` is
///   discarded if the eye moved more than `t / 2 / N`; with
///   [`EpipolarOptions::occlusion_check`] the points are visited in the epipolar
///   order of [`Quadrants`]; each angular bin of the epipolar lines through
///   the new epipole ([`line_bins`]) records the distance from the epipole
///   and the signed distance `t` of the last point kept on it, and a point
///   is discarded when its distance from the epipole is below (moving
///   forward; above when the order reverses) the record of its bin or an
///   adjacent one while that record is nearer the camera by more than
///   [`OCCLUDER_GAP`] `* t` (it fell behind a nearer point on its line: it
///   is occluded). Without the depth test, points of neighboring lines of
///   one surface, visited row by row rather than strictly by distance,
///   would discard each other. Records restart with each quadrant (an
///   epipolar line never leaves its quadrant).
/// * Surviving points splat into the `(2r+1)^2` neighborhood exactly as
///   Alg. 1: an empty entry takes the point; a point not farther than the
///   entry's `t` lowers `t` and increments `cnt` for the same object or
///   overwrites the object with `cnt = 1`; a farther point of the same
///   object increments `cnt`. In addition [`AipEntry::t_other`] keeps the
///   nearest distance of the points that lost (the overwritten object's
///   nearest point, farther points of other objects).
///
/// `scratch` holds [`try_scratch_len`] floats (contents ignored and
/// overwritten).
///
/// # Errors
/// * [`Error::InvalidArgument`]: the cameras differ in size, or `options`
///   fails [`EpipolarOptions::try_validate`].
/// * [`Error::InsufficientSize`]: `pos` or `aip` shorter than
///   `width * height`, `scratch` shorter than [`try_scratch_len`].
///
/// Nothing is written on error.
pub fn try_reproject(
    aip: &mut [AipEntry],
    scratch: &mut [f32],
    pos: &[PosEntry],
    previous: &Camera,
    current: &Camera,
    options: &EpipolarOptions,
) -> Result<ReprojectStats, Error> {
    options.try_validate()?;
    let (w, h) = (current.width(), current.height());
    if previous.width() != w || previous.height() != h {
        return Err(Error::InvalidArgument);
    }
    let n = w as usize * h as usize;
    if pos.len() < n || aip.len() < n || scratch.len() < try_scratch_len(w, h)? {
        return Err(Error::InsufficientSize);
    }
    let aip = &mut aip[..n];
    let mut stats = ReprojectStats::default();
    if options.frustum_check && !frustum_contains(previous, current.eye()) {
        aip.fill(AipEntry::UNAVAILABLE);
        stats.frustum_failed = true;
        stats.points = pos[..n]
            .iter()
            .filter(|p| p.object != INVALID_OBJECT)
            .count() as u32;
        return Ok(stats);
    }
    aip.fill(AipEntry::EMPTY);
    let proj = Reprojector::new(current);
    let moved = (current.eye() - previous.eye()).length();
    let epipoles = Epipoles::of(previous, current);
    stats.no_baseline = epipoles.is_none();
    let mut ctx = Splat {
        aip,
        width: w,
        height: h,
        radius: options.splat_radius as i64,
        proj,
        moved,
        abrupt_frames: options.abrupt_frames,
    };
    match (options.occlusion_check, epipoles) {
        (true, Some(e)) => {
            let mut records = LineRecords::new(scratch, w, h, e.current.pixel, e.increasing());
            let quads = Quadrants::new(w, h, e.previous.pixel, e.outward());
            for qi in 0..4 {
                let q = quads.get(qi);
                if q.is_empty() {
                    continue;
                }
                records.reset();
                // `Quadrant::pixel` order, without a division per point.
                let (c0, c1) = q.columns;
                for r in 0..q.rows.1 - q.rows.0 {
                    let y = if q.rows_descending {
                        q.rows.1 - 1 - r
                    } else {
                        q.rows.0 + r
                    };
                    let row = &pos[y as usize * w as usize..][..w as usize];
                    if q.columns_descending {
                        for entry in row[c0 as usize..c1 as usize].iter().rev() {
                            ctx.point(entry, Some(&mut records), &mut stats);
                        }
                    } else {
                        for entry in &row[c0 as usize..c1 as usize] {
                            ctx.point(entry, Some(&mut records), &mut stats);
                        }
                    }
                }
            }
        }
        _ => {
            for entry in &pos[..n] {
                ctx.point(entry, None, &mut stats);
            }
        }
    }
    if options.depth_guard && options.guard_window > 0 {
        guard_window(ctx.aip, scratch, w, h, options.guard_window);
    }
    Ok(stats)
}

/// Nearest entries of a set of AIP entries, for the guard window: the
/// nearest `t` (`t1`) and its object (`o1`), and the nearest `t` of any
/// entry holding another object than `o1` (`t2`). The minimum over "another
/// object than mine" of a set is then `t1` if `o1` is not mine, else `t2`;
/// and summaries merge associatively, so a `(2g+1)^2` window is a vertical
/// merge of `2g+1` horizontal ones (`2 (2g+1)` merges per pixel instead of
/// `(2g+1)^2` reads). `min` is exact, so the result is bit-identical to the
/// direct scan.
#[derive(Clone, Copy)]
struct Nearest2 {
    t1: f32,
    o1: u32,
    t2: f32,
}

impl Nearest2 {
    /// The summary of the empty set.
    const EMPTY: Nearest2 = Nearest2 {
        t1: f32::INFINITY,
        o1: INVALID_OBJECT,
        t2: f32::INFINITY,
    };

    #[inline]
    fn of(a: &AipEntry) -> Nearest2 {
        if a.object == INVALID_OBJECT {
            Nearest2::EMPTY
        } else {
            Nearest2 {
                t1: a.t,
                o1: a.object,
                t2: f32::INFINITY,
            }
        }
    }

    #[inline]
    fn merge(self, o: Nearest2) -> Nearest2 {
        let (a, b) = if self.t1 <= o.t1 {
            (self, o)
        } else {
            (o, self)
        };
        // b's nearest of an object other than a.o1.
        let other = if b.o1 != a.o1 { b.t1 } else { b.t2 };
        Nearest2 {
            t1: a.t1,
            o1: a.o1,
            t2: a.t2.min(other),
        }
    }

    /// Nearest `t` of the set's entries holding another object than
    /// `object`.
    #[inline]
    fn other_than(&self, object: u32) -> f32 {
        if self.o1 != object {
            self.t1
        } else {
            self.t2
        }
    }

    #[inline]
    fn store(&self, out: &mut [f32]) {
        // The object id travels bit for bit through the f32 scratch
        // (`from_bits`/`to_bits` are transmutes; no arithmetic touches it).
        out[0] = self.t1;
        out[1] = f32::from_bits(self.o1);
        out[2] = self.t2;
    }

    #[inline]
    fn load(s: &[f32]) -> Nearest2 {
        Nearest2 {
            t1: s[0],
            o1: s[1].to_bits(),
            t2: s[2],
        }
    }
}

/// The guard window of [`EpipolarOptions::guard_window`]: lowers `t_other` of every
/// entry to the `t` of the entries within `g` pixels holding another
/// object. Reads only `object` and `t`, which it does not change, so it
/// works in place. Separable ([`Nearest2`]): `scratch` holds a ring of
/// `2g + 1` rows of horizontal window summaries (at least
/// `(2g + 1) * 3 * w` floats, which [`try_scratch_len`] covers).
fn guard_window(aip: &mut [AipEntry], scratch: &mut [f32], w: u32, h: u32, g: u32) {
    let (w, h, g) = (w as usize, h as usize, g as usize);
    let ring_rows = 2 * g + 1;
    let stride = GUARD_SUMMARY_FLOATS as usize * w;
    let ring = &mut scratch[..ring_rows * stride];
    // Horizontal summaries of row `y` into ring slot `y % ring_rows`.
    let summarize = |aip: &[AipEntry], ring: &mut [f32], y: usize| {
        let row = &aip[y * w..][..w];
        let out = &mut ring[(y % ring_rows) * stride..][..stride];
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(g), (x + g).min(w - 1));
            let mut s = Nearest2::EMPTY;
            for a in &row[x0..=x1] {
                s = s.merge(Nearest2::of(a));
            }
            s.store(&mut out[3 * x..3 * x + 3]);
        }
    };
    for y in 0..g.min(h) {
        summarize(aip, ring, y);
    }
    for y in 0..h {
        if y + g < h {
            summarize(aip, ring, y + g);
        }
        let (y0, y1) = (y.saturating_sub(g), (y + g).min(h - 1));
        for x in 0..w {
            let object = aip[y * w + x].object;
            if object == INVALID_OBJECT {
                continue;
            }
            let mut s = Nearest2::EMPTY;
            for ny in y0..=y1 {
                let at = (ny % ring_rows) * stride + 3 * x;
                s = s.merge(Nearest2::load(&ring[at..at + 3]));
            }
            let a = &mut aip[y * w + x];
            a.t_other = a.t_other.min(s.other_than(object));
        }
    }
}

/// Relative depth gap of the occlusion check: a point that breaks the
/// epipolar order is discarded only when the recorded point it fell behind
/// is nearer the camera by more than this fraction of the point's distance.
pub const OCCLUDER_GAP: f32 = 0.02;

/// Angular bins of the epipolar lines through the new epipole (seed 002
/// Sec. 4.2): `(axis, theta0, bins per radian, full circle)` for `len`
/// bins over a `width x height` image padded by [`MAX_SPLAT_RADIUS`] + 1.
/// An epipole inside the padded image takes the full circle from the +x
/// axis; one outside it takes the angular range the padded image covers
/// around the bisector of that range (an epipole at infinity gives a tiny
/// range of almost parallel lines, resolved in f32 because the angle is
/// measured from the bisector).
pub fn line_bins(width: u32, height: u32, epipole: Vec2, len: usize) -> (Vec2, f32, f32, bool) {
    let p = f64::from(MAX_SPLAT_RADIUS) + 1.0;
    let (w, h) = (f64::from(width), f64::from(height));
    let e = epipole.as_dvec2();
    let inside = e.x > -p && e.x < w + p && e.y > -p && e.y < h + p;
    let (axis, theta0, theta1) = if inside {
        (
            glam::DVec2::X,
            -core::f64::consts::PI,
            core::f64::consts::PI,
        )
    } else {
        let u0 = (glam::DVec2::new(w * 0.5, h * 0.5) - e).normalize();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for c in [
            glam::DVec2::new(-p, -p),
            glam::DVec2::new(w + p, -p),
            glam::DVec2::new(-p, h + p),
            glam::DVec2::new(w + p, h + p),
        ] {
            let d = c - e;
            let a = libm::atan2(u0.perp_dot(d), u0.dot(d));
            lo = lo.min(a);
            hi = hi.max(a);
        }
        let mid = 0.5 * (lo + hi);
        let r = glam::DVec2::new(libm::cos(mid), libm::sin(mid));
        let axis = glam::DVec2::new(u0.x * r.x - u0.y * r.y, u0.x * r.y + u0.y * r.x);
        let half = 0.5 * (hi - lo) * 1.001 + 1e-9;
        (axis, -half, half)
    };
    (
        axis.as_vec2(),
        theta0 as f32,
        (len as f64 / (theta1 - theta0)) as f32,
        inside,
    )
}

/// Per-epipolar-line records of the occlusion check: for each angular bin
/// ([`line_bins`]) the distance from the new epipole and the signed
/// distance `t` of the last point kept there.
struct LineRecords<'a> {
    data: &'a mut [f32],
    epipole: Vec2,
    /// Unit axis angles are measured from.
    axis: Vec2,
    /// Angle of the first bin and bins per radian.
    theta0: f32,
    scale: f32,
    /// The bins cover the full circle (epipole inside the padded image).
    full: bool,
    increasing: bool,
}

impl<'a> LineRecords<'a> {
    fn new(
        scratch: &'a mut [f32],
        width: u32,
        height: u32,
        epipole: Vec2,
        increasing: bool,
    ) -> Self {
        let len = 2 * line_bin_count(width, height);
        let (axis, theta0, scale, full) = line_bins(width, height, epipole, len / 2);
        LineRecords {
            data: &mut scratch[..len],
            epipole,
            axis,
            theta0,
            scale,
            full,
            increasing,
        }
    }

    fn reset(&mut self) {
        let init = if self.increasing {
            f32::NEG_INFINITY
        } else {
            f32::INFINITY
        };
        self.data.fill(init);
    }

    /// Checks the point at pixel position `p` and signed distance `t`
    /// against the records of its bin and the two adjacent ones (the lines
    /// its splat can reach): it fails when it breaks the distance order of
    /// a record nearer the camera by more than [`OCCLUDER_GAP`]; on success
    /// it becomes its bin's record.
    #[inline]
    fn check(&mut self, p: Vec2, t: f32) -> bool {
        let d = p - self.epipole;
        let a = self.axis.dot(d);
        let b = self.axis.perp_dot(d);
        let theta = libm::atan2f(b, a);
        let n = (self.data.len() / 2) as i64;
        let bin = libm::floorf((theta - self.theta0) * self.scale);
        let bin = if bin > 0.0 {
            (bin as i64).min(n - 1)
        } else {
            0
        };
        let dist = a * a + b * b;
        let mut ok = true;
        for k in bin - 1..=bin + 1 {
            let k = if self.full {
                k.rem_euclid(n)
            } else if k < 0 || k >= n {
                continue;
            } else {
                k
            };
            let r = self.data[2 * k as usize];
            let order = if self.increasing {
                dist >= r
            } else {
                dist <= r
            };
            ok &= order || !(self.data[2 * k as usize + 1] < t * (1.0 - OCCLUDER_GAP));
        }
        if ok {
            self.data[2 * bin as usize] = dist;
            self.data[2 * bin as usize + 1] = t;
        }
        ok
    }
}

struct Splat<'a> {
    aip: &'a mut [AipEntry],
    width: u32,
    height: u32,
    radius: i64,
    proj: Reprojector,
    moved: f32,
    abrupt_frames: u32,
}

impl Splat<'_> {
    #[inline]
    fn point(
        &mut self,
        entry: &PosEntry,
        records: Option<&mut LineRecords<'_>>,
        stats: &mut ReprojectStats,
    ) {
        if entry.object == INVALID_OBJECT {
            return;
        }
        stats.points += 1;
        let p = entry.point();
        let Some((px, t)) = self.proj.project(p) else {
            stats.behind += 1;
            return;
        };
        let (x, y) = (libm::floorf(px.x), libm::floorf(px.y));
        let r = self.radius as f32;
        if !(x >= -r && y >= -r && x < self.width as f32 + r && y < self.height as f32 + r) {
            stats.outside += 1;
            return;
        }
        let (x, y) = (x as i64, y as i64);
        // Sec. 4.3.1: delta = t / 2 / N.
        if self.abrupt_frames > 0 && self.moved > t * 0.5 / self.abrupt_frames as f32 {
            stats.abrupt_rejected += 1;
            self.flag(x, y, AipEntry::ABRUPT_REJECTED);
            return;
        }
        if let Some(rec) = records {
            if !rec.check(px, t) {
                stats.occlusion_rejected += 1;
                // The discarded point still bounds the one-object test of
                // another object (the depth guard): something is there at
                // distance t.
                let object = entry.object;
                self.for_each(x, y, |a, _, _| {
                    a.flags |= AipEntry::OCCLUSION_REJECTED;
                    if a.object != object {
                        a.t_other = a.t_other.min(t);
                    }
                });
                return;
            }
        }
        stats.splatted += 1;
        let object = entry.object;
        self.for_each(x, y, |a, ix, iy| {
            // Side of the pixel center the point landed on.
            let side = AipEntry::SURROUND_UP_LEFT
                << (u32::from(px.x >= ix as f32 + 0.5) + 2 * u32::from(px.y >= iy as f32 + 0.5));
            if a.object == INVALID_OBJECT {
                // First assignment.
                a.object = object;
                a.t = t;
                a.cnt = 1;
                a.flags |= side;
            } else if a.t >= t {
                if a.object == object {
                    a.cnt += 1;
                    a.flags |= side;
                } else {
                    // Rewrite by the closer object; the old one's nearest
                    // point becomes the guard.
                    a.t_other = a.t_other.min(a.t);
                    a.object = object;
                    a.cnt = 1;
                    a.flags = (a.flags & !AipEntry::SURROUNDED) | side;
                }
                a.t = t;
            } else if a.object == object {
                a.cnt += 1;
                a.flags |= side;
            } else {
                a.t_other = a.t_other.min(t);
            }
        });
    }

    fn flag(&mut self, x: i64, y: i64, bit: u32) {
        self.for_each(x, y, |a, _, _| a.flags |= bit);
    }

    #[inline]
    fn for_each(&mut self, x: i64, y: i64, mut f: impl FnMut(&mut AipEntry, i64, i64)) {
        let r = self.radius;
        let (w, h) = (self.width as i64, self.height as i64);
        for iy in (y - r).max(0)..=(y + r).min(h - 1) {
            let row = iy as usize * w as usize;
            for ix in (x - r).max(0)..=(x + r).min(w - 1) {
                f(&mut self.aip[row + ix as usize], ix, iy);
            }
        }
    }
}

/// Why a pixel takes the path its [`Decision`] names (seed 002 Fig. 6
/// colors in brackets).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Reason {
    /// Reprojection predicts the object: one ray/object test (red).
    Reprojected = 0,
    /// Too few points reached the pixel (`cnt < m_cnt`) or none (green).
    Failed = 1,
    /// Regular resampling picked the pixel this frame (white).
    Resampled = 2,
    /// A point near the pixel was discarded by the abrupt-motion test
    /// (blue).
    Abrupt = 3,
    /// No reprojection this frame (first frame, view-frustum check).
    Unavailable = 4,
}

/// The rendering-phase decision for one pixel (seed 002 Alg. 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Decision {
    /// The one object to test, or [`INVALID_OBJECT`] for full traversal.
    /// [`BACKGROUND_OBJECT`] means the pixel is background. If the test of
    /// a scene object finds no hit in `[0, tmax)`, the host falls back to
    /// full traversal from `tmin` (and counts the pixel as a failed
    /// reprojection).
    pub object: u32,
    /// End of the interval of the one-object test: the depth guard
    /// `t_other * (1 - guard_margin)` ([`AipEntry::t_other`],
    /// [`EpipolarOptions::guard_margin`]) with [`EpipolarOptions::depth_guard`], else `+inf`.
    pub tmax: f32,
    /// Ray distance at which a full traversal of this pixel may start:
    /// 0, or with [`EpipolarOptions::shift_origin`] the AIP distance minus epsilon
    /// (Sec. 5.3).
    pub tmin: f32,
    /// Why.
    pub reason: Reason,
}

/// The regular-resampling slot of pixel `(x, y)` for period `n` (seed 002
/// Sec. 4.3): the pixel is computed by the ORSA in frame `k` when
/// `resample_slot(x, y, n) == k mod n`, so the `n` frames use disjoint pixel
/// sets that cover the image.
///
/// For `n = 9` the slots tile the image with a 3x3 window in which
/// consecutive slots are a knight's move or more apart (the paper's Fig. 5
/// pattern is not reproduced in its text; this is our low-discrepancy
/// choice, every 3x3 window holding each slot once). For other `n` the slot
/// is the rank-1 lattice `(x + s y) mod n` with `s` the integer nearest
/// `0.618 n` that is coprime with `n` (so every run of `n` pixels in a row
/// holds each slot once). `n = 0` has no slots (returns `u32::MAX`).
pub fn resample_slot(x: u32, y: u32, n: u32) -> u32 {
    const PATTERN: [u32; 9] = [0, 6, 3, 4, 1, 7, 8, 5, 2];
    match n {
        0 => u32::MAX,
        1 => 0,
        9 => PATTERN[((y % 3) * 3 + x % 3) as usize],
        _ => {
            let mut s = libm::roundf(n as f32 * 0.618) as u32;
            while gcd(s, n) != 1 {
                s -= 1;
            }
            ((u64::from(x) + u64::from(s) * u64::from(y)) % u64::from(n)) as u32
        }
    }
}

fn gcd(mut a: u32, mut b: u32) -> u32 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// The rendering-phase decision of seed 002 Alg. 2 for pixel `(x, y)` of
/// frame `frame` with AIP entry `aip`:
///
/// 1. no reprojection this frame ([`AipEntry::NO_REPROJECTION`]):
///    full traversal ([`Reason::Unavailable`]);
/// 2. the pixel's regular-resampling slot is `frame mod N`: full traversal
///    ([`Reason::Resampled`]);
/// 3. a point near the pixel was dropped by the abrupt-motion test: full
///    traversal ([`Reason::Abrupt`]);
/// 4. `cnt >= m_cnt`: test `aip.object` only, on `[0, tmax)` with `tmax`
///    the depth guard ([`Reason::Reprojected`]); when the guard is on, a
///    background prediction with another object's point in its splat
///    (finite `t_other`) and any prediction whose points do not surround
///    the pixel center ([`AipEntry::SURROUNDED`]) take full traversal
///    instead;
/// 5. otherwise full traversal ([`Reason::Failed`]).
///
/// With [`EpipolarOptions::shift_origin`], a full traversal of a pixel whose entry
/// holds a scene object starts at `max(0, aip.t - shift_epsilon)` (Sec. 5.3).
/// The paper's argument is that no hit lies nearer than the nearest
/// reprojected point; that holds only where the reprojection is complete
/// (a newly disoccluded object nearer than `aip.t` would be skipped), which
/// is why it is off by default. Background entries never shift.
pub fn decide(aip: &AipEntry, x: u32, y: u32, frame: u32, options: &EpipolarOptions) -> Decision {
    let traverse = |reason| {
        let tmin = if options.shift_origin
            && aip.object != INVALID_OBJECT
            && aip.object != BACKGROUND_OBJECT
            && aip.t.is_finite()
        {
            (aip.t - options.shift_epsilon).max(0.0)
        } else {
            0.0
        };
        Decision {
            object: INVALID_OBJECT,
            tmin,
            tmax: f32::INFINITY,
            reason,
        }
    };
    if aip.flags & AipEntry::NO_REPROJECTION != 0 {
        return Decision {
            object: INVALID_OBJECT,
            tmin: 0.0,
            tmax: f32::INFINITY,
            reason: Reason::Unavailable,
        };
    }
    let n = options.resample_period;
    if n > 0 && resample_slot(x, y, n) == frame % n {
        return traverse(Reason::Resampled);
    }
    // Fig. 6 (blue): pixels near a point dropped for abrupt motion take the
    // ORSA. Dropping the near point alone would leave the farther points
    // around it unchallenged: they would win the pixel and the one-object
    // test would hit them through the object that was dropped.
    if aip.flags & AipEntry::ABRUPT_REJECTED != 0 {
        return traverse(Reason::Abrupt);
    }
    if aip.object != INVALID_OBJECT && aip.cnt >= options.m_cnt {
        let tmax = if options.depth_guard {
            aip.t_other * (1.0 - options.guard_margin)
        } else {
            f32::INFINITY
        };
        // A background decision has no ray/object test to bound: with the
        // depth guard, any other object's point in the splat sends the pixel
        // to full traversal.
        if aip.object == BACKGROUND_OBJECT && options.depth_guard && aip.t_other.is_finite() {
            return traverse(Reason::Failed);
        }
        // Just outside the object's silhouette (its points on one side of
        // the center only) the pixel may show a surface never sampled.
        if options.depth_guard && aip.flags & AipEntry::SURROUNDED != AipEntry::SURROUNDED {
            return traverse(Reason::Failed);
        }
        return Decision {
            object: aip.object,
            tmin: 0.0,
            tmax,
            reason: Reason::Reprojected,
        };
    }
    traverse(Reason::Failed)
}

/// [`decide`] for the rows `rows` of a `width`-wide image: `out[i]` for
/// pixel index `i = y * width + x` (only the rows in `rows` are written).
/// [`try_decide_band`] writes a band-sized buffer instead.
///
/// # Errors
/// [`Error::InvalidArgument`] for a zero width or invalid `options`;
/// [`Error::InsufficientSize`] if `aip` or `out` is shorter than
/// `rows.end() * width`. Nothing is written on error.
pub fn try_decide_rows(
    out: &mut [Decision],
    aip: &[AipEntry],
    width: u32,
    rows: RowRange,
    frame: u32,
    options: &EpipolarOptions,
) -> Result<(), Error> {
    let (start, end) = (
        rows.start() as usize * width as usize,
        rows.end() as usize * width as usize,
    );
    check_decide(width, options)?;
    let band = out.get_mut(start..end).ok_or(Error::InsufficientSize)?;
    try_decide_band(band, aip, width, rows, frame, options)
}

/// The checks shared by [`try_decide_rows`] and [`try_decide_band`].
fn check_decide(width: u32, options: &EpipolarOptions) -> Result<(), Error> {
    options.try_validate()?;
    if width == 0 {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

/// [`decide`] for the rows `rows` of a `width`-wide image into the band
/// `band`: `band[i - rows.start() * width]` for pixel index
/// `i = y * width + x`, so that threads deciding disjoint bands each hold
/// only their rows. `band` holds [`Decision`]s or any type made from one
/// (`From<Decision>`, the C ABI's record).
///
/// # Errors
/// [`Error::InvalidArgument`] for a zero width or invalid `options`;
/// [`Error::InsufficientSize`] if `aip` is shorter than
/// `rows.end() * width` or `band` than `rows.len() * width`. Nothing is
/// written on error.
pub fn try_decide_band<O: From<Decision>>(
    band: &mut [O],
    aip: &[AipEntry],
    width: u32,
    rows: RowRange,
    frame: u32,
    options: &EpipolarOptions,
) -> Result<(), Error> {
    check_decide(width, options)?;
    let w = width as usize;
    if aip.len() < rows.end() as usize * w || band.len() < rows.len() as usize * w {
        return Err(Error::InsufficientSize);
    }
    for (o, y) in band.chunks_exact_mut(w).zip(rows.rows()) {
        let row = y as usize * w;
        for (x, o) in (0..width).zip(o) {
            *o = decide(&aip[row + x as usize], x, y, frame, options).into();
        }
    }
    Ok(())
}
