//! Tracing a ray against a layered depth cube map (seed 001 Sec. 3.3-3.4,
//! Algorithm 1): [`LayeredMap`], the face walk (linear search through
//! the layers, then binary search), the empty-space skip walk over the
//! bound pyramid (ours), the comparison of the faces' candidates with
//! the seed's early stop, and the exit of a ray from the object.

use super::{bound_levels, bounds_per_face, level_dim, LayeredGrid, LAYERED_STAMP_LEN};
use super::{Face, LayeredHit, LayeredMiss, LayeredOptions, LayeredTrace, LayeredWork};
use crate::{Error, Ray};
use glam::Vec3;

/// How many texels (along the ray's dominant axis) before the object's
/// surface the ray of [`LayeredMap::exit`] may start: the G-buffer's front
/// point and the map's surface differ by the map's discretization.
pub const EXIT_ENTRY_TEXELS: f32 = 2.0;

/// The parameter range `[t0, t1]` within `[0, t_max]` of the ray `o + t d`
/// (box coordinates) inside the unit cube (slab clipping), or `None` if it
/// misses the cube.
fn clip_unit_cube(o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
    let (mut t0, mut t1) = (0.0f32, t_max);
    for a in 0..3 {
        if d[a] == 0.0 {
            if !(o[a] >= 0.0 && o[a] <= 1.0) {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d[a];
        let (mut ta, mut tb) = ((0.0 - o[a]) * inv, (1.0 - o[a]) * inv);
        if ta > tb {
            core::mem::swap(&mut ta, &mut tb);
        }
        t0 = t0.max(ta);
        t1 = t1.min(tb);
    }
    (t0 <= t1).then_some((t0, t1))
}

/// A read-only layered depth cube map over caller buffers: what rays are
/// traced against.
///
/// The contents are not validated (that would cost a pass over the map per
/// construction): a corrupt map (counts above the layer count, NaN depths,
/// a face inconsistent with its opposite) gives meaningless hits, but never
/// an out-of-bounds access or a panic.
#[derive(Clone, Copy, Debug)]
pub struct LayeredMap<'a> {
    pub(super) grid: LayeredGrid,
    pub(super) depth: &'a [f32],
    pub(super) payload: &'a [u32],
    pub(super) counts: &'a [u32],
    pub(super) bounds: &'a [f32],
}

/// The outcome of searching one face.
enum FaceOutcome {
    Hit(Candidate),
    StartedInside,
    Nothing { out_of_steps: bool },
}

/// A face's hit before the faces are compared.
#[derive(Clone, Copy)]
struct Candidate {
    t: f32,
    face: Face,
    texel: [u32; 2],
    layer: u32,
    mismatch: f32,
    /// The hit lies on interpolated depth (see [`LayeredOptions::smooth_texels`]).
    smooth: bool,
}

impl Candidate {
    /// Whether the seed's early stop accepts it: on interpolated depth and
    /// within the threshold of the surface.
    fn confident(&self, p: &LayeredOptions) -> bool {
        self.smooth && self.mismatch <= p.early_stop_texels
    }

    /// Ranking between faces: confident hits first, then hits on
    /// interpolated depth, then the seed's smallest `|h - z|`.
    fn better_than(&self, o: &Candidate, p: &LayeredOptions) -> bool {
        let key = |c: &Candidate| (!c.confident(p), !c.smooth);
        match key(self).cmp(&key(o)) {
            core::cmp::Ordering::Less => true,
            core::cmp::Ordering::Greater => false,
            core::cmp::Ordering::Equal => self.mismatch < o.mismatch,
        }
    }
}

/// The bound pyramid of one searched face: level `l` (1-based) starts at
/// `off[l]` and has `dim[l]` cells a side of `2 * layers` values.
struct Pyramid {
    levels: u32,
    off: [usize; 33],
    dim: [usize; 33],
}

/// Inside a layer at a sample.
#[derive(Clone, Copy)]
struct Inside {
    /// Layer of the searched face.
    layer: u32,
    /// `h - z`: how far behind the layer's front surface (normalized).
    front: f32,
}

/// The inside test of one face at one point.
#[derive(Clone, Copy)]
struct Sample {
    texel: [u32; 2],
    inside: Option<Inside>,
    /// The depths were interpolated (continuous neighborhood).
    smooth: bool,
}

impl<'a> LayeredMap<'a> {
    /// Binds read-only buffers (sizes from [`try_layered_len`](super::try_layered_len)) to `grid`.
    /// `bounds` must hold what [`LayeredMapMut::build_bounds`](super::LayeredMapMut::build_bounds) (or the
    /// "never skip" marks of [`LayeredMapMut::try_fill_column`](super::LayeredMapMut::try_fill_column)) left
    /// there; bounds that claim emptiness where the map has surfaces make
    /// traces skip them.
    ///
    /// # Errors
    /// * [`Error::InsufficientSize`] if a buffer is shorter than
    ///   [`LayeredGrid::len`] says.
    /// * [`Error::InvalidArgument`] if the map's stamp
    ///   ([`LAYERED_STAMP_LEN`]) is not `grid`'s: cleared for another
    ///   resolution, layer count or box, or never cleared.
    pub fn try_new(
        grid: LayeredGrid,
        depth: &'a [f32],
        payload: &'a [u32],
        counts: &'a [u32],
        bounds: &'a [f32],
    ) -> Result<Self, Error> {
        grid.check_buffers(depth.len(), payload.len(), counts.len(), bounds.len())?;
        let at = grid.stamp_at();
        if counts[at..at + LAYERED_STAMP_LEN] != grid.stamp() {
            return Err(Error::InvalidArgument);
        }
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

    /// The stored layer count of texel `(i, j)` of `face` (`None` out of
    /// range).
    pub fn count(&self, face: Face, i: u32, j: u32) -> Option<u32> {
        (i < self.grid.res && j < self.grid.res)
            .then(|| self.counts[self.grid.texel_index(face, i, j)])
    }

    /// Depth (normalized, from the face) and payload of layer `k` of texel
    /// `(i, j)` of `face` (`None` out of range, or `k` not below the
    /// texel's count).
    pub fn layer(&self, face: Face, i: u32, j: u32, k: u32) -> Option<(f32, u32)> {
        let c = self.count(face, i, j)?;
        if k >= c.min(self.grid.layers) {
            return None;
        }
        let idx = self.grid.texel_index(face, i, j) * self.grid.layers as usize + k as usize;
        Some((self.depth[idx], self.payload[idx]))
    }

    /// Whether the world point `p` lies inside the object as seen by
    /// `face`: along the face's viewing axis it lies between the front
    /// depth of some layer and that layer's back depth read from the
    /// opposite face (seed 001 Sec. 3.4, Algorithm 1 lines 6-17). Returns
    /// the layer, or `None` outside the object or the box.
    pub fn inside(&self, face: Face, p: Vec3) -> Option<u32> {
        let q = self.grid.box_coords(p);
        if !(q.cmpge(Vec3::ZERO).all() && q.cmple(Vec3::ONE).all()) {
            return None;
        }
        let mut fetches = 0;
        self.sample(face, q, &mut fetches).inside.map(|x| x.layer)
    }

    /// Where a ray that starts on the object's surface (at or within
    /// [`EXIT_ENTRY_TEXELS`] texels before it, e.g. a primary ray from
    /// the front surface a G-buffer pixel sees) leaves the object: the
    /// distance along the unit-direction `ray` of the first exit crossing
    /// behind its entry, or `None` if the ray does not enter the object
    /// within that window (the surface is not this object's, or the object
    /// is thinner than the map resolves) or the input is not finite.
    ///
    /// Ours, on seed 001's inside test (Sec. 3.4, Algorithm 1 lines 6-17:
    /// a point is inside when it lies between a layer's front depth and
    /// that layer's back depth read from the opposite face), on all three
    /// axes: a point is inside when one of them says so (near an axis's
    /// silhouette of the object its columns answer from a texel that may
    /// lie outside the silhouette, while an axis along the surface normal
    /// sees the point inside; the cost is exits up to about one texel late
    /// where the ray leaves at a grazing angle): samples every half texel (along the ray's
    /// dominant axis) from the ray's origin find the first inside point
    /// (within the window), then the first outside point behind it, and 24
    /// bisections between them locate the exit. Depths are interpolated between
    /// continuous texels (as [`LayeredOptions::smooth_texels`] at its
    /// default, 4 texels). A ray still inside where it leaves the box exits
    /// there. Hits of the exit closer than a texel to a thin gap may skip
    /// it (half-texel sampling).
    pub fn exit(&self, ray: &Ray) -> Option<f32> {
        let g = &self.grid;
        let o = g.box_coords(ray.origin);
        let d = g.local_from_world.transform_vector3(ray.dir) * g.inv_extent;
        if !(o.is_finite() && d.is_finite()) {
            return None;
        }
        let res = g.res as f32;
        let dmax = d.abs().max_element();
        if !(dmax > 0.0) {
            return None;
        }
        let (t0, t1) = clip_unit_cube(o, d, f32::INFINITY)?;
        let texel = 1.0 / (dmax * res);
        let window = EXIT_ENTRY_TEXELS * texel;
        if t0 > window {
            return None;
        }
        let faces = [0u32, 1, 2].map(|a| Face::of_axis(a, d[a as usize] < 0.0));
        let tau = LayeredOptions::default().smooth_texels / res;
        let mut fetches = 0u32;
        // Inside on any of the three axes: an axis's columns are unreliable
        // near that axis's silhouette of the object (the nearest texel may
        // lie outside it), where some other axis sees the point inside.
        let inside = |t: f32, fetches: &mut u32| {
            let q = (o + d * t).clamp(Vec3::ZERO, Vec3::ONE);
            faces
                .iter()
                .any(|&f| self.sample_smooth(f, q, tau, fetches).inside.is_some())
        };
        let step = 0.5 * texel;
        // The entry: the first inside sample within the window.
        let mut t = t0;
        loop {
            if inside(t, &mut fetches) {
                break;
            }
            t += step;
            if t > window.min(t1) {
                return None;
            }
        }
        // The exit: the first outside sample behind it.
        let mut lo = t;
        let hi = loop {
            let next = lo + step;
            if next >= t1 {
                if inside(t1, &mut fetches) {
                    return Some(t1);
                }
                break t1;
            }
            if !inside(next, &mut fetches) {
                break next;
            }
            lo = next;
        };
        let mut hi = hi;
        for _ in 0..24 {
            let mid = 0.5 * (lo + hi);
            if inside(mid, &mut fetches) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(0.5 * (lo + hi))
    }

    /// Algorithm 1's inner loop at box point `q` for `face`.
    #[inline]
    fn sample(&self, face: Face, q: Vec3, fetches: &mut u32) -> Sample {
        let res = self.grid.res;
        let a = face.axis();
        let (u, v) = face.uv_axes();
        let cell = |x: f32| {
            let c = (x * res as f32) as i64; // saturating; NaN -> 0
            c.clamp(0, res as i64 - 1) as u32
        };
        let (i, j) = (cell(q[u]), cell(q[v]));
        let texel = [i, j];
        // h: the sample's depth seen from the face (normalized).
        let h = if face.is_positive() { 1.0 - q[a] } else { q[a] };
        let l = self.grid.layers as usize;
        let ni = self.grid.texel_index(face, i, j);
        let fi = self.grid.texel_index(face.opposite(), i, j);
        // The fill functions give a face and its opposite the same count;
        // the searched face's is read (clamped: a corrupt map stays in
        // bounds).
        let m = (self.counts[ni] as usize).min(l);
        *fetches += 1;
        let (nb, fb) = (ni * l, fi * l);
        for k in 0..m {
            let z = self.depth[nb + k];
            // d: one minus the opposite face's depth of the paired layer.
            let d = 1.0 - self.depth[fb + m - 1 - k];
            *fetches += 2;
            if h < z {
                break;
            }
            if h <= d {
                return Sample {
                    texel,
                    inside: Some(Inside {
                        layer: k as u32,
                        front: h - z,
                    }),
                    smooth: false,
                };
            }
        }
        Sample {
            texel,
            inside: None,
            smooth: false,
        }
    }

    /// The inside test at box point `q` for `face` with depths bilinearly
    /// interpolated between the four nearest texel centers where they are
    /// continuous (our addition, [`LayeredOptions::smooth_texels`]; within a
    /// texel the seed reads one depth). Elsewhere, and with `tau <= 0`, it
    /// is [`LayeredMap::sample`]. `tau`: the continuity threshold in
    /// normalized depth.
    fn sample_smooth(&self, face: Face, q: Vec3, tau: f32, fetches: &mut u32) -> Sample {
        if !(tau > 0.0) {
            return self.sample(face, q, fetches);
        }
        let res = self.grid.res;
        let a = face.axis();
        let (u, v) = face.uv_axes();
        // Continuous texel coordinates relative to texel centers.
        let corner = |x: f32| {
            let c = x * res as f32 - 0.5;
            let f = libm::floorf(c);
            let lo = f as i64; // saturating; NaN -> 0
            let w = (c - f).clamp(0.0, 1.0);
            let w = if w.is_nan() { 0.0 } else { w };
            let cl = |k: i64| k.clamp(0, res as i64 - 1) as u32;
            (cl(lo), cl(lo.saturating_add(1)), w)
        };
        let (i0, i1, wx) = corner(q[u]);
        let (j0, j1, wy) = corner(q[v]);
        let l = self.grid.layers as usize;
        let opp = face.opposite();
        let ids = [(i0, j0), (i1, j0), (i0, j1), (i1, j1)];
        let mut m = [0usize; 4];
        let mut base = [(0usize, 0usize); 4];
        for (c, &(i, j)) in ids.iter().enumerate() {
            let ni = self.grid.texel_index(face, i, j);
            let fi = self.grid.texel_index(opp, i, j);
            m[c] = (self.counts[ni] as usize).min(l);
            base[c] = (ni * l, fi * l);
        }
        *fetches += 4;
        let n = m[0];
        if n == 0 || m.iter().any(|&x| x != n) {
            return self.sample(face, q, fetches);
        }
        let w = [
            (1.0 - wx) * (1.0 - wy),
            wx * (1.0 - wy),
            (1.0 - wx) * wy,
            wx * wy,
        ];
        let h = if face.is_positive() { 1.0 - q[a] } else { q[a] };
        let lerp = |vals: [f32; 4]| {
            let (mut lo, mut hi) = (vals[0], vals[0]);
            for &x in &vals[1..] {
                lo = lo.min(x);
                hi = hi.max(x);
            }
            // NaN (a corrupt map) compares false: interpolation refused.
            (hi - lo <= tau)
                .then(|| w[0] * vals[0] + w[1] * vals[1] + w[2] * vals[2] + w[3] * vals[3])
        };
        for k in 0..n {
            let zs = base.map(|(nb, _)| self.depth[nb + k]);
            *fetches += 4;
            let Some(z) = lerp(zs) else {
                return self.sample(face, q, fetches);
            };
            if h < z {
                break;
            }
            let ds = base.map(|(_, fb)| 1.0 - self.depth[fb + n - 1 - k]);
            *fetches += 4;
            let Some(d) = lerp(ds) else {
                return self.sample(face, q, fetches);
            };
            if h <= d {
                let mut s = self.sample_texel(face, q);
                s.inside = Some(Inside {
                    layer: k as u32,
                    front: h - z,
                });
                s.smooth = true;
                return s;
            }
        }
        let mut s = self.sample_texel(face, q);
        s.smooth = true;
        s
    }

    /// The nearest texel of box point `q` on `face`, with no test.
    fn sample_texel(&self, face: Face, q: Vec3) -> Sample {
        let res = self.grid.res;
        let (u, v) = face.uv_axes();
        let cell = |x: f32| {
            let c = (x * res as f32) as i64; // saturating; NaN -> 0
            c.clamp(0, res as i64 - 1) as u32
        };
        Sample {
            texel: [cell(q[u]), cell(q[v])],
            inside: None,
            smooth: false,
        }
    }

    /// The bound pyramid of `face`.
    fn pyramid(&self, face: Face) -> Pyramid {
        let res = self.grid.res;
        let per = 2 * self.grid.layers as usize;
        let levels = bound_levels(res);
        let mut p = Pyramid {
            levels,
            off: [0; 33],
            dim: [0; 33],
        };
        let mut a = face.index() * bounds_per_face(res) as usize * per;
        for l in 1..=levels as usize {
            let dim = level_dim(res, l as u32);
            p.off[l] = a;
            p.dim[l] = dim;
            a += dim * dim * per;
        }
        p
    }

    /// Empty-space skipping (our addition, see
    /// [`LayeredMapMut::build_bounds`]): from ray parameter `s` (box point
    /// `ob + d s`), walks the bound pyramid of `face` (Hi-Z style: up a
    /// level after each skipped cell, down where a cell cannot be skipped)
    /// to the first level-1 cell the ray cannot skip. Parameters are walk
    /// units (texels, see [`LayeredMap::search_face`]): the point is
    /// `ob + e s`. Returns the cell's entry and exit parameters,
    /// `(span, span)` if the ray leaves the box first, or `None` when the
    /// step cap ran out.
    ///
    /// The walk is bounded twice: by the caller's step cap (`budget`) and
    /// by `walk`, the visits a ray can need on this face (see
    /// [`walk_bound`]). Skipping only saves work, so a walk past `walk`
    /// (rounding at cell edges, seen on degenerate boxes: finding F23)
    /// stops skipping and returns `(s, span)`: the linear search covers
    /// the rest of the face.
    #[allow(clippy::too_many_arguments)]
    fn skip(
        &self,
        face: Face,
        pyr: &Pyramid,
        ob: Vec3,
        e: Vec3,
        mut s: f32,
        span: f32,
        level: &mut u32,
        budget: &mut u32,
        walk: &mut u32,
        work: &mut LayeredWork,
    ) -> Option<(f32, f32)> {
        if pyr.levels == 0 || *walk == 0 {
            return Some((s, span));
        }
        let res = self.grid.res as f32;
        let layers = self.grid.layers as usize;
        let per = 2 * layers;
        let a = face.axis();
        let (u, v) = face.uv_axes();
        let depth = |s: f32| {
            let x = ob[a] + e[a] * s;
            if face.is_positive() {
                1.0 - x
            } else {
                x
            }
        };
        loop {
            if s >= span {
                return Some((span, span));
            }
            if *budget == 0 {
                return None;
            }
            if *walk == 0 {
                return Some((s, span));
            }
            *budget -= 1;
            *walk -= 1;
            work.steps += 1;
            let l = (*level).clamp(1, pyr.levels) as usize;
            let size = (1u64 << l) as f32;
            let dim = pyr.dim[l];
            // The cell holding the point, ties broken toward the direction.
            let cell = |c: usize| -> (usize, f32, f32) {
                let x = (ob[c] + e[c] * s) * res;
                let nudge = if e[c] > 0.0 {
                    1e-3
                } else if e[c] < 0.0 {
                    -1e-3
                } else {
                    0.0
                };
                let k = (libm::floorf((x + nudge) / size) as i64).clamp(0, dim as i64 - 1);
                // Exit parameter along this axis.
                let lo = k as f32 * size;
                let hi = (lo + size).min(res);
                let te = if e[c] > 0.0 {
                    (hi / res - ob[c]) / e[c]
                } else if e[c] < 0.0 {
                    (lo / res - ob[c]) / e[c]
                } else {
                    f32::INFINITY
                };
                (k as usize, te, x)
            };
            let (ci, tu, _) = cell(u);
            let (cj, tv, _) = cell(v);
            let mut end = tu.min(tv).min(span);
            if !(end > s) {
                // On a cell edge by rounding: a nudge of 1/1000 texel
                // (at least one float step, so the walk moves).
                end = (s + 1e-3).max(float_after(s)).min(span);
            }
            let c = pyr.off[l] + (cj * dim + ci) * per;
            let (ha, hb) = (depth(s), depth(end));
            let (ha, hb) = (ha.min(hb), ha.max(hb));
            // Empty if the depth range misses every layer's hull; the
            // hulls' fronts grow with the layer, so the first hull in
            // front of the range ends the test.
            let mut empty = true;
            for k in 0..layers {
                work.fetches += 1;
                if hb < self.bounds[c + 2 * k] {
                    break;
                }
                work.fetches += 1;
                if !(ha > self.bounds[c + 2 * k + 1]) {
                    empty = false;
                    break;
                }
            }
            if empty {
                s = end;
                *level = (l as u32 + 1).min(pyr.levels);
            } else if l > 1 {
                *level = l as u32 - 1;
            } else {
                return Some((s, end));
            }
        }
    }

    /// Traces the world ray `ray` (unit direction) up to distance `t_max`
    /// (`+inf` allowed) against the map: seed 001 Sec. 3.3-3.4.
    ///
    /// 1. The ray is moved into box coordinates and clipped to the box
    ///    (the seed's entry and exit points A and B).
    /// 2. Up to three faces are searched, chosen by the signs of the
    ///    direction (for each axis, the face the ray moves away from, whose
    ///    depth `h` grows along the ray), the axis with the largest
    ///    direction component first. On each, a linear search with steps
    ///    of [`LayeredOptions::step_texels`] looks for the first sample inside
    ///    the object with Algorithm 1's layer loop; a binary search then
    ///    refines between that sample and the previous one. Ours: the
    ///    linear search jumps over cells of the bound pyramid the ray
    ///    crosses outside every layer's hull
    ///    ([`LayeredMapMut::build_bounds`](super::LayeredMapMut::build_bounds)), and the binary search runs on
    ///    interpolated depth ([`LayeredOptions::smooth_texels`]), started
    ///    only where the interpolated depth confirms the inside sample.
    /// 3. The seed's early stop: a face whose hit has `|h - z|` within
    ///    [`LayeredOptions::early_stop_texels`] is accepted at once (ours:
    ///    if the hit lies on interpolated depth); otherwise hits on
    ///    interpolated depth win over nearest-texel ones, then the smallest
    ///    mismatch over the searched faces (the face that sees the surface,
    ///    seed 001 Fig. 5).
    ///
    /// A ray whose origin lies inside the box is searched from its origin;
    /// if the origin is inside the object on every face that was searched,
    /// the result is [`LayeredMiss::StartedInside`]. If the ray enters the
    /// box from outside at a point inside the object (an object touching
    /// its box), the hit is the entry point.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a non-finite origin or direction, a
    /// direction whose length differs from 1 by more than 1e-3, a `t_max`
    /// that is NaN or not positive, or invalid `options` (see
    /// [`LayeredOptions`]).
    pub fn try_trace(
        &self,
        ray: &Ray,
        t_max: f32,
        options: &LayeredOptions,
    ) -> Result<LayeredTrace, Error> {
        let (o, d) = self.ray_coords(ray, t_max)?;
        options.validate()?;
        Ok(self.trace_valid(ray, t_max, o, d, options))
    }

    /// Traces `rays[k]` up to `t_max` into `out[k]` as
    /// [`LayeredMap::try_trace`] would (the same arguments in the same order,
    /// the ray replaced by a slice and the result by `out`). `out` holds
    /// [`LayeredTrace`]s or any type made from one (`From<LayeredTrace>`),
    /// `rays` [`Ray`]s or any type that converts into one: a host's (or the
    /// C ABI's) own records are traced in place, without a copy.
    ///
    /// Every input is validated before anything is written: on `Err` `out`
    /// is untouched. Elements of `out` past `rays.len()` are not written.
    ///
    /// # Errors
    /// * [`Error::InsufficientSize`]: `out.len() < rays.len()`.
    /// * [`Error::InvalidArgument`]: any ray, `t_max` or `options` rejected
    ///   as by [`LayeredMap::try_trace`].
    pub fn try_trace_rays<O: From<LayeredTrace>, R: Copy + Into<Ray>>(
        &self,
        out: &mut [O],
        rays: &[R],
        t_max: f32,
        options: &LayeredOptions,
    ) -> Result<(), Error> {
        if out.len() < rays.len() {
            return Err(Error::InsufficientSize);
        }
        for r in rays {
            self.ray_coords(&(*r).into(), t_max)?;
        }
        options.validate()?;
        for (o, r) in out.iter_mut().zip(rays) {
            let ray: Ray = (*r).into();
            let (a, d) = self.ray_coords(&ray, t_max)?;
            *o = self.trace_valid(&ray, t_max, a, d, options).into();
        }
        Ok(())
    }

    /// The ray's origin and direction in box coordinates, after checking
    /// the ray and `t_max` ([`LayeredMap::try_trace`]'s errors but `options`).
    fn ray_coords(&self, ray: &Ray, t_max: f32) -> Result<(Vec3, Vec3), Error> {
        if !ray.origin.is_finite()
            || !ray.dir.is_finite()
            || !((ray.dir.length_squared() - 1.0).abs() <= 2e-3)
            || !(t_max > 0.0)
        {
            return Err(Error::InvalidArgument);
        }
        let g = &self.grid;
        let o = g.box_coords(ray.origin);
        let d = g.local_from_world.transform_vector3(ray.dir) * g.inv_extent;
        if !(o.is_finite() && d.is_finite()) {
            return Err(Error::InvalidArgument);
        }
        Ok((o, d))
    }

    /// [`LayeredMap::try_trace`] on validated input (`o`, `d` from
    /// [`LayeredMap::ray_coords`]).
    fn trace_valid(
        &self,
        ray: &Ray,
        t_max: f32,
        o: Vec3,
        d: Vec3,
        options: &LayeredOptions,
    ) -> LayeredTrace {
        let g = &self.grid;
        let mut work = LayeredWork::default();
        // Slab clip against the unit cube over [0, t_max].
        let Some((t0, t1)) = clip_unit_cube(o, d, t_max) else {
            return LayeredTrace::Miss {
                reason: LayeredMiss::MissedBox,
                work,
            };
        };
        let ends_in_box = t1 >= t_max;
        let origin_in_box = t0 <= 0.0;
        // Faces: per axis the one whose depth grows along the ray, the
        // dominant axis first.
        let mut axes = [0usize, 1, 2];
        axes.sort_unstable_by(|&x, &y| d[y].abs().total_cmp(&d[x].abs()));
        let dmax = d.abs().max_element();
        let mut best: Option<Candidate> = None;
        let mut started_inside = 0;
        let mut out_of_steps = false;
        for &a in axes.iter() {
            let face = Face::of_axis(a as u32, d[a] < 0.0);
            work.faces += 1;
            match self.search_face(face, o, d, dmax, t0, t1, origin_in_box, options, &mut work) {
                FaceOutcome::Hit(c) => {
                    if best.is_none_or(|b| c.better_than(&b, options)) {
                        best = Some(c);
                    }
                    if c.confident(options) {
                        break;
                    }
                }
                FaceOutcome::StartedInside => started_inside += 1,
                FaceOutcome::Nothing { out_of_steps: s } => out_of_steps |= s,
            }
        }
        if let Some(c) = best {
            let idx = g.texel_index(c.face, c.texel[0], c.texel[1]) * g.layers as usize
                + c.layer as usize;
            work.fetches += 1;
            return LayeredTrace::Hit(LayeredHit {
                t: c.t,
                position: ray.at(c.t),
                face: c.face,
                texel: c.texel,
                layer: c.layer,
                payload: self.payload[idx],
                mismatch: c.mismatch,
                work,
            });
        }
        let reason = if started_inside == work.faces {
            LayeredMiss::StartedInside
        } else if out_of_steps {
            LayeredMiss::OutOfSteps
        } else if ends_in_box {
            LayeredMiss::EndOfRay
        } else {
            LayeredMiss::LeftBox
        };
        LayeredTrace::Miss { reason, work }
    }

    /// Linear then binary search on one face (seed 001 Algorithm 1 and the
    /// binary search of Sec. 3.3), with two additions of ours: empty space
    /// is skipped with the bound pyramid ([`LayeredMap::skip`]), and an
    /// inside sample of the linear search (nearest texel, as in the seed)
    /// starts the binary search only if the interpolated depth
    /// ([`LayeredMap::sample_smooth`]) confirms it; the binary search then
    /// runs on interpolated depth. An unconfirmed sample (a ray grazing the
    /// corner of a texel's column) does not stop the search.
    #[allow(clippy::too_many_arguments)]
    fn search_face(
        &self,
        face: Face,
        o: Vec3,
        d: Vec3,
        dmax: f32,
        t0: f32,
        t1: f32,
        origin_in_box: bool,
        p: &LayeredOptions,
        work: &mut LayeredWork,
    ) -> FaceOutcome {
        let res = self.grid.res as f32;
        // The walk's parameter s counts texels along the dominant axis from
        // the box entry (precision far away; no overflow where the box is
        // thin and `d` huge, finding F23): the point is `ob + e s` and
        // `t = t0 + s / (dmax res)`.
        let e = d / dmax / res;
        let span = (t1 - t0) * dmax * res;
        let dt = p.step_texels;
        let tau = self.depth_of_texels(face, p.smooth_texels);
        let ob = o + d * t0;
        let at = |s: f32| ob + e * s;
        let t_of = |s: f32| t0 + s / res / dmax;
        if !(e.is_finite() && span.is_finite()) {
            // A direction that vanished in box coordinates (underflow under
            // an extreme transform): the ray does not move through the map.
            return FaceOutcome::Nothing {
                out_of_steps: false,
            };
        }
        let pyr = self.pyramid(face);
        let mut level = pyr.levels.min(3);
        let mut budget = p.max_steps;
        let mut walk = walk_bound(self.grid.res, pyr.levels);
        let mut prev: Option<f32> = None;
        let mut s = 0.0f32;
        // Where the current non-skippable level-1 cell ends.
        let mut check_at = 0.0f32;
        loop {
            if s >= check_at && check_at < span {
                let Some((entry, end)) = self.skip(
                    face,
                    &pyr,
                    ob,
                    e,
                    check_at,
                    span,
                    &mut level,
                    &mut budget,
                    &mut walk,
                    work,
                ) else {
                    return FaceOutcome::Nothing { out_of_steps: true };
                };
                if entry >= span {
                    return FaceOutcome::Nothing {
                        out_of_steps: false,
                    };
                }
                check_at = end;
                if entry > s {
                    // [.., entry] was skipped: outside.
                    prev = Some(entry);
                    s = (entry + dt).min(end);
                }
                continue;
            }
            let last = s >= span;
            let s_here = s.min(span);
            if budget == 0 {
                return FaceOutcome::Nothing { out_of_steps: true };
            }
            budget -= 1;
            work.steps += 1;
            let smp = self.sample(face, at(s_here), &mut work.fetches);
            match (smp.inside, prev) {
                (None, _) => prev = Some(s_here),
                (Some(inside), None) => {
                    if origin_in_box {
                        return FaceOutcome::StartedInside;
                    }
                    // The object touches the box where the ray enters it.
                    let sm = self.sample_smooth(face, at(s_here), tau, &mut work.fetches);
                    let (sm, x) = match sm.inside {
                        Some(x) => (sm, x),
                        None => (smp, inside),
                    };
                    return FaceOutcome::Hit(self.candidate(face, t_of(s_here), &sm, x));
                }
                (Some(_), Some(lo)) => {
                    let sm = self.sample_smooth(face, at(s_here), tau, &mut work.fetches);
                    if let Some(x) = sm.inside {
                        let c = self.refine(face, ob, e, lo, s_here, (sm, x), tau, p, work);
                        let c = Candidate { t: t_of(c.t), ..c };
                        return FaceOutcome::Hit(c);
                    }
                    // A graze the interpolated depth does not confirm.
                    prev = Some(s_here);
                }
            }
            if last {
                return FaceOutcome::Nothing {
                    out_of_steps: false,
                };
            }
            // At least one float step: a step below the spacing of floats
            // near `s` (a tiny `step_texels` on a huge face) still moves.
            s = (s_here + dt).max(float_after(s_here));
        }
    }

    /// The binary search of seed 001 Sec. 3.3 between `lo` (outside) and
    /// `hi` (inside, sample `last`) on interpolated depth, in the walk
    /// units of [`LayeredMap::search_face`] (texels: the point is
    /// `ob + e s`); the candidate's `t` is the walk parameter, which the
    /// caller converts. If the interpolated surface begins before `lo`,
    /// the bracket first steps back (at most four linear steps).
    #[allow(clippy::too_many_arguments)]
    fn refine(
        &self,
        face: Face,
        ob: Vec3,
        e: Vec3,
        mut lo: f32,
        mut hi: f32,
        mut last: (Sample, Inside),
        tau: f32,
        p: &LayeredOptions,
        work: &mut LayeredWork,
    ) -> Candidate {
        let at = |s: f32| ob + e * s;
        let dt = p.step_texels;
        let mut back = 0;
        loop {
            work.binary_steps += 1;
            let m = self.sample_smooth(face, at(lo), tau, &mut work.fetches);
            let Some(x) = m.inside else { break };
            hi = lo;
            last = (m, x);
            if back == 4 || lo <= 0.0 {
                return self.candidate(face, hi, &last.0, last.1);
            }
            lo = (lo - dt).max(0.0);
            back += 1;
        }
        for _ in 0..p.binary_steps {
            if hi - lo <= p.texel_fraction {
                break;
            }
            let mid = 0.5 * (lo + hi);
            work.binary_steps += 1;
            let m = self.sample_smooth(face, at(mid), tau, &mut work.fetches);
            match m.inside {
                Some(x) => {
                    hi = mid;
                    last = (m, x);
                }
                None => lo = mid,
            }
        }
        self.candidate(face, hi, &last.0, last.1)
    }

    /// The candidate of an entry into layer `x.layer` of `face`.
    fn candidate(&self, face: Face, t: f32, s: &Sample, x: Inside) -> Candidate {
        Candidate {
            t,
            face,
            texel: s.texel,
            layer: x.layer,
            mismatch: self.texels(face, x.front),
            smooth: s.smooth,
        }
    }

    /// `texels` texels of `face` (its larger side) as a normalized depth.
    fn depth_of_texels(&self, face: Face, texels: f32) -> f32 {
        let (su, sv) = self.grid.texel_size(face);
        let ext = self.grid.max[face.axis()] - self.grid.min[face.axis()];
        texels * su.max(sv) / ext
    }

    /// A normalized depth difference along `face`'s axis in texels of the
    /// face (its larger texel side).
    fn texels(&self, face: Face, dz: f32) -> f32 {
        let (su, sv) = self.grid.texel_size(face);
        let ext = self.grid.max[face.axis()] - self.grid.min[face.axis()];
        dz * ext / su.max(sv)
    }
}

/// The smallest float above `s` (finite, `s >= 0`): `f32::next_up`,
/// which needs Rust 1.86.
fn float_after(s: f32) -> f32 {
    f32::from_bits(s.to_bits() + 1)
}

/// Bound of the empty-space walk on one face ([`LayeredMap::skip`]) of a
/// map with `res` texels a side and `levels` bound levels: a ray crosses at
/// most `2 res + 2` level-1 cells of a face (one per texel edge on each of
/// the two face axes, and the cell it starts in); each crossing costs at
/// most one visit per level down and one up. Four times that leaves room
/// for the nudges of rounding at cell edges.
fn walk_bound(res: u32, levels: u32) -> u32 {
    let crossings = 2u64 * u64::from(res) + 2;
    let visits = crossings * (2 * u64::from(levels) + 1) * 4;
    visits.min(u64::from(u32::MAX)) as u32
}
