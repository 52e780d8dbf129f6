//! The G-buffer and the host-ray list shared by the G-buffer passes
//! (`refl_ssr_*`, `refl_glossy_*`, `refl_planar_*`, `refl_layered_*` pass,
//! `refl_cluster_finalize_rows`): present whenever one of those families is
//! built (`mirror`, `depth-image` or `hiz`).

use crate::image::{refl_image_f32, refl_image_u8, refl_image_vec3};
use crate::ptr::check_pointer;
use crate::status::fail;
use crate::trace::{depth_image, refl_depth_image};
use crate::types::refl_vec3;
use refl_core::{Error, GBuffer, NormalSpace};

/// The space a G-buffer's normals are stored in.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_normal_space {
    /// World space.
    World = 0,
    /// View space of the G-buffer's camera (looking down -z).
    View = 1,
}

/// A deferred renderer's G-buffer. Every image must have the camera's
/// size. Optional images are absent when their `data` is NULL (their other
/// fields are then ignored).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_gbuffer {
    /// Depth, with the camera that rendered it and its convention.
    pub depth: refl_depth_image,
    /// Normals (any length; zero or non-finite marks a pixel without a
    /// usable surface).
    pub normals: refl_image_vec3,
    /// Space of `normals`, a `refl_normal_space`.
    pub normal_space: u32,
    /// Optional reflective mask: 0 = not reflective.
    pub mask: refl_image_u8,
    /// Optional per-pixel roughness in [0, 1]; pixels above
    /// `refl_ssr_options.max_roughness` (or NaN) are not traced.
    pub roughness: refl_image_f32,
    /// Optional lit color of the frame (linear RGB), read at the hits.
    pub color: refl_image_vec3,
    /// Optional back-face depth (same camera and convention as `depth`):
    /// a hit needs the ray between the front and the back depth. A back
    /// texel at the cleared value (far plane) behind a front surface makes
    /// it solid to the far plane (a one-sided floor or wall).
    pub back_depth: refl_image_f32,
}

/// A pixel's reflection ray for the host's own tracer.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_host_ray {
    /// Pixel column.
    pub x: u32,
    /// Pixel row.
    pub y: u32,
    /// The surface point (add the host tracer's own offset).
    pub origin: refl_vec3,
    /// Unit direction.
    pub dir: refl_vec3,
    /// Trace from this distance (`refl_ssr_options.t_min`).
    pub t_min: f32,
    /// Trace up to this distance (`refl_ssr_options.t_max`).
    pub t_max: f32,
    /// Why the pass did not answer: a `refl_ssr_status` from
    /// `refl_ssr_trace_rows`, a `refl_planar_status` from
    /// `refl_planar_resolve_rows`.
    pub status: u32,
}

/// The byte ranges of a G-buffer's images (for aliasing checks).
pub(crate) fn gbuffer_ranges(g: &refl_gbuffer) -> [(usize, usize); 6] {
    fn r<T>(p: *const T, len: usize) -> (usize, usize) {
        if p.is_null() {
            (0, 0)
        } else {
            (p as usize, len.saturating_mul(core::mem::size_of::<T>()))
        }
    }
    [
        r(g.depth.depth.data, g.depth.depth.len),
        r(g.normals.data, g.normals.len),
        r(g.mask.data, g.mask.len),
        r(g.roughness.data, g.roughness.len),
        r(g.color.data, g.color.len),
        r(g.back_depth.data, g.back_depth.len),
    ]
}

/// The NULL (and alignment) checks of a pass's required outputs, made
/// before any size is checked so that a NULL output is reported as
/// `REFL_STATUS_NULL_POINTER` whatever else is wrong: `out`, and `host`
/// unless it is an empty list.
pub(crate) fn required_outputs<T, H>(
    out: *mut T,
    host: *mut H,
    host_len: usize,
) -> Result<(), Error> {
    check_pointer(out.cast_const(), "out")?;
    if host_len > 0 {
        check_pointer(host.cast_const(), "host")?;
    }
    Ok(())
}

/// A refl-core G-buffer from its descriptor.
///
/// # Safety
/// Every non-NULL image `data` readable for its `len` texels for `'a` and
/// not written meanwhile.
pub(crate) unsafe fn gbuffer<'a>(g: &refl_gbuffer) -> Result<GBuffer<'a>, Error> {
    // SAFETY: caller contract.
    let depth = unsafe { depth_image(&g.depth) }?;
    let space = match g.normal_space {
        0 => NormalSpace::World,
        1 => NormalSpace::View,
        s => {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`gbuffer.normal_space` is {s}, not a refl_normal_space"),
            ))
        }
    };
    let size = |what: &str| {
        fail(
            Error::InvalidArgument,
            format_args!("`gbuffer.{what}` is not the camera's size"),
        )
    };
    // SAFETY: caller contract.
    let normals = unsafe { g.normals.view() }?;
    let mut gb = GBuffer::try_new(depth, normals, space).map_err(|_| size("normals"))?;
    if !g.mask.data.is_null() {
        // SAFETY: caller contract.
        gb = gb
            .try_with_mask(unsafe { g.mask.view() }?)
            .map_err(|_| size("mask"))?;
    }
    if !g.roughness.data.is_null() {
        // SAFETY: caller contract.
        let v = unsafe { g.roughness.view() }?;
        gb = gb.try_with_roughness(v).map_err(|_| size("roughness"))?;
    }
    if !g.color.data.is_null() {
        // SAFETY: caller contract.
        gb = gb
            .try_with_color(unsafe { g.color.view() }?)
            .map_err(|_| size("color"))?;
    }
    if !g.back_depth.data.is_null() {
        // SAFETY: caller contract.
        let v = unsafe { g.back_depth.view() }?;
        gb = gb.try_with_back_depth(v).map_err(|_| size("back_depth"))?;
    }
    Ok(gb)
}

/// Writes host ray number `index` of a call to `host[index]` if it is below
/// `host_len`; returns whether it was written.
///
/// # Safety
/// `host` non-null, aligned and writable for `host_len` entries (a size
/// that fits `isize`), or `host_len` 0.
pub(crate) unsafe fn put_host_ray(
    host: *mut refl_host_ray,
    host_len: usize,
    index: u32,
    v: refl_host_ray,
) -> bool {
    let i = index as usize;
    if i >= host_len {
        return false;
    }
    // SAFETY: `i < host_len`, writable by contract.
    unsafe { host.add(i).write(v) };
    true
}
