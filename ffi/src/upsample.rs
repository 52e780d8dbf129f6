//! Fewer rays for the mirror pass (`refl_core::upsample`, seed 004 Sec.
//! 4.7.3-4.7.4): trace one pixel of every 2x2 block into half-resolution
//! images, reconstruct the full-resolution image from them guided by the
//! G-buffer (cross-bilateral upsampling), and list (or re-trace) the pixels
//! no traced neighbor on the same surface reaches.
//!
//! A frame takes, after `refl_ssr_prepare` (the mirror pass's own setup:
//! the same `refl_ssr_options`, G-buffer and scratch describe the pass
//! here): `refl_upsample_half_size` (the half-resolution images' size),
//! `refl_upsample_trace_rows` over row bands of the half-resolution images
//! (a quarter of the rays; `refl_ssr_trace_rows`'s outputs per traced
//! pixel), then `refl_upsample_options_default` (or your own options) and
//! `refl_upsample_resolve_rows` over row bands of the full image. Frame `f`
//! traces with `frame = f`: four frames trace every pixel once, which the
//! temporal filter (`refl_temporal_resolve_rows`, `answered` from
//! `refl_upsample_status` COPIED or RETRACED with a HIT or SKY texel)
//! accumulates to the full-resolution result.

use crate::gbuffer::{gbuffer, refl_gbuffer, refl_host_ray, required_outputs};
use crate::image::{
    pixel_list, refl_image_pixel, refl_image_ssr_texel, refl_image_u8_mut, refl_image_vec3,
    refl_image_vec3_mut, refl_row_range,
};
use crate::ptr::{check_pointer, no_nulls, range, read, Out};
use crate::ssr::{
    mirror_pass, refl_ssr_options, refl_ssr_stats, refl_ssr_status, refl_ssr_texel, Band,
};
use crate::status::{fail, guard, refl_status};
use crate::temporal::{image_error, image_range, named_disjoint, same_size};
use crate::types::refl_vec2;
use refl_core::upsample::{
    try_half_size, HalfPass, Pattern, Subsample, UpsampleOptions, UpsamplePass, UpsampleSink,
    UpsampleStats, UpsampleStatus,
};
use refl_core::{Error, ImageViewMut, MirrorPass, MirrorTexel};

/// How the traced pixels are arranged over the 2x2 blocks
/// (`refl_upsample_subsample.pattern`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_upsample_pattern {
    /// Every block traces the frame's sub-pixel: a regular half-resolution
    /// grid.
    Uniform = 0,
    /// Every other block row traces the horizontally mirrored sub-pixel:
    /// the rows of traced pixels interleave (a staggered lattice).
    Staggered = 1,
}

/// Which pixel of each 2x2 block a frame traces.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_upsample_subsample {
    /// The arrangement over the blocks, a `refl_upsample_pattern`.
    pub pattern: u32,
    /// The frame number: frame `f` traces sub-pixel top-left, bottom-right,
    /// top-right, bottom-left for `f % 4` = 0, 1, 2, 3 (any value).
    pub frame: u32,
}

fn subsample(s: &refl_upsample_subsample) -> Result<Subsample, Error> {
    let pattern = match s.pattern {
        0 => Pattern::Uniform,
        1 => Pattern::Staggered,
        p => {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`subsample.pattern` is {p}, not a refl_upsample_pattern"),
            ))
        }
    };
    Ok(Subsample {
        pattern,
        frame: s.frame,
    })
}

/// Settings of the reconstruction; `refl_upsample_options_default` gives
/// the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_upsample_options {
    /// The depth edge: samples whose linear depth differs from the compared
    /// depth by more than this fraction of the pixel's depth weigh 0; > 0
    /// (+infinity turns the edge off; not NaN). Default 0.1.
    pub depth_threshold: f32,
    /// Width of the Gaussian depth weight, a fraction of the pixel's depth,
    /// greater than 0, not NaN (+infinity: every sample within the edge
    /// weighs the same). Default 0.05.
    pub depth_sigma: f32,
    /// Exponent of the normal weight; finite, >= 0 (0 turns it off).
    /// Default 8.
    pub normal_power: f32,
    /// Compare a sample's depth with the pixel's tangent plane at the
    /// sample's pixel rather than with the pixel's own depth (floors seen at
    /// grazing angles). Default false.
    pub plane_depth: bool,
    /// A reconstructed hit takes the G-buffer's lit color at its
    /// interpolated hit position rather than the mean of its samples'
    /// colors (with a `half_color` input and a G-buffer color). Default
    /// true.
    pub shade_hits: bool,
    /// Pixels no sample reaches are traced at full resolution by the mirror
    /// pass (`RETRACED`) instead of listed (`RETRACE`). Default false.
    pub retrace: bool,
    /// Pixels whose samples answer differently (a hit and a miss, a hit and
    /// the sky) count as reached by no sample. Default false.
    pub retrace_mixed: bool,
}

impl From<UpsampleOptions> for refl_upsample_options {
    fn from(o: UpsampleOptions) -> Self {
        Self {
            depth_threshold: o.depth_threshold,
            depth_sigma: o.depth_sigma,
            normal_power: o.normal_power,
            plane_depth: o.plane_depth,
            shade_hits: o.shade_hits,
            retrace: o.retrace,
            retrace_mixed: o.retrace_mixed,
        }
    }
}

impl From<refl_upsample_options> for UpsampleOptions {
    fn from(o: refl_upsample_options) -> Self {
        Self {
            depth_threshold: o.depth_threshold,
            depth_sigma: o.depth_sigma,
            normal_power: o.normal_power,
            plane_depth: o.plane_depth,
            shade_hits: o.shade_hits,
            retrace: o.retrace,
            retrace_mixed: o.retrace_mixed,
        }
    }
}

/// How a full-resolution pixel was made (the bytes of
/// `refl_upsample_resolve_rows`'s `status`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_upsample_status {
    /// No reflection: not reflective or no surface (its texel says which).
    Skipped = 0,
    /// The block's traced pixel: the sample itself, exactly.
    Copied = 1,
    /// Reconstructed from the samples around it.
    Interpolated = 2,
    /// No sample reaches it: listed for a full-resolution trace; its texel
    /// is `REFL_SSR_STATUS_SKIPPED` with zeros and its color black.
    Retrace = 3,
    /// As `RETRACE`, traced at full resolution by the pass (`retrace`):
    /// what `refl_ssr_trace_rows` gives there.
    Retraced = 4,
}

impl From<UpsampleStatus> for refl_upsample_status {
    fn from(s: UpsampleStatus) -> Self {
        match s {
            UpsampleStatus::Skipped => Self::Skipped,
            UpsampleStatus::Copied => Self::Copied,
            UpsampleStatus::Interpolated => Self::Interpolated,
            UpsampleStatus::Retrace => Self::Retrace,
            UpsampleStatus::Retraced => Self::Retraced,
        }
    }
}

const _: () = {
    use refl_upsample_status as C;
    use UpsampleStatus as R;
    assert!(C::Skipped as u32 == R::Skipped as u32);
    assert!(C::Copied as u32 == R::Copied as u32);
    assert!(C::Interpolated as u32 == R::Interpolated as u32);
    assert!(C::Retrace as u32 == R::Retrace as u32);
    assert!(C::Retraced as u32 == R::Retraced as u32);
};

/// Counts of one `refl_upsample_resolve_rows` call over its band.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_upsample_stats {
    /// Traced pixels copied (`COPIED`).
    pub copied: u32,
    /// Reconstructed pixels (`INTERPOLATED`).
    pub interpolated: u32,
    /// Pixels no sample reached (`RETRACE` and `RETRACED`).
    pub retrace: u32,
    /// Of the listed ones, those written to `retrace` (the first ones in
    /// row-major order; the rest did not fit).
    pub retrace_written: u32,
    /// Of those, the ones traced at full resolution (`RETRACED`).
    pub retraced: u32,
    /// Pixels whose texel is a `REFL_SSR_STATUS_HIT`.
    pub hits: u32,
}

impl From<UpsampleStats> for refl_upsample_stats {
    fn from(s: UpsampleStats) -> Self {
        Self {
            copied: s.copied,
            interpolated: s.interpolated,
            retrace: s.retrace,
            retrace_written: s.retrace_written,
            retraced: s.retraced,
            hits: s.hits,
        }
    }
}

/// The reconstruction's defaults: depth edge 0.1 and sigma 0.05 of the
/// pixel's depth (its own depth compared), normal power 8, reconstructed
/// hits shaded at their interpolated position, unreached pixels listed.
#[no_mangle]
pub extern "C" fn refl_upsample_options_default() -> refl_upsample_options {
    UpsampleOptions::default().into()
}

/// The size of the half-resolution images of a `width x height` frame,
/// `(ceil(width / 2), ceil(height / 2))`, into `*out_width` and
/// `*out_height`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if an output is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` if `width` or `height` is 0 or an output
/// is misaligned. Nothing is written on error.
///
/// # Safety
/// `out_width` and `out_height` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn refl_upsample_half_size(
    out_width: *mut u32,
    out_height: *mut u32,
    width: u32,
    height: u32,
) -> refl_status {
    guard("refl_upsample_half_size", || {
        let ow = Out::new(out_width, "out_width")?;
        let oh = Out::new(out_height, "out_height")?;
        let (w, h) = try_half_size(width, height).map_err(|e| {
            fail(
                e,
                format_args!("the size is {width}x{height}, not at least 1x1"),
            )
        })?;
        // SAFETY: caller contract.
        unsafe {
            ow.write(w);
            oh.write(h);
        }
        Ok(())
    })
}

/// The mirror pass described as for `refl_ssr_trace_rows` (`gbuffer`,
/// `ssr_options`, `scratch`), in two steps so that every required pointer
/// is checked before any value: [`pass_pointers`] (the G-buffer's required
/// images, the method and, for Hi-Z, `scratch`), then [`pass`].
fn pass_pointers(
    g: &refl_gbuffer,
    o: &refl_ssr_options,
    scratch: *const refl_vec2,
) -> Result<refl_core::MirrorOptions, Error> {
    no_nulls(&[
        (g.depth.depth.data.is_null(), "gbuffer.depth.depth.data"),
        (g.normals.data.is_null(), "gbuffer.normals.data"),
    ])?;
    let opts = crate::ssr::options(o)?;
    if opts.method == refl_core::MirrorMethod::HiZ {
        check_pointer(scratch, "scratch")?;
    }
    Ok(opts)
}

/// The pass of [`pass_pointers`]'s options.
///
/// # Safety
/// As `refl_ssr_trace_rows`.
unsafe fn pass<'a>(
    g: &refl_gbuffer,
    opts: refl_core::MirrorOptions,
    scratch: *const refl_vec2,
    scratch_len: usize,
) -> Result<MirrorPass<'a>, Error> {
    // SAFETY: caller contract.
    let gb = unsafe { gbuffer(g) }?;
    // SAFETY: caller contract.
    unsafe { mirror_pass(gb, opts, scratch, scratch_len) }
}

/// Traces one pixel of every 2x2 block (`subsample`) of the rows `rows` of
/// the half-resolution images (`refl_upsample_half_size` of the G-buffer):
/// block `(bx, by)`'s `refl_ssr_texel` goes to `out[by * half_width + bx]`
/// (`out` holds the whole half-resolution image, row stride `half_width`;
/// only the band's rows are written), exactly what `refl_ssr_trace_rows`
/// writes at the block's traced pixel (hit positions in full-resolution
/// pixels); its color to `color` (a half-resolution image) if `color.data`
/// is not NULL (then the G-buffer must have a color); the traced pixels
/// that need the host's tracer to `host` (full-resolution pixels, up to
/// `host_len`, block row-major order; `host` may be NULL with `host_len`
/// 0). The counts go to `*out_stats`. The traced pixel of block `(bx, by)`
/// is `(min(2 bx + s.x, width - 1), min(2 by + s.y, height - 1))` for the
/// block's sub-pixel `s` (`refl_upsample_subsample`).
///
/// The mirror pass is described as for `refl_ssr_trace_rows`: `gbuffer`,
/// `ssr_options`, and the pyramid `refl_ssr_prepare` built in `scratch`
/// (Hi-Z; NULL for stepping). Bands are independent.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `out`, `gbuffer`,
/// `ssr_options`, `subsample`, a required image, (Hi-Z) `scratch`, or
/// `host` with a non-zero `host_len` is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len` is less than the
/// half-resolution texel count, `scratch_len` or an image's `len` is too
/// small; `REFL_STATUS_INVALID_ARGUMENT` for rows reversed or beyond the
/// half height, `color` not of the half size or given without a G-buffer
/// color, an unknown pattern, outputs overlapping each other or the inputs,
/// and the cases of `refl_ssr_trace_rows`. The last-error message names the
/// argument. Nothing is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out` NULL or writable for `out_len`
/// texels; `color.data` NULL or writable for `color.len` texels; `host`
/// NULL or writable for `host_len` entries; `subsample` NULL or readable;
/// the rest as `refl_ssr_trace_rows`. No other thread writes the rows of
/// `out` and `color` this call writes.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_upsample_trace_rows(
    out_stats: *mut refl_ssr_stats,
    out: *mut refl_ssr_texel,
    out_len: usize,
    color: refl_image_vec3_mut,
    host: *mut refl_host_ray,
    host_len: usize,
    gbuffer: *const refl_gbuffer,
    ssr_options: *const refl_ssr_options,
    scratch: *const refl_vec2,
    scratch_len: usize,
    subsample: *const refl_upsample_subsample,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_upsample_trace_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        // SAFETY: caller contract.
        let (g, o, s) = unsafe {
            (
                read(gbuffer, "gbuffer")?,
                read(ssr_options, "ssr_options")?,
                read(subsample, "subsample")?,
            )
        };
        required_outputs(out, host, host_len)?;
        let opts = pass_pointers(&g, &o, scratch)?;
        let sub = self::subsample(&s)?;
        // SAFETY: caller contract.
        let pass = unsafe { self::pass(&g, opts, scratch, scratch_len) }?;
        let half = HalfPass::new(pass, sub);
        // SAFETY: caller contract.
        let mut band = unsafe {
            Band::try_sized(
                out,
                out_len,
                color,
                host,
                host_len,
                &g,
                half.size(),
                rows,
                (scratch as usize, scratch_len.saturating_mul(8)),
                (out_stats as usize, core::mem::size_of::<refl_ssr_stats>()),
            )
        }?;
        let stats = half.try_run_rows(band.rows, &mut band)?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(stats.into()) };
        Ok(())
    })
}

/// The refl-core options of `o`, each field checked against its range.
fn options(o: &refl_upsample_options) -> Result<UpsampleOptions, Error> {
    let bad = |field: &str, v: f32, range: &str| {
        fail(
            Error::InvalidArgument,
            format_args!("`options.{field}` is {v}, not {range}"),
        )
    };
    if !(o.depth_threshold > 0.0) {
        return Err(bad("depth_threshold", o.depth_threshold, "> 0"));
    }
    if !(o.depth_sigma > 0.0) {
        return Err(bad("depth_sigma", o.depth_sigma, "> 0"));
    }
    if !(o.normal_power >= 0.0 && o.normal_power.is_finite()) {
        return Err(bad("normal_power", o.normal_power, "finite and >= 0"));
    }
    let u = UpsampleOptions::from(*o);
    u.try_validate()
        .map_err(|e| fail(e, format_args!("`options` has a value out of range")))?;
    Ok(u)
}

/// `InvalidArgument` naming `name` unless `(width, height)` is `half`, the
/// half size of the G-buffer's `full`.
fn half_size(
    name: &str,
    width: u32,
    height: u32,
    half: (u32, u32),
    full: (u32, u32),
) -> Result<(), Error> {
    if (width, height) == half {
        return Ok(());
    }
    Err(fail(
        Error::InvalidArgument,
        format_args!(
            "`{name}` is {width}x{height}, not the half size {}x{} of the {}x{} G-buffer",
            half.0, half.1, full.0, full.1
        ),
    ))
}

/// The outputs of `refl_upsample_resolve_rows`: texels and colors through
/// the mirror pass's band, statuses and the re-trace list.
struct Sink<'a, 'b> {
    band: Band<'a, refl_ssr_texel>,
    status: Option<ImageViewMut<'b, u8>>,
    retrace: &'b mut [[u32; 2]],
}

impl UpsampleSink for Sink<'_, '_> {
    fn texel(&mut self, x: u32, y: u32, t: &MirrorTexel, color: [f32; 3], s: UpsampleStatus) {
        let v = refl_ssr_texel {
            status: refl_ssr_status::from(t.status) as u32,
            pixel: t.pixel.into(),
            t: t.t,
            confidence: t.confidence,
        };
        self.band.put(x, y, v, color);
        if let Some(p) = self.status.as_mut().and_then(|v| v.get_mut(x, y)) {
            *p = s as u8;
        }
    }

    fn retrace(&mut self, index: u32, x: u32, y: u32) -> bool {
        match self.retrace.get_mut(index as usize) {
            Some(slot) => {
                *slot = [x, y];
                true
            }
            None => false,
        }
    }
}

/// Reconstructs the rows `rows` of the full-resolution image from the
/// half-resolution samples `refl_upsample_trace_rows` traced with the same
/// pass and `subsample`: for each pixel of those rows writes its
/// `refl_ssr_texel` to `out[y * width + x]` (`out` holds the whole image,
/// row stride `width`; only the band's rows are written), its color to
/// `color` if `color.data` is not NULL (then `half_color` is required), its
/// `refl_upsample_status` as a byte to `status` if `status.data` is not
/// NULL, and the pixels no sample reaches (`RETRACE`) to `retrace` as far
/// as `retrace_len` holds them (`retrace` may be NULL with `retrace_len`
/// 0; with `options->retrace` they are traced instead, `RETRACED`, and not
/// listed). The counts go to `*out_stats`. A traced pixel copies its sample;
/// another one takes the samples of the blocks around it weighted by
/// bilinear distance, depth and normal similarity with a hard depth edge
/// (refl-core's `upsample` documents the weights); a reconstructed hit's
/// position, `t` and confidence are interpolated, its status is that of
/// the heaviest sample's class.
///
/// Inputs: the mirror pass as for `refl_ssr_trace_rows` (`gbuffer`,
/// `ssr_options`, `scratch`; the G-buffer is the full-resolution guide);
/// `subsample`; `half`, the half-resolution texels (every texel of the
/// view must hold a `refl_ssr_status`); `half_color`, optional (`data`
/// NULL), their colors (the host's answers may be in them). Bands are
/// independent; each band has its own `retrace` list.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `out`, `gbuffer`,
/// `ssr_options`, `subsample`, `half.data`, `options`, a required
/// G-buffer image, (Hi-Z) `scratch`, or `retrace` with a non-zero
/// `retrace_len` is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len <
/// width * height`, `scratch_len` or an image's `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for an option out of range (NaN
/// included), rows reversed or beyond the height, `half` or `half_color`
/// not of the half size, a `half` texel whose status is not a
/// `refl_ssr_status`, `color` or `status` not of the G-buffer's size,
/// `color` without `half_color` or without a G-buffer color, an unknown
/// pattern, outputs overlapping each other or an input, and the cases of
/// `refl_ssr_trace_rows`. The last-error message names the argument.
/// Nothing is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out` NULL or writable for `out_len`
/// texels; `color.data` NULL or writable for `color.len` texels,
/// `status.data` for `status.len` bytes, `retrace` for `retrace_len`
/// entries; `subsample` and `options` NULL or readable; `half` and
/// `half_color` readable for their `len` texels; the rest as
/// `refl_ssr_trace_rows`. No other thread writes the rows of `out`, `color`
/// and `status` this call writes.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_upsample_resolve_rows(
    out_stats: *mut refl_upsample_stats,
    out: *mut refl_ssr_texel,
    out_len: usize,
    color: refl_image_vec3_mut,
    status: refl_image_u8_mut,
    retrace: *mut refl_image_pixel,
    retrace_len: usize,
    gbuffer: *const refl_gbuffer,
    ssr_options: *const refl_ssr_options,
    scratch: *const refl_vec2,
    scratch_len: usize,
    subsample: *const refl_upsample_subsample,
    half: refl_image_ssr_texel,
    half_color: refl_image_vec3,
    options: *const refl_upsample_options,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_upsample_resolve_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        // Every required pointer before any size: NULL is reported first.
        no_nulls(&[
            (out.is_null(), "out"),
            (retrace.is_null() && retrace_len > 0, "retrace"),
            (gbuffer.is_null(), "gbuffer"),
            (ssr_options.is_null(), "ssr_options"),
            (subsample.is_null(), "subsample"),
            (half.data.is_null(), "half.data"),
            (options.is_null(), "options"),
        ])?;
        // SAFETY: caller contract.
        let (g, so, s, o) = unsafe {
            (
                read(gbuffer, "gbuffer")?,
                read(ssr_options, "ssr_options")?,
                read(subsample, "subsample")?,
                read(options, "options")?,
            )
        };
        let mopts = pass_pointers(&g, &so, scratch)?;
        let sub = self::subsample(&s)?;
        let opts = self::options(&o)?;
        // SAFETY: caller contract.
        let pass = unsafe { self::pass(&g, mopts, scratch, scratch_len) }?;
        let gb = pass.gbuffer();
        let (w, h) = (gb.width(), gb.height());
        let (hw, hh) = try_half_size(w, h)?;

        // The inputs: the half-resolution samples.
        // SAFETY: caller contract.
        let texels = unsafe { half.view("half") }.map_err(|e| {
            let t = &half;
            image_error(e, "half", t.len, t.width, t.height, t.stride)
        })?;
        half_size("half", texels.width(), texels.height(), (hw, hh), (w, h))?;
        let colors = if half_color.data.is_null() {
            None
        } else {
            // SAFETY: caller contract.
            let c = unsafe { half_color.view() }.map_err(|e| {
                let c = &half_color;
                image_error(e, "half_color", c.len, c.width, c.height, c.stride)
            })?;
            half_size("half_color", c.width(), c.height(), (hw, hh), (w, h))?;
            Some(c)
        };
        if !color.data.is_null() && colors.is_none() {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`color` is given without `half_color`"),
            ));
        }

        // The outputs.
        if !status.data.is_null() {
            same_size("status", status.width, status.height, w, h)?;
        }
        // SAFETY: caller contract.
        let list = unsafe { pixel_list(retrace, retrace_len, "retrace") }?;
        let extra = [
            ("half", range(half.data, half.len)),
            ("half_color", image_range(half_color.data, half_color.len)),
            ("scratch", (scratch as usize, scratch_len.saturating_mul(8))),
        ];
        let outs = [
            ("status", image_range(status.data.cast_const(), status.len)),
            ("retrace", image_range(retrace.cast_const(), retrace_len)),
        ];
        let other_outs = [
            ("out", range(out.cast_const(), out_len)),
            ("color", image_range(color.data.cast_const(), color.len)),
            ("out_stats", range(out_stats.cast_const(), 1)),
        ];
        let gr = crate::gbuffer::gbuffer_ranges(&g);
        let ins = [
            ("gbuffer.depth", gr[0]),
            ("gbuffer.normals", gr[1]),
            ("gbuffer.mask", gr[2]),
            ("gbuffer.roughness", gr[3]),
            ("gbuffer.color", gr[4]),
            ("gbuffer.back_depth", gr[5]),
            extra[0],
            extra[1],
            extra[2],
            other_outs[0],
            other_outs[1],
            other_outs[2],
        ];
        named_disjoint(&outs, &ins)?;
        let up = UpsamplePass::try_new(pass, sub, texels, colors, opts)?;
        // The texels, colors and stats: checked as the mirror pass's, and
        // against the half-resolution inputs.
        // SAFETY: caller contract.
        let band = unsafe {
            Band::try_sized(
                out,
                out_len,
                color,
                core::ptr::null_mut(),
                0,
                &g,
                (w, h),
                rows,
                (scratch as usize, scratch_len.saturating_mul(8)),
                (
                    out_stats as usize,
                    core::mem::size_of::<refl_upsample_stats>(),
                ),
            )
        }?;
        named_disjoint(&other_outs, &extra)?;
        let status_v = if status.data.is_null() {
            None
        } else {
            // SAFETY: caller contract (the band's rows writable, not
            // accessed by others during the call); disjoint (checked).
            Some(unsafe { status.band_mut(band.rows) }.map_err(|e| {
                let s = &status;
                image_error(e, "status", s.len, s.width, s.height, s.stride)
            })?)
        };
        let rows = band.rows;
        let mut sink = Sink {
            band,
            status: status_v,
            retrace: list,
        };
        let stats = up.try_run_rows(rows, &mut sink)?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(stats.into()) };
        Ok(())
    })
}
