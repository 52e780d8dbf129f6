//! The reference ray tracer: closest-hit and occlusion queries over a
//! [`Scene`] with an obvhs compressed wide BVH (CWBVH, 8-wide, SIMD node
//! tests), the fastest CPU traversal obvhs offers.
//!
//! The BVH is built with obvhs' "medium" preset (PLOC with medium search
//! distance, 5% reinsertion, up to 3 primitives per CWBVH leaf, no spatial
//! splits), the steps of `obvhs::cwbvh::builder::build_cwbvh` on padded
//! triangle boxes (see [`Tracer::new`]) and without its debug-build
//! validation. Triangles are stored in BVH leaf order, so traversal needs no
//! index indirection.
//!
//! Triangle tests are Möller–Trumbore in f32 (what a GPU would run); a ray
//! exactly through a shared edge may report either triangle, and the test is
//! not watertight (a ray through an edge can, rarely, slip between both).
//! `tests/tracer.rs` checks closest hits against an f64 brute force.

use crate::scene::Scene;
use glam::{UVec2, Vec3, Vec3A};
use obvhs::{
    aabb::Aabb,
    bvh2::reinsertion::ReinsertionOptimizer,
    cwbvh::{bvh2_to_cwbvh::bvh2_to_cwbvh, CwBvh},
    ploc::PlocBuilder,
    ray::{Ray as BvhRay, RayHit},
    BvhBuildParams,
};
use std::time::Instant;

/// A ray-triangle hit: the point is `origin + t dir` and
/// `(1 - u - v) a + u b + v c` for the primitive's vertices `[a, b, c]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Primitive id (index into [`Scene::tris`]).
    pub prim: u32,
    /// Ray parameter (a distance for a unit direction).
    pub t: f32,
    /// Barycentric weight of the second vertex.
    pub u: f32,
    /// Barycentric weight of the third vertex.
    pub v: f32,
}

/// A triangle prepared for intersection: `v0`, `e1 = v1 - v0`,
/// `e2 = v2 - v0` and its scene primitive id.
#[derive(Clone, Copy)]
struct PackedTri {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
    prim: u32,
}

/// Closest-hit ray tracer over a scene's triangles.
pub struct Tracer {
    bvh: CwBvh,
    tris: Vec<PackedTri>,
    build_ms: f64,
}

impl Tracer {
    /// Builds the BVH over `scene.tris` (timed, see [`Tracer::build_ms`]).
    /// The tracer does not keep a reference to the scene; rebuild it if the
    /// geometry changes.
    ///
    /// The leaf boxes are padded by `1e-5` of the scene's largest extent: it
    /// works around obvhs 0.4's Morton encoding, which wraps a centroid on
    /// the upper bound of the scene box (a flat, axis-aligned triangle on the
    /// boundary, such as a wall) to 0 and so sorts the far wall's triangles
    /// among the near wall's. The resulting tree made rays visit 5-8 times
    /// more nodes (room scene, 100k triangles: 0.45 instead of 2.7 Mrays/s).
    pub fn new(scene: &Scene) -> Tracer {
        let start = Instant::now();
        let aabbs = padded_aabbs(&scene.tris);
        let bvh = if aabbs.is_empty() {
            CwBvh::default()
        } else {
            let config = BvhBuildParams::medium_build();
            let mut bvh2 = PlocBuilder::with_capacity(aabbs.len()).build(
                config.ploc_search_distance,
                &aabbs,
                (0..aabbs.len() as u32).collect(),
                config.sort_precision,
                config.search_depth_threshold,
            );
            ReinsertionOptimizer::default().run(&mut bvh2, config.reinsertion_batch_ratio, None);
            bvh2_to_cwbvh(&bvh2, config.max_prims_per_leaf.clamp(1, 3), true, false)
        };
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let [a, b, c] = scene.tris[i as usize].map(Vec3A::from);
                PackedTri {
                    v0: a,
                    e1: b - a,
                    e2: c - a,
                    prim: i,
                }
            })
            .collect();
        Tracer {
            bvh,
            tris,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }

    /// Wall-clock time of the BVH build in milliseconds (including the
    /// bounding boxes and the leaf-order copy of the triangles).
    pub fn build_ms(&self) -> f64 {
        self.build_ms
    }

    /// The closest hit of the ray `origin + t dir` with `tmin <= t < tmax`,
    /// or `None`. `dir` need not be unit length (then `t` is not a
    /// distance) but must be finite and non-zero.
    pub fn trace(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let ray = BvhRay::new(origin.into(), dir.into(), tmin, tmax);
        let mut hit = RayHit::none();
        let mut uv = (0.0, 0.0);
        let tris = &self.tris;
        let found = self.bvh.ray_traverse(ray, &mut hit, |r, id| {
            match intersect(&tris[id], r) {
                // The traversal accepts exactly the hits with t < r.tmax.
                Some((t, u, v)) if t < r.tmax => {
                    uv = (u, v);
                    t
                }
                _ => f32::INFINITY,
            }
        });
        found.then(|| Hit {
            prim: tris[hit.primitive_id as usize].prim,
            t: hit.t,
            u: uv.0,
            v: uv.1,
        })
    }

    /// [`Self::trace`], also counting the work (seed 002's hardware-
    /// independent measures, Tables 1-3): one ray/triangle test per
    /// primitive the traversal hands out (`Ñ_IT`) and one traversal step per
    /// BVH node whose children are tested (`Ñ_TS`). The seed counts steps of
    /// a kd-tree; here a step is one 8-wide CWBVH node, so the numbers
    /// compare across refl's methods, not with the paper's. Same hits as
    /// [`Self::trace`] (the same traversal: obvhs' `traverse!`, which
    /// `ray_traverse` runs, with counters added).
    pub fn trace_counted(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        tmax: f32,
        count: &mut TraceCount,
    ) -> Option<Hit> {
        let ray = BvhRay::new(origin.into(), dir.into(), tmin, tmax);
        let mut traverse_ray = ray;
        let (mut best, mut uv) = (None::<(u32, f32)>, (0.0, 0.0));
        let mut state = self.bvh.new_traversal(ray.direction);
        let mut node;
        let tris = &self.tris;
        let (mut steps, mut tests) = (0u64, 0u64);
        obvhs::traverse!(
            self.bvh,
            node,
            state,
            {
                steps += 1;
                node.intersect_ray(&traverse_ray, state.oct_inv4)
            },
            {
                tests += 1;
                let id = state.primitive_id as usize;
                if let Some((t, u, v)) = intersect(&tris[id], &traverse_ray) {
                    if t < traverse_ray.tmax {
                        best = Some((state.primitive_id, t));
                        uv = (u, v);
                        traverse_ray.tmax = t;
                    }
                }
            }
        );
        count.rays += 1;
        count.steps += steps;
        count.tests += tests;
        best.map(|(id, t)| Hit {
            prim: tris[id as usize].prim,
            t,
            u: uv.0,
            v: uv.1,
        })
    }

    /// The primitive of *some* hit on the ray `origin + t dir` with
    /// `tmin <= t < tmax` (any-hit traversal, stops at the first hit found,
    /// as [`Self::occluded`]), or `None`: [`Self::occluded`] that also says
    /// what occludes.
    pub fn occluder(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<u32> {
        let ray = BvhRay::new(origin.into(), dir.into(), tmin, tmax);
        let mut state = self.bvh.new_traversal(ray.direction);
        let mut node;
        let tris = &self.tris;
        let mut found = None;
        'outer: {
            obvhs::traverse!(
                self.bvh,
                node,
                state,
                node.intersect_ray(&ray, state.oct_inv4),
                {
                    let id = state.primitive_id as usize;
                    if intersect(&tris[id], &ray).is_some_and(|(t, _, _)| t < ray.tmax) {
                        found = Some(tris[id].prim);
                        break 'outer;
                    }
                }
            );
        }
        found
    }

    /// `true` if anything lies on the ray `origin + t dir` with
    /// `tmin <= t < tmax` (any-hit traversal, stops at the first hit).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        let ray = BvhRay::new(origin.into(), dir.into(), tmin, tmax);
        let tris = &self.tris;
        !self.bvh.ray_traverse_miss(ray, |r, id| {
            intersect(&tris[id], r).map_or(f32::INFINITY, |(t, _, _)| t)
        })
    }
}

/// Work counted by [`Tracer::trace_counted`], summed over rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraceCount {
    /// Rays traced.
    pub rays: u64,
    /// Traversal steps: BVH nodes whose children were tested.
    pub steps: u64,
    /// Ray/triangle intersection tests.
    pub tests: u64,
}

impl std::ops::Add for TraceCount {
    type Output = TraceCount;

    /// The sum of two counts.
    fn add(self, o: TraceCount) -> TraceCount {
        TraceCount {
            rays: self.rays + o.rays,
            steps: self.steps + o.steps,
            tests: self.tests + o.tests,
        }
    }
}

impl TraceCount {
    /// Tests per ray over `rays` (seed 002's `Ñ_IT`); 0 for none.
    pub fn tests_per_ray(&self, rays: u64) -> f64 {
        if rays == 0 {
            0.0
        } else {
            self.tests as f64 / rays as f64
        }
    }

    /// Steps per ray over `rays` (seed 002's `Ñ_TS`); 0 for none.
    pub fn steps_per_ray(&self, rays: u64) -> f64 {
        if rays == 0 {
            0.0
        } else {
            self.steps as f64 / rays as f64
        }
    }
}

/// The triangles' bounding boxes, each padded by `1e-5` of the scene's
/// largest extent, so that no centroid lies on the upper bound of their
/// union (see [`Tracer::new`]); the boxes are merely a little conservative.
fn padded_aabbs(tris: &[[Vec3; 3]]) -> Vec<Aabb> {
    let mut bounds = Aabb::empty();
    for t in tris.iter().flatten() {
        bounds.extend((*t).into());
    }
    let pad = Vec3A::splat((bounds.max - bounds.min).max_element() * 1e-5);
    tris.iter()
        .map(|t| {
            let b = Aabb::from_points(&t.map(Vec3A::from));
            Aabb::new(b.min - pad, b.max + pad)
        })
        .collect()
}

/// Möller–Trumbore: `(t, u, v)` if the ray hits the triangle (edges
/// inclusive) with `tmin <= t <= tmax`.
#[inline(always)]
fn intersect(tri: &PackedTri, ray: &BvhRay) -> Option<(f32, f32, f32)> {
    let p = ray.direction.cross(tri.e2);
    let det = tri.e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = ray.origin - tri.v0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(tri.e1);
    let v = ray.direction.dot(q) * inv;
    if !(v >= 0.0 && u + v <= 1.0) {
        return None;
    }
    let t = tri.e2.dot(q) * inv;
    (t >= ray.tmin && t <= ray.tmax).then_some((t, u, v))
}

/// Where the ray `origin + t dir` meets the plane of triangle `tri`
/// (primitive `prim`), with its barycentrics, whether or not the point lies
/// inside the triangle; `None` if the ray is parallel to the plane or the
/// hit is not in front (`t <= 0`). This is how a visibility buffer
/// reconstructs the exact hit of a pixel from the primitive id a rasterizer
/// stored there.
pub fn ray_triangle_plane(tri: &[Vec3; 3], prim: u32, origin: Vec3, dir: Vec3) -> Option<Hit> {
    let (e1, e2) = (tri[1] - tri[0], tri[2] - tri[0]);
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - tri[0];
    let q = s.cross(e1);
    let t = e2.dot(q) * inv;
    (t > 0.0 && t.is_finite()).then(|| Hit {
        prim,
        t,
        u: s.dot(p) * inv,
        v: dir.dot(q) * inv,
    })
}
