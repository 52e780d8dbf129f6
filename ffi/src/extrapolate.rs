//! The extrapolation of surfaces (`refl_core::extrapolate`, seed 004 Sec.
//! 4.6.2): a bilateral dilation that fills the reflection of pixels whose
//! ray left the image from the answered pixels around them on the same
//! surface, so that the host traces fewer rays.
//!
//! A frame takes one call per row band after the mirror pass
//! (`refl_ssr_trace_rows`): `refl_extrapolate_options_default` (or your own
//! options), then `refl_extrapolate_fill_rows` from any number of threads,
//! reading the pass's texels and colors and writing the filled colors and
//! the pixels still left to the host.

use crate::gbuffer::{gbuffer, gbuffer_ranges, refl_gbuffer};
use crate::image::{
    pixel_list, refl_image_pixel, refl_image_ssr_texel, refl_image_u8_mut, refl_image_vec3,
    refl_image_vec3_mut, refl_row_range,
};
use crate::ptr::{no_nulls, range, read, Out};
use crate::status::{fail, guard, refl_status};
use crate::temporal::{image_error, image_range, named_disjoint, same_size};
use refl_core::extrapolate::{
    ExtrapolateOptions, ExtrapolatePass, ExtrapolateStats, ExtrapolateStatus,
    MAX_EXTRAPOLATE_RADIUS,
};
use refl_core::Error;

/// The largest `refl_extrapolate_options.radius`.
pub const REFL_EXTRAPOLATE_MAX_RADIUS: u32 = 16;
// A literal above (cbindgen copies the expression into the header), the
// core's value here.
const _: () = assert!(REFL_EXTRAPOLATE_MAX_RADIUS == MAX_EXTRAPOLATE_RADIUS);

/// Settings of the dilation; `refl_extrapolate_options_default` gives the
/// defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_extrapolate_options {
    /// Half-size of the square window searched around a hole, in pixels,
    /// in [1, `REFL_EXTRAPOLATE_MAX_RADIUS`]. Default 4.
    pub radius: u32,
    /// Width of the Gaussian spatial weight in pixels, > 0 (+infinity:
    /// every pixel of the window weighs the same; not NaN). Default 2.
    pub spatial_sigma: f32,
    /// The depth edge, a fraction of the hole's linear depth: pixels
    /// further in depth weigh 0; > 0 (+infinity turns the edge off; not
    /// NaN). Default 0.1.
    pub depth_threshold: f32,
    /// Width of the Gaussian depth weight, a fraction of the hole's depth,
    /// greater than 0, not NaN. Default 0.05.
    pub depth_sigma: f32,
    /// Exponent of the normal weight; finite, >= 0 (0 turns it off).
    /// Default 8.
    pub normal_power: f32,
    /// Holes smoother than this (the G-buffer's roughness; 0 without a
    /// roughness image, NaN counts as smooth) are left to the host; finite,
    /// >= 0 (0 fills every hole). Default 0.
    pub min_roughness: f32,
    /// Fill every status the host would trace, not only rays that left the
    /// image (`REFL_SSR_STATUS_LEFT_IMAGE`). Default false.
    pub all_host_rays: bool,
}

impl From<ExtrapolateOptions> for refl_extrapolate_options {
    fn from(o: ExtrapolateOptions) -> Self {
        Self {
            radius: o.radius,
            spatial_sigma: o.spatial_sigma,
            depth_threshold: o.depth_threshold,
            depth_sigma: o.depth_sigma,
            normal_power: o.normal_power,
            min_roughness: o.min_roughness,
            all_host_rays: o.all_host_rays,
        }
    }
}

impl From<refl_extrapolate_options> for ExtrapolateOptions {
    fn from(o: refl_extrapolate_options) -> Self {
        Self {
            radius: o.radius,
            spatial_sigma: o.spatial_sigma,
            depth_threshold: o.depth_threshold,
            depth_sigma: o.depth_sigma,
            normal_power: o.normal_power,
            min_roughness: o.min_roughness,
            all_host_rays: o.all_host_rays,
        }
    }
}

/// What the dilation did with a pixel (the bytes of
/// `refl_extrapolate_fill_rows`'s `status`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_extrapolate_status {
    /// Not a hole: the input color, unchanged.
    Kept = 0,
    /// A hole filled by the dilation.
    Filled = 1,
    /// A hole no answered pixel reaches: for the host (listed).
    Unfilled = 2,
    /// A hole smoother than `min_roughness`: for the host (listed).
    TooSmooth = 3,
}

impl From<ExtrapolateStatus> for refl_extrapolate_status {
    fn from(s: ExtrapolateStatus) -> Self {
        match s {
            ExtrapolateStatus::Kept => Self::Kept,
            ExtrapolateStatus::Filled => Self::Filled,
            ExtrapolateStatus::Unfilled => Self::Unfilled,
            ExtrapolateStatus::TooSmooth => Self::TooSmooth,
        }
    }
}

const _: () = {
    use refl_extrapolate_status as C;
    use ExtrapolateStatus as R;
    assert!(C::Kept as u32 == R::Kept as u32);
    assert!(C::Filled as u32 == R::Filled as u32);
    assert!(C::Unfilled as u32 == R::Unfilled as u32);
    assert!(C::TooSmooth as u32 == R::TooSmooth as u32);
};

/// Counts of one `refl_extrapolate_fill_rows` call over its band.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_extrapolate_stats {
    /// Holes: pixels with a surface whose ray left the image (or, with
    /// `all_host_rays`, needs the host).
    pub holes: u32,
    /// Holes filled (`FILLED`).
    pub filled: u32,
    /// Holes no answered pixel reaches (`UNFILLED`).
    pub unfilled: u32,
    /// Holes too smooth to fill (`TOO_SMOOTH`).
    pub too_smooth: u32,
    /// Of the unfilled and too smooth holes, those written to `host` (the
    /// first ones in row-major order; the rest did not fit).
    pub host_written: u32,
}

impl From<ExtrapolateStats> for refl_extrapolate_stats {
    fn from(s: ExtrapolateStats) -> Self {
        Self {
            holes: s.holes,
            filled: s.filled,
            unfilled: s.unfilled,
            too_smooth: s.too_smooth,
            host_written: s.host_written,
        }
    }
}

/// The dilation's defaults: radius 4, spatial sigma 2 pixels, depth edge
/// 0.1 and sigma 0.05 of the hole's depth, normal power 8, every hole
/// filled whatever its roughness, only rays that left the image.
#[no_mangle]
pub extern "C" fn refl_extrapolate_options_default() -> refl_extrapolate_options {
    ExtrapolateOptions::default().into()
}

/// The refl-core options of `o`, each field checked against its range
/// (the last-error message names the first one out of it).
fn options(o: &refl_extrapolate_options) -> Result<ExtrapolateOptions, Error> {
    let bad = |field: &str, v: &dyn core::fmt::Display, range: &str| {
        fail(
            Error::InvalidArgument,
            format_args!("`options.{field}` is {v}, not {range}"),
        )
    };
    if !(1..=MAX_EXTRAPOLATE_RADIUS).contains(&o.radius) {
        return Err(bad(
            "radius",
            &o.radius,
            "in [1, REFL_EXTRAPOLATE_MAX_RADIUS]",
        ));
    }
    for (field, v) in [
        ("spatial_sigma", o.spatial_sigma),
        ("depth_threshold", o.depth_threshold),
        ("depth_sigma", o.depth_sigma),
    ] {
        if !(v > 0.0) {
            return Err(bad(field, &v, "> 0"));
        }
    }
    for (field, v) in [
        ("normal_power", o.normal_power),
        ("min_roughness", o.min_roughness),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(bad(field, &v, "finite and >= 0"));
        }
    }
    let e = ExtrapolateOptions::from(*o);
    e.try_validate()
        .map_err(|e| fail(e, format_args!("`options` has a value out of range")))?;
    Ok(e)
}

/// Runs the dilation over the rows `rows` of the G-buffer: for each pixel
/// of those rows writes its color to `out` (the input `color` where it is
/// kept or left to the host, the weighted mean of the answered pixels
/// around it where a hole is filled) and, if `status.data` is not NULL, its
/// `refl_extrapolate_status` as a byte to `status`; only the band's rows of
/// `out` and `status` are written. The holes still for the host (unfilled
/// or too smooth) go to `host` in row-major order as far as `host_len`
/// holds them (`host` may be NULL with `host_len` 0); their texel's status
/// says why the mirror pass did not answer them. The counts go to
/// `*out_stats`. Per pixel (refl-core's `extrapolate` documents each
/// step): a hole is a pixel with a surface whose texel status is
/// `REFL_SSR_STATUS_LEFT_IMAGE` (or any host status with `all_host_rays`);
/// a hole rougher than `min_roughness` takes the mean of the texels within
/// `radius` pixels that answered (`HIT` or `SKY`, finite color, a surface),
/// weighted by a spatial Gaussian and the depth and normal range weights.
///
/// Inputs, each the G-buffer's size: `texels`, the mirror pass's texels
/// (`refl_ssr_trace_rows`'s `out` as an image; every texel of the view
/// must hold a `refl_ssr_status`); `color`, the reflection colors (the
/// pass's `color`, with the host's answers where it has them). Bands are
/// independent: every band reads the whole input; split the rows
/// (`refl_image_row_band`) across threads, each with its own `host` list.
/// `out` must not be `color`: keep the input.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `out.data`, `gbuffer`,
/// `texels.data`, `color.data`, `options`, a required G-buffer image, or
/// `host` with a non-zero `host_len` is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if an image's `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for an option out of range (NaN
/// included), rows reversed or beyond the height, an image (`out`,
/// `status`, `texels`, `color`) not of the G-buffer's size, a zero size or
/// a stride below the width, a texel whose status is not a
/// `refl_ssr_status`, a misaligned pointer, outputs overlapping each other
/// or an input, an unknown convention or normal space; the camera's status
/// if the G-buffer's camera is invalid. The last-error message names the
/// argument. Nothing is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out.data` NULL or writable for `out.len`
/// texels, `status.data` for `status.len` bytes and `host` for `host_len`
/// entries; `gbuffer` and `options` NULL or readable; every other image
/// readable for its `len` texels and not written during the call. No other
/// thread accesses the rows of `out` and `status` this call writes.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_extrapolate_fill_rows(
    out_stats: *mut refl_extrapolate_stats,
    out: refl_image_vec3_mut,
    status: refl_image_u8_mut,
    host: *mut refl_image_pixel,
    host_len: usize,
    gbuffer: *const refl_gbuffer,
    texels: refl_image_ssr_texel,
    color: refl_image_vec3,
    options: *const refl_extrapolate_options,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_extrapolate_fill_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        // Every required pointer before any size: NULL is reported first.
        no_nulls(&[
            (out.data.is_null(), "out.data"),
            (host.is_null() && host_len > 0, "host"),
            (gbuffer.is_null(), "gbuffer"),
            (texels.data.is_null(), "texels.data"),
            (color.data.is_null(), "color.data"),
            (options.is_null(), "options"),
        ])?;
        // SAFETY: caller contract.
        let (g, o) = unsafe { (read(gbuffer, "gbuffer")?, read(options, "options")?) };
        no_nulls(&[
            (g.depth.depth.data.is_null(), "gbuffer.depth.depth.data"),
            (g.normals.data.is_null(), "gbuffer.normals.data"),
        ])?;
        let opts = self::options(&o)?;
        // SAFETY: caller contract.
        let gb = unsafe { self::gbuffer(&g) }?;
        let (w, h) = (gb.width(), gb.height());
        let rows = rows.within(h)?;

        // The inputs, each of the G-buffer's size.
        // SAFETY: caller contract.
        let tex = unsafe { texels.view("texels") }.map_err(|e| {
            let t = &texels;
            image_error(e, "texels", t.len, t.width, t.height, t.stride)
        })?;
        same_size("texels", tex.width(), tex.height(), w, h)?;
        // SAFETY: caller contract.
        let col = unsafe { color.view() }.map_err(|e| {
            let c = &color;
            image_error(e, "color", c.len, c.width, c.height, c.stride)
        })?;
        same_size("color", col.width(), col.height(), w, h)?;

        // The outputs: the G-buffer's size, disjoint from each other and
        // from every input.
        same_size("out", out.width, out.height, w, h)?;
        if !status.data.is_null() {
            same_size("status", status.width, status.height, w, h)?;
        }
        // SAFETY: caller contract.
        let list = unsafe { pixel_list(host, host_len, "host") }?;
        let gr = gbuffer_ranges(&g);
        let ins = [
            ("gbuffer.depth", gr[0]),
            ("gbuffer.normals", gr[1]),
            ("gbuffer.mask", gr[2]),
            ("gbuffer.roughness", gr[3]),
            ("gbuffer.color", gr[4]),
            ("gbuffer.back_depth", gr[5]),
            ("texels", range(texels.data, texels.len)),
            ("color", range(color.data, color.len)),
        ];
        let outs = [
            ("out", range(out.data.cast_const(), out.len)),
            ("status", image_range(status.data.cast_const(), status.len)),
            ("host", image_range(host.cast_const(), host_len)),
            ("out_stats", range(out_stats.cast_const(), 1)),
        ];
        named_disjoint(&outs, &ins)?;
        let pass = ExtrapolatePass::try_new(gb, tex, col, opts)?;
        // SAFETY: caller contract (the band's rows writable, not accessed
        // by others during the call); disjoint from every input (checked).
        let mut out_v = unsafe { out.band_mut(rows) }
            .map_err(|e| image_error(e, "out", out.len, out.width, out.height, out.stride))?;
        let mut status_v = if status.data.is_null() {
            None
        } else {
            // SAFETY: as `out`.
            Some(unsafe { status.band_mut(rows) }.map_err(|e| {
                let s = &status;
                image_error(e, "status", s.len, s.width, s.height, s.stride)
            })?)
        };
        let stats = pass.try_run(&mut out_v, status_v.as_mut(), list)?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(stats.into()) };
        Ok(())
    })
}
