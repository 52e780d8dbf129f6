//! Screen-space reflections over the primary view's depth buffer: the ray
//! sets, the depth images and the measurements shared by the depth-image
//! kernels of refl-core (per-pixel stepping and Hi-Z traversal).
//!
//! * [`ReflectionRays`]: one mirror reflection ray per reflective pixel of a
//!   [`GBuffer`] (the same rays the reference traces), with the reference
//!   tracer's hit and whether that hit is visible in the depth buffer.
//! * [`evaluate`]: hit rate, false-hit rate and hit error in pixels of a
//!   kernel's [`Trace`]s against the reference hits.
//! * [`shade`]: the reflection image a screen-space method produces: the lit
//!   frame's color at the hit texel (what an engine's SSR reads), only for
//!   mirror pixels whose ray hit.
//!
//! Visible: the reference hit point projects into the image, and the pixel
//! it projects to sees the same object at a linear depth within
//! [`VISIBLE_DEPTH_TOLERANCE`] (relative) of the hit's. Found: a kernel hit
//! within [`FOUND_RADIUS_PX`] of the reference hit's projection. A false hit
//! is a hit reported for a ray whose reference hit is not visible (the true
//! surface is elsewhere: occluded, off screen, or nothing at all).

use crate::gbuffer::GBuffer;
use crate::scene::Scene;
use crate::shade::{reflection_dir, Shader};
use crate::tracer::{Hit, Tracer};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use refl_core::{Camera, DepthConvention, DepthImage, ImageView, Ray, Trace};

/// Relative linear-depth tolerance of the visibility test.
pub const VISIBLE_DEPTH_TOLERANCE: f32 = 0.02;

/// A kernel hit within this many pixels (Euclidean) of the reference hit's
/// projection counts as found.
pub const FOUND_RADIUS_PX: f32 = 1.0;

/// The reflection rays of a G-buffer and their reference hits.
#[derive(Clone, Debug, Default)]
pub struct ReflectionRays {
    /// Pixel index (into the G-buffer) of each ray.
    pub pixel: Vec<u32>,
    /// The ray as the reference traces it: from the surface point, with
    /// `tmin =` [`Shader::epsilon`].
    pub ray: Vec<Ray>,
    /// The ray as a depth-image kernel traces it: the origin moved off the
    /// surface toward the viewer by [`ReflectionRays::bias`] along the
    /// geometric normal, so that the ray's first texel (the reflector's own)
    /// is not a hit.
    pub screen_ray: Vec<Ray>,
    /// The reference (obvhs) hit of each ray.
    pub reference: Vec<Option<Hit>>,
    /// Projection `(px, py)` of the reference hit into the primary view,
    /// `None` for a miss or a point behind the eye.
    pub reference_pixel: Vec<Option<Vec2>>,
    /// Whether the reference hit is visible in the depth buffer (see the
    /// module docs).
    pub visible: Vec<bool>,
    /// The origin offset used for [`ReflectionRays::screen_ray`], world
    /// units.
    pub bias: f32,
}

impl ReflectionRays {
    /// Number of rays.
    pub fn len(&self) -> usize {
        self.ray.len()
    }

    /// `true` without rays.
    pub fn is_empty(&self) -> bool {
        self.ray.is_empty()
    }

    /// Number of rays whose reference hit is visible.
    pub fn visible_count(&self) -> usize {
        self.visible.iter().filter(|&&v| v).count()
    }
}

/// The mirror reflection rays of every reflective pixel of `g` (computed as
/// the reference renderer computes them), traced with the reference tracer.
pub fn reflection_rays(
    scene: &Scene,
    tracer: &Tracer,
    shader: &Shader,
    g: &GBuffer,
    pool: &rayon::ThreadPool,
) -> ReflectionRays {
    // A depth-proportional offset would be scale-free too, but one world
    // offset per scene keeps rays identical across depth conventions.
    let bias = scene.diameter() * 2e-4;
    let pixels: Vec<u32> = (0..g.len())
        .filter(|&i| g.is_reflective(i))
        .map(|i| i as u32)
        .collect();
    let rows: Vec<(Ray, Ray, Option<Hit>, Option<Vec2>, bool)> = pool.install(|| {
        pixels
            .par_iter()
            .map(|&p| {
                let i = p as usize;
                let view = -g.primary_ray(i).dir;
                let dir = reflection_dir(view, g.normal[i], g.geo_normal[i]);
                let ray = Ray {
                    origin: g.position[i],
                    dir,
                };
                let screen_ray = Ray {
                    origin: g.position[i] + g.geo_normal[i] * bias,
                    dir,
                };
                let hit = tracer.trace(ray.origin, dir, shader.epsilon, f32::INFINITY);
                let (px, visible) = match hit {
                    Some(h) => {
                        let p = ray.at(h.t);
                        match g.camera.project(p) {
                            Some(q) => {
                                let px = q.truncate();
                                (Some(px), visible_in(scene, g, h.prim, px, q.z))
                            }
                            None => (None, false),
                        }
                    }
                    None => (None, false),
                };
                (ray, screen_ray, hit, px, visible)
            })
            .collect()
    });
    let mut out = ReflectionRays {
        pixel: pixels,
        bias,
        ..ReflectionRays::default()
    };
    for (ray, screen_ray, hit, px, visible) in rows {
        out.ray.push(ray);
        out.screen_ray.push(screen_ray);
        out.reference.push(hit);
        out.reference_pixel.push(px);
        out.visible.push(visible);
    }
    out
}

/// Whether a hit on primitive `prim` at linear depth `z`, projecting to
/// `px`, is what the G-buffer's pixel under `px` sees.
fn visible_in(scene: &Scene, g: &GBuffer, prim: u32, px: Vec2, z: f32) -> bool {
    if !(px.x >= 0.0 && px.y >= 0.0 && px.x < g.width() as f32 && px.y < g.height() as f32) {
        return false;
    }
    let i = px.y as usize * g.width() as usize + px.x as usize;
    g.object[i] == scene.tri_object[prim as usize]
        && (g.depth[i] - z).abs() <= VISIBLE_DEPTH_TOLERANCE * z
}

/// A depth buffer of `g` in convention `c` with its camera (far plane
/// `far`, which may be infinite for the projective conventions).
pub struct DepthBuffer {
    /// Stored depths, row-major, `width * height`.
    pub data: Vec<f32>,
    /// The camera the depths are encoded for.
    pub camera: Camera,
    /// The convention.
    pub convention: DepthConvention,
}

impl DepthBuffer {
    /// Encodes `g`'s linear depth in convention `c` with far plane `far`.
    ///
    /// # Errors
    /// As [`GBuffer::depth_image`].
    pub fn new(g: &GBuffer, c: DepthConvention, far: f32) -> Result<Self, refl_core::Error> {
        let data = g.depth_image(c, far)?;
        let camera = Camera::try_new(
            g.camera.view(),
            g.camera.fov_y(),
            g.camera.near(),
            far,
            g.width(),
            g.height(),
        )?;
        Ok(Self {
            data,
            camera,
            convention: c,
        })
    }

    /// The refl-core view of the buffer.
    ///
    /// # Errors
    /// Only for an inconsistent buffer (never for one made by
    /// [`DepthBuffer::new`]).
    pub fn image(&self) -> Result<DepthImage<'_>, refl_core::Error> {
        let view = ImageView::try_new(
            &self.data,
            self.camera.width(),
            self.camera.height(),
            self.camera.width(),
        )?;
        DepthImage::try_new(view, self.camera, self.convention)
    }
}

/// Hit statistics of a kernel's traces against the reference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayStats {
    /// Rays traced.
    pub rays: usize,
    /// Rays whose reference hit is visible in the depth buffer.
    pub visible: usize,
    /// Visible rays the kernel found within [`FOUND_RADIUS_PX`].
    pub found: usize,
    /// Visible rays the kernel hit somewhere else (farther than
    /// [`FOUND_RADIUS_PX`]).
    pub wrong: usize,
    /// Visible rays the kernel missed.
    pub missed: usize,
    /// Rays whose reference hit is not visible, for which the kernel still
    /// reported a hit.
    pub false_hits: usize,
    /// Sum over visible rays with a kernel hit of the hit's distance in
    /// pixels to the reference hit's projection.
    pub err_px_sum: f64,
    /// Visible rays with a kernel hit (the count behind `err_px_sum`).
    pub err_px_count: usize,
    /// Total depth fetches.
    pub fetches: u64,
    /// Total steps.
    pub steps: u64,
    /// Total traversal iterations.
    pub iterations: u64,
}

impl RayStats {
    /// Share of visible rays found within one pixel.
    pub fn hit_rate(&self) -> f64 {
        ratio(self.found, self.visible)
    }

    /// Share of rays with an invisible reference hit that reported a hit.
    pub fn false_hit_rate(&self) -> f64 {
        ratio(self.false_hits, self.rays - self.visible)
    }

    /// Mean hit error in pixels over visible rays with a hit.
    pub fn mean_err_px(&self) -> f64 {
        if self.err_px_count == 0 {
            0.0
        } else {
            self.err_px_sum / self.err_px_count as f64
        }
    }

    /// Adds another frame's statistics.
    pub fn add(&mut self, o: &RayStats) {
        self.rays += o.rays;
        self.visible += o.visible;
        self.found += o.found;
        self.wrong += o.wrong;
        self.missed += o.missed;
        self.false_hits += o.false_hits;
        self.err_px_sum += o.err_px_sum;
        self.err_px_count += o.err_px_count;
        self.fetches += o.fetches;
        self.steps += o.steps;
        self.iterations += o.iterations;
    }
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}

/// Compares a kernel's traces (one per ray of `rays`, same order) with the
/// reference hits.
///
/// # Panics
/// If `traces` and `rays` differ in length.
pub fn evaluate(rays: &ReflectionRays, traces: &[Trace]) -> RayStats {
    assert_eq!(rays.len(), traces.len(), "one trace per ray");
    let mut s = RayStats {
        rays: rays.len(),
        ..RayStats::default()
    };
    for (i, t) in traces.iter().enumerate() {
        let w = t.work();
        s.fetches += u64::from(w.fetches);
        s.steps += u64::from(w.steps);
        s.iterations += u64::from(w.iterations);
        let visible = rays.visible[i];
        s.visible += usize::from(visible);
        match (t.hit(), visible) {
            (Some(h), true) => {
                let err = rays.reference_pixel[i].map_or(f32::INFINITY, |q| (h.pixel - q).length());
                s.err_px_sum += f64::from(err);
                s.err_px_count += 1;
                if err <= FOUND_RADIUS_PX {
                    s.found += 1;
                } else {
                    s.wrong += 1;
                }
            }
            (None, true) => s.missed += 1,
            (Some(_), false) => s.false_hits += 1,
            (None, false) => {}
        }
    }
    s
}

/// The reflection image of a screen-space method: every mirror pixel
/// (roughness 0) whose ray hit takes `lit[hit texel]`, the lit frame's
/// color where the ray landed; other pixels are not handled (glossy pixels
/// need the cone tracer, misses need a fallback).
pub fn shade(
    g: &GBuffer,
    lit: &[Vec3],
    rays: &ReflectionRays,
    traces: &[Trace],
) -> crate::render::ReflectionImage {
    let mut out = crate::render::ReflectionImage::empty(g.width(), g.height());
    let (w, h) = (g.width(), g.height());
    for (k, t) in traces.iter().enumerate() {
        let i = rays.pixel[k] as usize;
        if g.roughness[i] > 0.0 {
            continue;
        }
        if let Some(hit) = t.hit() {
            let x = (hit.pixel.x.max(0.0) as u32).min(w - 1);
            let y = (hit.pixel.y.max(0.0) as u32).min(h - 1);
            out.rgb[i] = lit[(y * w + x) as usize];
            out.handled[i] = true;
        }
    }
    out
}

/// Traces every ray of `rays` with `trace` on `pool` (in chunks), in ray
/// order.
pub fn trace_all(
    rays: &[Ray],
    pool: &rayon::ThreadPool,
    trace: impl Fn(&Ray) -> Trace + Sync,
) -> Vec<Trace> {
    pool.install(|| rays.par_iter().with_min_len(256).map(&trace).collect())
}

/// Traces every ray with the reference tracer (closest hit, `tmin`), for the
/// time ratio on the same rays.
pub fn trace_reference(
    tracer: &Tracer,
    rays: &[Ray],
    tmin: f32,
    pool: &rayon::ThreadPool,
) -> Vec<Option<Hit>> {
    pool.install(|| {
        rays.par_iter()
            .with_min_len(256)
            .map(|r| tracer.trace(r.origin, r.dir, tmin, f32::INFINITY))
            .collect()
    })
}
