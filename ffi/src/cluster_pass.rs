//! The cluster pass (`refl_core::cluster::pass`): seed 003's second-order
//! reflections as one plan call per frame and one finalize call per
//! cluster and row band.
//!
//! A frame: `refl_cluster_pass_options_default` (or your own options),
//! `refl_cluster_plan_len` (the scratch and the cluster list to allocate),
//! `refl_cluster_plan` (clusters, cameras, frusta, resolutions); then for
//! each `refl_cluster_plan_entry` with a camera (`camera.fallback ==
//! REFL_CLUSTER_FALLBACK_NONE`) render depth and color through
//! `camera.camera`, keeping only geometry strictly on the positive side of
//! `camera.clip` (a planar cluster leaves out its own `object`), culled
//! with `frustum`, and call `refl_cluster_finalize_rows` over the entry's
//! `rows` (in bands, from any number of threads; clusters own disjoint
//! pixels). Entries without a camera are finalized without a render: their
//! pixels go to the host list.

use crate::gbuffer::{gbuffer, gbuffer_ranges, put_host_ray, refl_gbuffer, refl_host_ray};
use crate::image::{refl_image_f32, refl_image_u32, refl_image_vec3, refl_row_range};
use crate::ptr::{byte_len, check_buffer, disjoint, read, Out};
use crate::status::{fail, guard, refl_status};
use crate::trace::{depth_image, refl_depth_image, refl_step_options};
use crate::types::{
    refl_cluster_camera, refl_cluster_camera_options, refl_cluster_fallback, refl_cluster_lobe,
    refl_cluster_options, refl_cluster_shade, refl_vec4,
};
use refl_core::cluster::{
    try_cluster_plan_len, ClusterCamera, ClusterObjects, ClusterPass, ClusterPassOptions,
    ClusterPlanEntry, ClusterPlanLen, ClusterPlanStats, ClusterRender, ClusterScratchMut,
    ClusterSink, ClusterStats, ClusterTexel, ClusterView, Lobe, ObjectBins,
};
use refl_core::glam::Vec4;
use refl_core::{Error, GBuffer, HostRay, RowRange};

/// Settings of the cluster pass; `refl_cluster_pass_options_default` gives
/// the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_cluster_pass_options {
    /// Clustering (seed 003 Sec. 3.2). Default: 13 x 8 bins, gain 64.
    pub cluster: refl_cluster_options,
    /// Cluster cameras (Sec. 3.3); `cone_half_angle` is the least one (a
    /// glossy object's lobe widens it to its `max_angle`). Default:
    /// `refl_cluster_camera_options_default`.
    pub camera: refl_cluster_camera_options,
    /// Surface thickness of the cluster depth images without a back-face
    /// image, a fraction of `camera.far_distance`; >= 0, +infinity allowed.
    /// Default 0.005.
    pub thickness: f32,
    /// Stepping through the depth images (stride >= 1). Default:
    /// `refl_step_options_default`.
    pub step: refl_step_options,
    /// Refine hits to sub-texel accuracy. Default true.
    pub refine: bool,
    /// Glossy fade (seed 003 Sec. 3.5 item 2): in clusters whose lobe
    /// samples several rays, a hit's weight falls from 1 on the image plane
    /// to 0 at the far plane; mirror clusters never fade. Default false.
    pub fade: bool,
    /// Rotates each pixel's lobe samples. Default 0.
    pub seed: u32,
    /// Host rays start at this distance; finite, >= 0. Default 0.
    pub t_min: f32,
    /// Host rays end at this distance; > t_min, +infinity allowed (the
    /// default).
    pub t_max: f32,
    /// Concave clusters (seed 003 Sec. 4.4): false (the default) finalizes
    /// them like convex ones; true traces the rays of a cluster whose
    /// camera is `concave` against their reflector (the cluster's object)
    /// in the G-buffer's depth too, and a ray that meets it first takes
    /// `render.reflector_diffuse` there (`render.reflector_diffuse` and
    /// `render.reflector_ids` then required for concave clusters).
    pub second_intersection: bool,
    /// Seed 003 Sec. 4.2.2: glossy clusters trace the mirror ray alone and
    /// average the lobe's neighborhood of its hit
    /// (`refl_cluster_finalize_input.single_ray`). Default false.
    pub glossy_single_ray: bool,
}

impl From<ClusterPassOptions> for refl_cluster_pass_options {
    fn from(o: ClusterPassOptions) -> Self {
        Self {
            cluster: o.cluster.into(),
            camera: o.camera.into(),
            thickness: o.thickness,
            step: refl_step_options {
                stride: o.step.stride,
                max_steps: o.step.max_steps,
            },
            refine: o.refine,
            fade: o.fade,
            seed: o.seed,
            t_min: o.t_min,
            t_max: o.t_max,
            second_intersection: o.second_intersection,
            glossy_single_ray: o.glossy_single_ray,
        }
    }
}

impl From<refl_cluster_pass_options> for ClusterPassOptions {
    fn from(o: refl_cluster_pass_options) -> Self {
        Self {
            cluster: o.cluster.into(),
            camera: o.camera.into(),
            thickness: o.thickness,
            step: o.step.into(),
            refine: o.refine,
            fade: o.fade,
            seed: o.seed,
            t_min: o.t_min,
            t_max: o.t_max,
            second_intersection: o.second_intersection,
            glossy_single_ray: o.glossy_single_ray,
        }
    }
}

/// The pass's defaults: the seed's 13 x 8 bins at gain 64, the camera
/// defaults, thickness 0.005 of the far distance, stepping defaults,
/// refined hits, no fade, seed 0, host rays over [0, +infinity), concave
/// clusters as convex ones, glossy lobes traced ray by ray.
#[no_mangle]
pub extern "C" fn refl_cluster_pass_options_default() -> refl_cluster_pass_options {
    ClusterPassOptions::default().into()
}

/// The reflective objects of a frame.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_cluster_objects {
    /// Object id per pixel, the G-buffer's size; an id at or beyond
    /// `lobes_len` (UINT32_MAX among them) marks a pixel that is not
    /// reflective.
    pub ids: refl_image_u32,
    /// One lobe per object (`{1, 0, 0}` for a mirror); read in place.
    pub lobes: *const refl_cluster_lobe,
    /// Number of objects (may be 0 with `lobes` NULL: nothing reflects).
    pub lobes_len: usize,
}

/// What a plan needs of caller memory (`refl_cluster_plan_len`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_cluster_plan_sizes {
    /// `uint32_t`s of scratch: the cluster id and the sorted index of every
    /// pixel (2 x width x height, in that order: the pixel lists are
    /// `scratch[width * height ..]`), then the cluster offsets (the most
    /// clusters, `refl_cluster_bins_max`, plus one) and four words per
    /// object (its pixel count and its three-word bin layout):
    /// `2 w h + bins_max + 1 + 4 objects`.
    pub scratch_len: usize,
    /// The most clusters a frame can have: the length of the list of
    /// `refl_cluster_plan_entry`.
    pub clusters_len: usize,
}

/// One cluster of a plan: what the host renders, and what
/// `refl_cluster_finalize_rows` reads back.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_cluster_plan_entry {
    /// The cluster id (its normal bin).
    pub id: u32,
    /// The object its pixels belong to.
    pub object: u32,
    /// Its pixels (indices y * width + x, raster order) are
    /// `scratch[width * height + first ..][.. len]`.
    pub first: u32,
    /// Number of pixels (at least 1).
    pub len: u32,
    /// The rows its pixels span: the bands of `refl_cluster_finalize_rows`
    /// lie within.
    pub rows: refl_row_range,
    /// The object's rays per pixel.
    pub lobe: refl_cluster_lobe,
    /// The camera to render with (`camera.camera`: view, fov_y, near, far
    /// and the resolution width x height; `camera.clip`: keep only its
    /// positive side), or `camera.fallback`, why there is none.
    pub camera: refl_cluster_camera,
    /// The camera's frustum, world space: six planes (a, b, c, d) with a
    /// unit normal pointing inside (a point is in the frustum when a x + b
    /// y + c z + d >= 0 for all six: left, right, bottom, top, near, far);
    /// with an infinite far plane (an infinite `far_distance`) the far
    /// plane is (0, 0, 0, 1), no bound; all zero without a camera.
    pub frustum: [refl_vec4; 6],
}

fn vec4(v: Vec4) -> refl_vec4 {
    refl_vec4 {
        x: v.x,
        y: v.y,
        z: v.z,
        w: v.w,
    }
}

impl From<ClusterPlanEntry> for refl_cluster_plan_entry {
    fn from(e: ClusterPlanEntry) -> Self {
        Self {
            id: e.id,
            object: e.object,
            first: e.first,
            len: e.len,
            rows: refl_row_range {
                begin: e.rows.start(),
                end: e.rows.end(),
            },
            lobe: e.lobe.into(),
            camera: refl_cluster_camera::from_view(&e.view),
            frustum: e.frustum.map(vec4),
        }
    }
}

/// The entry as refl-core's, checked: `InvalidArgument` for rows not
/// within `height`, an unknown fallback value or an invalid camera record.
fn entry(e: &refl_cluster_plan_entry, height: u32) -> Result<ClusterPlanEntry, Error> {
    let bad = |what: &str| {
        fail(
            Error::InvalidArgument,
            format_args!("`cluster`: {what} (not an entry of refl_cluster_plan)"),
        )
    };
    let rows = RowRange::try_new(e.rows.begin, e.rows.end, height)
        .map_err(|_| bad("rows not within the G-buffer"))?;
    let view = if e.camera.fallback == 0 {
        ClusterView::Camera(
            ClusterCamera::try_from(&e.camera).map_err(|_| bad("an invalid camera record"))?,
        )
    } else {
        ClusterView::Fallback(
            refl_cluster_fallback::reason(e.camera.fallback)
                .ok_or_else(|| bad("an unknown fallback value"))?,
        )
    };
    Ok(ClusterPlanEntry {
        id: e.id,
        object: e.object,
        first: e.first,
        len: e.len,
        rows,
        lobe: e.lobe.into(),
        view,
        frustum: e.frustum.map(|p| Vec4::new(p.x, p.y, p.z, p.w)),
    })
}

/// Counts of `refl_cluster_plan`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_cluster_plan_stats {
    /// Cluster ids the bin layout used.
    pub bins: u32,
    /// Non-empty clusters: the entries written.
    pub clusters: u32,
    /// Of those, the ones with a camera.
    pub cameras: u32,
    /// Of those, the planar ones (one lookup per pixel).
    pub planar_cameras: u32,
    /// Of those, the concave ones (seed 003 Sec. 4.4).
    pub concave_cameras: u32,
    /// Reflective pixels (in some cluster).
    pub pixels: u32,
}

impl From<ClusterPlanStats> for refl_cluster_plan_stats {
    fn from(s: ClusterPlanStats) -> Self {
        Self {
            bins: s.bins,
            clusters: s.clusters,
            cameras: s.cameras,
            planar_cameras: s.planar,
            concave_cameras: s.concave,
            pixels: s.pixels,
        }
    }
}

/// The host's render of one cluster, through the entry's camera (its size
/// and camera).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_cluster_render {
    /// Depth, with the entry's camera (`camera.camera`) and any
    /// convention; NaN, or at or beyond the far plane, marks an empty
    /// texel.
    pub depth: refl_depth_image,
    /// Color of the same texels (linear RGB), the depth's size.
    pub color: refl_image_vec3,
    /// Optional back-face depth (same camera and convention): a hit needs
    /// the ray between the two instead of the options' thickness. Absent
    /// when `data` is NULL.
    pub back_depth: refl_image_f32,
    /// Optional diffuse component of every G-buffer pixel (linear RGB, the
    /// G-buffer's size): the color of a ray that meets its concave
    /// cluster's object again
    /// (`refl_cluster_pass_options.second_intersection`; required then for
    /// a concave cluster, with `reflector_ids`). Absent when `data` is
    /// NULL.
    pub reflector_diffuse: refl_image_vec3,
    /// The object id of every G-buffer pixel (the plan's
    /// `refl_cluster_objects.ids`), read with `reflector_diffuse`; absent
    /// when `data` is NULL.
    pub reflector_ids: refl_image_u32,
}

/// One finalized pixel.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_cluster_texel {
    /// A `refl_ssr_status`: HIT (every ray hit), SKY (some ray reached the
    /// far plane: add `shade.env_weight` times the environment in
    /// `shade.env_dir`), or a status whose pixel is in the host list
    /// (LEFT_IMAGE, BEHIND_GEOMETRY, OUT_OF_STEPS; NO_PROJECTION, also for
    /// every pixel of a cluster without a camera).
    pub status: u32,
    /// The reflection (as `refl_cluster_finalize` computes it).
    pub shade: refl_cluster_shade,
}

/// Counts of one `refl_cluster_finalize_rows` call.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_cluster_stats {
    /// Pixels finalized.
    pub pixels: u32,
    /// Of those, HIT.
    pub hits: u32,
    /// Of those, SKY.
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
    /// Of those, rays their concave cluster answered itself, summed.
    pub self_hits: u64,
}

impl From<ClusterStats> for refl_cluster_stats {
    fn from(s: ClusterStats) -> Self {
        Self {
            pixels: s.pixels,
            hits: s.hits,
            sky: s.sky,
            host_rays: s.host_rays,
            host_rays_written: s.host_rays_written,
            rays: s.rays,
            ray_hits: s.ray_hits,
            self_hits: s.self_hits,
        }
    }
}

/// The options, G-buffer and objects of a call, read and checked.
///
/// # Safety
/// Each pointer NULL or readable; the images they describe readable for
/// their `len` texels for `'a`, not written meanwhile.
unsafe fn pass<'a>(
    gbuffer: *const refl_gbuffer,
    options: *const refl_cluster_pass_options,
) -> Result<(refl_gbuffer, ClusterPass<'a>), Error> {
    // SAFETY: caller contract.
    let (g, o) = unsafe { (read(gbuffer, "gbuffer")?, read(options, "options")?) };
    // SAFETY: caller contract.
    let gb: GBuffer<'a> = unsafe { self::gbuffer(&g) }?;
    let p = ClusterPass::try_new(gb, o.into()).map_err(|e| {
        fail(
            e,
            format_args!("`options`: a value out of its range (refl_cluster_pass_options)"),
        )
    })?;
    Ok((g, p))
}

/// The sizes of a plan for `g`, `objects` and `o`.
fn sizes(
    width: u32,
    height: u32,
    objects: &refl_cluster_objects,
    o: &ClusterPassOptions,
) -> Result<(ClusterPlanLen, usize), Error> {
    let n = try_cluster_plan_len(width, height, objects.lobes_len, o).map_err(|e| {
        fail(
            e,
            format_args!(
                "no plan of a {width}x{height} frame with {} objects and these clustering options",
                objects.lobes_len
            ),
        )
    })?;
    let words = n.words().ok_or_else(|| {
        fail(
            Error::InvalidArgument,
            format_args!("the scratch does not fit in memory"),
        )
    })?;
    Ok((n, words))
}

/// Size query: writes to `*out` the `uint32_t`s of scratch and the length
/// of the cluster list `refl_cluster_plan` needs for this G-buffer's size,
/// these objects (their number) and options.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `gbuffer`, `objects` or
/// `options` is NULL; `REFL_STATUS_INVALID_ARGUMENT` for invalid clustering
/// options, a frame of more than UINT32_MAX pixels or more bins than
/// `uint32_t` ids hold; the camera's status if it is invalid.
///
/// # Safety
/// `out` NULL or writable; the rest NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_cluster_plan_len(
    out: *mut refl_cluster_plan_sizes,
    gbuffer: *const refl_gbuffer,
    objects: *const refl_cluster_objects,
    options: *const refl_cluster_pass_options,
) -> refl_status {
    guard("refl_cluster_plan_len", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let (g, ob, o) = unsafe {
            (
                read(gbuffer, "gbuffer")?,
                read(objects, "objects")?,
                read(options, "options")?,
            )
        };
        let cam = crate::types::camera_named(&g.depth.camera, "gbuffer.depth.camera")?;
        let (n, words) = sizes(cam.width(), cam.height(), &ob, &o.into())?;
        // SAFETY: caller contract.
        unsafe {
            out.write(refl_cluster_plan_sizes {
                scratch_len: words,
                clusters_len: n.clusters,
            })
        };
        Ok(())
    })
}

/// The objects as refl-core's (ids and lobes read in place).
///
/// # Safety
/// `ids.data` readable for `ids.len` texels and `lobes` for `lobes_len`
/// lobes for `'a`, not written meanwhile.
unsafe fn objects<'a>(ob: &refl_cluster_objects) -> Result<ClusterObjects<'a>, Error> {
    // SAFETY: caller contract.
    let ids = unsafe { ob.ids.view() }?;
    let lobes: &'a [Lobe] = if ob.lobes_len == 0 {
        &[]
    } else {
        check_buffer(ob.lobes, ob.lobes_len, "objects.lobes")?;
        // SAFETY: non-null, aligned, length fits isize (check_buffer),
        // readable (contract); refl_cluster_lobe has Lobe's layout (the
        // assertions beside refl_cluster_lobe).
        unsafe { core::slice::from_raw_parts(ob.lobes.cast::<Lobe>(), ob.lobes_len) }
    };
    Ok(ClusterObjects { ids, lobes })
}

/// Plans a frame: from the G-buffer and the objects, the reflective pixels
/// (an id below `lobes_len`, mask not 0, roughness not NaN, a usable
/// surface), their clusters (seed 003 Sec. 3.2: normal bins per object),
/// each cluster's pixel list (raster order) and camera (Sec. 3.3, Eq. 1),
/// frustum and resolution. Writes the cluster ids and pixel lists into
/// `scratch` (`refl_cluster_plan_sizes.scratch_len` words; keep it for the
/// finalize calls), the non-empty clusters in increasing id into
/// `clusters[0 .. out_stats->clusters]`, and the counts into `*out_stats`.
/// A cluster whose camera is not representable gets
/// `REFL_CLUSTER_FALLBACK_DEGENERATE`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `clusters`,
/// `scratch`, `gbuffer`, `objects`, `options`, a required image, or
/// `objects->lobes` with a non-zero `lobes_len` is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `clusters_len` or `scratch_len` is
/// below `refl_cluster_plan_len`'s, or an image's `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for an option out of range, an invalid
/// lobe, an unknown convention or normal space, an image (ids included)
/// not of the camera's size, a misaligned pointer, or outputs overlapping
/// each other or an input; the camera's status if it is invalid. Nothing
/// is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `clusters` NULL or writable for
/// `clusters_len` entries; `scratch` NULL or writable for `scratch_len`
/// words; `gbuffer`, `objects` and `options` NULL or readable, their
/// images and lobes readable and not written during the call.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_cluster_plan(
    out_stats: *mut refl_cluster_plan_stats,
    clusters: *mut refl_cluster_plan_entry,
    clusters_len: usize,
    scratch: *mut u32,
    scratch_len: usize,
    gbuffer: *const refl_gbuffer,
    objects: *const refl_cluster_objects,
    options: *const refl_cluster_pass_options,
) -> refl_status {
    guard("refl_cluster_plan", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        let clusters_bytes = check_buffer(clusters.cast_const(), clusters_len, "clusters")?;
        let scratch_bytes = check_buffer(scratch.cast_const(), scratch_len, "scratch")?;
        // SAFETY: caller contract.
        let (g, p) = unsafe { pass(gbuffer, options) }?;
        // SAFETY: caller contract.
        let ob = unsafe { read(objects, "objects") }?;
        // SAFETY: caller contract.
        let objs = unsafe { self::objects(&ob) }?;
        let (w, h) = (p.gbuffer().width(), p.gbuffer().height());
        let (n, words) = sizes(w, h, &ob, p.options())?;
        if scratch_len < words || clusters_len < n.clusters {
            return Err(fail(
                Error::InsufficientSize,
                format_args!(
                    "`scratch_len` {scratch_len} / `clusters_len` {clusters_len}: the plan needs {words} / {} (refl_cluster_plan_len)",
                    n.clusters
                ),
            ));
        }
        let mut ins = [(0usize, 0usize); 8];
        ins[..6].copy_from_slice(&gbuffer_ranges(&g));
        ins[6] = (ob.ids.data as usize, ob.ids.len.saturating_mul(4));
        ins[7] = (
            ob.lobes as usize,
            ob.lobes_len
                .saturating_mul(core::mem::size_of::<refl_cluster_lobe>()),
        );
        disjoint(
            &[
                (clusters as usize, clusters_bytes),
                (scratch as usize, scratch_bytes),
                (
                    out_stats as usize,
                    core::mem::size_of::<refl_cluster_plan_stats>(),
                ),
            ],
            &ins,
        )?;
        // SAFETY: the parts are disjoint consecutive ranges within `words
        // <= scratch_len` writable words (checked, contract), disjoint from
        // every input and from `clusters` (checked); ObjectBins is repr(C)
        // of three u32 (alignment 4).
        let dst = unsafe {
            let ids = scratch;
            let order = ids.add(n.ids);
            let offsets = order.add(n.order);
            let counts = offsets.add(n.offsets);
            let layout = counts.add(n.counts);
            ClusterScratchMut {
                ids: core::slice::from_raw_parts_mut(ids, n.ids),
                order: core::slice::from_raw_parts_mut(order, n.order),
                offsets: core::slice::from_raw_parts_mut(offsets, n.offsets),
                counts: core::slice::from_raw_parts_mut(counts, n.counts),
                layout: core::slice::from_raw_parts_mut(layout.cast::<ObjectBins>(), n.layout),
            }
        };
        // SAFETY: checked (non-null, aligned, size), writable by contract,
        // disjoint from the inputs and the scratch (checked).
        let list = unsafe { core::slice::from_raw_parts_mut(clusters, clusters_len) };
        // Validates everything before the first write.
        let st = p.try_plan(list, dst, &objs)?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(st.into()) };
        Ok(())
    })
}

/// Where a C finalize writes: texels by raw pointer (other threads may
/// write other clusters' pixels of the same image) and the host list.
struct Sink {
    texels: *mut refl_cluster_texel,
    width: usize,
    host: *mut refl_host_ray,
    host_len: usize,
}

impl ClusterSink for Sink {
    fn texel(&mut self, x: u32, y: u32, t: &ClusterTexel) {
        let v = refl_cluster_texel {
            status: crate::ssr::refl_ssr_status::from(t.status) as u32,
            shade: (&t.shade).into(),
        };
        let i = y as usize * self.width + x as usize;
        // SAFETY: `x < width`, `y < height` (pixels of the G-buffer), so
        // `i < width * height <= out_len` writable texels (checked by
        // `refl_cluster_finalize_rows`, contract); only this cluster's
        // pixels of this call's rows are written.
        unsafe { self.texels.add(i).write(v) };
    }

    fn host(&mut self, index: u32, r: &HostRay) -> bool {
        // SAFETY: `host` writable for `host_len` entries, or `host_len` 0
        // (checked by `refl_cluster_finalize_rows`).
        unsafe { put_host_ray(self.host, self.host_len, index, refl_host_ray::from(*r)) }
    }
}

/// Finalizes the pixels of one cluster in the rows `rows` (seed 003 Sec.
/// 3.4, 3.5): `cluster` is an entry `refl_cluster_plan` wrote for this
/// G-buffer and these options, `scratch` its scratch (at least the first
/// 2 x width x height words are read), `render` the host's render through
/// the entry's camera (NULL for an entry without a camera). For each of
/// the cluster's pixels in those rows writes its `refl_cluster_texel` to
/// `out[y * width + x]` (`out` holds the whole image; no other texel is
/// written) and appends the pixels whose reflection the render cannot
/// answer (statuses LEFT_IMAGE, BEHIND_GEOMETRY, OUT_OF_STEPS,
/// NO_PROJECTION) to `host` (up to `host_len`; NULL with 0 allowed) in
/// raster order as the mirror pass's rays (origin on the surface, the
/// mirror direction, the options' t_min and t_max). The counts go to
/// `*out_stats`. Clusters own disjoint pixels and bands disjoint rows:
/// threads may finalize any clusters and bands into one `out` at once,
/// each with its own `host` list. The shades are bit for bit
/// `refl_cluster_finalize`'s for the cluster's pixels.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `out`, `gbuffer`,
/// `options`, `scratch`, `cluster`, a required image, `host` with a
/// non-zero `host_len`, or `render` for an entry with a camera is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len < width * height`,
/// `scratch_len < 2 * width * height` or an image's `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for rows reversed or beyond the height,
/// an entry not of this plan (rows, pixels outside the scratch or the
/// image, pixels without a surface, an invalid camera record or lobe), a
/// render of another camera or size (color, back faces), outputs
/// overlapping each other or an input, and the cases of
/// `refl_cluster_plan`. Nothing is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out` NULL or writable for `out_len`
/// texels; `host` NULL or writable for `host_len` entries; `scratch` NULL
/// or readable for `scratch_len` words; `cluster` and `render` NULL or
/// readable, their images readable for their `len` texels; the rest as
/// `refl_cluster_plan`. No other thread writes the texels this call writes
/// or the scratch meanwhile.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_cluster_finalize_rows(
    out_stats: *mut refl_cluster_stats,
    out: *mut refl_cluster_texel,
    out_len: usize,
    host: *mut refl_host_ray,
    host_len: usize,
    gbuffer: *const refl_gbuffer,
    options: *const refl_cluster_pass_options,
    scratch: *const u32,
    scratch_len: usize,
    cluster: *const refl_cluster_plan_entry,
    render: *const refl_cluster_render,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_cluster_finalize_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        let out_bytes = check_buffer(out.cast_const(), out_len, "out")?;
        let host_bytes = if host_len == 0 && host.is_null() {
            0
        } else {
            check_buffer(host.cast_const(), host_len, "host")?
        };
        let scratch_bytes = check_buffer(scratch, scratch_len, "scratch")?;
        // SAFETY: caller contract.
        let (g, p) = unsafe { pass(gbuffer, options) }?;
        let (w, h) = (p.gbuffer().width(), p.gbuffer().height());
        let rows = rows.within(h)?;
        let n = w as usize * h as usize;
        if out_len < n {
            return Err(fail(
                Error::InsufficientSize,
                format_args!("`out_len` is {out_len}, a {w}x{h} image needs {n}"),
            ));
        }
        if scratch_len / 2 < n {
            return Err(fail(
                Error::InsufficientSize,
                format_args!(
                    "`scratch_len` is {scratch_len}, a plan of {w}x{h} holds at least {}",
                    2 * n
                ),
            ));
        }
        // SAFETY: caller contract.
        let e = entry(&unsafe { read(cluster, "cluster") }?, h)?;
        let r = if render.is_null() {
            None
        } else {
            // SAFETY: caller contract.
            Some(unsafe { read(render, "render") }?)
        };
        let rv = match &r {
            None => None,
            Some(r) => {
                // SAFETY: caller contract.
                let (depth, color) = unsafe { (depth_image(&r.depth)?, r.color.view()?) };
                let bad = |_| {
                    fail(
                        Error::InvalidArgument,
                        format_args!("`render`: color or back_depth not the depth's size"),
                    )
                };
                let mut v = ClusterRender::try_new(depth, color).map_err(bad)?;
                if !r.back_depth.data.is_null() {
                    // SAFETY: caller contract.
                    v = v
                        .try_with_back_depth(unsafe { r.back_depth.view() }?)
                        .map_err(bad)?;
                }
                if !r.reflector_diffuse.data.is_null() || !r.reflector_ids.data.is_null() {
                    // SAFETY: caller contract.
                    let (d, i) = unsafe { (r.reflector_diffuse.view()?, r.reflector_ids.view()?) };
                    v = v.with_reflector(d, i);
                }
                Some(v)
            }
        };
        if e.camera().is_some() && rv.is_none() {
            return Err(fail(
                Error::NullPointer,
                format_args!("`render` is NULL for a cluster with a camera"),
            ));
        }
        // Aliasing: the outputs must not overlap each other or the inputs.
        let mut ins = [(0usize, 0usize); 12];
        ins[..6].copy_from_slice(&gbuffer_ranges(&g));
        ins[6] = (scratch as usize, scratch_bytes);
        if let Some(r) = &r {
            ins[7] = (
                r.depth.depth.data as usize,
                r.depth.depth.len.saturating_mul(4),
            );
            ins[8] = (r.color.data as usize, r.color.len.saturating_mul(12));
            if !r.back_depth.data.is_null() {
                ins[9] = (
                    r.back_depth.data as usize,
                    r.back_depth.len.saturating_mul(4),
                );
            }
            if !r.reflector_diffuse.data.is_null() {
                ins[10] = (
                    r.reflector_diffuse.data as usize,
                    r.reflector_diffuse.len.saturating_mul(12),
                );
            }
            if !r.reflector_ids.data.is_null() {
                ins[11] = (
                    r.reflector_ids.data as usize,
                    r.reflector_ids.len.saturating_mul(4),
                );
            }
        }
        disjoint(
            &[
                (out as usize, out_bytes),
                (host as usize, host_bytes),
                (
                    out_stats as usize,
                    core::mem::size_of::<refl_cluster_stats>(),
                ),
            ],
            &ins,
        )?;
        byte_len::<u32>(scratch as usize, 2 * n)?;
        // SAFETY: within `scratch_len >= 2 n` readable words (checked,
        // contract), not written meanwhile (contract) and by no output of
        // this call (checked).
        let order = unsafe { core::slice::from_raw_parts(scratch.add(n), n) };
        let mut sink = Sink {
            texels: out,
            width: w as usize,
            host,
            host_len,
        };
        // Validates every input before the first write.
        let st = p
            .try_finalize_rows(&e, order, rv.as_ref(), rows, &mut sink)
            .map_err(|err| {
                fail(
                    err,
                    format_args!("`cluster` or `render` is not what refl_cluster_plan gave for this G-buffer"),
                )
            })?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(st.into()) };
        Ok(())
    })
}
