//! The screen-space mirror reflection pass (`refl_core::ssr`): G-buffer in,
//! reflections out, the rays the screen cannot answer handed back as a list
//! for the host's tracer.
//!
//! A frame takes four calls: `refl_ssr_options_default` (or your own
//! options), `refl_ssr_scratch_len` and `refl_ssr_prepare` (the Hi-Z
//! pyramid, nothing for stepping), then `refl_ssr_trace_rows` once per row
//! band, from any number of threads.

pub(crate) use crate::gbuffer::{
    gbuffer, gbuffer_ranges, put_host_ray, refl_gbuffer, refl_host_ray, required_outputs,
};
use crate::hiz::refl_hiz_options;
use crate::image::{refl_image_vec3_mut, refl_row_range};
use crate::ptr::{byte_len, check_buffer, check_pointer, disjoint, overlaps, read, Out};
use crate::status::{fail, guard, refl_status};
use crate::trace::refl_step_options;
use crate::types::refl_vec2;
use refl_core::{
    Error, GBuffer, HiZ, HiZTexel, HostRay, MirrorMethod, MirrorOptions, MirrorPass, MirrorSink,
    MirrorStats, MirrorStatus, MirrorTexel, RowRange,
};

/// The kernel of the pass.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_ssr_method {
    /// Per-pixel stepping (`refl_step_ray`).
    Step = 0,
    /// Hi-Z traversal (`refl_hiz_trace_ray`) over a pyramid that
    /// `refl_ssr_prepare` builds.
    Hiz = 1,
}

/// Settings of the pass; `refl_ssr_options_default` gives the measured
/// defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_ssr_options {
    /// The kernel, a `refl_ssr_method`.
    pub method: u32,
    /// Stepping settings (method `REFL_SSR_METHOD_STEP`).
    pub step: refl_step_options,
    /// Hi-Z settings (method `REFL_SSR_METHOD_HIZ`).
    pub hiz: refl_hiz_options,
    /// Surface thickness without a back-face image, relative to the
    /// reflecting pixel's linear depth; finite, >= 0. Default 0.5.
    pub thickness: f32,
    /// A ray starts where its projection has moved this many pixels from
    /// its surface point, so that it does not hit its own surface's depth
    /// texels; finite, >= 0. Default 1.
    pub start_pixels: f32,
    /// A ray starts no earlier than this distance; finite, >= 0. Default 0.
    pub t_min: f32,
    /// The longest ray, > t_min, +infinity allowed (the default).
    pub t_max: f32,
    /// Pixels with a roughness above this are not traced (only with a
    /// roughness image); not NaN. Default 0.1.
    pub max_roughness: f32,
    /// Width of the confidence fade at the image border, a fraction of the
    /// smaller image side in [0, 0.5]. Default 0.05.
    pub border_fade: f32,
    /// Refine hits to sub-pixel precision (`refl_trace_refine_hit`). Default true.
    pub refine: bool,
    /// Refuse hits on surfaces that face along the ray. Default true.
    pub reject_back_faces: bool,
    /// Refuse hits inside the thickness that are not on the visible
    /// surface (the ray passed behind an object). Default true.
    pub reject_hidden_hits: bool,
}

/// What the pass did at a pixel (`refl_ssr_texel.status`,
/// `refl_host_ray.status`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_ssr_status {
    /// Not reflective (mask, roughness), or a row the call did not cover.
    Skipped = 0,
    /// No usable surface: sky, NaN depth, zero or non-finite normal.
    NoSurface = 1,
    /// A validated hit.
    Hit = 2,
    /// The ray reached t_max or the far plane in front of every surface:
    /// it hits nothing (answered).
    Sky = 3,
    /// Host ray: the projected ray left the image.
    LeftImage = 4,
    /// Host ray: the ray passed behind geometry.
    BehindGeometry = 5,
    /// Host ray: the kernel's step or iteration cap was reached.
    OutOfSteps = 6,
    /// Host ray: no usable projection (the ray runs toward its own
    /// vanishing point), or a hit so far away that its distance overflows
    /// a float.
    NoProjection = 7,
    /// Host ray: the hit surface faces along the ray.
    BackFace = 8,
    /// Host ray: the kernel's hit lies inside the thickness, not on the
    /// visible surface.
    Hidden = 9,
}

impl From<MirrorStatus> for refl_ssr_status {
    fn from(s: MirrorStatus) -> Self {
        match s {
            MirrorStatus::Skipped => Self::Skipped,
            MirrorStatus::NoSurface => Self::NoSurface,
            MirrorStatus::Hit => Self::Hit,
            MirrorStatus::Sky => Self::Sky,
            MirrorStatus::LeftImage => Self::LeftImage,
            MirrorStatus::BehindGeometry => Self::BehindGeometry,
            MirrorStatus::OutOfSteps => Self::OutOfSteps,
            MirrorStatus::NoProjection => Self::NoProjection,
            MirrorStatus::BackFace => Self::BackFace,
            MirrorStatus::Hidden => Self::Hidden,
        }
    }
}

/// One pixel of the pass's output.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_ssr_texel {
    /// A `refl_ssr_status`.
    pub status: u32,
    /// Sub-pixel position of the hit (the texel hit is its floor); 0
    /// without a hit.
    pub pixel: refl_vec2,
    /// Distance from the surface point to the hit along the ray; 0 without
    /// a hit.
    pub t: f32,
    /// Confidence of the hit in [0, 1] (1 inside, fading at the border);
    /// blend `probe + confidence * (color - probe)`. 0 without a hit.
    pub confidence: f32,
}

impl From<HostRay> for refl_host_ray {
    fn from(r: HostRay) -> Self {
        Self {
            x: r.x,
            y: r.y,
            origin: r.origin.into(),
            dir: r.dir.into(),
            t_min: r.t_min,
            t_max: r.t_max,
            status: refl_ssr_status::from(r.status) as u32,
        }
    }
}

/// Counts of one `refl_ssr_trace_rows` call.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_ssr_stats {
    /// Pixels traced (reflective, with a surface).
    pub traced: u32,
    /// Validated hits.
    pub hits: u32,
    /// Rays answered as sky.
    pub sky: u32,
    /// Pixels that need the host's tracer.
    pub host_rays: u32,
    /// Of those, the ones written to the host list (the first ones in
    /// row-major order; the rest did not fit, their texels still say so).
    pub host_rays_written: u32,
}

impl From<MirrorStats> for refl_ssr_stats {
    fn from(s: MirrorStats) -> Self {
        Self {
            traced: s.traced,
            hits: s.hits,
            sky: s.sky,
            host_rays: s.host_rays,
            host_rays_written: s.host_rays_written,
        }
    }
}

impl From<MirrorOptions> for refl_ssr_options {
    fn from(o: MirrorOptions) -> Self {
        Self {
            method: match o.method {
                MirrorMethod::Step => refl_ssr_method::Step as u32,
                MirrorMethod::HiZ => refl_ssr_method::Hiz as u32,
            },
            step: refl_step_options {
                stride: o.step.stride,
                max_steps: o.step.max_steps,
            },
            hiz: o.hiz.into(),
            thickness: o.thickness,
            start_pixels: o.start_pixels,
            t_min: o.t_min,
            t_max: o.t_max,
            max_roughness: o.max_roughness,
            border_fade: o.border_fade,
            refine: o.refine,
            reject_back_faces: o.reject_back_faces,
            reject_hidden_hits: o.reject_hidden_hits,
        }
    }
}

pub(crate) fn options(o: &refl_ssr_options) -> Result<MirrorOptions, Error> {
    let method = match o.method {
        0 => MirrorMethod::Step,
        1 => MirrorMethod::HiZ,
        m => {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`options.method` is {m}, not a refl_ssr_method"),
            ))
        }
    };
    Ok(MirrorOptions {
        method,
        step: o.step.into(),
        hiz: o.hiz.into(),
        thickness: o.thickness,
        start_pixels: o.start_pixels,
        t_min: o.t_min,
        t_max: o.t_max,
        max_roughness: o.max_roughness,
        border_fade: o.border_fade,
        refine: o.refine,
        reject_back_faces: o.reject_back_faces,
        reject_hidden_hits: o.reject_hidden_hits,
    })
}

/// The pass's defaults: stepping, thickness 0.5 of the pixel's depth,
/// start after 1 pixel, t_min 0, t_max +infinity, roughness up to 0.1, a
/// 5% border fade, refined hits, back faces and hidden hits refused; the
/// kernels' own defaults (`refl_hiz_options_default`, stride 1).
#[no_mangle]
pub extern "C" fn refl_ssr_options_default() -> refl_ssr_options {
    MirrorOptions::default().into()
}

/// Size query: the number of `refl_vec2` scratch texels the pass needs for
/// this G-buffer's size and method (the Hi-Z pyramid, `refl_hiz_len`; 0 for
/// stepping) into `*out_len`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_len`, `gbuffer` or `options`
/// is NULL; `REFL_STATUS_INVALID_ARGUMENT` for an unknown method or an
/// invalid camera size.
///
/// # Safety
/// `out_len` NULL or writable; `gbuffer` and `options` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_ssr_scratch_len(
    out_len: *mut usize,
    gbuffer: *const refl_gbuffer,
    options: *const refl_ssr_options,
) -> refl_status {
    guard("refl_ssr_scratch_len", || {
        let out = Out::new(out_len, "out_len")?;
        // SAFETY: caller contract.
        let (g, o) = unsafe { (read(gbuffer, "gbuffer")?, read(options, "options")?) };
        let o = self::options(&o)?;
        let cam = crate::types::camera_named(&g.depth.camera, "gbuffer.depth.camera")?;
        let n = match o.method {
            MirrorMethod::Step => 0,
            MirrorMethod::HiZ => refl_core::try_hiz_len(cam.width(), cam.height())?,
        };
        // SAFETY: caller contract.
        unsafe { out.write(n) };
        Ok(())
    })
}

/// Prepares a frame: validates the G-buffer and the options together and,
/// for Hi-Z, builds the pyramid of the G-buffer's depth into `scratch`
/// (`refl_ssr_scratch_len` texels; for stepping `scratch` may be NULL and
/// nothing is written). Call it once per frame, before any
/// `refl_ssr_trace_rows`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `gbuffer`, `options`, a required
/// image or (Hi-Z) `scratch` is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if
/// `scratch_len` or an image's `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for an option out of range, an unknown
/// method, convention or normal space, an image not of the camera's size,
/// a misaligned pointer, or `scratch` overlapping a G-buffer image; the
/// camera's status if it is invalid. Nothing is written on error.
///
/// # Safety
/// `scratch` NULL or writable for `scratch_len` texels; `gbuffer` and
/// `options` NULL or readable, the images readable for their `len` texels
/// and not written during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_ssr_prepare(
    scratch: *mut refl_vec2,
    scratch_len: usize,
    gbuffer: *const refl_gbuffer,
    options: *const refl_ssr_options,
) -> refl_status {
    guard("refl_ssr_prepare", || {
        // SAFETY: caller contract.
        let (g, o) = unsafe { (read(gbuffer, "gbuffer")?, read(options, "options")?) };
        let opts = self::options(&o)?;
        // Every required pointer before any size: NULL is reported first.
        if opts.method == MirrorMethod::HiZ {
            check_pointer(scratch.cast_const(), "scratch")?;
        }
        // SAFETY: caller contract.
        let gb = unsafe { self::gbuffer(&g) }?;
        if opts.method == MirrorMethod::Step {
            // Validates the options against the G-buffer.
            MirrorPass::try_new(gb, opts, None)?;
            return Ok(());
        }
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
        let need = refl_core::try_hiz_len(gb.width(), gb.height())?;
        if scratch_len < need {
            return Err(fail(
                Error::InsufficientSize,
                format_args!(
                    "`scratch_len` is {scratch_len}, the pass needs {need} (refl_ssr_scratch_len)"
                ),
            ));
        }
        // Options first, with a pass over no pyramid but the right method
        // check: validate everything before the first write.
        MirrorPass::try_new(
            gb,
            MirrorOptions {
                method: MirrorMethod::Step,
                ..opts
            },
            None,
        )?;
        // SAFETY: non-null, aligned, writable for scratch_len >= need
        // texels (contract), size fits isize (check_buffer), disjoint from
        // the G-buffer (checked); refl_vec2 is [f32; 2].
        let s = unsafe { core::slice::from_raw_parts_mut(scratch.cast::<HiZTexel>(), need) };
        refl_core::try_build_hiz(s, gb.depth())
    })
}

/// The checked outputs of one `*_trace_rows` call of a G-buffer pass
/// (`refl_ssr_trace_rows`, `refl_glossy_trace_rows`): the band's rows and
/// where its texels (C structs of type `T`), colors and host rays go.
pub(crate) struct Band<'a, T> {
    /// The rows the call runs over.
    pub rows: RowRange,
    texels: *mut T,
    width: usize,
    /// Index of the first row's first texel (the band starts there).
    base: usize,
    color: Option<refl_core::ImageViewMut<'a, [f32; 3]>>,
    host: *mut refl_host_ray,
    host_len: usize,
}

impl<'a, T> Band<'a, T> {
    /// Checks a call's outputs against the G-buffer `g` (parsed as `gb`):
    /// `out` (`out_len >= width * height` texels), `color` (NULL data, or
    /// the camera's size with a G-buffer color), `host` (NULL with
    /// `host_len` 0, or `host_len` entries), `rows` within the height, and
    /// that no output overlaps another or an input (the G-buffer's images,
    /// `scratch_bytes` bytes at `scratch`, the stats at `stats`).
    ///
    /// # Safety
    /// `out` writable for `out_len` texels, `color.data` for `color.len`
    /// texels and `host` for `host_len` entries if not NULL; no other
    /// thread writes the band's rows of `out` and `color` while the band
    /// is in use.
    #[allow(clippy::too_many_arguments)]
    pub(crate) unsafe fn try_new(
        out: *mut T,
        out_len: usize,
        color: refl_image_vec3_mut,
        host: *mut refl_host_ray,
        host_len: usize,
        g: &refl_gbuffer,
        gb: &GBuffer<'_>,
        rows: refl_row_range,
        scratch: (usize, usize),
        stats: (usize, usize),
    ) -> Result<Self, Error> {
        // SAFETY: caller contract.
        unsafe {
            Self::try_sized(
                out,
                out_len,
                color,
                host,
                host_len,
                g,
                (gb.width(), gb.height()),
                rows,
                scratch,
                stats,
            )
        }
    }

    /// [`Band::try_new`] for outputs of `size` texels (the G-buffer's, or
    /// the half-resolution images of `refl_upsample_trace_rows`); `color`
    /// must then be of that size too.
    ///
    /// # Safety
    /// As [`Band::try_new`].
    #[allow(clippy::too_many_arguments)]
    pub(crate) unsafe fn try_sized(
        out: *mut T,
        out_len: usize,
        color: refl_image_vec3_mut,
        host: *mut refl_host_ray,
        host_len: usize,
        g: &refl_gbuffer,
        size: (u32, u32),
        rows: refl_row_range,
        scratch: (usize, usize),
        stats: (usize, usize),
    ) -> Result<Self, Error> {
        let out_bytes = check_buffer(out.cast_const(), out_len, "out")?;
        let host_bytes = if host_len == 0 && host.is_null() {
            0
        } else {
            check_buffer(host.cast_const(), host_len, "host")?
        };
        let (w, h) = size;
        let rows = RowRange::try_new(rows.begin, rows.end, h).map_err(|e| {
            fail(
                e,
                format_args!(
                    "`rows` [{}, {}) is not within [0, {h})",
                    rows.begin, rows.end
                ),
            )
        })?;
        let need = (w as usize)
            .checked_mul(h as usize)
            .ok_or(Error::InvalidArgument)?;
        if out_len < need {
            return Err(fail(
                Error::InsufficientSize,
                format_args!("`out_len` is {out_len}, a {w}x{h} image needs {need}"),
            ));
        }
        let color_view = if color.data.is_null() {
            None
        } else {
            if g.color.data.is_null() || color.width != w || color.height != h {
                return Err(fail(
                    Error::InvalidArgument,
                    format_args!("`color` needs a G-buffer color and the output's size ({w}x{h})"),
                ));
            }
            // SAFETY: caller contract (the band's rows writable, not
            // accessed by others during the call).
            Some(unsafe { color.band_mut(rows) }?)
        };
        // Aliasing: the outputs must not overlap each other or the inputs.
        let color_bytes = if color.data.is_null() {
            0
        } else {
            byte_len::<[f32; 3]>(color.data as usize, color.len)?
        };
        let outs = [
            (out as usize, out_bytes),
            (host as usize, host_bytes),
            (color.data as usize, color_bytes),
            stats,
        ];
        let mut ins = [(0usize, 0usize); 7];
        ins[..6].copy_from_slice(&gbuffer_ranges(g));
        ins[6] = scratch;
        disjoint(&outs, &ins)?;
        Ok(Self {
            rows,
            texels: out,
            width: w as usize,
            base: rows.start() as usize * w as usize,
            color: color_view,
            host,
            host_len,
        })
    }

    /// Writes pixel `(x, y)`'s texel and color.
    pub(crate) fn put(&mut self, x: u32, y: u32, v: T, color: [f32; 3]) {
        let i = (y - self.rows.start()) as usize * self.width + x as usize + self.base;
        // SAFETY: `i` indexes the band's texels (x < width, y in rows),
        // within `out_len >= width * height` writable texels (checked in
        // `try_new`, contract).
        unsafe { self.texels.add(i).write(v) };
        if let Some(c) = self.color.as_mut().and_then(|c| c.get_mut(x, y)) {
            *c = color;
        }
    }

    /// Writes host ray number `index`, if the list holds it.
    pub(crate) fn put_host(&mut self, index: u32, r: &HostRay) -> bool {
        // SAFETY: `host` non-null, aligned and writable for `host_len`
        // entries, or `host_len` 0 (checked when the band was made).
        unsafe { put_host_ray(self.host, self.host_len, index, refl_host_ray::from(*r)) }
    }
}

impl MirrorSink for Band<'_, refl_ssr_texel> {
    fn texel(&mut self, x: u32, y: u32, t: &MirrorTexel, color: [f32; 3]) {
        let v = refl_ssr_texel {
            status: refl_ssr_status::from(t.status) as u32,
            pixel: t.pixel.into(),
            t: t.t,
            confidence: t.confidence,
        };
        self.put(x, y, v, color);
    }

    fn host(&mut self, index: u32, r: &HostRay) -> bool {
        self.put_host(index, r)
    }
}

/// The mirror pass over `gb` with `opts` and, for Hi-Z, the pyramid
/// `refl_ssr_prepare` built into `scratch` (checked against the G-buffer's
/// camera).
///
/// # Safety
/// `scratch` NULL or readable for `scratch_len` texels for `'a`, not
/// written meanwhile.
pub(crate) unsafe fn mirror_pass<'a>(
    gb: GBuffer<'a>,
    opts: MirrorOptions,
    scratch: *const refl_vec2,
    scratch_len: usize,
) -> Result<MirrorPass<'a>, Error> {
    let hiz = match opts.method {
        MirrorMethod::Step => None,
        MirrorMethod::HiZ => {
            check_buffer(scratch, scratch_len, "scratch")?;
            // SAFETY: non-null, aligned, readable for scratch_len texels
            // (contract), size fits isize (check_buffer).
            let data =
                unsafe { core::slice::from_raw_parts(scratch.cast::<HiZTexel>(), scratch_len) };
            Some(
                HiZ::try_new(data, *gb.camera(), gb.convention()).map_err(|e| {
                    fail(
                        e,
                        format_args!(
                            "`scratch` is not the pyramid refl_ssr_prepare built for this G-buffer"
                        ),
                    )
                })?,
            )
        }
    };
    MirrorPass::try_new(gb, opts, hiz)
}

/// Runs the pass over the rows `rows` of the G-buffer: for each pixel of
/// those rows writes its `refl_ssr_texel` to `out[y * width + x]` (`out`
/// holds the whole `width x height` image, row stride `width`; only the
/// band's rows are written), its reflection color (the lit color at a hit,
/// black otherwise) to `color` if `color.data` is not NULL (then the
/// G-buffer must have a color), and appends the pixels that need the
/// host's tracer to `host` (up to `host_len`; `host` may be NULL with
/// `host_len` 0) in row-major order. The counts go to `*out_stats`.
///
/// Bands are independent: split the rows (`refl_image_row_band`) across threads,
/// each with its own `host` list. `scratch` is what `refl_ssr_prepare`
/// built for this G-buffer (Hi-Z; NULL for stepping); a pyramid built for
/// another camera or size is refused.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `out`, `gbuffer`,
/// `options`, a required image, (Hi-Z) `scratch`, or `host` with a
/// non-zero `host_len` is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if
/// `out_len < width * height`, `scratch_len` or an image's `len` is too
/// small; `REFL_STATUS_INVALID_ARGUMENT` for rows reversed or beyond the
/// height, `color` not of the camera's size or given without a G-buffer
/// color, outputs overlapping each other or the inputs, a pyramid not
/// built for this camera, and the cases of `refl_ssr_prepare`. Nothing is
/// written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out` NULL or writable for `out_len`
/// texels; `color.data` NULL or writable for `color.len` texels; `host`
/// NULL or writable for `host_len` entries; `scratch` NULL or readable for
/// `scratch_len` texels; the rest as `refl_ssr_prepare`. No other thread
/// writes the rows of `out` and `color` this call writes.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_ssr_trace_rows(
    out_stats: *mut refl_ssr_stats,
    out: *mut refl_ssr_texel,
    out_len: usize,
    color: refl_image_vec3_mut,
    host: *mut refl_host_ray,
    host_len: usize,
    gbuffer: *const refl_gbuffer,
    options: *const refl_ssr_options,
    scratch: *const refl_vec2,
    scratch_len: usize,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_ssr_trace_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        // SAFETY: caller contract.
        let (g, o) = unsafe { (read(gbuffer, "gbuffer")?, read(options, "options")?) };
        let opts = self::options(&o)?;
        // Every required pointer before any size: NULL is reported first.
        required_outputs(out, host, host_len)?;
        if opts.method == MirrorMethod::HiZ {
            check_pointer(scratch, "scratch")?;
        }
        // SAFETY: caller contract.
        let gb = unsafe { self::gbuffer(&g) }?;
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
                (scratch as usize, scratch_len.saturating_mul(8)),
                (out_stats as usize, core::mem::size_of::<refl_ssr_stats>()),
            )
        }?;
        // SAFETY: caller contract.
        let pass = unsafe { mirror_pass(gb, opts, scratch, scratch_len) }?;
        let stats = pass.try_run_rows(band.rows, &mut band)?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(stats.into()) };
        Ok(())
    })
}
