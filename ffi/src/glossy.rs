//! The glossy reflection pass (`refl_core::glossy`): G-buffer and lit
//! color in, per glossy pixel a pre-convolved reflection color by cone
//! tracing (seed 004) or multi-ray (seed 003 Sec. 3.5), the weight of the
//! host's probe, and the pixels the screen cannot answer as a list of
//! `refl_host_ray` for the host's tracer.
//!
//! A frame takes four calls: `refl_glossy_options_default` (or your own
//! options), `refl_glossy_scratch_len` and `refl_glossy_prepare` (the Hi-Z,
//! color and visibility pyramids), then `refl_glossy_trace_rows` once per
//! row band, from any number of threads. The G-buffer is the mirror pass's
//! `refl_gbuffer`; it needs a lit color and a roughness image.

use crate::hiz::refl_hiz_options;
use crate::image::{refl_image_vec3_mut, refl_row_range};
use crate::ptr::{check_buffer, check_pointer, overlaps, read, Out};
use crate::ssr::{
    gbuffer, gbuffer_ranges, refl_gbuffer, refl_host_ray, refl_ssr_status, required_outputs, Band,
};
use crate::status::{fail, guard, refl_status};
use crate::types::{refl_vec2, refl_vec3};
use refl_core::cone::{ConeOptions, FadeRange, Fades};
use refl_core::{
    try_glossy_scratch_len, try_prepare_glossy, ColorTexel, Error, GBuffer, GlossyMethod,
    GlossyOptions, GlossyPass, GlossyScratch, GlossyScratchLen, GlossyScratchMut, GlossySink,
    GlossyStats, GlossyTexel, HiZTexel, HostRay,
};

/// How the glossy pass integrates the lobe.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_glossy_method {
    /// Cone tracing over the color (and visibility) pyramid (seed 004).
    Cone = 0,
    /// Several Hi-Z rays in the cone, Phong-weighted (seed 003 Sec. 3.5).
    MultiRay = 1,
}

/// One fade of seed 004 Sec. 4.6.1: a factor 1 at or below `start`, 0 at
/// or above `end`, linear between.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_glossy_fade {
    /// Whether the fade applies.
    pub enabled: bool,
    /// Where the fade begins (finite when enabled).
    pub start: f32,
    /// Where it reaches 0 (finite, > start when enabled).
    pub end: f32,
}

/// Settings of the glossy pass; `refl_glossy_options_default` gives the
/// measured defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_glossy_options {
    /// A `refl_glossy_method`. Default cone.
    pub method: u32,
    /// Cone: most circles per pixel (clamped to 64). Default 8.
    pub max_circles: u32,
    /// Cone: added to a circle's mip level log2(2 r); finite. Default 0.
    pub level_bias: f32,
    /// Cone: weight samples by the pre-integrated visibility (then
    /// `refl_glossy_prepare` builds its pyramid). Default false.
    pub use_visibility: bool,
    /// Cone: largest anisotropic stretch along the axis, >= 1, finite
    /// (1: isotropic). Default 1.
    pub max_stretch: f32,
    /// Cone: relative depth tolerance of a sample's sphere weight; finite,
    /// >= 0. Default 0.01.
    pub depth_tolerance: f32,
    /// Cone: divide by the coverage (a weighted mean of the samples; the
    /// probe then takes only uncovered cones). Default true.
    pub normalize: bool,
    /// Cone: fade over dot(reflected, toward the eye). Default off.
    pub fade_toward_camera: refl_glossy_fade,
    /// Cone: fade over the hit's max(|2u - 1|, |2v - 1|). Default off.
    pub fade_border: refl_glossy_fade,
    /// Cone: fade over the travel from the ray's start to the hit (world
    /// units). Default off.
    pub fade_travel: refl_glossy_fade,
    /// Cone: size the cone from its world travel instead of the seed's
    /// screen-space triangle. Default false.
    pub view_space: bool,
    /// Standard deviation of the color pyramid's Gaussian, finer texels;
    /// finite, > 0. Default 1.
    pub sigma: f32,
    /// Multi-ray: rays per pixel, > 0. Default 8.
    pub rays: u32,
    /// Hi-Z settings of the mirror ray (the cone's axis) and of each
    /// multi-ray ray (`refl_hiz_default_options`).
    pub hiz: refl_hiz_options,
    /// As `refl_ssr_options.thickness`. Default 0.5.
    pub thickness: f32,
    /// As `refl_ssr_options.start_pixels`. Default 1.
    pub start_pixels: f32,
    /// As `refl_ssr_options.t_min`. Default 0.
    pub t_min: f32,
    /// As `refl_ssr_options.t_max`. Default +infinity.
    pub t_max: f32,
    /// Pixels with a roughness at or below this are not traced (left to
    /// the mirror pass, whose default `max_roughness` is the same); not
    /// NaN, < max_roughness; negative traces every roughness. Default 0.1.
    pub min_roughness: f32,
    /// Pixels with a roughness above this are not traced; not NaN.
    /// Default 1.
    pub max_roughness: f32,
    /// As `refl_ssr_options.refine`. Default true.
    pub refine: bool,
    /// As `refl_ssr_options.reject_back_faces`. Default true.
    pub reject_back_faces: bool,
    /// As `refl_ssr_options.reject_hidden_hits`. Default true.
    pub reject_hidden_hits: bool,
}

fn fade(f: Option<FadeRange>) -> refl_glossy_fade {
    match f {
        Some(r) => refl_glossy_fade {
            enabled: true,
            start: r.start,
            end: r.end,
        },
        None => refl_glossy_fade::default(),
    }
}

fn fade_range(f: refl_glossy_fade) -> Option<FadeRange> {
    f.enabled.then_some(FadeRange {
        start: f.start,
        end: f.end,
    })
}

impl From<GlossyOptions> for refl_glossy_options {
    fn from(o: GlossyOptions) -> Self {
        Self {
            method: match o.method {
                GlossyMethod::Cone => refl_glossy_method::Cone as u32,
                GlossyMethod::MultiRay => refl_glossy_method::MultiRay as u32,
            },
            max_circles: o.cone.max_circles,
            level_bias: o.cone.level_bias,
            use_visibility: o.cone.use_visibility,
            max_stretch: o.cone.max_stretch,
            depth_tolerance: o.cone.depth_tolerance,
            normalize: o.cone.normalize,
            fade_toward_camera: fade(o.fades.toward_camera),
            fade_border: fade(o.fades.border),
            fade_travel: fade(o.fades.travel),
            view_space: o.view_space,
            sigma: o.sigma,
            rays: o.rays,
            hiz: o.hiz.into(),
            thickness: o.thickness,
            start_pixels: o.start_pixels,
            t_min: o.t_min,
            t_max: o.t_max,
            min_roughness: o.min_roughness,
            max_roughness: o.max_roughness,
            refine: o.refine,
            reject_back_faces: o.reject_back_faces,
            reject_hidden_hits: o.reject_hidden_hits,
        }
    }
}

/// The refl-core options of a C options struct (the method checked; the
/// ranges are the pass's to check).
fn glossy_options(o: &refl_glossy_options) -> Result<GlossyOptions, Error> {
    let method = match o.method {
        0 => GlossyMethod::Cone,
        1 => GlossyMethod::MultiRay,
        m => {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`options.method` is {m}, not a refl_glossy_method"),
            ))
        }
    };
    Ok(GlossyOptions {
        method,
        cone: ConeOptions {
            max_circles: o.max_circles,
            level_bias: o.level_bias,
            use_visibility: o.use_visibility,
            max_stretch: o.max_stretch,
            depth_tolerance: o.depth_tolerance,
            normalize: o.normalize,
        },
        fades: Fades {
            toward_camera: fade_range(o.fade_toward_camera),
            border: fade_range(o.fade_border),
            travel: fade_range(o.fade_travel),
        },
        view_space: o.view_space,
        sigma: o.sigma,
        rays: o.rays,
        hiz: o.hiz.into(),
        thickness: o.thickness,
        start_pixels: o.start_pixels,
        t_min: o.t_min,
        t_max: o.t_max,
        min_roughness: o.min_roughness,
        max_roughness: o.max_roughness,
        refine: o.refine,
        reject_back_faces: o.reject_back_faces,
        reject_hidden_hits: o.reject_hidden_hits,
    })
}

/// One pixel of the glossy pass's output.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_glossy_texel {
    /// What happened to the pixel's mirror ray (the cone's axis), a
    /// `refl_ssr_status`: traced and validated as `refl_ssr_trace_rows`
    /// does with Hi-Z.
    pub status: u32,
    /// Sub-pixel position of the axis hit; 0 without a hit.
    pub pixel: refl_vec2,
    /// Distance from the surface point to the axis hit; 0 without a hit.
    pub t: f32,
    /// Share of the lobe the screen covered (cone coverage, or multi-ray's
    /// 1 - fallback_weight); 0 without a result.
    pub coverage: f32,
    /// The fades' factor (cone with a hit; 1 for multi-ray, 0 otherwise).
    pub fade: f32,
    /// The weight of your probe: final = color + fallback_weight * probe,
    /// with the probe sampled in `dir` at the pixel's roughness. 1 where
    /// the screen answered nothing, 0 for pixels the pass does not handle.
    pub fallback_weight: f32,
    /// Unit mirror direction (where to sample the probe); 0 for pixels the
    /// pass does not handle.
    pub dir: refl_vec3,
}

/// Counts of one `refl_glossy_trace_rows` call.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_glossy_stats {
    /// Pixels traced (glossy, with a surface).
    pub traced: u32,
    /// Validated axis hits.
    pub hits: u32,
    /// Axes answered as sky.
    pub sky: u32,
    /// Pixels that need the host's tracer.
    pub host_rays: u32,
    /// Of those, the ones written to the host list (the first ones in
    /// row-major order).
    pub host_rays_written: u32,
    /// Cone circles taken, summed over the pixels.
    pub circles: u64,
    /// Multi-ray rays traced (not below the surface), summed.
    pub lobe_rays: u64,
    /// Multi-ray rays that hit on screen, summed.
    pub lobe_hits: u64,
}

impl From<GlossyStats> for refl_glossy_stats {
    fn from(s: GlossyStats) -> Self {
        Self {
            traced: s.traced,
            hits: s.hits,
            sky: s.sky,
            host_rays: s.host_rays,
            host_rays_written: s.host_rays_written,
            circles: s.circles,
            lobe_rays: s.lobe_rays,
            lobe_hits: s.lobe_hits,
        }
    }
}

/// The pass's defaults: cone tracing with 8 circles, normalized, no
/// visibility weighting, no fades, the seed's screen-space triangle, sigma
/// 1; 8 rays for multi-ray; roughness in (0.1, 1]; the mirror pass's axis
/// defaults (Hi-Z defaults, thickness 0.5, start after 1 pixel, t_min 0,
/// t_max +infinity, refined hits, back faces and hidden hits refused).
#[no_mangle]
pub extern "C" fn refl_glossy_options_default() -> refl_glossy_options {
    GlossyOptions::default().into()
}

/// The scratch parts' lengths of a G-buffer and options.
///
/// # Safety
/// As `refl_glossy_scratch_len`.
unsafe fn scratch_parts(
    gbuffer: *const refl_gbuffer,
    options: *const refl_glossy_options,
) -> Result<(refl_gbuffer, GlossyOptions, GlossyScratchLen, usize), Error> {
    // SAFETY: caller contract.
    let (g, o) = unsafe { (read(gbuffer, "gbuffer")?, read(options, "options")?) };
    let opts = glossy_options(&o)?;
    let cam = crate::types::camera_named(&g.depth.camera, "gbuffer.depth.camera")?;
    let n = try_glossy_scratch_len(cam.width(), cam.height(), &opts)?;
    let floats = n.floats().ok_or_else(|| {
        fail(
            Error::InvalidArgument,
            format_args!(
                "the scratch of a {}x{} frame does not fit in memory",
                cam.width(),
                cam.height()
            ),
        )
    })?;
    Ok((g, opts, n, floats))
}

/// Size query: the number of floats of scratch the pass needs for this
/// G-buffer's size and these options into `*out_len`: the Hi-Z pyramid
/// (`refl_hiz_len` texels of 2 floats), the color pyramid
/// (`refl_cone_pyramid_len`'s color texels of 3 floats) and, with
/// `use_visibility` on for the cone, the visibility pyramid, back to back.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_len`, `gbuffer` or `options`
/// is NULL; `REFL_STATUS_INVALID_ARGUMENT` for an unknown method or an
/// invalid camera size; the camera's status if it is invalid.
///
/// # Safety
/// `out_len` NULL or writable; `gbuffer` and `options` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_glossy_scratch_len(
    out_len: *mut usize,
    gbuffer: *const refl_gbuffer,
    options: *const refl_glossy_options,
) -> refl_status {
    guard("refl_glossy_scratch_len", || {
        let out = Out::new(out_len, "out_len")?;
        // SAFETY: caller contract.
        let (.., floats) = unsafe { scratch_parts(gbuffer, options) }?;
        // SAFETY: caller contract.
        unsafe { out.write(floats) };
        Ok(())
    })
}

/// The three parts of a scratch of `n` parts' lengths at `p`, writable.
///
/// # Safety
/// `p` non-null, aligned and writable for `n.floats()` floats, not
/// accessed otherwise while the parts live.
unsafe fn parts_mut<'a>(p: *mut f32, n: &GlossyScratchLen) -> GlossyScratchMut<'a> {
    // SAFETY: disjoint consecutive ranges within `n.floats()` floats
    // (caller contract); [f32; 2] and [f32; 3] have the alignment of f32.
    unsafe {
        let color = p.add(2 * n.hiz);
        let vis = color.add(3 * n.color);
        GlossyScratchMut {
            hiz: core::slice::from_raw_parts_mut(p.cast::<HiZTexel>(), n.hiz),
            color: core::slice::from_raw_parts_mut(color.cast::<ColorTexel>(), n.color),
            visibility: core::slice::from_raw_parts_mut(vis, n.visibility),
        }
    }
}

/// The three parts of a scratch of `n` parts' lengths at `p`.
///
/// # Safety
/// `p` non-null, aligned and readable for `n.floats()` floats, not
/// written while the parts live.
unsafe fn parts<'a>(p: *const f32, n: &GlossyScratchLen) -> GlossyScratch<'a> {
    // SAFETY: as `parts_mut`, read only.
    unsafe {
        let color = p.add(2 * n.hiz);
        let vis = color.add(3 * n.color);
        GlossyScratch {
            hiz: core::slice::from_raw_parts(p.cast::<HiZTexel>(), n.hiz),
            color: core::slice::from_raw_parts(color.cast::<ColorTexel>(), n.color),
            visibility: core::slice::from_raw_parts(vis, n.visibility),
        }
    }
}

/// The G-buffer of a prepare or trace call, with the options checked
/// against it.
///
/// # Safety
/// As `refl_glossy_prepare`.
unsafe fn checked_gbuffer<'a>(
    g: &refl_gbuffer,
    opts: &GlossyOptions,
) -> Result<GBuffer<'a>, Error> {
    opts.try_validate()
        .map_err(|e| fail(e, format_args!("`options` has a value out of range")))?;
    // SAFETY: caller contract.
    let gb = unsafe { gbuffer(g) }?;
    if g.color.data.is_null() || g.roughness.data.is_null() {
        return Err(fail(
            Error::InvalidArgument,
            format_args!("`gbuffer` needs a lit color and a roughness image"),
        ));
    }
    Ok(gb)
}

fn short_scratch(scratch_len: usize, need: usize) -> Error {
    fail(
        Error::InsufficientSize,
        format_args!(
            "`scratch_len` is {scratch_len}, the pass needs {need} (refl_glossy_scratch_len)"
        ),
    )
}

/// Prepares a frame: validates the G-buffer (it needs a lit color and a
/// roughness image) and the options together, and builds into `scratch`
/// (`refl_glossy_scratch_len` floats) the Hi-Z pyramid of the depth, the
/// color pyramid of the lit color (level 0 only for multi-ray) and, when
/// the options read it, the visibility pyramid; each ends with the stamp
/// `refl_glossy_trace_rows` checks. Call it once per frame, before any
/// `refl_glossy_trace_rows`. (The build is single-threaded; a host may
/// instead build the three parts with `refl_hiz_build_rows`,
/// `refl_cone_build_color_rows` and `refl_cone_build_visibility_rows` on
/// its threads, at the offsets 0, 2 x hiz texels and that plus 3 x color
/// texels.)
///
/// Returns `REFL_STATUS_NULL_POINTER` if `scratch`, `gbuffer`, `options`
/// or a required image is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if
/// `scratch_len` or an image's `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for an option out of range, an unknown
/// method, convention or normal space, a G-buffer without color or
/// roughness, a non-finite lit color, an image not of the camera's size, a
/// misaligned pointer, or `scratch` overlapping a G-buffer image; the
/// camera's status if it is invalid. Nothing is written on error.
///
/// # Safety
/// `scratch` NULL or writable for `scratch_len` floats; `gbuffer` and
/// `options` NULL or readable, the images readable for their `len` texels
/// and not written during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_glossy_prepare(
    scratch: *mut f32,
    scratch_len: usize,
    gbuffer: *const refl_gbuffer,
    options: *const refl_glossy_options,
) -> refl_status {
    guard("refl_glossy_prepare", || {
        // SAFETY: caller contract.
        let (g, opts, n, need) = unsafe { scratch_parts(gbuffer, options) }?;
        // Every required pointer before any size: NULL is reported first.
        check_pointer(scratch.cast_const(), "scratch")?;
        // SAFETY: caller contract.
        let gb = unsafe { checked_gbuffer(&g, &opts) }?;
        let bytes = check_buffer(scratch.cast_const(), scratch_len, "scratch")?;
        if gbuffer_ranges(&g)
            .iter()
            .any(|r| overlaps(r.0, r.1, scratch as usize, bytes))
        {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`scratch` overlaps a G-buffer image"),
            ));
        }
        if scratch_len < need {
            return Err(short_scratch(scratch_len, need));
        }
        // SAFETY: non-null, aligned, writable for scratch_len >= need
        // floats (contract), size fits isize (check_buffer), disjoint from
        // the G-buffer (checked).
        let dst = unsafe { parts_mut(scratch, &n) };
        try_prepare_glossy(dst, &gb, &opts)
    })
}

impl From<GlossyTexel> for refl_glossy_texel {
    fn from(t: GlossyTexel) -> Self {
        Self {
            status: refl_ssr_status::from(t.status) as u32,
            pixel: t.pixel.into(),
            t: t.t,
            coverage: t.coverage,
            fade: t.fade,
            fallback_weight: t.fallback_weight,
            dir: t.dir.into(),
        }
    }
}

impl GlossySink for Band<'_, refl_glossy_texel> {
    fn texel(&mut self, x: u32, y: u32, t: &GlossyTexel, color: [f32; 3]) {
        self.put(x, y, (*t).into(), color);
    }

    fn host(&mut self, index: u32, r: &HostRay) -> bool {
        self.put_host(index, r)
    }
}

/// Runs the pass over the rows `rows` of the G-buffer: for each pixel of
/// those rows writes its `refl_glossy_texel` to `out[y * width + x]`
/// (`out` holds the whole `width x height` image, row stride `width`; only
/// the band's rows are written), its reflection color (premultiplied: add
/// `fallback_weight` times your probe) to `color` if `color.data` is not
/// NULL, and appends the pixels that need the host's tracer to `host` (up
/// to `host_len`; `host` may be NULL with `host_len` 0) in row-major
/// order. The counts go to `*out_stats`.
///
/// Bands are independent: split the rows (`refl_image_row_band`) across threads,
/// each with its own `host` list. `scratch` is what `refl_glossy_prepare`
/// built for this G-buffer and these options; pyramids built for another
/// camera or size, or not built, are refused.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `out`, `gbuffer`,
/// `options`, `scratch`, a required image, or `host` with a non-zero
/// `host_len` is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len < width
/// * height`, `scratch_len` or an image's `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for rows reversed or beyond the height,
/// `color` not of the camera's size, outputs overlapping each other or the
/// inputs, a scratch not prepared for this G-buffer, and the cases of
/// `refl_glossy_prepare`. Nothing is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out` NULL or writable for `out_len`
/// texels; `color.data` NULL or writable for `color.len` texels; `host`
/// NULL or writable for `host_len` entries; `scratch` NULL or readable for
/// `scratch_len` floats; the rest as `refl_glossy_prepare`. No other thread
/// writes the rows of `out` and `color` this call writes.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_glossy_trace_rows(
    out_stats: *mut refl_glossy_stats,
    out: *mut refl_glossy_texel,
    out_len: usize,
    color: refl_image_vec3_mut,
    host: *mut refl_host_ray,
    host_len: usize,
    gbuffer: *const refl_gbuffer,
    options: *const refl_glossy_options,
    scratch: *const f32,
    scratch_len: usize,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_glossy_trace_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        // SAFETY: caller contract.
        let (g, opts, n, need) = unsafe { scratch_parts(gbuffer, options) }?;
        // Every required pointer before any size: NULL is reported first.
        required_outputs(out, host, host_len)?;
        check_pointer(scratch, "scratch")?;
        // SAFETY: caller contract.
        let gb = unsafe { checked_gbuffer(&g, &opts) }?;
        let scratch_bytes = check_buffer(scratch, scratch_len, "scratch")?;
        // SAFETY: caller contract.
        let mut band = unsafe {
            Band::try_new(
                out,
                out_len,
                color,
                host,
                host_len,
                &g,
                &gb,
                rows,
                (scratch as usize, scratch_bytes),
                (
                    out_stats as usize,
                    core::mem::size_of::<refl_glossy_stats>(),
                ),
            )
        }?;
        if scratch_len < need {
            return Err(short_scratch(scratch_len, need));
        }
        // SAFETY: non-null, aligned, readable for scratch_len >= need
        // floats (contract), size fits isize (check_buffer); no output
        // overlaps it (checked).
        let parts = unsafe { parts(scratch, &n) };
        let pass = GlossyPass::try_new(gb, opts, parts).map_err(|e| {
            fail(
                e,
                format_args!(
                    "`scratch` is not what refl_glossy_prepare built for this G-buffer and options"
                ),
            )
        })?;
        let stats = pass.try_run_rows(band.rows, &mut band)?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(stats.into()) };
        Ok(())
    })
}
