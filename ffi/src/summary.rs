//! The frame summary (`refl_core::summary`, issue 15 part 1): one pass
//! over a G-buffer, by row bands on tile rows, that counts reflective
//! pixels per object and roughness class, border contact and 8x8 tile
//! classes, and accumulates what the plane test of each object needs; the
//! measurements a planner reads before it picks methods and skips passes.

use crate::gbuffer::{gbuffer, gbuffer_ranges, refl_gbuffer};
use crate::image::{refl_image_u32, refl_row_range};
use crate::ptr::{
    byte_len, check_pointer, disjoint, range, read, slice_mut_or_empty, slice_or_empty, Out,
};
use crate::status::{fail, guard, refl_status};
use refl_core::plan::{
    choices_len, try_choose_methods, try_plan_passes, Budget, BudgetPlan, Choice, ChoiceReason,
    CostEntry, FrameMotion, HostCaps, ObjectHints, Pass, PassPlan, PlanOptions, SkipReason,
    Surface, PASS_COUNT,
};
use refl_core::summary::{
    try_summarize_rows, FrameSummary, ObjectSummary, SummaryOptions, NO_OBJECT, TILE,
};
use refl_core::Error;

/// Side of a classification tile in pixels: bands of
/// `refl_summary_rows` start on a multiple of it.
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
pub struct refl_summary_frame {
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
/// the first band). The sums feed `refl_summary_object_plane`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_summary_object {
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
    assert!(size_of::<refl_summary_frame>() == size_of::<FrameSummary>());
    assert!(align_of::<refl_summary_frame>() == align_of::<FrameSummary>());
    assert!(offset_of!(refl_summary_frame, tiles) == offset_of!(FrameSummary, tiles));
    assert!(offset_of!(refl_summary_frame, unlisted) == offset_of!(FrameSummary, unlisted));
    assert!(size_of::<refl_summary_object>() == size_of::<ObjectSummary>());
    assert!(align_of::<refl_summary_object>() == align_of::<ObjectSummary>());
    assert!(offset_of!(refl_summary_object, rect) == offset_of!(ObjectSummary, rect));
    assert!(offset_of!(refl_summary_object, origin) == offset_of!(ObjectSummary, origin));
    assert!(offset_of!(refl_summary_object, normal_sum) == offset_of!(ObjectSummary, normal_sum));
    assert!(offset_of!(refl_summary_object, point_sum) == offset_of!(ObjectSummary, point_sum));
    assert!(
        offset_of!(refl_summary_object, point_products)
            == offset_of!(ObjectSummary, point_products)
    );
    assert!(offset_of!(refl_summary_object, depth_sum) == offset_of!(ObjectSummary, depth_sum));
    assert!(size_of::<refl_plan_object_hints>() == size_of::<ObjectHints>());
    assert!(align_of::<refl_plan_object_hints>() == align_of::<ObjectHints>());
    assert!(
        offset_of!(refl_plan_object_hints, planar_mirror) == offset_of!(ObjectHints, planar_mirror)
    );
    assert!(
        offset_of!(refl_plan_object_hints, layered_map) == offset_of!(ObjectHints, layered_map)
    );
    assert!(offset_of!(refl_plan_object_hints, moving) == offset_of!(ObjectHints, moving));
};

impl From<refl_summary_frame> for FrameSummary {
    fn from(f: refl_summary_frame) -> Self {
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

impl From<FrameSummary> for refl_summary_frame {
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

impl From<refl_summary_object> for ObjectSummary {
    fn from(o: refl_summary_object) -> Self {
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

impl From<ObjectSummary> for refl_summary_object {
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
/// (`refl_summary_object_plane`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_summary_plane_fit {
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
    /// Whether the object passes the plane test of the options (at least
    /// three pixels, `coherence >= normal_cos`, `rms_distance <=
    /// plane_tolerance * mean_depth`).
    pub planar: bool,
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
/// summaries merged with `refl_summary_merge_frame` and
/// `refl_summary_merge_object`). `ids` (`data` NULL: none, every pixel is
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
pub unsafe extern "C" fn refl_summary_rows(
    frame: *mut refl_summary_frame,
    objects: *mut refl_summary_object,
    objects_len: usize,
    gbuffer: *const refl_gbuffer,
    ids: refl_image_u32,
    options: *const refl_summary_options,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_summary_rows", || {
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
        let obj_bytes = byte_len::<refl_summary_object>(objects as usize, objects_len)?;
        let mut ins: [(usize, usize); 9] = [(0, 0); 9];
        ins[..6].copy_from_slice(&gbuffer_ranges(&g));
        ins[6] = range(ids.data, if ids.data.is_null() { 0 } else { ids.len });
        ins[7] = range(gbuffer, 1);
        ins[8] = range(options, 1);
        disjoint(
            &[
                (frame as usize, core::mem::size_of::<refl_summary_frame>()),
                (objects as usize, obj_bytes),
            ],
            &ins,
        )?;
        // SAFETY: caller contract (readable and writable, disjoint from the
        // inputs: checked above); refl_summary_object is ObjectSummary field
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
pub unsafe extern "C" fn refl_summary_merge_frame(
    dst: *mut refl_summary_frame,
    src: *const refl_summary_frame,
) -> refl_status {
    guard("refl_summary_merge_frame", || {
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
pub unsafe extern "C" fn refl_summary_merge_object(
    dst: *mut refl_summary_object,
    src: *const refl_summary_object,
) -> refl_status {
    guard("refl_summary_merge_object", || {
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
pub unsafe extern "C" fn refl_summary_object_plane(
    out: *mut refl_summary_plane_fit,
    summary: *const refl_summary_object,
    options: *const refl_summary_options,
) -> refl_status {
    guard("refl_summary_object_plane", || {
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
            out.write(refl_summary_plane_fit {
                normal: fit.normal.into(),
                point: fit.point.into(),
                coherence: fit.coherence,
                rms_distance: fit.rms_distance,
                mean_depth: fit.mean_depth,
                planar: s.is_planar(&opts),
            })
        };
        Ok(())
    })
}

/// The passes of a frame (`refl_plan_decision.pass`), in the order they
/// run (`refl_core::plan::Pass`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_plan_pass {
    /// The Hi-Z pyramid of the depth image.
    Hiz = 0,
    /// The planar pass (extra views of planar mirrors).
    Planar = 1,
    /// The screen-space mirror pass.
    Mirror = 2,
    /// The color pyramid of the lit image (glossy cones).
    ColorPyramid = 3,
    /// The visibility pyramid (glossy cones).
    VisibilityPyramid = 4,
    /// The glossy pass.
    Glossy = 5,
    /// The layered-maps pass.
    Layered = 6,
    /// The lists of unresolved rays for the host's tracer.
    HostRays = 7,
    /// Environment probe lookups for rough pixels.
    Probe = 8,
    /// The temporal pass (seed 004 Sec. 4.6.5, `refl_temporal_*`): the
    /// history re-projected into the frame, recovering pixels whose ray
    /// failed.
    Temporal = 9,
}

/// Why a pass runs or is skipped (`refl_plan_decision.reason`,
/// `refl_core::plan::SkipReason`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_plan_reason {
    /// It runs.
    Runs = 0,
    /// Its family is not compiled in (`refl_config.h`).
    NotBuilt = 1,
    /// No reflective pixel of its class is left for it.
    NoPixels = 2,
    /// Every mirror pixel is on the planar pass.
    AllMirrorsPlanar = 3,
    /// Nothing that would read it runs (a pyramid without its pass).
    NoReader = 4,
    /// The host cannot do what it needs (extra views, a tracer, a probe).
    NoHostSupport = 5,
    /// No object has layered maps.
    NoMaps = 6,
    /// The pass's own setting leaves it out.
    NotUsed = 7,
    /// Nothing moved since the last frame and the host keeps its
    /// reflections: they are this frame's.
    Unchanged = 8,
    /// Every object with layered maps moved: the maps are stale.
    MapsStale = 9,
}

/// Number of passes in `refl_plan.passes`.
pub const REFL_PLAN_PASS_COUNT: usize = 10;

const _: () = assert!(REFL_PLAN_PASS_COUNT == PASS_COUNT);

/// What the host can do (`refl_core::plan::HostCaps`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_plan_host_caps {
    /// It can rasterize extra views (the planar pass's mirrored camera).
    pub planar_views: bool,
    /// It has a ray tracer for the rays the screen cannot answer.
    pub ray_tracer: bool,
    /// It has a prefiltered environment probe for rough reflections.
    pub probe: bool,
}

/// What the host states about one object (`refl_core::plan::ObjectHints`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_plan_object_hints {
    /// A planar mirror (the host knows its plane).
    pub planar_mirror: bool,
    /// The object has layered depth maps the layered pass can trace.
    pub layered_map: bool,
    /// The object moved or changed shape since the last frame: its
    /// layered maps are stale, and the frame is not unchanged.
    pub moving: bool,
}

/// How the passes that run are set up (`refl_core::plan::PlanOptions`);
/// `refl_plan_options_default` gives the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct refl_plan_options {
    /// The mirror pass traces with Hi-Z (else it steps: no pyramid).
    /// Default true.
    pub mirror_hiz: bool,
    /// The glossy options read a visibility pyramid. Default true.
    pub glossy_visibility: bool,
    /// The host keeps the last frame's reflections (the temporal pass's
    /// history) and can show them again. Default false.
    pub history: bool,
    /// The camera is the last frame's. Default false.
    pub camera_still: bool,
    /// Nothing else changed since the last frame (geometry, lights,
    /// materials; objects whose hints say `moving` count as changes
    /// whatever this says). Default false. With `history`, `camera_still`,
    /// `scene_still` and no moving object, every pass is skipped as
    /// UNCHANGED.
    pub scene_still: bool,
}

/// One pass's decision.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_plan_decision {
    /// The pass (`refl_plan_pass`).
    pub pass: u32,
    /// Why it runs or not (`refl_plan_reason`; `REFL_PLAN_REASON_RUNS`
    /// when it runs).
    pub reason: u32,
    /// Bytes of the buffer it builds (pyramids; 0 for the others and when
    /// skipped).
    pub bytes: usize,
}

/// The decisions of a frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_plan {
    /// One per pass, indexed by `refl_plan_pass`.
    pub passes: [refl_plan_decision; REFL_PLAN_PASS_COUNT],
    /// Objects sent to the planar pass.
    pub planar_objects: u32,
    /// Mirror-class pixels left to the mirror pass.
    pub mirror_pixels: u64,
}

impl From<Pass> for refl_plan_pass {
    fn from(p: Pass) -> Self {
        match p {
            Pass::HiZ => Self::Hiz,
            Pass::Planar => Self::Planar,
            Pass::Mirror => Self::Mirror,
            Pass::ColorPyramid => Self::ColorPyramid,
            Pass::VisibilityPyramid => Self::VisibilityPyramid,
            Pass::Glossy => Self::Glossy,
            Pass::Layered => Self::Layered,
            Pass::HostRays => Self::HostRays,
            Pass::Probe => Self::Probe,
            Pass::Temporal => Self::Temporal,
        }
    }
}

impl From<SkipReason> for refl_plan_reason {
    fn from(r: SkipReason) -> Self {
        match r {
            SkipReason::Runs => Self::Runs,
            SkipReason::NotBuilt => Self::NotBuilt,
            SkipReason::NoPixels => Self::NoPixels,
            SkipReason::AllMirrorsPlanar => Self::AllMirrorsPlanar,
            SkipReason::NoReader => Self::NoReader,
            SkipReason::NoHostSupport => Self::NoHostSupport,
            SkipReason::NoMaps => Self::NoMaps,
            SkipReason::NotUsed => Self::NotUsed,
            SkipReason::Unchanged => Self::Unchanged,
            SkipReason::MapsStale => Self::MapsStale,
        }
    }
}

impl From<PassPlan> for refl_plan {
    fn from(p: PassPlan) -> Self {
        Self {
            passes: p.passes.map(|d| refl_plan_decision {
                pass: refl_plan_pass::from(d.pass) as u32,
                reason: refl_plan_reason::from(d.reason) as u32,
                bytes: d.bytes,
            }),
            planar_objects: p.planar_objects,
            mirror_pixels: p.mirror_pixels,
        }
    }
}

/// The defaults: Hi-Z for the mirror pass, a visibility pyramid for the
/// glossy pass.
#[no_mangle]
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub extern "C" fn refl_plan_options_default() -> refl_plan_options {
    let o = PlanOptions::default();
    refl_plan_options {
        mirror_hiz: o.mirror_hiz,
        glossy_visibility: o.glossy_visibility,
        history: o.motion.history,
        camera_still: o.motion.camera_still,
        scene_still: o.motion.scene_still,
    }
}

/// Decides every pass of a `width x height` frame into `*out` from its
/// summary (`*frame`, `objects[0 .. objects_len]`: `refl_summary_rows`
/// over the whole image), the host's `hints` per object (`hints_len` equal
/// to `objects_len`, or 0 with `hints` NULL: nothing stated), `*caps` and
/// the options, and writes into `planar[k]` whether object `k` goes to the
/// planar pass (`planar_len >= objects_len`). The rules (`refl_core::plan`):
/// planar mirrors (stated, or passing the plane test with only mirror
/// pixels) go to the planar pass when the host renders extra views; the
/// mirror pass runs for the mirror pixels left; the glossy pass and its
/// pyramids for glossy pixels; Hi-Z when the mirror pass uses it or the
/// glossy pass runs; the layered pass when an object has maps and a
/// screen-space pass runs (MAPS_STALE when every mapped
/// object's hints say `moving`); host rays with a tracer; the probe for
/// rough pixels; the temporal pass with the mirror pass when
/// `options->history`. With `history`, `camera_still` and `scene_still`
/// and no object `moving`, every pass is skipped as UNCHANGED (the last
/// frame's reflections hold). A skip says why, and `bytes` are those of
/// the pyramids built.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `frame`, `caps`,
/// `summary_options`, `options`, or `objects` / `planar` / `hints` with a
/// non-zero length is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if
/// `planar_len < objects_len`; `REFL_STATUS_INVALID_ARGUMENT` for
/// `hints_len` neither 0 nor `objects_len`, summary options out of range,
/// a zero size, a misaligned pointer, or `planar` overlapping an input.
/// Nothing is written on error.
///
/// # Safety
/// `out` NULL or writable; `planar` NULL or writable for `planar_len`
/// bools; the inputs NULL or readable for their lengths.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_plan_passes(
    out: *mut refl_plan,
    planar: *mut bool,
    planar_len: usize,
    frame: *const refl_summary_frame,
    objects: *const refl_summary_object,
    objects_len: usize,
    hints: *const refl_plan_object_hints,
    hints_len: usize,
    caps: *const refl_plan_host_caps,
    summary_options: *const refl_summary_options,
    options: *const refl_plan_options,
    width: u32,
    height: u32,
) -> refl_status {
    guard("refl_plan_passes", || {
        let out_w = Out::new(out, "out")?;
        if planar_len > 0 {
            check_pointer(planar.cast_const(), "planar")?;
        }
        if objects_len > 0 {
            check_pointer(objects, "objects")?;
        }
        if hints_len > 0 {
            check_pointer(hints, "hints")?;
        }
        // SAFETY: caller contract.
        let (f, c, so, o) = unsafe {
            (
                read(frame, "frame")?,
                read(caps, "caps")?,
                read(summary_options, "summary_options")?,
                read(options, "options")?,
            )
        };
        let planar_bytes = byte_len::<bool>(planar as usize, planar_len)?;
        let objects_bytes = byte_len::<refl_summary_object>(objects as usize, objects_len)?;
        let hints_bytes = byte_len::<refl_plan_object_hints>(hints as usize, hints_len)?;
        disjoint(
            &[(planar as usize, planar_bytes)],
            &[
                (objects as usize, objects_bytes),
                (hints as usize, hints_bytes),
                range(frame, 1),
                range(caps, 1),
                range(summary_options, 1),
                range(options, 1),
                range(out.cast_const(), 1),
            ],
        )?;
        // SAFETY: checked pointers, readable for their lengths (contract);
        // refl_summary_object is ObjectSummary field for field (asserted),
        // refl_plan_object_hints is three bools as ObjectHints is (converted).
        let objs =
            unsafe { slice_or_empty(objects.cast::<ObjectSummary>(), objects_len, "objects") }?;
        // SAFETY: as above.
        let hs = unsafe { slice_or_empty(hints, hints_len, "hints") }?;
        // SAFETY: checked, writable for planar_len (contract), disjoint.
        let pl = unsafe { slice_mut_or_empty(planar, planar_len, "planar") }?;
        let caps = HostCaps {
            planar_views: c.planar_views,
            ray_tracer: c.ray_tracer,
            probe: c.probe,
        };
        let po = PlanOptions {
            mirror_hiz: o.mirror_hiz,
            glossy_visibility: o.glossy_visibility,
            motion: FrameMotion {
                history: o.history,
                camera_still: o.camera_still,
                scene_still: o.scene_still,
            },
        };
        let plan = plan_with_hints(pl, &f.into(), objs, hs, &caps, &so.into(), &po, (width, height))
            .map_err(|e| {
                fail(
                    e,
                    format_args!(
                        "`hints_len` must be 0 or `objects_len`, `planar_len` at least `objects_len`, the size and `summary_options` valid"
                    ),
                )
            })?;
        // SAFETY: checked; caller contract.
        unsafe { out_w.write(plan.into()) };
        Ok(())
    })
}

/// `try_plan_passes` with the C hints (layout-identical to
/// `ObjectHints`: two bools, asserted).
#[allow(clippy::too_many_arguments)]
fn plan_with_hints(
    planar: &mut [bool],
    frame: &FrameSummary,
    objects: &[ObjectSummary],
    hints: &[refl_plan_object_hints],
    caps: &HostCaps,
    summary_options: &SummaryOptions,
    options: &PlanOptions,
    size: (u32, u32),
) -> Result<PassPlan, Error> {
    // SAFETY: refl_plan_object_hints and ObjectHints are both three bools in the
    // same order (asserted below), so the slice reinterprets in place.
    let hints: &[ObjectHints] =
        unsafe { core::slice::from_raw_parts(hints.as_ptr().cast(), hints.len()) };
    try_plan_passes(
        planar,
        frame,
        objects,
        hints,
        caps,
        summary_options,
        options,
        size,
    )
}

// ------------------------------------------------- method choice by budget

/// The reflectors a calibrated option applies to
/// (`refl_plan_cost_entry.surface`, `refl_core::plan::Surface`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_plan_surface {
    /// Any reflector.
    Any = 0,
    /// Planar reflectors only (the planar pass; errors measured there).
    Planar = 1,
    /// Curved (non-planar) reflectors only.
    Curved = 2,
}

/// What a budget limits (`refl_plan_budget.kind`,
/// `refl_core::plan::Budget`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_plan_budget_kind {
    /// The frame's mean error, 0..255, over the pixels the plan covers
    /// (`refl_plan_budget_plan.covered`: the groups with an option), at
    /// most `value`.
    MaxError = 0,
    /// The frame's time at most `value` times the reference tracer's time
    /// for one ray per reflective pixel.
    MaxTime = 1,
}

/// Why a group got its option (`refl_plan_choice.reason`,
/// `refl_core::plan::ChoiceReason`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_plan_choice_reason {
    /// The group's fastest option on the front, and the budget holds with
    /// it.
    Fastest = 0,
    /// The budget bought the group a more accurate option than its
    /// fastest, but not its most accurate.
    TradeOff = 1,
    /// The group's most accurate option on the front, within the budget.
    MostAccurate = 2,
    /// The error budget cannot be met: every group takes its most accurate
    /// option.
    ErrorBudgetUnreachable = 3,
    /// The time budget cannot be met: every group takes its fastest
    /// option.
    TimeBudgetUnreachable = 4,
    /// One option is on the group's front (any other is dominated).
    OnlyOption = 5,
    /// No calibrated option applies (class, surface, or what the host
    /// offers): the group's pixels are left out of the plan.
    NoOption = 6,
}

/// A table index that is no entry (`refl_plan_choice.entry`, `faster`,
/// `more_accurate`).
pub const REFL_PLAN_NO_ENTRY: u32 = 0xFFFF_FFFF;

/// One calibrated option (`refl_core::plan::CostEntry`, the same struct):
/// a method at one setting on the reflective pixels of one roughness class
/// and surface, with its measured cost and error.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_plan_cost_entry {
    /// The caller's name for the method and setting (opaque here).
    pub id: u32,
    /// The roughness class it applies to: 0 mirror, 1 glossy, 2 rough.
    pub roughness_class: u8,
    /// The reflectors it applies to (`refl_plan_surface`).
    pub surface: u32,
    /// The passes it runs, one bit `1 << refl_plan_pass` each (at least
    /// one, none past `REFL_PLAN_PASS_COUNT`).
    pub passes: u32,
    /// Time per reflective pixel over the reference tracer's time per ray.
    /// Finite, >= 0.
    pub time_ratio: f32,
    /// Mean absolute error on 0..255 over the pixels it handles. Finite,
    /// >= 0.
    pub error_255: f32,
}

/// What a frame may spend (`refl_core::plan::Budget`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_plan_budget {
    /// What it limits (`refl_plan_budget_kind`).
    pub kind: u32,
    /// The limit. Finite, >= 0.
    pub value: f32,
}

/// The option chosen for one group of pixels (one object's reflective
/// pixels of one roughness class, or those of unlisted objects), and why
/// (`refl_core::plan::Choice`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_plan_choice {
    /// The object (its index in `objects`), or `REFL_SUMMARY_NO_OBJECT`
    /// for the pixels of unlisted objects.
    pub object: u32,
    /// Their roughness class: 0 mirror, 1 glossy, 2 rough.
    pub roughness_class: u32,
    /// Reflective pixels of the group.
    pub pixels: u64,
    /// The chosen entry's index in the table (`REFL_PLAN_NO_ENTRY`: no
    /// option applies, `REFL_PLAN_CHOICE_REASON_NO_OPTION`).
    pub entry: u32,
    /// Why (`refl_plan_choice_reason`).
    pub reason: u32,
    /// Options of the table that apply to the group.
    pub applicable: u32,
    /// Of them, the ones on the group's Pareto front.
    pub front: u32,
    /// The next faster option on the front, not taken
    /// (`REFL_PLAN_NO_ENTRY`: the choice is the fastest).
    pub faster: u32,
    /// The next more accurate option on the front, not taken
    /// (`REFL_PLAN_NO_ENTRY`: the choice is the most accurate).
    pub more_accurate: u32,
    /// The chosen entry's `id` (0 without an entry).
    pub id: u32,
    /// The chosen entry's `passes` (0 without an entry).
    pub passes: u32,
    /// The chosen entry's `time_ratio` (0 without an entry).
    pub time_ratio: f32,
    /// The chosen entry's `error_255` (0 without an entry).
    pub error_255: f32,
    /// The group's part of the plan's `time_ratio` (its pixels times the
    /// entry's time ratio over the frame's reflective pixels).
    pub time_share: f64,
    /// The group's part of the plan's `error_255` (its pixels times the
    /// entry's error over the covered pixels).
    pub error_share: f64,
    /// The object is a plane (as `planar` said; unlisted pixels are not).
    pub planar: bool,
}

/// What `refl_plan_choose_methods` predicts for the frame
/// (`refl_core::plan::BudgetPlan`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_plan_budget_plan {
    /// Groups written to `choices`.
    pub groups: usize,
    /// Reflective pixels of the frame.
    pub reflective: u64,
    /// Of them, the ones some option handles.
    pub covered: u64,
    /// Predicted time: the sum over groups of pixels times the entry's
    /// `time_ratio`, over the reflective pixels.
    pub time_ratio: f64,
    /// Predicted mean error (0..255) over the covered pixels.
    pub error_255: f64,
    /// Whether the prediction meets the budget.
    pub met: bool,
}

// The table is read in place as the core's entries, and the core's
// choices are worked out in the caller's `choices` (each C record at least
// as large, converted last to first).
const _: () = {
    use core::mem::{align_of, offset_of, size_of};
    assert!(size_of::<refl_plan_cost_entry>() == size_of::<CostEntry>());
    assert!(align_of::<refl_plan_cost_entry>() == align_of::<CostEntry>());
    assert!(offset_of!(refl_plan_cost_entry, id) == offset_of!(CostEntry, id));
    assert!(offset_of!(refl_plan_cost_entry, roughness_class) == offset_of!(CostEntry, class));
    assert!(offset_of!(refl_plan_cost_entry, surface) == offset_of!(CostEntry, surface));
    assert!(offset_of!(refl_plan_cost_entry, passes) == offset_of!(CostEntry, passes));
    assert!(offset_of!(refl_plan_cost_entry, time_ratio) == offset_of!(CostEntry, time_ratio));
    assert!(offset_of!(refl_plan_cost_entry, error_255) == offset_of!(CostEntry, error_255));
    assert!(size_of::<refl_plan_choice>() >= size_of::<Choice>());
    assert!(align_of::<refl_plan_choice>() >= align_of::<Choice>());
};

impl From<ChoiceReason> for refl_plan_choice_reason {
    fn from(r: ChoiceReason) -> Self {
        match r {
            ChoiceReason::Fastest => Self::Fastest,
            ChoiceReason::TradeOff => Self::TradeOff,
            ChoiceReason::MostAccurate => Self::MostAccurate,
            ChoiceReason::ErrorBudgetUnreachable => Self::ErrorBudgetUnreachable,
            ChoiceReason::TimeBudgetUnreachable => Self::TimeBudgetUnreachable,
            ChoiceReason::OnlyOption => Self::OnlyOption,
            ChoiceReason::NoOption => Self::NoOption,
        }
    }
}

impl From<Surface> for refl_plan_surface {
    fn from(s: Surface) -> Self {
        match s {
            Surface::Any => Self::Any,
            Surface::Planar => Self::Planar,
            Surface::Curved => Self::Curved,
        }
    }
}

impl From<CostEntry> for refl_plan_cost_entry {
    fn from(e: CostEntry) -> Self {
        Self {
            id: e.id,
            roughness_class: e.class as u8,
            surface: refl_plan_surface::from(e.surface) as u32,
            passes: e.passes,
            time_ratio: e.time_ratio,
            error_255: e.error_255,
        }
    }
}

impl From<Budget> for refl_plan_budget {
    fn from(b: Budget) -> Self {
        match b {
            Budget::MaxError(v) => Self {
                kind: refl_plan_budget_kind::MaxError as u32,
                value: v,
            },
            Budget::MaxTime(v) => Self {
                kind: refl_plan_budget_kind::MaxTime as u32,
                value: v,
            },
        }
    }
}

impl TryFrom<refl_plan_budget> for Budget {
    type Error = Error;
    fn try_from(b: refl_plan_budget) -> Result<Self, Error> {
        match b.kind {
            0 => Ok(Budget::MaxError(b.value)),
            1 => Ok(Budget::MaxTime(b.value)),
            _ => Err(Error::InvalidArgument),
        }
    }
}

impl From<BudgetPlan> for refl_plan_budget_plan {
    fn from(p: BudgetPlan) -> Self {
        Self {
            groups: p.groups,
            reflective: p.reflective,
            covered: p.covered,
            time_ratio: p.time_ratio,
            error_255: p.error_255,
            met: p.met,
        }
    }
}

/// The C record of the core's `choice`, with the chosen entry's fields
/// from `table` and its shares of `plan`.
pub(crate) fn choice_to_c(c: &Choice, table: &[CostEntry], plan: &BudgetPlan) -> refl_plan_choice {
    let idx = |i: Option<usize>| i.map_or(REFL_PLAN_NO_ENTRY, |i| i as u32);
    let e = c.entry.and_then(|i| table.get(i));
    let p = c.group.pixels as f64;
    let (time_share, error_share) = match e {
        Some(e) => (
            p * f64::from(e.time_ratio) / plan.reflective.max(1) as f64,
            if plan.covered > 0 {
                p * f64::from(e.error_255) / plan.covered as f64
            } else {
                0.0
            },
        ),
        None => (0.0, 0.0),
    };
    refl_plan_choice {
        object: c.group.object,
        roughness_class: c.group.class as u32,
        pixels: c.group.pixels,
        entry: idx(c.entry),
        reason: refl_plan_choice_reason::from(c.reason) as u32,
        applicable: c.applicable,
        front: c.front,
        faster: idx(c.faster),
        more_accurate: idx(c.more_accurate),
        id: e.map_or(0, |e| e.id),
        passes: e.map_or(0, |e| e.passes),
        time_ratio: e.map_or(0.0, |e| e.time_ratio),
        error_255: e.map_or(0.0, |e| e.error_255),
        time_share,
        error_share,
        planar: c.group.planar,
    }
}

/// Writes into `*out_len` the most groups `refl_plan_choose_methods`
/// writes for a summary of `objects` objects (one per object and class,
/// one per class for unlisted objects): the `choices_len` that always
/// suffices.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_len` is NULL,
/// `REFL_STATUS_INVALID_ARGUMENT` if it is misaligned. Nothing is written
/// on error.
///
/// # Safety
/// `out_len` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn refl_plan_choices_len(out_len: *mut usize, objects: u32) -> refl_status {
    guard("refl_plan_choices_len", || {
        let out = Out::new(out_len, "out_len")?;
        // SAFETY: checked; caller contract.
        unsafe { out.write(choices_len(objects as usize)) };
        Ok(())
    })
}

/// Chooses, for every object and roughness class of a frame's reflective
/// pixels, the calibrated option of `table[0 .. table_len]` that
/// `*budget` asks for (`refl_core::plan::try_choose_methods`), writes the
/// groups into `choices` (in object order, then the unlisted pixels per
/// class) and the prediction into `*out` (`out->groups` records written).
/// The summary is `*frame`, `objects[0 .. objects_len]`
/// (`refl_summary_rows` over the whole image); `planar[k]` says whether
/// object `k` is a plane (`planar_len >= objects_len`; `refl_plan_passes`
/// writes it); `hints` (`hints_len` equal to `objects_len`, or 0 with
/// `hints` NULL: nothing stated) and `*caps` say what the host offers. An
/// option applies to a group when its class and surface match and the host
/// offers every pass it runs (the planar pass only for a planar object);
/// of those, only the Pareto front counts, and
/// the choice across groups is a greedy multiple-choice knapsack along the
/// fronts (see the core's docs). `choices_len` of
/// what `refl_plan_choices_len` gives for `objects_len` always suffices.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `frame`, `caps`, `budget`,
/// or `choices` / `objects` / `planar` / `hints` / `table` with a non-zero
/// length is NULL; `REFL_STATUS_INSUFFICIENT_SIZE` if `choices_len` is
/// less than the groups of the frame; `REFL_STATUS_INVALID_ARGUMENT` for a
/// budget of an unknown kind or a NaN, infinite or negative value, a table
/// entry with an unknown class or surface, a NaN, infinite or negative
/// time or error, or an empty or unknown pass mask, `table_len` of
/// `REFL_PLAN_NO_ENTRY` or more, `hints_len` neither 0 nor `objects_len`,
/// `planar_len < objects_len`, objects whose reflective pixels of a class
/// add up to more than the frame's, class counts (the frame's three, or the
/// objects' of one class) that add up past `UINT64_MAX`, a misaligned
/// pointer (with a non-zero length), or `choices` overlapping an input.
/// Nothing is written on error. A frame without reflective pixels gives no
/// group: `choices` may then be NULL with `choices_len` 0.
///
/// # Safety
/// `out` NULL or writable; `choices` NULL or writable for `choices_len`
/// records; the inputs NULL or readable for their lengths.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_plan_choose_methods(
    out: *mut refl_plan_budget_plan,
    choices: *mut refl_plan_choice,
    choices_len: usize,
    frame: *const refl_summary_frame,
    objects: *const refl_summary_object,
    objects_len: usize,
    planar: *const bool,
    planar_len: usize,
    hints: *const refl_plan_object_hints,
    hints_len: usize,
    caps: *const refl_plan_host_caps,
    table: *const refl_plan_cost_entry,
    table_len: usize,
    budget: *const refl_plan_budget,
) -> refl_status {
    guard("refl_plan_choose_methods", || {
        let out_w = Out::new(out, "out")?;
        for (p, len, name) in [
            (choices.cast_const().cast::<u8>(), choices_len, "choices"),
            (objects.cast(), objects_len, "objects"),
            (planar.cast(), planar_len, "planar"),
            (hints.cast(), hints_len, "hints"),
            (table.cast(), table_len, "table"),
        ] {
            if len > 0 && p.is_null() {
                return Err(fail(Error::NullPointer, format_args!("`{name}` is NULL")));
            }
        }
        if choices_len > 0 {
            check_pointer(choices.cast_const(), "choices")?;
        }
        if objects_len > 0 {
            check_pointer(objects, "objects")?;
        }
        if hints_len > 0 {
            check_pointer(hints, "hints")?;
        }
        if table_len > 0 {
            check_pointer(table, "table")?;
        }
        // SAFETY: caller contract.
        let (f, c, b) = unsafe {
            (
                read(frame, "frame")?,
                read(caps, "caps")?,
                read(budget, "budget")?,
            )
        };
        let bud = Budget::try_from(b)
            .and_then(|b| b.try_validate().map(|()| b))
            .map_err(|e| {
                fail(
                    e,
                    format_args!(
                        "`budget` must have a known kind and a finite value >= 0 (kind {}, value {})",
                        b.kind, b.value
                    ),
                )
            })?;
        if table_len >= REFL_PLAN_NO_ENTRY as usize {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`table_len` must be less than `REFL_PLAN_NO_ENTRY`"),
            ));
        }
        let choices_bytes = byte_len::<refl_plan_choice>(choices as usize, choices_len)?;
        let objects_bytes = byte_len::<refl_summary_object>(objects as usize, objects_len)?;
        let planar_bytes = byte_len::<bool>(planar as usize, planar_len)?;
        let hints_bytes = byte_len::<refl_plan_object_hints>(hints as usize, hints_len)?;
        let table_bytes = byte_len::<refl_plan_cost_entry>(table as usize, table_len)?;
        disjoint(
            &[(choices as usize, choices_bytes)],
            &[
                (objects as usize, objects_bytes),
                (planar as usize, planar_bytes),
                (hints as usize, hints_bytes),
                (table as usize, table_bytes),
                range(frame, 1),
                range(caps, 1),
                range(budget, 1),
                range(out.cast_const(), 1),
            ],
        )?;
        // SAFETY: checked pointer, readable for table_len (contract).
        let raw_table = unsafe { slice_or_empty(table, table_len, "table") }?;
        for (i, e) in raw_table.iter().enumerate() {
            if e.roughness_class > 2 || e.surface > 2 {
                return Err(fail(
                    Error::InvalidArgument,
                    format_args!(
                        "`table[{i}]` has an unknown class {} or surface {}",
                        e.roughness_class, e.surface
                    ),
                ));
            }
        }
        // SAFETY: refl_plan_cost_entry is CostEntry field for field
        // (asserted above), and every class and surface was just checked
        // to be a variant of the core's enums.
        let table: &[CostEntry] =
            unsafe { core::slice::from_raw_parts(raw_table.as_ptr().cast(), raw_table.len()) };
        for (i, e) in table.iter().enumerate() {
            e.try_validate().map_err(|err| {
                fail(
                    err,
                    format_args!(
                        "`table[{i}]` needs a finite time and error >= 0 and a pass mask of known passes, not empty"
                    ),
                )
            })?;
        }
        if !(hints_len == 0 || hints_len == objects_len) {
            return Err(fail(
                Error::InvalidArgument,
                format_args!(
                    "`hints_len` must be 0 or `objects_len` ({objects_len}), not {hints_len}"
                ),
            ));
        }
        if planar_len < objects_len {
            return Err(fail(
                Error::InvalidArgument,
                format_args!(
                    "`planar_len` ({planar_len}) is less than `objects_len` ({objects_len})"
                ),
            ));
        }
        // SAFETY: checked pointers, readable for their lengths (contract);
        // refl_summary_object is ObjectSummary field for field (asserted).
        let objs =
            unsafe { slice_or_empty(objects.cast::<ObjectSummary>(), objects_len, "objects") }?;
        // SAFETY: as above.
        let pl = unsafe { slice_or_empty(planar, planar_len, "planar") }?;
        // SAFETY: as above; refl_plan_object_hints is ObjectHints (asserted).
        let hs = unsafe { slice_or_empty(hints.cast::<ObjectHints>(), hints_len, "hints") }?;
        // The groups, counted as the core counts them.
        let too_many = || {
            fail(
                Error::InvalidArgument,
                format_args!("class counts of `objects` or `frame` add up past UINT64_MAX"),
            )
        };
        let mut listed = [0u64; 3];
        let mut needed = 0usize;
        for o in objs {
            for (l, &n) in listed.iter_mut().zip(&o.classes) {
                *l = l.checked_add(n).ok_or_else(too_many)?;
                needed += usize::from(n > 0);
            }
        }
        f.classes
            .iter()
            .try_fold(0u64, |s, &n| s.checked_add(n))
            .ok_or_else(too_many)?;
        for (&l, &n) in listed.iter().zip(&f.classes) {
            if l > n {
                return Err(fail(
                    Error::InvalidArgument,
                    format_args!(
                        "`objects` have more reflective pixels in a class than `frame` (together)"
                    ),
                ));
            }
            needed += usize::from(n > l);
        }
        if choices_len < needed {
            return Err(fail(
                Error::InsufficientSize,
                format_args!(
                    "`choices_len` ({choices_len}) is less than the frame's {needed} groups"
                ),
            ));
        }
        let caps = HostCaps {
            planar_views: c.planar_views,
            ray_tracer: c.ray_tracer,
            probe: c.probe,
        };
        // Every check is done: the core's choices are worked out in the
        // first `needed` records of `choices` (each record at least as large
        // and as aligned as a `Choice`, asserted), initialized first.
        let scratch = choices.cast::<Choice>();
        for k in 0..needed {
            // SAFETY: within the first `needed` records of `choices`
            // (writable, disjoint from the inputs: checked), aligned.
            unsafe { scratch.add(k).write(Choice::default()) };
        }
        // A frame without groups forms no slice over `choices`, which may
        // then be NULL (or anything) with `choices_len` 0.
        let chs: &mut [Choice] = if needed == 0 {
            &mut []
        } else {
            // SAFETY: initialized above; no other reference to `choices`;
            // non-NULL and aligned (checked, `choices_len >= needed > 0`).
            unsafe { core::slice::from_raw_parts_mut(scratch, needed) }
        };
        let plan = try_choose_methods(chs, &f.into(), objs, pl, hs, &caps, table, bud)
            .map_err(|e| fail(e, format_args!("the core refused the checked inputs")))?;
        // Convert last to first: record `k` covers only core choices `k`
        // and later, already read.
        for k in (0..plan.groups).rev() {
            // SAFETY: an initialized core choice (k < needed), read before
            // its record is written.
            let ch = unsafe { scratch.add(k).read() };
            // SAFETY: within `choices` (k < needed <= choices_len), aligned.
            unsafe { choices.add(k).write(choice_to_c(&ch, table, &plan)) };
        }
        // SAFETY: checked; caller contract.
        unsafe { out_w.write(plan.into()) };
        Ok(())
    })
}
