//! Layered depth cube maps and the potential-reflection-region test
//! (seed 001 Sec. 3.2-3.4, Algorithm 1): size query, column rays, filling
//! from depth-peeled hits, tracing, PRR classification.
//!
//! Buffer layout (see refl-core's `layered` module): for `res` texels per
//! face side and `L` layers, `depth` (float) and `payload` (uint32_t) hold
//! `6 * res * res * L` elements at index `((face * res + j) * res + i) * L + k`,
//! `counts` (uint32_t) holds `6 * res * res` at `(face * res + j) * res + i`
//! and then `REFL_LAYERED_STAMP_LEN` words that record the grid the map was
//! cleared for (`refl_layered_clear`; a trace with another grid is
//! `REFL_STATUS_INVALID_ARGUMENT`),
//! `bounds` (float) the empty-space pyramids (`refl_layered_build_bounds`).
//! Faces: 0 = +X, 1 = -X, 2 = +Y, 3 = -Y, 4 = +Z, 5 = -Z; each looks into
//! the box; texel axes of axis a are u = (a + 1) % 3, v = (a + 2) % 3.
//! Depths are normalized to [0, 1] from the face.

use crate::ptr::{byte_len, no_overlap, overlaps, range, read, slice, slice_mut, Out};
use crate::status::{fail, fail_str, guard, refl_status};
use crate::types::{refl_mat4, refl_ray, refl_vec3};
use refl_core::glam::{Affine3A, Mat4, Vec3};
use refl_core::layered::{
    try_layered_len, try_prr_classify, ColumnFill, Face, LayerHit, LayeredGrid, LayeredMap,
    LayeredMapMut, LayeredMiss, LayeredOptions, LayeredStamp, LayeredTrace, PrrClass,
};
use refl_core::Error;

/// Words after a layered map's per-texel counts that record the grid it
/// was cleared for (counted in `refl_layered_len`'s `counts`).
pub const REFL_LAYERED_STAMP_LEN: usize = 4;
// The header's constant is refl-core's.
const _: () = assert!(REFL_LAYERED_STAMP_LEN == refl_core::LAYERED_STAMP_LEN);

/// The geometry of a layered depth cube map.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_layered_grid {
    /// Minimum corner of the object's local box (finite).
    pub min: refl_vec3,
    /// Maximum corner of the local box; every component must exceed `min`.
    pub max: refl_vec3,
    /// Texels per face side, >= 1.
    pub face_res: u32,
    /// Layers per texel, >= 1.
    pub layers: u32,
    /// Object-to-world transform, an invertible affine matrix (last row
    /// 0, 0, 0, 1); the identity when the box is given in world space.
    pub world_from_local: refl_mat4,
}

/// Element counts of the three buffers of a layered depth cube map.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_layered_sizes {
    /// Floats of the depth buffer: `6 * res * res * layers`.
    pub depth_len: usize,
    /// uint32_t of the payload buffer: `6 * res * res * layers`.
    pub payload_len: usize,
    /// uint32_t of the layer-count buffer: `6 * res * res`.
    pub counts_len: usize,
    /// Floats of the empty-space bound buffer: per face, levels
    /// `1..=ceil(log2 res)` of `ceil(res / 2^l)^2` cells, `2 * layers`
    /// floats each (0 for res 1).
    pub bounds_len: usize,
}

/// A read-only layered depth cube map: grid plus caller buffers.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_layered_map {
    /// The grid.
    pub grid: refl_layered_grid,
    /// Normalized depths, `depth_len` floats readable.
    pub depth: *const f32,
    /// Number of floats readable from `depth`.
    pub depth_len: usize,
    /// Payloads (ids), `payload_len` readable.
    pub payload: *const u32,
    /// Number of uint32_t readable from `payload`.
    pub payload_len: usize,
    /// Per-texel layer counts, `counts_len` readable.
    pub counts: *const u32,
    /// Number of uint32_t readable from `counts`.
    pub counts_len: usize,
    /// Empty-space bounds as `refl_layered_build_bounds` (or the fill
    /// functions) left them, `bounds_len` readable.
    pub bounds: *const f32,
    /// Number of floats readable from `bounds`.
    pub bounds_len: usize,
}

/// A writable layered depth cube map (the four buffers must not overlap).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct refl_layered_map_mut {
    /// The grid.
    pub grid: refl_layered_grid,
    /// Normalized depths, `depth_len` floats writable.
    pub depth: *mut f32,
    /// Number of floats writable from `depth`.
    pub depth_len: usize,
    /// Payloads (ids), `payload_len` writable.
    pub payload: *mut u32,
    /// Number of uint32_t writable from `payload`.
    pub payload_len: usize,
    /// Per-texel layer counts, `counts_len` writable.
    pub counts: *mut u32,
    /// Number of uint32_t writable from `counts`.
    pub counts_len: usize,
    /// Empty-space bounds, `bounds_len` writable.
    pub bounds: *mut f32,
    /// Number of floats writable from `bounds`.
    pub bounds_len: usize,
}

/// The world-space orthographic ray of one face texel, to be cast through
/// every surface of the object.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_layered_column_ray {
    /// Start on the face plane at the texel center, world space.
    pub origin: refl_vec3,
    /// Unit direction into the box, world space.
    pub dir: refl_vec3,
    /// World length of the column (the ray leaves the box at `t_max`).
    pub t_max: f32,
}

/// One surface crossing along a column ray. The fill functions sort the
/// caller's array of crossings in place (it is their scratch).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_layered_layer_hit {
    /// Distance along the column ray, finite (clamped to `[0, t_max]`).
    pub t: f32,
    /// Payload of the surface (primitive id, packed color, ...).
    pub id: u32,
    /// True if the surface faces the ray origin (the ray enters the
    /// object), false where it leaves.
    pub front: bool,
}

// refl_layered_layer_hit is refl-core's `LayerHit` (`#[repr(C)]`), field for field:
// the fill functions sort the caller's array in place as core records.
const _: () = {
    use core::mem::{align_of, offset_of, size_of};
    assert!(size_of::<refl_layered_layer_hit>() == size_of::<LayerHit>());
    assert!(align_of::<refl_layered_layer_hit>() == align_of::<LayerHit>());
    assert!(offset_of!(refl_layered_layer_hit, t) == offset_of!(LayerHit, t));
    assert!(offset_of!(refl_layered_layer_hit, id) == offset_of!(LayerHit, id));
    assert!(offset_of!(refl_layered_layer_hit, front) == offset_of!(LayerHit, front));
};

/// What filling a column did.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_layered_column_fill {
    /// Solid intervals found along the column.
    pub intervals: u32,
    /// Layers stored: `min(intervals, layers)`; fewer than `intervals`
    /// means the thinnest gaps were filled (approximate column).
    pub stored: u32,
}

/// Settings of the layered trace (seed 001 Sec. 3.3, Algorithm 1);
/// `refl_layered_options_default` gives the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_layered_options {
    /// Linear-search step in texels, > 0 and finite.
    pub step_texels: f32,
    /// Cap on linear-search steps plus bound cells visited per face, >= 1.
    pub max_steps: u32,
    /// Cap on binary-search iterations, <= 64.
    pub binary_steps: u32,
    /// Binary search stops when its bracket spans at most this many
    /// texels, >= 0.
    pub texel_fraction: f32,
    /// Early stop: accept a face's hit on interpolated depth when the ray
    /// depth is within this many texels of the layer depth, >= 0 (+inf
    /// allowed).
    pub early_stop_texels: f32,
    /// The binary search interpolates depth between texel centers whose
    /// depths differ by at most this many texels (same layer count); 0
    /// reads the nearest texel only. >= 0 and finite.
    pub smooth_texels: f32,
}

/// Why a layered trace found no hit (`REFL_LAYERED_MISS_NONE` for a hit).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum refl_layered_miss {
    /// Not a miss: the ray hit.
    None = 0,
    /// The ray does not meet the box.
    MissedBox = 1,
    /// The ray crossed the box without entering the object.
    LeftBox = 2,
    /// The ray ended (t_max) inside the box before the object.
    EndOfRay = 3,
    /// The linear-search step cap was reached.
    OutOfSteps = 4,
    /// The ray starts inside the object.
    StartedInside = 5,
}

/// The result of tracing one ray against a layered depth cube map.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_layered_result {
    /// True for a hit, false for a miss.
    pub hit: bool,
    /// A `refl_layered_miss` value (0 for a hit).
    pub miss: u32,
    /// World distance along the ray of the hit (0 for a miss).
    pub t: f32,
    /// World position of the hit (zeros for a miss).
    pub position: refl_vec3,
    /// Face (0..6) whose search produced the hit.
    pub face: u32,
    /// Texel column `i` on that face.
    pub texel_x: u32,
    /// Texel row `j` on that face.
    pub texel_y: u32,
    /// Layer of that texel the hit lies in.
    pub layer: u32,
    /// Payload of that layer.
    pub payload: u32,
    /// Ray depth minus stored depth at the hit, in texels (0 for a miss).
    pub mismatch: f32,
    /// Faces searched.
    pub faces: u32,
    /// Linear-search samples plus bound-pyramid cells visited.
    pub steps: u32,
    /// Binary-search iterations.
    pub binary_steps: u32,
    /// Buffer reads.
    pub fetches: u32,
}

/// The class of a reflector triangle in the potential-reflection-region
/// test (seed 001 Sec. 3.2).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum refl_layered_prr_class {
    /// No reflection of the bounding sphere on the triangle.
    Outside = 0,
    /// The mirrored sphere is on the camera's side of the plane.
    WrongSide = 1,
    /// The camera is inside the mirrored sphere (conservatively reflects).
    CameraInside = 2,
    /// Seed case 1: a corner lies inside the cone.
    Vertex = 3,
    /// Seed case 2: an edge crosses the cone.
    Edge = 4,
    /// Seed case 3: the conic section lies inside the triangle.
    Ellipse = 5,
}

impl From<LayeredOptions> for refl_layered_options {
    fn from(p: LayeredOptions) -> Self {
        Self {
            step_texels: p.step_texels,
            max_steps: p.max_steps,
            binary_steps: p.binary_steps,
            texel_fraction: p.texel_fraction,
            early_stop_texels: p.early_stop_texels,
            smooth_texels: p.smooth_texels,
        }
    }
}

impl From<refl_layered_options> for LayeredOptions {
    fn from(p: refl_layered_options) -> Self {
        Self {
            step_texels: p.step_texels,
            max_steps: p.max_steps,
            binary_steps: p.binary_steps,
            texel_fraction: p.texel_fraction,
            early_stop_texels: p.early_stop_texels,
            smooth_texels: p.smooth_texels,
        }
    }
}

impl From<PrrClass> for refl_layered_prr_class {
    fn from(c: PrrClass) -> Self {
        match c {
            PrrClass::Outside => Self::Outside,
            PrrClass::WrongSide => Self::WrongSide,
            PrrClass::CameraInside => Self::CameraInside,
            PrrClass::Vertex => Self::Vertex,
            PrrClass::Edge => Self::Edge,
            PrrClass::Ellipse => Self::Ellipse,
        }
    }
}

impl From<LayeredTrace> for refl_layered_result {
    fn from(t: LayeredTrace) -> Self {
        let w = t.work();
        let mut r = Self {
            faces: w.faces,
            steps: w.steps,
            binary_steps: w.binary_steps,
            fetches: w.fetches,
            ..Self::default()
        };
        match t {
            LayeredTrace::Hit(h) => {
                r.hit = true;
                r.t = h.t;
                r.position = h.position.into();
                r.face = h.face as u32;
                r.texel_x = h.texel[0];
                r.texel_y = h.texel[1];
                r.layer = h.layer;
                r.payload = h.payload;
                r.mismatch = h.mismatch;
            }
            LayeredTrace::Miss { reason, .. } => {
                r.miss = match reason {
                    LayeredMiss::MissedBox => refl_layered_miss::MissedBox,
                    LayeredMiss::LeftBox => refl_layered_miss::LeftBox,
                    LayeredMiss::EndOfRay => refl_layered_miss::EndOfRay,
                    LayeredMiss::OutOfSteps => refl_layered_miss::OutOfSteps,
                    LayeredMiss::StartedInside => refl_layered_miss::StartedInside,
                } as u32;
            }
        }
        r
    }
}

impl TryFrom<&refl_layered_grid> for LayeredGrid {
    type Error = Error;

    /// Validates the grid: corners, sizes, and an affine, invertible
    /// transform.
    fn try_from(g: &refl_layered_grid) -> Result<Self, Error> {
        let m = Mat4::from(g.world_from_local);
        if !m.is_finite() {
            return Err(Error::InvalidArgument);
        }
        let row3 = m.row(3);
        if row3 != refl_core::glam::Vec4::W {
            return Err(Error::InvalidArgument);
        }
        LayeredGrid::try_new(g.min.into(), g.max.into(), g.face_res, g.layers)?
            .try_with_transform(Affine3A::from_mat4(m))
    }
}

impl From<&LayeredGrid> for refl_layered_grid {
    fn from(g: &LayeredGrid) -> Self {
        Self {
            min: g.min().into(),
            max: g.max().into(),
            face_res: g.face_res(),
            layers: g.layers(),
            world_from_local: Mat4::from(g.world_from_local()).into(),
        }
    }
}

/// A face index as a `Face`.
fn face(v: u32) -> Result<Face, Error> {
    Face::from_index(v).ok_or(Error::InvalidArgument)
}

/// Checks a caller buffer pointer: `NullPointer` if null, `InvalidArgument`
/// if misaligned or its byte length overflows. Returns its byte range.
fn buffer<T>(p: *const T, len: usize) -> Result<(usize, usize), Error> {
    if p.is_null() {
        return Err(Error::NullPointer);
    }
    if !p.is_aligned() {
        return Err(Error::InvalidArgument);
    }
    Ok((p as usize, byte_len::<T>(p as usize, len)?))
}

impl refl_layered_map {
    /// A refl-core view of the map.
    ///
    /// # Safety
    /// Each buffer must be readable for its stated length for `'a` and not
    /// be written meanwhile.
    pub unsafe fn view<'a>(&self) -> Result<LayeredMap<'a>, Error> {
        buffer(self.depth, self.depth_len)?;
        buffer(self.payload, self.payload_len)?;
        buffer(self.counts, self.counts_len)?;
        buffer(self.bounds, self.bounds_len)?;
        let grid = LayeredGrid::try_from(&self.grid)?;
        // SAFETY: non-null, aligned, lengths fit isize (checked above);
        // readability by the caller's contract.
        let (d, p, c, b) = unsafe {
            (
                core::slice::from_raw_parts(self.depth, self.depth_len),
                core::slice::from_raw_parts(self.payload, self.payload_len),
                core::slice::from_raw_parts(self.counts, self.counts_len),
                core::slice::from_raw_parts(self.bounds, self.bounds_len),
            )
        };
        LayeredMap::try_new(grid, d, p, c, b).map_err(|e| {
            if e != Error::InvalidArgument {
                return e;
            }
            // The stamp after the counts: what the map was cleared for.
            let (res, layers) = (self.grid.face_res, self.grid.layers);
            match LayeredStamp::read(c, res).or_else(|| LayeredStamp::read_tail(c)) {
                Some(st) if (st.face_res, st.layers) != (res, layers) => fail(
                    e,
                    format_args!(
                        "`map`: cleared for face_res {} and {} layers, the grid says {res} and {layers}",
                        st.face_res, st.layers
                    ),
                ),
                Some(_) => fail_str(e, "`map`: cleared for another grid box (min/max)"),
                _ => fail_str(
                    e,
                    "`map`: no stamp after the counts (never cleared with refl_layered_clear, or cleared for another face_res)",
                ),
            }
        })
    }

    /// The byte ranges of the four buffers.
    pub(crate) fn ranges(&self) -> [(usize, usize); 4] {
        [
            (self.depth as usize, self.depth_len * 4),
            (self.payload as usize, self.payload_len * 4),
            (self.counts as usize, self.counts_len * 4),
            (self.bounds as usize, self.bounds_len * 4),
        ]
    }
}

impl refl_layered_map_mut {
    /// A refl-core mutable view of the map.
    ///
    /// # Safety
    /// Each buffer must be readable and writable for its stated length for
    /// `'a` and not be accessed through another pointer meanwhile.
    pub unsafe fn view_mut<'a>(&self) -> Result<LayeredMapMut<'a>, Error> {
        let a = buffer(self.depth.cast_const(), self.depth_len)?;
        let b = buffer(self.payload.cast_const(), self.payload_len)?;
        let c = buffer(self.counts.cast_const(), self.counts_len)?;
        let e = buffer(self.bounds.cast_const(), self.bounds_len)?;
        let all = [a, b, c, e];
        for (k, x) in all.iter().enumerate() {
            if all[k + 1..].iter().any(|y| overlaps(x.0, x.1, y.0, y.1)) {
                return Err(Error::InvalidArgument);
            }
        }
        let grid = LayeredGrid::try_from(&self.grid)?;
        // SAFETY: non-null, aligned, sizes fit isize, pairwise disjoint
        // (checked above); exclusivity by the caller's contract.
        let (d, p, c, b) = unsafe {
            (
                core::slice::from_raw_parts_mut(self.depth, self.depth_len),
                core::slice::from_raw_parts_mut(self.payload, self.payload_len),
                core::slice::from_raw_parts_mut(self.counts, self.counts_len),
                core::slice::from_raw_parts_mut(self.bounds, self.bounds_len),
            )
        };
        LayeredMapMut::try_new(grid, d, p, c, b)
    }

    /// The byte ranges of the four buffers.
    fn ranges(&self) -> [(usize, usize); 4] {
        [
            (self.depth as usize, self.depth_len * 4),
            (self.payload as usize, self.payload_len * 4),
            (self.counts as usize, self.counts_len * 4),
            (self.bounds as usize, self.bounds_len * 4),
        ]
    }
}

/// The caller's crossings as refl-core records, borrowed in place (an
/// empty array may be NULL); checks that they overlap neither the map's
/// buffers nor `out` (`out_bytes` bytes at `out`).
///
/// # Safety
/// `hits` NULL or readable and writable for `count` elements, not accessed
/// through another pointer during `'a`.
unsafe fn hits_mut<'a>(
    hits: *mut refl_layered_layer_hit,
    count: usize,
    map: &refl_layered_map_mut,
    out: (usize, usize),
) -> Result<&'a mut [LayerHit], Error> {
    if count == 0 {
        return Ok(&mut []);
    }
    let r = buffer(hits.cast_const(), count)?;
    let m = map.ranges();
    no_overlap(r, &[m[0], m[1], m[2], m[3], out], "hits")?;
    // SAFETY: non-null, aligned, size fits isize (checked); readable and
    // writable by the caller's contract, disjoint from the map and `out`
    // (checked); refl_layered_layer_hit is LayerHit field for field (asserted
    // above).
    Ok(unsafe { core::slice::from_raw_parts_mut(hits.cast::<LayerHit>(), count) })
}

/// Writes to `*out` the element counts of the depth, payload, count and
/// bound buffers of a map with `face_res x face_res` texels per face and `layers`
/// layers.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a zero size or a count overflowing
/// `size_t`.
///
/// # Safety
/// `out` must be NULL or point to a writable `refl_layered_sizes`.
#[no_mangle]
pub unsafe extern "C" fn refl_layered_len(
    out: *mut refl_layered_sizes,
    face_res: u32,
    layers: u32,
) -> refl_status {
    guard("refl_layered_len", || {
        let out = Out::new(out, "out")?;
        let l = try_layered_len(face_res, layers)?;
        // SAFETY: caller contract.
        unsafe {
            out.write(refl_layered_sizes {
                depth_len: l.depth,
                payload_len: l.payload,
                counts_len: l.counts,
                bounds_len: l.bounds,
            })
        };
        Ok(())
    })
}

/// The default trace options: half-texel steps (at most 4096 steps and
/// skipped cells per face), 16 binary iterations down to 1/16 texel, early
/// stop at one texel, depth interpolated across steps of up to 4 texels.
#[no_mangle]
pub extern "C" fn refl_layered_options_default() -> refl_layered_options {
    LayeredOptions::default().into()
}

/// Writes to `*out` the world-space orthographic ray of texel `(i, j)` of
/// `face` (0..6): it starts on the face plane at the texel center and runs
/// into the box, leaving it at `t_max` (seed 001 Sec. 3.3). Cast it through
/// every surface of the object and pass all crossings to
/// `refl_layered_fill_column` with the same face; that fills the face and
/// its opposite, so one face per axis suffices.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` or `grid` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for an invalid grid (non-finite corner,
/// zero size, non-affine or non-finite matrix), a face above 5 or a texel
/// out of range; `REFL_STATUS_DEGENERATE_GEOMETRY` for a box of zero
/// extent or a singular transform.
///
/// # Safety
/// `out` must be NULL or writable; `grid` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_layered_face_ray(
    out: *mut refl_layered_column_ray,
    grid: *const refl_layered_grid,
    face: u32,
    i: u32,
    j: u32,
) -> refl_status {
    guard("refl_layered_face_ray", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let grid = LayeredGrid::try_from(&unsafe { read(grid, "grid") }?)?;
        let r = grid.try_face_ray(self::face(face)?, i, j)?;
        // SAFETY: caller contract.
        unsafe {
            out.write(refl_layered_column_ray {
                origin: r.origin.into(),
                dir: r.dir.into(),
                t_max: r.t_max,
            })
        };
        Ok(())
    })
}

/// Empties every texel of the map: count 0, depth +inf, payload
/// 0xFFFFFFFF, every bound cell the empty hull (+inf, -inf), the exact
/// bounds of the empty map; and stamps the map with its grid
/// (`REFL_LAYERED_STAMP_LEN` words after the counts).
///
/// Returns `REFL_STATUS_NULL_POINTER` if `map` or one of its buffers is
/// NULL; `REFL_STATUS_INVALID_ARGUMENT` for an invalid grid, misaligned or
/// overlapping buffers; `REFL_STATUS_INSUFFICIENT_SIZE` for a buffer
/// shorter than `refl_layered_len` says; `REFL_STATUS_DEGENERATE_GEOMETRY`
/// as for `refl_layered_face_ray`.
///
/// # Safety
/// `map` must be NULL or readable, its buffers writable for their lengths.
#[no_mangle]
pub unsafe extern "C" fn refl_layered_clear(map: *const refl_layered_map_mut) -> refl_status {
    guard("refl_layered_clear", || {
        // SAFETY: caller contract.
        let desc = unsafe { read(map, "map") }?;
        // SAFETY: caller contract.
        let mut m = unsafe { desc.view_mut() }?;
        m.clear();
        Ok(())
    })
}

/// Fills texel `(i, j)` of `face` and of its opposite face from all
/// `hits_len` crossings `hits` of the column ray `refl_layered_face_ray`
/// `(face, i, j)`, in any order (seed 001 Sec. 3.4: front layers with their
/// back faces found through the opposite face). Crossings become solid
/// intervals (a front hit while outside opens one, a back hit while inside
/// closes it, other hits are ignored, an open interval ends at the far
/// face); with more intervals than layers the smallest gaps are filled.
/// The bound cells that see the column become "never skip" (traces stay
/// correct, only slower, until `refl_layered_build_bounds`). Writes what it
/// did to `*out`. `hits` is the call's scratch: on success it is sorted in
/// place (by `t`); it must not overlap the map or `out`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `map`, one of the map's
/// buffers, or `hits` with a non-zero count is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a face above 5, a texel out of range,
/// a non-finite `t`, an invalid grid, or misaligned or overlapping buffers;
/// `REFL_STATUS_INSUFFICIENT_SIZE` and `REFL_STATUS_DEGENERATE_GEOMETRY` as
/// for `refl_layered_clear`. On error nothing is written, `hits` included.
///
/// # Safety
/// `out` NULL or writable; `map` NULL or readable with writable buffers;
/// `hits` NULL or readable and writable for `hits_len` elements.
#[no_mangle]
pub unsafe extern "C" fn refl_layered_fill_column(
    out: *mut refl_layered_column_fill,
    map: *const refl_layered_map_mut,
    face: u32,
    i: u32,
    j: u32,
    hits: *mut refl_layered_layer_hit,
    hits_len: usize,
) -> refl_status {
    let out_at = out as usize;
    guard("refl_layered_fill_column", || {
        let out = Out::new(out, "out")?;
        // SAFETY: caller contract.
        let desc = unsafe { read(map, "map") }?;
        let out_range = (out_at, core::mem::size_of::<refl_layered_column_fill>());
        if desc
            .ranges()
            .iter()
            .any(|r| overlaps(r.0, r.1, out_range.0, out_range.1))
        {
            return Err(Error::InvalidArgument);
        }
        let face = self::face(face)?;
        // SAFETY: caller contract.
        let hits = unsafe { hits_mut(hits, hits_len, &desc, out_range) }?;
        // SAFETY: caller contract.
        let mut m = unsafe { desc.view_mut() }?;
        // Validates the texel and every crossing before sorting or writing.
        let f: ColumnFill = m.try_fill_column(face, i, j, hits)?;
        // SAFETY: caller contract.
        unsafe {
            out.write(refl_layered_column_fill {
                intervals: f.intervals,
                stored: f.stored,
            })
        };
        Ok(())
    })
}

/// Fills a whole face (and its opposite) from the crossings of all its
/// column rays: the crossings of texel `(i, j)` are
/// `hits[offsets[j * res + i] .. offsets[j * res + i + 1]]`, so `offsets`
/// holds `res * res + 1` non-decreasing values with the last at most
/// `hits_len` (a CSR layout). Each column is filled as by
/// `refl_layered_fill_column`; then the empty-space bounds of `face` and
/// its opposite are rebuilt (as `refl_layered_build_bounds` does). If `out`
/// is not NULL, the number of columns whose gaps had to be filled
/// (approximate columns) is written to it. `hits` is the call's scratch:
/// on success each column's crossings are sorted in place; it must not
/// overlap the map, `offsets` or `out`.
///
/// Everything is validated before anything is written: on error the map
/// and `hits` are untouched. Returns `REFL_STATUS_NULL_POINTER` if `map`, its buffers,
/// `offsets`, or `hits` with a non-zero count is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for decreasing offsets or one beyond
/// `hits_len`, and the cases of `refl_layered_fill_column`;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `offsets_len < res * res + 1` or a
/// map buffer is short.
///
/// # Safety
/// `out` NULL or writable; `map` NULL or readable with writable buffers;
/// `hits` NULL or readable and writable for `hits_len`, `offsets` NULL or
/// readable for `offsets_len` elements.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_layered_fill_face(
    out: *mut u32,
    map: *const refl_layered_map_mut,
    face: u32,
    hits: *mut refl_layered_layer_hit,
    hits_len: usize,
    offsets: *const usize,
    offsets_len: usize,
) -> refl_status {
    let out_at = out as usize;
    guard("refl_layered_fill_face", || {
        let out = Out::optional(out, "out")?;
        // SAFETY: caller contract.
        let desc = unsafe { read(map, "map") }?;
        let face = self::face(face)?;
        let res = desc.grid.face_res as usize;
        let need = res
            .checked_mul(res)
            .and_then(|n| n.checked_add(1))
            .ok_or(Error::InvalidArgument)?;
        buffer(offsets, offsets_len)?;
        if offsets_len < need {
            return Err(Error::InsufficientSize);
        }
        let out_range = if out.is_some() { (out_at, 4) } else { (0, 0) };
        if desc
            .ranges()
            .iter()
            .any(|x| overlaps(x.0, x.1, out_range.0, out_range.1))
        {
            return Err(Error::InvalidArgument);
        }
        let m = desc.ranges();
        no_overlap(
            range(offsets, need),
            &[m[0], m[1], m[2], m[3], range(hits, hits_len)],
            "offsets",
        )?;
        // SAFETY: non-null, aligned, size checked; readable by contract and
        // disjoint from everything the call writes (checked).
        let offs = unsafe { slice(offsets, need, "offsets") }?;
        // SAFETY: caller contract.
        let hits = unsafe { hits_mut(hits, hits_len, &desc, out_range) }?;
        // SAFETY: caller contract.
        let mut m = unsafe { desc.view_mut() }?;
        // Validates everything (offsets, every crossing, every column ray)
        // before sorting or writing.
        let approx = m.try_fill_face(face, hits, offs)?;
        if let Some(o) = out {
            // SAFETY: caller contract.
            unsafe { o.write(approx) };
        }
        Ok(())
    })
}

/// Builds the empty-space bounds of all six faces from the filled map: per
/// face a pyramid of the smallest front depth over each cell dilated by one
/// texel, which lets traces skip cells the ray crosses in front of every
/// surface or behind every solid interval (an addition to seed 001).
///
/// Returns `REFL_STATUS_NULL_POINTER`, `REFL_STATUS_INVALID_ARGUMENT`,
/// `REFL_STATUS_INSUFFICIENT_SIZE` and `REFL_STATUS_DEGENERATE_GEOMETRY` as
/// `refl_layered_clear`; on error nothing is written.
///
/// # Safety
/// `map` must be NULL or readable, its buffers writable for their lengths.
#[no_mangle]
pub unsafe extern "C" fn refl_layered_build_bounds(
    map: *const refl_layered_map_mut,
) -> refl_status {
    guard("refl_layered_build_bounds", || {
        // SAFETY: caller contract.
        let desc = unsafe { read(map, "map") }?;
        // SAFETY: caller contract.
        let mut m = unsafe { desc.view_mut() }?;
        m.build_bounds();
        Ok(())
    })
}

/// Traces one world ray (unit direction) up to distance `t_max` (+inf
/// allowed) against the map (seed 001 Sec. 3.3-3.4, Algorithm 1: box clip,
/// up to three faces chosen by the direction's signs, linear then binary
/// search through the layers, early stop; with empty space skipped through
/// the bounds and the binary search on interpolated depth) and writes the
/// result to `*out`.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out`, `map`, a map buffer or
/// `options` is NULL; `REFL_STATUS_INVALID_ARGUMENT` for a non-finite ray,
/// a direction whose length is not 1 (within 1e-3), `t_max` NaN or not
/// positive, invalid parameters or grid; `REFL_STATUS_INSUFFICIENT_SIZE`
/// for a short map buffer; `REFL_STATUS_DEGENERATE_GEOMETRY` for a
/// degenerate grid.
///
/// # Safety
/// `out` NULL or writable; `map` NULL or readable with readable buffers;
/// `options` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn refl_layered_trace_ray(
    out: *mut refl_layered_result,
    map: *const refl_layered_map,
    ray: refl_ray,
    t_max: f32,
    options: *const refl_layered_options,
) -> refl_status {
    let out_at = out as usize;
    guard("refl_layered_trace_ray", || {
        let out = Out::new(out, "out")?;
        crate::ptr::no_nulls(&[(map.is_null(), "map"), (options.is_null(), "options")])?;
        // SAFETY: caller contract.
        let desc = unsafe { read(map, "map") }?;
        // SAFETY: caller contract.
        let options = LayeredOptions::from(unsafe { read(options, "options") }?);
        let r = (out_at, core::mem::size_of::<refl_layered_result>());
        if desc.ranges().iter().any(|x| overlaps(x.0, x.1, r.0, r.1)) {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: caller contract.
        let m = unsafe { desc.view() }?;
        let res = m.try_trace(&ray.into(), t_max, &options)?;
        // SAFETY: caller contract.
        unsafe { out.write(res.into()) };
        Ok(())
    })
}

/// Traces `rays_len` rays (as `refl_layered_trace_ray`, one `t_max` for all)
/// and writes result `k` to `out[k]`. All rays are validated first: on
/// error nothing is written.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `map`, a map buffer or `options`
/// is NULL, or `out` / `rays` with a non-zero count;
/// `REFL_STATUS_INSUFFICIENT_SIZE` if `out_len < rays_len` or a map buffer
/// is short; `REFL_STATUS_INVALID_ARGUMENT` as for `refl_layered_trace_ray`,
/// for any invalid ray, or for `out` overlapping `rays` or the map.
///
/// # Safety
/// `out` NULL or writable for `out_len` results; `rays` NULL or readable
/// for `rays_len`; `map` and `options` as for `refl_layered_trace_ray`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn refl_layered_trace_rays(
    out: *mut refl_layered_result,
    out_len: usize,
    map: *const refl_layered_map,
    rays: *const refl_ray,
    rays_len: usize,
    t_max: f32,
    options: *const refl_layered_options,
) -> refl_status {
    guard("refl_layered_trace_rays", || {
        crate::ptr::no_nulls(&[(map.is_null(), "map"), (options.is_null(), "options")])?;
        if rays_len == 0 {
            return Ok(());
        }
        let o = buffer(out.cast_const(), out_len)?;
        let r = buffer(rays, rays_len)?;
        if out_len < rays_len {
            return Err(Error::InsufficientSize);
        }
        // SAFETY: caller contract.
        let desc = unsafe { read(map, "map") }?;
        // SAFETY: caller contract.
        let options = LayeredOptions::from(unsafe { read(options, "options") }?);
        let o = (o.0, rays_len * core::mem::size_of::<refl_layered_result>());
        if overlaps(o.0, o.1, r.0, r.1)
            || desc.ranges().iter().any(|x| overlaps(x.0, x.1, o.0, o.1))
        {
            return Err(Error::InvalidArgument);
        }
        // SAFETY: caller contract.
        let m = unsafe { desc.view() }?;
        // SAFETY: non-null, aligned, size checked; readable by contract.
        let rays = unsafe { slice(rays, rays_len, "rays") }?;
        // SAFETY: non-null, aligned, out_len >= rays_len, disjoint from
        // the inputs (checked); writable by contract.
        let out = unsafe { slice_mut(out, rays_len, "out") }?;
        // Validates every ray, t_max and the parameters before the first
        // write.
        m.try_trace_rays(out, rays, t_max, &options)
    })
}

/// Classifies reflector triangle `p0 p1 p2` for a camera at `eye` and a
/// reflected object with bounding sphere (`center`, `radius`) with the
/// potential-reflection-region test of seed 001 Sec. 3.2 (camera cone
/// around the mirrored sphere against the triangle: corner inside, edge
/// crossing, section inside) and writes a `refl_layered_prr_class` to `*out`.
/// Classes 2-5 may show a reflection; 0 and 1 cannot.
///
/// Returns `REFL_STATUS_NULL_POINTER` if `out` is NULL;
/// `REFL_STATUS_INVALID_ARGUMENT` for a non-finite input or a radius that
/// is not positive; `REFL_STATUS_DEGENERATE_GEOMETRY` for a zero-area
/// triangle.
///
/// # Safety
/// `out` must be NULL or point to a writable `uint32_t`.
#[no_mangle]
pub unsafe extern "C" fn refl_layered_prr_classify(
    out: *mut u32,
    eye: refl_vec3,
    center: refl_vec3,
    radius: f32,
    p0: refl_vec3,
    p1: refl_vec3,
    p2: refl_vec3,
) -> refl_status {
    guard("refl_layered_prr_classify", || {
        let out = Out::new(out, "out")?;
        let c = try_prr_classify(
            eye.into(),
            center.into(),
            radius,
            [p0, p1, p2].map(Vec3::from),
        )?;
        // SAFETY: caller contract.
        unsafe { out.write(refl_layered_prr_class::from(c) as u32) };
        Ok(())
    })
}
