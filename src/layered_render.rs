//! Reflections from layered depth cube maps (seed 001): every reflected
//! object of a scene as a [`LayeredObject`], the G-buffer's reflective
//! pixels traced against all of them by refl-core's layered pass
//! ([`refl_core::LayeredPass`]: the mirror ray and its start, the maps that
//! apply, the nearest hit), and the measurements of `refl report`'s
//! `layered` rows.
//!
//! Which maps a pixel searches is decided per reflector triangle first
//! (seed 001 Sec. 3.2, the potential reflection regions): every frame the
//! reflective objects' triangles get a mask of the maps that may reflect on
//! them ([`refl_core::try_prr_masks`]), and each pixel, through the
//! G-buffer's primitive id, searches only its triangle's maps
//! ([`refl_core::LayeredPass::try_with_regions`]). The masks are
//! conservative, so the hits are those of the pass without them; what they
//! save is counted ([`LayeredPassStats::prr_skipped`]).
//!
//! Reflected objects are the scene's compact, closed, non-reflective
//! objects ([`reflected_objects`]): seed 001 represents the objects seen in
//! a curved reflector by layered depth maps and leaves the surroundings
//! (walls, floors) to an environment map. A pixel whose ray hits
//! one of the maps is shaded from the primitive id the map stores (the
//! pixel's ray, as the pass traced it, intersected with that triangle's
//! plane), as the planar method shades its visibility buffer. A ray that
//! leaves every map takes the global environment (seed 001 Sec. 4.1: the
//! surroundings as an environment map), here [`Surroundings`]: the scene
//! without its mapped objects, rendered once into a direction table from
//! the center of the reflectors, so that the method answers every mirror
//! pixel and its error compares with the other methods'.

use crate::gbuffer::GBuffer;
use crate::layered::{self, LayeredObject};
use crate::probe::{PrefilteredEnv, ProbeSizes};
use crate::render::ReflectionImage;
use crate::scene::Aabb;
use crate::scene::Scene;
use crate::screen::{ReflectionRays, PYRAMID_BAND};
use crate::shade::env_map;
use crate::shade::Shader;
use crate::tracer::{ray_triangle_plane, Hit, Tracer};
use glam::Vec3;
use rayon::prelude::*;
use refl_core::layered::{LayeredMap, LayeredOptions};
use refl_core::{
    layered_pass_scratch_len, prr_mask_words, try_prepare_layered_pass, try_prr_masks,
    try_prr_masks_len, DepthConvention, DepthImage, Error, GBuffer as CoreGBuffer, ImageView,
    ImageViewMut, LayeredBound, LayeredPass, LayeredPassOptions, LayeredPassStats,
    LayeredPassStatus, LayeredPassTexel, NormalSpace, PrrStats, PrrTriangle, RowRange,
    PRR_NO_REGION,
};
use std::sync::Arc;

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

/// The layered pass's results of one frame: one texel per pixel (what the
/// pass wrote: status, map, hit, fetches) and the pass's counts.
#[derive(Clone, Debug, Default)]
pub struct LayeredTraces {
    /// Per pixel, row-major.
    pub texels: Vec<LayeredPassTexel>,
    /// Counts summed over the bands.
    pub stats: LayeredPassStats,
    /// Counts of the frame's potential-reflection-region masks (`None`
    /// when the pass ran without regions).
    pub prr: Option<PrrStats>,
}

/// The reflector triangles of a scene as regions of the layered pass
/// (seed 001 Sec. 3.2): every triangle of a reflective object, with the
/// vertex normals the G-buffer interpolates, and per scene triangle its
/// region.
#[derive(Clone, Debug, Default)]
pub struct PrrRegions {
    /// The regions' triangles (world space).
    pub triangles: Vec<PrrTriangle>,
    /// Per scene triangle, its region ([`PRR_NO_REGION`] for triangles of
    /// objects that are not reflective).
    pub region_of: Vec<u32>,
}

impl PrrRegions {
    /// The reflective objects' triangles of `scene`.
    pub fn new(scene: &Scene) -> Self {
        let mut out = PrrRegions {
            triangles: Vec::new(),
            region_of: vec![PRR_NO_REGION; scene.tris.len()],
        };
        for (t, tri) in scene.tris.iter().enumerate() {
            let o = scene.tri_object[t] as usize;
            if !scene.materials[scene.objects[o].material as usize].is_reflective() {
                continue;
            }
            out.region_of[t] = out.triangles.len() as u32;
            out.triangles.push(PrrTriangle {
                corners: tri.map(|p| p.to_array()),
                normals: scene.normals[t].map(|n| n.to_array()),
            });
        }
        out
    }

    /// The regions a frame needs: the reflector triangles that its
    /// reflective pixels see, in the order they first appear, and per
    /// pixel of `g` the index of its triangle among them
    /// ([`PRR_NO_REGION`] for pixels the pass does not trace with a
    /// region: not reflective, or not on a reflector triangle). Only these
    /// triangles' masks are built: a triangle no pixel sees needs none.
    pub fn frame_regions(&self, g: &GBuffer) -> (Vec<PrrTriangle>, Vec<u32>) {
        let mut local = vec![PRR_NO_REGION; self.triangles.len()];
        let mut tris = Vec::new();
        let pixels = (0..g.len())
            .map(|i| {
                let Some(&r) = self.region_of.get(g.prim[i] as usize) else {
                    return PRR_NO_REGION;
                };
                if r == PRR_NO_REGION || !g.is_reflective(i) {
                    return PRR_NO_REGION;
                }
                let slot = &mut local[r as usize];
                if *slot == PRR_NO_REGION {
                    *slot = tris.len() as u32;
                    tris.push(self.triangles[r as usize]);
                }
                *slot
            })
            .collect();
        (tris, pixels)
    }
}

/// The G-buffer images the layered pass reads, in refl-core's layout
/// (made once per frame, outside the timed pass, as an engine has them).
pub struct LayeredFrame {
    normals: Vec<[f32; 3]>,
    mask: Vec<u8>,
}

impl LayeredFrame {
    /// World normals and the reflective mask of `g`.
    pub fn new(g: &GBuffer) -> Self {
        Self {
            normals: g.normal.iter().map(|n| n.to_array()).collect(),
            mask: (0..g.len()).map(|i| u8::from(g.is_reflective(i))).collect(),
        }
    }

    /// refl-core's view of `g` with these images: linear depth (`+inf` for
    /// background), world normals, the reflective mask (every reflective
    /// pixel is traced: no roughness image).
    fn gbuffer<'a>(&'a self, g: &'a GBuffer) -> Result<CoreGBuffer<'a>, Error> {
        let (w, h) = (g.width(), g.height());
        let depth = DepthImage::try_new(
            ImageView::try_new(&g.depth, w, h, w)?,
            g.camera,
            DepthConvention::Linear,
        )?;
        CoreGBuffer::try_new(
            depth,
            ImageView::try_new(&self.normals, w, h, w)?,
            NormalSpace::World,
        )?
        .try_with_mask(ImageView::try_new(&self.mask, w, h, w)?)
    }
}

/// The global environment of seed 001 Sec. 4.1 for the rays that leave
/// every map: what the scene without its mapped objects and its
/// reflectors shows in each
/// direction from one point, the center of the reflective objects' bounds,
/// as a latitude-longitude table (256 x 128, bilinear lookup,
/// [`PrefilteredEnv`] level 0; its one filtered level, for the widest
/// lobe at one sample a texel, is never read). Each texel is the
/// reference's shade of the first surface its direction meets (the
/// procedural sky where none), so the table is exact for surroundings at
/// infinity and approximate (parallax) for near walls, as an environment
/// map is.
pub struct Surroundings {
    table: PrefilteredEnv,
    /// The point the table is seen from.
    pub center: Vec3,
    /// Build time (one ray per texel, traced and shaded), ms.
    pub build_ms: f64,
}

impl Surroundings {
    /// Renders the table for `shader`'s scene without the objects of
    /// [`reflected_objects`], on `pool`.
    pub fn build(shader: &Shader, pool: &rayon::ThreadPool) -> Self {
        let start = std::time::Instant::now();
        let scene = shader.scene;
        let mapped = reflected_objects(scene);
        let mut bounds = Aabb::EMPTY;
        for o in &scene.objects {
            if scene.materials[o.material as usize].is_reflective() {
                bounds.grow(o.bounds.min);
                bounds.grow(o.bounds.max);
            }
        }
        let center = if bounds.min.x <= bounds.max.x {
            (bounds.min + bounds.max) * 0.5
        } else {
            Vec3::ZERO
        };
        // The scene without its mapped objects and without the reflectors
        // (an environment map is what surrounds them; the center lies on
        // or in them), and each kept triangle's id in the scene.
        let keep: Vec<u32> = (0..scene.tris.len() as u32)
            .filter(|&t| {
                let o = scene.tri_object[t as usize];
                let material = scene.objects[o as usize].material as usize;
                !mapped.contains(&o) && !scene.materials[material].is_reflective()
            })
            .collect();
        let mut sub = scene.clone();
        sub.tris = keep.iter().map(|&t| scene.tris[t as usize]).collect();
        sub.normals = keep.iter().map(|&t| scene.normals[t as usize]).collect();
        sub.tri_object = keep.iter().map(|&t| scene.tri_object[t as usize]).collect();
        let tracer = Tracer::new(&sub);
        let env = |d: Vec3| match tracer.trace(center, d, 0.0, f32::INFINITY) {
            Some(h) => shader.shade_reflection_hit(
                center,
                d,
                &Hit {
                    prim: keep[h.prim as usize],
                    ..h
                },
            ),
            None => env_map(d),
        };
        let sizes = ProbeSizes {
            levels: 2,
            max_roughness: 1.0,
            max_width: 256,
            samples: 1,
        };
        let table = pool.install(|| PrefilteredEnv::build(env, sizes));
        Self {
            table,
            center,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }

    /// The environment in direction `dir`.
    pub fn sample(&self, dir: Vec3) -> Vec3 {
        self.table.sample(dir, 0.0)
    }

    /// Bytes of the table.
    pub fn bytes(&self) -> usize {
        self.table.bytes()
    }
}

/// The layered maps of a scene's reflected objects.
pub struct LayeredScene {
    /// One map per reflected object.
    pub objects: Vec<LayeredObject>,
    /// Build time of all maps, ms.
    pub build_ms: f64,
    /// The global environment for rays that leave every map (see
    /// [`Surroundings`]); `None` leaves them unhandled.
    pub surroundings: Option<Arc<Surroundings>>,
    /// The scene's reflector triangles as regions of the pass (seed 001
    /// Sec. 3.2); `None` traces every pixel against every map.
    pub regions: Option<PrrRegions>,
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
        let regions = Some(PrrRegions::new(scene));
        Ok(Self {
            objects,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
            surroundings: None,
            regions,
        })
    }

    /// Shades every map's samples ([`LayeredObject::shade_samples`]): the
    /// colors the texels store.
    pub fn shade_samples(&mut self, shader: &Shader, pool: &rayon::ThreadPool) {
        for o in &mut self.objects {
            o.shade_samples(shader, pool);
        }
    }

    /// Caller-buffer bytes of all maps (depth, payload, counts, bounds)
    /// and their stored colors (12 bytes a sample once shaded).
    pub fn bytes(&self) -> usize {
        self.objects
            .iter()
            .map(|o| {
                o.depth.len() * 4
                    + o.payload.len() * 4
                    + o.counts.len() * 4
                    + o.bounds.len() * 4
                    + o.colors.len() * 12
            })
            .sum()
    }

    /// Runs refl-core's layered pass over the reflective pixels of `g`
    /// (`frame` its images) against every map with the kernel settings
    /// `params`, in row bands on `pool`: the pass's options otherwise
    /// default, object ids from the G-buffer (a pixel's ray skips its own
    /// object's map), the bounds prepared per call (per frame) and, with
    /// [`LayeredScene::regions`], the potential-reflection-region masks of
    /// the frame's camera (seed 001 Sec. 3.2, built on `pool`) for the
    /// reflector triangles the frame's reflective pixels see, each pixel's
    /// region from the G-buffer's primitive id ([`PrrRegions::frame_regions`]). The pixels the
    /// maps cannot answer are not listed (their texels say why).
    ///
    /// # Errors
    /// The pass's errors (bad parameters, buffers that do not match the
    /// G-buffer's camera: never for a rendered one).
    pub fn trace(
        &self,
        g: &GBuffer,
        frame: &LayeredFrame,
        params: &LayeredOptions,
        pool: &rayon::ThreadPool,
    ) -> Result<LayeredTraces, Error> {
        let (w, h) = (g.width(), g.height());
        let gb = frame.gbuffer(g)?;
        let maps: Vec<LayeredMap<'_>> = self.objects.iter().map(|o| o.map()).collect();
        let ids: Vec<u32> = self.objects.iter().map(|o| o.object).collect();
        let options = LayeredPassOptions {
            trace: *params,
            max_roughness: f32::INFINITY,
            ..LayeredPassOptions::default()
        };
        let mut bounds = vec![LayeredBound::default(); layered_pass_scratch_len(&maps[..])];
        try_prepare_layered_pass(&mut bounds, &gb, &maps[..], &options)?;
        let mut pass = LayeredPass::try_new(gb, &maps[..], options, &bounds)?
            .try_with_ids(ImageView::try_new(&g.object, w, h, w)?, &ids)?;
        let (mut masks, mut pixel_regions, mut prr) = (Vec::new(), Vec::new(), None);
        if let Some(r) = &self.regions {
            let tris;
            (tris, pixel_regions) = r.frame_regions(g);
            masks = vec![0u64; try_prr_masks_len(tris.len(), bounds.len())?];
            let eye = g.camera.eye();
            const CHUNK: usize = 1024;
            let words = prr_mask_words(bounds.len());
            let parts: Vec<PrrStats> = pool.install(|| {
                masks
                    .par_chunks_mut(CHUNK * words)
                    .zip(tris.par_chunks(CHUNK))
                    .map(|(m, t)| try_prr_masks(m, t, eye, &bounds))
                    .collect::<Result<_, Error>>()
            })?;
            prr = Some(parts.iter().fold(PrrStats::default(), |a, b| PrrStats {
                regions: a.regions + b.regions,
                pairs: a.pairs + b.pairs,
                may_reflect: a.may_reflect + b.may_reflect,
                untested: a.untested + b.untested,
            }));
        }
        if self.regions.is_some() {
            pass = pass.try_with_regions(ImageView::try_new(&pixel_regions, w, h, w)?, &masks)?;
        }
        let mut texels = vec![LayeredPassTexel::default(); g.len()];
        let band = PYRAMID_BAND as usize * w as usize;
        let bands: Vec<LayeredPassStats> = pool.install(|| {
            texels
                .par_chunks_mut(band)
                .enumerate()
                .map(|(k, t)| {
                    let y0 = k as u32 * PYRAMID_BAND;
                    let rows = RowRange::try_new(y0, (y0 + PYRAMID_BAND).min(h), h)?;
                    pass.try_run(
                        &mut ImageViewMut::try_band(t, w, h, w, rows)?,
                        None,
                        &mut [],
                    )
                })
                .collect::<Result<_, Error>>()
        })?;
        let stats = bands
            .iter()
            .fold(LayeredPassStats::default(), |a, b| a.sum(b));
        Ok(LayeredTraces { texels, stats, prr })
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

/// Compares the layered pass's hits with the reference hits of `rays`
/// (the same pixels; the pass's ray of a pixel is generated by refl-core,
/// the reference's by the root package, from the same surface point and
/// normal).
pub fn evaluate(
    scene: &Scene,
    ls: &LayeredScene,
    rays: &ReflectionRays,
    traces: &LayeredTraces,
) -> LayeredStats {
    let mut s = LayeredStats {
        rays: rays.len(),
        ..LayeredStats::default()
    };
    for (k, &p) in rays.pixel.iter().enumerate() {
        let t = &traces.texels[p as usize];
        s.fetches += u64::from(t.fetches);
        let reference = rays.reference[k].map(|h| (scene.tri_object[h.prim as usize], h.t));
        let ref_obj =
            reference.and_then(|(o, t)| ls.objects.iter().find(|m| m.object == o).map(|m| (m, t)));
        if ref_obj.is_some() {
            s.to_objects += 1;
        }
        let hit = (t.status == LayeredPassStatus::Hit)
            .then(|| ls.objects.get(t.map as usize))
            .flatten();
        match (hit, ref_obj) {
            (Some(o), Some((m, rt))) if o.object == m.object => {
                let texel = (m.grid.max() - m.grid.min()).max_element() / m.grid.face_res() as f32;
                let err = (t.position - rays.ray[k].at(rt)).length() / texel;
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

/// How the `layered` method shades a map hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayeredShading {
    /// From the texel, as seed 001 does: the color its layer stores
    /// ([`LayeredObject::shade_samples`]: the crossing of the texel's column
    /// ray, shaded once), so the map's resolution shows in the image.
    Texel,
    /// Diagnostic: the primitive the layer's crossing hit, intersected
    /// exactly with the pixel's ray and shaded there (what the report did
    /// before the maps stored color; it hides the texel's sampling).
    PrimitiveId,
}

/// The reflection image of the `layered` method: every mirror pixel
/// (roughness 0) whose ray hit a map, shaded as `shading` says; with
/// `env`, every other mirror pixel the pass traced takes the environment
/// in its ray's direction (seed 001 Sec. 4.1).
pub fn shade(
    shader: &Shader,
    g: &GBuffer,
    ls: &LayeredScene,
    traces: &LayeredTraces,
    shading: LayeredShading,
    env: Option<&Surroundings>,
) -> ReflectionImage {
    let scene = shader.scene;
    let mut out = ReflectionImage::empty(g.width(), g.height());
    for (i, t) in traces.texels.iter().enumerate() {
        if g.roughness[i] > 0.0 || !g.is_reflective(i) {
            continue;
        }
        if t.status != LayeredPassStatus::Hit {
            if let Some(env) = env {
                if t.dir.is_finite() && t.dir != Vec3::ZERO {
                    out.rgb[i] = env.sample(t.dir);
                    out.handled[i] = true;
                }
            }
            continue;
        }
        let Some(obj) = ls.objects.get(t.map as usize) else {
            continue;
        };
        let color = match shading {
            LayeredShading::Texel => obj.colors.get(t.payload as usize).copied(),
            LayeredShading::PrimitiveId => obj.sample(t.payload).and_then(|(_, _, h)| {
                let tri = scene.tris.get(h.prim as usize)?;
                let origin = g.position[i];
                let exact = ray_triangle_plane(tri, h.prim, origin, t.dir).unwrap_or(Hit {
                    prim: h.prim,
                    t: t.t,
                    u: 0.0,
                    v: 0.0,
                });
                Some(shader.shade_reflection_hit(origin, t.dir, &exact))
            }),
        };
        if let Some(c) = color {
            out.rgb[i] = c;
            out.handled[i] = true;
        }
    }
    out
}
