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

mod bins;
mod camera;
mod finalize;
pub mod pass;

pub use bins::{
    normal_bin, try_assign_clusters, try_bin_layout, try_cluster_bins_max, try_cluster_ranges,
    try_count_objects, ClusterOptions, ObjectBins, BINS_LIMIT, MAX_PHI_BINS, MAX_THETA_BINS,
};
pub use camera::{
    center_height, try_cluster_camera, ClipPlane, ClusterCamera, ClusterCameraOptions,
    ClusterFallback, ClusterView, CONCAVE_TOLERANCE, MAX_TAN, MAX_TAN_PLANE,
};
pub use finalize::{
    try_finalize_cluster, try_lobe_angle, ClusterShade, FinalizeInput, Lobe, GLOSSY_NEIGHBORHOOD,
    MAX_LOBE_RAYS,
};
pub use pass::{
    try_cluster_plan_len, ClusterObjects, ClusterPass, ClusterPassOptions, ClusterPlanEntry,
    ClusterPlanLen, ClusterPlanStats, ClusterRender, ClusterScratchMut, ClusterSink, ClusterStats,
    ClusterTexel,
};

use bins::{assign_clusters, count_objects};
use camera::cluster_camera;
use finalize::{check_finalize, finalize_pixel, SelfHits, Unanswered};

use crate::{Error, ImageView};
use glam::Vec3;

/// Object id of a pixel that belongs to no reflective object.
pub const NO_OBJECT: u32 = u32::MAX;

/// Cluster id of a pixel that belongs to no cluster.
pub const NO_CLUSTER: u32 = u32::MAX;

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
