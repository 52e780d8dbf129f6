//! Second-order feed-forward reflections (seed 003): normal-bin clustering
//! of the reflective pixels (Sec. 3.2), one pinhole camera per cluster
//! (Sec. 3.3, Eq. 1), and per-pixel finalization by intersecting each
//! pixel's reflected ray(s) with the cluster's depth image (Sec. 3.4, glossy
//! bundles of Sec. 3.5).
//!
//! The host renders the depth image of each cluster (its rasterizer, its
//! GPU); this module tells it which pixels form a cluster, with which camera
//! and clip plane to render, and turns the rendered depth and color into the
//! reflection of the cluster's pixels. Every buffer belongs to the caller.
//!
//! # Example
//! ```rust
//! use refl_core::cluster::{try_assign_clusters, try_bin_layout, try_cluster_camera};
//! use refl_core::cluster::{try_cluster_ranges, try_count_objects, ClusterCameraOptions};
//! use refl_core::cluster::{ClusterInput, ClusterOptions, ClusterView, ObjectBins};
//! use refl_core::glam::Vec3;
//! use refl_core::{ImageView, ImageViewMut, RowRange};
//!
//! // 4 x 4 pixels of one reflective object, the floor y = 0, seen from (0, 2, 5).
//! let positions: Vec<[f32; 3]> = (0..16).map(|i| [(i % 4) as f32 - 1.5, 0.0, (i / 4) as f32 - 1.5]).collect();
//! let (normals, objects) = ([[0.0f32, 1.0, 0.0]; 16], [0u32; 16]);
//! let (normals, objects) = (ImageView::try_new(&normals, 4, 4, 4)?, ImageView::try_new(&objects, 4, 4, 4)?);
//!
//! // Steps 1 and 2: alone on the whole frame, the object gets all 13 x 8 bins.
//! let mut counts = [0u32];
//! try_count_objects(&mut counts, &objects, RowRange::try_all(4)?)?;
//! let mut layout = [ObjectBins::default()];
//! let bins = try_bin_layout(&mut layout, &counts, 16, &ClusterOptions::default())?;
//! assert_eq!((counts[0], bins), (16, 13 * 8));
//! // Steps 3 and 4: the normal (0, 1, 0) has azimuth 0 and polar angle 0: bin 0.
//! let mut ids = [u32::MAX; 16];
//! try_assign_clusters(&mut ImageViewMut::try_new(&mut ids, 4, 4, 4)?, &normals, &objects, &layout)?;
//! let (mut offsets, mut order) = (vec![0u32; bins as usize + 1], [0u32; 16]);
//! try_cluster_ranges(&mut offsets, &mut order, &ImageView::try_new(&ids, 4, 4, 4)?, bins)?;
//! assert_eq!((ids, &offsets[..3]), ([0; 16], &[0, 16, 16][..]));
//!
//! // Step 5: a planar cluster's camera is the mirrored eye (0, -2, 5), with f = 1.
//! let input = ClusterInput { positions: ImageView::try_new(&positions, 4, 4, 4)?, normals };
//! let (eye, pixels) = (Vec3::new(0.0, 2.0, 5.0), &order[offsets[0] as usize..offsets[1] as usize]);
//! let ClusterView::Camera(c) = try_cluster_camera(&input, pixels, eye, &ClusterCameraOptions::default())? else {
//!     panic!("a planar cluster has a camera");
//! };
//! assert!(c.planar && c.f == 1.0 && c.eye0 == Vec3::new(0.0, -2.0, 5.0));
//! assert!((c.camera.eye() - c.eye0).length() < 1e-5 && c.clip.normal == Vec3::Y);
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! # Pipeline
//!
//! 1. [`try_count_objects`]: per reflective object, the pixels where it is
//!    visible (per row band; bands add up).
//! 2. [`try_bin_layout`]: per object, the `theta x phi` bin resolution from
//!    its screen share `a_R` and the number of visible reflective objects
//!    `n_v` (Sec. 3.2), and where its bins start; a cluster id is a bin
//!    index, at most [`try_cluster_bins_max`].
//! 3. [`try_assign_clusters`]: the cluster id of every pixel (per row band;
//!    a pure function of the pixel's normal and object).
//! 4. [`try_cluster_ranges`]: a counting sort of the pixels by cluster:
//!    `offsets[c]..offsets[c + 1]` of `order` are cluster `c`'s pixel
//!    indices (`y * width + x`) in raster order.
//! 5. [`try_cluster_camera`] per non-empty cluster (clusters are
//!    independent: a host may build them on its threads): the camera of
//!    Sec. 3.3, or a [`ClusterFallback`] reason.
//! 6. The host renders depth (and color) through [`ClusterCamera::camera`],
//!    keeping only geometry strictly in front of [`ClusterCamera::clip`].
//! 7. [`try_finalize_cluster`]: per pixel of the cluster, the reflected
//!    ray (or a glossy bundle of 8..49 rays) stepped through the depth image
//!    with [`crate::step::try_step`]; hits take the depth image's color,
//!    misses are reported with a direction for the host's environment
//!    lookup (callback-free fallback).
//!
//! The cluster pass ([`ClusterPass`], module `pass`) is this pipeline
//! over a G-buffer as one plan call per frame and one finalize call per
//! cluster and row band, with the glue (surfaces, rays, host rays, the
//! finalize input) in refl-core.
//!
//! # Conventions
//!
//! Positions and normals are world space; a pixel's normal is unit length
//! and faces the viewer. Object ids index the per-object tables;
//! [`NO_OBJECT`] (or any id at or beyond the table) marks a pixel that is
//! not reflective. A pixel without a cluster has id [`NO_CLUSTER`].

pub mod pass;

pub use pass::{
    try_cluster_plan_len, ClusterObjects, ClusterPass, ClusterPassOptions, ClusterPlanEntry,
    ClusterPlanLen, ClusterPlanStats, ClusterRender, ClusterScratchMut, ClusterSink, ClusterStats,
    ClusterTexel,
};

use crate::step::{try_step, StepOptions};
use crate::trace::{refine_hit, REFINE_CONTINUITY};
use crate::{
    Camera, DepthImage, Error, ImageView, ImageViewMut, Miss, Ray, RowRange, Thickness, Trace,
};
use glam::{DVec3, Vec2, Vec3};

/// Object id of a pixel that belongs to no reflective object.
pub const NO_OBJECT: u32 = u32::MAX;

/// Cluster id of a pixel that belongs to no cluster.
pub const NO_CLUSTER: u32 = u32::MAX;

/// Seed 003 Sec. 3.2: "MAXTHETABINS and MAXPHIBINS are constants that we
/// set to 13 and 8".
pub const MAX_THETA_BINS: u32 = 13;

/// See [`MAX_THETA_BINS`].
pub const MAX_PHI_BINS: u32 = 8;

/// Largest bin count per axis accepted by [`ClusterOptions`].
pub const BINS_LIMIT: u32 = 1024;

/// Clustering parameters (seed 003 Sec. 3.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterOptions {
    /// Azimuth bins of an object covering the whole frame alone (seed: 13).
    pub max_theta_bins: u32,
    /// Polar bins of an object covering the whole frame alone (seed: 8).
    pub max_phi_bins: u32,
    /// Multiplier of the seed's modulation `a_R / n_v` (seed: 1). The seed's
    /// formula, taken literally, gives one bin to every object that covers
    /// less than `n_v / 13` of the frame; a gain above 1 refines the bins of
    /// smaller objects (more clusters, fewer disocclusions): the host's
    /// cluster-count setting.
    pub gain: f32,
}

impl Default for ClusterOptions {
    /// The seed's constants, gain 1.
    fn default() -> Self {
        Self {
            max_theta_bins: MAX_THETA_BINS,
            max_phi_bins: MAX_PHI_BINS,
            gain: 1.0,
        }
    }
}

impl ClusterOptions {
    fn validate(&self) -> Result<(), Error> {
        if self.max_theta_bins == 0
            || self.max_phi_bins == 0
            || self.max_theta_bins > BINS_LIMIT
            || self.max_phi_bins > BINS_LIMIT
            || !(self.gain > 0.0 && self.gain.is_finite())
        {
            return Err(Error::InvalidArgument);
        }
        Ok(())
    }
}

/// The bins of one reflective object in the current frame (`repr(C)`:
/// three `u32`, so that a C host's scratch can hold them).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct ObjectBins {
    /// Azimuth bins (0 if the object is not visible).
    pub theta_bins: u32,
    /// Polar bins (0 if the object is not visible).
    pub phi_bins: u32,
    /// Cluster id of the object's first bin; its bins are
    /// `first .. first + theta_bins * phi_bins`.
    pub first: u32,
}

/// The largest number of clusters (bins) a frame can have with `objects`
/// reflective objects: `objects * max_theta_bins * max_phi_bins`. Size the
/// `offsets` of [`try_cluster_ranges`] one larger.
///
/// # Errors
/// [`Error::InvalidArgument`] for invalid `options` or a count that does not
/// fit in `u32` (ids are `u32`, [`NO_CLUSTER`] excluded).
pub fn try_cluster_bins_max(objects: u32, options: &ClusterOptions) -> Result<u32, Error> {
    options.validate()?;
    let n =
        u64::from(objects) * u64::from(options.max_theta_bins) * u64::from(options.max_phi_bins);
    if n >= u64::from(NO_CLUSTER) {
        return Err(Error::InvalidArgument);
    }
    Ok(n as u32)
}

/// Adds, for every pixel of `rows` with an object id below `counts.len()`,
/// one to `counts[id]` (seed 003 Sec. 3.2 step 2: the screen share `a_R`
/// is `counts[id]` over the frame's pixel count). Call per row band with
/// one `counts` per band and add them, or sequentially with one.
///
/// # Errors
/// [`Error::InvalidArgument`] if `rows` ends beyond the image;
/// [`Error::InsufficientSize`] if a count would overflow (`counts` is then
/// untouched).
pub fn try_count_objects(
    counts: &mut [u32],
    objects: &ImageView<'_, u32>,
    rows: RowRange,
) -> Result<(), Error> {
    count_objects(counts, objects.width(), objects.height(), rows, |x, y| {
        objects.get(x, y).unwrap_or(NO_OBJECT)
    })
}

/// [`try_count_objects`] over the object ids `object(x, y)` of a `width x
/// height` image (the cluster pass's reflective pixels).
pub(crate) fn count_objects(
    counts: &mut [u32],
    width: u32,
    height: u32,
    rows: RowRange,
    object: impl Fn(u32, u32) -> u32,
) -> Result<(), Error> {
    if rows.end() > height {
        return Err(Error::InvalidArgument);
    }
    // Each id gains at most the band's pixel count: check before writing.
    let band = u64::from(rows.len()) * u64::from(width);
    if counts
        .iter()
        .any(|&c| u64::from(c) + band > u64::from(u32::MAX))
    {
        return Err(Error::InsufficientSize);
    }
    for y in rows.rows() {
        for x in 0..width {
            if let Some(c) = counts.get_mut(object(x, y) as usize) {
                *c += 1;
            }
        }
    }
    Ok(())
}

/// Per object, the bin resolution of seed 003 Sec. 3.2 step 4:
/// with `a_R = counts[k] / frame_pixels` and `n_v` the number of objects
/// with `a_R > 0`, the modulation is `s = min(1, gain * a_R / n_v)` and the
/// object gets `max(1, ceil(max_theta_bins * s))` azimuth and
/// `max(1, ceil(max_phi_bins * s))` polar bins (the seed's
/// `i = MAXTHETABINS * theta / 360 * a_R / n_v` read as a bin count). An
/// object with no pixel gets none. Writes `out[k]` for every object and
/// returns the number of cluster ids used (the sum of the bins). `out`
/// holds [`ObjectBins`] or any type made from one (`From<ObjectBins>`, a
/// host's or the C ABI's own record).
///
/// # Errors
/// * [`Error::InvalidArgument`]: invalid `options`, `frame_pixels == 0`, or
///   counts summing to more than `frame_pixels`.
/// * [`Error::InsufficientSize`]: `out.len() < counts.len()`.
pub fn try_bin_layout<O: From<ObjectBins>>(
    out: &mut [O],
    counts: &[u32],
    frame_pixels: u64,
    options: &ClusterOptions,
) -> Result<u32, Error> {
    options.validate()?;
    if frame_pixels == 0 {
        return Err(Error::InvalidArgument);
    }
    if out.len() < counts.len() {
        return Err(Error::InsufficientSize);
    }
    let total: u64 = counts.iter().map(|&c| u64::from(c)).sum();
    if total > frame_pixels {
        return Err(Error::InvalidArgument);
    }
    try_cluster_bins_max(counts.len().min(u32::MAX as usize) as u32, options)?;
    if counts.len() > u32::MAX as usize {
        return Err(Error::InvalidArgument);
    }
    let n_v = counts.iter().filter(|&&c| c > 0).count() as f64;
    let mut first = 0u32;
    for (o, &c) in out.iter_mut().zip(counts) {
        if c == 0 {
            *o = ObjectBins {
                theta_bins: 0,
                phi_bins: 0,
                first,
            }
            .into();
            continue;
        }
        let a_r = c as f64 / frame_pixels as f64;
        let s = (f64::from(options.gain) * a_r / n_v).min(1.0);
        let bins = |max: u32| (libm::ceil(f64::from(max) * s) as u32).clamp(1, max);
        let (t, p) = (bins(options.max_theta_bins), bins(options.max_phi_bins));
        *o = ObjectBins {
            theta_bins: t,
            phi_bins: p,
            first,
        }
        .into();
        first += t * p;
    }
    Ok(first)
}

/// The bin of a unit normal among `theta_bins x phi_bins` (seed 003 Sec.
/// 3.2): azimuth `theta = atan2(n.z, n.x)` in `[0, 2 pi)` and polar angle
/// `phi = acos(n.y)` in `[0, pi]` (world Y up), each cut into equal
/// intervals; returns `theta_index * phi_bins + phi_index`.
#[inline]
pub fn normal_bin(n: Vec3, theta_bins: u32, phi_bins: u32) -> u32 {
    let two_pi = core::f32::consts::TAU;
    let mut theta = libm::atan2f(n.z, n.x);
    if theta < 0.0 {
        theta += two_pi;
    }
    let phi = libm::acosf(n.y.clamp(-1.0, 1.0));
    let i = ((theta / two_pi * theta_bins as f32) as u32).min(theta_bins.saturating_sub(1));
    let j =
        ((phi / core::f32::consts::PI * phi_bins as f32) as u32).min(phi_bins.saturating_sub(1));
    i * phi_bins + j
}

/// Writes the cluster id of every pixel of the owned rows of `ids`
/// (seed 003 Sec. 3.2 step 4): `layout[k].first + normal_bin(n, ...)` for a
/// pixel of object `k` with bins, [`NO_CLUSTER`] for a pixel whose object
/// id has no bins or lies beyond `layout`. `layout` holds [`ObjectBins`]
/// or any record that converts into one (`Into<ObjectBins>`).
///
/// # Errors
/// * [`Error::InvalidArgument`]: views of different sizes, or a clustered
///   pixel whose normal is not finite and non-zero (`ids` is then
///   untouched: every pixel is checked before any is written).
pub fn try_assign_clusters<L: Copy + Into<ObjectBins>>(
    ids: &mut ImageViewMut<'_, u32>,
    normals: &ImageView<'_, [f32; 3]>,
    objects: &ImageView<'_, u32>,
    layout: &[L],
) -> Result<(), Error> {
    let (w, h) = (ids.width(), ids.height());
    if normals.width() != w
        || normals.height() != h
        || objects.width() != w
        || objects.height() != h
    {
        return Err(Error::InvalidArgument);
    }
    assign_clusters(
        ids,
        layout,
        |x, y| objects.get(x, y).unwrap_or(NO_OBJECT),
        |x, y| normals.get(x, y).map(Vec3::from_array),
    )
}

/// [`try_assign_clusters`] over the object ids `object(x, y)` and the
/// normals `normal(x, y)` of an image of `ids`' size (the cluster pass's
/// reflective pixels).
pub(crate) fn assign_clusters<L: Copy + Into<ObjectBins>>(
    ids: &mut ImageViewMut<'_, u32>,
    layout: &[L],
    object: impl Fn(u32, u32) -> u32,
    normal: impl Fn(u32, u32) -> Option<Vec3>,
) -> Result<(), Error> {
    let w = ids.width();
    let Some(rows) = ids.owned_rows() else {
        return Ok(());
    };
    let bins_of = |id: u32| {
        layout
            .get(id as usize)
            .map(|&b| b.into())
            .filter(|b: &ObjectBins| b.theta_bins > 0 && b.phi_bins > 0)
    };
    for y in rows.rows() {
        for x in 0..w {
            if bins_of(object(x, y)).is_some() {
                let n = normal(x, y).unwrap_or(Vec3::NAN);
                if !(n.is_finite() && n.length_squared() > 0.0) {
                    return Err(Error::InvalidArgument);
                }
            }
        }
    }
    for y in rows.rows() {
        for x in 0..w {
            let c = match bins_of(object(x, y)) {
                Some(b) => {
                    let n = normal(x, y).unwrap_or(Vec3::Y).normalize();
                    b.first + normal_bin(n, b.theta_bins, b.phi_bins)
                }
                None => NO_CLUSTER,
            };
            if let Some(t) = ids.get_mut(x, y) {
                *t = c;
            }
        }
    }
    Ok(())
}

/// Counting sort of the pixels by cluster: on return, `order[offsets[c] ..
/// offsets[c + 1]]` are the pixel indices `y * width + x` of cluster `c`
/// in raster order, for `c < clusters`; pixels with [`NO_CLUSTER`] are
/// left out. Returns the number of clustered pixels.
///
/// # Errors
/// * [`Error::InsufficientSize`]: `offsets.len() < clusters + 1`, or
///   `order` shorter than the clustered pixels.
/// * [`Error::InvalidArgument`]: an id that is neither below `clusters`
///   nor [`NO_CLUSTER`], or an image of more than `u32::MAX` pixels.
///
/// Outputs are untouched on error.
pub fn try_cluster_ranges(
    offsets: &mut [u32],
    order: &mut [u32],
    ids: &ImageView<'_, u32>,
    clusters: u32,
) -> Result<u32, Error> {
    let (w, h) = (ids.width(), ids.height());
    if u64::from(w) * u64::from(h) > u64::from(u32::MAX) {
        return Err(Error::InvalidArgument);
    }
    if (offsets.len() as u64) < u64::from(clusters) + 1 {
        return Err(Error::InsufficientSize);
    }
    let mut total = 0u32;
    for y in 0..h {
        for &c in ids.row(y).unwrap_or(&[]) {
            if c == NO_CLUSTER {
                continue;
            }
            if c >= clusters {
                return Err(Error::InvalidArgument);
            }
            total += 1;
        }
    }
    if (order.len() as u64) < u64::from(total) {
        return Err(Error::InsufficientSize);
    }
    let offsets = &mut offsets[..clusters as usize + 1];
    offsets.fill(0);
    for y in 0..h {
        for &c in ids.row(y).unwrap_or(&[]) {
            if c != NO_CLUSTER {
                offsets[c as usize + 1] += 1;
            }
        }
    }
    for c in 1..offsets.len() {
        offsets[c] += offsets[c - 1];
    }
    // Fill with a running cursor per cluster, stored in offsets[c] and
    // restored afterwards by shifting.
    for y in 0..h {
        for (x, &c) in ids.row(y).unwrap_or(&[]).iter().enumerate() {
            if c != NO_CLUSTER {
                let slot = &mut offsets[c as usize];
                order[*slot as usize] = y * w + x as u32;
                *slot += 1;
            }
        }
    }
    for c in (1..offsets.len()).rev() {
        offsets[c] = offsets[c - 1];
    }
    offsets[0] = 0;
    Ok(total)
}

/// The per-pixel inputs of a frame's reflective pixels: world position
/// and unit world normal, same size.
#[derive(Clone, Copy, Debug)]
pub struct ClusterInput<'a> {
    /// Reflector surface point per pixel (x, y, z).
    pub positions: ImageView<'a, [f32; 3]>,
    /// Unit shading normal per pixel, facing the viewer.
    pub normals: ImageView<'a, [f32; 3]>,
}

/// Where the cluster kernels read a pixel's surface point and normal:
/// a [`ClusterInput`] (the kernels' images) or the cluster pass's
/// G-buffer (`crate::cluster::pass`).
pub(crate) trait Surfaces {
    /// Width of the image the pixel indices `y * width + x` refer to.
    fn width(&self) -> u32;
    /// The surface point and normal of pixel index `index`, `None` outside
    /// the image (or, for the pass, for a pixel without a surface).
    fn at(&self, index: u32) -> Option<(Vec3, Vec3)>;
}

impl Surfaces for ClusterInput<'_> {
    fn width(&self) -> u32 {
        self.positions.width()
    }

    fn at(&self, index: u32) -> Option<(Vec3, Vec3)> {
        let w = self.positions.width();
        if w == 0 {
            return None;
        }
        let (x, y) = (index % w, index / w);
        Some((
            Vec3::from_array(self.positions.get(x, y)?),
            Vec3::from_array(self.normals.get(x, y)?),
        ))
    }
}

impl ClusterInput<'_> {
    fn validate_sizes(&self) -> Result<(), Error> {
        if self.positions.width() != self.normals.width()
            || self.positions.height() != self.normals.height()
        {
            return Err(Error::InvalidArgument);
        }
        Ok(())
    }

    fn validate(&self, pixels: &[u32]) -> Result<(), Error> {
        self.validate_sizes()?;
        validate_pixels(self, pixels)
    }
}

/// Every listed pixel lies in the image, with a finite position and a
/// finite normal of unit length (within 1e-2).
fn validate_pixels(input: &impl Surfaces, pixels: &[u32]) -> Result<(), Error> {
    for &p in pixels {
        let (pos, n) = input.at(p).ok_or(Error::InvalidArgument)?;
        if !(pos.is_finite() && n.is_finite() && (n.length_squared() - 1.0).abs() <= 1e-2) {
            return Err(Error::InvalidArgument);
        }
    }
    Ok(())
}

/// Cluster camera parameters (seed 003 Sec. 3.3 and 3.5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterCameraOptions {
    /// `D`: distance from the image plane to the far plane; the scene
    /// diameter for mirrors, nearer for glossy clusters (Sec. 3.5).
    pub far_distance: f32,
    /// Half-angle (radians, `[0, pi/2)`) of the glossy cone: the image
    /// frame grows to hold it (Sec. 3.5 item 1). 0 for mirrors.
    pub cone_half_angle: f32,
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
    /// `D = 100`, mirror, resolution 1x, at most 2048 texels a side,
    /// clusters of at least 4 pixels, `f <= 16`.
    fn default() -> Self {
        Self {
            far_distance: 100.0,
            cone_half_angle: 0.0,
            resolution_scale: 1.0,
            max_resolution: 2048,
            min_pixels: 4,
            max_f: 16.0,
        }
    }
}

impl ClusterCameraOptions {
    fn validate(&self) -> Result<(), Error> {
        let ok = self.far_distance > 0.0
            && self.far_distance.is_finite()
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
    /// ([`ClusterPass::try_plan`]) records as this fallback rather than
    /// failing the frame.
    Degenerate,
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
fn reflected(eye: Vec3, p: Vec3, n: Vec3) -> Option<Vec3> {
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
/// [`try_cluster_ranges`]) seen from `eye`.
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
    Ok(ClusterView::Camera(ClusterCamera {
        camera,
        clip,
        centroid: pc,
        normal: nc,
        eye0: e0,
        f,
        diagonals: [d_n, d_f, d_big_f],
        planar,
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

/// Most rays per pixel of a [`Lobe`] (the seed uses 8 to 49).
pub const MAX_LOBE_RAYS: u32 = 64;

/// The reflected rays of one pixel (seed 003 Sec. 3.5 item 3: "the
/// reflected rays sample ... a cone with apex at the surface point and with
/// an axis defined by the reflected ray"; the blend `G(d_i, p.g)` is the
/// application's BRDF, here a Phong lobe). `repr(C)` (a `u32` and two
/// `f32`), so that a C host's array of lobes is read in place.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Lobe {
    /// Rays per pixel: 1 traces the mirror direction only; `2..=64` sample
    /// the lobe (seed: 8..49).
    pub rays: u32,
    /// Phong exponent `n` of the lobe `cos^n` around the mirror direction
    /// (ignored for one ray).
    pub exponent: f32,
    /// Half-angle (radians) the lobe is truncated to: directions are drawn
    /// from `cos^n` restricted to `theta <= max_angle` (so that the cluster
    /// camera's frame, widened by the same angle, holds them). Use
    /// [`try_lobe_angle`] for the angle holding a share of the lobe's energy.
    pub max_angle: f32,
}

impl Lobe {
    /// One mirror ray per pixel.
    pub const MIRROR: Lobe = Lobe {
        rays: 1,
        exponent: 0.0,
        max_angle: 0.0,
    };

    fn validate(&self) -> Result<(), Error> {
        if self.rays == 0 || self.rays > MAX_LOBE_RAYS {
            return Err(Error::InvalidArgument);
        }
        if self.rays > 1
            && !(self.exponent >= 0.0
                && self.exponent.is_finite()
                && self.max_angle > 0.0
                && self.max_angle < 1.5)
        {
            return Err(Error::InvalidArgument);
        }
        Ok(())
    }
}

/// The half-angle of the Phong lobe `cos^n` that holds the share
/// `energy` of its samples ([`crate::lobe::try_phong_lobe_angle`], here
/// also refusing an infinite exponent: a cluster lobe of several rays has a
/// finite one).
///
/// # Errors
/// [`Error::InvalidArgument`] for a negative or non-finite exponent or an
/// `energy` outside `(0, 1)`.
pub fn try_lobe_angle(exponent: f32, energy: f32) -> Result<f32, Error> {
    if !exponent.is_finite() {
        return Err(Error::InvalidArgument);
    }
    crate::lobe::try_phong_lobe_angle(exponent, energy)
}

/// What [`try_finalize_cluster`] needs besides the cluster's pixels, its
/// camera and its images: the depth image's thickness and how to trace
/// and weight each pixel's rays. A bundle of per-call inputs (it holds a
/// borrowed back-face image), not settings with defaults.
#[derive(Clone, Copy, Debug)]
pub struct FinalizeInput<'a> {
    /// Surface thickness of the depth image (as [`try_step`]).
    pub thickness: Thickness<'a>,
    /// Stepping options.
    pub step: StepOptions,
    /// Refine hits to sub-texel accuracy ([`refine_hit`]).
    pub refine: bool,
    /// The rays per pixel.
    pub lobe: Lobe,
    /// Glossy fade (Sec. 3.5 item 2): a hit's weight falls linearly from 1
    /// on the image plane to 0 at the far plane; the missing weight is left
    /// to the host (its diffuse color).
    pub fade: bool,
    /// Rotates each pixel's lobe samples (hashed with the pixel index).
    pub seed: u32,
}

/// The reflection of one cluster pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ClusterShade {
    /// Sum of the hit colors times their weights, over the traced rays:
    /// the reflection is `rgb + env_weight * env(env_dir) + (1 - hit_weight
    /// - env_weight) * diffuse`.
    pub rgb: Vec3,
    /// Sum of the hit weights over the traced rays (1 per hit without fade).
    pub hit_weight: f32,
    /// Share of the traced rays that found nothing in the depth image: the
    /// host adds its environment there (the pixel fell back if `> 0`).
    pub env_weight: f32,
    /// The normalized mean direction of the rays that fell back (the mirror
    /// direction if none did).
    pub env_dir: Vec3,
    /// The mirror direction of the pixel.
    pub mirror_dir: Vec3,
    /// Rays traced (lobe samples above the surface, or the mirror ray).
    pub rays: u32,
    /// Rays that hit.
    pub hits: u32,
    /// Depth texels read, summed over the rays.
    pub fetches: u32,
    /// Steps, summed over the rays.
    pub steps: u32,
}

/// Direction `k` of `lobe` around the unit `axis` for a pixel with sample
/// rotation `rot`: Hammersley points, rotated, through the inverse CDF of
/// the truncated Phong lobe ([`crate::lobe::sample_truncated_phong_lobe`]).
fn lobe_dir(lobe: &Lobe, axis: Vec3, k: u32, rot: Vec2) -> Vec3 {
    let xi = crate::lobe::hammersley(k, lobe.rays) + rot;
    let xi = xi - xi.floor();
    crate::lobe::sample_truncated_phong_lobe(axis, lobe.exponent, lobe.max_angle, xi)
}

/// The color at a hit: bilinear between the 2x2 texel centers around
/// `pixel`, using only texels whose depth continues the hit texel's surface
/// (within [`REFINE_CONTINUITY`] relative), renormalized.
fn sample_color(depth: &DepthImage<'_>, color: &ImageView<'_, [f32; 3]>, pixel: Vec2) -> Vec3 {
    let (w, h) = (depth.width(), depth.height());
    let hx = (pixel.x as u32).min(w - 1);
    let hy = (pixel.y as u32).min(h - 1);
    let z0 = depth.linear_at(hx, hy).unwrap_or(f32::NAN);
    let base = color.get(hx, hy).map_or(Vec3::ZERO, Vec3::from_array);
    if !(z0 > 0.0 && z0.is_finite()) {
        return base;
    }
    let p = pixel - Vec2::splat(0.5);
    let (fx, fy) = (libm::floorf(p.x), libm::floorf(p.y));
    let (ax, ay) = (p.x - fx, p.y - fy);
    let (mut sum, mut wsum) = (Vec3::ZERO, 0.0f32);
    for (dx, dy, wt) in [
        (0i64, 0i64, (1.0 - ax) * (1.0 - ay)),
        (1, 0, ax * (1.0 - ay)),
        (0, 1, (1.0 - ax) * ay),
        (1, 1, ax * ay),
    ] {
        let (x, y) = (fx as i64 + dx, fy as i64 + dy);
        if x < 0 || y < 0 || x >= i64::from(w) || y >= i64::from(h) || !(wt > 0.0) {
            continue;
        }
        let (x, y) = (x as u32, y as u32);
        let Some(z) = depth.linear_at(x, y) else {
            continue;
        };
        if !((z - z0).abs() <= REFINE_CONTINUITY * z0) {
            continue;
        }
        if let Some(c) = color.get(x, y) {
            sum += Vec3::from_array(c) * wt;
            wsum += wt;
        }
    }
    if wsum > 0.0 {
        sum / wsum
    } else {
        base
    }
}

fn validate_thickness(depth: &DepthImage<'_>, t: &Thickness<'_>) -> Result<(), Error> {
    match t {
        Thickness::Constant(c) if !(*c >= 0.0) => Err(Error::InvalidArgument),
        Thickness::BackFaces(v) if v.width() != depth.width() || v.height() != depth.height() => {
            Err(Error::InvalidArgument)
        }
        _ => Ok(()),
    }
}

/// Finalizes the reflection of the pixels `pixels` of one cluster (seed 003
/// Sec. 3.1 step 3c, Sec. 3.4, Sec. 3.5): for each pixel, the mirror ray
/// from its surface point (or [`Lobe::rays`] lobe samples above its
/// surface) is traced through the cluster's depth image `depth` (rendered
/// through `cam.camera`, any [`crate::DepthConvention`]) with the stepping
/// kernel [`try_step`], ending at the far plane `D` of the cluster camera.
/// For a planar cluster the mirror ray's line passes through the camera eye
/// and projects to one texel: one step, one fetch (Sec. 4.3). A hit takes
/// the bilinear color of `color` (same size as `depth`) over the texels
/// continuing the hit surface; a miss (left the frame, passed behind
/// geometry, reached the far plane) is a fallback ray whose direction goes
/// to [`ClusterShade::env_dir`]. `out[k]` is written for `pixels[k]`;
/// `out` holds [`ClusterShade`]s or any type made from one
/// (`From<ClusterShade>`, a host's or the C ABI's own record).
/// Lobe samples below the pixel's surface (normal) are not traced; if none
/// is above, the mirror ray is traced alone.
///
/// Returns the number of pixels that fell back (at least one ray missed).
///
/// # Errors
/// * [`Error::InsufficientSize`]: `out.len() < pixels.len()`.
/// * [`Error::InvalidArgument`]: a non-finite `eye`, an invalid lobe,
///   thickness or stride, a camera whose centroid, unit normal or far
///   distance is not finite (or not positive), a `color` image of another size than `depth`, or
///   a listed pixel outside the input or with a non-finite position or a
///   non-unit normal (as [`try_cluster_camera`]).
///
/// `out` is untouched on error.
///
/// # Panics
/// Never.
#[allow(clippy::too_many_arguments)]
pub fn try_finalize_cluster<O: From<ClusterShade>>(
    out: &mut [O],
    input: &ClusterInput<'_>,
    pixels: &[u32],
    eye: Vec3,
    cam: &ClusterCamera,
    depth: &DepthImage<'_>,
    color: &ImageView<'_, [f32; 3]>,
    finalize: &FinalizeInput<'_>,
) -> Result<u32, Error> {
    if out.len() < pixels.len() {
        return Err(Error::InsufficientSize);
    }
    input.validate_sizes()?;
    check_finalize(input, pixels, eye, cam, depth, color, finalize)?;
    let mut fallbacks = 0u32;
    for (o, &p) in out.iter_mut().zip(pixels) {
        let (shade, _) = finalize_pixel(input, p, eye, cam, depth, color, finalize);
        if shade.env_weight > 0.0 {
            fallbacks += 1;
        }
        *o = shade.into();
    }
    Ok(fallbacks)
}

/// The checks of [`try_finalize_cluster`] after the output length and the
/// input's sizes (its `# Errors`), over any [`Surfaces`].
pub(crate) fn check_finalize(
    input: &impl Surfaces,
    pixels: &[u32],
    eye: Vec3,
    cam: &ClusterCamera,
    depth: &DepthImage<'_>,
    color: &ImageView<'_, [f32; 3]>,
    finalize: &FinalizeInput<'_>,
) -> Result<(), Error> {
    if !eye.is_finite() || color.width() != depth.width() || color.height() != depth.height() {
        return Err(Error::InvalidArgument);
    }
    finalize.lobe.validate()?;
    validate_thickness(depth, &finalize.thickness)?;
    if finalize.step.stride == 0 {
        return Err(Error::InvalidArgument);
    }
    validate_pixels(input, pixels)?;
    let (pc, nc, d_far) = (cam.centroid, cam.normal, cam.far_distance);
    if !(pc.is_finite()
        && nc.is_finite()
        && (nc.length_squared() - 1.0).abs() <= 1e-3
        && d_far > 0.0
        && d_far.is_finite())
    {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

/// Why a ray of a cluster pixel found nothing in the depth image, when the
/// image cannot answer it: it left the image, passed behind geometry, ran
/// out of steps, or had no usable projection (the kernel refused it). A
/// ray that reached the far plane `D` in front of every surface (or
/// started beyond it) is answered: nothing lies within `D` there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Unanswered {
    /// [`Miss::LeftImage`].
    LeftImage,
    /// [`Miss::BehindGeometry`].
    BehindGeometry,
    /// [`Miss::OutOfSteps`].
    OutOfSteps,
    /// [`Miss::DegenerateProjection`], or a ray the kernel refused.
    NoProjection,
}

/// One pixel of [`try_finalize_cluster`] (checked by [`check_finalize`]):
/// its shade and, if one of its rays found nothing the depth image can
/// answer, the first such ray's reason.
pub(crate) fn finalize_pixel(
    input: &impl Surfaces,
    p: u32,
    eye: Vec3,
    cam: &ClusterCamera,
    depth: &DepthImage<'_>,
    color: &ImageView<'_, [f32; 3]>,
    finalize: &FinalizeInput<'_>,
) -> (ClusterShade, Option<Unanswered>) {
    let (pc, nc, d_far) = (cam.centroid, cam.normal, cam.far_distance);
    let (pos, n) = input.at(p).unwrap_or((Vec3::ZERO, Vec3::Y));
    let axis = reflected(eye, pos, n).unwrap_or(n);
    let s = (pos - pc).dot(nc);
    let mut shade = ClusterShade {
        mirror_dir: axis,
        ..ClusterShade::default()
    };
    let (mut env_dir, mut misses) = (Vec3::ZERO, 0u32);
    let mut unanswered = None;
    let hash = crate::lobe::pixel_hash;
    let rot = crate::lobe::hash_rotation(hash(p ^ hash(finalize.seed)));
    let mut trace = |dir: Vec3, shade: &mut ClusterShade| {
        shade.rays += 1;
        let dn = dir.dot(nc);
        let t_max = if dn > 1e-6 {
            (d_far - s) / dn
        } else {
            f32::INFINITY
        };
        let ray = Ray { origin: pos, dir };
        let result = if t_max > 0.0 {
            Some(try_step(
                depth,
                finalize.thickness,
                ray,
                t_max,
                finalize.step,
            ))
        } else {
            None
        };
        let why = match &result {
            Some(Ok(Trace::Miss { reason, .. })) => match reason {
                Miss::EndOfRay => None,
                Miss::LeftImage => Some(Unanswered::LeftImage),
                Miss::BehindGeometry => Some(Unanswered::BehindGeometry),
                Miss::OutOfSteps => Some(Unanswered::OutOfSteps),
                Miss::DegenerateProjection => Some(Unanswered::NoProjection),
            },
            Some(Err(_)) => Some(Unanswered::NoProjection),
            _ => None,
        };
        if unanswered.is_none() {
            unanswered = why;
        }
        let result = result.and_then(Result::ok);
        let hit = match result {
            Some(Trace::Hit(hit)) => Some(if finalize.refine {
                refine_hit(depth, &ray, t_max, &hit)
            } else {
                hit
            }),
            _ => None,
        };
        if let Some(tr) = result {
            let w = tr.work();
            shade.fetches = shade.fetches.saturating_add(w.fetches);
            shade.steps = shade.steps.saturating_add(w.steps);
        }
        match hit {
            Some(hit) => {
                let wgt = if finalize.fade {
                    (1.0 - (s + dn * hit.t) / d_far).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                shade.rgb += sample_color(depth, color, hit.pixel) * wgt;
                shade.hit_weight += wgt;
                shade.hits += 1;
            }
            None => {
                env_dir += dir;
                misses += 1;
            }
        }
    };
    if finalize.lobe.rays > 1 {
        for k in 0..finalize.lobe.rays {
            let dir = lobe_dir(&finalize.lobe, axis, k, rot);
            if dir.dot(n) > 0.0 && dir.is_finite() {
                trace(dir, &mut shade);
            }
        }
    }
    if shade.rays == 0 {
        trace(axis, &mut shade);
    }
    let inv = 1.0 / shade.rays as f32;
    shade.rgb *= inv;
    shade.hit_weight *= inv;
    shade.env_weight = misses as f32 * inv;
    shade.env_dir = env_dir.try_normalize().unwrap_or(axis);
    (shade, unanswered)
}
