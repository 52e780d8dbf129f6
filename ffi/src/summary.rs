//! The frame summary (`refl_core::summary`, issue 15 part 1): one pass
//! over a G-buffer, by row bands on tile rows, that counts reflective
//! pixels per object and roughness class, border contact and 8x8 tile
//! classes, and accumulates what the plane test of each object needs; the
//! measurements a planner reads before it picks methods and skips passes.

use crate::gbuffer::{gbuffer, gbuffer_ranges, refl_gbuffer};
use crate::image::{refl_image_u32, refl_row_range};
use crate::ptr::{byte_len, check_pointer, disjoint, range, read, slice_mut_or_empty, Out};
use crate::status::{fail, guard, refl_status};
use refl_core::summary::{
    try_summarize_rows, FrameSummary, ObjectSummary, SummaryOptions, NO_OBJECT, TILE,
};
use refl_core::Error;

/// Side of a classification tile in pixels: bands of
/// `refl_summarize_rows` start on a multiple of it.
pub const REFL_SUMMARY_TILE: u32 = 8;

/// The object id of a pixel that belongs to no object.
pub const REFL_SUMMARY_NO_OBJECT: u32 = 0xFFFF_FFFF;

const _: () = assert!(REFL_SUMMARY_TILE == TILE && REFL_SUMMARY_NO_OBJECT == NO_OBJECT);

/// Settings of the summary (`refl_core::summary::SummaryOptions`);
/// `refl_summary_options_default` gives the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_summary_options {
    /// Upper roughness bound of the mirror class, finite, >= 0. Default
    /// 0.1 (the mirror pass's `max_roughness`).
    pub mirror_roughness: f32,
    /// Upper roughness bound of the glossy class, >= `mirror_roughness`,
    /// +infinity allowed; rougher pixels are left to a probe. Default 1.0
    /// (the glossy pass's `max_roughness`).
    pub glossy_roughness: f32,
    /// Reflective pixels within this many pixels of the border count as
    /// touching it. Default `REFL_SUMMARY_TILE`.
    pub border_pixels: u32,
    /// Plane test: RMS distance of the points from their plane relative to
    /// their mean depth, finite, >= 0. Default 1e-3.
    pub plane_tolerance: f32,
    /// Plane test: least length of the mean of the unit normals, in
    /// [0, 1]. Default 0.99.
    pub normal_cos: f32,
}

impl From<refl_summary_options> for SummaryOptions {
    fn from(o: refl_summary_options) -> Self {
        Self {
            mirror_roughness: o.mirror_roughness,
            glossy_roughness: o.glossy_roughness,
            border_pixels: o.border_pixels,
            plane_tolerance: o.plane_tolerance,
            normal_cos: o.normal_cos,
        }
    }
}

impl From<SummaryOptions> for refl_summary_options {
    fn from(o: SummaryOptions) -> Self {
        Self {
            mirror_roughness: o.mirror_roughness,
            glossy_roughness: o.glossy_roughness,
            border_pixels: o.border_pixels,
            plane_tolerance: o.plane_tolerance,
            normal_cos: o.normal_cos,
        }
    }
}

/// Counts over the bands summarized so far (zero-initialize before the
/// first band). Roughness classes are indexed 0 mirror, 1 glossy, 2 rough.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_frame_summary {
    /// Pixels summarized.
    pub pixels: u64,
    /// Of them, pixels with a surface (depth in front of the far plane, a
    /// usable normal).
    pub surfaces: u64,
    /// Reflective pixels: a surface, mask not 0, roughness not NaN, object
    /// id not `REFL_SUMMARY_NO_OBJECT`.
    pub reflective: u64,
    /// Reflective pixels per roughness class.
    pub classes: [u64; 3],
    /// Reflective pixels within `border_pixels` of the border.
    pub border: u64,
    /// Reflective pixels whose id is past the object list (in no object).
    pub unlisted: u64,
    /// Tiles without a reflective pixel, then tiles per roughness class of
    /// their sharpest reflective pixel (a mirror pixel makes a mirror tile).
    pub tiles: [u64; 4],
}

/// What one object's reflective pixels add up to (zero-initialize before
/// the first band). The sums feed `refl_object_summary_plane`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_object_summary {
    /// Reflective pixels.
    pub pixels: u64,
    /// Of them, per roughness class (0 mirror, 1 glossy, 2 rough).
    pub classes: [u64; 3],
    /// Of them, within `border_pixels` of the border.
    pub border_pixels: u64,
    /// Bounding rectangle `x0, y0, x1, y1` (exclusive ends) of the
    /// reflective pixels; all zero while there are none.
    pub rect: [u32; 4],
    /// The first point seen, the origin of the point sums.
    pub origin: [f64; 3],
    /// Sum of the unit normals.
    pub normal_sum: [f64; 3],
    /// Sum of the points relative to `origin`.
    pub point_sum: [f64; 3],
    /// Sums of the products of the relative coordinates: xx, yy, zz, xy,
    /// xz, yz.
    pub point_products: [f64; 6],
    /// Sum of the linear depths.
    pub depth_sum: f64,
}

// The C structs are the core's, field for field (the objects are
// summarized in place, without a copy).
const _: () = {
    use core::mem::{align_of, offset_of, size_of};
    assert!(size_of::<refl_frame_summary>() == size_of::<FrameSummary>());
    assert!(align_of::<refl_frame_summary>() == align_of::<FrameSummary>());
    assert!(offset_of!(refl_frame_summary, tiles) == offset_of!(FrameSummary, tiles));
    assert!(offset_of!(refl_frame_summary, unlisted) == offset_of!(FrameSummary, unlisted));
    assert!(size_of::<refl_object_summary>() == size_of::<ObjectSummary>());
    assert!(align_of::<refl_object_summary>() == align_of::<ObjectSummary>());
    assert!(offset_of!(refl_object_summary, rect) == offset_of!(ObjectSummary, rect));
    assert!(offset_of!(refl_object_summary, origin) == offset_of!(ObjectSummary, origin));
    assert!(offset_of!(refl_object_summary, normal_sum) == offset_of!(ObjectSummary, normal_sum));
    assert!(offset_of!(refl_object_summary, point_sum) == offset_of!(ObjectSummary, point_sum));
    assert!(
        offset_of!(refl_object_summary, point_products)
            == offset_of!(ObjectSummary, point_products)
    );
    assert!(offset_of!(refl_object_summary, depth_sum) == offset_of!(ObjectSummary, depth_sum));
};

impl From<refl_frame_summary> for FrameSummary {
    fn from(f: refl_frame_summary) -> Self {
        Self {
            pixels: f.pixels,
            surfaces: f.surfaces,
            reflective: f.reflective,
            classes: f.classes,
            border: f.border,
            unlisted: f.unlisted,
            tiles: f.tiles,
        }
    }
}

impl From<FrameSummary> for refl_frame_summary {
    fn from(f: FrameSummary) -> Self {
        Self {
            pixels: f.pixels,
            surfaces: f.surfaces,
            reflective: f.reflective,
            classes: f.classes,
            border: f.border,
            unlisted: f.unlisted,
            tiles: f.tiles,
        }
    }
}

impl From<refl_object_summary> for ObjectSummary {
    fn from(o: refl_object_summary) -> Self {
        Self {
            pixels: o.pixels,
            classes: o.classes,
            border_pixels: o.border_pixels,
            rect: o.rect,
            origin: o.origin.into(),
            normal_sum: o.normal_sum.into(),
            point_sum: o.point_sum.into(),
            point_products: o.point_products,
            depth_sum: o.depth_sum,
        }
    }
}

impl From<ObjectSummary> for refl_object_summary {
    fn from(o: ObjectSummary) -> Self {
        Self {
            pixels: o.pixels,
            classes: o.classes,
            border_pixels: o.border_pixels,
            rect: o.rect,
            origin: o.origin.into(),
            normal_sum: o.normal_sum.into(),
            point_sum: o.point_sum.into(),
            point_products: o.point_products,
            depth_sum: o.depth_sum,
        }
    }
}

/// The best plane through an object's reflective points
/// (`refl_object_summary_plane`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_plane_fit {
    /// Unit mean normal.
    pub normal: [f64; 3],
    /// The mean point.
    pub point: [f64; 3],
    /// Length of the mean of the unit normals: 1 when all agree.
    pub coherence: f64,
    /// RMS distance of the points from the plane through `point` with
    /// `normal`.
    pub rms_distance: f64,
    /// Mean linear depth of the points.
    pub mean_depth: f64,
    /// 1 if the object passes the plane test of the options (at least
    /// three pixels, `coherence >= normal_cos`, `rms_distance <=
    /// plane_tolerance * mean_depth`), else 0.
    pub planar: u32,
}

/// The defaults: mirror up to roughness 0.1, glossy up to 1.0, a border of
/// one tile, plane tolerance 1e-3 of the depth, normals within 0.99.
#[no_mangle]
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub extern "C" fn refl_summary_options_default() -> refl_summary_options {
    SummaryOptions::default().into()
}

/// Summarizes the rows `rows` of `gbuffer` into `*frame` and
/// `objects[0 .. objects_len]`, adding to what they hold (zero them before
/// a frame's first band; bands may run on several threads into separate
/// summaries merged with `refl_frame_summary_merge` and
/// `refl_object_summary_merge`). `ids` (`data` NULL: none, every pixel is
/// object 0) gives each pixel's object, an index into `objects` or
/// `REFL_SUMMARY_NO_OBJECT`; ids past `objects_len` are counted in
/// `frame->unlisted`. A band starts on a multiple of `REFL_SUMMARY_TILE`
/// rows and ends on one or at the bottom of the image.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `frame`, `gbuffer`, `options`,
/// `objects` (with `objects_len > 0`) or a required image is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `objects_len` is 0 or an image's
/// `len` is too small; `REFL_STATUS_INVALID_ARGUMENT` for options out of
/// range, `ids` not of the G-buffer's size, rows beyond the height or not
/// on tile rows, a misaligned pointer, or `frame` / `objects` overlapping
/// each other or an input; the G-buffer's errors as the passes report
/// them. Nothing is written on error.
///
/// # Safety
/// `frame` NULL or readable and writable; `objects` NULL or readable and
/// writable for `objects_len` records; `gbuffer` and `options` NULL or
/// readable, the G-buffer's images and `ids.data` readable for their
/// lengths and not written during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_summarize_rows(
    frame: *mut refl_frame_summary,
    objects: *mut refl_object_summary,
    objects_len: usize,
    gbuffer: *const refl_gbuffer,
    ids: refl_image_u32,
    options: *const refl_summary_options,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_summarize_rows", || {
        let frame_out = Out::new(frame, "frame")?;
        if objects_len > 0 {
            check_pointer(objects.cast_const(), "objects")?;
        }
        // SAFETY: caller contract.
        let (g, o) = unsafe { (read(gbuffer, "gbuffer")?, read(options, "options")?) };
        let opts = SummaryOptions::from(o);
        opts.try_validate()
            .map_err(|e| fail(e, format_args!("`options` has a value out of range")))?;
        // SAFETY: caller contract.
        let gb = unsafe { self::gbuffer(&g) }?;
        let ids_view = if ids.data.is_null() {
            None
        } else {
            // SAFETY: caller contract.
            Some(unsafe { ids.view() }?)
        };
        let rows = rows.within(gb.height())?;
        if objects_len == 0 {
            return Err(fail(
                Error::InsufficientSize,
                format_args!("`objects_len` is 0: the summary needs object 0 at least"),
            ));
        }
        let obj_bytes = byte_len::<refl_object_summary>(objects as usize, objects_len)?;
        let mut ins: [(usize, usize); 9] = [(0, 0); 9];
        ins[..6].copy_from_slice(&gbuffer_ranges(&g));
        ins[6] = range(ids.data, if ids.data.is_null() { 0 } else { ids.len });
        ins[7] = range(gbuffer, 1);
        ins[8] = range(options, 1);
        disjoint(
            &[
                (frame as usize, core::mem::size_of::<refl_frame_summary>()),
                (objects as usize, obj_bytes),
            ],
            &ins,
        )?;
        // SAFETY: caller contract (readable and writable, disjoint from the
        // inputs: checked above); refl_object_summary is ObjectSummary field
        // for field (asserted above).
        let objs =
            unsafe { slice_mut_or_empty(objects.cast::<ObjectSummary>(), objects_len, "objects") }?;
        // SAFETY: caller contract.
        let mut f = FrameSummary::from(unsafe { read(frame.cast_const(), "frame") }?);
        try_summarize_rows(&mut f, objs, &gb, ids_view.as_ref(), rows, &opts).map_err(|e| {
            fail(
                e,
                format_args!("`ids` must have the G-buffer's size and `rows` start on a tile row"),
            )
        })?;
        // SAFETY: checked non-null and aligned; caller contract.
        unsafe { frame_out.write(f.into()) };
        Ok(())
    })
}

/// Adds `*src` (another band's counts of the same frame) to `*dst`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if a pointer is NULL,
/// `REFL_STATUS_INVALID_ARGUMENT` if one is misaligned. `dst` may be `src`
/// (the counts double).
///
/// # Safety
/// `dst` NULL or readable and writable, `src` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_frame_summary_merge(
    dst: *mut refl_frame_summary,
    src: *const refl_frame_summary,
) -> refl_status {
    guard("refl_frame_summary_merge", || {
        let out = Out::new(dst, "dst")?;
        // SAFETY: caller contract.
        let (mut a, b) = unsafe { (read(dst.cast_const(), "dst")?, read(src, "src")?) };
        let mut f = FrameSummary::from(a);
        f.merge(&b.into());
        a = f.into();
        // SAFETY: checked; caller contract.
        unsafe { out.write(a) };
        Ok(())
    })
}

/// Adds `*src` (the same object in another band) to `*dst`; the point sums
/// move to `dst`'s origin.
///
/// Returns `REFL_STATUS_NULL_POINTER` if a pointer is NULL,
/// `REFL_STATUS_INVALID_ARGUMENT` if one is misaligned.
///
/// # Safety
/// `dst` NULL or readable and writable, `src` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_object_summary_merge(
    dst: *mut refl_object_summary,
    src: *const refl_object_summary,
) -> refl_status {
    guard("refl_object_summary_merge", || {
        let out = Out::new(dst, "dst")?;
        // SAFETY: caller contract.
        let (a, b) = unsafe { (read(dst.cast_const(), "dst")?, read(src, "src")?) };
        let mut s = ObjectSummary::from(a);
        s.merge(&b.into());
        // SAFETY: checked; caller contract.
        unsafe { out.write(s.into()) };
        Ok(())
    })
}

/// The best plane through an object's reflective points, and whether it
/// passes the plane test of `options`, into `*out`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if a pointer is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for options out of range or a misaligned
/// pointer; `REFL_STATUS_DEGENERATE_GEOMETRY` when there is no plane (no
/// pixels, or normals that cancel out). Nothing is written on error.
///
/// # Safety
/// `out` NULL or writable; `summary` and `options` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_object_summary_plane(
    out: *mut refl_plane_fit,
    summary: *const refl_object_summary,
    options: *const refl_summary_options,
) -> refl_status {
    guard("refl_object_summary_plane", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let (s, o) = unsafe { (read(summary, "summary")?, read(options, "options")?) };
        let opts = SummaryOptions::from(o);
        opts.try_validate()
            .map_err(|e| fail(e, format_args!("`options` has a value out of range")))?;
        let s = ObjectSummary::from(s);
        let fit = s.plane().ok_or_else(|| {
            fail(
                Error::DegenerateGeometry,
                format_args!("no plane: the summary has no pixels or its normals cancel out"),
            )
        })?;
        // SAFETY: checked; caller contract.
        unsafe {
            out.write(refl_plane_fit {
                normal: fit.normal.into(),
                point: fit.point.into(),
                coherence: fit.coherence,
                rms_distance: fit.rms_distance,
                mean_depth: fit.mean_depth,
                planar: u32::from(s.is_planar(&opts)),
            })
        };
        Ok(())
    })
}
