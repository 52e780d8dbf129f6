//! Normal-bin clustering of the reflective pixels (seed 003 Sec. 3.2):
//! per-object pixel counts, the per-object bin layout, the normal bin and
//! cluster id of every pixel, and the counting sort into per-cluster
//! pixel ranges.

use super::{NO_CLUSTER, NO_OBJECT};
use crate::{Error, ImageView, ImageViewMut, RowRange};
use glam::Vec3;

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
    pub(super) fn validate(&self) -> Result<(), Error> {
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
