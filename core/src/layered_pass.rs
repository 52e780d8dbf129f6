//! The layered-maps reflection pass: G-buffer and a set of layered depth
//! cube maps in (seed 001, `crate::layered`), one mirror ray per
//! reflective pixel traced against every map, the nearest hit reported with
//! its map, face, texel and layer, and the pixels the maps cannot answer
//! handed back as world rays for the host's own tracer (design.md,
//! "Passes"; issue 13).
//!
//! Seed 001 renders reflections on curved reflectors from one layered depth
//! texture per *reflected object* (the objects near the reflector; the
//! surroundings come from an environment map). A host builds the maps once
//! ([`crate::layered::LayeredMapMut`]) and, per frame:
//!
//! 1. [`layered_pass_scratch_len`] and [`try_prepare_layered_pass`]: the
//!    options and every map validated, and per map its world bounding
//!    sphere ([`LayeredBound`]) in caller memory; optionally
//!    [`try_prr_masks`]: per reflector triangle, the maps that may reflect
//!    on it (seed 001 Sec. 3.2);
//! 2. [`LayeredPass::try_new`] (and [`LayeredPass::try_with_ids`],
//!    [`LayeredPass::try_with_regions`]) over the
//!    G-buffer, the maps and the bounds, then [`LayeredPass::try_run`] or
//!    [`LayeredPass::try_run_rows`] over row bands from its threads, or
//!    [`LayeredPass::try_trace_rays`] over a list of its own rays (the
//!    host rays another pass handed over, for instance).
//!
//! # Example
//! ```rust
//! use refl_core::glam::{Affine3A, Vec3};
//! use refl_core::{layered_pass_scratch_len, try_layered_len, try_prepare_layered_pass, Camera};
//! use refl_core::{DepthConvention, DepthImage, Face, GBuffer, ImageView, ImageViewMut, LayerHit};
//! use refl_core::{LayeredBound, LayeredGrid, LayeredMap, LayeredMapMut, LayeredPass};
//! use refl_core::{LayeredPassOptions, LayeredPassStatus, LayeredPassTexel, NormalSpace};
//!
//! // Once: the map of the cube [-0.5, 0.5]^3 (payload 7) in the box [-1, 1]^3, as in
//! // the `layered` module's example.
//! let grid = LayeredGrid::try_new(Vec3::splat(-1.0), Vec3::splat(1.0), 4, 1)?;
//! let len = try_layered_len(4, 1)?;
//! let (mut depth, mut payload) = (vec![0.0f32; len.depth], vec![0u32; len.payload]);
//! let (mut counts, mut bounds) = (vec![0u32; len.counts], vec![0.0f32; len.bounds]);
//! let mut map = LayeredMapMut::try_new(grid, &mut depth, &mut payload, &mut counts, &mut bounds)?;
//! map.clear();
//! for face in [Face::NegX, Face::NegY, Face::NegZ] {
//!     for (i, j) in (0..4).flat_map(|j| (0..4).map(move |i| (i, j))) {
//!         let column = grid.try_face_ray(face, i, j)?;
//!         let (u, v) = face.uv_axes();
//!         let inside = column.origin[u].abs() < 0.5 && column.origin[v].abs() < 0.5;
//!         let enter = LayerHit { t: 0.5, id: 7, front: true };
//!         let mut hits = if inside { vec![enter, LayerHit { t: 1.5, front: false, ..enter }] } else { vec![] };
//!         map.try_fill_column(face, i, j, &mut hits)?;
//!     }
//! }
//! map.build_bounds();
//! drop(map);
//! // Per frame: the cube placed around (3, 0, -2).
//! let placed = grid.try_with_transform(Affine3A::from_translation(Vec3::new(3.0, 0.0, -2.0)))?;
//! let maps = [LayeredMap::try_new(placed, &depth, &payload, &counts, &bounds)?];
//!
//! // A one-pixel G-buffer: a mirror at depth 2 straight ahead, its normal (1, 0, 1)
//! // turns the view ray (0, 0, -1) into (1, 0, 0).
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 0.1, 100.0, 1, 1)?;
//! let (front, normal) = ([2.0f32], [[1.0f32, 0.0, 1.0]]);
//! let front = DepthImage::try_new(ImageView::try_new(&front, 1, 1, 1)?, cam, DepthConvention::Linear)?;
//! let gbuffer = GBuffer::try_new(front, ImageView::try_new(&normal, 1, 1, 1)?, NormalSpace::World)?;
//! let options = LayeredPassOptions::default();
//! let mut spheres = vec![LayeredBound::default(); layered_pass_scratch_len(&maps[..])];
//! try_prepare_layered_pass(&mut spheres, &gbuffer, &maps[..], &options)?;
//! let pass = LayeredPass::try_new(gbuffer, &maps[..], options, &spheres)?;
//! let mut out = [LayeredPassTexel::default()];
//! pass.try_run(&mut ImageViewMut::try_new(&mut out, 1, 1, 1)?, None, &mut [])?;
//!
//! // From (0, 0, -2) along +X the ray enters the cube's face x = 2.5 at t = 2.5,
//! // which the -X face of the map sees.
//! let hit = out[0];
//! assert_eq!((hit.status, hit.map, hit.face, hit.payload), (LayeredPassStatus::Hit, 0, Face::NegX, 7));
//! assert!((hit.t - 2.5).abs() < 1e-4 && (hit.position - Vec3::new(2.5, 0.0, -2.0)).length() < 1e-4);
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! # Per pixel
//! 1. **Ray.** Which pixels are traced, the surface point `P`, the
//!    reflection direction `r` and where the ray starts (`t_start`) are the
//!    mirror pass's, by the same code (`crate::ssr`, module docs, steps 1
//!    to 4: mask and roughness, `r = v - 2 (v . n) n` of seed 001's
//!    appendix, the start once the ray's projection has moved
//!    [`LayeredPassOptions::start_pixels`] pixels, and no earlier than
//!    [`LayeredPassOptions::t_min`]). A ray whose projection never moves
//!    that far goes to the host ([`LayeredPassStatus::NoProjection`]); one
//!    that starts at or beyond [`LayeredPassOptions::t_max`] reaches
//!    nothing ([`LayeredPassStatus::Sky`], answered). The start rule keeps
//!    a screen-space ray off its reflector's own depth texels; the maps
//!    hold reflected objects, not the reflector (step 2), so by default
//!    the rule is off (`start_pixels = 0`: the ray starts at `t_min`, and
//!    only a ray along the line of sight has no projection). Measured on
//!    the root package's room (`tests/screen.rs`, 984 rays whose reference
//!    hit is a mapped object): 99.7% of them hit that object within a texel
//!    diagonal at 0, 99.0% at 0.5, 97.1% at 1 and 93.5% at 2 pixels (a
//!    later start passes over objects close to the reflector).
//! 2. **Which maps apply.** A map is traced unless its id equals the
//!    pixel's object id (with an id image, [`LayeredPass::try_with_ids`]:
//!    the reflector's own map; seed 001 maps reflected objects, a
//!    reflector does not reflect itself) or the ray misses the map's
//!    bounding sphere within the ray's reach (ours: the per-ray form of
//!    seed 001 Sec. 3.2, where the reflected object's bounding sphere
//!    decides which reflector regions may show it). The sphere holds the
//!    map's box with a margin ([`BOUND_SLACK`]), so a ray it rejects is one
//!    the kernel reports as [`LayeredMiss::MissedBox`] after no work: the
//!    cull changes the cost, never the result. With regions
//!    ([`LayeredPass::try_with_regions`]) the seed's own, per-triangle form
//!    of Sec. 3.2 (Fig. 2(a)) comes first: a pixel traces only the maps
//!    its reflector triangle's mask holds ([`try_prr_masks`], once per
//!    frame per triangle and map instead of once per ray and map). The
//!    masks are widened to keep every map whose sphere test a pixel's ray
//!    of that triangle can pass ([`prr_radii`]), so regions too change the
//!    cost only: [`LayeredPassStats::prr_skipped`] counts the sphere tests
//!    they save, [`LayeredPassStats::sphere_culled`] the ones left.
//! 3. **Trace** ([`LayeredMap::try_trace`], seed 001 Sec. 3.3-3.4 and
//!    Algorithm 1, with [`LayeredPassOptions::trace`]) of the ray from
//!    `P + t_start r`, the maps in their order: the first up to
//!    `t_max - t_start`, each later one only up to the nearest hit so far
//!    (a map whose surface lies behind it cannot be seen); the nearest hit
//!    wins, the earlier map on a tie. `t` is reported from `P`.
//! 4. **Hit.** The map's index, face, texel and layer, the hit's position
//!    on the face in texels (its sub-texel position), the payload, and a
//!    confidence from the kernel's mismatch `m` (how far behind the
//!    surface the searched face stores the hit lies, in texels): `1` when
//!    `m` is within the seed's early-stop threshold `e`
//!    ([`LayeredOptions::early_stop_texels`]: the face sees the surface it
//!    hit, seed 001 Sec. 3.3), `e / m` beyond it (the ray entered the
//!    face's column through its side, seed 001 Fig. 5: the further behind,
//!    the less the stored depth says about the hit; ours).
//! 5. **Shade.** The maps carry a `u32` payload per layer, whatever the
//!    host stored (a primitive id, a packed color). With
//!    [`LayeredPassOptions::payload_color`] the payload is a packed color
//!    (bytes `r, g, b, a` from the least significant, as a little-endian
//!    `refl_rgba8`) and a color output gets `[r, g, b] / 255` at each hit
//!    (black elsewhere); without it the host shades from the payload.
//!
//! # What goes to the host
//! A ray that hits no map is appended to the host list as a
//! [`LayeredHostRay`] from `P` with the options' `t_min` and `t_max`, its
//! status saying why: it met no mapped object ([`LayeredPassStatus::LeftMaps`]:
//! the surroundings, which the maps do not hold), a map's step cap ran
//! out ([`LayeredPassStatus::OutOfSteps`]), or it starts inside a mapped
//! object ([`LayeredPassStatus::StartedInside`]: a disocclusion, the map
//! holds no surface the ray can see from there), or it has no usable
//! projection ([`LayeredPassStatus::NoProjection`]). The list is the
//! caller's slice; rays past its end are counted, and
//! [`LayeredPass::host_ray`] gives any pixel's ray again.

use crate::layered::{
    try_prr_classify, Face, LayeredGrid, LayeredHit, LayeredMap, LayeredMiss, LayeredTrace,
    PrrTriangle,
};
use crate::ssr::Setup;
use crate::{
    Error, GBuffer, HostRay, ImageView, ImageViewMut, LayeredOptions, MirrorOptions, MirrorPass,
    MirrorRay, MirrorStatus, Ray, RowRange,
};
use glam::{DVec3, Vec2, Vec3};

/// Relative margin of a map's bounding sphere in the per-ray test (module
/// docs, step 2): the sphere is widened by this times the distances from
/// the world origin to the ray's start and from there to the sphere's
/// center, far beyond the f32 rounding of the kernel's box coordinates
/// (about `1e-7` of the same distances), so that every ray the kernel
/// clips to the box passes the test.
pub const BOUND_SLACK: f64 = 1e-4;

/// Settings of the layered pass. [`LayeredPassOptions::default`] is what
/// the root package's report runs (with every reflective pixel traced).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayeredPassOptions {
    /// The kernel's settings ([`LayeredMap::try_trace`]).
    pub trace: LayeredOptions,
    /// Where a ray starts: once its projection has moved this many pixels
    /// from its surface point (finite, `>= 0`; as
    /// [`MirrorOptions::start_pixels`]; module docs, step 1: 0 by
    /// default).
    pub start_pixels: f32,
    /// A ray starts no earlier than this distance from its surface point
    /// (finite, `>= 0`).
    pub t_min: f32,
    /// The longest ray, world units (`> t_min`; `+inf` allowed).
    pub t_max: f32,
    /// Pixels with a roughness above this are not traced (used only with
    /// a roughness image; NaN roughness is never traced). Not NaN.
    pub max_roughness: f32,
    /// The maps' payloads are packed colors (module docs, step 5).
    pub payload_color: bool,
}

impl Default for LayeredPassOptions {
    /// The kernel's defaults ([`LayeredOptions::default`]), no start
    /// offset (`start_pixels = 0`, `t_min = 0`; module docs, step 1),
    /// `t_max = +inf`, the mirror pass's roughness limit (0.1), payloads
    /// that are not colors.
    fn default() -> Self {
        let m = MirrorOptions::default();
        Self {
            trace: LayeredOptions::default(),
            start_pixels: 0.0,
            t_min: m.t_min,
            t_max: m.t_max,
            max_roughness: m.max_roughness,
            payload_color: false,
        }
    }
}

impl LayeredPassOptions {
    /// The mirror pass's options whose rays this pass traces: the same
    /// start, `t_min`, `t_max` and roughness limit, the mirror pass's
    /// defaults otherwise (its kernel settings are not used).
    pub fn mirror_options(&self) -> MirrorOptions {
        MirrorOptions {
            start_pixels: self.start_pixels,
            t_min: self.t_min,
            t_max: self.t_max,
            max_roughness: self.max_roughness,
            border_fade: 0.0,
            ..MirrorOptions::default()
        }
    }

    /// Checks every option's range (see the fields); the pass's calls do
    /// it themselves.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for an option out of its range.
    pub fn try_validate(&self) -> Result<(), Error> {
        self.trace.validate()?;
        crate::ssr::validate_options(&self.mirror_options())
    }
}

/// What the pass did at one pixel (or one ray of a list).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum LayeredPassStatus {
    /// Not reflective (mask 0, roughness above the limit or NaN), or not in
    /// the rows a run wrote.
    #[default]
    Skipped = 0,
    /// No usable surface: sky, NaN depth, zero or non-finite normal.
    NoSurface = 1,
    /// The ray hit a map's object.
    Hit = 2,
    /// The ray starts at or beyond `t_max`: it reaches nothing (answered).
    Sky = 3,
    /// Host: the ray met no mapped object (it missed or crossed every box).
    LeftMaps = 4,
    /// Host: a map's step cap was reached and no map hit.
    OutOfSteps = 5,
    /// Host: the ray starts inside a mapped object (a disocclusion) and no
    /// map hit.
    StartedInside = 6,
    /// Host: the ray has no usable projection (it never moves
    /// `start_pixels` from its origin); not traced.
    NoProjection = 7,
}

impl LayeredPassStatus {
    /// `true` for the statuses whose pixels are handed to the host.
    pub const fn needs_host(self) -> bool {
        matches!(
            self,
            Self::LeftMaps | Self::OutOfSteps | Self::StartedInside | Self::NoProjection
        )
    }
}

/// One pixel (or one listed ray) of the pass's output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayeredPassTexel {
    /// What happened.
    pub status: LayeredPassStatus,
    /// Index of the map hit (into the maps the pass traces); 0 without a
    /// hit.
    pub map: u32,
    /// The face whose search found the hit; [`Face::PosX`] without a hit.
    pub face: Face,
    /// The texel `(i, j)` of that face; `[0, 0]` without a hit.
    pub texel: [u32; 2],
    /// The hit's position on that face in texels (the texel axes of
    /// [`Face::uv_axes`], `0..face_res`; the sub-texel position), always
    /// within `texel`'s cell `[i, i + 1] x [j, j + 1]`: where the map's
    /// transform is so stretched that `position` at f32 resolution falls
    /// outside the box, the cell bounds it; `[0, 0]` without a hit.
    pub uv: Vec2,
    /// The layer of that texel the hit lies in; 0 without a hit.
    pub layer: u32,
    /// The layer's payload; 0 without a hit.
    pub payload: u32,
    /// Distance along the ray from its surface point (a listed ray: its
    /// origin) to the hit (world units); 0 without a hit.
    pub t: f32,
    /// World position of the hit; 0 without a hit.
    pub position: Vec3,
    /// Confidence of the hit in `[0, 1]` (module docs, step 4); 0 without a
    /// hit.
    pub confidence: f32,
    /// The ray's unit direction (where to sample a probe); 0 for pixels
    /// without a ray (skipped, no surface).
    pub dir: Vec3,
    /// Buffer reads of the kernel, summed over the maps traced.
    pub fetches: u32,
}

impl Default for LayeredPassTexel {
    fn default() -> Self {
        Self {
            status: LayeredPassStatus::Skipped,
            map: 0,
            face: Face::PosX,
            texel: [0; 2],
            uv: Vec2::ZERO,
            layer: 0,
            payload: 0,
            t: 0.0,
            position: Vec3::ZERO,
            confidence: 0.0,
            dir: Vec3::ZERO,
            fetches: 0,
        }
    }
}

/// A pixel's (or a listed ray's) reflection ray for the host's tracer
/// (C: `refl_host_ray` with a `refl_layered_pass_status`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LayeredHostRay {
    /// Pixel column.
    pub x: u32,
    /// Pixel row.
    pub y: u32,
    /// The surface point (a listed ray: its origin; add the host's own
    /// offset).
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// Trace from this distance ([`LayeredPassOptions::t_min`]; a listed
    /// ray: its own).
    pub t_min: f32,
    /// Trace up to this distance ([`LayeredPassOptions::t_max`]; a listed
    /// ray: its own).
    pub t_max: f32,
    /// Why the maps did not answer.
    pub status: LayeredPassStatus,
}

/// Counts of one run over a band (or a ray list).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LayeredPassStats {
    /// Rays traced (pixels: reflective with a surface).
    pub traced: u32,
    /// Hits.
    pub hits: u32,
    /// Rays answered as sky.
    pub sky: u32,
    /// Rays that need the host's tracer.
    pub host_rays: u32,
    /// Of those, the ones written to the host list (the first ones in
    /// order; the rest did not fit).
    pub host_rays_written: u32,
    /// Kernel traces (a ray against one map), summed.
    pub kernel_traces: u64,
    /// Buffer reads of the kernel, summed.
    pub fetches: u64,
    /// (ray, map) pairs whose map the ray's bounding-sphere test rejected
    /// (module docs, step 2): no kernel trace.
    pub sphere_culled: u64,
    /// (ray, map) pairs the pixel's region mask skipped before the sphere
    /// test ([`LayeredPass::try_with_regions`], module docs, step 2): the
    /// lookups seed 001 Sec. 3.2's test saves. The masks are conservative,
    /// so every such pair is one the sphere test would have rejected:
    /// `sphere_culled + prr_skipped` of a run with regions is
    /// `sphere_culled` of the same run without them, and every other count
    /// and every texel are the same.
    pub prr_skipped: u64,
}

impl LayeredPassStats {
    /// The counts of two runs (bands) added.
    pub fn sum(&self, o: &Self) -> Self {
        Self {
            traced: self.traced + o.traced,
            hits: self.hits + o.hits,
            sky: self.sky + o.sky,
            host_rays: self.host_rays + o.host_rays,
            host_rays_written: self.host_rays_written + o.host_rays_written,
            kernel_traces: self.kernel_traces + o.kernel_traces,
            fetches: self.fetches + o.fetches,
            sphere_culled: self.sphere_culled + o.sphere_culled,
            prr_skipped: self.prr_skipped + o.prr_skipped,
        }
    }
}

/// The world bounding sphere of one map and the key of the map it was
/// computed for: what [`try_prepare_layered_pass`] writes per map
/// (`#[repr(C)]`: the C ABI's `refl_layered_bound`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct LayeredBound {
    /// Center, world space.
    pub center: [f32; 3],
    /// Radius, world units: the farthest box corner from the center, plus
    /// `1e-4` of it.
    pub radius: f32,
    /// A hash of the map's grid ([`LayeredGrid::fingerprint`]), placement
    /// and index: [`LayeredPass::try_new`] refuses bounds prepared for
    /// other maps.
    pub key: u32,
}

/// The maps a [`LayeredPass`] traces, by index: a slice of
/// [`LayeredMap`]s, or the host's own container (the C ABI reads the
/// caller's map descriptors through it, without copying them).
pub trait LayeredMapSet {
    /// Number of maps.
    fn len(&self) -> usize;

    /// `true` without maps.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Map `k` (`k < len()`), or `None` if it is not usable (then the pass
    /// refuses the set).
    fn map(&self, k: usize) -> Option<LayeredMap<'_>>;
}

impl<'m> LayeredMapSet for [LayeredMap<'m>] {
    fn len(&self) -> usize {
        <[LayeredMap<'m>]>::len(self)
    }

    fn map(&self, k: usize) -> Option<LayeredMap<'_>> {
        self.get(k).copied()
    }
}

/// The key of map `k` with grid `g` (FNV-1a over the grid's fingerprint,
/// its placement's bits and `k`).
fn bound_key(g: &LayeredGrid, k: usize) -> u32 {
    let mut h: u32 = 0x811c_9dc5;
    let mut eat = |word: u32| {
        for b in word.to_le_bytes() {
            h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
        }
    };
    eat(g.fingerprint());
    for v in g.world_from_local().to_cols_array() {
        eat(v.to_bits());
    }
    eat(k as u32);
    eat((k as u64 >> 32) as u32);
    h
}

/// The bound of map `k` with grid `g`, or `None` if it is not finite.
fn bound_of(g: &LayeredGrid, k: usize) -> Option<LayeredBound> {
    let m = g.world_from_local();
    let cols = m.to_cols_array().map(f64::from);
    // World point of a local point, in f64.
    let world = |p: DVec3| {
        DVec3::new(
            cols[0] * p.x + cols[3] * p.y + cols[6] * p.z + cols[9],
            cols[1] * p.x + cols[4] * p.y + cols[7] * p.z + cols[10],
            cols[2] * p.x + cols[5] * p.y + cols[8] * p.z + cols[11],
        )
    };
    let (lo, hi) = (g.min().as_dvec3(), g.max().as_dvec3());
    let c = world(0.5 * (lo + hi));
    let mut r = 0.0f64;
    for k in 0..8 {
        let corner = DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        r = r.max((world(corner) - c).length());
    }
    let r = r * (1.0 + 1e-4);
    let center = c.as_vec3();
    let radius = r as f32;
    (center.is_finite() && radius.is_finite()).then_some(LayeredBound {
        center: center.to_array(),
        radius,
        key: bound_key(g, k),
    })
}

/// Whether the ray `o + t d` (`d` of about unit length), `0 <= t <= t_max`,
/// may meet the sphere of `b` widened by [`BOUND_SLACK`] (module docs, step
/// 2). In f64.
fn may_meet(b: &LayeredBound, o: Vec3, d: Vec3, t_max: f32) -> bool {
    let o = o.as_dvec3();
    let d = d.as_dvec3();
    let len = d.length();
    if !(len > 0.0) {
        return true;
    }
    let u = d / len;
    let oc = DVec3::from_array(b.center.map(f64::from)) - o;
    let tc = oc.dot(u);
    let pad = f64::from(b.radius) + BOUND_SLACK * (o.length() + oc.length());
    let perp = (oc - u * tc).length_squared();
    !(perp > pad * pad || tc + pad < 0.0 || tc - pad > f64::from(t_max) * len)
}

/// Elements of the caller memory ([`LayeredBound`]s) a layered pass over
/// `maps` needs: one per map.
pub fn layered_pass_scratch_len<M: LayeredMapSet + ?Sized>(maps: &M) -> usize {
    maps.len()
}

/// Prepares a frame: validates `options` (against `gbuffer`) and every
/// map, and writes map `k`'s world bounding sphere and key into `dst[k]`
/// (module docs, step 2). Call it once per frame, and again after a map
/// moved (a new `world_from_local`) or was rebuilt for another grid.
///
/// # Errors
/// * [`Error::InsufficientSize`]: `dst` shorter than
///   [`layered_pass_scratch_len`].
/// * [`Error::InvalidArgument`]: an option out of its range; a map that is
///   not usable ([`LayeredMapSet::map`] is `None`); a map whose bounding
///   sphere is not finite in f32 (a box far beyond the f32 range).
///
/// Nothing is written on error.
pub fn try_prepare_layered_pass<M: LayeredMapSet + ?Sized>(
    dst: &mut [LayeredBound],
    gbuffer: &GBuffer<'_>,
    maps: &M,
    options: &LayeredPassOptions,
) -> Result<(), Error> {
    options.try_validate()?;
    MirrorPass::try_rays_only(*gbuffer, options.mirror_options())?;
    let n = maps.len();
    if dst.len() < n {
        return Err(Error::InsufficientSize);
    }
    for k in 0..n {
        let m = maps.map(k).ok_or(Error::InvalidArgument)?;
        bound_of(m.grid(), k).ok_or(Error::InvalidArgument)?;
    }
    for (k, slot) in dst[..n].iter_mut().enumerate() {
        if let Some(b) = maps.map(k).and_then(|m| bound_of(m.grid(), k)) {
            *slot = b;
        }
    }
    Ok(())
}

/// The `u64` words of one region's mask for `maps` maps (bit `k % 64` of
/// word `k / 64` for map `k`): `ceil(maps / 64)`, at least 1.
pub const fn prr_mask_words(maps: usize) -> usize {
    if maps == 0 {
        1
    } else {
        maps.div_ceil(64)
    }
}

/// Elements (`u64` words) of the masks of `triangles` regions over `maps`
/// maps: `triangles * prr_mask_words(maps)` ([`try_prr_masks`],
/// [`LayeredPass::try_with_regions`]).
///
/// # Errors
/// [`Error::InvalidArgument`] if the count overflows `usize`.
pub fn try_prr_masks_len(triangles: usize, maps: usize) -> Result<usize, Error> {
    triangles
        .checked_mul(prr_mask_words(maps))
        .ok_or(Error::InvalidArgument)
}

/// The region id of a pixel without a region
/// ([`LayeredPass::try_with_regions`]): every map applies.
pub const PRR_NO_REGION: u32 = u32::MAX;

/// The radii of one (reflector triangle, map) pair's potential-reflection
/// test in [`try_prr_masks`] ([`prr_radii`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrrRadii {
    /// The radius of the sphere about the map's center whose cone
    /// [`try_prr_classify`] tests (seed 001 Sec. 3.2, Fig. 2(a)).
    pub cone: f32,
    /// The map applies whatever the cone says when the triangle may come
    /// this close to the map's center: its bounding box and its plane both
    /// lie within `near` of the center.
    pub near: f32,
}

/// The radii [`try_prr_masks`] tests triangle `tri` against the map of
/// bound `b` with, for a camera at `eye`, or `None` where the map applies
/// to the triangle untested ([`PrrTriangle::normal_spread_sin`] is `None`,
/// or a radius is not finite in f32). In f64, rounded up.
///
/// Seed 001 Sec. 3.2 asks whether the reflection of the object's bounding
/// sphere (center `O`, radius `R`) about the triangle's plane can show on
/// the triangle: the cone from the camera `C` tangent to the mirrored
/// sphere (Fig. 2(a)) meets the triangle. The pass traces a map only for a
/// ray that passes the sphere test of module docs' step 2 (`may_meet`),
/// so the masks must keep every map whose *padded* sphere the pass's ray
/// may meet; three widenings of ours make the seed's test conservative for
/// that (`kappa` = [`BOUND_SLACK`], `V_i` the corners, `D = max |V_i - O|`,
/// `Q = max |V_i|`):
///
/// 1. **The pass's pad.** The sphere test widens `R` by `kappa (|o| +
///    |O - o|)`, `o` the ray's start, which lies up to `t_start` along the
///    ray from the surface point `P`; a start beyond the sphere fails the
///    test, so `t_start <= (1 + 3 kappa)(|P - O| + R + kappa |P|)` and the
///    pad is at most `pad = R + 1.01 kappa (2 R + Q + 3 D)`.
/// 2. **Shading normals.** The pass reflects the view ray about the
///    G-buffer's normal, within `delta` of the plane's
///    ([`PrrTriangle::normal_spread_sin`]); the two mirror directions are
///    at most `2 sin delta` apart (`|H_n v - H_f v| <= 2 |n n^T - f f^T|
///    = 2 sin delta`, `H` the appendix's mirror), so a ray meeting the
///    sphere within `s <= D + pad` of `P` has a plane-mirror ray that
///    passes within `pad + 2 sin(delta) (D + pad)` of `O`.
/// 3. **Rounding.** The pass's surface point comes back from depth and
///    its direction is rounded to f32, and [`try_prr_classify`] runs in f32:
///    `m = kappa (|C| + Q + |O| + D + pad)` more, far above both (about
///    `1e-6` of the same lengths).
///
/// `cone = pad + 2 sin(delta) (D + pad) + m`. The sphere test also passes a
/// ray whose start lies behind the sphere's center within `pad` (its
/// nearest point then is its start, up to `sqrt 2 pad` from `O`): a
/// triangle that may come that close keeps the map,
/// `near = 1.5 pad + m`.
pub fn prr_radii(tri: &PrrTriangle, eye: Vec3, b: &LayeredBound) -> Option<PrrRadii> {
    let kappa = BOUND_SLACK;
    let sin_delta = tri.normal_spread_sin()?;
    let o = DVec3::from_array(b.center.map(f64::from));
    let r = f64::from(b.radius);
    let v = tri.corners.map(|c| DVec3::from_array(c.map(f64::from)));
    let q = v.iter().fold(0.0f64, |m, p| m.max(p.length()));
    let d = v.iter().fold(0.0f64, |m, p| m.max((*p - o).length()));
    let pad = r + 1.01 * kappa * (2.0 * r + q + 3.0 * d);
    let m = kappa * (eye.as_dvec3().length() + q + o.length() + d + pad);
    let cone = pad + 2.0 * sin_delta * (d + pad) + m;
    let near = 1.5 * pad + m;
    let up = |x: f64| {
        let f = (x * (1.0 + 1e-6)) as f32;
        f.is_finite().then_some(f)
    };
    Some(PrrRadii {
        cone: up(cone)?,
        near: up(near)?,
    })
}

/// `true` if the triangle's bounding box and its plane both lie within
/// `near` of `o` ([`PrrRadii::near`]), in f64.
fn prr_near(tri: &PrrTriangle, o: Vec3, near: f32) -> bool {
    let v = tri.corners.map(|c| DVec3::from_array(c.map(f64::from)));
    let o = o.as_dvec3();
    let lo = v[0].min(v[1]).min(v[2]);
    let hi = v[0].max(v[1]).max(v[2]);
    let box_dist = (o - o.clamp(lo, hi)).length();
    let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
    let plane_dist = n.dot(o - v[0]).abs();
    let near = f64::from(near);
    box_dist <= near && plane_dist <= near
}

/// Counts of one [`try_prr_masks`] call.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PrrStats {
    /// Triangles (regions) written.
    pub regions: u64,
    /// (triangle, map) pairs: `regions` times the maps.
    pub pairs: u64,
    /// Pairs whose bit is set (the map may reflect on the triangle).
    pub may_reflect: u64,
    /// Of those, pairs set untested ([`prr_radii`] is `None`: a
    /// degenerate triangle, normals 90 degrees or more from its plane).
    pub untested: u64,
}

/// The potential-reflection-region masks of seed 001 Sec. 3.2 (Fig. 2(a))
/// for the layered pass's regions ([`LayeredPass::try_with_regions`]):
/// for each reflector triangle `triangles[t]` (world space, with the
/// vertex normals the G-buffer interpolates on it), with `n =`
/// [`prr_mask_words`]`(bounds.len())` words per triangle, bit `k % 64` of
/// `dst[t * n + k / 64]` is set if the map of `bounds[k]` (the bounds [`try_prepare_layered_pass`]
/// wrote for this frame) may reflect on the triangle for a camera at
/// `eye`: [`try_prr_classify`] with the map's center and
/// [`PrrRadii::cone`] says [`PrrClass::may_reflect`](crate::PrrClass::may_reflect)
/// (or refuses the triangle as degenerate), or the triangle comes within
/// [`PrrRadii::near`] of the center, or [`prr_radii`] is `None`. Bits of
/// no map are 0. Once per frame (the camera moved) and
/// per placement of the maps.
///
/// The masks are conservative (see [`prr_radii`]): a pixel whose surface
/// point lies on triangle `t` (its normal one the vertex normals
/// interpolate) traces, with its mask, every map it traces without it.
///
/// # Errors
/// * [`Error::InvalidArgument`]: a non-finite `eye`, corner or normal; a
///   bound whose center is not finite or whose radius is not finite and
///   `>= 0`; a length that overflows ([`try_prr_masks_len`]).
/// * [`Error::InsufficientSize`]: `dst` shorter than
///   [`try_prr_masks_len`]`(triangles.len(), bounds.len())`.
///
/// Nothing is written on error.
pub fn try_prr_masks(
    dst: &mut [u64],
    triangles: &[PrrTriangle],
    eye: Vec3,
    bounds: &[LayeredBound],
) -> Result<PrrStats, Error> {
    let bound_ok = |b: &LayeredBound| {
        b.center.iter().all(|c| c.is_finite()) && b.radius.is_finite() && b.radius >= 0.0
    };
    if !eye.is_finite()
        || !bounds.iter().all(bound_ok)
        || !triangles.iter().all(PrrTriangle::is_finite)
    {
        return Err(Error::InvalidArgument);
    }
    if dst.len() < try_prr_masks_len(triangles.len(), bounds.len())? {
        return Err(Error::InsufficientSize);
    }
    let words = prr_mask_words(bounds.len());
    let mut stats = PrrStats::default();
    for (mask, tri) in dst.chunks_exact_mut(words).zip(triangles) {
        mask.fill(0);
        let corners = tri.corners.map(Vec3::from_array);
        for (k, b) in bounds.iter().enumerate() {
            let center = Vec3::from_array(b.center);
            let set = match prr_radii(tri, eye, b) {
                None => {
                    stats.untested += 1;
                    true
                }
                Some(r) => {
                    prr_near(tri, center, r.near)
                        || try_prr_classify(eye, center, r.cone, corners)
                            .map_or(true, |c| c.may_reflect())
                }
            };
            if set {
                mask[k / 64] |= 1 << (k % 64);
                stats.may_reflect += 1;
            }
        }
        stats.regions += 1;
        stats.pairs += bounds.len() as u64;
    }
    Ok(stats)
}

/// Where [`LayeredPass::try_run_rows`] puts its results.
pub trait LayeredPassSink {
    /// Pixel `(x, y)`'s texel and reflection color (the payload's color at
    /// a hit with [`LayeredPassOptions::payload_color`], black otherwise).
    fn texel(&mut self, x: u32, y: u32, texel: &LayeredPassTexel, color: [f32; 3]);
    /// Host ray number `index` of this run (0, 1, ... in row-major order,
    /// counting only those stored); returns `false` if it was not stored
    /// (the list is full).
    fn host(&mut self, index: u32, ray: &LayeredHostRay) -> bool;
}

/// The nearest hit over the maps and the flags of the misses.
#[derive(Clone, Copy, Default)]
struct MapsTrace {
    best: Option<(usize, LayeredHit, LayeredGrid)>,
    started_inside: bool,
    out_of_steps: bool,
    kernels: u32,
    fetches: u32,
    sphere_culled: u32,
    prr_skipped: u32,
}

/// One ray's result with its color and host ray.
struct Traced {
    texel: LayeredPassTexel,
    color: [f32; 3],
    host: Option<LayeredHostRay>,
    kernels: u32,
    sphere_culled: u32,
    prr_skipped: u32,
}

/// The layered pass over one frame (module docs).
pub struct LayeredPass<'a, M: ?Sized = [LayeredMap<'a>]> {
    mirror: MirrorPass<'a>,
    maps: &'a M,
    bounds: &'a [LayeredBound],
    ids: Option<(ImageView<'a, u32>, &'a [u32])>,
    regions: Option<(ImageView<'a, u32>, &'a [u64])>,
    options: LayeredPassOptions,
}

impl<M: ?Sized> Clone for LayeredPass<'_, M> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<M: ?Sized> Copy for LayeredPass<'_, M> {}

impl<'a, M: LayeredMapSet + ?Sized> LayeredPass<'a, M> {
    /// Describes the pass over `gbuffer` and `maps` with `options` and the
    /// bounds [`try_prepare_layered_pass`] wrote for them.
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: an option out of its range; a map
    ///   that is not usable; bounds not prepared for these maps (another
    ///   grid, placement or order: the keys).
    /// * [`Error::InsufficientSize`]: fewer bounds than maps.
    pub fn try_new(
        gbuffer: GBuffer<'a>,
        maps: &'a M,
        options: LayeredPassOptions,
        bounds: &'a [LayeredBound],
    ) -> Result<Self, Error> {
        options.try_validate()?;
        let mirror = MirrorPass::try_rays_only(gbuffer, options.mirror_options())?;
        let n = maps.len();
        if bounds.len() < n {
            return Err(Error::InsufficientSize);
        }
        for (k, b) in bounds[..n].iter().enumerate() {
            let m = maps.map(k).ok_or(Error::InvalidArgument)?;
            if b.key != bound_key(m.grid(), k) {
                return Err(Error::InvalidArgument);
            }
        }
        Ok(Self {
            mirror,
            maps,
            bounds: &bounds[..n],
            ids: None,
            regions: None,
            options,
        })
    }

    /// The same pass with object ids: pixel `(x, y)`'s ray skips every map
    /// `k` with `map_ids[k] == ids(x, y)` (its reflector's own map; module
    /// docs, step 2). A listed ray uses the id at its `(x, y)` (none
    /// outside the image).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `ids` is not the G-buffer's size;
    /// [`Error::InsufficientSize`] if `map_ids` is shorter than the maps.
    pub fn try_with_ids(self, ids: ImageView<'a, u32>, map_ids: &'a [u32]) -> Result<Self, Error> {
        let g = self.mirror.gbuffer();
        if ids.width() != g.width() || ids.height() != g.height() {
            return Err(Error::InvalidArgument);
        }
        if map_ids.len() < self.maps.len() {
            return Err(Error::InsufficientSize);
        }
        Ok(Self {
            ids: Some((ids, map_ids)),
            ..self
        })
    }

    /// The same pass with potential reflection regions (seed 001 Sec. 3.2,
    /// Fig. 2(a); module docs, step 2): pixel `(x, y)` with region
    /// `r = regions(x, y)` traces only the maps whose bit is set in its
    /// mask (`n =` [`prr_mask_words`]`(maps)` words per region, bit
    /// `k % 64` of `masks[r * n + k / 64]` for map `k`), a pixel with region
    /// [`PRR_NO_REGION`] every map. A region is a reflector triangle
    /// (the G-buffer's primitive id, re-indexed to the triangles the host
    /// gave [`try_prr_masks`]), and the masks are what [`try_prr_masks`]
    /// wrote for this frame's camera and bounds: then every texel and
    /// count is the same as without regions, except that
    /// [`LayeredPassStats::prr_skipped`] counts the sphere tests saved.
    /// A pixel whose region is not the triangle its surface point lies on
    /// may lose hits. Listed rays ([`LayeredPass::try_trace_rays`]) do not
    /// use regions: their directions are the host's, not the pixel's
    /// mirror ray the masks were made for.
    ///
    /// Every region id is checked here (once per frame).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `regions` is not the G-buffer's size,
    /// or a region id is neither below `masks.len() / n` nor
    /// [`PRR_NO_REGION`].
    pub fn try_with_regions(
        self,
        regions: ImageView<'a, u32>,
        masks: &'a [u64],
    ) -> Result<Self, Error> {
        let g = self.mirror.gbuffer();
        if regions.width() != g.width() || regions.height() != g.height() {
            return Err(Error::InvalidArgument);
        }
        let count = masks.len() / prr_mask_words(self.maps.len());
        for y in 0..regions.height() {
            for x in 0..regions.width() {
                match regions.get(x, y) {
                    Some(r) if r == PRR_NO_REGION || (r as usize) < count => {}
                    _ => return Err(Error::InvalidArgument),
                }
            }
        }
        Ok(Self {
            regions: Some((regions, masks)),
            ..self
        })
    }

    /// The G-buffer.
    pub fn gbuffer(&self) -> &GBuffer<'a> {
        self.mirror.gbuffer()
    }

    /// The options.
    pub const fn options(&self) -> &LayeredPassOptions {
        &self.options
    }

    /// The mirror pass whose rays this pass traces (its rays only: it has
    /// no kernel).
    pub const fn ray_pass(&self) -> &MirrorPass<'a> {
        &self.mirror
    }

    /// The ray the pass traces for pixel `(x, y)` ([`MirrorPass::ray`]), or
    /// `None` where it traces none.
    pub fn ray(&self, x: u32, y: u32) -> Option<MirrorRay> {
        self.mirror.ray(x, y)
    }

    /// The host ray of pixel `(x, y)` as the pass would hand it over with
    /// `status` (for pixels whose list entry did not fit), or `None` for a
    /// pixel without a reflection ray or one answered without tracing.
    pub fn host_ray(&self, x: u32, y: u32, status: LayeredPassStatus) -> Option<LayeredHostRay> {
        match self.mirror.setup(x, y) {
            Setup::Trace(r) | Setup::Host(r, _) => Some(self.host_entry(x, y, &r, status)),
            Setup::Done(_) | Setup::Sky(_) => None,
        }
    }

    fn host_entry(
        &self,
        x: u32,
        y: u32,
        r: &MirrorRay,
        status: LayeredPassStatus,
    ) -> LayeredHostRay {
        LayeredHostRay {
            x,
            y,
            origin: r.origin,
            dir: r.dir,
            t_min: self.options.t_min,
            t_max: self.options.t_max,
            status,
        }
    }

    /// The object id at `(x, y)`, if the pass has ids and the pixel is in
    /// the image.
    fn own_id(&self, x: u32, y: u32) -> Option<u32> {
        self.ids.and_then(|(img, _)| img.get(x, y))
    }

    /// The region mask of `(x, y)`: the maps its region may see (`None`,
    /// every map, without regions or with [`PRR_NO_REGION`]).
    fn region_mask(&self, x: u32, y: u32) -> Option<&'a [u64]> {
        let (img, masks) = self.regions?;
        let n = prr_mask_words(self.maps.len());
        let r = img.get(x, y)? as usize;
        masks.get(r.checked_mul(n)?..r.checked_add(1)?.checked_mul(n)?)
    }

    /// Module docs, steps 2 and 3: `ray` (from the segment's start) up to
    /// `t_seg` against every map that applies (`mask`: the region's maps).
    fn trace_maps(
        &self,
        own: Option<u32>,
        mask: Option<&[u64]>,
        ray: &Ray,
        t_seg: f32,
    ) -> MapsTrace {
        let mut out = MapsTrace::default();
        for (k, b) in self.bounds.iter().enumerate() {
            if let (Some(id), Some((_, map_ids))) = (own, self.ids) {
                if map_ids.get(k) == Some(&id) {
                    continue;
                }
            }
            let t_max = out.best.map_or(t_seg, |(_, h, _)| h.t);
            if !(t_max > 0.0) {
                // A hit at the segment's start: nothing can be nearer.
                break;
            }
            if mask.is_some_and(|m| m.get(k / 64).is_some_and(|w| w >> (k % 64) & 1 == 0)) {
                out.prr_skipped += 1;
                continue;
            }
            if !may_meet(b, ray.origin, ray.dir, t_max) {
                out.sphere_culled += 1;
                continue;
            }
            let Some(m) = self.maps.map(k) else {
                continue;
            };
            // Not reached for a ray the pass validated (finite, unit
            // direction) and validated options, unless the map's placement
            // takes the ray beyond the f32 range: that map is passed over.
            let Ok(tr) = m.try_trace(ray, t_max, &self.options.trace) else {
                continue;
            };
            out.kernels += 1;
            out.fetches = out.fetches.saturating_add(tr.work().fetches);
            match tr {
                LayeredTrace::Hit(h) => {
                    if out.best.is_none_or(|(_, bh, _)| h.t < bh.t) {
                        out.best = Some((k, h, *m.grid()));
                    }
                }
                LayeredTrace::Miss { reason, .. } => match reason {
                    LayeredMiss::StartedInside => out.started_inside = true,
                    LayeredMiss::OutOfSteps => out.out_of_steps = true,
                    _ => {}
                },
            }
        }
        out
    }

    /// The texel of a traced segment that started `t_start` from its
    /// origin and ends at `t_end` (the pass's `t_max` for its pixels, a
    /// listed ray's own), and its color.
    fn texel_of(
        &self,
        mt: &MapsTrace,
        t_start: f32,
        t_end: f32,
        dir: Vec3,
    ) -> (LayeredPassTexel, [f32; 3]) {
        let mut t = LayeredPassTexel {
            dir,
            fetches: mt.fetches,
            ..LayeredPassTexel::default()
        };
        let Some((k, h, grid)) = mt.best else {
            t.status = if mt.started_inside {
                LayeredPassStatus::StartedInside
            } else if mt.out_of_steps {
                LayeredPassStatus::OutOfSteps
            } else {
                LayeredPassStatus::LeftMaps
            };
            return (t, [0.0; 3]);
        };
        let q = grid.box_coords(h.position);
        let (u, v) = h.face.uv_axes();
        let res = grid.face_res() as f32;
        let e = self.options.trace.early_stop_texels;
        t.status = LayeredPassStatus::Hit;
        t.map = k as u32;
        t.face = h.face;
        t.texel = h.texel;
        // F28: a transform stretched beyond f32 (a shear of 1e21) puts
        // `position` outside the box; the texel is the search's, so the
        // sub-texel position stays in its cell.
        let (ti, tj) = (h.texel[0] as f32, h.texel[1] as f32);
        t.uv = Vec2::new(
            (q[u] * res).max(ti).min(ti + 1.0),
            (q[v] * res).max(tj).min(tj + 1.0),
        );
        t.layer = h.layer;
        t.payload = h.payload;
        // The kernel's `t` is at most `t_max - t_start`, which rounds: the
        // sum may pass `t_max` by an ulp (F32); the hit lies at the end.
        let sum = t_start + h.t;
        t.t = if sum > t_end { t_end } else { sum };
        t.position = h.position;
        t.confidence = if h.mismatch <= e {
            1.0
        } else if h.mismatch > e {
            (e / h.mismatch).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let color = if self.options.payload_color {
            let [r, g, b, _] = h.payload.to_le_bytes();
            [r, g, b].map(|c| f32::from(c) / 255.0)
        } else {
            [0.0; 3]
        };
        (t, color)
    }

    fn trace_pixel(&self, x: u32, y: u32) -> Traced {
        let done = |status, dir| Traced {
            texel: LayeredPassTexel {
                status,
                dir,
                ..LayeredPassTexel::default()
            },
            color: [0.0; 3],
            host: None,
            kernels: 0,
            sphere_culled: 0,
            prr_skipped: 0,
        };
        let r = match self.mirror.setup(x, y) {
            Setup::Done(s) => {
                let s = match s {
                    MirrorStatus::Skipped => LayeredPassStatus::Skipped,
                    _ => LayeredPassStatus::NoSurface,
                };
                return done(s, Vec3::ZERO);
            }
            Setup::Sky(r) => return done(LayeredPassStatus::Sky, r.dir),
            Setup::Host(r, _) => {
                let s = LayeredPassStatus::NoProjection;
                let mut out = done(s, r.dir);
                out.host = Some(self.host_entry(x, y, &r, s));
                return out;
            }
            Setup::Trace(r) => r,
        };
        let mt = self.trace_maps(
            self.own_id(x, y),
            self.region_mask(x, y),
            &r.kernel_ray(),
            self.options.t_max - r.t_start,
        );
        let (texel, color) = self.texel_of(&mt, r.t_start, self.options.t_max, r.dir);
        let host = texel
            .status
            .needs_host()
            .then(|| self.host_entry(x, y, &r, texel.status));
        Traced {
            texel,
            color,
            host,
            kernels: mt.kernels,
            sphere_culled: mt.sphere_culled,
            prr_skipped: mt.prr_skipped,
        }
    }

    /// Traces one pixel: its texel, its reflection color (module docs,
    /// step 5) and, for the statuses of [`LayeredPassStatus::needs_host`],
    /// its host ray.
    pub fn pixel(&self, x: u32, y: u32) -> (LayeredPassTexel, [f32; 3], Option<LayeredHostRay>) {
        let p = self.trace_pixel(x, y);
        (p.texel, p.color, p.host)
    }

    /// Runs the pass over the rows `out` owns (a whole image or a band from
    /// [`ImageViewMut::try_band`]): writes every pixel's
    /// [`LayeredPassTexel`], the payload colors into `color` (needs
    /// [`LayeredPassOptions::payload_color`]), and appends the pixels that
    /// need the host's tracer to `host` in row-major order, as far as
    /// `host` holds them (`host` may be empty).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `out` or `color` is not the G-buffer's
    /// size, their bands differ, or `color` is given without
    /// `payload_color`. Nothing is written then.
    pub fn try_run(
        &self,
        out: &mut ImageViewMut<'_, LayeredPassTexel>,
        color: Option<&mut ImageViewMut<'_, [f32; 3]>>,
        host: &mut [LayeredHostRay],
    ) -> Result<LayeredPassStats, Error> {
        let (w, h) = (self.gbuffer().width(), self.gbuffer().height());
        if out.width() != w || out.height() != h {
            return Err(Error::InvalidArgument);
        }
        if let Some(c) = color.as_deref() {
            if !self.options.payload_color
                || c.width() != w
                || c.height() != h
                || c.owned_rows() != out.owned_rows()
            {
                return Err(Error::InvalidArgument);
            }
        }
        let Some(rows) = out.owned_rows() else {
            return Ok(LayeredPassStats::default());
        };
        struct Views<'o, 'c, 'h, 'x, 'y> {
            out: &'o mut ImageViewMut<'x, LayeredPassTexel>,
            color: Option<&'c mut ImageViewMut<'y, [f32; 3]>>,
            host: &'h mut [LayeredHostRay],
        }
        impl LayeredPassSink for Views<'_, '_, '_, '_, '_> {
            fn texel(&mut self, x: u32, y: u32, texel: &LayeredPassTexel, color: [f32; 3]) {
                if let Some(p) = self.out.get_mut(x, y) {
                    *p = *texel;
                }
                if let Some(c) = self.color.as_deref_mut().and_then(|c| c.get_mut(x, y)) {
                    *c = color;
                }
            }
            fn host(&mut self, index: u32, ray: &LayeredHostRay) -> bool {
                match self.host.get_mut(index as usize) {
                    Some(slot) => {
                        *slot = *ray;
                        true
                    }
                    None => false,
                }
            }
        }
        Ok(self.run_rows(rows, &mut Views { out, color, host }))
    }

    /// Runs the pass over `rows` (checked against the G-buffer's height)
    /// and hands every pixel's texel and color, and every host ray in
    /// row-major order, to `sink`: the loop of [`LayeredPass::try_run`] for
    /// hosts whose buffers are not [`ImageViewMut`]s (refl-ffi writes C
    /// structs through it).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `rows` ends beyond the G-buffer's
    /// height. Nothing is handed to `sink` then.
    pub fn try_run_rows(
        &self,
        rows: RowRange,
        sink: &mut impl LayeredPassSink,
    ) -> Result<LayeredPassStats, Error> {
        if rows.end() > self.gbuffer().height() {
            return Err(Error::InvalidArgument);
        }
        Ok(self.run_rows(rows, sink))
    }

    fn count(stats: &mut LayeredPassStats, p: &Traced) {
        if !matches!(
            p.texel.status,
            LayeredPassStatus::Skipped | LayeredPassStatus::NoSurface
        ) {
            stats.traced += 1;
        }
        match p.texel.status {
            LayeredPassStatus::Hit => stats.hits += 1,
            LayeredPassStatus::Sky => stats.sky += 1,
            _ => {}
        }
        stats.kernel_traces += u64::from(p.kernels);
        stats.sphere_culled += u64::from(p.sphere_culled);
        stats.prr_skipped += u64::from(p.prr_skipped);
        stats.fetches += u64::from(p.texel.fetches);
    }

    fn run_rows(&self, rows: RowRange, sink: &mut impl LayeredPassSink) -> LayeredPassStats {
        let mut stats = LayeredPassStats::default();
        for y in rows.rows() {
            for x in 0..self.gbuffer().width() {
                let p = self.trace_pixel(x, y);
                Self::count(&mut stats, &p);
                if let Some(hr) = p.host {
                    if sink.host(stats.host_rays_written, &hr) {
                        stats.host_rays_written += 1;
                    }
                    stats.host_rays += 1;
                }
                sink.texel(x, y, &p.texel, p.color);
            }
        }
        stats
    }

    /// The segment of a listed ray: its start point and length, or `None`
    /// for a ray the pass refuses.
    fn segment(r: &HostRay) -> Option<(Ray, f32)> {
        let ok = r.origin.is_finite()
            && r.dir.is_finite()
            && (r.dir.length_squared() - 1.0).abs() <= 2e-3
            && r.t_min >= 0.0
            && r.t_min.is_finite()
            && r.t_max > r.t_min;
        let start = r.origin + r.dir * r.t_min;
        (ok && start.is_finite()).then_some((
            Ray {
                origin: start,
                dir: r.dir,
            },
            r.t_max - r.t_min,
        ))
    }

    /// Traces the host's own rays (`rays[k]`, e.g. the host rays of the
    /// mirror pass, [`HostRay`], or any record that converts into one) as
    /// the pass traces a pixel's ray (module docs, steps 2 to 5) from
    /// `origin + t_min dir` up to `t_max` (no start rule: the ray's own
    /// `t_min`), skipping the maps of the object id at the ray's `(x, y)`
    /// when the pass has ids. Writes ray `k`'s texel to `out[k]` (`t` from
    /// the ray's origin; status `Hit` or a host status), its color to
    /// `color[k]` if `color` is given, and appends the rays the maps cannot
    /// answer to `host` in order, as far as it holds them, with their own
    /// `(x, y)`, origin, `t_min` and `t_max`. The listed rays' statuses
    /// are not read.
    ///
    /// Every input is validated before anything is written; elements past
    /// `rays.len()` are not written.
    ///
    /// # Errors
    /// * [`Error::InsufficientSize`]: `out` or `color` shorter than
    ///   `rays`.
    /// * [`Error::InvalidArgument`]: a ray with a non-finite origin or
    ///   direction, a direction whose length differs from 1 by more than
    ///   about 1e-3, `t_min` negative or not finite, `t_max` not above
    ///   `t_min` (NaN included), or a start point `origin + t_min dir`
    ///   beyond the f32 range; `color` given without `payload_color`.
    pub fn try_trace_rays<O, H, R>(
        &self,
        out: &mut [O],
        color: Option<&mut [[f32; 3]]>,
        host: &mut [H],
        rays: &[R],
    ) -> Result<LayeredPassStats, Error>
    where
        O: From<LayeredPassTexel>,
        H: From<LayeredHostRay>,
        R: Copy + Into<HostRay>,
    {
        if out.len() < rays.len() || color.as_ref().is_some_and(|c| c.len() < rays.len()) {
            return Err(Error::InsufficientSize);
        }
        if color.is_some() && !self.options.payload_color {
            return Err(Error::InvalidArgument);
        }
        if rays.iter().any(|r| Self::segment(&(*r).into()).is_none()) {
            return Err(Error::InvalidArgument);
        }
        let mut color = color;
        let mut stats = LayeredPassStats::default();
        for (k, r) in rays.iter().enumerate() {
            let r: HostRay = (*r).into();
            let Some((seg, t_seg)) = Self::segment(&r) else {
                continue;
            };
            let mt = self.trace_maps(self.own_id(r.x, r.y), None, &seg, t_seg);
            let (texel, c) = self.texel_of(&mt, r.t_min, r.t_max, r.dir);
            let host_ray = texel.status.needs_host().then_some(LayeredHostRay {
                x: r.x,
                y: r.y,
                origin: r.origin,
                dir: r.dir,
                t_min: r.t_min,
                t_max: r.t_max,
                status: texel.status,
            });
            let p = Traced {
                texel,
                color: c,
                host: host_ray,
                kernels: mt.kernels,
                sphere_culled: mt.sphere_culled,
                prr_skipped: mt.prr_skipped,
            };
            Self::count(&mut stats, &p);
            if let Some(hr) = p.host {
                if let Some(slot) = host.get_mut(stats.host_rays_written as usize) {
                    *slot = hr.into();
                    stats.host_rays_written += 1;
                }
                stats.host_rays += 1;
            }
            out[k] = p.texel.into();
            if let Some(cs) = color.as_deref_mut() {
                cs[k] = p.color;
            }
        }
        Ok(stats)
    }
}
