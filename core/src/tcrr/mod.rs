//! Temporal reflection reprojection, TCRR (seed 000, Xie, Wang, Dutré 2017).
//!
//! Reuses the reflections of a key frame in later frames of a moving camera
//! and re-traces only the pixels that cannot be reused (seed 000 Alg. 1):
//!
//! 1. **Reflection buffers** (Sec. 3.1, [`ReflectionBuffers`]): per key-frame
//!    pixel the normal and depth (B.1), the specular factor (B.2), the
//!    reflected color (B.3) and the reflected ray's travel distance (B.4),
//!    as caller image views.
//! 2. **Reflection pixel matching** (Sec. 3.2.1, [`search::try_search`]): per
//!    reflective pixel `s`, the pixel `s*` of the key frame whose surface
//!    reflects `s`'s reflected point toward the *current* eye, found by
//!    descending the [`reflection_distance`] function (Fig. 4) over 3x3
//!    neighborhoods (Alg. 2); the offsets `s* - s` go to an offset buffer
//!    with [`INVALID_OFFSET`] where no match exists.
//! 3. **Reflection shifting** (Sec. 3.2.2, [`shift::try_shift`]): the grid mesh
//!    of the reflection buffer, each vertex moved by its offset, rasterized
//!    into an intermediate reflection image with the depth test on
//!    `s.d + s.r`; the mesh is cut at depth discontinuities and triangles
//!    magnified beyond a threshold (16 in the seed) are discarded.
//! 4. **Warping and composition** (Sec. 3.3, [`try_warp`]): the intermediate
//!    image, attached to the key frame's surfaces, is warped into the
//!    current view by depth (reverse reprojection); disoccluded and
//!    uncovered pixels form the re-trace mask and a compact pixel list for
//!    the host's ray tracer ([`warp::try_retrace_list`]); [`warp::try_compose`]
//!    blends diffuse and reflection with Fresnel weights; the
//!    [`KeyFramePolicy`] starts a new key frame when the re-trace share
//!    exceeds a threshold (0.3 in the seed, Sec. 4.4).
//!
//! Every pass takes the band of rows its mutable output views own
//! ([`crate::ImageViewMut::try_split_at_row`]), so a host can thread it; the
//! result does not depend on the banding.
//!
//! # Example
//! The distance function and the key-frame policy; the passes have their own
//! examples ([`search`], [`shift`], [`warp`]).
//! ```rust
//! use refl_core::glam::Vec3;
//! use refl_core::{reflection_distance, KeyFramePolicy, Reflected};
//!
//! // A floor point W = (0, 0, -1) reflects the eye's view of R = (0, 2, -3) into the
//! // eye (0, 1, 0): the ray from R's mirror image (0, -2, -3) through W meets the eye.
//! let (eye, r) = (Vec3::Y, Reflected::Point(Vec3::new(0.0, 2.0, -3.0)));
//! assert!(reflection_distance(eye, Vec3::new(0.0, 0.0, -1.0), Vec3::Y, r).unwrap() < 1e-6);
//! // Through W' = (0, 0, -2) the ray runs along (0, 2, 1) / sqrt(5) and passes the
//! // eye at |(0, 1, 2) x (0, 2, 1)| / sqrt(5) = 3 / sqrt(5).
//! let d = reflection_distance(eye, Vec3::new(0.0, 0.0, -2.0), Vec3::Y, r).unwrap();
//! assert!((d - 3.0 / 5f32.sqrt()).abs() < 1e-5);
//! // A floor seen from below reflects nothing into the eye.
//! assert_eq!(reflection_distance(eye, Vec3::new(0.0, 0.0, -1.0), Vec3::NEG_Y, r), None);
//!
//! // A new key frame once more than 30% of the reflective pixels need re-tracing.
//! let policy = KeyFramePolicy::try_new(0.3)?;
//! assert!(!policy.needs_key_frame(30, 100) && policy.needs_key_frame(31, 100));
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! Errata and choices (checked against the seed, see the tests):
//! * Alg. 2 line 3 back-projects `s.r`; the surface position comes from the
//!   depth `s.d` (the reflected distance `s.r` enters line 4).
//! * Alg. 2 line 11 stops only when the best neighbor is strictly worse;
//!   on a plateau (equal distances) it would cycle. Here the search stops
//!   unless a neighbor is strictly better, and an iteration cap ends it
//!   (INVALID).
//! * The distance function is undefined when `R` lies on the candidate's
//!   tangent plane (`M = R` and the ray from `M` through `W_n` is tangent;
//!   `M = W_n` when `R = W_n`; design.md erratum); such candidates have no
//!   distance ([`reflection_distance`] returns `None`), as do candidates the
//!   eye sees from behind.
//! * Reflected rays that leave the scene (`s.r = +inf`) reflect a point at
//!   infinity; the distance function then uses the limit of the ray from
//!   `M` (a line through `W_n` in the mirrored direction).
//! * Sub-pixel offsets (an addition, on by default): the seed's offsets are
//!   whole pixels. At the converged pixel the zero of the distance function
//!   on its tangent plane is found in closed form (where the line from the
//!   eye to `M` crosses the plane) and projected into the key camera,
//!   which places the match between pixel centers
//!   ([`TcrrOptions::subpixel`]).

pub mod search;
pub mod shift;
pub mod warp;

use crate::{Camera, DepthConvention, Error, ImageView, ImageViewMut};
use core::mem::size_of;
use glam::Vec3;

pub use search::{try_search, SearchStats};
pub use shift::{try_shift, ShiftStats, COVERAGE_EDGE, COVERAGE_NONE, COVERAGE_REUSE};
pub use warp::{
    fresnel_weight, retrace_count, try_compose, try_retrace_list, try_warp, CurrentView, Fresnel,
    WarpStats, MASK_NONE, MASK_RETRACE, MASK_REUSED,
};

/// Caller-buffer bytes per pixel of one TCRR frame besides the host's own
/// G-buffer: the key frame's reflection buffers (depth 4, normal 12,
/// specular 4, color 12, distance 4), its [`Surfel`]s (32), the offsets
/// (8), the intermediate image of [`try_shift`] (color 12, depth 4, coverage
/// 1), the warped color (12), the re-trace mask (1) and the re-trace list
/// of [`try_retrace_list`] (4, worst case).
pub const BYTES_PER_PIXEL: usize = 4 * size_of::<f32>() // depth, specular, distance, shifted depth
    + 4 * size_of::<[f32; 3]>() // normal, color, shifted color, warped color
    + size_of::<Surfel>()
    + size_of::<[f32; 2]>() // offsets
    + 2 * size_of::<u8>() // coverage, mask
    + size_of::<u32>(); // re-trace list

/// The caller-buffer bytes TCRR needs for a `width x height` frame with
/// tightly packed rows: `width * height * `[`BYTES_PER_PIXEL`] (size each
/// image with [`crate::image::try_required_len`]).
///
/// # Errors
/// [`Error::InvalidArgument`] for a zero size or a count that does not fit
/// in `usize`.
pub fn try_frame_bytes(width: u32, height: u32) -> Result<usize, Error> {
    if width == 0 || height == 0 {
        return Err(Error::InvalidArgument);
    }
    (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(BYTES_PER_PIXEL))
        .ok_or(Error::InvalidArgument)
}

/// The offset-buffer value of a pixel without a match (seed 000 Alg. 2,
/// "INVALID"). Any offset with a non-finite component reads as invalid.
pub const INVALID_OFFSET: [f32; 2] = [f32::INFINITY, f32::INFINITY];

/// `true` for a usable offset (both components finite).
#[inline]
pub fn offset_is_valid(o: [f32; 2]) -> bool {
    o[0].is_finite() && o[1].is_finite()
}

/// Positions within this many pixels of a texel center are taken as that
/// texel (sub-pixel offsets snap to whole pixels, warped positions to texel
/// centers), so a stationary camera reproduces its key frame exactly
/// instead of through a resampling blur of f32 rounding.
pub const SNAP_PX: f32 = 1.0 / 256.0;

/// Below this value of `n . (R - W_n) / |R - W_n|` the reflected point lies
/// (numerically) on the candidate's tangent plane and the distance function
/// is undefined (8 f32 epsilons, the threshold [`crate::Camera`]-adjacent
/// modules use for collinearity).
pub const GRAZING_SINE: f32 = 8.0 * f32::EPSILON;

/// What a key-frame pixel's reflected ray reached (seed 000 Alg. 2 line 4:
/// `R = reflect(s.n, E_old) s.r + W`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reflected {
    /// A reflected surface point `R` (finite reflected distance).
    Point(Vec3),
    /// The direction of a reflected ray that left the scene: `R` at
    /// infinity.
    Direction(Vec3),
}

/// The distance function of seed 000 Sec. 3.2.1 (Fig. 4): the Euclidean
/// distance from the eye `eye` to the ray that starts at `M`, the reflected
/// point `R` mirrored about the candidate's tangent plane (through
/// `surface` = `W_n` with normal `normal` = `s_n.n`), and passes through
/// `W_n`. Zero means the candidate reflects `R` exactly into the eye.
///
/// With `e = eye - W_n`, `h_R = n . (R - W_n)` and the ray direction
/// `v = reflect((R - W_n) / |R - W_n|, n)`, the ray point nearest the eye
/// has parameter `s = e . v + |R - W_n|` from `M`; the result is `|e x v|`
/// for `s >= 0` and `|eye - M|` otherwise (the eye "before" the ray's
/// start). For [`Reflected::Direction`] `d` the ray starts at infinity and
/// the result is `|e x reflect(d, n)|`.
///
/// `normal` need not be unit length (it is normalized here).
///
/// Returns `None` where the function is undefined or the candidate cannot
/// reflect anything into the eye: non-finite input or a zero normal; `R` on
/// or behind the tangent plane (`h_R <= `[`GRAZING_SINE`]` |R - W_n|`, which
/// includes `R = W_n`, design.md erratum); the eye on or behind the tangent
/// plane (`n . e <= 0`).
pub fn reflection_distance(
    eye: Vec3,
    surface: Vec3,
    normal: Vec3,
    reflected: Reflected,
) -> Option<f32> {
    if !(eye.is_finite() && surface.is_finite()) {
        return None;
    }
    let n = normal.try_normalize()?;
    let e = eye - surface;
    if !(n.dot(e) > 0.0) {
        return None;
    }
    match reflected {
        Reflected::Point(r) => {
            if !r.is_finite() {
                return None;
            }
            let rr = r - surface;
            let len = rr.length();
            let h = n.dot(rr);
            if !(h > GRAZING_SINE * len) {
                return None;
            }
            // v = (W_n - M) / |W_n - M|; |W_n - M| = |R - W_n| (a mirror
            // is an isometry), and W_n - M = 2 h n - (R - W_n).
            let v = (2.0 * h * n - rr) / len;
            let s = e.dot(v) + len;
            let d = if s >= 0.0 {
                // (E - M) x v = (e + len v) x v = e x v: no cancellation
                // against the (possibly large) |R - W_n|.
                e.cross(v).length()
            } else {
                (e + v * len).length()
            };
            d.is_finite().then_some(d)
        }
        Reflected::Direction(dir) => {
            let d = dir.try_normalize()?;
            let h = n.dot(d);
            if !(h > GRAZING_SINE) {
                return None;
            }
            let v = 2.0 * h * n - d;
            let dist = e.cross(v).length();
            dist.is_finite().then_some(dist)
        }
    }
}

/// Settings of the TCRR passes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TcrrOptions {
    /// Iteration cap of the neighborhood search (seed 000 Alg. 2): at most
    /// this many 3x3 neighborhoods are evaluated per pixel; a search that
    /// has not converged by then records [`INVALID_OFFSET`]. At least 1.
    pub max_iterations: u32,
    /// Magnification threshold of reflection shifting (seed 000 Sec. 4.1:
    /// 16): a shifted grid triangle whose area exceeds this multiple of its
    /// original area (half a pixel) is discarded. Finite, at least 1.
    pub magnification: f32,
    /// Depth-discontinuity tolerance (relative to linear depth) of the
    /// reflector's surface: neighbors `a`, `b` are on one surface when each
    /// lies within `discontinuity * min(z_a, z_b)` of the other's tangent
    /// plane. Defines the reflector's silhouette (Alg. 2), the cuts of the
    /// grid mesh (Sec. 3.2.2) and the disocclusion test of warping
    /// (Sec. 3.3). The tangent-plane form does not cut surfaces seen at
    /// grazing angles, whose depth grows fast from pixel to pixel. Finite,
    /// positive.
    pub discontinuity: f32,
    /// Discontinuity tolerance of the reflected geometry: grid neighbors
    /// are also cut where the path lengths `s.d + s.r` differ by more than
    /// this fraction of the smaller one (the motion-parallax gaps of
    /// Sec. 3.2.2, Fig. 5), or where one reflected ray left the scene and
    /// the other did not. Finite, positive.
    pub reflected_discontinuity: f32,
    /// Refine each match between pixel centers by a quadratic fit of the
    /// squared distance over the final 3x3 neighborhood (an addition to the
    /// seed, see the module docs); `false` gives the seed's whole-pixel
    /// offsets.
    pub subpixel: bool,
    /// Re-trace threshold on the reflected color's local contrast (an
    /// addition to the seed, which names "detecting the fidelity of the
    /// projected reflections more precisely" as future work, Sec. 5): a
    /// warped pixel whose bilinear taps differ by more than this in any
    /// linear RGB channel lies on a reflected edge, where resampling the
    /// key frame cannot reproduce the ray-traced point sample, and is
    /// re-traced. Positive; `+inf` turns the test off (the seed's warping).
    pub retrace_contrast: f32,
}

impl Default for TcrrOptions {
    /// Cap 64, magnification 16 (seed 000 Sec. 4.1), discontinuity 0.02,
    /// reflected discontinuity 0.1, sub-pixel refinement on, re-trace
    /// contrast 0.1 (on the room path it re-traces about 7% more of the
    /// mirror pixels and cuts the reuse error about fourfold, see
    /// `examples/tcrr_bench.rs`).
    fn default() -> Self {
        Self {
            max_iterations: 64,
            magnification: 16.0,
            discontinuity: 0.02,
            reflected_discontinuity: 0.1,
            subpixel: true,
            retrace_contrast: 0.1,
        }
    }
}

impl TcrrOptions {
    /// Checks the ranges documented on the fields.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a field out of range.
    pub fn try_validate(&self) -> Result<(), Error> {
        let ok = self.max_iterations >= 1
            && self.magnification >= 1.0
            && self.magnification.is_finite()
            && self.discontinuity > 0.0
            && self.discontinuity.is_finite()
            && self.reflected_discontinuity > 0.0
            && self.reflected_discontinuity.is_finite()
            && self.retrace_contrast > 0.0;
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidArgument)
        }
    }
}

/// The key-frame policy of seed 000 Sec. 4.3/4.4: a frame becomes a key
/// frame (its reflection buffers are re-traced) when the share of reflective
/// pixels TCRR marks for re-tracing exceeds the threshold (0.3 in the seed).
///
/// A frame whose camera equals the last frame's, in a scene where nothing
/// moved, needs neither: the last frame's reflection is this frame's, and
/// the host skips search, shift and warp (`cpp_tests/tcrr_embree`, path
/// `still`). Nothing here decides that; only the host knows its scene is
/// static.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeyFramePolicy {
    threshold: f32,
}

impl KeyFramePolicy {
    /// A policy with re-trace share threshold `threshold` in `[0, 1]`.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a threshold outside `[0, 1]` or NaN.
    pub fn try_new(threshold: f32) -> Result<Self, Error> {
        if (0.0..=1.0).contains(&threshold) {
            Ok(Self { threshold })
        } else {
            Err(Error::InvalidArgument)
        }
    }

    /// The threshold.
    pub const fn threshold(&self) -> f32 {
        self.threshold
    }

    /// `true` if `retrace` re-traced pixels out of `reflective` reflective
    /// pixels exceed the threshold share (`retrace > threshold *
    /// reflective`, exact in f64). A frame without reflective pixels never
    /// needs a key frame.
    pub fn needs_key_frame(&self, retrace: u64, reflective: u64) -> bool {
        reflective > 0 && retrace as f64 > f64::from(self.threshold) * reflective as f64
    }
}

/// A key-frame surface sample: world position, unit normal, linear depth.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Surf {
    pub pos: Vec3,
    pub normal: Vec3,
    pub z: f32,
}

impl Surf {
    /// `true` if `self` and `other` lie on one surface: each within
    /// `tol * min(z)` of the other's tangent plane.
    #[inline(always)]
    pub fn connected(&self, other: &Surf, tol: f32) -> bool {
        let d = other.pos - self.pos;
        let lim = tol * self.z.min(other.z);
        self.normal.dot(d).abs() <= lim && other.normal.dot(d).abs() <= lim
    }
}

/// World positions of a camera's pixel centers at a linear depth, affine in
/// the pixel index ([`Camera::unproject`] without the matrix product per
/// texel; the inner loops of every pass back-project through it).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PixelRays {
    eye: Vec3,
    d0: Vec3,
    dx: Vec3,
    dy: Vec3,
}

impl PixelRays {
    pub(crate) fn new(camera: &Camera) -> Self {
        let (d0, dx, dy) = camera.pixel_center_rays();
        Self {
            eye: camera.eye(),
            d0,
            dx,
            dy,
        }
    }

    /// The point at linear depth `z` through the center of pixel `(x, y)`.
    #[inline(always)]
    pub(crate) fn point(&self, x: u32, y: u32, z: f32) -> Vec3 {
        self.eye + (self.d0 + self.dx * x as f32 + self.dy * y as f32) * z
    }
}

/// A reflected target prepared for repeated [`distance_squared`] calls
/// (a direction normalized once).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Target {
    Point(Vec3),
    Direction(Vec3),
}

impl Target {
    #[inline]
    pub(crate) fn new(r: Reflected) -> Option<Self> {
        match r {
            Reflected::Point(p) => p.is_finite().then_some(Target::Point(p)),
            Reflected::Direction(d) => d.try_normalize().map(Target::Direction),
        }
    }
}

/// The square of [`reflection_distance`] for a unit `normal` and finite
/// `eye` and `surface`, without square roots (the search compares squared
/// distances): with `u = reflect(R - W_n, n)` (`|u| = |R - W_n|`), the
/// ray's nearest point to the eye has parameter `s >= 0` iff
/// `e . u + |R - W_n|^2 >= 0`, and the squared distance is
/// `|e x u|^2 / |R - W_n|^2`, else `|e + u|^2`; for a direction `d`,
/// `|e x reflect(d, n)|^2`. `None` exactly where [`reflection_distance`]
/// is `None` (the grazing test squared: `h > 0` and
/// `h^2 > GRAZING_SINE^2 |R - W_n|^2`).
#[inline(always)]
pub(crate) fn distance_squared(eye: Vec3, surface: Vec3, n: Vec3, t: Target) -> Option<f32> {
    let e = eye - surface;
    if !(n.dot(e) > 0.0) {
        return None;
    }
    let d2 = match t {
        Target::Point(r) => {
            let rr = r - surface;
            let l2 = rr.length_squared();
            let h = n.dot(rr);
            if !(h > 0.0 && h * h > GRAZING_SINE * GRAZING_SINE * l2) {
                return None;
            }
            let u = 2.0 * h * n - rr;
            if e.dot(u) + l2 >= 0.0 {
                e.cross(u).length_squared() / l2
            } else {
                (e + u).length_squared()
            }
        }
        Target::Direction(d) => {
            let h = n.dot(d);
            if !(h > GRAZING_SINE) {
                return None;
            }
            e.cross(2.0 * h * n - d).length_squared()
        }
    };
    d2.is_finite().then_some(d2)
}

/// [`Surfel::flags`] bit: the texel sees a surface (finite positive linear
/// depth, finite non-zero normal); `pos`, `z` and `normal` are valid.
pub const SURFEL_SURFACE: u32 = 1;
/// [`Surfel::flags`] bit: the texel has a positive specular factor.
pub const SURFEL_SPECULAR: u32 = 2;
/// [`Surfel::flags`] bit: the texel's reflected distance is `>= 0` (or
/// `+inf`); with [`SURFEL_SURFACE`] and [`SURFEL_SPECULAR`] the texel is a
/// reflective sample (see [`ReflectionBuffers`]).
pub const SURFEL_DISTANCE: u32 = 4;

/// A key-frame texel back-projected once per key frame by [`try_prepare`]: the
/// surface of seed 000 Alg. 2 line 3 (`W` from the depth `s.d`) with its
/// unit normal `s.n`, which every pass reads many times per key frame
/// (the search up to a 3x3 neighborhood per pixel and step, shifting per
/// grid vertex, warping per bilinear tap). Attach a prepared image with
/// [`ReflectionBuffers::try_with_surfels`]; without one the passes
/// back-project on the fly, with identical results.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct Surfel {
    /// World position of the surface seen through the texel center.
    pub pos: [f32; 3],
    /// Linear depth of that point.
    pub z: f32,
    /// Unit normal (the stored B.1 normal, normalized).
    pub normal: [f32; 3],
    /// [`SURFEL_SURFACE`], [`SURFEL_SPECULAR`], [`SURFEL_DISTANCE`] bits.
    pub flags: u32,
}

/// Back-projects the key frame's texels into `surfels` over the rows it
/// owns (see [`Surfel`]); run it once per key frame (bands in parallel),
/// then attach the image with [`ReflectionBuffers::try_with_surfels`].
/// Returns the number of reflective samples in the band.
///
/// # Errors
/// [`Error::InvalidArgument`] (nothing written) if the image's size
/// differs from the buffers'.
pub fn try_prepare(
    surfels: &mut ImageViewMut<'_, Surfel>,
    buffers: &ReflectionBuffers<'_>,
) -> Result<u32, Error> {
    if surfels.width() != buffers.width() || surfels.height() != buffers.height() {
        return Err(Error::InvalidArgument);
    }
    let Some(rows) = surfels.owned_rows() else {
        return Ok(0);
    };
    let mut n = 0;
    for y in rows.rows() {
        for x in 0..buffers.width() {
            let mut out = Surfel::default();
            if let Some(s) = buffers.compute_surface(x, y) {
                out.pos = s.pos.to_array();
                out.z = s.z;
                out.normal = s.normal.to_array();
                out.flags |= SURFEL_SURFACE;
            }
            if buffers.specular.get(x, y).is_some_and(|s| s > 0.0) {
                out.flags |= SURFEL_SPECULAR;
            }
            if buffers.distance.get(x, y).is_some_and(|r| r >= 0.0) {
                out.flags |= SURFEL_DISTANCE;
            }
            const SAMPLE: u32 = SURFEL_SURFACE | SURFEL_SPECULAR | SURFEL_DISTANCE;
            n += u32::from(out.flags & SAMPLE == SAMPLE);
            if let Some(t) = surfels.get_mut(x, y) {
                *t = out;
            }
        }
    }
    Ok(n)
}

/// The reflection buffers of a key frame (seed 000 Sec. 3.1): the camera
/// that rendered them and, per pixel,
/// * B.1 `depth` (stored in `convention`) and the world-space `normal`
///   (facing the camera, normalized when read);
/// * B.2 `specular`: the specular factor, `> 0` marks a reflective pixel;
/// * B.3 `color`: the reflected radiance (linear RGB);
/// * B.4 `distance`: the reflected ray's travel distance from the surface
///   to the reflected point, `+inf` where it left the scene.
///
/// A pixel is a *reflective sample* if its specular factor is positive,
/// its depth decodes to a finite positive distance, its normal is finite and
/// non-zero and its distance is non-negative (or `+inf`); any other pixel
/// (NaN, negative distance, background) takes no part in matching and is
/// never reused.
#[derive(Clone, Copy, Debug)]
pub struct ReflectionBuffers<'a> {
    camera: Camera,
    rays: PixelRays,
    surfels: Option<ImageView<'a, Surfel>>,
    convention: DepthConvention,
    depth: ImageView<'a, f32>,
    normal: ImageView<'a, [f32; 3]>,
    specular: ImageView<'a, f32>,
    color: ImageView<'a, [f32; 3]>,
    distance: ImageView<'a, f32>,
}

/// A reflective key-frame sample with its reflected target.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sample {
    pub surf: Surf,
    /// Reflected distance (`+inf` allowed).
    pub r: f32,
}

impl<'a> ReflectionBuffers<'a> {
    /// Binds the five views to the key frame's camera and depth convention.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if a view's size differs from the
    /// camera's.
    pub fn try_new(
        camera: Camera,
        convention: DepthConvention,
        depth: ImageView<'a, f32>,
        normal: ImageView<'a, [f32; 3]>,
        specular: ImageView<'a, f32>,
        color: ImageView<'a, [f32; 3]>,
        distance: ImageView<'a, f32>,
    ) -> Result<Self, Error> {
        let (w, h) = (camera.width(), camera.height());
        let same = |vw: u32, vh: u32| vw == w && vh == h;
        if !(same(depth.width(), depth.height())
            && same(normal.width(), normal.height())
            && same(specular.width(), specular.height())
            && same(color.width(), color.height())
            && same(distance.width(), distance.height()))
        {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            camera,
            rays: PixelRays::new(&camera),
            surfels: None,
            convention,
            depth,
            normal,
            specular,
            color,
            distance,
        })
    }

    /// The buffers with a [`try_prepare`]d surfel image attached: the passes
    /// read each texel's surface, specular and distance flags from it
    /// instead of back-projecting. The image must have been prepared from
    /// these buffers (a stale one gives wrong matches, never a panic).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if its size differs from the buffers'.
    pub fn try_with_surfels(mut self, surfels: ImageView<'a, Surfel>) -> Result<Self, Error> {
        if surfels.width() != self.width() || surfels.height() != self.height() {
            return Err(Error::InvalidArgument);
        }
        self.surfels = Some(surfels);
        Ok(self)
    }

    /// The key frame's camera (`E_old` is its eye).
    pub const fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The depth convention of [`ReflectionBuffers::depth`].
    pub const fn convention(&self) -> DepthConvention {
        self.convention
    }

    /// B.1 depth.
    pub const fn depth(&self) -> &ImageView<'a, f32> {
        &self.depth
    }

    /// B.1 normal.
    pub const fn normal(&self) -> &ImageView<'a, [f32; 3]> {
        &self.normal
    }

    /// B.2 specular factor.
    pub const fn specular(&self) -> &ImageView<'a, f32> {
        &self.specular
    }

    /// B.3 reflected color.
    pub const fn color(&self) -> &ImageView<'a, [f32; 3]> {
        &self.color
    }

    /// B.4 reflected distance.
    pub const fn distance(&self) -> &ImageView<'a, f32> {
        &self.distance
    }

    /// Width in pixels.
    pub const fn width(&self) -> u32 {
        self.camera.width()
    }

    /// Height in pixels.
    pub const fn height(&self) -> u32 {
        self.camera.height()
    }

    /// The surface seen through texel `(x, y)`, whatever its material.
    #[inline(always)]
    pub(crate) fn surface(&self, x: u32, y: u32) -> Option<Surf> {
        match &self.surfels {
            Some(v) => {
                let s = v.get(x, y)?;
                (s.flags & SURFEL_SURFACE != 0).then(|| Surf {
                    pos: Vec3::from_array(s.pos),
                    normal: Vec3::from_array(s.normal),
                    z: s.z,
                })
            }
            None => self.compute_surface(x, y),
        }
    }

    /// [`ReflectionBuffers::surface`] and [`ReflectionBuffers::is_reflective`]
    /// of one texel, with one surfel fetch where surfels are attached.
    #[inline(always)]
    pub(crate) fn surface_reflective(&self, x: u32, y: u32) -> Option<(Surf, bool)> {
        match &self.surfels {
            Some(v) => {
                let s = v.get(x, y)?;
                if s.flags & SURFEL_SURFACE == 0 {
                    return None;
                }
                const REFLECTIVE: u32 = SURFEL_SPECULAR | SURFEL_DISTANCE;
                Some((
                    Surf {
                        pos: Vec3::from_array(s.pos),
                        normal: Vec3::from_array(s.normal),
                        z: s.z,
                    },
                    s.flags & REFLECTIVE == REFLECTIVE,
                ))
            }
            None => {
                let surf = self.compute_surface(x, y)?;
                Some((surf, self.is_reflective(x, y)))
            }
        }
    }

    /// [`ReflectionBuffers::surface`] from the B.1 buffers.
    #[inline(always)]
    fn compute_surface(&self, x: u32, y: u32) -> Option<Surf> {
        let d = self.depth.get(x, y)?;
        let z = self.camera.decode_depth(d, self.convention);
        if !(z > 0.0 && z.is_finite()) {
            return None;
        }
        let n = Vec3::from_array(self.normal.get(x, y)?).try_normalize()?;
        let pos = self.rays.point(x, y, z);
        pos.is_finite().then_some(Surf { pos, normal: n, z })
    }

    /// `true` if texel `(x, y)` is a reflective sample's texel apart from
    /// its surface: positive specular factor and a reflected distance
    /// `>= 0` (see [`ReflectionBuffers::sample`]).
    #[inline(always)]
    pub(crate) fn is_reflective(&self, x: u32, y: u32) -> bool {
        match &self.surfels {
            Some(v) => v.get(x, y).is_some_and(|s| {
                s.flags & (SURFEL_SPECULAR | SURFEL_DISTANCE) == SURFEL_SPECULAR | SURFEL_DISTANCE
            }),
            None => self.is_specular(x, y) && self.distance.get(x, y).is_some_and(|r| r >= 0.0),
        }
    }

    /// `true` if texel `(x, y)` has a positive specular factor.
    #[inline(always)]
    pub(crate) fn is_specular(&self, x: u32, y: u32) -> bool {
        match &self.surfels {
            Some(v) => v.get(x, y).is_some_and(|s| s.flags & SURFEL_SPECULAR != 0),
            None => self.specular.get(x, y).is_some_and(|s| s > 0.0),
        }
    }

    /// The reflected path length `s.d + s.r` of a texel with a positive
    /// specular factor, positive linear depth and non-negative reflected
    /// distance (`+inf` allowed); `None` otherwise. Read from the specular,
    /// depth and distance planes (12 bytes a texel), not the 32-byte
    /// surfels: shifting reads it for every grid vertex's 4-neighbors, over
    /// four rows at a time.
    #[inline(always)]
    pub(crate) fn path_length(&self, x: u32, y: u32) -> Option<f32> {
        if !self.specular.get(x, y).is_some_and(|s| s > 0.0) {
            return None;
        }
        let z = self
            .camera
            .decode_depth(self.depth.get(x, y)?, self.convention);
        let r = self.distance.get(x, y)?;
        (z > 0.0 && r >= 0.0).then_some(z + r)
    }

    /// The reflective sample at texel `(x, y)`, if it is one.
    #[inline(always)]
    pub(crate) fn sample(&self, x: u32, y: u32) -> Option<Sample> {
        if !self.is_reflective(x, y) {
            return None;
        }
        let r = self.distance.get(x, y)?;
        if !(r >= 0.0) {
            return None;
        }
        let surf = self.surface(x, y)?;
        Some(Sample { surf, r })
    }

    /// The reflected target of a sample (seed 000 Alg. 2 line 4):
    /// `R = W + s.r reflect(E_old - W, s.n)`, or the reflected direction
    /// for `s.r = +inf`. `None` if the key eye lies on the surface.
    #[inline]
    pub(crate) fn target(&self, s: &Sample) -> Option<Reflected> {
        let view = (self.camera.eye() - s.surf.pos).try_normalize()?;
        let n = s.surf.normal;
        let d = 2.0 * view.dot(n) * n - view;
        if s.r.is_infinite() {
            Some(Reflected::Direction(d))
        } else {
            let r = s.surf.pos + d * s.r;
            r.is_finite().then_some(Reflected::Point(r))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift) for the property checks.
    fn rng(state: &mut u64) -> f32 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }

    #[test]
    fn distance_squared_is_the_square_of_reflection_distance() {
        let mut st = 0x9e37_79b9_7f4a_7c15u64;
        let mut defined = 0;
        for k in 0..20_000 {
            let mut v = || Vec3::new(rng(&mut st), rng(&mut st), rng(&mut st));
            let eye = v() * 4.0;
            let w = v();
            let n = v().normalize_or(Vec3::Y);
            let r = if k % 5 == 0 {
                Reflected::Direction(v())
            } else {
                Reflected::Point(v() * 3.0)
            };
            let d = reflection_distance(eye, w, n, r);
            let d2 = Target::new(r).and_then(|t| distance_squared(eye, w, n, t));
            match (d, d2) {
                (Some(d), Some(d2)) => {
                    defined += 1;
                    let (a, b) = (f64::from(d) * f64::from(d), f64::from(d2));
                    assert!((a - b).abs() <= 1e-5 * (1.0 + a), "{a} {b}");
                }
                (None, None) => {}
                other => panic!("definedness differs: {other:?}"),
            }
        }
        assert!(defined > 5_000, "{defined}");
    }
}
