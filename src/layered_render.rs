//! Reflections from layered depth cube maps (seed 001): every reflected
//! object of a scene as a [`LayeredObject`], reflection rays traced against
//! all of them, and the measurements of `refl report`'s `layered` rows.
//!
//! Reflected objects are the scene's compact, closed, non-reflective
//! objects ([`reflected_objects`]): seed 001 represents the objects seen in
//! a curved reflector by layered depth maps and leaves the surroundings
//! (walls, floors) to an environment map. A ray is handled when it hits one
//! of the maps; the hit is shaded from the primitive id the map stores
//! (the ray intersected with that triangle's plane), as the planar method
//! shades its visibility buffer.

use crate::gbuffer::GBuffer;
use crate::layered::{self, LayeredObject};
use crate::render::ReflectionImage;
use crate::scene::Scene;
use crate::screen::ReflectionRays;
use crate::shade::Shader;
use crate::tracer::ray_triangle_plane;
use rayon::prelude::*;
use refl_core::layered::{LayeredHit, LayeredOptions};
use refl_core::Error;

/// Largest reflected object, as a share of the scene diameter (larger
/// objects are surroundings).
pub const MAX_OBJECT_SHARE: f32 = 0.35;

/// Objects the `layered` method builds maps for: not reflective, with a
/// bounding box smaller than [`MAX_OBJECT_SHARE`] of the scene diameter and
/// at least 2% of its own diagonal thick on every axis (closed volumes, not
/// walls).
pub fn reflected_objects(scene: &Scene) -> Vec<u32> {
    let diameter = scene.diameter();
    scene
        .objects
        .iter()
        .enumerate()
        .filter(|(_, o)| {
            let d = o.bounds.diagonal();
            let size = o.bounds.max - o.bounds.min;
            !scene.materials[o.material as usize].is_reflective()
                && d < MAX_OBJECT_SHARE * diameter
                && size.min_element() > 0.02 * d
                && !o.tris.is_empty()
        })
        .map(|(i, _)| i as u32)
        .collect()
}

/// One ray's result over all maps: the nearest hit with its object, and
/// the depth fetches spent.
pub type LayeredResult = (Option<(u32, LayeredHit)>, u32);

/// The layered maps of a scene's reflected objects.
pub struct LayeredScene {
    /// One map per reflected object.
    pub objects: Vec<LayeredObject>,
    /// Build time of all maps, ms.
    pub build_ms: f64,
}

impl LayeredScene {
    /// Builds a `face_res`-texel, `layers`-layer map of every object of
    /// [`reflected_objects`].
    ///
    /// # Errors
    /// As [`layered::build`].
    pub fn build(
        scene: &Scene,
        face_res: u32,
        layers: u32,
        pool: &rayon::ThreadPool,
    ) -> Result<Self, Error> {
        let start = std::time::Instant::now();
        let objects = reflected_objects(scene)
            .into_iter()
            .map(|o| layered::build(scene, o, face_res, layers, pool))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            objects,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// Caller-buffer bytes of all maps (depth, payload, counts, bounds).
    pub fn bytes(&self) -> usize {
        self.objects
            .iter()
            .map(|o| {
                o.depth.len() * 4 + o.payload.len() * 4 + o.counts.len() * 4 + o.bounds.len() * 4
            })
            .sum()
    }

    /// The nearest hit of `ray` over every map but the one of object
    /// `skip` (the reflector itself): `(object, hit, fetches)`.
    fn trace_one(
        &self,
        ray: &refl_core::Ray,
        skip: u32,
        params: &LayeredOptions,
    ) -> Result<LayeredResult, Error> {
        let mut best: Option<(u32, LayeredHit)> = None;
        let mut fetches = 0;
        for o in &self.objects {
            if o.object == skip {
                continue;
            }
            let t_max = best.map_or(f32::INFINITY, |(_, h)| h.t);
            if !(t_max > 0.0) {
                // A hit at the ray's origin: nothing can be nearer.
                break;
            }
            let tr = o.map().try_trace(ray, t_max, params)?;
            fetches += tr.work().fetches;
            if let Some(h) = tr.hit() {
                if best.is_none_or(|(_, b)| h.t < b.t) {
                    best = Some((o.object, *h));
                }
            }
        }
        Ok((best, fetches))
    }

    /// Traces the rays of `rays` (from their surface points) against every
    /// map on `pool`.
    ///
    /// # Errors
    /// The first error of a map's trace (a non-unit ray or bad parameters).
    pub fn trace(
        &self,
        g: &GBuffer,
        rays: &ReflectionRays,
        params: &LayeredOptions,
        pool: &rayon::ThreadPool,
    ) -> Result<Vec<LayeredResult>, Error> {
        pool.install(|| {
            rays.ray
                .par_iter()
                .zip(rays.pixel.par_iter())
                .with_min_len(64)
                .map(|(r, &p)| self.trace_one(r, g.object[p as usize], params))
                .collect()
        })
    }
}

/// Hit agreement of layered traces with the reference hits.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LayeredStats {
    /// Rays traced.
    pub rays: usize,
    /// Rays whose reference hit is on a mapped object.
    pub to_objects: usize,
    /// Of those, rays the maps hit on the same object within one texel
    /// diagonal of the reference hit point.
    pub agree: usize,
    /// Rays the maps hit while the reference hits another object (or
    /// nothing): hits on an occluded or wrong object.
    pub false_hits: usize,
    /// Sum of hit-point errors in texels over rays hitting the same object
    /// as the reference.
    pub err_texels_sum: f64,
    /// Count behind `err_texels_sum`.
    pub err_count: usize,
    /// Total depth fetches.
    pub fetches: u64,
}

impl LayeredStats {
    /// Adds another frame's statistics.
    pub fn add(&mut self, o: &LayeredStats) {
        self.rays += o.rays;
        self.to_objects += o.to_objects;
        self.agree += o.agree;
        self.false_hits += o.false_hits;
        self.err_texels_sum += o.err_texels_sum;
        self.err_count += o.err_count;
        self.fetches += o.fetches;
    }
}

/// Compares layered traces with the reference hits of `rays`.
pub fn evaluate(
    scene: &Scene,
    ls: &LayeredScene,
    rays: &ReflectionRays,
    traces: &[LayeredResult],
) -> LayeredStats {
    let mut s = LayeredStats {
        rays: rays.len(),
        ..LayeredStats::default()
    };
    for (k, (hit, fetches)) in traces.iter().enumerate() {
        s.fetches += u64::from(*fetches);
        let reference = rays.reference[k].map(|h| (scene.tri_object[h.prim as usize], h.t));
        let ref_obj =
            reference.and_then(|(o, t)| ls.objects.iter().find(|m| m.object == o).map(|m| (m, t)));
        if ref_obj.is_some() {
            s.to_objects += 1;
        }
        match (hit, ref_obj) {
            (Some((o, h)), Some((m, t))) if *o == m.object => {
                let texel = (m.grid.max() - m.grid.min()).max_element() / m.grid.face_res() as f32;
                let err = (h.position - rays.ray[k].at(t)).length() / texel;
                s.err_texels_sum += f64::from(err);
                s.err_count += 1;
                if err <= std::f32::consts::SQRT_2 {
                    s.agree += 1;
                }
            }
            (Some(_), _) => s.false_hits += 1,
            (None, _) => {}
        }
    }
    s
}

/// The reflection image of the `layered` method: every mirror pixel
/// (roughness 0) whose ray hit a map, shaded at the exact intersection with
/// the primitive the map stores.
pub fn shade(
    shader: &Shader,
    g: &GBuffer,
    rays: &ReflectionRays,
    traces: &[LayeredResult],
) -> ReflectionImage {
    let scene = shader.scene;
    let mut out = ReflectionImage::empty(g.width(), g.height());
    for (k, (hit, _)) in traces.iter().enumerate() {
        let i = rays.pixel[k] as usize;
        if g.roughness[i] > 0.0 {
            continue;
        }
        let Some((_, h)) = hit else { continue };
        let r = rays.ray[k];
        let prim = h.payload;
        let Some(tri) = scene.tris.get(prim as usize) else {
            continue;
        };
        let exact = ray_triangle_plane(tri, prim, r.origin, r.dir).unwrap_or(crate::tracer::Hit {
            prim,
            t: h.t,
            u: 0.0,
            v: 0.0,
        });
        out.rgb[i] = shader.shade_reflection_hit(r.origin, r.dir, &exact);
        out.handled[i] = true;
    }
    out
}
