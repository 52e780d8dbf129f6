//! The cluster pass: seed 003's second-order reflections as one plan call
//! per frame and one finalize call per cluster and row band (design.md,
//! "Passes"; issue 13).
//!
//! The kernels of [`crate::cluster`] are the parts; this is the glue a host
//! needed around them, moved into refl-core:
//!
//! 1. **Size query** ([`try_cluster_plan_len`]): the caller memory of a
//!    plan ([`ClusterScratchMut`]: two `u32` per pixel and a few per
//!    object) and the most clusters a frame can have.
//! 2. **Plan** ([`ClusterPass::try_plan`], once per frame): from the
//!    G-buffer and the objects' id image, the reflective pixels (below),
//!    their object counts, the bin layout, the per-pixel cluster ids, the
//!    counting sort into per-cluster pixel lists
//!    ([`try_count_objects`](super::try_count_objects),
//!    [`try_bin_layout`],
//!    [`try_assign_clusters`](super::try_assign_clusters),
//!    [`try_cluster_ranges`]), then one camera
//!    per non-empty cluster ([`try_cluster_camera`](super::try_cluster_camera))
//!    with its frustum ([`Camera::frustum_planes`](crate::Camera::frustum_planes)) and resolution, written
//!    to the caller's list of [`ClusterPlanEntry`].
//! 3. **The host renders** each entry with a camera: depth (and color)
//!    through [`ClusterCamera::camera`], only geometry strictly in front of
//!    [`ClusterCamera::clip`] (a planar cluster also leaves out its own
//!    object), culled with [`ClusterPlanEntry::frustum`].
//! 4. **Finalize** ([`ClusterPass::try_finalize_rows`] per cluster and row
//!    band, [`ClusterPass::try_finalize`] over an image band): per pixel
//!    of the cluster in the band, its reflection
//!    ([`try_finalize_cluster`](super::try_finalize_cluster)'s
//!    [`ClusterShade`]) with a status ([`ClusterTexel`]), and the pixels the
//!    depth image cannot answer appended to the caller's list of
//!    [`HostRay`]s. Clusters own disjoint pixels and bands disjoint rows:
//!    a host's threads may finalize any clusters and bands at once.
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::cluster::{try_cluster_plan_len, ClusterObjects, ClusterPass, ClusterPassOptions};
//! use refl_core::cluster::{ClusterPlanEntry, ClusterRender, ClusterScratchMut, ClusterTexel};
//! use refl_core::cluster::{Lobe, ObjectBins, NO_OBJECT};
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::{Camera, DepthConvention, DepthImage, GBuffer, ImageView, ImageViewMut};
//! use refl_core::{MirrorStatus, NormalSpace};
//!
//! // 16 x 16 pixels: the eye 1 above the floor y = 0 (object 0), looking down -Z at a
//! // wall at z = -4 (not reflective).
//! let cam = Camera::try_look_at(Vec3::Y, Vec3::new(0.0, 1.0, -1.0), Vec3::Y, FRAC_PI_2, 0.1, 100.0, 16, 16)?;
//! let (mut depth, mut normals) = (vec![4.0f32; 256], vec![[0.0, 0.0, 1.0f32]; 256]);
//! let mut ids = vec![NO_OBJECT; 256];
//! for (i, (d, n)) in depth.iter_mut().zip(&mut normals).enumerate() {
//!     // Row y looks along NDC y = 1 - (2 y + 1) / 16 and meets the floor at depth -1 / NDC y.
//!     let floor = -1.0 / (1.0 - (2 * (i / 16) + 1) as f32 / 16.0);
//!     if (0.0..4.0).contains(&floor) {
//!         (*d, *n, ids[i]) = (floor, [0.0, 1.0, 0.0], 0);
//!     }
//! }
//! let depth = DepthImage::try_new(ImageView::try_new(&depth, 16, 16, 16)?, cam, DepthConvention::Linear)?;
//! let gbuffer = GBuffer::try_new(depth, ImageView::try_new(&normals, 16, 16, 16)?, NormalSpace::World)?;
//! let lobes = [Lobe::MIRROR];
//! let objects = ClusterObjects { ids: ImageView::try_new(&ids, 16, 16, 16)?, lobes: &lobes };
//!
//! // Plan: the flat floor is one planar cluster of 96 pixels, rendered from the
//! // mirrored eye (0, -1, 0).
//! let options = ClusterPassOptions::default();
//! let pass = ClusterPass::try_new(gbuffer, options)?;
//! let len = try_cluster_plan_len(16, 16, lobes.len(), &options)?;
//! let (mut cluster_ids, mut order) = (vec![0u32; len.ids], vec![0u32; len.order]);
//! let (mut offsets, mut counts) = (vec![0u32; len.offsets], vec![0u32; len.counts]);
//! let mut layout = vec![ObjectBins::default(); len.layout];
//! let scratch = ClusterScratchMut {
//!     ids: &mut cluster_ids, order: &mut order, offsets: &mut offsets,
//!     counts: &mut counts, layout: &mut layout,
//! };
//! let mut plan: Vec<Option<ClusterPlanEntry>> = vec![None; len.clusters];
//! let stats = pass.try_plan(&mut plan, scratch, &objects)?;
//! assert_eq!((stats.clusters, stats.planar, stats.pixels), (1, 1, 96));
//! let entry = plan[0].expect("one cluster");
//! let camera = entry.camera().expect("a planar cluster has a camera").camera;
//! assert!((camera.eye() - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-5);
//!
//! // The host renders the wall through that camera: depth and color per texel.
//! let (w, h) = (camera.width(), camera.height());
//! let wall_depth: Vec<f32> = (0..w * h)
//!     .map(|i| camera.primary_ray(Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5)))
//!     .map(|ray| camera.linear_depth(ray.at((-4.0 - ray.origin.z) / ray.dir.z)))
//!     .collect();
//! let wall_color = vec![[0.2f32, 0.4, 0.6]; wall_depth.len()];
//! let depth = DepthImage::try_new(ImageView::try_new(&wall_depth, w, h, w)?, camera, DepthConvention::Linear)?;
//! let render = ClusterRender::try_new(depth, ImageView::try_new(&wall_color, w, h, w)?)?;
//!
//! // Finalize: every floor pixel sees the wall.
//! let mut out = vec![ClusterTexel::default(); 256];
//! let mut view = ImageViewMut::try_new(&mut out, 16, 16, 16)?;
//! let done = pass.try_finalize(&mut view, &mut [], &entry, &order, Some(&render))?;
//! assert_eq!((done.pixels, done.hits), (96, 96));
//! // Pixel (8, 13) reflects the floor point P toward the wall point Q at height 1.75
//! // (the `ssr` example's pixel).
//! let (p, q) = (Vec3::new(1.0 / 11.0, 0.0, -16.0 / 11.0), Vec3::new(0.25, 1.75, -4.0));
//! let shade = out[13 * 16 + 8].shade;
//! assert_eq!((out[13 * 16 + 8].status, shade.hit_weight), (MirrorStatus::Hit, 1.0));
//! assert!((shade.mirror_dir - (q - p).normalize()).length() < 1e-4);
//! assert!((shade.rgb - Vec3::new(0.2, 0.4, 0.6)).length() < 1e-5);
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! # Pixels and rays
//! The surface point, the normal (turned toward the eye) and the mirror
//! direction of a pixel are the mirror pass's ([`crate::ssr`], module docs,
//! steps 1 to 3: the same code, a [`MirrorPass`] over the G-buffer with
//! [`ClusterPassOptions::mirror_options`]), and so are the host rays
//! ([`MirrorPass::host_ray`]: origin on the surface, `t_min`, `t_max` of the
//! options). A pixel is reflective when its id in [`ClusterObjects::ids`]
//! is below the number of objects (`lobes.len()`) and the mirror pass has
//! a ray for it (mask not 0, roughness not NaN, a usable surface; roughness
//! is not compared: the object's [`Lobe`] says how glossy it is). The
//! depth image needs no start offset: its clip plane removes the
//! reflector's own cluster surface (seed 003 Sec. 3.3), so every ray is
//! stepped from its surface point, as the kernel does.
//!
//! # Per cluster
//! * Camera options: [`ClusterPassOptions::camera`], the cone half-angle
//!   the larger of its own and, for a glossy lobe (`rays > 1`), the lobe's
//!   [`Lobe::max_angle`] (the frame holds every lobe direction; seed 003
//!   Sec. 3.5 item 1), and for a glossy lobe the far distance
//!   `min(D, r / tan(max_angle))` with `r` the
//!   [`ClusterCameraOptions::glossy_blur_radius`] (Sec. 3.5 item 2).
//!   With [`ClusterPassOptions::fade`] a glossy hit then fades to 0 at that
//!   nearer far plane, as the seed blends it.
//! * A cluster whose camera is not representable gets
//!   [`ClusterFallback::Degenerate`] instead of failing the frame.
//! * Finalize input: thickness [`ClusterPassOptions::thickness`] times the
//!   pass's far distance `D` (not a glossy cluster's nearer one), or the render's back-face image; the pass's step,
//!   refine, fade and seed options; the object's lobe.
//!
//! # Concave clusters
//! Seed 003 Sec. 4.4 handles concave reflectors "in one of two ways". By
//! default the pass takes the first: a concave cluster is finalized like a
//! convex one, and a ray that would meet the reflector again sees what the
//! depth image holds beyond it (the depth image is clipped at the
//! cluster's front, so it never holds the cluster). With
//! [`ClusterPassOptions::second_intersection`] it takes the second: the
//! plan marks the clusters whose surface's center lies behind their image
//! plane ([`ClusterCamera::concave`], [`ClusterPlanStats::concave`]), and
//! each ray of such a cluster is also stepped through the output view's
//! depth image (the G-buffer's, with the mirror pass's start rule and
//! thickness, [`ClusterPassOptions::mirror_options`], and this pass's
//! stepping) up to its depth-image hit; if it hits a pixel of the
//! cluster's own object (the reflector; the seed says "the cluster itself",
//! but clusters gather similar normals, so the second intersection mostly
//! lies on another cluster of the reflector) from that surface's front,
//! the ray is answered there with the reflector's diffuse color at that
//! pixel ([`ClusterRender::with_reflector`]) and counted in
//! [`ClusterShade::self_hits`]. "None of the two methods provide the
//! accurate second order reflection, but the second method provides a
//! more stable reflection, at the small additional cost": one screen-space
//! trace per ray of the concave clusters only.
//!
//! # Status of a finalized pixel
//! * [`MirrorStatus::Hit`]: every traced ray hit the depth image.
//! * [`MirrorStatus::Sky`]: some ray reached the far plane `D` in front of
//!   every surface and none went to the host: the environment in
//!   [`ClusterShade::env_dir`] with weight [`ClusterShade::env_weight`]
//!   answers it.
//! * Host ([`MirrorStatus::needs_host`]): a ray left the image
//!   ([`MirrorStatus::LeftImage`]), passed behind geometry
//!   ([`MirrorStatus::BehindGeometry`]), ran out of steps
//!   ([`MirrorStatus::OutOfSteps`]) or had no projection
//!   ([`MirrorStatus::NoProjection`]; the first such ray of the pixel
//!   decides), or the cluster has no camera (a [`ClusterView::Fallback`]
//!   entry, [`MirrorStatus::NoProjection`], shade: `env_weight` 1 in the
//!   mirror direction). The host traces the pixel's mirror ray for the
//!   share `env_weight` (or looks up its environment there).

use super::{
    assign_clusters, check_finalize, cluster_camera, count_objects, finalize_pixel, try_bin_layout,
    try_cluster_bins_max, try_cluster_ranges, validate_pixels, ClusterCamera, ClusterCameraOptions,
    ClusterFallback, ClusterOptions, ClusterShade, ClusterView, FinalizeInput, Lobe, ObjectBins,
    SelfHits, Surfaces, Unanswered, NO_OBJECT,
};
use crate::step::StepOptions;
use crate::{
    DepthImage, Error, GBuffer, HostRay, ImageView, ImageViewMut, MirrorMethod, MirrorOptions,
    MirrorPass, MirrorStatus, RowRange, Thickness,
};
use glam::{Vec3, Vec4};

/// Settings of the cluster pass. [`ClusterPassOptions::default`] has the
/// gain and thickness `refl report` runs the cluster method with (gain 64,
/// thickness 0.005 of the far distance, which the report sets to the scene
/// diameter; set [`ClusterCameraOptions::far_distance`] to yours).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterPassOptions {
    /// Clustering (seed 003 Sec. 3.2).
    pub cluster: ClusterOptions,
    /// Cluster cameras (Sec. 3.3); the cone half-angle is the least one
    /// (module docs, "Per cluster").
    pub camera: ClusterCameraOptions,
    /// Surface thickness of the cluster depth images without a back-face
    /// image, as a fraction of the far distance `D`
    /// ([`ClusterCameraOptions::far_distance`]); `>= 0`, `+inf` allowed.
    pub thickness: f32,
    /// Stepping through the depth images (`stride >= 1`).
    pub step: StepOptions,
    /// Refine hits to sub-texel accuracy.
    pub refine: bool,
    /// Glossy fade (Sec. 3.5 item 2, [`FinalizeInput::fade`]) of the
    /// clusters whose lobe samples several rays; mirror clusters never
    /// fade.
    pub fade: bool,
    /// Rotates each pixel's lobe samples.
    pub seed: u32,
    /// Host rays start at this distance (finite, `>= 0`), as
    /// [`MirrorOptions::t_min`].
    pub t_min: f32,
    /// Host rays end at this distance (`> t_min`, `+inf` allowed).
    pub t_max: f32,
    /// Concave clusters (seed 003 Sec. 4.4): `false` handles them like
    /// convex ones (the seed's first way: "ignoring the second
    /// intersection with the reflector surface sampled by the cluster");
    /// `true` takes the seed's second way: the rays of a cluster whose
    /// camera is [`ClusterCamera::concave`] are also traced against their
    /// reflector itself in the output view, and a ray that meets it before
    /// anything in the depth image takes the reflector's diffuse color
    /// there ([`ClusterRender::with_reflector`], then
    /// required for concave clusters; module docs, "Concave clusters").
    pub second_intersection: bool,
    /// Seed 003 Sec. 4.2.2's cheaper glossy reflection: glossy clusters
    /// trace the mirror ray alone and average the lobe's neighborhood of
    /// the hit ([`FinalizeInput::single_ray`]).
    pub glossy_single_ray: bool,
}

impl Default for ClusterPassOptions {
    /// Gain 64 (the seed's 13 x 8 bins), the camera defaults
    /// ([`ClusterCameraOptions::default`]), thickness 0.005 `D` (the root
    /// package's `THICKNESS_OF_DIAMETER` with `D` the scene diameter),
    /// stepping defaults, refined hits, no fade, seed 0, host rays over
    /// `[0, +inf)`, concave clusters as convex ones, glossy lobes traced
    /// ray by ray.
    fn default() -> Self {
        Self {
            cluster: ClusterOptions {
                gain: 64.0,
                ..ClusterOptions::default()
            },
            camera: ClusterCameraOptions::default(),
            thickness: 0.005,
            step: StepOptions::default(),
            refine: true,
            fade: false,
            seed: 0,
            t_min: 0.0,
            t_max: f32::INFINITY,
            second_intersection: false,
            glossy_single_ray: false,
        }
    }
}

impl ClusterPassOptions {
    /// The mirror pass's options the pass generates its rays and host rays
    /// with: stepping, [`ClusterPassOptions::t_min`] and
    /// [`ClusterPassOptions::t_max`], no roughness limit, no border fade.
    pub fn mirror_options(&self) -> MirrorOptions {
        MirrorOptions {
            method: MirrorMethod::Step,
            t_min: self.t_min,
            t_max: self.t_max,
            max_roughness: f32::INFINITY,
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
        self.cluster.validate()?;
        self.camera.validate()?;
        if !(self.thickness >= 0.0) || self.step.stride == 0 {
            return Err(Error::InvalidArgument);
        }
        crate::ssr::validate_options(&self.mirror_options())
    }
}

/// The reflective objects of a frame: an id per pixel and a lobe per
/// object (module docs, "Pixels and rays").
#[derive(Clone, Copy, Debug)]
pub struct ClusterObjects<'a> {
    /// Object id per pixel, the G-buffer's size; an id at or beyond
    /// `lobes.len()` ([`NO_OBJECT`] among them) marks a
    /// pixel that is not reflective.
    pub ids: ImageView<'a, u32>,
    /// The rays per pixel of each object ([`Lobe::MIRROR`] for a mirror).
    pub lobes: &'a [Lobe],
}

/// Elements of each part of a plan's caller memory
/// ([`try_cluster_plan_len`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ClusterPlanLen {
    /// Cluster id per pixel ([`ClusterScratchMut::ids`]).
    pub ids: usize,
    /// Pixel indices sorted by cluster ([`ClusterScratchMut::order`]).
    pub order: usize,
    /// Cluster offsets into `order` ([`ClusterScratchMut::offsets`]).
    pub offsets: usize,
    /// Pixels per object ([`ClusterScratchMut::counts`]).
    pub counts: usize,
    /// Bins per object ([`ClusterScratchMut::layout`]).
    pub layout: usize,
    /// The most clusters a frame can have: the length of the list of
    /// [`ClusterPlanEntry`] ([`ClusterPass::try_plan`]).
    pub clusters: usize,
}

impl ClusterPlanLen {
    /// The five scratch parts back to back in one buffer of `u32`s (ids,
    /// order, offsets, counts, layout of three `u32` each: what the C
    /// ABI's scratch holds), or `None` on overflow.
    pub fn words(&self) -> Option<usize> {
        self.ids
            .checked_add(self.order)?
            .checked_add(self.offsets)?
            .checked_add(self.counts)?
            .checked_add(self.layout.checked_mul(3)?)
    }
}

/// The caller memory of a plan ([`ClusterPass::try_plan`]), each part at
/// least its [`ClusterPlanLen`] long. After the plan, `order` holds every
/// cluster's pixels ([`ClusterPlanEntry::first`], [`ClusterPlanEntry::len`]),
/// which [`ClusterPass::try_finalize_rows`] reads.
#[derive(Debug)]
pub struct ClusterScratchMut<'s> {
    /// Cluster id per pixel ([`NO_CLUSTER`](super::NO_CLUSTER) for pixels in
    /// none), row-major, the G-buffer's width as stride.
    pub ids: &'s mut [u32],
    /// Pixel indices `y * width + x`, grouped by cluster, each group in
    /// raster order.
    pub order: &'s mut [u32],
    /// `order[offsets[c] .. offsets[c + 1]]` are cluster `c`'s pixels.
    pub offsets: &'s mut [u32],
    /// Reflective pixels per object.
    pub counts: &'s mut [u32],
    /// Bins per object.
    pub layout: &'s mut [ObjectBins],
}

/// The caller memory of a plan of a `width x height` G-buffer with
/// `objects` objects (lobes) and `options`.
///
/// # Errors
/// [`Error::InvalidArgument`] for a zero size, a frame of more than
/// `u32::MAX` pixels, invalid clustering options, or more bins than
/// `u32` ids hold ([`try_cluster_bins_max`]).
pub fn try_cluster_plan_len(
    width: u32,
    height: u32,
    objects: usize,
    options: &ClusterPassOptions,
) -> Result<ClusterPlanLen, Error> {
    let pixels = u64::from(width) * u64::from(height);
    if pixels == 0 || pixels > u64::from(u32::MAX) {
        return Err(Error::InvalidArgument);
    }
    let objects32 = u32::try_from(objects).map_err(|_| Error::InvalidArgument)?;
    let bins = try_cluster_bins_max(objects32, &options.cluster)?;
    let pixels = usize::try_from(pixels).map_err(|_| Error::InvalidArgument)?;
    Ok(ClusterPlanLen {
        ids: pixels,
        order: pixels,
        offsets: bins as usize + 1,
        counts: objects,
        layout: objects,
        clusters: (bins as usize).min(pixels),
    })
}

/// One cluster of a plan: what the host renders and what
/// [`ClusterPass::try_finalize_rows`] reads back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterPlanEntry {
    /// The cluster id (its bin).
    pub id: u32,
    /// The object its pixels belong to.
    pub object: u32,
    /// Its pixels are `order[first .. first + len]` of the plan's
    /// [`ClusterScratchMut::order`], in raster order.
    pub first: u32,
    /// Number of pixels (at least 1).
    pub len: u32,
    /// The rows its pixels span (finalize bands lie within).
    pub rows: RowRange,
    /// The object's rays per pixel.
    pub lobe: Lobe,
    /// The camera to render (its [`Camera`](crate::Camera) holds the resolution and the
    /// frustum's angles and depth range), or why there is none.
    pub view: ClusterView,
    /// The camera's frustum planes, world space
    /// ([`Camera::frustum_planes`](crate::Camera::frustum_planes): with an
    /// infinite far plane the last is `(0, 0, 0, 1)`, no bound; all zero
    /// without a camera).
    pub frustum: [Vec4; 6],
}

impl ClusterPlanEntry {
    /// The cluster's camera, if it has one.
    pub fn camera(&self) -> Option<&ClusterCamera> {
        match &self.view {
            ClusterView::Camera(c) => Some(c),
            ClusterView::Fallback(_) => None,
        }
    }
}

/// Counts of a plan.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClusterPlanStats {
    /// Cluster ids used by the bin layout (the bins of the visible
    /// objects).
    pub bins: u32,
    /// Non-empty clusters: the entries written.
    pub clusters: u32,
    /// Of those, the ones with a camera.
    pub cameras: u32,
    /// Of those, the planar ones.
    pub planar: u32,
    /// Of those, the concave ones ([`ClusterCamera::concave`]).
    pub concave: u32,
    /// Reflective pixels (in some cluster).
    pub pixels: u32,
}

/// The host's render of one cluster: depth through the entry's camera (any
/// [`crate::DepthConvention`]), the color of the same texels and,
/// optionally, back-face depth (then a hit needs the ray between the two,
/// instead of [`ClusterPassOptions::thickness`]).
#[derive(Clone, Copy, Debug)]
pub struct ClusterRender<'a> {
    depth: DepthImage<'a>,
    color: ImageView<'a, [f32; 3]>,
    back_depth: Option<ImageView<'a, f32>>,
    reflector: Option<(ImageView<'a, [f32; 3]>, ImageView<'a, u32>)>,
}

impl<'a> ClusterRender<'a> {
    /// Binds a cluster's depth and color.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `color` is not `depth`'s size.
    pub fn try_new(depth: DepthImage<'a>, color: ImageView<'a, [f32; 3]>) -> Result<Self, Error> {
        if color.width() != depth.width() || color.height() != depth.height() {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            depth,
            color,
            back_depth: None,
            reflector: None,
        })
    }

    /// Adds back-face depth (same camera and convention).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `back_depth` is not the depth's size.
    pub fn try_with_back_depth(mut self, back_depth: ImageView<'a, f32>) -> Result<Self, Error> {
        if back_depth.width() != self.depth.width() || back_depth.height() != self.depth.height() {
            return Err(Error::InvalidArgument);
        }
        self.back_depth = Some(back_depth);
        Ok(self)
    }

    /// Adds, for every pixel of the output view (the G-buffer's size,
    /// checked when finalizing), its diffuse component and its object id
    /// (the plan's [`ClusterObjects::ids`]): a ray of a concave cluster
    /// that meets its own object again takes the diffuse color there (seed
    /// 003 Sec. 4.4: "the ray color is set to the diffuse component of the
    /// cluster sample"; [`ClusterPassOptions::second_intersection`]).
    pub const fn with_reflector(
        mut self,
        diffuse: ImageView<'a, [f32; 3]>,
        ids: ImageView<'a, u32>,
    ) -> Self {
        self.reflector = Some((diffuse, ids));
        self
    }

    /// The reflector's diffuse and id images, if any.
    pub const fn reflector(&self) -> Option<&(ImageView<'a, [f32; 3]>, ImageView<'a, u32>)> {
        self.reflector.as_ref()
    }

    /// The depth image.
    pub const fn depth(&self) -> &DepthImage<'a> {
        &self.depth
    }

    /// The color image.
    pub const fn color(&self) -> &ImageView<'a, [f32; 3]> {
        &self.color
    }

    /// The back-face depth, if any.
    pub const fn back_depth(&self) -> Option<&ImageView<'a, f32>> {
        self.back_depth.as_ref()
    }
}

/// One finalized pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ClusterTexel {
    /// What happened (module docs, "Status of a finalized pixel").
    pub status: MirrorStatus,
    /// The reflection: [`try_finalize_cluster`](super::try_finalize_cluster)'s
    /// result for the pixel.
    pub shade: ClusterShade,
}

/// Counts of one finalize call.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClusterStats {
    /// Pixels finalized.
    pub pixels: u32,
    /// Of those, [`MirrorStatus::Hit`].
    pub hits: u32,
    /// Of those, [`MirrorStatus::Sky`].
    pub sky: u32,
    /// Pixels that need the host's tracer.
    pub host_rays: u32,
    /// Of those, the ones written to the host list (the first ones in
    /// raster order).
    pub host_rays_written: u32,
    /// Rays traced, summed over the pixels.
    pub rays: u64,
    /// Rays that hit, summed.
    pub ray_hits: u64,
    /// Of those, rays answered by their concave cluster's reflector itself
    /// ([`ClusterShade::self_hits`]), summed.
    pub self_hits: u64,
}

/// Where [`ClusterPass::try_finalize_rows`] puts its results.
pub trait ClusterSink {
    /// Pixel `(x, y)`'s result.
    fn texel(&mut self, x: u32, y: u32, texel: &ClusterTexel);
    /// Host ray number `index` of this call (raster order, counting only
    /// those stored); returns `false` if it was not stored (the list is
    /// full).
    fn host(&mut self, index: u32, ray: &HostRay) -> bool;
}

/// The cluster pass over one frame (module docs).
#[derive(Clone, Copy, Debug)]
pub struct ClusterPass<'a> {
    mirror: MirrorPass<'a>,
    options: ClusterPassOptions,
}

/// The G-buffer's surfaces as the kernels read them: the mirror pass's
/// surface point and normal (turned toward the eye) of each pixel.
struct PassSurfaces<'p, 'a> {
    mirror: &'p MirrorPass<'a>,
}

impl Surfaces for PassSurfaces<'_, '_> {
    fn width(&self) -> u32 {
        self.mirror.gbuffer().width()
    }

    fn at(&self, index: u32) -> Option<(Vec3, Vec3)> {
        let g = self.mirror.gbuffer();
        let (x, y) = (index % g.width(), index / g.width());
        let r = self.mirror.reflection(x, y).ok()?;
        Some((r.origin, r.normal))
    }
}

impl<'a> ClusterPass<'a> {
    /// Describes the pass over `gbuffer` with `options`.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for an option out of its range
    /// ([`ClusterPassOptions::try_validate`]) or a G-buffer of more than
    /// `u32::MAX` pixels.
    pub fn try_new(gbuffer: GBuffer<'a>, options: ClusterPassOptions) -> Result<Self, Error> {
        options.try_validate()?;
        if u64::from(gbuffer.width()) * u64::from(gbuffer.height()) > u64::from(u32::MAX) {
            return Err(Error::InvalidArgument);
        }
        #[cfg(feature = "hiz")]
        let mirror = MirrorPass::try_new(gbuffer, options.mirror_options(), None)?;
        #[cfg(not(feature = "hiz"))]
        let mirror = MirrorPass::try_new(gbuffer, options.mirror_options())?;
        Ok(Self { mirror, options })
    }

    /// The G-buffer.
    pub const fn gbuffer(&self) -> &GBuffer<'a> {
        self.mirror.gbuffer()
    }

    /// The options.
    pub const fn options(&self) -> &ClusterPassOptions {
        &self.options
    }

    /// The mirror pass whose rays the pass uses.
    pub const fn mirror_pass(&self) -> &MirrorPass<'a> {
        &self.mirror
    }

    fn surfaces(&self) -> PassSurfaces<'_, 'a> {
        PassSurfaces {
            mirror: &self.mirror,
        }
    }

    /// The object of pixel `(x, y)` if it is reflective (module docs).
    fn object(&self, objects: &ClusterObjects<'_>, x: u32, y: u32) -> u32 {
        match objects.ids.get(x, y) {
            Some(id)
                if (id as usize) < objects.lobes.len() && self.mirror.reflection(x, y).is_ok() =>
            {
                id
            }
            _ => NO_OBJECT,
        }
    }

    /// The camera options of a cluster of `lobe` (module docs): a glossy
    /// lobe widens the frame by its angle (seed 003 Sec. 3.5 item 1) and
    /// brings the far plane to `min(D, r / tan(max_angle))`
    /// ([`ClusterCameraOptions::glossy_blur_radius`], Sec. 3.5 item 2).
    fn camera_options(&self, lobe: &Lobe) -> ClusterCameraOptions {
        let mut c = self.options.camera;
        if lobe.rays > 1 {
            c.cone_half_angle = c.cone_half_angle.max(lobe.max_angle);
            let tan = libm::tanf(lobe.max_angle);
            let near = c.glossy_blur_radius / tan;
            // `tan > 0` for a lobe angle in (0, pi/2); `near` is positive
            // (or +inf); NaN never replaces `D`.
            if tan > 0.0 && near < c.far_distance {
                c.far_distance = near;
            }
        }
        c
    }

    /// Plans the frame (module docs, step 2): writes into `scratch` the
    /// cluster ids and per-cluster pixel lists and into `clusters[..n]` the
    /// `n` non-empty clusters in increasing id, each with its camera (or
    /// fallback reason), frustum and pixels; returns the counts (`n` is
    /// [`ClusterPlanStats::clusters`]). `clusters` holds
    /// [`ClusterPlanEntry`]s or any type made from one
    /// (`From<ClusterPlanEntry>`, the C ABI's record).
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: `objects.ids` not the G-buffer's
    ///   size, an invalid lobe, more objects or bins than `u32` ids hold.
    /// * [`Error::InsufficientSize`]: a scratch part or `clusters` shorter
    ///   than [`try_cluster_plan_len`] says.
    ///
    /// Nothing is written on error.
    pub fn try_plan<O: From<ClusterPlanEntry>>(
        &self,
        clusters: &mut [O],
        scratch: ClusterScratchMut<'_>,
        objects: &ClusterObjects<'_>,
    ) -> Result<ClusterPlanStats, Error> {
        let g = self.gbuffer();
        let (w, h) = (g.width(), g.height());
        let need = try_cluster_plan_len(w, h, objects.lobes.len(), &self.options)?;
        if objects.ids.width() != w || objects.ids.height() != h {
            return Err(Error::InvalidArgument);
        }
        for lobe in objects.lobes {
            lobe.validate()?;
        }
        if scratch.ids.len() < need.ids
            || scratch.order.len() < need.order
            || scratch.offsets.len() < need.offsets
            || scratch.counts.len() < need.counts
            || scratch.layout.len() < need.layout
            || clusters.len() < need.clusters
        {
            return Err(Error::InsufficientSize);
        }
        // Every input is valid: nothing below fails (the kernels' checks
        // hold by construction: unit normals of reflective pixels, counts
        // from zero, ids from the layout).
        let n = need.ids;
        let (ids, order) = (&mut scratch.ids[..n], &mut scratch.order[..n]);
        let counts = &mut scratch.counts[..need.counts];
        let layout = &mut scratch.layout[..need.layout];
        // The reflective pixels' objects, once per pixel, in `order` (free
        // until the counting sort).
        for y in 0..h {
            for x in 0..w {
                order[(y * w + x) as usize] = self.object(objects, x, y);
            }
        }
        let obj = ImageView::try_new(order, w, h, w)?;
        let all = RowRange::try_all(h)?;
        counts.fill(0);
        count_objects(counts, w, h, all, |x, y| obj.get(x, y).unwrap_or(NO_OBJECT))?;
        let bins = try_bin_layout(
            layout,
            counts,
            u64::from(w) * u64::from(h),
            &self.options.cluster,
        )?;
        let mut idv = ImageViewMut::try_new(ids, w, h, w)?;
        assign_clusters(
            &mut idv,
            layout,
            |x, y| obj.get(x, y).unwrap_or(NO_OBJECT),
            |x, y| self.mirror.reflection(x, y).ok().map(|r| r.normal),
        )?;
        let offsets = &mut scratch.offsets[..bins as usize + 1];
        let pixels = try_cluster_ranges(offsets, order, &ImageView::try_new(ids, w, h, w)?, bins)?;
        let eye = g.camera().eye();
        let surfaces = self.surfaces();
        let mut st = ClusterPlanStats {
            bins,
            pixels,
            ..ClusterPlanStats::default()
        };
        for c in 0..bins {
            let (a, b) = (offsets[c as usize], offsets[c as usize + 1]);
            if b <= a {
                continue;
            }
            let px = &order[a as usize..b as usize];
            let (p0, p1) = (px[0], px[px.len() - 1]);
            let object = objects.ids.get(p0 % w, p0 / w).unwrap_or(0);
            let lobe = objects
                .lobes
                .get(object as usize)
                .copied()
                .unwrap_or(Lobe::MIRROR);
            let view = cluster_camera(&surfaces, px, eye, &self.camera_options(&lobe))
                .unwrap_or(ClusterView::Fallback(ClusterFallback::Degenerate));
            let frustum = match &view {
                ClusterView::Camera(cc) => {
                    st.cameras += 1;
                    st.planar += u32::from(cc.planar);
                    st.concave += u32::from(cc.concave);
                    cc.camera.frustum_planes()
                }
                ClusterView::Fallback(_) => [Vec4::ZERO; 6],
            };
            let entry = ClusterPlanEntry {
                id: c,
                object,
                first: a,
                len: b - a,
                rows: RowRange::try_new(p0 / w, p1 / w + 1, h)?,
                lobe,
                view,
                frustum,
            };
            if let Some(slot) = clusters.get_mut(st.clusters as usize) {
                *slot = entry.into();
            }
            st.clusters += 1;
        }
        Ok(st)
    }

    /// The pixels of `cluster` in `rows`: the sub-slice of its (raster
    /// order) pixel list, checked.
    fn band<'o>(
        &self,
        cluster: &ClusterPlanEntry,
        order: &'o [u32],
        rows: RowRange,
    ) -> Result<&'o [u32], Error> {
        let g = self.gbuffer();
        let (w, h) = (g.width(), g.height());
        if rows.end() > h {
            return Err(Error::InvalidArgument);
        }
        let (a, len) = (cluster.first as usize, cluster.len as usize);
        let px = order
            .get(a..a.checked_add(len).ok_or(Error::InvalidArgument)?)
            .ok_or(Error::InvalidArgument)?;
        let lo = px.partition_point(|&p| p / w < rows.start());
        let hi = lo + px[lo..].partition_point(|&p| p / w < rows.end());
        let band = &px[lo..hi];
        // A list not in raster order (not a plan's) could hold pixels of
        // other rows: refused, as pixels outside the image are.
        if band
            .iter()
            .any(|&p| p / w < rows.start() || p / w >= rows.end())
        {
            return Err(Error::InvalidArgument);
        }
        Ok(band)
    }

    /// The kernel input of a cluster of lobe `lobe` rendered as `render`
    /// (module docs, "Per cluster").
    fn finalize_input<'r>(&self, lobe: Lobe, render: &ClusterRender<'r>) -> FinalizeInput<'r> {
        let o = &self.options;
        FinalizeInput {
            thickness: match render.back_depth {
                Some(b) => Thickness::BackFaces(b),
                // A fraction of the pass's `D`, whatever the cluster's
                // own far plane (a nearer glossy one included).
                None => Thickness::Constant(o.thickness * o.camera.far_distance),
            },
            step: o.step,
            refine: o.refine,
            lobe,
            // The seed fades glossy reflections only (Sec. 3.5 item 2).
            fade: o.fade && lobe.rays > 1,
            seed: o.seed,
            single_ray: o.glossy_single_ray,
        }
    }

    /// Finalizes the pixels of `cluster` (an entry of
    /// [`ClusterPass::try_plan`], whose `order` it reads) in `rows` from the
    /// host's `render` of it (module docs, step 4): hands each pixel's
    /// [`ClusterTexel`] and, for the statuses of
    /// [`MirrorStatus::needs_host`], its host ray (raster order) to `sink`.
    /// A cluster without a camera needs no render (`render` is ignored):
    /// its pixels go to the host.
    ///
    /// The shade is bit for bit
    /// [`try_finalize_cluster`](super::try_finalize_cluster)'s over the
    /// band's pixels with the G-buffer's surfaces, the entry's camera and
    /// the finalize input of the module docs, except for the rays a
    /// concave cluster answers itself (module docs, "Concave clusters").
    ///
    /// # Errors
    /// [`Error::InvalidArgument`]: `rows` beyond the G-buffer; an entry
    /// whose pixels are not in `order`, outside the image or without a
    /// surface (not this G-buffer's plan); an invalid lobe or camera record;
    /// no render, or a render of another camera, for an entry with a
    /// camera; with [`ClusterPassOptions::second_intersection`], a concave
    /// entry's render without reflector images of the G-buffer's size
    /// ([`ClusterRender::with_reflector`]). Nothing is handed to `sink` then.
    pub fn try_finalize_rows(
        &self,
        cluster: &ClusterPlanEntry,
        order: &[u32],
        render: Option<&ClusterRender<'_>>,
        rows: RowRange,
        sink: &mut impl ClusterSink,
    ) -> Result<ClusterStats, Error> {
        let band = self.band(cluster, order, rows)?;
        cluster.lobe.validate()?;
        let surfaces = self.surfaces();
        let eye = self.gbuffer().camera().eye();
        let w = self.gbuffer().width();
        let g = self.gbuffer();
        let traced = match &cluster.view {
            ClusterView::Camera(cc) => {
                let r = render.ok_or(Error::InvalidArgument)?;
                if r.depth.camera() != &cc.camera {
                    return Err(Error::InvalidArgument);
                }
                let fin = self.finalize_input(cluster.lobe, r);
                check_finalize(&surfaces, band, eye, cc, &r.depth, &r.color, &fin)?;
                // Sec. 4.4's second way, for concave clusters.
                let own = if self.options.second_intersection && cc.concave {
                    let (diffuse, ids) = r.reflector.as_ref().ok_or(Error::InvalidArgument)?;
                    if diffuse.width() != g.width()
                        || diffuse.height() != g.height()
                        || ids.width() != g.width()
                        || ids.height() != g.height()
                    {
                        return Err(Error::InvalidArgument);
                    }
                    Some(SelfHits {
                        mirror: &self.mirror,
                        ids,
                        object: cluster.object,
                        diffuse,
                    })
                } else {
                    None
                };
                Some((cc, r, fin, own))
            }
            ClusterView::Fallback(_) => {
                validate_pixels(&surfaces, band)?;
                None
            }
        };
        let mut st = ClusterStats::default();
        for &p in band {
            let (x, y) = (p % w, p / w);
            let Ok(refl) = self.mirror.reflection(x, y) else {
                // Not reached: validated above.
                continue;
            };
            let texel = match &traced {
                Some((cc, r, fin, own)) => {
                    let (shade, why) = finalize_pixel(
                        &surfaces,
                        p,
                        eye,
                        cc,
                        &r.depth,
                        &r.color,
                        fin,
                        own.as_ref(),
                    );
                    let status = match why {
                        Some(Unanswered::LeftImage) => MirrorStatus::LeftImage,
                        Some(Unanswered::BehindGeometry) => MirrorStatus::BehindGeometry,
                        Some(Unanswered::OutOfSteps) => MirrorStatus::OutOfSteps,
                        Some(Unanswered::NoProjection) => MirrorStatus::NoProjection,
                        None if shade.env_weight > 0.0 => MirrorStatus::Sky,
                        None => MirrorStatus::Hit,
                    };
                    ClusterTexel { status, shade }
                }
                None => ClusterTexel {
                    status: MirrorStatus::NoProjection,
                    shade: ClusterShade {
                        env_weight: 1.0,
                        env_dir: refl.dir,
                        mirror_dir: refl.dir,
                        ..ClusterShade::default()
                    },
                },
            };
            st.pixels += 1;
            st.rays += u64::from(texel.shade.rays);
            st.ray_hits += u64::from(texel.shade.hits);
            st.self_hits += u64::from(texel.shade.self_hits);
            match texel.status {
                MirrorStatus::Hit => st.hits += 1,
                MirrorStatus::Sky => st.sky += 1,
                _ => {}
            }
            if texel.status.needs_host() {
                let hr = self
                    .mirror
                    .host_ray_from(x, y, refl.origin, refl.dir, texel.status);
                if sink.host(st.host_rays_written, &hr) {
                    st.host_rays_written += 1;
                }
                st.host_rays += 1;
            }
            sink.texel(x, y, &texel);
        }
        Ok(st)
    }

    /// [`ClusterPass::try_finalize_rows`] over the rows `out` owns (a whole
    /// image or a band from [`ImageViewMut::try_band`]): writes the
    /// cluster's pixels of those rows into `out` (other pixels are left as
    /// they are) and appends its host rays to `host` as far as it holds
    /// them.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `out` is not the G-buffer's size, and
    /// as [`ClusterPass::try_finalize_rows`]. Nothing is written then.
    pub fn try_finalize(
        &self,
        out: &mut ImageViewMut<'_, ClusterTexel>,
        host: &mut [HostRay],
        cluster: &ClusterPlanEntry,
        order: &[u32],
        render: Option<&ClusterRender<'_>>,
    ) -> Result<ClusterStats, Error> {
        let g = self.gbuffer();
        if out.width() != g.width() || out.height() != g.height() {
            return Err(Error::InvalidArgument);
        }
        let Some(rows) = out.owned_rows() else {
            return Ok(ClusterStats::default());
        };
        struct Views<'o, 'x, 'h> {
            out: &'o mut ImageViewMut<'x, ClusterTexel>,
            host: &'h mut [HostRay],
        }
        impl ClusterSink for Views<'_, '_, '_> {
            fn texel(&mut self, x: u32, y: u32, texel: &ClusterTexel) {
                if let Some(t) = self.out.get_mut(x, y) {
                    *t = *texel;
                }
            }
            fn host(&mut self, index: u32, ray: &HostRay) -> bool {
                match self.host.get_mut(index as usize) {
                    Some(slot) => {
                        *slot = *ray;
                        true
                    }
                    None => false,
                }
            }
        }
        self.try_finalize_rows(cluster, order, render, rows, &mut Views { out, host })
    }
}
