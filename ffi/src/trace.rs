//! Ray / depth-image intersection: the C types shared by the depth-image
//! kernels (a depth image with its camera, surface thickness, the result of
//! one traced ray) and the per-pixel stepping exports (seed 003 Sec. 3.4).
//!
//! Results follow refl-core's `Trace`: a hit carries its sub-pixel position,
//! ray parameter, depths and work counters; a miss says why
//! (`refl_trace_miss`), never a sentinel NaN.

use crate::image::refl_image_f32;
use crate::ptr::{byte_len, no_overlap, range, read, slice, slice_mut, Out};
use crate::status::{guard, refl_status};
use crate::types::{convention, refl_camera, refl_ray, refl_vec2};
#[cfg(feature = "depth-image")]
use refl_core::StepOptions;
use refl_core::{DepthImage, Error, Miss, Ray, Thickness, Trace};

/// A depth image with the camera that rendered it and its convention.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_depth_image {
    /// The stored depths; width and height must equal the camera's. Texel
    /// (x, y) holds the depth seen through pixel center (x + 0.5, y + 0.5).
    /// A NaN texel, or one at or beyond the far plane, holds no surface.
    pub depth: refl_image_f32,
    /// The camera that rendered the image (validated on every call).
    pub camera: refl_camera,
    /// Convention of the stored depths, a `refl_depth_convention`.
    pub convention: u32,
}

/// How far behind the front-most surface a ray may pass and still hit it.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_trace_thickness {
    /// Thickness of every surface in linear depth (world units along the
    /// view axis), >= 0, may be +infinity (everything behind a surface is
    /// solid). Used when `back_faces.data` is NULL, ignored otherwise.
    pub constant: f32,
    /// A back-face depth image (same size, camera and convention as the
    /// front image): the ray hits where its depth lies between the two. Set
    /// `data` to NULL to use `constant` instead (the other fields are then
    /// ignored).
    pub back_faces: refl_image_f32,
}

/// Why a traced ray found no surface; `REFL_TRACE_MISS_NONE` for a hit.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum refl_trace_miss {
    /// The ray hit the depth image.
    None = 0,
    /// The projected ray left the image rectangle (or, coming toward the
    /// camera, the near plane) before hitting anything.
    LeftImage = 1,
    /// The walk ended while the ray was behind geometry deeper than its
    /// thickness: what it hits is hidden from this image.
    BehindGeometry = 2,
    /// The step or iteration cap was reached.
    OutOfSteps = 3,
    /// The ray ended (`t_max`, the far plane, or its vanishing point under
    /// an infinite far plane) in front of every surface.
    EndOfRay = 4,
    /// Nothing of the ray projects into the view (entirely behind the near
    /// plane, beyond the far plane, or outside the image's frustum).
    DegenerateProjection = 5,
}

impl From<Miss> for refl_trace_miss {
    fn from(m: Miss) -> Self {
        match m {
            Miss::LeftImage => Self::LeftImage,
            Miss::BehindGeometry => Self::BehindGeometry,
            Miss::OutOfSteps => Self::OutOfSteps,
            Miss::EndOfRay => Self::EndOfRay,
            Miss::DegenerateProjection => Self::DegenerateProjection,
        }
    }
}

/// The result of tracing one ray against a depth image.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_trace_result {
    /// `REFL_TRACE_MISS_NONE` (0) for a hit, otherwise the `refl_trace_miss` reason.
    pub miss: u32,
    /// Sub-pixel position of the hit in the depth image (pixels, origin
    /// top-left); the texel hit is (floor(x), floor(y)). 0 on a miss.
    pub pixel: refl_vec2,
    /// Ray parameter of the hit (world distance from the origin); the point
    /// origin + t * dir projects to `pixel` up to rounding. 0 on a miss.
    pub t: f32,
    /// Linear depth of the hit point on the ray. 0 on a miss.
    pub depth: f32,
    /// Linear depth stored in the image at the texel hit. 0 on a miss.
    pub surface_depth: f32,
    /// Pixel (or cell) steps along the projected ray, hit or miss.
    pub steps: u32,
    /// Depth texels read (back-face and pyramid texels included).
    pub fetches: u32,
    /// Loop iterations of a hierarchical traversal (0 for stepping).
    pub iterations: u32,
}

impl From<Trace> for refl_trace_result {
    fn from(t: Trace) -> Self {
        let w = t.work();
        let base = Self {
            steps: w.steps,
            fetches: w.fetches,
            iterations: w.iterations,
            ..Self::default()
        };
        match t {
            Trace::Hit(h) => Self {
                miss: refl_trace_miss::None as u32,
                pixel: h.pixel.into(),
                t: h.t,
                depth: h.depth,
                surface_depth: h.surface_depth,
                ..base
            },
            Trace::Miss { reason, .. } => Self {
                miss: refl_trace_miss::from(reason) as u32,
                ..base
            },
        }
    }
}

/// Options of the per-pixel stepping kernel (`refl_step_ray`);
/// `refl_step_options_default` gives the defaults (`stride = 1`,
/// `max_steps = UINT32_MAX`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg(feature = "depth-image")]
pub struct refl_step_options {
    /// Texels per coarse step, >= 1. 1 tests every texel the ray's
    /// projection touches; larger strides sample every `stride`-th texel and
    /// refine the last coarse interval texel by texel once the ray reaches
    /// behind a surface.
    pub stride: u32,
    /// The most steps (coarse plus refinement) spent on one ray; reaching it
    /// gives `REFL_TRACE_MISS_OUT_OF_STEPS`. 0 allows none.
    pub max_steps: u32,
}

/// The stepping defaults: `stride = 1`, `max_steps = UINT32_MAX` (the walk
/// is still bounded by the `width + height` texels a segment can touch).
#[no_mangle]
#[cfg(feature = "depth-image")]
pub extern "C" fn refl_step_options_default() -> refl_step_options {
    StepOptions::default().into()
}

#[cfg(feature = "depth-image")]
impl From<StepOptions> for refl_step_options {
    fn from(o: StepOptions) -> Self {
        Self {
            stride: o.stride,
            max_steps: o.max_steps,
        }
    }
}

#[cfg(feature = "depth-image")]
impl From<refl_step_options> for StepOptions {
    fn from(o: refl_step_options) -> Self {
        Self {
            stride: o.stride,
            max_steps: o.max_steps,
        }
    }
}

/// A refl-core depth image from its C descriptor: the camera, the
/// convention and the depth view are validated.
///
/// # Safety
/// `d.depth.data` must be NULL or readable for `d.depth.len` floats for
/// `'a`, and not be written meanwhile.
pub(crate) unsafe fn depth_image<'a>(d: &refl_depth_image) -> Result<DepthImage<'a>, Error> {
    // SAFETY: caller contract.
    let view = unsafe { d.depth.view() }?;
    let conv = convention(d.convention)?;
    let cam = crate::types::camera_named(&d.camera, "image.camera")?;
    DepthImage::try_new(view, cam, conv)
}

/// A refl-core thickness from its C descriptor (validated by the kernels:
/// a negative or NaN constant, a back-face image of another size).
///
/// # Safety
/// `t.back_faces.data` must be NULL or readable for `t.back_faces.len`
/// floats for `'a`, and not be written meanwhile.
pub(crate) unsafe fn thickness<'a>(t: &refl_trace_thickness) -> Result<Thickness<'a>, Error> {
    if t.back_faces.data.is_null() {
        Ok(Thickness::Constant(t.constant))
    } else {
        // SAFETY: caller contract.
        Ok(Thickness::BackFaces(unsafe { t.back_faces.view() }?))
    }
}

/// The byte ranges of the caller memory a depth image and a thickness
/// read (the stated `len` of each image; a NULL back-face image is empty).
pub(crate) fn depth_ranges(
    img: &refl_depth_image,
    th: &refl_trace_thickness,
) -> [(usize, usize); 2] {
    [
        range(img.depth.data, img.depth.len),
        range(th.back_faces.data, th.back_faces.len),
    ]
}

#[cfg(feature = "depth-image")]
/// Reads the three by-pointer inputs shared by the stepping exports; also
/// returns the byte ranges the image and thickness read.
///
/// # Safety
/// As `refl_step_ray`.
#[allow(clippy::type_complexity)]
unsafe fn step_inputs<'a>(
    image: *const refl_depth_image,
    thickness: *const refl_trace_thickness,
    options: *const refl_step_options,
) -> Result<
    (
        DepthImage<'a>,
        Thickness<'a>,
        StepOptions,
        [(usize, usize); 2],
    ),
    Error,
> {
    // SAFETY: caller contract.
    let (img_c, th_c, opts) = unsafe {
        (
            read(image, "image")?,
            read(thickness, "thickness")?,
            read(options, "options")?,
        )
    };
    // SAFETY: caller contract.
    let img = unsafe { depth_image(&img_c) }?;
    // SAFETY: caller contract.
    let th = unsafe { self::thickness(&th_c) }?;
    Ok((img, th, opts.into(), depth_ranges(&img_c, &th_c)))
}

/// Traces one ray against a depth image by per-pixel stepping along its
/// projection (seed 003 Sec. 3.4; `refl_core::step` documents the
/// algorithm): the ray `ray.origin + t * ray.dir`, `t` in `[0, t_max]`, is
/// clipped to the camera's frustum, projected, and walked texel by texel
/// from its near to its far end; a texel is hit where the ray's linear
/// depth lies between its front depth and front + thickness (or its
/// back-face depth). A ray through the camera's eye (a planar reflector's
/// ray) is resolved with one lookup. Writes the hit or the miss reason to
/// `*out`.
///
/// `ray.dir` must be unit length (within 1e-3); `t_max` > 0, +infinity
/// allowed (up to the far plane).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `image`, `image->depth.data`,
/// `thickness` or `options` is NULL; `REFL_STATUS_INVALID_ARGUMENT` for a
/// non-finite or non-unit ray, a NaN or non-positive `t_max`, an unknown
/// convention, a misaligned pointer, a zero or overflowing image size,
/// `stride < width`, an image or back-face image whose size differs from
/// the camera's, a NaN or negative constant thickness, or `stride == 0`;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if an image's `len` is too small; the
/// camera's status if it is invalid.
///
/// # Safety
/// `out` must be NULL or writable; `image`, `thickness` and `options` NULL
/// or readable; the images' `data` readable for `len` floats and not
/// written during the call.
#[no_mangle]
#[cfg(feature = "depth-image")]
pub unsafe extern "C" fn refl_step_ray(
    out: *mut refl_trace_result,
    image: *const refl_depth_image,
    thickness: *const refl_trace_thickness,
    ray: refl_ray,
    t_max: f32,
    options: *const refl_step_options,
) -> refl_status {
    guard("refl_step_ray", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let (img, th, opts, _) = unsafe { step_inputs(image, thickness, options) }?;
        let ray = Ray {
            origin: ray.origin.into(),
            dir: ray.dir.into(),
        };
        let r = refl_core::try_step(&img, th, ray, t_max, opts)?;
        // SAFETY: caller contract.
        unsafe { out.write(r.into()) };
        Ok(())
    })
}

/// Traces `rays_len` rays as `refl_step_ray` would, writing result `i` to
/// `out[i]`: the arguments of `refl_step_ray` in the same order, the ray,
/// `t_max` and the result replaced by arrays. `t_max` holds either one
/// value for every ray (`t_max_len == 1`) or one per ray
/// (`t_max_len >= rays_len`).
///
/// Every input is validated before anything is written: on any error
/// `out` is untouched. Elements of `out` past `rays_len` are never
/// written; `out` must not overlap the rays, `t_max` or the images
/// (`REFL_STATUS_INVALID_ARGUMENT`). Rays are independent: a host splits a
/// large batch into chunks (e.g. rows of a reflection buffer) and calls
/// this from its own threads.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `rays`, `t_max`, `image`,
/// `image->depth.data`, `thickness` or `options` is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len < rays_len` or `t_max_len`
/// is neither 1 nor at least `rays_len`; `REFL_STATUS_INVALID_ARGUMENT` if
/// `t_max_len` is 0, `out` overlaps an input, or for any ray, `t_max`,
/// image, thickness or option rejected as by `refl_step_ray`.
///
/// # Safety
/// `out` must be NULL or writable for `out_len` results; `rays` NULL or
/// readable for `rays_len` rays; `t_max` NULL or readable for `t_max_len`
/// floats; the rest as `refl_step_ray`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
#[cfg(feature = "depth-image")]
pub unsafe extern "C" fn refl_step_rays(
    out: *mut refl_trace_result,
    out_len: usize,
    image: *const refl_depth_image,
    thickness: *const refl_trace_thickness,
    rays: *const refl_ray,
    rays_len: usize,
    t_max: *const f32,
    t_max_len: usize,
    options: *const refl_step_options,
) -> refl_status {
    guard("refl_step_rays", || {
        crate::ptr::no_nulls(&[
            (out.is_null(), "out"),
            (rays.is_null(), "rays"),
            (t_max.is_null(), "t_max"),
        ])?;
        // SAFETY: caller contract.
        let (img, th, opts, inputs) = unsafe { step_inputs(image, thickness, options) }?;
        // SAFETY: caller contract.
        let (out, rays, t_max) =
            unsafe { batch_arrays(out, out_len, rays, rays_len, t_max, t_max_len, inputs) }?;
        // Validates every ray before the first write: `out` is untouched
        // on error.
        refl_core::try_step_rays(out, &img, th, rays, t_max, opts)
    })
}

/// The three arrays of a batch trace (`refl_step_rays`,
/// `refl_hiz_trace_rays`) after their checks: `out` aligned and long
/// enough, `t_max` one value or one per ray, and `out` overlapping neither
/// the rays, `t_max` nor the `inputs` byte ranges (the images read).
///
/// # Safety
/// As `refl_step_rays`; the pointers are non-NULL.
#[allow(clippy::type_complexity)]
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub(crate) unsafe fn batch_arrays<'a>(
    out: *mut refl_trace_result,
    out_len: usize,
    rays: *const refl_ray,
    rays_len: usize,
    t_max: *const f32,
    t_max_len: usize,
    inputs: [(usize, usize); 2],
) -> Result<(&'a mut [refl_trace_result], &'a [refl_ray], &'a [f32]), Error> {
    if !out.is_aligned() || t_max_len == 0 {
        return Err(Error::InvalidArgument);
    }
    if out_len < rays_len || (t_max_len != 1 && t_max_len < rays_len) {
        return Err(Error::InsufficientSize);
    }
    let out_bytes = byte_len::<refl_trace_result>(out as usize, rays_len)?;
    let t_len = t_max_len.min(rays_len).max(1);
    // SAFETY: caller contract; `out` overlaps neither (checked below before
    // it is borrowed).
    let (r, t) = unsafe {
        (
            slice(rays, rays_len, "rays")?,
            slice(t_max, t_len, "t_max")?,
        )
    };
    no_overlap(
        (out as usize, out_bytes),
        &[
            range(rays, rays_len),
            range(t_max, t_len),
            inputs[0],
            inputs[1],
        ],
        "out",
    )?;
    // SAFETY: non-null, aligned, writable for out_len >= rays_len results
    // (caller contract), disjoint from every input (checked).
    let o = unsafe { slice_mut(out, rays_len, "out") }?;
    Ok((o, r, t))
}

/// Refines a hit of `refl_step_ray` / `refl_hiz_trace_ray` to sub-texel
/// accuracy (`refl_core::trace::refine_hit`): the ray is intersected with
/// the plane through the hit texel's center point and its coplanar (or
/// continuous) neighbors, never across a silhouette; where that plane is
/// met outside the 3x3 texels around the texel, the fit moves there (up to
/// 4 fits). On a surface seen at a grazing angle this moves the hit from
/// the first texel plate the ray meets to the surface itself. The refined
/// `pixel`, `t` and `depth` replace the hit's if the point lies on the ray
/// within `[0, t_max]`; otherwise, and for a miss (`hit->miss != 0`),
/// `*out` is `*hit`. `fetches` counts the extra texels read.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `image`,
/// `image->depth.data` or `hit` is NULL; `REFL_STATUS_INVALID_ARGUMENT` for
/// a non-finite or non-unit ray, a NaN or non-positive `t_max`, a hit with
/// an unknown miss value or non-finite fields, or an invalid image (as
/// `refl_step_ray`); `REFL_STATUS_INSUFFICIENT_SIZE` for a short image.
///
/// # Safety
/// `out` NULL or writable; `image` and `hit` NULL or readable; the image's
/// `data` readable for `len` floats and not written during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_trace_refine_hit(
    out: *mut refl_trace_result,
    image: *const refl_depth_image,
    ray: refl_ray,
    t_max: f32,
    hit: *const refl_trace_result,
) -> refl_status {
    guard("refl_trace_refine_hit", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let (img_c, h) = unsafe { (read(image, "image")?, read(hit, "hit")?) };
        // SAFETY: caller contract.
        let img = unsafe { depth_image(&img_c) }?;
        let ray = Ray {
            origin: ray.origin.into(),
            dir: ray.dir.into(),
        };
        refl_core::trace::try_validate_ray(&ray, t_max)?;
        if h.miss > refl_trace_miss::DegenerateProjection as u32
            || !(h.pixel.x.is_finite()
                && h.pixel.y.is_finite()
                && h.t.is_finite()
                && h.depth.is_finite()
                && h.surface_depth.is_finite())
        {
            return Err(Error::InvalidArgument);
        }
        let result = if h.miss == refl_trace_miss::None as u32 {
            let core_hit = refl_core::DepthHit {
                pixel: refl_core::glam::Vec2::new(h.pixel.x, h.pixel.y),
                t: h.t,
                depth: h.depth,
                surface_depth: h.surface_depth,
                work: refl_core::Work {
                    steps: h.steps,
                    fetches: h.fetches,
                    iterations: h.iterations,
                },
            };
            refl_trace_result::from(refl_core::Trace::Hit(refl_core::trace::refine_hit(
                &img, &ray, t_max, &core_hit,
            )))
        } else {
            h
        };
        // SAFETY: caller contract.
        unsafe { out.write(result) };
        Ok(())
    })
}
