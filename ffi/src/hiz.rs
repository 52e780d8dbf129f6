//! Hi-Z min/max pyramid and hierarchical ray traversal (seed 004
//! Sec. 4.4.1, 4.4.3, 4.6.6, 4.6.7, 4.7.1; `refl_core::hiz` documents the
//! algorithm).
//!
//! The pyramid lives in one caller buffer of `refl_vec2` texels: `x` is the
//! closest and `y` the farthest linear depth under the texel (NaN: no
//! surface). `refl_hiz_len` gives its length and level count,
//! `refl_hiz_level` where each level lives.

use crate::image::refl_row_range;
use crate::ptr::{byte_len, check_buffer, overlaps, pyramid_band, range, read, Out};
use crate::status::{fail, guard, refl_status};
use crate::trace::{depth_image, refl_depth_image, refl_trace_result, refl_trace_thickness};
use crate::types::{convention, refl_camera, refl_ray, refl_vec2};
use refl_core::{Error, HiZ, HiZLayout, HiZOptions, HiZTexel, PyramidStamp, Ray, Thickness};

/// Texels after the last level of a Hi-Z pyramid that record the image
/// size and camera it was built for (counted in `refl_hiz_len`, written by
/// `refl_hiz_build` and by the `refl_hiz_build_rows` call of the last
/// level). Tracing a pyramid with a camera other than the one it was built
/// for is `REFL_STATUS_INVALID_ARGUMENT`.
pub const REFL_HIZ_STAMP_TEXELS: usize = 2;

// The header's constant is refl-core's.
const _: () = assert!(REFL_HIZ_STAMP_TEXELS == refl_core::HIZ_STAMP_TEXELS);

/// Where one pyramid level lives in the buffer: texels `offset` to
/// `offset + width * height - 1`, row by row, row stride `width`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_hiz_level_info {
    /// Index (in `refl_vec2` texels) of the level's first texel.
    pub offset: usize,
    /// Width in texels: `max(1, image_width >> level)`.
    pub width: u32,
    /// Height in texels: `max(1, image_height >> level)`.
    pub height: u32,
}

/// A built Hi-Z pyramid with the camera of its depth image.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_hiz {
    /// The pyramid built by `refl_hiz_build` (texel `x` = closest, `y` =
    /// farthest linear depth).
    pub data: *const refl_vec2,
    /// Number of texels readable from `data`, at least `refl_hiz_len`'s.
    pub len: usize,
    /// The camera of the depth image the pyramid was built from (validated
    /// on every call); its size is the pyramid's level-0 size.
    pub camera: refl_camera,
    /// Convention of the depth image, a `refl_depth_convention`; used to
    /// decode back-face images.
    pub convention: u32,
}

/// Settings of the Hi-Z traversal; `refl_hiz_options_default` gives the
/// defaults (start level 2, stop level 0, 1024 iterations, 4 prologue
/// steps).
/// Every setting returns the same first hit; they trade iterations for
/// fetches.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct refl_hiz_options {
    /// Level the hierarchical walk starts at after the prologue; clamped to
    /// the last level and raised to `stop_level` if below it.
    pub start_level: u32,
    /// Finest level of the hierarchical walk: 0 resolves hits in the
    /// hierarchy; L > 0 resolves a level-L cell by unit steps through its
    /// pixels (still exact). Clamped to the last level.
    pub stop_level: u32,
    /// Cap on hierarchical loop iterations; reaching it gives
    /// `REFL_TRACE_MISS_OUT_OF_STEPS`.
    pub max_iterations: u32,
    /// One-pixel steps before the hierarchy; `UINT32_MAX` gives plain
    /// per-pixel stepping.
    pub prologue_steps: u32,
}

impl From<refl_hiz_options> for HiZOptions {
    fn from(o: refl_hiz_options) -> Self {
        Self {
            start_level: o.start_level,
            stop_level: o.stop_level,
            max_iterations: o.max_iterations,
            prologue_steps: o.prologue_steps,
        }
    }
}

impl From<HiZOptions> for refl_hiz_options {
    fn from(o: HiZOptions) -> Self {
        Self {
            start_level: o.start_level,
            stop_level: o.stop_level,
            max_iterations: o.max_iterations,
            prologue_steps: o.prologue_steps,
        }
    }
}

/// Size query: the number of `refl_vec2` texels of the Hi-Z pyramid of a
/// `width x height` image (all levels, then `REFL_HIZ_STAMP_TEXELS`) into
/// `*out_len`, and its level count
/// (the last level is 1 x 1) into `*out_levels`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if an output is NULL,
/// `REFL_STATUS_INVALID_ARGUMENT` for a zero size or a count that does not
/// fit in `size_t`.
///
/// # Safety
/// `out_len` and `out_levels` must be NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn refl_hiz_len(
    out_len: *mut usize,
    out_levels: *mut u32,
    width: u32,
    height: u32,
) -> refl_status {
    guard("refl_hiz_len", || {
        let (ol, oc) = (
            Out::new(out_len, "out_len")?,
            Out::new(out_levels, "out_levels")?,
        );
        let l = HiZLayout::try_new(width, height)?;
        let len = refl_core::hiz::try_hiz_len(width, height)?;
        // SAFETY: caller contract.
        unsafe {
            ol.write(len);
            oc.write(l.level_count());
        }
        Ok(())
    })
}

/// Layout query: where level `level` of the pyramid of a `width x height`
/// image lives in the buffer.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL,
/// `REFL_STATUS_INVALID_ARGUMENT` for a zero or overflowing size or a
/// `level` not below the level count.
///
/// # Safety
/// `out` must be NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn refl_hiz_level(
    out: *mut refl_hiz_level_info,
    width: u32,
    height: u32,
    level: u32,
) -> refl_status {
    guard("refl_hiz_level", || {
        let out = Out::new(out, "out")?;
        let l = HiZLayout::try_new(width, height)?
            .level(level)
            .ok_or(Error::InvalidArgument)?;
        // SAFETY: caller contract.
        unsafe {
            out.write(refl_hiz_level_info {
                offset: l.offset,
                width: l.width,
                height: l.height,
            })
        };
        Ok(())
    })
}

/// The default traversal options: start level 2, stop level 0, 1024
/// iterations, 4 prologue steps.
#[no_mangle]
pub extern "C" fn refl_hiz_options_default() -> refl_hiz_options {
    HiZOptions::default().into()
}

/// `InvalidArgument` if the depth image's buffer overlaps the pyramid
/// bytes `[dst, dst + dst_bytes)`.
fn check_no_overlap(img: &refl_depth_image, dst: usize, dst_bytes: usize) -> Result<(), Error> {
    let src = img.depth.data as usize;
    let src_bytes = byte_len::<f32>(src, img.depth.len)?;
    if overlaps(src, src_bytes, dst, dst_bytes) {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

/// Builds the whole Hi-Z pyramid of `*image` into `dst` (seed 004
/// Sec. 4.4.1): level 0 is the image's linear depth (NaN, or a depth that
/// decodes to <= 0, is "no surface" and stored as NaN), each coarser texel
/// the min (`x`) and max (`y`) of the 2x2 texels below, the last column and
/// row also folding an odd leftover column/row, so every texel bounds all
/// texels under it. NaN is ignored by min/max.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `dst`, `image` or
/// `image->depth.data` is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if
/// `dst_len` is below `refl_hiz_len`'s count or the image's `len` is too
/// small; `REFL_STATUS_INVALID_ARGUMENT` for an unknown convention, a
/// misaligned pointer, a bad image size or stride, an image whose size
/// differs from the camera's, or `dst` overlapping the depth image; the
/// camera's status if it is invalid. Nothing is written on error.
///
/// # Safety
/// `dst` must be NULL or writable for `dst_len` texels; `image` NULL or
/// readable, its `depth.data` readable for `depth.len` floats and not
/// written during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_hiz_build(
    dst: *mut refl_vec2,
    dst_len: usize,
    image: *const refl_depth_image,
) -> refl_status {
    guard("refl_hiz_build", || {
        let bytes = check_buffer(dst.cast_const(), dst_len, "dst")?;
        // SAFETY: caller contract.
        let img_c = unsafe { read(image, "image") }?;
        // SAFETY: caller contract.
        let img = unsafe { depth_image(&img_c) }?;
        check_no_overlap(&img_c, dst as usize, bytes)?;
        let len = refl_core::hiz::try_hiz_len(img.width(), img.height())?;
        if dst_len < len {
            return Err(fail(
                Error::InsufficientSize,
                format_args!("`dst_len` is {dst_len}, the pyramid needs {len} (refl_hiz_len)"),
            ));
        }
        // SAFETY: non-null, aligned, writable for dst_len >= len texels
        // (caller contract), size fits isize (byte_len), disjoint from the
        // depth image (checked). refl_vec2 is [f32; 2] (types.rs).
        let s = unsafe { core::slice::from_raw_parts_mut(dst.cast::<HiZTexel>(), len) };
        refl_core::try_build_hiz(s, &img)
    })
}

/// Builds the rows `rows` of level `level` of the pyramid in
/// `dst`, for hosts that split the build across threads: build level 0
/// (from `*image`) completely, then level 1 (from level 0 in `dst`), and so
/// on; the row bands of one level may run concurrently on different
/// threads. Only the rows written and, for `level > 0`, level `level - 1`
/// (read) are touched; the call that builds the last level also writes
/// the pyramid's stamp (the texels after the last level, which record the
/// image size and camera that `refl_hiz_trace_ray` checks). The result
/// equals `refl_hiz_build`'s.
///
/// Returns as `refl_hiz_build`, plus `REFL_STATUS_INVALID_ARGUMENT` if
/// `level` is not below the level count or the rows are empty, reversed or
/// beyond the level's height.
///
/// # Safety
/// As `refl_hiz_build`; in addition no other thread may write the rows
/// this call writes or the level it reads during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_hiz_build_rows(
    dst: *mut refl_vec2,
    dst_len: usize,
    image: *const refl_depth_image,
    level: u32,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_hiz_build_rows", || {
        let bytes = check_buffer(dst.cast_const(), dst_len, "dst")?;
        // SAFETY: caller contract.
        let img_c = unsafe { read(image, "image") }?;
        // SAFETY: caller contract.
        let img = unsafe { depth_image(&img_c) }?;
        check_no_overlap(&img_c, dst as usize, bytes)?;
        let layout = HiZLayout::try_new(img.width(), img.height())?;
        let len = refl_core::hiz::try_hiz_len(img.width(), img.height())?;
        if dst_len < len {
            return Err(fail(
                Error::InsufficientSize,
                format_args!("`dst_len` is {dst_len}, the pyramid needs {len} (refl_hiz_len)"),
            ));
        }
        // SAFETY: `dst` checked above, writable by contract; the band and
        // the finer level are this call's alone (contract).
        let (out, finer, rows) =
            unsafe { pyramid_band(dst.cast::<HiZTexel>(), dst_len, &layout, level, rows) }?;
        match finer {
            None => refl_core::try_build_hiz_level0_rows(out, &img, rows),
            Some(finer) => refl_core::try_build_hiz_level_rows(out, finer, &layout, level, rows),
        }?;
        if level + 1 == layout.level_count() {
            // The last level (1 x 1, one band) is built last: stamp the
            // pyramid with its image's size and camera.
            // SAFETY: dst is writable for dst_len >= len texels (caller
            // contract); no other thread touches the pyramid while its last
            // level is built (contract), so this is the only reference.
            let all = unsafe { core::slice::from_raw_parts_mut(dst.cast::<HiZTexel>(), len) };
            refl_core::try_stamp_hiz(all, img.camera())?;
        }
        Ok(())
    })
}

/// Binds a `refl_hiz` descriptor to a core pyramid; a pyramid whose stamp
/// is not its camera's is refused with a last-error detail that says what
/// it was built for.
///
/// # Safety
/// `h.data` NULL or readable for `h.len` texels for `'a`, not written
/// meanwhile.
pub(crate) unsafe fn bind_hiz<'a>(h: &refl_hiz) -> Result<HiZ<'a>, Error> {
    check_buffer(h.data, h.len, "hiz.data")?;
    let conv = convention(h.convention)?;
    let cam = crate::types::camera_named(&h.camera, "hiz.camera")?;
    // SAFETY: non-null, aligned, readable for `len` texels (contract), size
    // fits isize (check_buffer); refl_vec2 is [f32; 2].
    let data = unsafe { core::slice::from_raw_parts(h.data.cast::<HiZTexel>(), h.len) };
    HiZ::try_new(data, cam, conv).map_err(|e| {
        let (w, hh) = (cam.width(), cam.height());
        let need = refl_core::hiz::try_hiz_len(w, hh).unwrap_or(0);
        if e == Error::InsufficientSize {
            return fail(
                e,
                format_args!("`hiz.len` is {}, a {w}x{hh} pyramid needs {need}", h.len),
            );
        }
        stamp_mismatch(e, "hiz", data, &cam, w, hh)
    })
}

/// The error `e` for a pyramid (`name`) whose stamp is not the one a
/// `w x h` frame of `cam` needs, with a last-error detail saying what the
/// pyramid was built for (its stamp where the frame's size puts it, else at
/// the end of the buffer).
pub(crate) fn stamp_mismatch<T: refl_core::PyramidTexel>(
    e: Error,
    name: &str,
    data: &[T],
    cam: &refl_core::Camera,
    w: u32,
    h: u32,
) -> Error {
    let found = PyramidStamp::read(data, w, h).or_else(|| PyramidStamp::read_tail(data));
    match found {
        Some(s) if (s.width, s.height) != (w, h) => fail(
            e,
            format_args!(
                "`{name}`: the pyramid was built for {}x{}, the camera is {w}x{h}",
                s.width, s.height
            ),
        ),
        Some(s) if s.camera != 0 && s.camera != cam.fingerprint() => fail(
            e,
            format_args!("`{name}`: the pyramid was built for another camera of the same size"),
        ),
        _ => fail(
            e,
            format_args!(
                "`{name}`: no pyramid stamp where a {w}x{h} pyramid ends (not built, or its last level not built)"
            ),
        ),
    }
}

/// Reads a pyramid descriptor, a thickness and options; also returns the
/// byte ranges of the pyramid and the back-face image.
///
/// # Safety
/// As `refl_hiz_trace_ray`.
#[allow(clippy::type_complexity)]
unsafe fn trace_inputs<'a>(
    hiz: *const refl_hiz,
    thickness: *const refl_trace_thickness,
    options: *const refl_hiz_options,
) -> Result<(HiZ<'a>, Thickness<'a>, HiZOptions, [(usize, usize); 2]), Error> {
    // SAFETY: caller contract.
    let (h, th_c, opts) = unsafe {
        (
            read(hiz, "hiz")?,
            read(thickness, "thickness")?,
            read(options, "options")?,
        )
    };
    // SAFETY: caller contract.
    let hz = unsafe { bind_hiz(&h) }?;
    // SAFETY: caller contract.
    let th = unsafe { crate::trace::thickness(&th_c) }?;
    let ranges = [
        range(h.data, h.len),
        range(th_c.back_faces.data, th_c.back_faces.len),
    ];
    Ok((hz, th, opts.into(), ranges))
}

/// Traces one ray against a Hi-Z pyramid (seed 004 Sec. 4.4.3 with the
/// extensions of Sec. 4.6.6 travel behind surfaces, 4.6.7 rays toward the
/// camera and 4.7.1 a linear prologue; `refl_core::hiz` documents the
/// algorithm): the ray `ray.origin + t * ray.dir`, `t` in `[0, t_max]`, is
/// clipped to the camera's frustum and walked in screen space over the
/// pyramid; a texel is hit where the ray's linear depth lies between its
/// front depth and front + thickness (or its back-face depth). The first
/// hit agrees with `refl_step_ray` (per-pixel stepping) within a pixel
/// wherever f32 resolves the scene to better than a pixel (the rounding
/// of the camera's and the ray's world coordinates, e.g. 0.125 at 1.6e6,
/// below a pixel's footprint at the hit's depth); both round the same
/// segment differently beyond that.
/// Writes the hit or the miss reason to `*out`.
///
/// `ray.dir` must be unit length (within 1e-3); `t_max` > 0, +infinity
/// allowed.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `hiz`, `hiz->data`,
/// `thickness` or `options` is NULL; `REFL_STATUS_INVALID_ARGUMENT` for a
/// non-finite or non-unit ray, a NaN or non-positive `t_max`, an unknown
/// convention, a misaligned pointer, a NaN or negative constant thickness,
/// or a back-face image whose size differs from the camera's;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `hiz->len` is below `refl_hiz_len`'s
/// count for the camera's size or a back-face image's `len` is too small;
/// the camera's status if it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `hiz`, `thickness` and `options` NULL
/// or readable; `hiz->data` readable for `hiz->len` texels and the
/// back-face image's `data` for its `len` floats, not written during the
/// call.
#[no_mangle]
pub unsafe extern "C" fn refl_hiz_trace_ray(
    out: *mut refl_trace_result,
    hiz: *const refl_hiz,
    thickness: *const refl_trace_thickness,
    ray: refl_ray,
    t_max: f32,
    options: *const refl_hiz_options,
) -> refl_status {
    guard("refl_hiz_trace_ray", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let (hz, th, opts, _) = unsafe { trace_inputs(hiz, thickness, options) }?;
        let ray = Ray {
            origin: ray.origin.into(),
            dir: ray.dir.into(),
        };
        let r = refl_core::try_trace_hiz(&hz, th, ray, t_max, &opts)?;
        // SAFETY: caller contract.
        unsafe { out.write(r.into()) };
        Ok(())
    })
}

/// Writes to `*out` how many rays `refl_hiz_trace_rays` walks at once on
/// this CPU: 8 where its AVX2 ray stream runs (x86-64 with AVX2, detected
/// at run time), 1 where the scalar walk runs. The results are the same
/// bits either way; this only says which loop runs (for logs and
/// benchmarks).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL.
///
/// # Safety
/// `out` must be NULL or point to a writable `uint32_t`.
#[no_mangle]
pub unsafe extern "C" fn refl_hiz_stream_lanes(out: *mut u32) -> refl_status {
    guard("refl_hiz_stream_lanes", || {
        let o = Out::new(out, "out")?;
        // SAFETY: caller contract.
        unsafe { o.write(refl_core::hiz_stream_lanes() as u32) };
        Ok(())
    })
}

/// Traces `rays_len` rays as `refl_hiz_trace_ray` would, writing result
/// `i` to `out[i]`: the arguments of `refl_hiz_trace_ray` in the same
/// order, the ray, `t_max` and the result replaced by arrays. `t_max`
/// holds one value for every ray (`t_max_len == 1`) or one per ray
/// (`t_max_len >= rays_len`).
///
/// Every input is validated before anything is written: on any error `out`
/// is untouched. Elements of `out` past `rays_len` are never written;
/// `out` must not overlap the rays, `t_max`, the pyramid or the back-face
/// image (`REFL_STATUS_INVALID_ARGUMENT`). Rays are independent: split a
/// batch into chunks and call this from several threads.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `rays`, `t_max`, `hiz`,
/// `hiz->data`, `thickness` or `options` is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len < rays_len` or `t_max_len`
/// is neither 1 nor at least `rays_len`; `REFL_STATUS_INVALID_ARGUMENT` if
/// `t_max_len` is 0, `out` overlaps an input, or for any ray, `t_max`,
/// pyramid, thickness or option rejected as by `refl_hiz_trace_ray`.
///
/// # Safety
/// `out` must be NULL or writable for `out_len` results; `rays` NULL or
/// readable for `rays_len` rays; `t_max` NULL or readable for `t_max_len`
/// floats; the rest as `refl_hiz_trace_ray`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_hiz_trace_rays(
    out: *mut refl_trace_result,
    out_len: usize,
    hiz: *const refl_hiz,
    thickness: *const refl_trace_thickness,
    rays: *const refl_ray,
    rays_len: usize,
    t_max: *const f32,
    t_max_len: usize,
    options: *const refl_hiz_options,
) -> refl_status {
    guard("refl_hiz_trace_rays", || {
        crate::ptr::no_nulls(&[
            (out.is_null(), "out"),
            (rays.is_null(), "rays"),
            (t_max.is_null(), "t_max"),
        ])?;
        // SAFETY: caller contract.
        let (hz, th, opts, inputs) = unsafe { trace_inputs(hiz, thickness, options) }?;
        // SAFETY: caller contract.
        let (out, rays, t_max) = unsafe {
            crate::trace::batch_arrays(out, out_len, rays, rays_len, t_max, t_max_len, inputs)
        }?;
        // Validates every ray before the first write: `out` is untouched
        // on error.
        refl_core::try_trace_hiz_rays(out, &hz, th, rays, t_max, &opts)
    })
}
