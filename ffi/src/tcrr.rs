//! Temporal reflection reprojection (TCRR, seed 000) exports: reflection
//! buffers and their prepared surfels, the distance function (Fig. 4),
//! neighborhood search (Alg. 2), reflection shifting, warping, the re-trace
//! list, composition and the key-frame policy.
//!
//! One frame after a key frame, per row band (threads may run disjoint
//! bands of one pass at once; every band of a pass must finish before the
//! next pass starts):
//! `refl_tcrr_prepare` (once per key frame) -> `refl_tcrr_search` ->
//! `refl_tcrr_shift` -> `refl_tcrr_warp` -> `refl_tcrr_retrace_list` ->
//! (host traces the listed pixels) -> `refl_tcrr_compose`, and
//! `refl_tcrr_needs_key_frame` on the warp counts. After a key frame fill
//! the offsets with `refl_tcrr_reset_offsets`.

use crate::camera::finite3;
use crate::image::{
    refl_image_f32, refl_image_f32_mut, refl_image_tcrr_surfel, refl_image_tcrr_surfel_mut,
    refl_image_u8, refl_image_u8_mut, refl_image_vec2, refl_image_vec2_mut, refl_image_vec3,
    refl_image_vec3_mut, refl_row_range,
};
use crate::ptr::{read, Out};
use crate::status::{guard, refl_status};
use crate::types::{convention, refl_camera, refl_vec3};
use refl_core::tcrr::{
    self, CurrentView, Fresnel, KeyFramePolicy, Reflected, ReflectionBuffers, TcrrOptions,
};
use refl_core::{Error, RowRange};

/// A key-frame texel back-projected once per key frame
/// (`refl_tcrr_prepare`); layout of refl-core's `tcrr::Surfel`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_tcrr_surfel {
    /// World position of the surface seen through the texel center.
    pub pos: refl_vec3,
    /// Linear depth of that point.
    pub z: f32,
    /// Unit normal.
    pub normal: refl_vec3,
    /// Bits: 1 surface valid, 2 positive specular factor, 4 reflected
    /// distance >= 0 (`REFL_TCRR_SURFEL_*`).
    pub flags: u32,
}

const _: () = {
    use core::mem::{align_of, size_of};
    assert!(size_of::<refl_tcrr_surfel>() == size_of::<tcrr::Surfel>());
    assert!(align_of::<refl_tcrr_surfel>() == align_of::<tcrr::Surfel>());
    assert!(size_of::<refl_tcrr_surfel>() == 32);
    assert!(REFL_TCRR_SURFEL_SURFACE == tcrr::SURFEL_SURFACE);
    assert!(REFL_TCRR_SURFEL_SPECULAR == tcrr::SURFEL_SPECULAR);
    assert!(REFL_TCRR_SURFEL_DISTANCE == tcrr::SURFEL_DISTANCE);
    assert!(REFL_TCRR_COVERAGE_NONE == tcrr::COVERAGE_NONE);
    assert!(REFL_TCRR_COVERAGE_REUSE == tcrr::COVERAGE_REUSE);
    assert!(REFL_TCRR_COVERAGE_EDGE == tcrr::COVERAGE_EDGE);
    assert!(REFL_TCRR_MASK_NONE == tcrr::MASK_NONE);
    assert!(REFL_TCRR_MASK_REUSED == tcrr::MASK_REUSED);
    assert!(REFL_TCRR_MASK_RETRACE == tcrr::MASK_RETRACE);
    assert!(REFL_TCRR_BYTES_PER_PIXEL == 4 + 12 + 4 + 12 + 4 + 32 + 8 + 12 + 4 + 1 + 12 + 1 + 4);
};

/// `refl_tcrr_surfel::flags` bit: the surface fields are valid.
pub const REFL_TCRR_SURFEL_SURFACE: u32 = 1;
/// `refl_tcrr_surfel::flags` bit: positive specular factor.
pub const REFL_TCRR_SURFEL_SPECULAR: u32 = 2;
/// `refl_tcrr_surfel::flags` bit: reflected distance >= 0 (or +inf).
pub const REFL_TCRR_SURFEL_DISTANCE: u32 = 4;

/// Intermediate coverage (`refl_tcrr_shift`): no reflection.
pub const REFL_TCRR_COVERAGE_NONE: u8 = 0;
/// Intermediate coverage: a shifted, reusable reflection.
pub const REFL_TCRR_COVERAGE_REUSE: u8 = 1;
/// Intermediate coverage: next to a moving reflection edge (re-traced).
pub const REFL_TCRR_COVERAGE_EDGE: u8 = 2;
/// Re-trace mask (`refl_tcrr_warp`): not a reflective pixel.
pub const REFL_TCRR_MASK_NONE: u8 = 0;
/// Re-trace mask: reflection reused from the key frame.
pub const REFL_TCRR_MASK_REUSED: u8 = 1;
/// Re-trace mask: the host must trace this pixel's reflection.
pub const REFL_TCRR_MASK_RETRACE: u8 = 2;

/// What `refl_tcrr_reflection_distance`'s `reflected` argument is.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_tcrr_reflected {
    /// A reflected surface point R.
    Point = 0,
    /// The direction of a reflected ray that left the scene (R at
    /// infinity).
    Direction = 1,
}

/// How `refl_tcrr_compose` weights the reflection.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_tcrr_fresnel {
    /// The specular factor itself.
    Off = 0,
    /// Schlick's approximation with the specular factor as reflectance at
    /// normal incidence.
    Schlick = 1,
}

fn fresnel(v: u32) -> Result<Fresnel, Error> {
    match v {
        0 => Ok(Fresnel::Off),
        1 => Ok(Fresnel::Schlick),
        _ => Err(Error::InvalidArgument),
    }
}

/// Settings of the TCRR passes (refl-core `TcrrOptions`); fill with
/// `refl_tcrr_options_default`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_tcrr_options {
    /// Iteration cap of the neighborhood search, >= 1 (default 64).
    pub max_iterations: u32,
    /// Magnification threshold of shifting, finite and >= 1 (seed: 16).
    pub magnification: f32,
    /// Depth-discontinuity tolerance of the reflector's surface, relative
    /// to linear depth; finite, > 0 (default 0.02).
    pub discontinuity: f32,
    /// Discontinuity tolerance of the reflected path `s.d + s.r`, relative;
    /// finite, > 0 (default 0.1).
    pub reflected_discontinuity: f32,
    /// Sub-pixel offsets (default); false: the seed's whole-pixel offsets.
    pub subpixel: bool,
    /// Warping re-traces a pixel whose bilinear taps differ by more than
    /// this in a linear RGB channel (a reflected edge); > 0, +inf turns
    /// the test off (default 0.1).
    pub retrace_contrast: f32,
}

impl TryFrom<&refl_tcrr_options> for TcrrOptions {
    type Error = Error;
    fn try_from(p: &refl_tcrr_options) -> Result<Self, Error> {
        let t = TcrrOptions {
            max_iterations: p.max_iterations,
            magnification: p.magnification,
            discontinuity: p.discontinuity,
            reflected_discontinuity: p.reflected_discontinuity,
            subpixel: p.subpixel,
            retrace_contrast: p.retrace_contrast,
        };
        t.try_validate()?;
        Ok(t)
    }
}

impl From<&TcrrOptions> for refl_tcrr_options {
    fn from(p: &TcrrOptions) -> Self {
        Self {
            max_iterations: p.max_iterations,
            magnification: p.magnification,
            discontinuity: p.discontinuity,
            reflected_discontinuity: p.reflected_discontinuity,
            subpixel: p.subpixel,
            retrace_contrast: p.retrace_contrast,
        }
    }
}

/// The reflection buffers of a key frame (seed 000 Sec. 3.1) and its
/// camera. All images have the camera's size.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_tcrr_key {
    /// The key frame's camera (its eye is `E_old`).
    pub camera: refl_camera,
    /// `refl_depth_convention` of `depth`.
    pub convention: u32,
    /// B.1 depth.
    pub depth: refl_image_f32,
    /// B.1 world-space normal (normalized when read).
    pub normal: refl_image_vec3,
    /// B.2 specular factor, > 0 marks a reflective pixel.
    pub specular: refl_image_f32,
    /// B.3 reflected color (linear RGB).
    pub color: refl_image_vec3,
    /// B.4 reflected distance, +inf where the reflected ray left the scene.
    pub distance: refl_image_f32,
    /// Surfels prepared from these buffers by `refl_tcrr_prepare`, or
    /// `data == NULL` to back-project on the fly (same results, slower).
    pub surfels: refl_image_tcrr_surfel,
}

/// The current frame as TCRR reads it.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_tcrr_current {
    /// The current camera (its eye is `E_cur`).
    pub camera: refl_camera,
    /// `refl_depth_convention` of `depth`.
    pub convention: u32,
    /// Current depth buffer.
    pub depth: refl_image_f32,
    /// Current specular factors, > 0 marks the pixels that need a
    /// reflection.
    pub specular: refl_image_f32,
}

/// Counts of one `refl_tcrr_search` call over its band.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_tcrr_search_stats {
    /// Reflective samples visited.
    pub reflective: u32,
    /// Samples that found a match.
    pub matched: u32,
    /// Samples that recorded the INVALID offset.
    pub invalid: u32,
    /// 3x3 neighborhoods (or fast-path steps) evaluated.
    pub iterations: u64,
}

/// Counts of one `refl_tcrr_shift` call over its band.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_tcrr_shift_stats {
    /// Grid triangles rasterized.
    pub drawn: u32,
    /// Grid triangles discarded by the magnification threshold.
    pub magnified: u32,
    /// Pixels of the band covered at least once.
    pub covered: u32,
}

/// Counts of one `refl_tcrr_warp` call over its band.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_tcrr_warp_stats {
    /// Reflective pixels of the current frame.
    pub reflective: u32,
    /// Pixels whose reflection was reused.
    pub reused: u32,
    /// Pixels marked `REFL_TCRR_MASK_RETRACE`.
    pub retrace: u32,
}

/// Caller-buffer bytes per pixel of one TCRR frame besides the host's own
/// G-buffer: reflection buffers (depth 4, normal 12, specular 4, color 12,
/// distance 4), surfels 32, offsets 8, intermediate color 12, depth 4 and
/// coverage 1, warped color 12, mask 1, re-trace list 4 (worst case).
pub const REFL_TCRR_BYTES_PER_PIXEL: usize = 110;
// The header's constant is refl-core's.
const _: () = assert!(REFL_TCRR_BYTES_PER_PIXEL == tcrr::BYTES_PER_PIXEL);

/// # Safety
/// `p` NULL or readable.
unsafe fn options(p: *const refl_tcrr_options) -> Result<TcrrOptions, Error> {
    // SAFETY: forwarded contract.
    TcrrOptions::try_from(&unsafe { read(p, "options") }?)
        .map_err(|e| crate::status::fail_str(e, "`options` out of range (see refl_tcrr_options)"))
}

/// # Safety
/// `k`'s images readable as described on `refl_tcrr_key` for `'a`.
unsafe fn key_buffers<'a>(k: &refl_tcrr_key) -> Result<ReflectionBuffers<'a>, Error> {
    let cam = crate::types::camera_named(&k.camera, "key.camera")?;
    let conv = convention(k.convention)?;
    // SAFETY: forwarded contract (each view validates its descriptor).
    let b = unsafe {
        ReflectionBuffers::try_new(
            cam,
            conv,
            k.depth.view()?,
            k.normal.view()?,
            k.specular.view()?,
            k.color.view()?,
            k.distance.view()?,
        )
    }?;
    if k.surfels.data.is_null() {
        Ok(b)
    } else {
        // SAFETY: forwarded contract.
        b.try_with_surfels(unsafe { k.surfels.view() }?)
    }
}

/// # Safety
/// `c`'s images readable for `'a`.
unsafe fn current_view<'a>(c: &refl_tcrr_current) -> Result<CurrentView<'a>, Error> {
    let cam = crate::types::camera_named(&c.camera, "current.camera")?;
    let conv = convention(c.convention)?;
    // SAFETY: forwarded contract.
    unsafe { CurrentView::try_new(cam, conv, c.depth.view()?, c.specular.view()?) }
}

/// `refl_tcrr_key` pointer, read and null-checked.
///
/// # Safety
/// `k` NULL or readable.
unsafe fn read_key(k: *const refl_tcrr_key) -> Result<refl_tcrr_key, Error> {
    // SAFETY: forwarded contract.
    unsafe { read(k, "key") }
}

/// The default TCRR settings (iteration cap 64, magnification 16 as in
/// seed 000 Sec. 4.1, discontinuity 0.02, reflected discontinuity 0.1,
/// sub-pixel offsets on, re-trace contrast 0.1).
#[no_mangle]
pub extern "C" fn refl_tcrr_options_default() -> refl_tcrr_options {
    (&TcrrOptions::default()).into()
}

/// Writes to `*out_bytes` the caller-buffer bytes TCRR needs for a
/// `width x height` frame with tightly packed rows
/// (`REFL_TCRR_BYTES_PER_PIXEL` per pixel, see its docs); size each image
/// with `refl_image_required_len`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_bytes` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a zero size or a count that does not
/// fit in `size_t`.
///
/// # Safety
/// `out_bytes` must be NULL or point to a writable `size_t`.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_frame_bytes(
    out_bytes: *mut usize,
    width: u32,
    height: u32,
) -> refl_status {
    guard("refl_tcrr_frame_bytes", || {
        let out = Out::new(out_bytes, "out_bytes")?;
        let n = tcrr::try_frame_bytes(width, height)?;
        // SAFETY: caller contract.
        unsafe { out.write(n) };
        Ok(())
    })
}

/// Writes to `*out` the distance function of seed 000 Fig. 4: the distance
/// from `eye` to the ray that starts at the reflected point R mirrored
/// about the tangent plane through `surface` with normal `normal`
/// (normalized here) and passes through `surface`. `reflected` is R for
/// `kind == REFL_TCRR_REFLECTED_POINT`, or the direction of a reflected ray
/// that left the scene for `REFL_TCRR_REFLECTED_DIRECTION`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for non-finite input or an unknown
/// `kind`; `REFL_STATUS_DEGENERATE_GEOMETRY` where the function is
/// undefined (zero normal, R on or behind the tangent plane, the eye on or
/// behind it).
///
/// # Safety
/// `out` must be NULL or point to a writable `float`.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_reflection_distance(
    out: *mut f32,
    eye: refl_vec3,
    surface: refl_vec3,
    normal: refl_vec3,
    reflected: refl_vec3,
    kind: u32,
) -> refl_status {
    guard("refl_tcrr_reflection_distance", || {
        let out = Out::new(out, "out")?;
        let (e, w, n, r) = (
            finite3(eye)?,
            finite3(surface)?,
            finite3(normal)?,
            finite3(reflected)?,
        );
        let r = match kind {
            0 => Reflected::Point(r),
            1 => Reflected::Direction(r),
            _ => return Err(Error::InvalidArgument),
        };
        let d = tcrr::reflection_distance(e, w, n, r).ok_or(Error::DegenerateGeometry)?;
        // SAFETY: caller contract.
        unsafe { out.write(d) };
        Ok(())
    })
}

/// Back-projects rows `[rows.begin, rows.end)` of the key frame into
/// `surfels` (once per key frame, before the frame's first search) and
/// writes to `*out_reflective` (if not NULL) the number of reflective
/// samples in those rows. Attach the image as `key.surfels` afterwards; the
/// `key.surfels` given here is ignored.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `key` or an image's data is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an invalid camera or descriptor, an
/// unknown convention, images of different sizes or a bad row range;
/// `REFL_STATUS_INSUFFICIENT_SIZE` for a short buffer. Nothing is written
/// then.
///
/// # Safety
/// `key` must be NULL or readable and its images readable as described;
/// `surfels` writable for its rows `rows`; `out_reflective` NULL or
/// writable.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_prepare(
    surfels: refl_image_tcrr_surfel_mut,
    out_reflective: *mut u32,
    key: *const refl_tcrr_key,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_tcrr_prepare", || {
        // Checked before anything is written (an error leaves every output
        // untouched).
        let out_reflective_checked = Out::optional(out_reflective, "out_reflective")?;
        crate::ptr::no_nulls(&[(surfels.data.is_null(), "surfels.data")])?;
        // SAFETY: caller contract.
        let mut k = unsafe { read_key(key) }?;
        k.surfels.data = core::ptr::null();
        // SAFETY: caller contract.
        let b = unsafe { key_buffers(&k) }?;
        let rows = RowRange::try_new(rows.begin, rows.end, surfels.height)?;
        // SAFETY: caller contract.
        let mut v = unsafe { surfels.band_mut(rows) }?;
        if v.width() != b.width() || v.height() != b.height() {
            return Err(Error::InvalidArgument);
        }
        let n = tcrr::try_prepare(&mut v, &b)?;
        if let Some(o) = out_reflective_checked {
            // SAFETY: caller contract.
            unsafe { o.write(n) };
        }
        Ok(())
    })
}

/// Fills rows `[rows.begin, rows.end)` of an offset image with the INVALID
/// offset (+inf, +inf): after a key frame, so the next search starts at
/// each pixel itself (seed 000 Alg. 2).
///
/// Returns `REFL_STATUS_NULL_POINTER` for a NULL `offsets.data`;
/// `REFL_STATUS_INVALID_ARGUMENT` / `REFL_STATUS_INSUFFICIENT_SIZE` for a
/// bad descriptor or row range.
///
/// # Safety
/// `offsets` must be writable for the rows.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_reset_offsets(
    offsets: refl_image_vec2_mut,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_tcrr_reset_offsets", || {
        crate::ptr::no_nulls(&[(offsets.data.is_null(), "offsets.data")])?;
        let rows = RowRange::try_new(rows.begin, rows.end, offsets.height)?;
        // SAFETY: caller contract.
        let mut v = unsafe { offsets.band_mut(rows) }?;
        v.fill(tcrr::INVALID_OFFSET);
        Ok(())
    })
}

/// Neighborhood search (seed 000 Alg. 2) over rows `[rows.begin,
/// rows.end)`: on entry `offsets` holds the previous frame's offsets, on
/// return the offsets from each key-frame pixel to its match for the
/// current eye `eye` (INVALID, i.e. non-finite, where none). Counts go to
/// `*out_stats` if it is not NULL.
///
/// Returns `REFL_STATUS_NULL_POINTER` for NULL `key`, `options` or image
/// data; `REFL_STATUS_INVALID_ARGUMENT` for a bad camera, convention,
/// descriptor, size mismatch, row range, non-finite `eye` or parameter
/// out of range; `REFL_STATUS_INSUFFICIENT_SIZE` for a short buffer.
/// `offsets` is untouched then.
///
/// # Safety
/// Pointers NULL or valid; images valid as described; the rows of
/// `offsets` not accessed by another thread during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_search(
    offsets: refl_image_vec2_mut,
    out_stats: *mut refl_tcrr_search_stats,
    key: *const refl_tcrr_key,
    eye: refl_vec3,
    options: *const refl_tcrr_options,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_tcrr_search", || {
        // Checked before anything is written (an error leaves every output
        // untouched).
        let out_stats_checked = Out::optional(out_stats, "out_stats")?;
        crate::ptr::no_nulls(&[
            (offsets.data.is_null(), "offsets.data"),
            (key.is_null(), "key"),
            (options.is_null(), "options"),
        ])?;
        // SAFETY: caller contract.
        let k = unsafe { read_key(key) }?;
        // SAFETY: caller contract.
        let p = unsafe { self::options(options) }?;
        // SAFETY: caller contract.
        let b = unsafe { key_buffers(&k) }?;
        let eye = finite3(eye)?;
        let rows = RowRange::try_new(rows.begin, rows.end, offsets.height)?;
        // SAFETY: caller contract.
        let mut v = unsafe { offsets.band_mut(rows) }?;
        let s = tcrr::try_search(&mut v, &b, eye, &p)?;
        if let Some(o) = out_stats_checked {
            // SAFETY: caller contract.
            unsafe {
                o.write(refl_tcrr_search_stats {
                    reflective: s.reflective,
                    matched: s.matched,
                    invalid: s.invalid,
                    iterations: s.iterations,
                })
            };
        }
        Ok(())
    })
}

/// Reflection shifting (seed 000 Sec. 3.2.2) into rows `[rows.begin,
/// rows.end)` of the intermediate image: the key frame's grid mesh moved by
/// `offsets` and rasterized with the depth test on `s.d + s.r`, cut at
/// discontinuities, magnified triangles discarded. The three outputs are
/// cleared over the rows first. Counts go to `*out_stats` if not NULL.
///
/// Returns as `refl_tcrr_search` (outputs untouched on error).
///
/// # Safety
/// As `refl_tcrr_search`; the rows of the three outputs not accessed by
/// another thread during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_shift(
    color: refl_image_vec3_mut,
    depth: refl_image_f32_mut,
    coverage: refl_image_u8_mut,
    out_stats: *mut refl_tcrr_shift_stats,
    key: *const refl_tcrr_key,
    offsets: refl_image_vec2,
    options: *const refl_tcrr_options,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_tcrr_shift", || {
        // Checked before anything is written (an error leaves every output
        // untouched).
        let out_stats_checked = Out::optional(out_stats, "out_stats")?;
        crate::ptr::no_nulls(&[
            (color.data.is_null(), "color.data"),
            (depth.data.is_null(), "depth.data"),
            (coverage.data.is_null(), "coverage.data"),
            (offsets.data.is_null(), "offsets.data"),
            (key.is_null(), "key"),
            (options.is_null(), "options"),
        ])?;
        // SAFETY: caller contract.
        let k = unsafe { read_key(key) }?;
        // SAFETY: caller contract.
        let p = unsafe { self::options(options) }?;
        // SAFETY: caller contract.
        let b = unsafe { key_buffers(&k) }?;
        // SAFETY: caller contract.
        let ov = unsafe { offsets.view() }?;
        let r = RowRange::try_new(rows.begin, rows.end, color.height)?;
        // SAFETY: caller contract (three distinct images).
        let (mut c, mut d, mut v) = unsafe {
            (
                color.band_mut(r)?,
                depth.band_mut(r)?,
                coverage.band_mut(r)?,
            )
        };
        let s = tcrr::try_shift(&mut c, &mut d, &mut v, &b, &ov, &p)?;
        if let Some(o) = out_stats_checked {
            // SAFETY: caller contract.
            unsafe {
                o.write(refl_tcrr_shift_stats {
                    drawn: s.drawn,
                    magnified: s.magnified,
                    covered: s.covered,
                })
            };
        }
        Ok(())
    })
}

/// Warping (seed 000 Sec. 3.3) of the intermediate image (`source`,
/// `source_depth`, `coverage` from `refl_tcrr_shift`) into rows
/// `[rows.begin, rows.end)` of the current view: `color` gets the reused
/// reflection, `mask` `REFL_TCRR_MASK_{NONE,REUSED,RETRACE}`. For the
/// naive baseline pass the key frame's own colors, `s.d + s.r` and its
/// reflective mask (coverage 1), with `options->retrace_contrast = +inf`. Counts go to `*out_stats` if not NULL.
///
/// Returns as `refl_tcrr_search`, also for NULL `current` (outputs
/// untouched on error).
///
/// # Safety
/// As `refl_tcrr_search`; the rows of `color` and `mask` not accessed by
/// another thread during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_warp(
    color: refl_image_vec3_mut,
    mask: refl_image_u8_mut,
    out_stats: *mut refl_tcrr_warp_stats,
    current: *const refl_tcrr_current,
    key: *const refl_tcrr_key,
    source: refl_image_vec3,
    source_depth: refl_image_f32,
    coverage: refl_image_u8,
    options: *const refl_tcrr_options,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_tcrr_warp", || {
        // Checked before anything is written (an error leaves every output
        // untouched).
        let out_stats_checked = Out::optional(out_stats, "out_stats")?;
        crate::ptr::no_nulls(&[
            (color.data.is_null(), "color.data"),
            (mask.data.is_null(), "mask.data"),
            (current.is_null(), "current"),
            (key.is_null(), "key"),
            (options.is_null(), "options"),
        ])?;
        // SAFETY: caller contract.
        let (k, cur) = unsafe { (read_key(key)?, read(current, "current")?) };
        // SAFETY: caller contract.
        let p = unsafe { self::options(options) }?;
        // SAFETY: caller contract.
        let b = unsafe { key_buffers(&k) }?;
        // SAFETY: caller contract.
        let cv = unsafe { current_view(&cur) }?;
        // SAFETY: caller contract.
        let (sv, sd, cov) = unsafe { (source.view()?, source_depth.view()?, coverage.view()?) };
        let r = RowRange::try_new(rows.begin, rows.end, color.height)?;
        // SAFETY: caller contract (two distinct images).
        let (mut c, mut m) = unsafe { (color.band_mut(r)?, mask.band_mut(r)?) };
        let s = tcrr::try_warp(&mut c, &mut m, &cv, &b, &sv, &sd, &cov, &p)?;
        if let Some(o) = out_stats_checked {
            // SAFETY: caller contract.
            unsafe {
                o.write(refl_tcrr_warp_stats {
                    reflective: s.reflective,
                    reused: s.reused,
                    retrace: s.retrace,
                })
            };
        }
        Ok(())
    })
}

/// Writes the pixel indices `y * width + x` of the `REFL_TCRR_MASK_RETRACE`
/// pixels of `mask`, row-major, to `list[0..n)` and their number `n` to
/// `*out_len` (the compact list for the host's ray tracer). With `list`
/// NULL only the number is written (size query).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_len` or `mask.data` is
/// NULL; `REFL_STATUS_INVALID_ARGUMENT` for a bad descriptor or an image
/// with more than 2^32 pixels; `REFL_STATUS_INSUFFICIENT_SIZE` (nothing
/// written) if `list_len` is below the number of pixels.
///
/// # Safety
/// `list` NULL or writable for `list_len` `uint32_t`; `out_len` NULL or
/// writable; `mask` readable.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_retrace_list(
    list: *mut u32,
    list_len: usize,
    out_len: *mut usize,
    mask: refl_image_u8,
) -> refl_status {
    guard("refl_tcrr_retrace_list", || {
        let out = Out::new(out_len, "out_len")?;
        // SAFETY: caller contract.
        let m = unsafe { mask.view() }?;
        let n = if list.is_null() {
            if u64::from(m.width()) * u64::from(m.height()) > u64::from(u32::MAX) {
                return Err(Error::InvalidArgument);
            }
            tcrr::retrace_count(&m)
        } else {
            if !list.is_aligned() {
                return Err(Error::InvalidArgument);
            }
            crate::ptr::byte_len::<u32>(list as usize, list_len)?;
            // SAFETY: non-null, aligned, `list_len` writable by contract.
            let l = unsafe { core::slice::from_raw_parts_mut(list, list_len) };
            tcrr::try_retrace_list(l, &m)?
        };
        // SAFETY: caller contract.
        unsafe { out.write(n) };
        Ok(())
    })
}

/// Output composition (seed 000 Sec. 3.3) over rows `[rows.begin,
/// rows.end)`: `out = (1 - w) diffuse + w reflection` at the current
/// frame's reflective pixels (a positive specular factor where the
/// current depth holds a surface: it decodes to a positive distance in
/// front of the far plane, and the world point at the pixel center,
/// `refl_camera_unproject`, is finite), `w` the specular factor (`fresnel ==
/// REFL_TCRR_FRESNEL_OFF`) or Schlick's Fresnel term of it
/// (`REFL_TCRR_FRESNEL_SCHLICK`) with `cos = n . normalize(E_cur - P)`;
/// `out = diffuse` elsewhere (background pixels included, whatever their
/// specular factor).
///
/// Returns `REFL_STATUS_NULL_POINTER` for NULL `current` or image data;
/// `REFL_STATUS_INVALID_ARGUMENT` for an unknown `fresnel`, a bad camera,
/// descriptor, size mismatch or row range;
/// `REFL_STATUS_INSUFFICIENT_SIZE` for a short buffer. `out` is untouched
/// then.
///
/// # Safety
/// Images valid as described; the rows of `out` not accessed by another
/// thread during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_compose(
    out: refl_image_vec3_mut,
    diffuse: refl_image_vec3,
    reflection: refl_image_vec3,
    normal: refl_image_vec3,
    current: *const refl_tcrr_current,
    fresnel: u32,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_tcrr_compose", || {
        crate::ptr::no_nulls(&[
            (out.data.is_null(), "out.data"),
            (current.is_null(), "current"),
        ])?;
        // SAFETY: caller contract.
        let cur = unsafe { read(current, "current") }?;
        let mode = self::fresnel(fresnel)?;
        // SAFETY: caller contract.
        let cv = unsafe { current_view(&cur) }?;
        // SAFETY: caller contract.
        let (d, r, n) = unsafe { (diffuse.view()?, reflection.view()?, normal.view()?) };
        let rr = RowRange::try_new(rows.begin, rows.end, out.height)?;
        // SAFETY: caller contract.
        let mut o = unsafe { out.band_mut(rr) }?;
        tcrr::try_compose(&mut o, &d, &r, &n, &cv, mode)
    })
}

/// Writes to `*out` the reflection weight of `refl_tcrr_compose` for
/// specular factor `f` and `cos_theta` (both clamped to [0, 1]; 0 for
/// `f <= 0` or NaN).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an unknown `fresnel`.
///
/// # Safety
/// `out` must be NULL or point to a writable `float`.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_fresnel_weight(
    out: *mut f32,
    f: f32,
    cos_theta: f32,
    fresnel: u32,
) -> refl_status {
    guard("refl_tcrr_fresnel_weight", || {
        let out = Out::new(out, "out")?;
        let w = tcrr::fresnel_weight(f, cos_theta, self::fresnel(fresnel)?);
        // SAFETY: caller contract.
        unsafe { out.write(w) };
        Ok(())
    })
}

/// The key-frame policy of seed 000 Sec. 4.3/4.4: writes true to `*out`
/// if `retrace` re-traced pixels out of `reflective` exceed the share
/// `threshold` (0.3 in the seed), else false (always false without
/// reflective pixels).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a threshold outside [0, 1] or NaN,
/// or `retrace > reflective`.
///
/// # Safety
/// `out` must be NULL or point to a writable `bool`.
#[no_mangle]
pub unsafe extern "C" fn refl_tcrr_needs_key_frame(
    out: *mut bool,
    threshold: f32,
    retrace: u64,
    reflective: u64,
) -> refl_status {
    guard("refl_tcrr_needs_key_frame", || {
        let out = Out::new(out, "out")?;
        let p = KeyFramePolicy::try_new(threshold)?;
        if retrace > reflective {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: caller contract.
        unsafe { out.write(p.needs_key_frame(retrace, reflective)) };
        Ok(())
    })
}
