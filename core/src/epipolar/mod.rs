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

use crate::Error;
use glam::Vec3;

mod decide;
mod order;
mod reproject;

pub use decide::{decide, resample_slot, try_decide_band, try_decide_rows, Decision, Reason};
pub use order::{line_bins, Epipole, Epipoles, Quadrant, Quadrants, OCCLUDER_GAP};
pub use reproject::{
    frustum_contains, line_bin_count, try_reproject, try_scratch_len, ReprojectStats, Reprojector,
};

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
