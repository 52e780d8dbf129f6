//! Glossy cone tracing (seed 004 Sec. 4.4.2, 4.4.4, 4.4.5, 4.6.1, 4.6.8)
//! and the multi-ray alternative (seed 003 Sec. 3.5); `refl_core::cone`
//! documents the algorithm.
//!
//! The color pyramid is one caller buffer of `refl_vec3` texels, the
//! visibility pyramid one of floats; both have the Hi-Z pyramid's layout
//! (`refl_hiz_level`) and `refl_cone_pyramid_len` texels.

use crate::hiz::refl_hiz;
use crate::hiz::{bind_hiz, stamp_mismatch};
use crate::image::{refl_image_vec3, refl_row_range};
use crate::ptr::{byte_len, check_buffer, overlaps, pyramid_band, read, Out};
use crate::status::{fail, fail_str, guard, refl_status};
use crate::trace::refl_trace_thickness;
use crate::types::{
    refl_cone, refl_cone_fades, refl_cone_multiray_options, refl_cone_multiray_result,
    refl_cone_options, refl_cone_result, refl_ray, refl_vec2, refl_vec3,
};
use refl_core::cone::{
    try_build_color_level0_rows, try_build_color_level_rows, try_build_visibility_level0_rows,
    try_build_visibility_level_rows, Cone, ConeOptions, ConePyramids, FadeRange, Fades,
    MultiRayOptions,
};
use refl_core::{ColorTexel, Error, HiZLayout, Ray};

/// The cone pyramids of one frame, bound together.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_cone_pyramids {
    /// The frame's Hi-Z pyramid and camera.
    pub hiz: refl_hiz,
    /// The color pyramid (`refl_cone_build_color`).
    pub color: *const refl_vec3,
    /// Texels readable from `color`, at least `refl_cone_pyramid_len`'s
    /// `out_color_len`.
    pub color_len: usize,
    /// The visibility pyramid (`refl_cone_build_visibility`), or NULL with
    /// `visibility_len` 0 for none (enough for `refl_cone_multiray` and for
    /// `refl_cone_trace` with `use_visibility` off; with it on the trace is
    /// `REFL_STATUS_INVALID_ARGUMENT`).
    pub visibility: *const f32,
    /// Floats readable from `visibility`, at least `refl_cone_pyramid_len`'s
    /// `out_visibility_len` (or 0 with a NULL `visibility`).
    pub visibility_len: usize,
}

/// Binds a `refl_cone_pyramids` descriptor.
///
/// # Safety
/// Every buffer NULL or readable for its length for `'a`, not written
/// meanwhile.
unsafe fn bind_pyramids<'a>(p: &refl_cone_pyramids) -> Result<ConePyramids<'a>, Error> {
    check_buffer(p.color, p.color_len, "pyramids.color")?;
    // NULL with length 0: no visibility pyramid (multi-ray, or a cone
    // trace with use_visibility off).
    let no_vis = p.visibility.is_null() && p.visibility_len == 0;
    if !no_vis {
        check_buffer(p.visibility, p.visibility_len, "pyramids.visibility")?;
    }
    // SAFETY: caller contract.
    let hz = unsafe { bind_hiz(&p.hiz) }?;
    // SAFETY: non-null, aligned, readable (contract), sizes fit isize
    // (check); refl_vec3 is [f32; 3].
    let (color, vis) = unsafe {
        (
            core::slice::from_raw_parts(p.color.cast::<ColorTexel>(), p.color_len),
            if no_vis {
                &[][..]
            } else {
                core::slice::from_raw_parts(p.visibility, p.visibility_len)
            },
        )
    };
    ConePyramids::try_new(hz, color, vis).map_err(|e| {
        let cam = *hz.camera();
        let (w, h) = (cam.width(), cam.height());
        if e == Error::InsufficientSize {
            return fail_str(
                e,
                "`pyramids.color_len` or `pyramids.visibility_len` below refl_cone_pyramid_len's",
            );
        }
        if refl_core::PyramidStamp::read(color, w, h)
            != Some(refl_core::PyramidStamp::of_size(w, h))
        {
            stamp_mismatch(e, "pyramids.color", color, &cam, w, h)
        } else {
            stamp_mismatch(e, "pyramids.visibility", vis, &cam, w, h)
        }
    })
}

/// The cone half-angle for a Phong specular power (seed 004 Eq. 4.1 with
/// the acos erratum, xi = 0.244; powers 1024..2048 blend to 0, +infinity
/// gives 0) into `*out`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL,
/// `REFL_STATUS_INVALID_ARGUMENT` for a NaN or negative power.
///
/// # Safety
/// `out` must be NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn refl_cone_angle_from_phong(out: *mut f32, power: f32) -> refl_status {
    guard("refl_cone_angle_from_phong", || {
        let out = Out::new(out, "out")?;
        let t = refl_core::try_cone_angle_from_phong(power)?;
        // SAFETY: caller contract.
        unsafe { out.write(t) };
        Ok(())
    })
}

/// The cone half-angle for a perceptual roughness in [0, 1] (Phong power
/// `2 / r^4 - 2`, `refl_core::lobe::try_phong_power_from_roughness`) into
/// `*out`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL,
/// `REFL_STATUS_INVALID_ARGUMENT` for NaN or a roughness outside [0, 1].
///
/// # Safety
/// `out` must be NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn refl_cone_angle_from_roughness(
    out: *mut f32,
    roughness: f32,
) -> refl_status {
    guard("refl_cone_angle_from_roughness", || {
        let out = Out::new(out, "out")?;
        let t = refl_core::try_cone_angle_from_roughness(roughness)?;
        // SAFETY: caller contract.
        unsafe { out.write(t) };
        Ok(())
    })
}

/// Size query: texels of the color pyramid (`refl_vec3`) into
/// `*out_color_len` and floats of the visibility pyramid into
/// `*out_visibility_len`, for a `width x height` frame. Both are the Hi-Z
/// layout's levels (`refl_hiz_level`) followed by the pyramid's stamp
/// (`REFL_CONE_COLOR_STAMP_TEXELS` texels, `REFL_CONE_VISIBILITY_STAMP_LEN`
/// floats), which records the size (and, for visibility, the Hi-Z's
/// camera) that `refl_cone_trace` checks.
///
/// Returns `REFL_STATUS_NULL_POINTER` if an output is NULL,
/// `REFL_STATUS_INVALID_ARGUMENT` for a zero or overflowing size.
///
/// # Safety
/// `out_color_len` and `out_visibility_len` must be NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn refl_cone_pyramid_len(
    out_color_len: *mut usize,
    out_visibility_len: *mut usize,
    width: u32,
    height: u32,
) -> refl_status {
    guard("refl_cone_pyramid_len", || {
        let oc = Out::new(out_color_len, "out_color_len")?;
        let ov = Out::new(out_visibility_len, "out_visibility_len")?;
        let c = refl_core::try_color_pyramid_len(width, height)?;
        let v = refl_core::try_visibility_pyramid_len(width, height)?;
        // SAFETY: caller contract.
        unsafe {
            oc.write(c);
            ov.write(v);
        }
        Ok(())
    })
}

/// Texels after the color pyramid's last level that hold its stamp.
pub const REFL_CONE_COLOR_STAMP_TEXELS: usize = 2;
/// Floats after the visibility pyramid's last level that hold its stamp.
pub const REFL_CONE_VISIBILITY_STAMP_LEN: usize = 4;
// The header's constants are refl-core's.
const _: () = assert!(
    REFL_CONE_COLOR_STAMP_TEXELS == refl_core::COLOR_STAMP_TEXELS
        && REFL_CONE_VISIBILITY_STAMP_LEN == refl_core::VISIBILITY_STAMP_LEN
);

/// Builds the rows `rows` of level `level` of the color
/// pyramid of `*image` in `dst` (level 0 copies the image; level L blurs
/// level L - 1 with a normalized Gaussian of standard deviation `sigma`
/// finer texels and halves it). Build level by level; row bands of one
/// level may run on different threads.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `dst`, `image` or its data is
/// NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if `dst_len` is below
/// `refl_cone_pyramid_len` or the image is short;
/// `REFL_STATUS_INVALID_ARGUMENT` for a bad image, a non-finite texel, a
/// `sigma` not finite and positive, a level or row range out of bounds, a
/// misaligned pointer, or `dst` overlapping the image. Nothing is written
/// on error.
///
/// # Safety
/// `dst` NULL or writable for `dst_len` texels; `image` NULL or readable,
/// its data readable for `len` texels; no other thread writes the rows
/// written or the level read.
#[no_mangle]
pub unsafe extern "C" fn refl_cone_build_color_rows(
    dst: *mut refl_vec3,
    dst_len: usize,
    image: *const refl_image_vec3,
    level: u32,
    rows: refl_row_range,
    sigma: f32,
) -> refl_status {
    guard("refl_cone_build_color_rows", || {
        let bytes = check_buffer(dst.cast_const(), dst_len, "dst")?;
        // SAFETY: caller contract.
        let img_c = unsafe { read(image, "image") }?;
        // SAFETY: caller contract.
        let view = unsafe { img_c.view() }?;
        let src_bytes = byte_len::<refl_vec3>(img_c.data as usize, img_c.len)?;
        if overlaps(img_c.data as usize, src_bytes, dst as usize, bytes) {
            return Err(Error::InvalidArgument);
        }
        if !(sigma > 0.0 && sigma.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        let layout = HiZLayout::try_new(view.width(), view.height())?;
        let len = refl_core::try_color_pyramid_len(view.width(), view.height())?;
        if dst_len < len {
            return Err(fail(
                Error::InsufficientSize,
                format_args!("`dst_len` is {dst_len}, the color pyramid needs {len}"),
            ));
        }
        // SAFETY: `dst` checked above, writable by contract; the band and
        // the finer level are this call's alone (contract).
        let (out, finer, rows) =
            unsafe { pyramid_band(dst.cast::<ColorTexel>(), dst_len, &layout, level, rows) }?;
        match finer {
            None => try_build_color_level0_rows(out, &view, rows),
            Some(finer) => try_build_color_level_rows(out, finer, &layout, level, rows, sigma),
        }?;
        if level + 1 == layout.level_count() {
            // SAFETY: dst writable for dst_len >= len texels (contract); no
            // other thread touches the pyramid while its last level is
            // built (contract).
            let all = unsafe { core::slice::from_raw_parts_mut(dst.cast::<ColorTexel>(), len) };
            refl_core::try_stamp_color_pyramid(all, view.width(), view.height())?;
        }
        Ok(())
    })
}

/// Builds the whole color pyramid of `*image` into `dst` (seed 004
/// Sec. 4.4.4 / 4.5.4), as `refl_cone_build_color_rows` level by level.
/// Every texel is validated first: nothing is written on error.
///
/// Returns as `refl_cone_build_color_rows`.
///
/// # Safety
/// As `refl_cone_build_color_rows`.
#[no_mangle]
pub unsafe extern "C" fn refl_cone_build_color(
    dst: *mut refl_vec3,
    dst_len: usize,
    image: *const refl_image_vec3,
    sigma: f32,
) -> refl_status {
    guard("refl_cone_build_color", || {
        let bytes = check_buffer(dst.cast_const(), dst_len, "dst")?;
        // SAFETY: caller contract.
        let img_c = unsafe { read(image, "image") }?;
        // SAFETY: caller contract.
        let view = unsafe { img_c.view() }?;
        let src_bytes = byte_len::<refl_vec3>(img_c.data as usize, img_c.len)?;
        if overlaps(img_c.data as usize, src_bytes, dst as usize, bytes) {
            return Err(Error::InvalidArgument);
        }
        let n = refl_core::try_color_pyramid_len(view.width(), view.height())?;
        if dst_len < n {
            return Err(Error::InsufficientSize);
        }
        // SAFETY: non-null, aligned, writable for dst_len >= n texels
        // (contract), disjoint from the image (checked).
        let s = unsafe { core::slice::from_raw_parts_mut(dst.cast::<ColorTexel>(), n) };
        refl_core::try_build_color_pyramid(s, &view, sigma)
    })
}

/// Builds the rows `rows` of level `level` of the visibility
/// pyramid of `*hiz` in `dst` (level 0: 1 where a foreground surface is,
/// 0 elsewhere; level L from level L - 1 and the Hi-Z, seed 004
/// Sec. 4.4.2 / Listing 4.4 as `refl_core::cone` reads it). Build level by
/// level; row bands of one level may run on different threads.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `dst`, `hiz` or its data is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `dst_len` or the pyramid is short;
/// `REFL_STATUS_INVALID_ARGUMENT` for an unknown convention, a level or row
/// range out of bounds, a misaligned pointer, or `dst` overlapping the
/// Hi-Z; the camera's status if it is invalid. Nothing is written on
/// error.
///
/// # Safety
/// `dst` NULL or writable for `dst_len` floats; `hiz` NULL or readable,
/// its data readable for `len` texels; no other thread writes the rows
/// written or the level read.
#[no_mangle]
pub unsafe extern "C" fn refl_cone_build_visibility_rows(
    dst: *mut f32,
    dst_len: usize,
    hiz: *const refl_hiz,
    level: u32,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_cone_build_visibility_rows", || {
        let bytes = check_buffer(dst.cast_const(), dst_len, "dst")?;
        // SAFETY: caller contract.
        let h = unsafe { read(hiz, "hiz") }?;
        // SAFETY: caller contract.
        let hz = unsafe { bind_hiz(&h) }?;
        let hb = byte_len::<refl_vec2>(h.data as usize, h.len)?;
        if overlaps(h.data as usize, hb, dst as usize, bytes) {
            return Err(Error::InvalidArgument);
        }
        let layout = *hz.layout();
        let len = refl_core::try_visibility_pyramid_len(layout.width(), layout.height())?;
        if dst_len < len {
            return Err(fail(
                Error::InsufficientSize,
                format_args!("`dst_len` is {dst_len}, the visibility pyramid needs {len}"),
            ));
        }
        // SAFETY: `dst` checked above, writable by contract; the band and
        // the finer level are this call's alone (contract).
        let (out, finer, rows) = unsafe { pyramid_band(dst, dst_len, &layout, level, rows) }?;
        match finer {
            None => try_build_visibility_level0_rows(out, &hz, rows),
            Some(finer) => try_build_visibility_level_rows(out, finer, &hz, level, rows),
        }?;
        if level + 1 == layout.level_count() {
            // SAFETY: dst writable for dst_len >= len floats (contract),
            // disjoint from the Hi-Z (checked); no other thread touches the
            // pyramid while its last level is built (contract).
            let all = unsafe { core::slice::from_raw_parts_mut(dst, len) };
            refl_core::try_stamp_visibility_pyramid(all, &hz)?;
        }
        Ok(())
    })
}

/// Builds the whole visibility pyramid of `*hiz` into `dst`.
///
/// Returns as `refl_cone_build_visibility_rows`.
///
/// # Safety
/// As `refl_cone_build_visibility_rows`.
#[no_mangle]
pub unsafe extern "C" fn refl_cone_build_visibility(
    dst: *mut f32,
    dst_len: usize,
    hiz: *const refl_hiz,
) -> refl_status {
    guard("refl_cone_build_visibility", || {
        let bytes = check_buffer(dst.cast_const(), dst_len, "dst")?;
        // SAFETY: caller contract.
        let h = unsafe { read(hiz, "hiz") }?;
        // SAFETY: caller contract.
        let hz = unsafe { bind_hiz(&h) }?;
        let hb = byte_len::<refl_vec2>(h.data as usize, h.len)?;
        if overlaps(h.data as usize, hb, dst as usize, bytes) {
            return Err(Error::InvalidArgument);
        }
        let n = refl_core::try_visibility_pyramid_len(hz.layout().width(), hz.layout().height())?;
        if dst_len < n {
            return Err(Error::InsufficientSize);
        }
        // SAFETY: non-null, aligned, writable for dst_len >= n floats,
        // disjoint from the Hi-Z (checked).
        let s = unsafe { core::slice::from_raw_parts_mut(dst, n) };
        refl_core::try_build_visibility_pyramid(s, &hz)
    })
}

impl From<ConeOptions> for refl_cone_options {
    fn from(o: ConeOptions) -> Self {
        Self {
            max_circles: o.max_circles,
            level_bias: o.level_bias,
            use_visibility: o.use_visibility,
            max_stretch: o.max_stretch,
            depth_tolerance: o.depth_tolerance,
            normalize: o.normalize,
        }
    }
}

impl From<refl_cone_options> for ConeOptions {
    fn from(o: refl_cone_options) -> Self {
        Self {
            max_circles: o.max_circles,
            level_bias: o.level_bias,
            use_visibility: o.use_visibility,
            max_stretch: o.max_stretch,
            depth_tolerance: o.depth_tolerance,
            normalize: o.normalize,
        }
    }
}

/// The default cone options: 8 circles, bias 0, visibility on,
/// isotropic, 1% depth tolerance, no normalization.
#[no_mangle]
pub extern "C" fn refl_cone_options_default() -> refl_cone_options {
    ConeOptions::default().into()
}

/// The default multi-ray options: 8 rays (the low end of seed 003
/// Sec. 3.5's 8 to 49), no rotation, the Hi-Z defaults.
#[no_mangle]
pub extern "C" fn refl_cone_multiray_options_default() -> refl_cone_multiray_options {
    MultiRayOptions::default().into()
}

impl From<refl_cone_multiray_options> for MultiRayOptions {
    fn from(o: refl_cone_multiray_options) -> Self {
        Self {
            rays: o.rays,
            rotation: o.rotation.into(),
            hiz: o.hiz.into(),
        }
    }
}

impl From<MultiRayOptions> for refl_cone_multiray_options {
    fn from(o: MultiRayOptions) -> Self {
        Self {
            rays: o.rays,
            rotation: o.rotation.into(),
            hiz: o.hiz.into(),
        }
    }
}

fn texel(v: refl_vec3) -> ColorTexel {
    [v.x, v.y, v.z]
}

fn vec3(c: ColorTexel) -> refl_vec3 {
    refl_vec3 {
        x: c[0],
        y: c[1],
        z: c[2],
    }
}

/// Integrates the cone `*cone` over the pyramids (seed 004 Sec. 4.4.5 /
/// Listing 4.7): in-radius circles from the hit toward the apex, trilinear
/// color and visibility, weighted by how far the cone's sphere reaches the
/// cell's closest depth, until the coverage reaches 1; the rest is
/// `fallback`. Writes the result to `*out`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `pyramids` (or one of its
/// buffers), `cone` or `options` is NULL; `REFL_STATUS_INSUFFICIENT_SIZE`
/// if a pyramid is shorter than `refl_cone_pyramid_len`;
/// `REFL_STATUS_INVALID_ARGUMENT` for non-finite or non-positive cone
/// inputs, a `theta` outside [0, pi/2), a non-finite fallback, bad options,
/// an unknown convention or a misaligned pointer; the camera's status if it
/// is invalid.
///
/// # Safety
/// `out` NULL or writable; `pyramids`, `cone` and `options` NULL or
/// readable; the pyramid buffers readable for their lengths and not written
/// during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_cone_trace(
    out: *mut refl_cone_result,
    pyramids: *const refl_cone_pyramids,
    cone: *const refl_cone,
    fallback: refl_vec3,
    options: *const refl_cone_options,
) -> refl_status {
    guard("refl_cone_trace", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let (p, c, o) = unsafe {
            (
                read(pyramids, "pyramids")?,
                read(cone, "cone")?,
                read(options, "options")?,
            )
        };
        // SAFETY: caller contract.
        let pyr = unsafe { bind_pyramids(&p) }?;
        let cone = Cone {
            apex: c.apex.into(),
            apex_depth: c.apex_depth,
            hit: c.hit.into(),
            hit_depth: c.hit_depth,
            theta: c.theta,
            n_dot_v: c.n_dot_v,
            travel: c.travel,
        };
        let r = refl_core::try_cone_trace(&pyr, &cone, texel(fallback), &o.into())?;
        // SAFETY: caller contract.
        unsafe {
            out.write(refl_cone_result {
                color: vec3(r.color),
                coverage: r.coverage,
                circles: r.circles,
                fetches: r.fetches,
            })
        };
        Ok(())
    })
}

/// The product of the enabled fades of `*fades` (seed 004 Sec. 4.6.1) for
/// a reflection ray of unit direction `reflected` seen from the unit
/// direction `toward_eye`, hitting at pixel `hit` of a `width x height`
/// frame after traveling `t`, into `*out`. Blend
/// `fallback + fade * (color - fallback)`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `fades` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an enabled range that is not finite
/// with `end > start`, a zero size or non-finite inputs.
///
/// # Safety
/// `out` NULL or writable; `fades` NULL or readable.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_cone_fade(
    out: *mut f32,
    fades: *const refl_cone_fades,
    reflected: refl_vec3,
    toward_eye: refl_vec3,
    hit: refl_vec2,
    width: u32,
    height: u32,
    t: f32,
) -> refl_status {
    guard("refl_cone_fade", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let f = unsafe { read(fades, "fades") }?;
        let range = |r: crate::types::refl_cone_fade_range| {
            r.enabled.then_some(FadeRange {
                start: r.start,
                end: r.end,
            })
        };
        let fades = Fades {
            toward_camera: range(f.toward_camera),
            border: range(f.border),
            travel: range(f.travel),
        };
        let v = fades.try_factor(
            reflected.into(),
            toward_eye.into(),
            hit.into(),
            width,
            height,
            t,
        )?;
        // SAFETY: caller contract.
        unsafe { out.write(v) };
        Ok(())
    })
}

/// The multi-ray glossy reflection (seed 003 Sec. 3.5,
/// `refl_core::cone::try_multiray`): `options->rays` directions uniform in
/// the cone of half-angle `theta` around `ray.dir` (rays below the surface
/// of unit `normal` skipped), each traced with the Hi-Z from `ray.origin`
/// over `[0, t_max]`; a hit reads the level-0 color, a miss `fallback`; the
/// mean is weighted by `cos^power` (the Phong lobe). Writes `*out`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `pyramids` (or a buffer),
/// `thickness` or `options` is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` for
/// short pyramids or a short back-face image;
/// `REFL_STATUS_INVALID_ARGUMENT` for zero rays, a ray rejected by
/// `refl_hiz_trace_ray`, a non-finite normal, rotation or fallback, a
/// `theta` outside [0, pi/2), a NaN or negative power, a bad thickness, an
/// unknown convention or a misaligned pointer; the camera's status if it is
/// invalid.
///
/// # Safety
/// As `refl_cone_trace`; `thickness` NULL or readable, a back-face image
/// readable for its length.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_cone_multiray(
    out: *mut refl_cone_multiray_result,
    pyramids: *const refl_cone_pyramids,
    thickness: *const refl_trace_thickness,
    ray: refl_ray,
    normal: refl_vec3,
    t_max: f32,
    theta: f32,
    power: f32,
    options: *const refl_cone_multiray_options,
    fallback: refl_vec3,
) -> refl_status {
    guard("refl_cone_multiray", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let (p, th_c, o) = unsafe {
            (
                read(pyramids, "pyramids")?,
                read(thickness, "thickness")?,
                read(options, "options")?,
            )
        };
        // SAFETY: caller contract.
        let pyr = unsafe { bind_pyramids(&p) }?;
        // SAFETY: caller contract.
        let th = unsafe { crate::trace::thickness(&th_c) }?;
        let fb = texel(fallback);
        if !(fb.iter().all(|c| c.is_finite())) {
            return Err(Error::InvalidArgument);
        }
        let opts = MultiRayOptions::from(o);
        let ray = Ray {
            origin: ray.origin.into(),
            dir: ray.dir.into(),
        };
        let r = refl_core::try_multiray(
            &pyr,
            th,
            ray,
            normal.into(),
            t_max,
            theta,
            power,
            &opts,
            |_| fb,
        )?;
        // SAFETY: caller contract.
        unsafe {
            out.write(refl_cone_multiray_result {
                color: vec3(r.color),
                traced: r.traced,
                hits: r.hits,
                iterations: r.iterations,
            })
        };
        Ok(())
    })
}
