//! Temporal filtering of screen-space reflections (seed 004 Sec. 4.6.5,
//! with the re-projection of Sec. 4.6.4, Listing 4.9): a history buffer in
//! caller memory accumulates each pixel's reflection over frames; every
//! frame re-projects the current pixel's surface point into the previous
//! frame, rejects history that shows another surface (depth and,
//! optionally, normal), blends the current result into the history that
//! survives, and lets pixels whose ray failed this frame take the history
//! where it is valid ("we can just rely on the previous re-projected result
//! that is already stored in the history buffer and have a chance of
//! recovering that missing pixel").
//!
//! Described once ([`TemporalPass::try_new`]: the current G-buffer, this
//! frame's reflection colors and which of them were answered, the previous
//! history with its camera, the options), executed over row bands
//! ([`TemporalPass::try_run`] into the next history; bands are
//! independent). The history written this frame is the next frame's input:
//! the host keeps two buffers and swaps them ("this history buffer is the
//! same buffer we write our final reflection computation to").
//!
//! # Per pixel
//! 1. **Surface.** A pixel without a usable surface ([`GBuffer::surface`])
//!    or with mask 0 is [`TemporalStatus::Skipped`]: its history texel is
//!    emptied (`frames = 0`) and its color is this frame's, unchanged.
//! 2. **Re-projection** (Sec. 4.6.4, Listing 4.9's `VP_prev VP_curr^-1`):
//!    the pixel's world point `P` (the G-buffer's unprojection of the pixel
//!    center) is projected by the history's camera to a sub-pixel position
//!    `q` and a linear depth `z_prev`. `P` behind that camera or `q`
//!    outside its image: no history ([`TemporalStats::off_screen`]).
//! 3. **Rejection.** The 2x2 history texels around `q` (bilinear, texel
//!    centers at `i + 0.5`) are each kept only if they hold history
//!    (`frames > 0`, finite color), their own surface point (the history
//!    camera's unprojection of the texel center at its stored depth) lies
//!    within [`TemporalOptions::depth_tolerance`] `* z_prev` of the current
//!    surface's tangent plane (the seed's depth test, "compare them by an
//!    epsilon", taken along the normal: for a surface facing the camera it
//!    is the depth difference, and on a floor seen at a grazing angle,
//!    whose depth changes by more than the tolerance from one texel to
//!    the next, it still keeps the texels of the same floor), and their
//!    stored normal has a cosine of at least
//!    [`TemporalOptions::normal_cos`] with
//!    the current one (the seed's "to get even more accurate results, one
//!    could also use the normal"; `-1` turns it off). The kept texels'
//!    bilinear weights are renormalized; if they sum to less than
//!    [`MIN_HISTORY_WEIGHT`] there is no history (the pixel was disoccluded,
//!    [`TemporalStats::rejected`]).
//! 4. **Blend.** Answered this frame with history (its color the kept
//!    texels' renormalized bilinear mean, its `frames` the fewest among
//!    them; with [`TemporalOptions::clamp_history`], that color first
//!    clamped per channel to the range of this frame's answered colors in
//!    the 3x3 pixels around the pixel, see below): with `n = min(frames + 1,`
//!    [`TemporalOptions::max_frames`]`)`, `color = history + (current -
//!    history) / n` ([`TemporalStatus::Blended`]): the running mean of the
//!    frames seen, which becomes an exponential average of weight `1 /
//!    max_frames` once `n` reaches the cap (the cap bounds the lag of
//!    reflections that move against their reflector). Answered without
//!    history: the current color, `frames = 1`
//!    ([`TemporalStatus::Reset`]).
//! 5. **Recovery.** Not answered (or a non-finite color) with history
//!    that keeps at least [`MIN_RECOVERY_WEIGHT`] of the bilinear
//!    footprint, and [`TemporalOptions::recover`]: the history's color and
//!    frame count, capped at [`TemporalOptions::max_frames`] (history
//!    written with a larger cap stays in the documented range)
//!    ([`TemporalStatus::Recovered`]). Without history: the current color
//!    as given (the host's fallback), `frames = 0`, so that no later frame
//!    takes it for history ([`TemporalStatus::Unanswered`]).
//! 6. The texel written stores the current surface's linear depth, unit
//!    world normal and reflection distance for the next frame's tests.
//!
//! **History clamping** ([`TemporalOptions::clamp_history`], a production
//! extension beyond the seed: the neighborhood clamp of temporal
//! anti-aliasing, Karis, "High Quality Temporal Supersampling", SIGGRAPH
//! 2014 course *Advances in Real-Time Rendering*): history that survived
//! the surface tests may still show another reflection (the reflected
//! object moved against its reflector, or the re-projection of a curved
//! reflector's reflection is approximate); this frame's answered
//! neighbors bound what the reflection can be here, so history outside
//! their per-channel range `[lo, hi]` is moved to its nearest point
//! before the blend: `color = c + (current - c) / n` with `c =
//! clamp(history, lo, hi)`. The range always holds the current color, so
//! a history inside it is unchanged, and the blend never leaves it.
//! Measured on the report's camera paths (`refl report --method
//! hiz-temporal`, `max_frames=8`): error 11.10 to 10.88 (room), 21.67 to
//! 21.31 (concave), 15.84 to 15.63 (walkthrough), 4.49 to 4.23 (stage)
//! through the virtual point, and the seed's surface re-projection's
//! ghosting on the stage's mirror floor 17.01 to 6.60; flicker rises by
//! 2 to 4 percent (the history follows the current frame more closely).
//!
//! What normals add: the depth test alone accepts history from a surface
//! at the same depth with another orientation (a crease, an edge seen
//! edge-on, a normal map that changed), whose reflection points elsewhere;
//! the normal test rejects those. It costs 12 bytes a texel of history.
//!
//! # Reflection-aware re-projection
//!
//! Re-projecting the reflector's surface point (as the seed does) is exact
//! for the reflector, not for what it reflects: a reflection whose object
//! lies at another depth than the mirror moves differently under camera
//! motion (parallax), so accumulated history lags behind it and ghosts
//! ([`TemporalOptions::max_frames`] bounds the lag). Given this frame's
//! reflection distances ([`TemporalPass::try_with_distance`]: the mirror
//! pass's hit `t`), the pass re-projects instead the reflection's
//! *virtual point*, the point the eye sees through the mirror, `eye + (P -
//! eye) (|P - eye| + t) / |P - eye|` (exact for a planar mirror, an
//! approximation on curved ones; the re-projection of Stachowiak's
//! "Stochastic Screen-Space Reflections", SIGGRAPH 2015, a production
//! extension beyond the seed), at `1e6 |P - eye|` for the sky. The
//! texels found there must still pass step 3's surface tests (they show
//! the same reflector) and their own virtual point must lie as far from
//! the history's eye as this one within the tolerance (the same reflected
//! surface; the sky only with the sky). A
//! failed pixel, which has no distance this frame, takes the one the
//! history holds at its surface's re-projection, refined twice by the one
//! it holds at that distance's virtual point. The history stores each
//! texel's distance for the next frame. TCRR (`crate::tcrr`, seed 000)
//! is refl's full reflection re-projection, with its own search.
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::glam::Vec3;
//! use refl_core::temporal::{History, HistoryTexel, TemporalOptions, TemporalPass, TemporalStatus};
//! use refl_core::{Camera, DepthConvention, DepthImage, GBuffer, ImageView, ImageViewMut, NormalSpace};
//!
//! // 8 x 8 pixels of a wall at linear depth 4, reflecting red this frame,
//! // except pixel (3, 3), whose ray failed.
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 0.1, 100.0, 8, 8)?;
//! let (depth, normals) = (vec![4.0f32; 64], vec![[0.0, 0.0, 1.0f32]; 64]);
//! let depth = DepthImage::try_new(ImageView::try_new(&depth, 8, 8, 8)?, cam, DepthConvention::Linear)?;
//! let gbuffer = GBuffer::try_new(depth, ImageView::try_new(&normals, 8, 8, 8)?, NormalSpace::World)?;
//! let color = vec![[1.0f32, 0.0, 0.0]; 64];
//! let mut answered = vec![1u8; 64];
//! answered[3 * 8 + 3] = 0;
//!
//! // The last frame (same camera) had green everywhere, pixel (3, 3) included.
//! let green = HistoryTexel { color: [0.0, 1.0, 0.0], frames: 1.0, normal: [0.0, 0.0, 1.0], depth: 4.0, distance: 0.0 };
//! let last = vec![green; 64];
//! let history = History::try_new(cam, ImageView::try_new(&last, 8, 8, 8)?)?;
//!
//! let pass = TemporalPass::try_new(
//!     gbuffer,
//!     ImageView::try_new(&color, 8, 8, 8)?,
//!     ImageView::try_new(&answered, 8, 8, 8)?,
//!     Some(history),
//!     TemporalOptions::default(),
//! )?;
//! let mut next = vec![HistoryTexel::default(); 64];
//! let stats = pass.try_run(&mut ImageViewMut::try_new(&mut next, 8, 8, 8)?, None)?;
//! assert_eq!((stats.blended, stats.recovered), (63, 1));
//! // The green history lies outside this frame's answered colors around
//! // the pixel (all red): the history clamp (default) moves it to red
//! // before the blend. The failed pixel keeps the history.
//! assert_eq!(next[0].color, [1.0, 0.0, 0.0]);
//! assert_eq!(next[3 * 8 + 3].color, [0.0, 1.0, 0.0]);
//! assert_eq!(pass.pixel(3, 3).1, TemporalStatus::Recovered);
//!
//! // Without the clamp, the seed's blend: two frames averaged.
//! let options = TemporalOptions { clamp_history: false, ..TemporalOptions::default() };
//! let pass = TemporalPass::try_new(gbuffer, ImageView::try_new(&color, 8, 8, 8)?, ImageView::try_new(&answered, 8, 8, 8)?, Some(history), options)?;
//! assert_eq!(pass.pixel(0, 0).0.color, [0.5, 0.5, 0.0]);
//! # Ok::<(), refl_core::Error>(())
//! ```

use crate::gbuffer::Surface;
use crate::{Camera, DepthConvention, Error, GBuffer, ImageView, ImageViewMut, RowRange};
use glam::{Vec2, Vec3};

/// One texel of a history buffer: the accumulated reflection of the
/// surface the pixel showed, with that surface's depth and normal and the
/// reflection's distance for the next frame's re-projection and rejection
/// tests. 36 bytes, `repr(C)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct HistoryTexel {
    /// Accumulated reflection color (linear RGB).
    pub color: [f32; 3],
    /// Frames accumulated into `color` (the fewest of the texels it was
    /// re-projected from), at most
    /// [`TemporalOptions::max_frames`]; `0` marks a texel without history
    /// (a cleared buffer of zeros is an empty history).
    pub frames: f32,
    /// Unit world-space normal of the surface.
    pub normal: [f32; 3],
    /// Linear depth of the surface in the history's camera (positive).
    pub depth: f32,
    /// Distance from the surface to what it reflects (the mirror pass's
    /// hit `t`; `+inf` for a reflection of the sky); `0` where unknown (no
    /// distance image). A recovered pixel stores the distance its
    /// re-projection used (module docs, "Reflection-aware re-projection").
    pub distance: f32,
}

/// The previous frame's history: its texels and the camera they were
/// written with.
#[derive(Clone, Copy, Debug)]
pub struct History<'a> {
    camera: Camera,
    texels: ImageView<'a, HistoryTexel>,
}

impl<'a> History<'a> {
    /// Binds the history written last frame to that frame's camera.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `texels` is not the camera's size.
    pub fn try_new(camera: Camera, texels: ImageView<'a, HistoryTexel>) -> Result<Self, Error> {
        if texels.width() != camera.width() || texels.height() != camera.height() {
            return Err(Error::InvalidArgument);
        }
        Ok(Self { camera, texels })
    }

    /// The camera the history was written with.
    pub const fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The history's texels.
    pub const fn texels(&self) -> &ImageView<'a, HistoryTexel> {
        &self.texels
    }
}

/// Least sum of the kept texels' bilinear weights that still counts as
/// history (module docs, step 3): a sample whose surviving texels carry
/// less than this share of the bilinear footprint sits on a silhouette.
pub const MIN_HISTORY_WEIGHT: f32 = 0.05;

/// Least share of the bilinear footprint a failed pixel's history must
/// keep to be recovered (module docs, step 5): below it the pixel sits on
/// the silhouette of what the history holds, where the surviving texels
/// reflect the edge of what failed. Measured: with the report's recovery
/// setting (`max_frames = 1`, virtual point), taking history down to
/// [`MIN_HISTORY_WEIGHT`] raised the error of the Hi-Z mirror pass on the
/// room, concave and walkthrough paths; at 0.5 it lowers it on all four
/// (`refl report`, method `hiz-temporal`).
pub const MIN_RECOVERY_WEIGHT: f32 = 0.5;

/// Settings of the temporal filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TemporalOptions {
    /// Most frames the history averages (`>= 1`; `+inf` is the running
    /// mean of every frame). `1` turns the blend off (recovery remains).
    /// Default 8.
    pub max_frames: f32,
    /// Relative tolerance of the rejection test (`>= 0`, finite): a
    /// history texel is kept when its surface point lies within
    /// `depth_tolerance * z_prev` of the current surface's tangent plane
    /// (module docs, step 3). Default 0.02.
    pub depth_tolerance: f32,
    /// Least cosine between the history texel's normal and the current
    /// one (in `[-1, 1]`; `-1` tests depth only, as the seed's demo does).
    /// Default 0.9 (about 25 degrees).
    pub normal_cos: f32,
    /// Pixels whose ray failed this frame take the history where it is
    /// valid. Default `true`.
    pub recover: bool,
    /// Clamps the history color of an answered pixel to the range of this
    /// frame's answered colors in its 3x3 neighborhood before the blend
    /// (module docs, "History clamping"). Default `true`.
    pub clamp_history: bool,
}

impl Default for TemporalOptions {
    fn default() -> Self {
        Self {
            max_frames: 8.0,
            depth_tolerance: 0.02,
            normal_cos: 0.9,
            recover: true,
            clamp_history: true,
        }
    }
}

impl TemporalOptions {
    /// # Errors
    /// [`Error::InvalidArgument`] if a field is NaN or outside its range.
    pub fn try_validate(&self) -> Result<(), Error> {
        let ok = self.max_frames >= 1.0
            && self.depth_tolerance >= 0.0
            && self.depth_tolerance.is_finite()
            && (-1.0..=1.0).contains(&self.normal_cos);
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidArgument)
        }
    }
}

/// What the filter did at one pixel (module docs, steps 1, 4, 5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum TemporalStatus {
    /// No usable surface or mask 0: the history is emptied there.
    #[default]
    Skipped = 0,
    /// Answered this frame and blended with the history.
    Blended = 1,
    /// Answered this frame without usable history (first frame,
    /// off-screen, disoccluded): the current color alone.
    Reset = 2,
    /// Not answered this frame; the history's color is used.
    Recovered = 3,
    /// Not answered and no history: the current (fallback) color, marked
    /// as no history.
    Unanswered = 4,
}

/// Counts of one run over a band.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TemporalStats {
    /// Pixels answered and blended with history.
    pub blended: u32,
    /// Pixels answered without usable history.
    pub reset: u32,
    /// Failed pixels recovered from history.
    pub recovered: u32,
    /// Failed pixels without history.
    pub unanswered: u32,
    /// Pixels with a surface whose re-projected point lies behind the
    /// history's camera or outside its image.
    pub off_screen: u32,
    /// Pixels whose re-projected history texels were all rejected (depth,
    /// normal, empty) although the point lies in the history's image.
    pub rejected: u32,
}

/// The history a pixel's re-projection found: color and frames.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Found {
    color: Vec3,
    frames: f32,
    /// The kept texels' share of the bilinear footprint.
    weight: f32,
    /// The kept texels' reflection ([`Reflections::mean`]).
    reflected: Reflected,
}

/// The 2x2 texels around the sub-pixel position `(qx, qy)` (texel centers
/// at `i + 0.5`) with their bilinear weights (seed 004 Listing 4.9's
/// `linearSampler`): `(x0 + dx, y0 + dy, w)` with `(x0, y0) = floor(q -
/// 0.5)`, `a = q - 0.5 - (x0, y0)` and `w = (1 - a_x or a_x)(1 - a_y or
/// a_y)`. Shared by the temporal filter and `crate::bounce`.
pub(crate) fn bilinear_footprint(qx: f32, qy: f32) -> [(i64, i64, f32); 4] {
    let (fx, fy) = (libm::floorf(qx - 0.5), libm::floorf(qy - 0.5));
    let (ax, ay) = (qx - 0.5 - fx, qy - 0.5 - fy);
    let (x0, y0) = (fx as i64, fy as i64);
    [
        (x0, y0, (1.0 - ax) * (1.0 - ay)),
        (x0 + 1, y0, ax * (1.0 - ay)),
        (x0, y0 + 1, (1.0 - ax) * ay),
        (x0 + 1, y0 + 1, ax * ay),
    ]
}

/// The seed's depth test of a previous texel (seed 004 Sec. 4.6.4: "store
/// the previous frame's depth buffer ... compare them by an epsilon"),
/// taken along the current surface's normal: texel `(x, y)` of `camera`
/// at linear depth `z` unprojects (its center) to `at`, kept when `|(at -
/// p) . n| <= tol` for the current surface point `p` with unit normal `n`
/// (for a surface facing the camera the depth difference; on a floor seen
/// at a grazing angle it still keeps the texels of the same floor).
/// Shared by the temporal filter and `crate::bounce`. Returns `at` too.
pub(crate) fn on_tangent_plane(
    camera: &Camera,
    x: u32,
    y: u32,
    z: f32,
    p: Vec3,
    n: Vec3,
    tol: f32,
) -> (Vec3, bool) {
    let center = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
    let at = camera.unproject(center, z, DepthConvention::Linear);
    (at, (at - p).dot(n).abs() <= tol)
}

/// The virtual point of a reflection at distance `t` from the surface
/// point `p` seen from `eye`: `eye + (p - eye) (|p - eye| + t) / |p -
/// eye|`, at [`SKY_DISTANCE`] `|p - eye|` past `p` for the sky (module
/// docs, "Reflection-aware re-projection").
#[inline]
fn virtual_point(eye: Vec3, p: Vec3, t: f32) -> Vec3 {
    let v = p - eye;
    let d = v.length();
    let t = if t.is_finite() { t } else { SKY_DISTANCE * d };
    eye + v * ((d + t) / d)
}

/// A reflection distance that is known: positive (`+inf` for the sky).
#[inline]
fn known_distance(t: f32) -> Option<f32> {
    (t > 0.0).then_some(t)
}

/// What a history texel reflects.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Reflected {
    /// No distance stored.
    Unknown,
    /// The sky.
    Sky,
    /// The virtual point (module docs, "Reflection-aware re-projection").
    Point(Vec3),
}

/// The reflections of the kept texels: the weighted mean of their virtual
/// points when all have one, the sky when all are the sky, otherwise
/// (mixed or unknown) the reflection of the texel of the largest bilinear
/// weight.
#[derive(Clone, Copy, Debug)]
struct Reflections {
    sum: Vec3,
    weight: f32,
    sky: bool,
    unknown: bool,
    nearest: (Reflected, f32),
}

impl Default for Reflections {
    fn default() -> Self {
        Self {
            sum: Vec3::ZERO,
            weight: 0.0,
            sky: false,
            unknown: false,
            nearest: (Reflected::Unknown, 0.0),
        }
    }
}

impl Reflections {
    fn add(&mut self, r: Reflected, w: f32) {
        if w > self.nearest.1 {
            self.nearest = (r, w);
        }
        match r {
            Reflected::Point(v) => {
                self.sum += v * w;
                self.weight += w;
            }
            Reflected::Sky => self.sky = true,
            Reflected::Unknown => self.unknown = true,
        }
    }

    fn mean(&self) -> Reflected {
        match (self.unknown, self.sky, self.weight > 0.0) {
            (false, true, false) => Reflected::Sky,
            (false, false, true) => {
                let v = self.sum / self.weight;
                if v.is_finite() {
                    Reflected::Point(v)
                } else {
                    self.nearest.0
                }
            }
            _ => self.nearest.0,
        }
    }
}

/// Why a pixel found no history.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum NoHistory {
    /// First frame (no history given).
    None,
    /// Behind the history's camera or outside its image.
    OffScreen,
    /// Every texel around the point was rejected.
    Rejected,
}

/// The temporal filter over one frame (module docs).
#[derive(Clone, Copy, Debug)]
pub struct TemporalPass<'a> {
    gbuffer: GBuffer<'a>,
    current: ImageView<'a, [f32; 3]>,
    answered: ImageView<'a, u8>,
    distance: Option<ImageView<'a, f32>>,
    history: Option<History<'a>>,
    options: TemporalOptions,
}

/// How far past a surface a reflection of the sky is re-projected, in
/// multiples of the surface's distance from the eye (a point at infinity
/// for every camera the history can hold).
const SKY_DISTANCE: f32 = 1e6;

impl<'a> TemporalPass<'a> {
    /// Binds this frame's G-buffer, its reflection colors `current` (e.g.
    /// the mirror pass's color output, with the host's answers or
    /// fallbacks filled in), `answered` (non-zero where `current` holds an
    /// answer: for the mirror pass, [`crate::MirrorStatus::Hit`] and
    /// [`crate::MirrorStatus::Sky`], plus the pixels the host traced), the
    /// previous frame's history (`None` on the first frame or after a
    /// cut) and the options.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `current`, `answered` or the history
    /// is not the G-buffer's size, or the options are out of range.
    pub fn try_new(
        gbuffer: GBuffer<'a>,
        current: ImageView<'a, [f32; 3]>,
        answered: ImageView<'a, u8>,
        history: Option<History<'a>>,
        options: TemporalOptions,
    ) -> Result<Self, Error> {
        options.try_validate()?;
        let (w, h) = (gbuffer.width(), gbuffer.height());
        let same = |vw: u32, vh: u32| vw == w && vh == h;
        if !same(current.width(), current.height())
            || !same(answered.width(), answered.height())
            || history.is_some_and(|hi| !same(hi.texels.width(), hi.texels.height()))
        {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            gbuffer,
            current,
            answered,
            distance: None,
            history,
            options,
        })
    }

    /// Adds this frame's reflection distances (the mirror pass's hit `t`
    /// of each answered pixel, `+inf` for the sky; `0`, negative or NaN
    /// where unknown): the history is then re-projected through the
    /// reflection's virtual point (module docs, "Reflection-aware
    /// re-projection") instead of the reflector's surface point.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `distance` is not the G-buffer's size.
    pub fn try_with_distance(mut self, distance: ImageView<'a, f32>) -> Result<Self, Error> {
        if distance.width() != self.gbuffer.width() || distance.height() != self.gbuffer.height() {
            return Err(Error::InvalidArgument);
        }
        self.distance = Some(distance);
        Ok(self)
    }

    /// The options.
    pub const fn options(&self) -> &TemporalOptions {
        &self.options
    }

    /// History texel `(x, y)`, if kept for the surface point `p` with unit
    /// normal `n` at depth `z` in the history's camera, whose reflection's
    /// virtual point is `expect` if known (with its distance: module docs,
    /// step 3 and "Reflection-aware re-projection").
    #[allow(clippy::too_many_arguments)]
    fn kept(
        &self,
        hist: &History<'_>,
        x: i64,
        y: i64,
        p: Vec3,
        n: Vec3,
        z: f32,
        expect: Option<(Vec3, f32)>,
    ) -> Option<(HistoryTexel, Reflected)> {
        if x < 0 || y < 0 {
            return None;
        }
        let t = hist.texels.get(x as u32, y as u32)?;
        if !(t.frames > 0.0 && t.frames.is_finite() && Vec3::from_array(t.color).is_finite()) {
            return None;
        }
        let (at, plane_ok) = on_tangent_plane(
            &hist.camera,
            x as u32,
            y as u32,
            t.depth,
            p,
            n,
            self.options.depth_tolerance * z,
        );
        let normal_ok = self.options.normal_cos <= -1.0
            || Vec3::from_array(t.normal).dot(n) >= self.options.normal_cos;
        let eye = hist.camera.eye();
        let reflected = match known_distance(t.distance) {
            Some(d) if d.is_finite() => Reflected::Point(virtual_point(eye, at, d)),
            Some(_) => Reflected::Sky,
            None => Reflected::Unknown,
        };
        // The same reflected surface: the texel's own virtual point as far
        // from the history's eye as this one within the tolerance (its
        // lateral offset is the texel's footprint, not a difference), or
        // both the sky.
        let distance_ok = match (expect, reflected) {
            (Some((v, e)), Reflected::Point(vh)) if e.is_finite() => {
                let r = (v - eye).length();
                ((vh - eye).length() - r).abs() <= self.options.depth_tolerance * r
            }
            (Some(_), Reflected::Point(_)) => false,
            (Some((_, e)), Reflected::Sky) => !e.is_finite(),
            _ => true,
        };
        (t.depth > 0.0 && plane_ok && normal_ok && distance_ok).then_some((t, reflected))
    }

    /// Steps 2 and 3 for the surface point `p` with unit normal `n`,
    /// re-projecting the point `at` (`p` itself, or the reflection's
    /// virtual point) and expecting the reflection distance `expect` if
    /// known.
    fn find(
        &self,
        at: Vec3,
        p: Vec3,
        n: Vec3,
        expect: Option<(Vec3, f32)>,
    ) -> Result<Found, NoHistory> {
        let hist = self.history.as_ref().ok_or(NoHistory::None)?;
        let cam = &hist.camera;
        let q = cam.project(at).ok_or(NoHistory::OffScreen)?;
        // The tolerance scale: the surface's depth in the history's camera.
        let z = if at == p { q.z } else { cam.linear_depth(p) };
        if !(z > 0.0) {
            return Err(NoHistory::OffScreen);
        }
        let (w, h) = (cam.width() as f32, cam.height() as f32);
        if !(q.x >= 0.0 && q.x <= w && q.y >= 0.0 && q.y <= h) {
            return Err(NoHistory::OffScreen);
        }
        let mut sum = Vec3::ZERO;
        let (mut wsum, mut frames) = (0.0f32, f32::INFINITY);
        let mut reflections = Reflections::default();
        for (x, y, wt) in bilinear_footprint(q.x, q.y) {
            if !(wt > 0.0) {
                continue;
            }
            if let Some((t, r)) = self.kept(hist, x, y, p, n, z, expect) {
                sum += Vec3::from_array(t.color) * wt;
                frames = frames.min(t.frames);
                reflections.add(r, wt);
                wsum += wt;
            }
        }
        if !(wsum >= MIN_HISTORY_WEIGHT) {
            return Err(NoHistory::Rejected);
        }
        let color = sum / wsum;
        // A weighted mean of finite colors is finite unless the sum
        // overflowed; such history is dropped rather than propagated.
        if !color.is_finite() {
            return Err(NoHistory::Rejected);
        }
        Ok(Found {
            color,
            frames,
            weight: wsum,
            reflected: reflections.mean(),
        })
    }

    /// Steps 2 and 3 for the surface `s` seen from `eye` (module docs):
    /// through the reflection's virtual point at distance `t` where known
    /// (this frame's), or else at the distance the history's virtual point
    /// puts it (a failed pixel), through the surface point otherwise. Also
    /// returns the distance used, `0` for none.
    fn find_for(&self, s: &Surface, eye: Vec3, t: Option<f32>) -> (Result<Found, NoHistory>, f32) {
        let (p, n) = (s.position, s.normal);
        if self.distance.is_none() {
            return (self.find(p, p, n, None), 0.0);
        }
        let t = match t {
            Some(t) => Some(t),
            // A failed pixel: the distance along its own ray to the virtual
            // point the history holds where its surface was, refined twice by
            // the virtual point the history holds there (a fixed point where
            // the reflection varies smoothly, as on a planar mirror).
            None => {
                let d = (p - eye).length();
                let along = |r: Reflected| match r {
                    Reflected::Point(v) => known_distance((v - eye).length() - d),
                    Reflected::Sky => Some(f32::INFINITY),
                    Reflected::Unknown => None,
                };
                let probe = |at: Vec3| {
                    self.find(at, p, n, None)
                        .ok()
                        .and_then(|f| along(f.reflected))
                };
                let mut t = probe(p);
                for _ in 0..2 {
                    let Some(guess) = t else { break };
                    let at = virtual_point(eye, p, guess);
                    if !at.is_finite() {
                        break;
                    }
                    t = probe(at).or(Some(guess));
                }
                t
            }
        };
        match t {
            Some(t) => {
                let at = virtual_point(eye, p, t);
                if at.is_finite() {
                    (self.find(at, p, n, Some((at, t))), t)
                } else {
                    (self.find(p, p, n, None), 0.0)
                }
            }
            None => (self.find(p, p, n, None), 0.0),
        }
    }

    /// The per-channel range of `cur` (pixel `(x, y)`'s finite current
    /// color) and this frame's finite answered colors in the 3x3 pixels
    /// around `(x, y)` (module docs, "History clamping").
    fn neighborhood_range(&self, x: u32, y: u32, cur: Vec3) -> (Vec3, Vec3) {
        let (mut lo, mut hi) = (cur, cur);
        let (w, h) = (self.gbuffer.width(), self.gbuffer.height());
        for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
            for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                if self.answered.get(nx, ny).unwrap_or(0) == 0 {
                    continue;
                }
                let c = Vec3::from_array(self.current.get(nx, ny).unwrap_or([f32::NAN; 3]));
                if c.is_finite() {
                    lo = lo.min(c);
                    hi = hi.max(c);
                }
            }
        }
        (lo, hi)
    }

    /// Pixel `(x, y)`'s next history texel and status (module docs), and
    /// why it found no history, if it did not.
    fn resolve(&self, x: u32, y: u32) -> (HistoryTexel, TemporalStatus, Option<NoHistory>) {
        let cur = self.current.get(x, y).unwrap_or([0.0; 3]);
        let masked = self
            .gbuffer
            .mask()
            .is_some_and(|m| m.get(x, y).unwrap_or(0) == 0);
        let surface = if masked {
            None
        } else {
            self.gbuffer.surface(x, y)
        };
        let Some(s) = surface else {
            let t = HistoryTexel {
                color: cur,
                ..HistoryTexel::default()
            };
            return (t, TemporalStatus::Skipped, None);
        };
        let cur_v = Vec3::from_array(cur);
        let answered = self.answered.get(x, y).unwrap_or(0) != 0 && cur_v.is_finite();
        let t_cur = if answered {
            self.distance
                .as_ref()
                .and_then(|d| d.get(x, y))
                .and_then(known_distance)
        } else {
            None
        };
        let (found, t_used) = self.find_for(&s, self.gbuffer.camera().eye(), t_cur);
        let texel = |color: Vec3, frames: f32, distance: f32| HistoryTexel {
            color: color.to_array(),
            frames,
            normal: s.normal.to_array(),
            depth: s.depth,
            distance,
        };
        let t_now = t_cur.unwrap_or(0.0);
        match (answered, found) {
            (true, Ok(hist)) => {
                let n = (hist.frames + 1.0).min(self.options.max_frames);
                let h = if self.options.clamp_history {
                    let (lo, hi) = self.neighborhood_range(x, y, cur_v);
                    hist.color.clamp(lo, hi)
                } else {
                    hist.color
                };
                let color = h + (cur_v - h) / n;
                // current and history finite: so is a convex combination,
                // except where `cur - hist` overflows; fall back to the
                // current color there.
                let color = if color.is_finite() { color } else { cur_v };
                (texel(color, n, t_now), TemporalStatus::Blended, None)
            }
            (true, Err(why)) => (texel(cur_v, 1.0, t_now), TemporalStatus::Reset, Some(why)),
            // The count capped: history written with a larger
            // `max_frames` (or by the host) may hold more frames than this
            // frame's cap, the range `HistoryTexel::frames` promises (fuzz
            // finding F30); the next blend caps it anyway.
            (false, Ok(hist)) if self.options.recover && hist.weight >= MIN_RECOVERY_WEIGHT => (
                texel(hist.color, hist.frames.min(self.options.max_frames), t_used),
                TemporalStatus::Recovered,
                None,
            ),
            (false, found) => {
                let mut t = texel(Vec3::ZERO, 0.0, 0.0);
                t.color = cur;
                (t, TemporalStatus::Unanswered, found.err())
            }
        }
    }

    /// Pixel `(x, y)`'s next history texel and what the filter did there
    /// (what [`TemporalPass::try_run`] writes); `(default, Skipped)`
    /// outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> (HistoryTexel, TemporalStatus) {
        if x >= self.gbuffer.width() || y >= self.gbuffer.height() {
            return (HistoryTexel::default(), TemporalStatus::Skipped);
        }
        let (t, s, _) = self.resolve(x, y);
        (t, s)
    }

    /// Runs the filter over the rows `next` owns (a whole image or a band
    /// from [`ImageViewMut::try_band`]): writes every pixel's next history
    /// texel (its `color` is this frame's filtered reflection) and, if
    /// given, its [`TemporalStatus`] as a byte into `status`.
    ///
    /// Contract: `next` is the next frame's history, not the one this pass
    /// reads (Rust's borrows guarantee it); `next` and `status` are the
    /// G-buffer's size and own the same rows.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `next` or `status` is not the
    /// G-buffer's size or their bands differ. Nothing is written then.
    pub fn try_run(
        &self,
        next: &mut ImageViewMut<'_, HistoryTexel>,
        mut status: Option<&mut ImageViewMut<'_, u8>>,
    ) -> Result<TemporalStats, Error> {
        let (w, h) = (self.gbuffer.width(), self.gbuffer.height());
        let Some(rows) = crate::image::try_output_rows(next, status.as_deref(), w, h)? else {
            return Ok(TemporalStats::default());
        };
        Ok(self.run_rows(rows, &mut |x, y, t, st| {
            crate::image::put_pixel(next, status.as_deref_mut(), x, y, *t, st as u8);
        }))
    }

    /// Runs the filter over `rows` (checked against the G-buffer's height)
    /// and hands every pixel's texel and status to `sink`: the loop of
    /// [`TemporalPass::try_run`] for hosts whose buffers are not
    /// [`ImageViewMut`]s.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `rows` ends beyond the G-buffer's
    /// height. Nothing is handed to `sink` then.
    pub fn try_run_rows(
        &self,
        rows: RowRange,
        sink: &mut impl FnMut(u32, u32, &HistoryTexel, TemporalStatus),
    ) -> Result<TemporalStats, Error> {
        if rows.end() > self.gbuffer.height() {
            return Err(Error::InvalidArgument);
        }
        Ok(self.run_rows(rows, sink))
    }

    fn run_rows(
        &self,
        rows: RowRange,
        sink: &mut impl FnMut(u32, u32, &HistoryTexel, TemporalStatus),
    ) -> TemporalStats {
        let mut stats = TemporalStats::default();
        for y in rows.rows() {
            for x in 0..self.gbuffer.width() {
                let (t, s, why) = self.resolve(x, y);
                match s {
                    TemporalStatus::Skipped => {}
                    TemporalStatus::Blended => stats.blended += 1,
                    TemporalStatus::Reset => stats.reset += 1,
                    TemporalStatus::Recovered => stats.recovered += 1,
                    TemporalStatus::Unanswered => stats.unanswered += 1,
                }
                match why {
                    Some(NoHistory::OffScreen) => stats.off_screen += 1,
                    Some(NoHistory::Rejected) => stats.rejected += 1,
                    Some(NoHistory::None) | None => {}
                }
                sink(x, y, &t, s);
            }
        }
        stats
    }
}
