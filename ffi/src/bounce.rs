//! Approximate multiple reflection bounces (`refl_core::bounce`, seed 004
//! Sec. 4.6.4, Listing 4.9): the source color the reflection pass reads
//! this frame is the previous frame's final image (reflections included),
//! re-projected into this frame and validated by depth, so that a mirror
//! seen in a mirror shows that mirror's reflection, one bounce more every
//! frame.
//!
//! A frame takes one call per row band before the reflection pass:
//! `refl_bounce_options_default` (or your own options), then
//! `refl_bounce_source_rows` from any number of threads, reading this
//! frame's G-buffer (its `color` the lit color without reflections) and
//! the previous frame's final image with its depth (`refl_bounce_previous`),
//! writing the source image the host then gives the reflection pass as its
//! G-buffer's `color`. On the first frame, or after a cut, the source is
//! the lit color itself.

use crate::gbuffer::{gbuffer, gbuffer_ranges, refl_gbuffer};
use crate::image::{refl_image_u8_mut, refl_image_vec3, refl_image_vec3_mut, refl_row_range};
use crate::ptr::{no_nulls, range, read, Out};
use crate::status::{fail, guard, refl_status};
use crate::temporal::{image_error, image_range, named_disjoint, same_size};
use crate::trace::{depth_image, refl_depth_image};
use refl_core::bounce::{BounceOptions, BouncePass, BounceStats, BounceStatus, PreviousFrame};
use refl_core::Error;

/// The previous frame's final image (reflections composed in) with the
/// depth image it was rendered with.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_bounce_previous {
    /// The previous frame's depth, camera and convention. The camera may
    /// differ from this frame's in pose, field of view, planes and size
    /// (that is the re-projection).
    pub depth: refl_depth_image,
    /// The previous frame's final color (linear RGB), of the previous
    /// camera's size.
    pub color: refl_image_vec3,
}

/// Settings of the bounce pass; `refl_bounce_options_default` gives the
/// defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_bounce_options {
    /// Weight of the previous final image in the source, in [0, 1]:
    /// `source = lit + attenuation (previous - lit)`. 1 is the seed's demo,
    /// 0 one bounce (`source = lit`). Default 1.
    pub attenuation: f32,
    /// Relative tolerance of the validation, finite, >= 0: a previous texel
    /// is kept when its surface point lies within `depth_tolerance` times
    /// its depth in the previous camera of the current surface's tangent
    /// plane. Default 0.02.
    pub depth_tolerance: f32,
}

impl From<BounceOptions> for refl_bounce_options {
    fn from(o: BounceOptions) -> Self {
        Self {
            attenuation: o.attenuation,
            depth_tolerance: o.depth_tolerance,
        }
    }
}

impl From<refl_bounce_options> for BounceOptions {
    fn from(o: refl_bounce_options) -> Self {
        Self {
            attenuation: o.attenuation,
            depth_tolerance: o.depth_tolerance,
        }
    }
}

/// Where a pixel's source color came from (the bytes of
/// `refl_bounce_source_rows`'s `status`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_bounce_status {
    /// No usable surface (sky, NaN depth, unusable normal): `lit`.
    NoSurface = 0,
    /// Re-projected into the previous frame and validated: `lit +
    /// attenuation (previous - lit)` (`lit` itself where `lit` is not
    /// finite or the blend overflows).
    Reprojected = 1,
    /// Behind the previous camera or outside its image: `lit`.
    OffScreen = 2,
    /// Every previous texel around the re-projection was rejected
    /// (disoccluded, no surface, non-finite color): `lit`.
    Rejected = 3,
}

impl From<BounceStatus> for refl_bounce_status {
    fn from(s: BounceStatus) -> Self {
        match s {
            BounceStatus::NoSurface => Self::NoSurface,
            BounceStatus::Reprojected => Self::Reprojected,
            BounceStatus::OffScreen => Self::OffScreen,
            BounceStatus::Rejected => Self::Rejected,
        }
    }
}

const _: () = {
    use refl_bounce_status as C;
    use BounceStatus as R;
    assert!(C::NoSurface as u32 == R::NoSurface as u32);
    assert!(C::Reprojected as u32 == R::Reprojected as u32);
    assert!(C::OffScreen as u32 == R::OffScreen as u32);
    assert!(C::Rejected as u32 == R::Rejected as u32);
};

/// Counts of one `refl_bounce_source_rows` call over its band.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_bounce_stats {
    /// Pixels that read the previous final image (`REPROJECTED`).
    pub reprojected: u32,
    /// Pixels whose previous texels were all rejected (`REJECTED`).
    pub rejected: u32,
    /// Pixels re-projected behind the previous camera or outside its image
    /// (`OFF_SCREEN`).
    pub off_screen: u32,
    /// Pixels without a usable surface (`NO_SURFACE`).
    pub no_surface: u32,
}

impl From<BounceStats> for refl_bounce_stats {
    fn from(s: BounceStats) -> Self {
        Self {
            reprojected: s.reprojected,
            rejected: s.rejected,
            off_screen: s.off_screen,
            no_surface: s.no_surface,
        }
    }
}

/// The pass's defaults: the previous final image as it is (attenuation 1,
/// the seed's demo), previous texels kept within 2% of their depth of the
/// current surface's tangent plane.
#[no_mangle]
pub extern "C" fn refl_bounce_options_default() -> refl_bounce_options {
    BounceOptions::default().into()
}

/// The refl-core options of `o`, each field checked against its range.
fn options(o: &refl_bounce_options) -> Result<BounceOptions, Error> {
    if !(0.0..=1.0).contains(&o.attenuation) {
        return Err(fail(
            Error::InvalidArgument,
            format_args!("`options.attenuation` is {}, not in [0, 1]", o.attenuation),
        ));
    }
    if !(o.depth_tolerance >= 0.0 && o.depth_tolerance.is_finite()) {
        return Err(fail(
            Error::InvalidArgument,
            format_args!(
                "`options.depth_tolerance` is {}, not finite and >= 0",
                o.depth_tolerance
            ),
        ));
    }
    let b = BounceOptions::from(*o);
    b.try_validate()
        .map_err(|e| fail(e, format_args!("`options` has a value out of range")))?;
    Ok(b)
}

/// Runs the bounce pass over the rows `rows` of the G-buffer: for each
/// pixel of those rows writes its source color to `out` and, if
/// `status.data` is not NULL, its `refl_bounce_status` as a byte to
/// `status`; only the band's rows of `out` and `status` are written. The
/// counts go to `*out_stats`. Per pixel (refl-core's `bounce` documents
/// each step): the pixel's world point is projected into the previous
/// camera; the 2x2 previous texels around it are kept if their depth is a
/// surface, their color finite and their point on the current surface's
/// tangent plane (`depth_tolerance`); if they carry enough of the bilinear
/// weight the source is `lit + attenuation (previous - lit)`, else `lit`.
///
/// `gbuffer` is this frame's, with its `color` the lit color without
/// reflections (required). `previous` is the image the host composed last
/// frame, reflections included, with that frame's depth and camera; its
/// size may differ from this frame's. `out` and `status` have the
/// G-buffer's size. `out` is this frame's source, not the previous color
/// or the lit color: keep two final images and swap them. Bands are
/// independent: split the rows (`refl_image_row_band`) across threads.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `out.data`,
/// `gbuffer`, `previous`, `options`, a required G-buffer image, the
/// G-buffer's `color.data`, or the previous depth or color data is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if an image's `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for an option out of range (NaN
/// included), rows reversed or beyond the height, `out` or `status` not of
/// the G-buffer's size, the previous color not of the previous camera's
/// size, a zero size or a stride below the width, a misaligned pointer,
/// outputs overlapping each other or an input, an unknown convention or
/// normal space; the camera's status if the G-buffer's or the previous
/// camera is invalid. The last-error message names the argument. Nothing
/// is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out.data` NULL or writable for `out.len`
/// texels and `status.data` for `status.len` bytes; `gbuffer`, `previous`
/// and `options` NULL or readable; every other image readable for its
/// `len` texels and not written during the call. No other thread accesses
/// the rows of `out` and `status` this call writes.
#[no_mangle]
pub unsafe extern "C" fn refl_bounce_source_rows(
    out_stats: *mut refl_bounce_stats,
    out: refl_image_vec3_mut,
    status: refl_image_u8_mut,
    gbuffer: *const refl_gbuffer,
    previous: *const refl_bounce_previous,
    options: *const refl_bounce_options,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_bounce_source_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        // Every required pointer before any size: NULL is reported first.
        no_nulls(&[
            (out.data.is_null(), "out.data"),
            (gbuffer.is_null(), "gbuffer"),
            (previous.is_null(), "previous"),
            (options.is_null(), "options"),
        ])?;
        // SAFETY: caller contract.
        let (g, prev, o) = unsafe {
            (
                read(gbuffer, "gbuffer")?,
                read(previous, "previous")?,
                read(options, "options")?,
            )
        };
        no_nulls(&[
            (g.depth.depth.data.is_null(), "gbuffer.depth.depth.data"),
            (g.normals.data.is_null(), "gbuffer.normals.data"),
            (g.color.data.is_null(), "gbuffer.color.data"),
            (prev.depth.depth.data.is_null(), "previous.depth.depth.data"),
            (prev.color.data.is_null(), "previous.color.data"),
        ])?;
        let opts = self::options(&o)?;
        // SAFETY: caller contract.
        let gb = unsafe { self::gbuffer(&g) }?;
        let (w, h) = (gb.width(), gb.height());
        let rows = rows.within(h)?;

        // The previous frame: its color of its camera's size.
        let pcam = crate::types::camera_named(&prev.depth.camera, "previous.depth.camera")?;
        let pd = &prev.depth.depth;
        same_size(
            "previous.depth.depth",
            pd.width,
            pd.height,
            pcam.width(),
            pcam.height(),
        )?;
        let c = prev.depth.convention;
        crate::types::convention(c).map_err(|e| {
            fail(
                e,
                format_args!("`previous.depth.convention` is {c}, not a refl_depth_convention"),
            )
        })?;
        // SAFETY: caller contract.
        let pdepth = unsafe { depth_image(&prev.depth) }.map_err(|e| {
            let d = &prev.depth.depth;
            image_error(
                e,
                "previous.depth.depth",
                d.len,
                d.width,
                d.height,
                d.stride,
            )
        })?;
        // SAFETY: caller contract.
        let pcolor = unsafe { prev.color.view() }.map_err(|e| {
            let c = &prev.color;
            image_error(e, "previous.color", c.len, c.width, c.height, c.stride)
        })?;
        same_size(
            "previous.color",
            pcolor.width(),
            pcolor.height(),
            pcam.width(),
            pcam.height(),
        )?;
        let previous = PreviousFrame::try_new(pdepth, pcolor)?;

        // The outputs: the G-buffer's size, disjoint from each other and
        // from every input.
        same_size("out", out.width, out.height, w, h)?;
        if !status.data.is_null() {
            same_size("status", status.width, status.height, w, h)?;
        }
        let gr = gbuffer_ranges(&g);
        let ins = [
            ("gbuffer.depth", gr[0]),
            ("gbuffer.normals", gr[1]),
            ("gbuffer.mask", gr[2]),
            ("gbuffer.roughness", gr[3]),
            ("gbuffer.color", gr[4]),
            ("gbuffer.back_depth", gr[5]),
            (
                "previous.depth",
                range(prev.depth.depth.data, prev.depth.depth.len),
            ),
            ("previous.color", range(prev.color.data, prev.color.len)),
        ];
        let outs = [
            ("out", range(out.data.cast_const(), out.len)),
            ("status", image_range(status.data.cast_const(), status.len)),
            ("out_stats", range(out_stats.cast_const(), 1)),
        ];
        named_disjoint(&outs, &ins)?;
        let pass = BouncePass::try_new(gb, previous, opts)?;
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
        let stats = pass.try_run(&mut out_v, status_v.as_mut())?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(stats.into()) };
        Ok(())
    })
}
