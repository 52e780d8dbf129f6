//! Second-order feed-forward reflections (seed 003; `refl_core::cluster`
//! documents the algorithm): normal-bin clustering, cluster cameras and the
//! per-pixel finalization against a cluster's depth image.
//!
//! Pipeline per frame: `refl_cluster_count_objects` (per row band),
//! `refl_cluster_bin_layout`, `refl_cluster_assign` (per row band),
//! `refl_cluster_ranges`; then per non-empty cluster `refl_cluster_build_camera`,
//! the host renders depth and color through the camera (geometry strictly
//! in front of the clip plane only), and `refl_cluster_finalize`. The
//! cluster pass (`refl_cluster_plan_len`, `refl_cluster_plan`,
//! `refl_cluster_finalize_rows`) does all of it from a G-buffer.
//!
//! Arrays are borrowed in place (nothing is copied or allocated); every
//! input is validated before the first output is written, so a failed call
//! leaves every output untouched, and an output array must not overlap an
//! input (`REFL_STATUS_INVALID_ARGUMENT`).

use crate::image::{refl_image_u32, refl_image_u32_mut, refl_image_vec3, refl_row_range};
use crate::ptr::{
    byte_len, no_overlap, overlaps, range, read, slice_mut, slice_mut_or_empty, slice_or_empty, Out,
};
use crate::status::{guard, refl_status};
use crate::trace::{depth_image, refl_depth_image, refl_step_options, refl_trace_thickness};
use crate::types::{
    refl_cluster_camera, refl_cluster_camera_options, refl_cluster_lobe, refl_cluster_object_bins,
    refl_cluster_options, refl_cluster_shade, refl_vec3,
};
use refl_core::cluster::{
    self, ClusterCamera, ClusterCameraOptions, ClusterInput, ClusterOptions, FinalizeInput,
};
use refl_core::{Error, ImageView, RowRange, Thickness};

/// What `refl_cluster_finalize` needs besides the cluster's pixels, camera
/// and images (`refl_core::cluster::FinalizeInput`): the depth image's
/// thickness and how to trace and weight each pixel's rays. A bundle of
/// per-call inputs, not settings with defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_cluster_finalize_input {
    /// Surface thickness of the depth image.
    pub thickness: refl_trace_thickness,
    /// Stepping options (`stride >= 1`).
    pub step: refl_step_options,
    /// Refine hits to sub-texel accuracy.
    pub refine: bool,
    /// The rays per pixel.
    pub lobe: refl_cluster_lobe,
    /// Glossy fade: a hit's weight falls from 1 on the image plane to 0 at
    /// the far plane (the missing weight is the host's diffuse color).
    pub fade: bool,
    /// Rotates each pixel's lobe samples.
    pub seed: u32,
    /// Seed 003 Sec. 4.2.2's cheaper glossy reflection: a lobe of several
    /// rays traces its mirror ray alone and takes the lobe-weighted mean of
    /// `color` over the lobe's footprint around the hit (at most 7 x 7
    /// texels). No effect on a one-ray lobe.
    pub single_ray: bool,
}

/// Checks an output array: non-null, aligned, a possible length.
fn check_out<T>(p: *mut T, count: usize) -> Result<(), Error> {
    if p.is_null() {
        return Err(Error::NullPointer);
    }
    if !p.is_aligned() {
        return Err(Error::InvalidArgument);
    }
    byte_len::<T>(p as usize, count)?;
    Ok(())
}

fn rows(r: refl_row_range, height: u32) -> Result<RowRange, Error> {
    RowRange::try_new(r.begin, r.end, height)
}

/// The seed's clustering constants (13 x 8 bins, gain 1).
#[no_mangle]
pub extern "C" fn refl_cluster_options_default() -> refl_cluster_options {
    ClusterOptions::default().into()
}

/// The default cluster camera options (D = 100, mirror, 1x resolution, at
/// most 2048 texels a side, clusters of at least 4 pixels, f <= 16).
#[no_mangle]
pub extern "C" fn refl_cluster_camera_options_default() -> refl_cluster_camera_options {
    ClusterCameraOptions::default().into()
}

/// Writes to `*out` the most clusters a frame with `objects` reflective
/// objects can have (`objects * max_theta_bins * max_phi_bins`): size the
/// `offsets` of `refl_cluster_ranges` one larger.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `options` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for invalid options or a count that does
/// not fit in `uint32_t`.
///
/// # Safety
/// `out` NULL or writable; `options` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_cluster_bins_max(
    out: *mut u32,
    objects: u32,
    options: *const refl_cluster_options,
) -> refl_status {
    guard("refl_cluster_bins_max", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let p = ClusterOptions::from(unsafe { read(options, "options") }?);
        let n = cluster::try_cluster_bins_max(objects, &p)?;
        // SAFETY: caller contract.
        unsafe { out.write(n) };
        Ok(())
    })
}

/// Adds, for every pixel of `rows` whose object id is below `counts_len`,
/// one to `counts[id]` (the screen share a_R of seed 003 Sec. 3.2). Call
/// per row band with one `counts` array per band and add them up.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `counts` (with `counts_len > 0`)
/// or `objects.data` is NULL; `REFL_STATUS_INVALID_ARGUMENT` for a bad
/// image descriptor, a row range beyond the image, or `counts` overlapping
/// the image; `REFL_STATUS_INSUFFICIENT_SIZE` if a count could overflow.
///
/// # Safety
/// `counts` NULL or readable and writable for `counts_len` values;
/// `objects.data` readable for `objects.len` values.
#[no_mangle]
pub unsafe extern "C" fn refl_cluster_count_objects(
    counts: *mut u32,
    counts_len: usize,
    objects: refl_image_u32,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_cluster_count_objects", || {
        if counts_len > 0 {
            crate::ptr::check_buffer(counts.cast_const(), counts_len, "counts")?;
        }
        // SAFETY: caller contract.
        let view = unsafe { objects.view() }?;
        let r = self::rows(rows, view.height())?;
        no_overlap(
            range(counts, counts_len),
            &[range(objects.data, objects.len)],
            "counts",
        )?;
        // SAFETY: checked above (non-null, aligned, length), readable and
        // writable by contract, disjoint from the image (checked).
        let c = unsafe { slice_mut_or_empty(counts, counts_len, "counts") }?;
        // Checks every count for overflow before the first write.
        cluster::try_count_objects(c, &view, r)
    })
}

/// Per object, the bin resolution of seed 003 Sec. 3.2 (from its pixel
/// count `counts[k]` over `frame_pixels` and the number of visible
/// objects) and its first cluster id; writes `out[k]` for every object and
/// the total number of cluster ids to `*out_total`.
///
/// Returns `REFL_STATUS_NULL_POINTER` for a NULL output, `options`, or a
/// NULL array with a non-zero length; `REFL_STATUS_INVALID_ARGUMENT` for
/// invalid options, `frame_pixels == 0`, or counts summing above it;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len < counts_len`.
///
/// # Safety
/// `out_total` NULL or writable; `out` NULL or writable for `out_len`
/// values; `counts` NULL or readable for `counts_len`; `options` NULL or
/// readable.
#[no_mangle]
pub unsafe extern "C" fn refl_cluster_bin_layout(
    out_total: *mut u32,
    out: *mut refl_cluster_object_bins,
    out_len: usize,
    counts: *const u32,
    counts_len: usize,
    frame_pixels: u64,
    options: *const refl_cluster_options,
) -> refl_status {
    guard("refl_cluster_bin_layout", || {
        let total_out = Out::new(out_total, "out_total")?;
        check_out(out, out_len)?;
        // SAFETY: caller contract.
        let c = unsafe { slice_or_empty(counts, counts_len, "counts") }?;
        // SAFETY: caller contract.
        let p = ClusterOptions::from(unsafe { read(options, "options") }?);
        if out_len < counts_len {
            return Err(Error::InsufficientSize);
        }
        no_overlap(range(out, out_len), &[range(counts, counts_len)], "out")?;
        // SAFETY: checked by check_out, writable by contract, disjoint from
        // `counts` (checked).
        let o = unsafe { slice_mut(out, out_len, "out") }?;
        // Validates everything before the first write.
        let total = cluster::try_bin_layout(o, c, frame_pixels, &p)?;
        // SAFETY: caller contract.
        unsafe { total_out.write(total) };
        Ok(())
    })
}

/// Writes the cluster id of every pixel in `rows` of `ids` (seed 003 Sec.
/// 3.2 step 4): the object's first id plus the bin of the pixel's normal,
/// `UINT32_MAX` for a pixel whose object has no bins or lies beyond
/// `layout`. Only the band's rows of `ids` are touched, so threads may fill
/// disjoint bands of one image at once.
///
/// Returns `REFL_STATUS_NULL_POINTER` for a NULL image or `layout` with a
/// non-zero length; `REFL_STATUS_INVALID_ARGUMENT` for bad descriptors,
/// images of different sizes, a row range beyond the image, `ids`
/// overlapping an input, or a clustered pixel with a non-finite or zero
/// normal; `REFL_STATUS_INSUFFICIENT_SIZE` for a short image.
///
/// # Safety
/// `ids.data` writable for its band and not accessed meanwhile; the inputs
/// readable for their `len`.
#[no_mangle]
pub unsafe extern "C" fn refl_cluster_assign(
    ids: refl_image_u32_mut,
    rows: refl_row_range,
    normals: refl_image_vec3,
    objects: refl_image_u32,
    layout: *const refl_cluster_object_bins,
    layout_len: usize,
) -> refl_status {
    guard("refl_cluster_assign", || {
        // SAFETY: caller contract.
        let lay = unsafe { slice_or_empty(layout, layout_len, "layout") }?;
        // SAFETY: caller contract.
        let (nv, ov) = unsafe { (normals.view()?, objects.view()?) };
        // SAFETY: caller contract (validates the descriptor only).
        unsafe { ids.as_const().view() }?;
        let r = self::rows(rows, ids.height)?;
        no_overlap(
            range(ids.data, ids.len),
            &[
                range(normals.data, normals.len),
                range(objects.data, objects.len),
                range(layout, layout_len),
            ],
            "ids",
        )?;
        // SAFETY: caller contract; checked descriptor, disjoint from the
        // inputs (checked). Only the band's rows are borrowed.
        let mut out = unsafe { ids.band_mut(r) }?;
        // Checks every pixel of the band before the first write.
        cluster::try_assign_clusters(&mut out, &nv, &ov, lay)
    })
}

/// Counting sort of the pixels by cluster: `order[offsets[c] ..
/// offsets[c + 1]]` are the pixel indices (y * width + x) of cluster `c`
/// in raster order, for `c < clusters`; pixels with id `UINT32_MAX` are
/// left out. Writes the number of clustered pixels to `*out_total`.
///
/// Returns `REFL_STATUS_NULL_POINTER` for a NULL output or image;
/// `REFL_STATUS_INVALID_ARGUMENT` for a bad descriptor, an id neither below
/// `clusters` nor `UINT32_MAX`, or overlapping buffers;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `offsets_len < clusters + 1` or
/// `order_len` is below the clustered pixel count.
///
/// # Safety
/// Outputs writable for their lengths; `ids.data` readable.
#[no_mangle]
pub unsafe extern "C" fn refl_cluster_ranges(
    out_total: *mut u32,
    offsets: *mut u32,
    offsets_len: usize,
    order: *mut u32,
    order_len: usize,
    ids: refl_image_u32,
    clusters: u32,
) -> refl_status {
    guard("refl_cluster_ranges", || {
        let total_out = Out::new(out_total, "out_total")?;
        check_out(offsets, offsets_len)?;
        check_out(order, order_len)?;
        // SAFETY: caller contract.
        let view = unsafe { ids.view() }?;
        let ids_bytes = ids.len.saturating_mul(4);
        let (ob, rb) = (offsets_len * 4, order_len * 4);
        if overlaps(offsets as usize, ob, order as usize, rb)
            || overlaps(offsets as usize, ob, ids.data as usize, ids_bytes)
            || overlaps(order as usize, rb, ids.data as usize, ids_bytes)
        {
            return Err(Error::InvalidArgument);
        }
        if offsets_len < clusters as usize + 1 {
            return Err(Error::InsufficientSize);
        }
        // SAFETY: checked by check_out, writable by contract, pairwise
        // disjoint and disjoint from `ids` (checked).
        let (off, ord) = unsafe {
            (
                slice_mut(offsets, offsets_len, "offsets")?,
                slice_mut(order, order_len, "order")?,
            )
        };
        // Validates every id before the first write.
        let total = cluster::try_cluster_ranges(off, ord, &view, clusters)?;
        // SAFETY: caller contract.
        unsafe { total_out.write(total) };
        Ok(())
    })
}

/// The cluster camera of seed 003 Sec. 3.3 (Eq. 1) for the pixels
/// `pixels[0 .. pixels_len]` (indices y * width + x into `positions` and
/// `normals`, e.g. one range of `refl_cluster_ranges`) seen from `eye`.
/// Writes a camera, or a fallback reason (`refl_cluster_fallback`), to
/// `*out`. Planar clusters come out with f = 1 and the camera eye exactly
/// at the mirrored eye.
///
/// Returns `REFL_STATUS_NULL_POINTER` for a NULL `out`, `options`, image, or
/// `pixels` with a non-zero count; `REFL_STATUS_INVALID_ARGUMENT` for
/// invalid options, a non-finite eye, images of different sizes, a pixel
/// outside the image, a non-finite position or a non-unit normal;
/// `REFL_STATUS_DEGENERATE_GEOMETRY` if the camera is not representable.
///
/// # Safety
/// `out` NULL or writable; inputs readable for their lengths.
#[no_mangle]
pub unsafe extern "C" fn refl_cluster_build_camera(
    out: *mut refl_cluster_camera,
    positions: refl_image_vec3,
    normals: refl_image_vec3,
    pixels: *const u32,
    pixels_len: usize,
    eye: refl_vec3,
    options: *const refl_cluster_camera_options,
) -> refl_status {
    guard("refl_cluster_build_camera", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let px = unsafe { slice_or_empty(pixels, pixels_len, "pixels") }?;
        // SAFETY: caller contract.
        let p = ClusterCameraOptions::from(unsafe { read(options, "options") }?);
        // SAFETY: caller contract.
        let input = unsafe {
            ClusterInput {
                positions: positions.view()?,
                normals: normals.view()?,
            }
        };
        let v = cluster::try_cluster_camera(&input, px, eye.into(), &p)?;
        // SAFETY: caller contract.
        unsafe { out.write(refl_cluster_camera::from_view(&v)) };
        Ok(())
    })
}

/// Writes to `*out` the half-angle (radians) of the Phong lobe cos^n that
/// holds the share `energy` of its samples: acos((1 - energy)^(1 / (n + 1))).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a negative or non-finite exponent or
/// an energy outside (0, 1).
///
/// # Safety
/// `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn refl_cluster_lobe_angle(
    out: *mut f32,
    exponent: f32,
    energy: f32,
) -> refl_status {
    guard("refl_cluster_lobe_angle", || {
        let out = Out::new(out, "out")?;
        let a = cluster::try_lobe_angle(exponent, energy)?;
        // SAFETY: caller contract.
        unsafe { out.write(a) };
        Ok(())
    })
}

/// Finalizes the reflection of the pixels `pixels[0 .. pixels_len]` of one
/// cluster (seed 003 Sec. 3.4, 3.5): each pixel's mirror ray (or lobe
/// samples) is stepped through the cluster depth image `depth` (rendered
/// through `camera->camera`) up to the far plane; hits take the bilinear
/// color of `color` over the texels of the hit surface, misses are
/// reported for the host's environment lookup. Writes `out[k]` for
/// `pixels[k]` and the number of pixels with at least one missed ray to
/// `*out_fallbacks`.
///
/// Returns `REFL_STATUS_NULL_POINTER` for a NULL pointer argument (or
/// `pixels` with a non-zero count); `REFL_STATUS_INVALID_ARGUMENT` for a
/// fallback camera record, an invalid camera, lobe, thickness or stride, a
/// color image of another size than the depth image, a non-finite eye, a
/// listed pixel outside the input or with a non-finite position or
/// non-unit normal, an unknown convention, or `out` overlapping an input;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len < pixels_len` or an image
/// is short.
///
/// # Safety
/// Outputs writable for their lengths; every input readable for its length
/// and not written during the call.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_cluster_finalize(
    out_fallbacks: *mut u32,
    out: *mut refl_cluster_shade,
    out_len: usize,
    positions: refl_image_vec3,
    normals: refl_image_vec3,
    pixels: *const u32,
    pixels_len: usize,
    eye: refl_vec3,
    camera: *const refl_cluster_camera,
    depth: *const refl_depth_image,
    color: refl_image_vec3,
    input: *const refl_cluster_finalize_input,
) -> refl_status {
    guard("refl_cluster_finalize", || {
        let fb_out = Out::new(out_fallbacks, "out_fallbacks")?;
        check_out(out, out_len)?;
        // SAFETY: caller contract.
        let px = unsafe { slice_or_empty(pixels, pixels_len, "pixels") }?;
        // SAFETY: caller contract.
        let (cam_c, depth_c, input_c) = unsafe {
            (
                read(camera, "camera")?,
                read(depth, "depth")?,
                read(input, "input")?,
            )
        };
        let cam = ClusterCamera::try_from(&cam_c)?;
        // SAFETY: caller contract.
        let di = unsafe { depth_image(&depth_c) }?;
        let thickness = if input_c.thickness.back_faces.data.is_null() {
            Thickness::Constant(input_c.thickness.constant)
        } else {
            // SAFETY: caller contract.
            Thickness::BackFaces(unsafe { input_c.thickness.back_faces.view() }?)
        };
        // SAFETY: caller contract.
        let (input, cv) = unsafe {
            (
                ClusterInput {
                    positions: positions.view()?,
                    normals: normals.view()?,
                },
                color.view()?,
            )
        };
        let inputs = [
            range(positions.data, positions.len),
            range(normals.data, normals.len),
            range(color.data, color.len),
            range(depth_c.depth.data, depth_c.depth.len),
            range(
                input_c.thickness.back_faces.data,
                input_c.thickness.back_faces.len,
            ),
            range(pixels, pixels_len),
        ];
        no_overlap(range(out, out_len), &inputs, "out")?;
        let fin = FinalizeInput {
            thickness,
            step: input_c.step.into(),
            refine: input_c.refine,
            lobe: input_c.lobe.into(),
            fade: input_c.fade,
            seed: input_c.seed,
            single_ray: input_c.single_ray,
        };
        if out_len < px.len() {
            return Err(Error::InsufficientSize);
        }
        let cv: ImageView<'_, [f32; 3]> = cv;
        // SAFETY: checked by check_out, writable by contract, disjoint from
        // every input (checked).
        let o = unsafe { slice_mut(out, out_len, "out") }?;
        // Validates every input and listed pixel before the first write.
        let fell = cluster::try_finalize_cluster(o, &input, px, eye.into(), &cam, &di, &cv, &fin)?;
        // SAFETY: caller contract.
        unsafe { fb_out.write(fell) };
        Ok(())
    })
}
