//! The layered-maps pass (`refl_core::layered_pass`): G-buffer and layered
//! depth cube maps in (seed 001), per reflective pixel the nearest hit on
//! the maps (map, face, texel, layer, payload) or why there is none, and
//! the pixels the maps cannot answer as a list of `refl_host_ray` for the
//! host's tracer. A second entry traces the host's own rays (for example
//! the host rays of `refl_ssr_trace_rows`) against the same maps.
//!
//! A frame takes four calls once the maps are built (`refl_layered_clear`,
//! `refl_layered_fill_face`): `refl_layered_pass_options_default` (or your
//! own options), `refl_layered_pass_scratch_len` and
//! `refl_layered_pass_prepare` (every map validated, its world bounding
//! sphere written to the scratch), then `refl_layered_trace_rows` once per
//! row band, from any number of threads (or `refl_layered_trace_host_rays`
//! on a list of rays). The G-buffer is the mirror pass's `refl_gbuffer`.
//!
//! Optionally, potential reflection regions (seed 001 Sec. 3.2, Fig. 2(a)):
//! `refl_layered_prr_masks` writes per reflector triangle the maps that may
//! reflect on it, and `refl_layered_pass_input.regions` gives each pixel's
//! triangle, so that a pixel traces only its triangle's maps (same results,
//! fewer per-ray sphere tests).

use crate::gbuffer::{gbuffer, gbuffer_ranges, put_host_ray, refl_gbuffer, refl_host_ray};
use crate::image::{refl_image_u32, refl_image_vec3_mut, refl_row_range};
use crate::layered::{refl_layered_map, refl_layered_options};
use crate::ptr::{
    byte_len, check_buffer, check_pointer, overlaps, range, read, slice_mut_or_empty,
    slice_or_empty, Out,
};
use crate::status::{fail, guard, refl_status};
use crate::types::{refl_vec2, refl_vec3};
use refl_core::layered::LayeredMap;
use refl_core::{
    prr_mask_words, try_prepare_layered_pass, try_prr_masks, try_prr_masks_len, Error, GBuffer,
    HostRay, ImageView, ImageViewMut, LayeredBound, LayeredHostRay, LayeredMapSet, LayeredPass,
    LayeredPassOptions, LayeredPassSink, LayeredPassStats, LayeredPassStatus, LayeredPassTexel,
    MirrorStatus, PrrStats, PrrTriangle, PRR_NO_REGION,
};

/// The region id of a pixel without a region
/// (`refl_layered_pass_input.regions`): every map applies.
pub const REFL_LAYERED_NO_REGION: u32 = 0xFFFF_FFFF;

const _: () = assert!(REFL_LAYERED_NO_REGION == PRR_NO_REGION);

/// Settings of the layered pass; `refl_layered_pass_options_default` gives
/// the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_layered_pass_options {
    /// The kernel's settings (`refl_layered_options_default`).
    pub trace: refl_layered_options,
    /// A ray starts where its projection has moved this many pixels from
    /// its surface point (as `refl_ssr_options.start_pixels`); finite and
    /// not negative. Default 0: the maps hold reflected objects, not the
    /// reflector, so the ray starts at its surface point (t_min).
    pub start_pixels: f32,
    /// A ray starts no earlier than this distance; finite, >= 0. Default 0.
    pub t_min: f32,
    /// The longest ray, > t_min, +infinity allowed (the default).
    pub t_max: f32,
    /// Pixels with a roughness above this are not traced (only with a
    /// roughness image); not NaN. Default 0.1.
    pub max_roughness: f32,
    /// The maps' payloads are packed colors (bytes r, g, b, a from the
    /// least significant, a little-endian `refl_rgba8`): the color output
    /// gets [r, g, b] / 255 at each hit. Default false.
    pub payload_color: bool,
}

impl From<LayeredPassOptions> for refl_layered_pass_options {
    fn from(o: LayeredPassOptions) -> Self {
        Self {
            trace: o.trace.into(),
            start_pixels: o.start_pixels,
            t_min: o.t_min,
            t_max: o.t_max,
            max_roughness: o.max_roughness,
            payload_color: o.payload_color,
        }
    }
}

impl From<refl_layered_pass_options> for LayeredPassOptions {
    fn from(o: refl_layered_pass_options) -> Self {
        Self {
            trace: o.trace.into(),
            start_pixels: o.start_pixels,
            t_min: o.t_min,
            t_max: o.t_max,
            max_roughness: o.max_roughness,
            payload_color: o.payload_color,
        }
    }
}

/// What the pass did at a pixel or listed ray (`refl_layered_pass_texel.status`,
/// `refl_host_ray.status` of its host rays).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum refl_layered_pass_status {
    /// Not reflective (mask, roughness), or a row the call did not cover.
    Skipped = 0,
    /// No usable surface: sky, NaN depth, zero or non-finite normal.
    NoSurface = 1,
    /// The ray hit a map's object.
    Hit = 2,
    /// The ray starts at or beyond t_max: it reaches nothing (answered).
    Sky = 3,
    /// Host ray: the ray met no mapped object.
    LeftMaps = 4,
    /// Host ray: a map's step cap was reached and no map hit.
    OutOfSteps = 5,
    /// Host ray: the ray starts inside a mapped object (a disocclusion)
    /// and no map hit.
    StartedInside = 6,
    /// Host ray: no usable projection (not traced).
    NoProjection = 7,
}

impl From<LayeredPassStatus> for refl_layered_pass_status {
    fn from(s: LayeredPassStatus) -> Self {
        match s {
            LayeredPassStatus::Skipped => Self::Skipped,
            LayeredPassStatus::NoSurface => Self::NoSurface,
            LayeredPassStatus::Hit => Self::Hit,
            LayeredPassStatus::Sky => Self::Sky,
            LayeredPassStatus::LeftMaps => Self::LeftMaps,
            LayeredPassStatus::OutOfSteps => Self::OutOfSteps,
            LayeredPassStatus::StartedInside => Self::StartedInside,
            LayeredPassStatus::NoProjection => Self::NoProjection,
        }
    }
}

/// One pixel (or listed ray) of the pass's output.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_layered_pass_texel {
    /// A `refl_layered_pass_status`.
    pub status: u32,
    /// Index of the map hit in `refl_layered_pass_input.maps`; 0 without a
    /// hit.
    pub map: u32,
    /// Face (0..6) whose search found the hit; 0 without a hit.
    pub face: u32,
    /// Texel column `i` on that face; 0 without a hit.
    pub texel_x: u32,
    /// Texel row `j` on that face; 0 without a hit.
    pub texel_y: u32,
    /// The hit's position on the face in texels (sub-texel), always within
    /// the texel's cell `[texel_x, texel_x + 1] x [texel_y, texel_y + 1]`
    /// (also where a map transform stretched beyond float precision puts
    /// `position` outside the box); 0 without a hit.
    pub uv: refl_vec2,
    /// Layer of that texel; 0 without a hit.
    pub layer: u32,
    /// Payload of that layer; 0 without a hit.
    pub payload: u32,
    /// Distance from the surface point (a listed ray: its origin) to the
    /// hit; 0 without a hit.
    pub t: f32,
    /// World position of the hit; 0 without a hit.
    pub position: refl_vec3,
    /// Confidence in [0, 1]: 1 where the searched face sees the surface it
    /// hit (the kernel's mismatch within `trace.early_stop_texels`),
    /// `early_stop_texels / mismatch` beyond; 0 without a hit.
    pub confidence: f32,
    /// Unit ray direction (where to sample a probe); 0 for pixels without
    /// a ray.
    pub dir: refl_vec3,
    /// Buffer reads of the kernel over the maps traced.
    pub fetches: u32,
}

impl From<LayeredPassTexel> for refl_layered_pass_texel {
    fn from(t: LayeredPassTexel) -> Self {
        Self {
            status: refl_layered_pass_status::from(t.status) as u32,
            map: t.map,
            face: t.face as u32,
            texel_x: t.texel[0],
            texel_y: t.texel[1],
            uv: t.uv.into(),
            layer: t.layer,
            payload: t.payload,
            t: t.t,
            position: t.position.into(),
            confidence: t.confidence,
            dir: t.dir.into(),
            fetches: t.fetches,
        }
    }
}

/// Counts of one `refl_layered_trace_rows` or `refl_layered_trace_host_rays`
/// call.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_layered_pass_stats {
    /// Rays traced (pixels: reflective, with a surface).
    pub traced: u32,
    /// Hits.
    pub hits: u32,
    /// Rays answered as sky.
    pub sky: u32,
    /// Rays that need the host's tracer.
    pub host_rays: u32,
    /// Of those, the ones written to the host list (the first ones in
    /// order; the rest did not fit, their texels still say so).
    pub host_rays_written: u32,
    /// Kernel traces (a ray against one map), summed.
    pub kernel_traces: u64,
    /// Buffer reads of the kernel, summed.
    pub fetches: u64,
    /// (ray, map) pairs the ray's bounding-sphere test rejected (no
    /// kernel trace).
    pub sphere_culled: u64,
    /// (ray, map) pairs the pixel's region mask skipped before the sphere
    /// test (0 without regions): the lookups the potential reflection
    /// regions save. The masks are conservative: `sphere_culled +
    /// prr_skipped` is the `sphere_culled` of the same call without
    /// regions, every other count and every texel are the same.
    pub prr_skipped: u64,
}

impl From<LayeredPassStats> for refl_layered_pass_stats {
    fn from(s: LayeredPassStats) -> Self {
        Self {
            traced: s.traced,
            hits: s.hits,
            sky: s.sky,
            host_rays: s.host_rays,
            host_rays_written: s.host_rays_written,
            kernel_traces: s.kernel_traces,
            fetches: s.fetches,
            sphere_culled: s.sphere_culled,
            prr_skipped: s.prr_skipped,
        }
    }
}

impl From<LayeredHostRay> for refl_host_ray {
    fn from(r: LayeredHostRay) -> Self {
        Self {
            x: r.x,
            y: r.y,
            origin: r.origin.into(),
            dir: r.dir.into(),
            t_min: r.t_min,
            t_max: r.t_max,
            status: refl_layered_pass_status::from(r.status) as u32,
        }
    }
}

/// One map's world bounding sphere and the key of the map it was computed
/// for: the scratch `refl_layered_pass_prepare` writes, one per map.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_layered_bound {
    /// Center, world space.
    pub center: refl_vec3,
    /// Radius, world units.
    pub radius: f32,
    /// A hash of the map's grid, placement and index (a scratch prepared
    /// for other maps is refused).
    pub key: u32,
}

// refl_layered_bound is refl-core's `LayeredBound` (`#[repr(C)]`), field for
// field: the scratch is read and written in place as core records.
const _: () = {
    use core::mem::{align_of, offset_of, size_of};
    assert!(size_of::<refl_layered_bound>() == size_of::<LayeredBound>());
    assert!(align_of::<refl_layered_bound>() == align_of::<LayeredBound>());
    assert!(offset_of!(refl_layered_bound, center) == offset_of!(LayeredBound, center));
    assert!(offset_of!(refl_layered_bound, radius) == offset_of!(LayeredBound, radius));
    assert!(offset_of!(refl_layered_bound, key) == offset_of!(LayeredBound, key));
};

/// What a layered pass reads besides its options: the G-buffer, the maps,
/// and optionally object ids (a pixel's ray skips the maps of its own
/// object: a reflector does not reflect itself).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_layered_pass_input {
    /// The G-buffer (as `refl_ssr_trace_rows` reads it; its color is not
    /// read).
    pub gbuffer: refl_gbuffer,
    /// The maps (`maps_len` descriptors; NULL with 0 allowed), each cleared
    /// and filled for its grid; their buffers must not be written while a
    /// call reads them.
    pub maps: *const refl_layered_map,
    /// Number of maps.
    pub maps_len: usize,
    /// Optional object id per pixel (the camera's size; absent when `data`
    /// is NULL).
    pub ids: refl_image_u32,
    /// With `ids`: the object id of each map (`map_ids_len >= maps_len`);
    /// pixel (x, y)'s ray skips map k when `map_ids[k] == ids(x, y)`.
    /// Ignored without `ids`.
    pub map_ids: *const u32,
    /// Number of ids readable from `map_ids`.
    pub map_ids_len: usize,
    /// Optional region per pixel (the camera's size; absent when `data` is
    /// NULL): the index of the reflector triangle the pixel's surface
    /// point lies on, into `region_masks` (the triangles given to
    /// `refl_layered_prr_masks`), or `REFL_LAYERED_NO_REGION` (every map
    /// applies). Read by `refl_layered_trace_rows` only (listed rays have the host's
    /// directions, not the mirror rays the masks were made for).
    pub regions: refl_image_u32,
    /// With `regions`: per region the maps that may reflect on it, as
    /// `refl_layered_prr_masks` writes them: `n = ceil(maps_len / 64)`
    /// words (at least 1) per region, bit `k % 64` of word `k / 64` for map
    /// k; pixel (x, y) with region r traces map k only if that bit of
    /// `region_masks[r * n + k / 64]` is set. Ignored without `regions`.
    pub region_masks: *const u64,
    /// Number of words readable from `region_masks`.
    pub region_masks_len: usize,
}

/// The caller's maps, read through their descriptors (no copy).
struct CMaps<'a> {
    descs: &'a [refl_layered_map],
}

impl LayeredMapSet for CMaps<'_> {
    fn len(&self) -> usize {
        self.descs.len()
    }

    fn map(&self, k: usize) -> Option<LayeredMap<'_>> {
        // SAFETY: every map's buffers are readable for their lengths and
        // not written during the call (the exports' contract); the views
        // live no longer than the call.
        unsafe { self.descs.get(k)?.view() }.ok()
    }
}

/// A listed ray as refl-core reads it (its status is not read).
#[repr(transparent)]
#[derive(Clone, Copy)]
struct ListedRay(refl_host_ray);

impl From<ListedRay> for HostRay {
    fn from(r: ListedRay) -> Self {
        Self {
            x: r.0.x,
            y: r.0.y,
            origin: r.0.origin.into(),
            dir: r.0.dir.into(),
            t_min: r.0.t_min,
            t_max: r.0.t_max,
            status: MirrorStatus::Skipped,
        }
    }
}

/// A call's parsed inputs.
struct Inputs<'a> {
    g: refl_gbuffer,
    inp: refl_layered_pass_input,
    gb: GBuffer<'a>,
    maps: CMaps<'a>,
    ids: Option<(ImageView<'a, u32>, &'a [u32])>,
    regions: Option<(ImageView<'a, u32>, &'a [u64])>,
    opts: LayeredPassOptions,
}

impl Inputs<'_> {
    /// The byte ranges the call reads: the G-buffer's images, the ids,
    /// the map descriptors and ids, and every map's buffers (`f` gets
    /// each).
    fn each_range(
        &self,
        mut f: impl FnMut((usize, usize)) -> Result<(), Error>,
    ) -> Result<(), Error> {
        for r in gbuffer_ranges(&self.g) {
            f(r)?;
        }
        if !self.inp.ids.data.is_null() {
            f(range(self.inp.ids.data, self.inp.ids.len))?;
            f(range(self.inp.map_ids, self.inp.map_ids_len))?;
        }
        if !self.inp.regions.data.is_null() {
            f(range(self.inp.regions.data, self.inp.regions.len))?;
            f(range(self.inp.region_masks, self.inp.region_masks_len))?;
        }
        f(range(self.inp.maps, self.inp.maps_len))?;
        for d in self.maps.descs {
            for r in d.ranges() {
                f(r)?;
            }
        }
        Ok(())
    }

    /// `InvalidArgument` if an output range overlaps another or an input
    /// (`extra`: the call's other inputs, e.g. the scratch or the rays).
    fn disjoint(&self, outs: &[(usize, usize)], extra: &[(usize, usize)]) -> Result<(), Error> {
        let clash = || {
            fail(
                Error::InvalidArgument,
                format_args!("the outputs overlap each other or an input"),
            )
        };
        for (k, a) in outs.iter().enumerate() {
            if outs[k + 1..]
                .iter()
                .chain(extra)
                .any(|b| overlaps(a.0, a.1, b.0, b.1))
            {
                return Err(clash());
            }
            self.each_range(|b| {
                if overlaps(a.0, a.1, b.0, b.1) {
                    Err(clash())
                } else {
                    Ok(())
                }
            })?;
        }
        Ok(())
    }
}

/// Reads and validates a call's input and options: the options' ranges,
/// the G-buffer, every map, the ids.
///
/// # Safety
/// `input` and `options` NULL or readable; the G-buffer's, the ids' and
/// every map's buffers readable for their lengths and not written during
/// `'a`.
unsafe fn inputs<'a>(
    input: *const refl_layered_pass_input,
    options: *const refl_layered_pass_options,
) -> Result<Inputs<'a>, Error> {
    // SAFETY: caller contract.
    let (inp, o) = unsafe { (read(input, "input")?, read(options, "options")?) };
    let opts = LayeredPassOptions::from(o);
    opts.try_validate()
        .map_err(|e| fail(e, format_args!("`options` has a value out of range")))?;
    let g = inp.gbuffer;
    // SAFETY: caller contract.
    let gb = unsafe { gbuffer(&g) }?;
    // SAFETY: caller contract.
    let descs = unsafe { slice_or_empty(inp.maps, inp.maps_len, "input.maps") }?;
    for (k, d) in descs.iter().enumerate() {
        // SAFETY: caller contract.
        unsafe { d.view() }.map_err(|e| {
            fail(
                e,
                format_args!("`input.maps[{k}]` is not a map of its grid (buffers, grid, stamp)"),
            )
        })?;
    }
    let ids = if inp.ids.data.is_null() {
        None
    } else {
        // SAFETY: caller contract.
        let v = unsafe { inp.ids.view() }?;
        if v.width() != gb.width() || v.height() != gb.height() {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`input.ids` is not the camera's size"),
            ));
        }
        if inp.map_ids_len < inp.maps_len {
            return Err(fail(
                Error::InsufficientSize,
                format_args!(
                    "`input.map_ids_len` is {}, there are {} maps",
                    inp.map_ids_len, inp.maps_len
                ),
            ));
        }
        // SAFETY: caller contract.
        let m = unsafe { slice_or_empty(inp.map_ids, inp.map_ids_len, "input.map_ids") }?;
        Some((v, m))
    };
    let regions = if inp.regions.data.is_null() {
        None
    } else {
        // SAFETY: caller contract.
        let v = unsafe { inp.regions.view() }?;
        if v.width() != gb.width() || v.height() != gb.height() {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`input.regions` is not the camera's size"),
            ));
        }
        // SAFETY: caller contract.
        let m = unsafe {
            slice_or_empty(inp.region_masks, inp.region_masks_len, "input.region_masks")
        }?;
        Some((v, m))
    };
    Ok(Inputs {
        g,
        inp,
        gb,
        maps: CMaps { descs },
        ids,
        regions,
        opts,
    })
}

/// The scratch pointer of a pass with maps, checked before any size or
/// image: a NULL `scratch` is reported as `NULL_POINTER` (as the other
/// passes do since finding F21; finding F25 was this pass reporting a NULL
/// scratch of length 0 as too short, or an input error first).
///
/// # Safety
/// `input` NULL or readable.
unsafe fn scratch_required<T>(
    input: *const refl_layered_pass_input,
    scratch: *const T,
) -> Result<(), Error> {
    // SAFETY: caller contract.
    let inp = unsafe { read(input, "input") }?;
    if inp.maps_len > 0 {
        check_pointer(scratch, "scratch")?;
    }
    Ok(())
}

/// The prepared scratch as refl-core's records, and its length as the
/// overlap checks see it. Without maps the scratch is not read: a NULL
/// `scratch` is then empty whatever `scratch_len` says (the header's
/// "NULL or readable for `scratch_len` records"; fuzz finding F29).
///
/// # Safety
/// `scratch` NULL or readable for `scratch_len` records, not written
/// during `'a`.
unsafe fn bounds<'a>(
    scratch: *const refl_layered_bound,
    scratch_len: usize,
    maps_len: usize,
) -> Result<(&'a [LayeredBound], usize), Error> {
    let len = if maps_len == 0 && scratch.is_null() {
        0
    } else {
        scratch_len
    };
    // SAFETY: caller contract; refl_layered_bound is LayeredBound field for
    // field (asserted above).
    let sc = unsafe { slice_or_empty(scratch.cast::<LayeredBound>(), len, "scratch") }?;
    Ok((sc, len))
}

/// The pass of a trace call: `inputs` with the prepared `scratch` (its
/// keys checked), and the ids.
fn pass<'a>(
    i: &'a Inputs<'a>,
    scratch: &'a [LayeredBound],
) -> Result<LayeredPass<'a, CMaps<'a>>, Error> {
    let need = i.inp.maps_len;
    if scratch.len() < need {
        return Err(fail(
            Error::InsufficientSize,
            format_args!(
                "`scratch_len` is {}, the pass needs {need} (refl_layered_pass_scratch_len)",
                scratch.len()
            ),
        ));
    }
    let p = LayeredPass::try_new(i.gb, &i.maps, i.opts, scratch).map_err(|e| {
        fail(
            e,
            format_args!("`scratch` is not what refl_layered_pass_prepare wrote for these maps"),
        )
    })?;
    let p = match i.ids {
        Some((ids, m)) => p.try_with_ids(ids, m)?,
        None => p,
    };
    match i.regions {
        Some((r, m)) => p.try_with_regions(r, m).map_err(|e| {
            fail(
                e,
                format_args!(
                    "a region id of `input.regions` is neither below the {} regions of `region_masks` nor REFL_LAYERED_NO_REGION",
                    m.len() / prr_mask_words(i.inp.maps_len)
                ),
            )
        }),
        None => Ok(p),
    }
}

/// The pass's defaults: the kernel's (`refl_layered_options_default`),
/// no start offset (start_pixels 0, t_min 0), t_max +infinity, roughness
/// up to 0.1, payloads that are not colors.
#[no_mangle]
pub extern "C" fn refl_layered_pass_options_default() -> refl_layered_pass_options {
    LayeredPassOptions::default().into()
}

/// Size query: the number of `refl_layered_bound` records of scratch the
/// pass needs for this input (one per map) into `*out_len`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_len`, `input` or `options`
/// is NULL.
///
/// # Safety
/// `out_len` NULL or writable; `input` and `options` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_layered_pass_scratch_len(
    out_len: *mut usize,
    input: *const refl_layered_pass_input,
    options: *const refl_layered_pass_options,
) -> refl_status {
    guard("refl_layered_pass_scratch_len", || {
        let out = Out::new(out_len, "out_len")?;
        // SAFETY: caller contract.
        let (inp, _) = unsafe { (read(input, "input")?, read(options, "options")?) };
        // SAFETY: caller contract.
        unsafe { out.write(inp.maps_len) };
        Ok(())
    })
}

/// Prepares a frame: validates the options, the G-buffer, every map
/// (buffers, grid, the stamp `refl_layered_clear` left) and the ids, and
/// writes into `scratch[k]` map k's world bounding sphere and key. A trace
/// skips a map whose sphere its ray misses (the per-ray form of seed 001's
/// potential-reflection-region test; the kernel would miss the map's box:
/// results are the same, only cheaper). Call it once per frame, before any
/// `refl_layered_trace_rows`, and again after a map moved.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `input`, `options`, a required
/// G-buffer image, a map buffer, `input.maps` or (with ids)
/// `input.map_ids` or (with regions) `input.region_masks` with a non-zero
/// length, or `scratch` with a non-zero count of maps is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `scratch_len` is below the number of
/// maps, `input.map_ids_len` below it, or an image's or a map buffer's
/// `len` is too small;
/// `REFL_STATUS_INVALID_ARGUMENT` for an option out of range, an unknown
/// convention or normal space, an image not of the camera's size, a map
/// whose grid or stamp does not match, a map too far out for f32, a
/// misaligned pointer, or `scratch` overlapping an input;
/// `REFL_STATUS_DEGENERATE_GEOMETRY` for a map's degenerate grid; the
/// camera's status if it is invalid. Nothing is written on error.
///
/// # Safety
/// `scratch` NULL or writable for `scratch_len` records; `input` and
/// `options` NULL or readable, the images, map descriptors, map buffers
/// and ids readable for their lengths and not written during the call.
#[no_mangle]
pub unsafe extern "C" fn refl_layered_pass_prepare(
    scratch: *mut refl_layered_bound,
    scratch_len: usize,
    input: *const refl_layered_pass_input,
    options: *const refl_layered_pass_options,
) -> refl_status {
    guard("refl_layered_pass_prepare", || {
        // SAFETY: caller contract.
        unsafe { scratch_required(input, scratch.cast_const()) }?;
        // SAFETY: caller contract.
        let i = unsafe { inputs(input, options) }?;
        let need = i.inp.maps_len;
        if need == 0 {
            return Ok(());
        }
        let bytes = check_buffer(scratch.cast_const(), scratch_len, "scratch")?;
        if scratch_len < need {
            return Err(fail(
                Error::InsufficientSize,
                format_args!(
                    "`scratch_len` is {scratch_len}, the pass needs {need} (refl_layered_pass_scratch_len)"
                ),
            ));
        }
        i.disjoint(&[(scratch as usize, bytes)], &[])?;
        // SAFETY: non-null, aligned, writable for scratch_len records
        // (contract), size fits isize (check_buffer), disjoint from every
        // input (checked); refl_layered_bound is LayeredBound.
        let dst =
            unsafe { slice_mut_or_empty(scratch.cast::<LayeredBound>(), scratch_len, "scratch") }?;
        try_prepare_layered_pass(dst, &i.gb, &i.maps, &i.opts)
    })
}

/// One reflector triangle as a region of `refl_layered_prr_masks`: its
/// world corners and the vertex normals the G-buffer's shading normals
/// interpolate on it (any non-zero length, consistently oriented; for flat
/// shading the face normal three times).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_layered_prr_triangle {
    /// World corners.
    pub corners: [refl_vec3; 3],
    /// Vertex normals.
    pub normals: [refl_vec3; 3],
}

// refl_layered_prr_triangle is refl-core's `PrrTriangle` (`#[repr(C)]`),
// field for field: the triangles are read in place.
const _: () = {
    use core::mem::{align_of, offset_of, size_of};
    assert!(size_of::<refl_layered_prr_triangle>() == size_of::<PrrTriangle>());
    assert!(align_of::<refl_layered_prr_triangle>() == align_of::<PrrTriangle>());
    assert!(offset_of!(refl_layered_prr_triangle, corners) == offset_of!(PrrTriangle, corners));
    assert!(offset_of!(refl_layered_prr_triangle, normals) == offset_of!(PrrTriangle, normals));
    assert!(size_of::<refl_vec3>() == size_of::<[f32; 3]>());
};

/// Counts of one `refl_layered_prr_masks` call.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_layered_prr_stats {
    /// Triangles (regions) written.
    pub regions: u64,
    /// (triangle, map) pairs.
    pub pairs: u64,
    /// Pairs whose bit is set (the map may reflect on the triangle).
    pub may_reflect: u64,
    /// Of those, pairs set untested (a degenerate triangle, normals 90
    /// degrees or more from its plane).
    pub untested: u64,
}

impl From<PrrStats> for refl_layered_prr_stats {
    fn from(s: PrrStats) -> Self {
        Self {
            regions: s.regions,
            pairs: s.pairs,
            may_reflect: s.may_reflect,
            untested: s.untested,
        }
    }
}

/// Size query: the `uint64_t` words of the masks of `triangles` reflector
/// triangles over `maps` maps (`triangles * ceil(maps / 64)`, at least one
/// word per triangle) into `*out_len`: the `masks_len` of
/// `refl_layered_prr_masks` and the `region_masks_len` of its regions.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_len` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` if the count overflows `size_t` (only
/// where `size_t` has 32 bits).
///
/// # Safety
/// `out_len` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn refl_layered_prr_masks_len(
    out_len: *mut usize,
    triangles: u32,
    maps: u32,
) -> refl_status {
    guard("refl_layered_prr_masks_len", || {
        let out = Out::new(out_len, "out_len")?;
        let n = try_prr_masks_len(triangles as usize, maps as usize).map_err(|e| {
            fail(
                e,
                format_args!("{triangles} triangles x {maps} maps overflow"),
            )
        })?;
        // SAFETY: caller contract.
        unsafe { out.write(n) };
        Ok(())
    })
}

/// The potential-reflection-region masks of seed 001 Sec. 3.2 (Fig. 2(a))
/// for `input.regions`: for each reflector triangle `triangles[t]`, with
/// `n = ceil(scratch_len / 64)` words per triangle (at least 1), bit
/// `k % 64` of `masks[t * n + k / 64]` is set if map k (of the `scratch`
/// that `refl_layered_pass_prepare` wrote for this frame, `scratch_len`
/// maps) may reflect on the triangle for a camera at `eye`: the seed's cone test
/// (`refl_layered_prr_classify`) against the map's bounding sphere,
/// widened so that the masks keep every map the pass's per-ray sphere test
/// can pass for a pixel on the triangle (interpolated normals, rounding;
/// refl-core's `prr_radii` documents the widening). Bits of no map are 0.
/// Call it per frame after `refl_layered_pass_prepare`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats` is NULL, or `masks`,
/// `triangles` or `scratch` with a non-zero length;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `masks_len` is below
/// `refl_layered_prr_masks_len`; `REFL_STATUS_INVALID_ARGUMENT` for a
/// non-finite `eye`, corner or normal, a count that overflows,
/// a record of `scratch` with a non-finite center or radius (or a negative
/// radius), a misaligned pointer, or `masks` overlapping an input. Nothing
/// is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `masks` NULL or writable for `masks_len`
/// values; `triangles` NULL or readable for `triangles_len` records;
/// `scratch` NULL or readable for `scratch_len` records.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_layered_prr_masks(
    out_stats: *mut refl_layered_prr_stats,
    masks: *mut u64,
    masks_len: usize,
    triangles: *const refl_layered_prr_triangle,
    triangles_len: usize,
    eye: refl_vec3,
    scratch: *const refl_layered_bound,
    scratch_len: usize,
) -> refl_status {
    guard("refl_layered_prr_masks", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        let masks_bytes = optional_out(masks.cast_const(), masks_len, "masks")?;
        // SAFETY: caller contract; refl_layered_prr_triangle is PrrTriangle
        // (asserted above).
        let tris =
            unsafe { slice_or_empty(triangles.cast::<PrrTriangle>(), triangles_len, "triangles") }?;
        // SAFETY: caller contract; refl_layered_bound is LayeredBound.
        let bounds =
            unsafe { slice_or_empty(scratch.cast::<LayeredBound>(), scratch_len, "scratch") }?;
        let need = try_prr_masks_len(triangles_len, scratch_len)?;
        if masks_len < need {
            return Err(fail(
                Error::InsufficientSize,
                format_args!(
                    "`masks_len` is {masks_len}, {triangles_len} triangles over {scratch_len} maps need {need} (refl_layered_prr_masks_len)"
                ),
            ));
        }
        let outs = [
            (masks as usize, masks_bytes),
            (
                out_stats as usize,
                core::mem::size_of::<refl_layered_prr_stats>(),
            ),
        ];
        let ins = [range(triangles, triangles_len), range(scratch, scratch_len)];
        for (k, a) in outs.iter().enumerate() {
            if outs[k + 1..]
                .iter()
                .chain(&ins)
                .any(|b| overlaps(a.0, a.1, b.0, b.1))
            {
                return Err(fail(
                    Error::InvalidArgument,
                    format_args!("the outputs overlap each other or an input"),
                ));
            }
        }
        // SAFETY: checked non-null (or empty), aligned, size fits isize;
        // writable by contract, disjoint from the inputs (checked).
        let dst = unsafe { slice_mut_or_empty(masks, masks_len, "masks") }?;
        let st = try_prr_masks(dst, tris, eye.into(), bounds).map_err(|e| {
            fail(
                e,
                format_args!("`eye`, a triangle or a scratch record is not finite"),
            )
        })?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(st.into()) };
        Ok(())
    })
}

/// Where a C band's results go.
struct Sink<'a> {
    texels: *mut refl_layered_pass_texel,
    width: usize,
    color: Option<ImageViewMut<'a, [f32; 3]>>,
    host: *mut refl_host_ray,
    host_len: usize,
}

impl LayeredPassSink for Sink<'_> {
    fn texel(&mut self, x: u32, y: u32, t: &LayeredPassTexel, color: [f32; 3]) {
        let i = y as usize * self.width + x as usize;
        // SAFETY: `i` indexes the image's texels (x < width, y < height),
        // within `out_len >= width * height` writable texels (checked by
        // `refl_layered_trace_rows`, contract).
        unsafe { self.texels.add(i).write((*t).into()) };
        if let Some(c) = self.color.as_mut().and_then(|c| c.get_mut(x, y)) {
            *c = color;
        }
    }

    fn host(&mut self, index: u32, r: &LayeredHostRay) -> bool {
        // SAFETY: `host` non-null, aligned and writable for `host_len`
        // entries, or `host_len` 0 (checked by `refl_layered_trace_rows`).
        unsafe { put_host_ray(self.host, self.host_len, index, (*r).into()) }
    }
}

/// The bytes of an optional output array: 0 for NULL with a zero length,
/// else checked as `check_buffer`.
fn optional_out<T>(p: *const T, len: usize, name: &str) -> Result<usize, Error> {
    if p.is_null() && len == 0 {
        Ok(0)
    } else {
        check_buffer(p, len, name)
    }
}

/// Runs the pass over the rows `rows` of the G-buffer: for each pixel of
/// those rows writes its `refl_layered_pass_texel` to `out[y * width + x]`
/// (`out` holds the whole `width x height` image, row stride `width`; only
/// the band's rows are written), its payload color to `color` if
/// `color.data` is not NULL (needs `options.payload_color`; black where
/// there is no hit), and appends the pixels the maps cannot answer to
/// `host` (up to `host_len`; NULL with 0 allowed; origin the surface
/// point, `t_min` and `t_max` the options', status a
/// `refl_layered_pass_status`) in row-major order. The counts go to
/// `*out_stats`. Per pixel (seed 001 Sec. 3.3-3.4 on each map): the mirror
/// ray and its start exactly as `refl_ssr_trace_rows` makes them, traced
/// with `refl_layered_trace_ray` against every map that applies (not the
/// pixel's own object's, with ids; one whose sphere the ray meets), each
/// later map only up to the nearest hit so far; the nearest hit wins.
///
/// Bands are independent: split the rows (`refl_image_row_band`) across
/// threads, each with its own `host` list. `scratch` is what
/// `refl_layered_pass_prepare` wrote for these maps.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `out`, `input`,
/// `options`, `scratch` (with maps), a required image, a map buffer, or
/// `host` with a non-zero `host_len` is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len < width * height`,
/// `scratch_len` is below the number of maps, or an image's or map
/// buffer's `len` is too small; `REFL_STATUS_INVALID_ARGUMENT` for rows
/// reversed or beyond the height, `color` not of the camera's size or
/// given without `payload_color`, outputs overlapping each other or the
/// inputs, a scratch not prepared for these maps (other maps, order or
/// placement), a region id neither below the regions of
/// `input.region_masks` nor `REFL_LAYERED_NO_REGION`, and the cases of `refl_layered_pass_prepare`.
/// Nothing is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out` NULL or writable for `out_len`
/// texels; `color.data` NULL or writable for `color.len` texels; `host`
/// NULL or writable for `host_len` entries; `scratch` NULL or readable for
/// `scratch_len` records; the rest as `refl_layered_pass_prepare`. No
/// other thread writes the rows of `out` and `color` this call writes.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_layered_trace_rows(
    out_stats: *mut refl_layered_pass_stats,
    out: *mut refl_layered_pass_texel,
    out_len: usize,
    color: refl_image_vec3_mut,
    host: *mut refl_host_ray,
    host_len: usize,
    input: *const refl_layered_pass_input,
    options: *const refl_layered_pass_options,
    scratch: *const refl_layered_bound,
    scratch_len: usize,
    rows: refl_row_range,
) -> refl_status {
    guard("refl_layered_trace_rows", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        let out_bytes = check_buffer(out.cast_const(), out_len, "out")?;
        let host_bytes = optional_out(host.cast_const(), host_len, "host")?;
        // SAFETY: caller contract.
        unsafe { scratch_required(input, scratch) }?;
        // SAFETY: caller contract.
        let i = unsafe { inputs(input, options) }?;
        let (w, h) = (i.gb.width(), i.gb.height());
        let rows = rows.within(h)?;
        let need = (w as usize)
            .checked_mul(h as usize)
            .ok_or(Error::InvalidArgument)?;
        if out_len < need {
            return Err(fail(
                Error::InsufficientSize,
                format_args!("`out_len` is {out_len}, a {w}x{h} image needs {need}"),
            ));
        }
        let color_bytes = if color.data.is_null() {
            0
        } else {
            if !i.opts.payload_color || color.width != w || color.height != h {
                return Err(fail(
                    Error::InvalidArgument,
                    format_args!("`color` needs options.payload_color and the camera's size"),
                ));
            }
            byte_len::<[f32; 3]>(color.data as usize, color.len)?
        };
        // SAFETY: caller contract.
        let (sc, sc_len) = unsafe { bounds(scratch, scratch_len, i.inp.maps_len) }?;
        i.disjoint(
            &[
                (out as usize, out_bytes),
                (host as usize, host_bytes),
                (color.data as usize, color_bytes),
                (
                    out_stats as usize,
                    core::mem::size_of::<refl_layered_pass_stats>(),
                ),
            ],
            &[range(scratch, sc_len)],
        )?;
        let p = pass(&i, sc)?;
        let color_view = if color.data.is_null() {
            None
        } else {
            // SAFETY: caller contract (the band's rows writable, not
            // accessed by others during the call).
            Some(unsafe { color.band_mut(rows) }?)
        };
        let mut sink = Sink {
            texels: out,
            width: w as usize,
            color: color_view,
            host,
            host_len,
        };
        let st = p.try_run_rows(rows, &mut sink)?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(st.into()) };
        Ok(())
    })
}

/// Traces the host's own rays `rays[k]` (e.g. the host rays of
/// `refl_ssr_trace_rows`; their `status` is not read) against the maps as
/// `refl_layered_trace_rows` traces a pixel's ray, from `origin + t_min *
/// dir` up to `t_max` (no start rule), skipping with ids the maps of the
/// object at the ray's (x, y) (none outside the image). Writes ray k's
/// texel to `out[k]` (`t` from the ray's origin), its payload color to
/// `color[k]` if `color` is not NULL (needs `options.payload_color`), and
/// appends the rays the maps cannot answer to `host` (up to `host_len`;
/// NULL with 0 allowed) in order, with their own x, y, origin, t_min and
/// t_max. The counts go to `*out_stats`. Every ray is validated first.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out_stats`, `input`, `options`,
/// `scratch` (with maps), a required image, a map buffer, or `out`,
/// `rays`, `color`, `host` with a non-zero length is NULL;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len` or (with `color`)
/// `color_len` is below `rays_len`, or as `refl_layered_trace_rows`;
/// `REFL_STATUS_INVALID_ARGUMENT` for a ray with a non-finite origin or
/// direction, a direction whose length is not 1 (within about 1e-3), a
/// `t_min` negative or not finite, a `t_max` not above `t_min`, a start
/// point beyond the float range, `color` given without `payload_color`,
/// outputs overlapping each other or the inputs (`rays` included), and
/// the cases of `refl_layered_trace_rows`. Nothing is written on error.
///
/// # Safety
/// `out_stats` NULL or writable; `out`, `color`, `host` NULL or writable
/// for `out_len`, `color_len`, `host_len` elements; `rays` NULL or
/// readable for `rays_len`; the rest as `refl_layered_trace_rows`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_layered_trace_host_rays(
    out_stats: *mut refl_layered_pass_stats,
    out: *mut refl_layered_pass_texel,
    out_len: usize,
    color: *mut refl_vec3,
    color_len: usize,
    host: *mut refl_host_ray,
    host_len: usize,
    input: *const refl_layered_pass_input,
    options: *const refl_layered_pass_options,
    scratch: *const refl_layered_bound,
    scratch_len: usize,
    rays: *const refl_host_ray,
    rays_len: usize,
) -> refl_status {
    guard("refl_layered_trace_host_rays", || {
        let stats_out = Out::new(out_stats, "out_stats")?;
        let out_bytes = optional_out(out.cast_const(), out_len, "out")?;
        let color_bytes = optional_out(color.cast_const(), color_len, "color")?;
        let host_bytes = optional_out(host.cast_const(), host_len, "host")?;
        let rays_bytes = optional_out(rays, rays_len, "rays")?;
        // SAFETY: caller contract.
        unsafe { scratch_required(input, scratch) }?;
        // SAFETY: caller contract.
        let i = unsafe { inputs(input, options) }?;
        if out_len < rays_len {
            return Err(fail(
                Error::InsufficientSize,
                format_args!("`out_len` is {out_len}, there are {rays_len} rays"),
            ));
        }
        let with_color = !color.is_null();
        if with_color && color_len < rays_len {
            return Err(fail(
                Error::InsufficientSize,
                format_args!("`color_len` is {color_len}, there are {rays_len} rays"),
            ));
        }
        if with_color && !i.opts.payload_color {
            return Err(fail(
                Error::InvalidArgument,
                format_args!("`color` needs options.payload_color"),
            ));
        }
        // SAFETY: caller contract.
        let (sc, sc_len) = unsafe { bounds(scratch, scratch_len, i.inp.maps_len) }?;
        i.disjoint(
            &[
                (out as usize, out_bytes),
                (color as usize, color_bytes),
                (host as usize, host_bytes),
                (
                    out_stats as usize,
                    core::mem::size_of::<refl_layered_pass_stats>(),
                ),
            ],
            &[range(scratch, sc_len), (rays as usize, rays_bytes)],
        )?;
        let p = pass(&i, sc)?;
        // SAFETY: checked non-null (or empty), aligned, sizes fit isize;
        // readable by contract; ListedRay is refl_host_ray.
        let rays = unsafe { slice_or_empty(rays.cast::<ListedRay>(), rays_len, "rays") }?;
        // SAFETY: as above, writable by contract, disjoint from every input
        // and each other (checked).
        let out = unsafe { slice_mut_or_empty(out, rays_len, "out") }?;
        // SAFETY: as above; refl_vec3 is three floats.
        let colors = unsafe { slice_mut_or_empty(color.cast::<[f32; 3]>(), color_len, "color") }?;
        // SAFETY: as above.
        let host = unsafe { slice_mut_or_empty(host, host_len, "host") }?;
        let st = p
            .try_trace_rays(out, with_color.then_some(colors), host, rays)
            .map_err(|e| {
                fail(
                    e,
                    format_args!(
                        "a ray of `rays` is refused (non-finite, not unit length, or t_min/t_max out of range)"
                    ),
                )
            })?;
        // SAFETY: caller contract.
        unsafe { stats_out.write(st.into()) };
        Ok(())
    })
}
