//! A CPU z-buffer rasterizer that produces a visibility buffer: per pixel,
//! the nearest primitive id and its linear depth, for any
//! [`refl_core::Camera`], mirrored ones included.
//!
//! Pipeline (what a GPU does, written out):
//!
//! 1. **Object culling** against the view frustum (narrowed to the scissor
//!    rectangle) and the user clip plane, with each object's bounding box.
//! 2. **Clipping** (Sutherland–Hodgman, world space) against the user clip
//!    plane, keeping the strictly positive side (geometry *in* the plane,
//!    such as the reflector itself, is dropped), then against the near plane
//!    (linear depth >= near). There is no far plane: like the reference
//!    tracer, the visibility buffer sees everything in front of the near
//!    plane.
//! 3. **Setup**: vertices are projected with [`refl_core::Camera::project`];
//!    the clipped polygon is fanned into triangles. No face is culled: a
//!    mirrored camera ([`refl_core::Camera::is_mirrored`]) reverses winding,
//!    and the scenes contain open, two-sided surfaces. Each triangle is
//!    brought to positive screen area by swapping two vertices.
//! 4. **Rasterization** at pixel centers `(x + 0.5, y + 0.5)` with the
//!    top-left fill rule. Edge functions are evaluated in f64 from the f32
//!    projected vertices, always with the two edge vertices in a canonical
//!    order, so the two triangles sharing an edge get exactly opposite
//!    values there and every pixel center on a shared edge is covered
//!    exactly once (watertight).
//! 5. **Depth test** on `1 / z` interpolated linearly in screen space (exact
//!    perspective-correct depth); ties go to the smaller primitive id, so the
//!    result does not depend on the order of work.
//!
//! Work is parallel over triangle chunks for steps 2-3 and over bands of
//! [`BAND_ROWS`] rows for steps 4-5, on the caller's rayon pool.
//!
//! Shading then reconstructs the exact hit of a pixel by intersecting the
//! camera's primary ray with the stored primitive ([`VisBuffer::hit`]).

use crate::scene::{Aabb, Scene, NONE};
use crate::tracer::{ray_triangle_plane, Hit};
use glam::{DVec2, Vec2, Vec3};
use rayon::prelude::*;
use refl_core::{Camera, Plane};

/// Rows per rasterization band (the unit of parallel work).
pub const BAND_ROWS: u32 = 8;

/// Triangles per setup work item.
pub const SETUP_CHUNK: usize = 4096;

/// A half-open pixel rectangle `[x0, x1) x [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl PixelRect {
    /// The whole `width x height` image.
    pub fn full(width: u32, height: u32) -> Self {
        Self {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// `true` if the rectangle contains no pixel.
    pub fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    /// The intersection of two rectangles.
    pub fn intersect(&self, other: &PixelRect) -> PixelRect {
        PixelRect {
            x0: self.x0.max(other.x0),
            y0: self.y0.max(other.y0),
            x1: self.x1.min(other.x1),
            y1: self.y1.min(other.y1),
        }
    }

    /// The bounding rectangle of the pixels of a `width`-wide image whose
    /// indices satisfy `keep`; `None` if there are none.
    pub fn bounding(width: u32, len: usize, keep: impl Fn(usize) -> bool) -> Option<PixelRect> {
        let mut r: Option<PixelRect> = None;
        for i in (0..len).filter(|&i| keep(i)) {
            let (x, y) = ((i % width as usize) as u32, (i / width as usize) as u32);
            let b = r.get_or_insert(PixelRect {
                x0: x,
                y0: y,
                x1: x + 1,
                y1: y + 1,
            });
            b.x0 = b.x0.min(x);
            b.x1 = b.x1.max(x + 1);
            b.y0 = b.y0.min(y);
            b.y1 = b.y1.max(y + 1);
        }
        r
    }
}

/// What to rasterize.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RasterOptions {
    /// Keep only geometry strictly on the positive side of this world-space
    /// plane (for a mirrored camera: the side in front of the mirror).
    pub clip_plane: Option<Plane>,
    /// Skip this object entirely (e.g. the reflector itself).
    pub exclude_object: Option<u32>,
    /// Only write pixels inside this rectangle (the whole image if `None`).
    pub scissor: Option<PixelRect>,
}

/// Work counters of one rasterization.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RasterStats {
    /// Objects rejected by the frustum / clip-plane test.
    pub objects_culled: usize,
    /// Triangles after clipping whose footprint covers at least one pixel
    /// center's bounding box (the ones sent to the band rasterizers).
    pub triangles_rasterized: usize,
}

/// Per-pixel nearest primitive and its linear depth.
#[derive(Clone, Debug)]
pub struct VisBuffer {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Nearest primitive id per pixel, [`NONE`] where nothing was drawn.
    pub prim: Vec<u32>,
    /// Linear depth of that primitive at the pixel center, `+inf` where
    /// nothing was drawn.
    pub depth: Vec<f32>,
    /// Work counters.
    pub stats: RasterStats,
}

impl VisBuffer {
    /// The exact hit at pixel index `i` seen through `camera` (the camera the
    /// buffer was rasterized with): the camera's primary ray through the
    /// pixel center intersected with the plane of the stored primitive.
    /// `None` where nothing was drawn.
    pub fn hit(&self, scene: &Scene, camera: &Camera, i: usize) -> Option<Hit> {
        let prim = self.prim[i];
        if prim == NONE {
            return None;
        }
        let (x, y) = (i % self.width as usize, i / self.width as usize);
        let ray = camera.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
        ray_triangle_plane(&scene.tris[prim as usize], prim, ray.origin, ray.dir)
    }
}

/// A projected triangle ready for rasterization: pixel-space vertices with
/// positive area, reciprocal linear depths, and the pixel rows/columns whose
/// centers its bounding box may cover (half-open).
#[derive(Clone, Copy)]
struct Setup {
    v: [Vec2; 3],
    inv_z: [f32; 3],
    prim: u32,
    x0: u32,
    x1: u32,
    y0: u32,
    y1: u32,
}

/// A convex polygon of at most 3 + 2 vertices (a triangle clipped by two
/// planes).
#[derive(Clone, Copy)]
struct Poly {
    v: [Vec3; 5],
    n: usize,
}

impl Poly {
    /// Sutherland–Hodgman against `dist(p) > 0` (`strict`) or `>= 0`.
    fn clip(&self, dist: impl Fn(Vec3) -> f32, strict: bool) -> Poly {
        let inside = |d: f32| if strict { d > 0.0 } else { d >= 0.0 };
        let mut out = Poly {
            v: [Vec3::ZERO; 5],
            n: 0,
        };
        let mut push = |p: Vec3| {
            if out.n < out.v.len() {
                out.v[out.n] = p;
                out.n += 1;
            }
        };
        for k in 0..self.n {
            let (a, b) = (self.v[k], self.v[(k + 1) % self.n]);
            let (da, db) = (dist(a), dist(b));
            if inside(da) {
                push(a);
            }
            if inside(da) != inside(db) {
                push(a + (b - a) * (da / (da - db)));
            }
        }
        out
    }
}

/// Rasterizes `scene` through `camera` into a visibility buffer on `pool`.
pub fn rasterize(
    scene: &Scene,
    camera: &Camera,
    options: &RasterOptions,
    pool: &rayon::ThreadPool,
) -> VisBuffer {
    let mut out = VisBuffer {
        width: 0,
        height: 0,
        prim: Vec::new(),
        depth: Vec::new(),
        stats: RasterStats::default(),
    };
    rasterize_into(&mut out, scene, camera, options, pool);
    out
}

/// Bounding boxes of every object's [`SETUP_CHUNK`]-triangle chunks (the
/// rasterizer's work items), for culling below object level when one frame
/// is drawn through many cameras (meshlet-style culling). Compute them once
/// per frame: after the scene moved they are stale.
#[derive(Clone, Debug, Default)]
pub struct ChunkBounds {
    /// `(first triangle, end triangle, bounds)` per chunk, objects in order.
    pub chunks: Vec<(u32, u32, Aabb)>,
}

impl ChunkBounds {
    /// The chunk bounds of `scene`, in parallel on `pool`.
    pub fn new(scene: &Scene, pool: &rayon::ThreadPool) -> Self {
        let mut ranges = Vec::new();
        for object in &scene.objects {
            push_chunks(&mut ranges, object.tris.clone());
        }
        let chunks = pool.install(|| {
            ranges
                .par_iter()
                .map(|&(a, b)| {
                    let mut bb = Aabb::EMPTY;
                    for t in &scene.tris[a as usize..b as usize] {
                        for &v in t {
                            bb.grow(v);
                        }
                    }
                    (a, b, bb)
                })
                .collect()
        });
        Self { chunks }
    }
}

/// Splits the triangle range `tris` into the rasterizer's work items of at
/// most [`SETUP_CHUNK`] triangles, `(start, end)` each, appended to `out`.
fn push_chunks(out: &mut Vec<(u32, u32)>, tris: std::ops::Range<u32>) {
    let mut start = tris.start;
    while start < tris.end {
        let end = (start + SETUP_CHUNK as u32).min(tris.end);
        out.push((start, end));
        start = end;
    }
}

/// [`rasterize`] into `out`, reusing its buffers (no allocation once they
/// are large enough): what a renderer drawing one depth image after another
/// does with one render target.
pub fn rasterize_into(
    out: &mut VisBuffer,
    scene: &Scene,
    camera: &Camera,
    options: &RasterOptions,
    pool: &rayon::ThreadPool,
) {
    rasterize_chunks(out, scene, camera, options, None, pool);
}

/// [`rasterize_into`] that also culls the chunks of `bounds` (computed
/// for this `scene`) against the frustum and the clip plane, after the
/// object-level test.
pub fn rasterize_into_culled(
    out: &mut VisBuffer,
    scene: &Scene,
    camera: &Camera,
    options: &RasterOptions,
    bounds: &ChunkBounds,
    pool: &rayon::ThreadPool,
) {
    rasterize_chunks(out, scene, camera, options, Some(bounds), pool);
}

fn rasterize_chunks(
    out: &mut VisBuffer,
    scene: &Scene,
    camera: &Camera,
    options: &RasterOptions,
    bounds: Option<&ChunkBounds>,
    pool: &rayon::ThreadPool,
) {
    let (w, h) = (camera.width(), camera.height());
    let full = PixelRect::full(w, h);
    let scissor = options.scissor.map_or(full, |s| s.intersect(&full));
    let mut stats = RasterStats::default();
    let n = (w as usize) * (h as usize);
    let mut prim = std::mem::take(&mut out.prim);
    prim.clear();
    prim.resize(n, NONE);
    // The depth buffer holds 1 / z while rasterizing.
    let mut inv_depth = std::mem::take(&mut out.depth);
    inv_depth.clear();
    inv_depth.resize(n, 0.0);
    if scissor.is_empty() {
        return finish(out, w, h, prim, inv_depth, stats);
    }

    // 1. Object culling, then chunks of visible triangles.
    let frustum = Frustum::new(camera, &scissor);
    let mut chunks: Vec<(u32, u32)> = Vec::new();
    for (id, object) in scene.objects.iter().enumerate() {
        if options.exclude_object == Some(id as u32) || object.tris.is_empty() {
            continue;
        }
        let corners = object.bounds.corners();
        let behind_plane = options
            .clip_plane
            .is_some_and(|plane| corners.iter().all(|&c| plane.signed_distance(c) <= 0.0));
        if behind_plane || frustum.outside(camera, &corners) {
            stats.objects_culled += 1;
            continue;
        }
        push_chunks(&mut chunks, object.tris.clone());
    }
    if let Some(b) = bounds {
        // Chunk culling: the same tests on each chunk's box (chunks are
        // sorted by their first triangle, as `chunks` is).
        let mut k = 0usize;
        chunks.retain(|&(start, _)| {
            while k < b.chunks.len() && b.chunks[k].0 < start {
                k += 1;
            }
            let Some(&(s0, _, bb)) = b.chunks.get(k) else {
                return true;
            };
            if s0 != start || bb.is_empty() {
                return true;
            }
            let corners = bb.corners();
            let behind = options
                .clip_plane
                .is_some_and(|plane| corners.iter().all(|&c| plane.signed_distance(c) <= 0.0));
            !(behind || frustum.outside(camera, &corners))
        });
    }

    // 2-3. Clip and set up triangles in parallel.
    let setups: Vec<Setup> = pool.install(|| {
        chunks
            .par_iter()
            .flat_map_iter(|&(start, end)| {
                let mut out = Vec::new();
                for p in start..end {
                    setup_triangle(scene, camera, options, &scissor, p, &mut out);
                }
                out
            })
            .collect()
    });
    stats.triangles_rasterized = setups.len();

    // Bin by bands of rows.
    let bands = h.div_ceil(BAND_ROWS) as usize;
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); bands];
    for (k, s) in setups.iter().enumerate() {
        for band in (s.y0 / BAND_ROWS)..=((s.y1 - 1) / BAND_ROWS) {
            bins[band as usize].push(k as u32);
        }
    }

    // 4-5. Rasterize the bands in parallel.
    let band_len = (w * BAND_ROWS) as usize;
    pool.install(|| {
        prim.par_chunks_mut(band_len)
            .zip(inv_depth.par_chunks_mut(band_len))
            .zip(bins.par_iter())
            .enumerate()
            .for_each(|(band, ((prim, inv_depth), bin))| {
                let row0 = band as u32 * BAND_ROWS;
                for &k in bin {
                    raster_band(&setups[k as usize], w, row0, prim, inv_depth);
                }
            });
    });
    finish(out, w, h, prim, inv_depth, stats)
}

fn finish(
    out: &mut VisBuffer,
    w: u32,
    h: u32,
    prim: Vec<u32>,
    mut depth: Vec<f32>,
    stats: RasterStats,
) {
    for (d, &p) in depth.iter_mut().zip(&prim) {
        *d = if p == NONE { f32::INFINITY } else { 1.0 / *d };
    }
    *out = VisBuffer {
        width: w,
        height: h,
        prim,
        depth,
        stats,
    };
}

/// The view frustum narrowed to a scissor rectangle, in view space (depth
/// `w = -z_view`): `x / (w tan_x)` within `ndc_x`, `y / (w tan_y)` within
/// `ndc_y`, `w >= near`.
struct Frustum {
    tan: Vec2,
    ndc_x: (f32, f32),
    ndc_y: (f32, f32),
}

impl Frustum {
    /// Slack of the culling planes (in NDC units, and relative for the near
    /// plane), so that rounding never culls a box that touches the frustum.
    const SLACK: f32 = 1e-3;

    fn new(camera: &Camera, r: &PixelRect) -> Self {
        let tan_y = (camera.fov_y() * 0.5).tan();
        let (w, h) = (camera.width() as f32, camera.height() as f32);
        Self {
            tan: Vec2::new(tan_y * camera.aspect(), tan_y),
            ndc_x: (2.0 * r.x0 as f32 / w - 1.0, 2.0 * r.x1 as f32 / w - 1.0),
            ndc_y: (1.0 - 2.0 * r.y1 as f32 / h, 1.0 - 2.0 * r.y0 as f32 / h),
        }
    }

    /// `true` if all `corners` lie outside one of the planes.
    fn outside(&self, camera: &Camera, corners: &[Vec3; 8]) -> bool {
        let v = corners.map(|c| camera.world_to_view(c));
        let all = |f: &dyn Fn(Vec3, f32) -> bool| v.iter().all(|&p| f(p, -p.z));
        let (tx, ty, e) = (self.tan.x, self.tan.y, Self::SLACK);
        all(&|_, w| w < camera.near() * (1.0 - e))
            || all(&|p, w| p.x > (self.ndc_x.1 + e) * w * tx)
            || all(&|p, w| p.x < (self.ndc_x.0 - e) * w * tx)
            || all(&|p, w| p.y > (self.ndc_y.1 + e) * w * ty)
            || all(&|p, w| p.y < (self.ndc_y.0 - e) * w * ty)
    }
}

/// Clips primitive `p`, projects it and appends the fan triangles that may
/// cover a pixel center inside `scissor`.
fn setup_triangle(
    scene: &Scene,
    camera: &Camera,
    options: &RasterOptions,
    scissor: &PixelRect,
    p: u32,
    out: &mut Vec<Setup>,
) {
    let t = scene.tris[p as usize];
    let mut poly = Poly {
        v: [t[0], t[1], t[2], Vec3::ZERO, Vec3::ZERO],
        n: 3,
    };
    if let Some(plane) = options.clip_plane {
        if !t.iter().all(|&v| plane.signed_distance(v) > 0.0) {
            poly = poly.clip(|v| plane.signed_distance(v), true);
        }
    }
    let near = camera.near();
    if !poly.v[..poly.n]
        .iter()
        .all(|&v| camera.linear_depth(v) >= near)
    {
        poly = poly.clip(|v| camera.linear_depth(v) - near, false);
    }
    if poly.n < 3 {
        return;
    }
    let mut projected = [Vec3::ZERO; 5];
    for (q, &v) in projected.iter_mut().zip(&poly.v[..poly.n]) {
        match camera.project(v) {
            Some(p) => *q = p,
            None => return,
        }
    }
    for k in 1..poly.n - 1 {
        let tri = [projected[0], projected[k], projected[k + 1]];
        let mut v = tri.map(|q| Vec2::new(q.x, q.y));
        let mut inv_z = tri.map(|q| 1.0 / q.z);
        let area = orient(v[0].as_dvec2(), v[1].as_dvec2(), v[2].as_dvec2());
        if area == 0.0 || !area.is_finite() {
            continue;
        }
        if area < 0.0 {
            v.swap(1, 2);
            inv_z.swap(1, 2);
        }
        // Pixel centers x + 0.5 within [min, max].
        let min = v[0].min(v[1]).min(v[2]);
        let max = v[0].max(v[1]).max(v[2]);
        let first = |m: f32, lo: u32| ((m - 0.5).ceil().max(lo as f32)) as u32;
        let last = |m: f32, hi: u32| ((m - 0.5).floor() + 1.0).clamp(0.0, hi as f32) as u32;
        let (x0, x1) = (first(min.x, scissor.x0), last(max.x, scissor.x1));
        let (y0, y1) = (first(min.y, scissor.y0), last(max.y, scissor.y1));
        if x0 >= x1 || y0 >= y1 {
            continue;
        }
        out.push(Setup {
            v,
            inv_z,
            prim: p,
            x0,
            x1,
            y0,
            y1,
        });
    }
}

/// Twice the signed area of `a b p`; positive when `p` is to the right of
/// `a -> b` on a y-down screen (clockwise as seen).
#[inline]
fn orient(a: DVec2, b: DVec2, p: DVec2) -> f64 {
    (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)
}

/// [`orient`] with the edge's vertices in canonical (lexicographic) order,
/// negated when swapped: both triangles of a shared edge see exactly
/// opposite values.
#[inline]
fn edge(a: DVec2, b: DVec2, p: DVec2) -> f64 {
    if (a.x, a.y) <= (b.x, b.y) {
        orient(a, b, p)
    } else {
        -orient(b, a, p)
    }
}

/// Top-left rule for an edge `a -> b` of a positive-area triangle on a
/// y-down screen: a top edge is horizontal with the interior below
/// (`dy == 0, dx > 0`), a left edge goes up (`dy < 0`).
#[inline]
fn top_left(a: DVec2, b: DVec2) -> bool {
    let d = b - a;
    d.y < 0.0 || (d.y == 0.0 && d.x > 0.0)
}

/// Rasterizes `s` into the band of rows starting at `row0` (`prim` and
/// `inv_depth` hold exactly that band's pixels).
fn raster_band(s: &Setup, width: u32, row0: u32, prim: &mut [u32], inv_depth: &mut [f32]) {
    let rows = (prim.len() / width as usize) as u32;
    let (y0, y1) = (s.y0.max(row0), s.y1.min(row0 + rows));
    let v = s.v.map(|p| p.as_dvec2());
    let iz = s.inv_z.map(f64::from);
    let area = orient(v[0], v[1], v[2]);
    let tl = [
        top_left(v[1], v[2]),
        top_left(v[2], v[0]),
        top_left(v[0], v[1]),
    ];
    let covers = |e: f64, top_left: bool| e > 0.0 || (e == 0.0 && top_left);
    for y in y0..y1 {
        let row = ((y - row0) * width) as usize;
        for x in s.x0..s.x1 {
            let p = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
            let e = [
                edge(v[1], v[2], p),
                edge(v[2], v[0], p),
                edge(v[0], v[1], p),
            ];
            if !(covers(e[0], tl[0]) && covers(e[1], tl[1]) && covers(e[2], tl[2])) {
                continue;
            }
            let z = ((e[0] * iz[0] + e[1] * iz[1] + e[2] * iz[2]) / area) as f32;
            let i = row + x as usize;
            if z > inv_depth[i] || (z == inv_depth[i] && s.prim < prim[i]) {
                inv_depth[i] = z;
                prim[i] = s.prim;
            }
        }
    }
}
