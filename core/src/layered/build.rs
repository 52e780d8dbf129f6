//! Building a layered depth cube map (seed 001 Sec. 3.3-3.4): the grid
//! ([`LayeredGrid`]) and the orthographic column ray of each face texel,
//! and the builder ([`LayeredMapMut`]) that fills a face and its opposite
//! from one column's surface crossings, clears and stamps the map, and
//! builds the empty-space bound pyramid (our addition).

use super::{bound_levels, bounds_per_face, level_dim, try_layered_len};
use super::{Face, LayeredLen, LayeredMap, LAYERED_MAGIC, LAYERED_STAMP_LEN, NO_PAYLOAD};
use crate::Error;
use glam::{Affine3A, Vec3};

/// The geometry of a layered depth cube map: the local box, its placement
/// in the world, the face resolution and the number of layers. Built only
/// through validating constructors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayeredGrid {
    pub(super) min: Vec3,
    pub(super) max: Vec3,
    pub(super) inv_extent: Vec3,
    pub(super) res: u32,
    pub(super) layers: u32,
    world_from_local: Affine3A,
    pub(super) local_from_world: Affine3A,
}

/// A world-space orthographic ray of one face texel, for the host to cast
/// through *all* surfaces of the object (see [`LayeredGrid::try_face_ray`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColumnRay {
    /// Start point on the face plane at the texel center, world space.
    pub origin: Vec3,
    /// Unit direction into the box, world space.
    pub dir: Vec3,
    /// World length of the column: the ray leaves the box at `t = t_max`.
    pub t_max: f32,
}

impl LayeredGrid {
    /// A grid over the local box `[min, max]` with `face_res x face_res`
    /// texels per face and `layers` layers per texel, placed with the
    /// identity transform (local = world).
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: a non-finite corner, `face_res` or
    ///   `layers` zero, or buffer sizes overflowing `usize`
    ///   ([`try_layered_len`]).
    /// * [`Error::DegenerateGeometry`]: `max <= min` on some axis (a box of
    ///   zero or negative extent), or an extent so small relative to the
    ///   corners that its inverse overflows.
    pub fn try_new(min: Vec3, max: Vec3, face_res: u32, layers: u32) -> Result<Self, Error> {
        if !(min.is_finite() && max.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        try_layered_len(face_res, layers)?;
        let ext = max - min;
        if !ext.is_finite() {
            return Err(Error::InvalidArgument);
        }
        let inv = ext.recip();
        if !(ext.min_element() > 0.0) || !inv.is_finite() {
            return Err(Error::DegenerateGeometry);
        }
        Ok(Self {
            min,
            max,
            inv_extent: inv,
            res: face_res,
            layers,
            world_from_local: Affine3A::IDENTITY,
            local_from_world: Affine3A::IDENTITY,
        })
    }

    /// The same grid placed in the world by `world_from_local` (any finite,
    /// invertible affine map: rotation, translation, scale, shear). Seed 001
    /// Sec. 3.3 moves the reflection ray into "the local space of the
    /// reflected object"; this is that transform, so a map built once
    /// follows a moving object.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a non-finite matrix;
    /// [`Error::DegenerateGeometry`] for a singular one (its inverse is not
    /// finite, or the determinant is zero).
    pub fn try_with_transform(self, world_from_local: Affine3A) -> Result<Self, Error> {
        if !world_from_local.is_finite() {
            return Err(Error::InvalidArgument);
        }
        let det = world_from_local.matrix3.determinant();
        if !(det.abs() > 0.0) || !det.is_finite() {
            return Err(Error::DegenerateGeometry);
        }
        let inv = world_from_local.inverse();
        if !inv.is_finite() {
            return Err(Error::DegenerateGeometry);
        }
        Ok(Self {
            world_from_local,
            local_from_world: inv,
            ..self
        })
    }

    /// Minimum corner of the local box.
    pub const fn min(&self) -> Vec3 {
        self.min
    }

    /// Maximum corner of the local box.
    pub const fn max(&self) -> Vec3 {
        self.max
    }

    /// Texels per face side.
    pub const fn face_res(&self) -> u32 {
        self.res
    }

    /// Layers per texel.
    pub const fn layers(&self) -> u32 {
        self.layers
    }

    /// The object-to-world transform.
    pub const fn world_from_local(&self) -> Affine3A {
        self.world_from_local
    }

    /// A 32-bit fingerprint of the grid's layout and box (`min`, `max`,
    /// face resolution, layers; FNV-1a over their bits), which a map's
    /// stamp records. The placement (`world_from_local`) is not part of it:
    /// a map built once follows its moving object.
    pub fn fingerprint(&self) -> u32 {
        let mut h: u32 = 0x811c_9dc5;
        let mut eat = |word: u32| {
            for b in word.to_le_bytes() {
                h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
            }
        };
        for v in self.min.to_array().into_iter().chain(self.max.to_array()) {
            eat(v.to_bits());
        }
        eat(self.res);
        eat(self.layers);
        h
    }

    /// The stamp words of a map cleared for this grid.
    pub(super) fn stamp(&self) -> [u32; LAYERED_STAMP_LEN] {
        [LAYERED_MAGIC, self.res, self.layers, self.fingerprint()]
    }

    /// Where the stamp starts in the counts buffer.
    pub(super) fn stamp_at(&self) -> usize {
        self.len().counts - LAYERED_STAMP_LEN
    }

    /// The buffer sizes of this grid.
    pub fn len(&self) -> LayeredLen {
        // Validated at construction.
        try_layered_len(self.res, self.layers).unwrap_or(LayeredLen {
            depth: 0,
            payload: 0,
            counts: 0,
            bounds: 0,
        })
    }

    /// Local size of a texel of `face` along its `u` and `v` axes.
    pub fn texel_size(&self, face: Face) -> (f32, f32) {
        let (u, v) = face.uv_axes();
        let ext = self.max - self.min;
        (ext[u] / self.res as f32, ext[v] / self.res as f32)
    }

    /// The orthographic ray of texel `(i, j)` of `face` (seed 001 Sec. 3.3:
    /// each face is rendered orthographically): it starts on the face plane
    /// at the texel center and runs into the box along the face's viewing
    /// axis, leaving it at `t_max`. The host casts it through **all**
    /// surfaces of the object (depth peeling) and hands every hit to
    /// [`LayeredMapMut::try_fill_column`] with the same `face`, which fills
    /// this face *and its opposite* (the same column). Casting the rays of
    /// one face per axis (e.g. `-X`, `-Y`, `-Z`) therefore fills the map.
    ///
    /// Hosts whose objects touch their box should enlarge the box a little
    /// so that no surface lies exactly on a face plane.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `i` or `j` is not below the resolution;
    /// [`Error::DegenerateGeometry`] if the transformed column is not
    /// finite or has zero length.
    pub fn try_face_ray(&self, face: Face, i: u32, j: u32) -> Result<ColumnRay, Error> {
        if i >= self.res || j >= self.res {
            return Err(Error::InvalidArgument);
        }
        let a = face.axis();
        let (u, v) = face.uv_axes();
        let ext = self.max - self.min;
        let r = self.res as f32;
        let mut start = Vec3::ZERO;
        start[u] = self.min[u] + ext[u] * ((i as f32 + 0.5) / r);
        start[v] = self.min[v] + ext[v] * ((j as f32 + 0.5) / r);
        let mut step = Vec3::ZERO;
        if face.is_positive() {
            start[a] = self.max[a];
            step[a] = -ext[a];
        } else {
            start[a] = self.min[a];
            step[a] = ext[a];
        }
        let origin = self.world_from_local.transform_point3(start);
        // Length and direction in f64 (fuzz finding F10): for a nearly
        // singular transform (an axis scaled by ~1e-22) the f32 squares
        // underflow and `span / span.length()` is not unit length.
        let span = self.world_from_local.transform_vector3(step).as_dvec3();
        let len = span.length();
        let t_max = len as f32;
        if !(t_max > 0.0) || !t_max.is_finite() || !origin.is_finite() {
            return Err(Error::DegenerateGeometry);
        }
        Ok(ColumnRay {
            origin,
            dir: (span / len).as_vec3(),
            t_max,
        })
    }

    /// Box coordinates (unit cube) of a world point.
    #[inline]
    pub fn box_coords(&self, world: Vec3) -> Vec3 {
        (self.local_from_world.transform_point3(world) - self.min) * self.inv_extent
    }

    #[inline]
    pub(super) fn texel_index(&self, face: Face, i: u32, j: u32) -> usize {
        (face.index() * self.res as usize + j as usize) * self.res as usize + i as usize
    }

    pub(super) fn check_buffers(
        &self,
        depth: usize,
        payload: usize,
        counts: usize,
        bounds: usize,
    ) -> Result<(), Error> {
        let need = self.len();
        if depth < need.depth
            || payload < need.payload
            || counts < need.counts
            || bounds < need.bounds
        {
            return Err(Error::InsufficientSize);
        }
        Ok(())
    }
}

/// One surface crossing of a column ray (input of
/// [`LayeredMapMut::try_fill_column`]). `#[repr(C)]`: the C ABI's
/// `refl_layered_layer_hit` is the same record, sorted in place.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct LayerHit {
    /// Distance along the [`ColumnRay`] (world units, `0..=t_max`; values
    /// outside are clamped).
    pub t: f32,
    /// Payload of the surface (primitive id, packed color, ...).
    pub id: u32,
    /// `true` if the surface faces the ray's origin (the ray *enters* the
    /// object there), `false` where it leaves.
    pub front: bool,
}

/// What [`LayeredMapMut::try_fill_column`] made of a column's hits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ColumnFill {
    /// Solid intervals found along the column.
    pub intervals: u32,
    /// Layers stored (`min(intervals, layers)`); fewer than `intervals`
    /// means gaps were filled (the column is approximate).
    pub stored: u32,
}

/// A mutable layered depth cube map over caller buffers: the builder.
#[derive(Debug)]
pub struct LayeredMapMut<'a> {
    grid: LayeredGrid,
    depth: &'a mut [f32],
    payload: &'a mut [u32],
    counts: &'a mut [u32],
    bounds: &'a mut [f32],
}

impl<'a> LayeredMapMut<'a> {
    /// Binds the four buffers (sizes from [`try_layered_len`]; longer buffers
    /// are fine, only the prefix is used) to `grid`. The contents are left
    /// as they are; call [`LayeredMapMut::clear`] before filling.
    ///
    /// # Errors
    /// [`Error::InsufficientSize`] if a buffer is shorter than
    /// [`LayeredGrid::len`] says.
    pub fn try_new(
        grid: LayeredGrid,
        depth: &'a mut [f32],
        payload: &'a mut [u32],
        counts: &'a mut [u32],
        bounds: &'a mut [f32],
    ) -> Result<Self, Error> {
        grid.check_buffers(depth.len(), payload.len(), counts.len(), bounds.len())?;
        Ok(Self {
            grid,
            depth,
            payload,
            counts,
            bounds,
        })
    }

    /// The grid.
    pub const fn grid(&self) -> &LayeredGrid {
        &self.grid
    }

    /// Empties every texel: count 0, depth `+inf`, payload [`NO_PAYLOAD`];
    /// the bounds become those of the empty map (empty hulls: everything
    /// can be skipped), which are exact; and stamps the map with its grid
    /// ([`LAYERED_STAMP_LEN`]), which [`LayeredMap::try_new`] checks.
    pub fn clear(&mut self) {
        let n = self.grid.len();
        self.depth[..n.depth].fill(f32::INFINITY);
        self.payload[..n.payload].fill(NO_PAYLOAD);
        let at = self.grid.stamp_at();
        self.counts[..at].fill(0);
        self.counts[at..n.counts].copy_from_slice(&self.grid.stamp());
        for (k, b) in self.bounds[..n.bounds].iter_mut().enumerate() {
            *b = if k % 2 == 0 {
                f32::INFINITY
            } else {
                f32::NEG_INFINITY
            };
        }
    }

    /// Makes the bounds of every cell that may see texel `(i, j)` of `face`
    /// and its opposite "never skip" (every layer spans the whole depth):
    /// conservative until [`LayeredMapMut::build_bounds`] makes them exact
    /// again.
    fn invalidate_bounds(&mut self, face: Face, i: u32, j: u32) {
        let res = self.grid.res;
        let per = 2 * self.grid.layers as usize;
        let per_face = bounds_per_face(res) as usize * per;
        let (i0, i1) = (i.saturating_sub(1), (i + 1).min(res - 1));
        let (j0, j1) = (j.saturating_sub(1), (j + 1).min(res - 1));
        for f in [face, face.opposite()] {
            let mut off = f.index() * per_face;
            for l in 1..=bound_levels(res) {
                let dim = level_dim(res, l);
                let sh = |x: u32| (u64::from(x) >> l) as usize;
                for cj in sh(j0)..=sh(j1) {
                    for ci in sh(i0)..=sh(i1) {
                        let c = off + (cj * dim + ci) * per;
                        for k in 0..per / 2 {
                            self.bounds[c + 2 * k] = f32::NEG_INFINITY;
                            self.bounds[c + 2 * k + 1] = f32::INFINITY;
                        }
                    }
                }
                off += dim * dim * per;
            }
        }
    }

    /// Builds the empty-space bounds of every face from the filled map (our
    /// addition to seed 001, not in the paper): for each face a pyramid
    /// whose level-`l` cell `(ci, cj)` holds, for each layer `k`, the
    /// smallest front depth and the largest back depth (read from the
    /// opposite face, seed 001 Sec. 3.4) of layer `k` over the texels of
    /// the cell **dilated by one texel** on each side (`+inf` / `-inf` where
    /// none of them has layer `k`). Each texel's solid interval `k` lies in
    /// the cell's hull of layer `k`, and the depth the trace interpolates at
    /// a point comes from the (at most four) texel centers within one texel
    /// of it; so a ray whose depth range while crossing the cell misses
    /// every hull meets no solid there, and [`LayeredMap::try_trace`] skips the
    /// cell (in front of the object, behind it, or in a gap between
    /// layers of a concave object).
    ///
    /// [`LayeredMapMut::try_fill_column`] marks the cells it affects "never
    /// skip", so traces stay correct without this call, only slower; call
    /// it once after filling. Cost: about `16 * layers` reads per level-1
    /// cell (`res^2 / 4` of them per face) plus the upper levels.
    pub fn build_bounds(&mut self) {
        for face in Face::ALL {
            self.build_face_bounds(face);
        }
    }

    /// [`LayeredMapMut::build_bounds`] for `face` alone (call it for a face
    /// and its opposite after filling that column grid).
    pub fn build_face_bounds(&mut self, face: Face) {
        let res = self.grid.res;
        let levels = bound_levels(res);
        if levels == 0 {
            return;
        }
        let l = self.grid.layers as usize;
        let per = 2 * l;
        let base = face.index() * bounds_per_face(res) as usize * per;
        let opp = face.opposite();
        // Level 1 from the texels (dilated 2x2 cells: 4x4 texel windows).
        let dim1 = level_dim(res, 1);
        for cj in 0..dim1 {
            for ci in 0..dim1 {
                let c = base + (cj * dim1 + ci) * per;
                for k in 0..l {
                    self.bounds[c + 2 * k] = f32::INFINITY;
                    self.bounds[c + 2 * k + 1] = f32::NEG_INFINITY;
                }
                let (x0, x1) = (
                    (2 * ci).saturating_sub(1),
                    (2 * ci + 2).min(res as usize - 1),
                );
                let (y0, y1) = (
                    (2 * cj).saturating_sub(1),
                    (2 * cj + 2).min(res as usize - 1),
                );
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        let ni = self.grid.texel_index(face, x as u32, y as u32);
                        let fi = self.grid.texel_index(opp, x as u32, y as u32);
                        let m = (self.counts[ni] as usize).min(l);
                        for k in 0..m {
                            let z = self.depth[ni * l + k];
                            let d = 1.0 - self.depth[fi * l + m - 1 - k];
                            let (lo, hi) = (&mut self.bounds[c + 2 * k], z);
                            *lo = lo.min(hi);
                            let hi = &mut self.bounds[c + 2 * k + 1];
                            *hi = hi.max(d);
                        }
                    }
                }
            }
        }
        // Upper levels: hulls over the 2x2 children (each already dilated).
        let (mut child, mut cdim) = (base, dim1);
        for lv in 2..=levels {
            let dim = level_dim(res, lv);
            let off = child + cdim * cdim * per;
            for cj in 0..dim {
                for ci in 0..dim {
                    let c = off + (cj * dim + ci) * per;
                    for k in 0..l {
                        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                        for y in 2 * cj..(2 * cj + 2).min(cdim) {
                            for x in 2 * ci..(2 * ci + 2).min(cdim) {
                                let cc = child + (y * cdim + x) * per + 2 * k;
                                lo = lo.min(self.bounds[cc]);
                                hi = hi.max(self.bounds[cc + 1]);
                            }
                        }
                        self.bounds[c + 2 * k] = lo;
                        self.bounds[c + 2 * k + 1] = hi;
                    }
                }
            }
            child = off;
            cdim = dim;
        }
    }

    /// Fills texel `(i, j)` of `face` **and of its opposite face** from all
    /// surface crossings `hits` of the column ray [`LayeredGrid::try_face_ray`]
    /// `(face, i, j)`, in any order (the buffer is sorted in place; it is
    /// the caller's scratch).
    ///
    /// Seed 001 Sec. 3.4 peels the layers with depth peeling and assumes
    /// closed surfaces ("all front faces are paired with the corresponding
    /// back faces"). Here the sorted crossings are turned into solid
    /// intervals with an inside/outside state machine: a front hit while
    /// outside opens an interval, a back hit while inside closes it, other
    /// hits (duplicates at shared edges, strays of open meshes) are ignored;
    /// an interval left open ends at the far face. The entry of interval
    /// `k` (counted from this face) is layer `k` of `face`; its exit is
    /// layer `n - 1 - k` of the opposite face, so the back depth of a layer
    /// is found "from the opposite side" exactly as the seed reads it.
    ///
    /// **More intervals than layers** (approximate): the pair of neighboring
    /// intervals with the smallest gap is merged until `layers` remain, i.e.
    /// the thinnest empty gaps are filled with solid. With one layer a
    /// concave column becomes its hull (the seed's single-layer map of a
    /// convex object); rays through the filled gaps then hit phantom
    /// surfaces. [`ColumnFill::stored`] `< intervals` reports it.
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: `i` or `j` out of range, a NaN or
    ///   infinite `t`. Nothing is written then (the hits may be reordered).
    pub fn try_fill_column(
        &mut self,
        face: Face,
        i: u32,
        j: u32,
        hits: &mut [LayerHit],
    ) -> Result<ColumnFill, Error> {
        let ray = self.grid.try_face_ray(face, i, j)?;
        if hits.iter().any(|h| !h.t.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        hits.sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(b.front.cmp(&a.front)));
        let l = self.grid.layers as usize;
        let (near, far) = (face, face.opposite());
        let nb = self.grid.texel_index(near, i, j) * l;
        let fb = self.grid.texel_index(far, i, j) * l;
        // Intervals along the ray of `face`, in normalized depth from `face`:
        // entries go to `near`'s slots, exits (temporarily, in the same
        // order) to `far`'s slots.
        let mut n = 0usize;
        let mut intervals = 0u32;
        let mut open: Option<(f32, u32)> = None;
        let inv = 1.0 / ray.t_max;
        let (depth, payload) = (&mut *self.depth, &mut *self.payload);
        let mut push = |s0: f32, id0: u32, s1: f32, id1: u32, n: &mut usize| {
            push_interval(depth, payload, nb, fb, l, n, (s0, id0), (s1, id1));
        };
        for h in hits.iter() {
            let s = (h.t * inv).clamp(0.0, 1.0);
            match (open, h.front) {
                (None, true) => open = Some((s, h.id)),
                (Some((s0, id0)), false) => {
                    push(s0, id0, s, h.id, &mut n);
                    intervals += 1;
                    open = None;
                }
                _ => {}
            }
        }
        if let Some((s0, id0)) = open {
            push(s0, id0, 1.0, id0, &mut n);
            intervals += 1;
        }
        // The far face sees the exits in reverse order, at depth 1 - s.
        let fd = &mut self.depth[fb..fb + l];
        let fp = &mut self.payload[fb..fb + l];
        fd[..n].reverse();
        fp[..n].reverse();
        for d in fd[..n].iter_mut() {
            *d = 1.0 - *d;
        }
        fd[n..].fill(f32::INFINITY);
        fp[n..].fill(NO_PAYLOAD);
        self.depth[nb + n..nb + l].fill(f32::INFINITY);
        self.payload[nb + n..nb + l].fill(NO_PAYLOAD);
        let ni = self.grid.texel_index(near, i, j);
        let fi = self.grid.texel_index(far, i, j);
        self.counts[ni] = n as u32;
        self.counts[fi] = n as u32;
        self.invalidate_bounds(face, i, j);
        Ok(ColumnFill {
            intervals,
            stored: n as u32,
        })
    }

    /// Fills the whole of `face` (and its opposite) from the crossings of
    /// all its column rays, then rebuilds the empty-space bounds of both
    /// faces. The crossings of texel `(i, j)` are
    /// `hits[offsets[j * res + i] .. offsets[j * res + i + 1]]` (a CSR
    /// layout: `res * res + 1` non-decreasing offsets, the last at most
    /// `hits.len()`); each column is filled as by
    /// [`LayeredMapMut::try_fill_column`] (each column's slice of `hits` is
    /// sorted in place). Returns the number of approximate columns (whose
    /// gaps had to be filled because they had more intervals than layers).
    ///
    /// Everything is validated before the first write: on error the map is
    /// unchanged (fuzz finding F15: a column ray that is not finite for one
    /// texel of a huge transform used to be found after earlier columns
    /// were written).
    ///
    /// # Errors
    /// * [`Error::InsufficientSize`]: fewer than `res * res + 1` offsets.
    /// * [`Error::InvalidArgument`]: decreasing offsets, one beyond
    ///   `hits.len()`, a NaN or infinite `t`.
    /// * [`Error::DegenerateGeometry`]: the column ray of some texel of
    ///   `face` is degenerate ([`LayeredGrid::try_face_ray`]).
    pub fn try_fill_face(
        &mut self,
        face: Face,
        hits: &mut [LayerHit],
        offsets: &[usize],
    ) -> Result<u32, Error> {
        let res = self.grid.res as usize;
        let need = res
            .checked_mul(res)
            .and_then(|n| n.checked_add(1))
            .ok_or(Error::InvalidArgument)?;
        if offsets.len() < need {
            return Err(Error::InsufficientSize);
        }
        let offs = &offsets[..need];
        if offs.windows(2).any(|w| w[0] > w[1]) || offs[need - 1] > hits.len() {
            return Err(Error::InvalidArgument);
        }
        if hits.iter().any(|h| !h.t.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        for j in 0..self.grid.res {
            for i in 0..self.grid.res {
                self.grid.try_face_ray(face, i, j)?;
            }
        }
        let mut approx = 0u32;
        for j in 0..self.grid.res {
            for i in 0..self.grid.res {
                let k = j as usize * res + i as usize;
                let f = self.try_fill_column(face, i, j, &mut hits[offs[k]..offs[k + 1]])?;
                approx += (f.stored < f.intervals) as u32;
            }
        }
        self.build_face_bounds(face);
        self.build_face_bounds(face.opposite());
        Ok(approx)
    }

    /// A read-only view of the map for tracing.
    pub fn as_map(&self) -> LayeredMap<'_> {
        LayeredMap {
            grid: self.grid,
            depth: self.depth,
            payload: self.payload,
            counts: self.counts,
            bounds: self.bounds,
        }
    }
}

/// Appends the interval `[a, b]` (depth, id pairs) to a texel's interval
/// list (entries at `depth[nb..]`, exits at `depth[fb..]`, `*n` of `l`
/// slots used); when the list is full, merges across the smallest gap.
#[allow(clippy::too_many_arguments)]
fn push_interval(
    depth: &mut [f32],
    payload: &mut [u32],
    nb: usize,
    fb: usize,
    l: usize,
    n: &mut usize,
    a: (f32, u32),
    b: (f32, u32),
) {
    if *n < l {
        depth[nb + *n] = a.0;
        payload[nb + *n] = a.1;
        depth[fb + *n] = b.0;
        payload[fb + *n] = b.1;
        *n += 1;
        return;
    }
    // Merge across the smallest gap among the l + 1 intervals.
    let mut best = l - 1;
    let mut best_gap = a.0 - depth[fb + l - 1];
    for k in 0..l - 1 {
        let g = depth[nb + k + 1] - depth[fb + k];
        if g < best_gap {
            best_gap = g;
            best = k;
        }
    }
    if best == l - 1 {
        depth[fb + l - 1] = b.0;
        payload[fb + l - 1] = b.1;
        return;
    }
    depth[fb + best] = depth[fb + best + 1];
    payload[fb + best] = payload[fb + best + 1];
    for k in best + 1..l - 1 {
        depth[nb + k] = depth[nb + k + 1];
        payload[nb + k] = payload[nb + k + 1];
        depth[fb + k] = depth[fb + k + 1];
        payload[fb + k] = payload[fb + k + 1];
    }
    depth[nb + l - 1] = a.0;
    payload[nb + l - 1] = a.1;
    depth[fb + l - 1] = b.0;
    payload[fb + l - 1] = b.1;
}
