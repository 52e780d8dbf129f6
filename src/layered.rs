//! Layered depth cube maps of scene objects (seed 001 Sec. 3.3-3.4): the
//! host side of refl-core's `layered` module.
//!
//! [`build`] makes the map of one object by casting every orthographic
//! column ray of the `-X`, `-Y` and `-Z` faces ([`LayeredGrid::try_face_ray`])
//! through **all** surfaces of that object with obvhs (the depth peeling of
//! seed 001 Sec. 3.4, done by ray casting): a [`Tracer`] over the object's
//! triangles alone is re-traced from just past each hit until the column is
//! exhausted. Columns run in parallel on the caller's rayon pool; each
//! column fills its face and the opposite face
//! ([`LayeredMapMut::try_fill_column`]). A payload is the index of the
//! crossing in [`LayeredObject::samples`]: the scene primitive, the column
//! ray and the hit, from which [`LayeredObject::shade_samples`] computes
//! the color the texel stores (seed 001 Sec. 3.3: the maps hold what the
//! method shades from, not ids).
//!
//! Facing (entering or leaving the solid) comes from the triangle winding:
//! `(b - a) x (c - a)` points out of the object, as in every built-in scene
//! (their reflected objects are closed, counter-clockwise meshes).

use crate::scene::{Aabb, Object, Scene};
use crate::shade::{Shader, Surface};
use crate::tracer::{Hit, Tracer};
use glam::Vec3;
use rayon::prelude::*;
use refl_core::layered::{
    ColumnRay, Face, LayerHit, LayeredGrid, LayeredMap, LayeredMapMut, LayeredOptions, LayeredTrace,
};
use refl_core::{Error, Ray};
use std::time::Instant;

/// The owned buffers of one object's layered depth cube map.
#[derive(Clone, Debug)]
pub struct LayeredObject {
    /// The object (index into [`Scene::objects`]).
    pub object: u32,
    /// Box (the object's bounds, enlarged a little), resolution, layers.
    pub grid: LayeredGrid,
    /// Normalized depths (refl-core layout).
    pub depth: Vec<f32>,
    /// Per layer, the index of its crossing in [`Self::samples`]
    /// (`refl_core::layered::NO_PAYLOAD` where empty).
    pub payload: Vec<u32>,
    /// Every column crossing the map stores from: a ray (origin, unit
    /// direction) that meets it from outside the solid and its hit on the
    /// scene primitive `hit.prim` (the column ray at an entering crossing,
    /// the reversed one at an exiting crossing).
    pub samples: Vec<(Vec3, Vec3, Hit)>,
    /// The color of each sample ([`Self::shade_samples`]; empty until
    /// then).
    pub colors: Vec<Vec3>,
    /// Layer counts per texel.
    pub counts: Vec<u32>,
    /// Empty-space bounds ([`LayeredMapMut::build_bounds`]).
    pub bounds: Vec<f32>,
    /// Columns cast (`3 res^2`).
    pub columns: u32,
    /// Columns with more solid intervals than layers (approximate).
    pub approx_columns: u32,
    /// Surface crossings found over all columns.
    pub crossings: u64,
    /// Wall-clock time of the build (tracer over the object, casting,
    /// filling), milliseconds.
    pub build_ms: f64,
}

impl LayeredObject {
    /// Shades every sample as the reference shades a reflection hit
    /// ([`Shader::direct`] at the crossing, its normals facing the column
    /// ray's origin): the colors the texels store, computed once per map
    /// (view-independent, the one-bounce rule), on `pool`.
    pub fn shade_samples(&mut self, shader: &Shader, pool: &rayon::ThreadPool) {
        let scene = shader.scene;
        self.colors = pool.install(|| {
            self.samples
                .par_iter()
                .map(|(o, d, h)| shader.direct(&Surface::at_hit(scene, *o, *d, h)))
                .collect()
        });
    }

    /// The sample a payload names, if any.
    pub fn sample(&self, payload: u32) -> Option<&(Vec3, Vec3, Hit)> {
        self.samples.get(payload as usize)
    }

    /// The refl-core view for tracing.
    pub fn map(&self) -> LayeredMap<'_> {
        // The buffers were sized from the grid in `build`.
        LayeredMap::try_new(
            self.grid,
            &self.depth,
            &self.payload,
            &self.counts,
            &self.bounds,
        )
        .expect("buffers sized from their grid")
    }
}

/// A tracer over the triangles of object `object_id` alone; its primitive
/// ids are offsets into the object's range (add `object.tris.start`).
///
/// # Errors
/// [`Error::InvalidArgument`] for an unknown object or one without
/// triangles.
pub fn object_tracer(scene: &Scene, object_id: u32) -> Result<(Tracer, &Object), Error> {
    let obj = scene
        .objects
        .get(object_id as usize)
        .ok_or(Error::InvalidArgument)?;
    let range = obj.tris.start as usize..obj.tris.end as usize;
    if range.is_empty() || range.end > scene.tris.len() {
        return Err(Error::InvalidArgument);
    }
    let sub = Scene {
        name: obj.name.clone(),
        tris: scene.tris[range.clone()].to_vec(),
        normals: scene.normals[range.clone()].to_vec(),
        tri_object: vec![0; range.len()],
        objects: vec![Object {
            tris: 0..range.len() as u32,
            ..obj.clone()
        }],
        materials: scene.materials.clone(),
        lights: Vec::new(),
        ambient: scene.ambient,
        camera_path: Vec::new(),
        near: scene.near,
        far: scene.far,
        skipped_degenerate_triangles: 0,
        load_notes: Vec::new(),
    };
    Ok((Tracer::new(&sub), obj))
}

/// Every crossing of `ray` with the object of `tracer` (whose primitive
/// `k` is scene primitive `first + k`, with vertices `tris[k]`): repeated
/// closest-hit queries, each starting `eps` past the previous hit.
pub fn column_hits(
    tracer: &Tracer,
    tris: &[[Vec3; 3]],
    first: u32,
    ray: &ColumnRay,
    eps: f32,
) -> Vec<LayerHit> {
    column_samples(tracer, tris, first, ray, eps)
        .into_iter()
        .map(|(l, _)| l)
        .collect()
}

/// [`column_hits`] with each crossing's hit (scene primitive id,
/// barycentrics).
fn column_samples(
    tracer: &Tracer,
    tris: &[[Vec3; 3]],
    first: u32,
    ray: &ColumnRay,
    eps: f32,
) -> Vec<(LayerHit, Hit)> {
    let mut out = Vec::new();
    let mut tmin = 0.0f32;
    // A column cannot cross more surfaces than there are triangles.
    for _ in 0..=tris.len() {
        let Some(h) = tracer.trace(ray.origin, ray.dir, tmin, ray.t_max) else {
            break;
        };
        let [a, b, c] = tris[h.prim as usize];
        let n = (b - a).cross(c - a);
        out.push((
            LayerHit {
                t: h.t,
                id: first + h.prim,
                front: n.dot(ray.dir) < 0.0,
            },
            Hit {
                prim: first + h.prim,
                ..h
            },
        ));
        tmin = h.t + eps;
    }
    out
}

/// Most layers [`build`] chooses with `layers = 0` (auto).
pub const MAX_AUTO_LAYERS: u32 = 8;

/// Builds the layered depth cube map of object `object_id` with
/// `face_res x face_res` texels per face and `layers` layers, casting the
/// columns in parallel on `pool`. `layers = 0` follows the object's depth
/// complexity (seed 001 Table 1 gives each object its own layer count):
/// the most solid intervals any column crosses (entering crossings),
/// capped at [`MAX_AUTO_LAYERS`], so that no column is approximated below
/// the cap. The box is the object's bounds enlarged
/// by 0.1% of its diagonal, so that no surface lies on a box face.
///
/// # Errors
/// [`Error::InvalidArgument`] for an unknown or empty object, a zero size;
/// [`Error::DegenerateGeometry`] for an object whose padded box still has
/// no extent (a single point). A flat object gets a thin box.
pub fn build(
    scene: &Scene,
    object_id: u32,
    face_res: u32,
    layers: u32,
    pool: &rayon::ThreadPool,
) -> Result<LayeredObject, Error> {
    let start = Instant::now();
    let (tracer, obj) = object_tracer(scene, object_id)?;
    let b: Aabb = obj.bounds;
    let pad = b.diagonal() * 1e-3;
    // Column rays depend on the box and the resolution, not on the layers.
    let probe = LayeredGrid::try_new(b.min - pad, b.max + pad, face_res, layers.max(1))?;
    let first = obj.tris.start;
    let tris = &scene.tris[obj.tris.start as usize..obj.tris.end as usize];
    let eps = b.diagonal() * 1e-6;
    let res = face_res as usize;
    let faces = [Face::NegX, Face::NegY, Face::NegZ];
    // Cast every column (3 res^2) in parallel.
    let columns: Vec<Vec<(LayerHit, Hit)>> = pool.install(|| {
        (0..3 * res * res)
            .into_par_iter()
            .map(|k| {
                let (f, ij) = (k / (res * res), k % (res * res));
                let (i, j) = ((ij % res) as u32, (ij / res) as u32);
                probe
                    .try_face_ray(faces[f], i, j)
                    .map(|r| column_samples(&tracer, tris, first, &r, eps))
                    .unwrap_or_default()
            })
            .collect()
    });
    let layers = if layers == 0 {
        let deepest = columns
            .iter()
            .map(|c| c.iter().filter(|(h, _)| h.front).count() as u32)
            .max()
            .unwrap_or(1);
        deepest.clamp(1, MAX_AUTO_LAYERS)
    } else {
        layers
    };
    let grid = LayeredGrid::try_new(b.min - pad, b.max + pad, face_res, layers)?;
    let len = grid.len();
    let (mut depth, mut payload, mut counts, mut bounds) = (
        vec![0.0f32; len.depth],
        vec![0u32; len.payload],
        vec![0u32; len.counts],
        vec![0.0f32; len.bounds],
    );
    let mut approx = 0;
    let mut crossings = 0u64;
    let mut samples = Vec::new();
    {
        let mut m =
            LayeredMapMut::try_new(grid, &mut depth, &mut payload, &mut counts, &mut bounds)?;
        m.clear();
        for (k, column) in columns.into_iter().enumerate() {
            let (f, ij) = (k / (res * res), k % (res * res));
            let (i, j) = ((ij % res) as u32, (ij / res) as u32);
            crossings += column.len() as u64;
            // Payloads name the crossings in `samples`.
            let mut hits = Vec::with_capacity(column.len());
            if let (Ok(r), false) = (grid.try_face_ray(faces[f], i, j), column.is_empty()) {
                for (l, h) in column {
                    hits.push(LayerHit {
                        id: samples.len() as u32,
                        ..l
                    });
                    // A sample is kept as a ray that sees its surface from
                    // outside the solid: the column ray at an entering
                    // crossing, the reversed ray from one unit beyond an
                    // exiting one (its normals then face out, as a
                    // reflection ray arriving from that side sees them).
                    if l.front {
                        samples.push((r.origin, r.dir, h));
                    } else {
                        let p = r.origin + r.dir * h.t;
                        samples.push((p + r.dir, -r.dir, Hit { t: 1.0, ..h }));
                    }
                }
            }
            let fill = m.try_fill_column(faces[f], i, j, &mut hits)?;
            approx += (fill.stored < fill.intervals) as u32;
        }
        m.build_bounds();
    }
    Ok(LayeredObject {
        object: object_id,
        grid,
        depth,
        payload,
        samples,
        colors: Vec::new(),
        counts,
        bounds,
        columns: (3 * res * res) as u32,
        approx_columns: approx,
        crossings,
        build_ms: start.elapsed().as_secs_f64() * 1e3,
    })
}

/// Traces reflection rays (unit directions, up to `t_max`) against the map
/// in parallel on `pool`, one result per ray.
///
/// # Errors
/// The first error of [`LayeredMap::try_trace`] (a non-finite or non-unit ray,
/// a bad `t_max` or bad parameters).
pub fn trace_rays(
    obj: &LayeredObject,
    rays: &[Ray],
    t_max: f32,
    params: &LayeredOptions,
    pool: &rayon::ThreadPool,
) -> Result<Vec<LayeredTrace>, Error> {
    let map = obj.map();
    pool.install(|| {
        rays.par_iter()
            .map(|r| map.try_trace(r, t_max, params))
            .collect()
    })
}
