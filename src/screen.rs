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

/// Where a screen-space reflection ray starts, in units of the reflector's
/// depth slope: `t0 = START_SLOPES * z * pixel_angle * tan(theta)`, with
/// `z` the pixel's linear depth, `pixel_angle` the angle one pixel spans
/// and `theta` the angle between the view direction and the surface normal
/// (`tan` clamped to 16). A depth texel stores the depth at its center, a
/// flat plate facing the camera; a ray leaving a surface that recedes from
/// the camera runs behind the plates of the surface's next texels for about
/// half a texel's depth change, `0.5 z pixel_angle tan(theta)`, and a
/// kernel would report those plates as hits (self-intersection). The mirror
/// ray climbs above the tangent plane at the same angle it was viewed at,
/// so after `t0` its depth lies `START_SLOPES` texel slopes in front of the
/// surface. Measured on the room scene (30k triangles, 256x192, stride 1):
/// 0 finds 5% of the visible hits within a pixel (the rest are
/// self-intersections), 0.5 finds 97.1%, 1 finds 96.7% and 2 finds 94.7%
/// (contact hits near the reflector are skipped).
pub const START_SLOPES: f32 = 0.5;

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
    /// The ray as a depth-image kernel traces it: the same line, its origin
    /// moved off the surface by [`ReflectionRays::bias`] along the geometric
    /// normal and then [`START_SLOPES`] depth slopes along the ray (module
    /// docs), so that the reflector's own depth texels are not hits.
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
    let pixel_angle = 2.0 * (g.camera.fov_y() * 0.5).tan() / g.height() as f32;
    let pixels: Vec<u32> = (0..g.len())
        .filter(|&i| g.is_reflective(i))
        .map(|i| i as u32)
        .collect();
    /// One ray's row: (ray, screen ray, reference hit, its pixel, visible).
    type RayRow = (Ray, Ray, Option<Hit>, Option<Vec2>, bool);
    let rows: Vec<RayRow> = pool.install(|| {
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
                // Start where the ray has climbed above the reflector's own
                // depth texels (module docs).
                let cos = view.dot(g.geo_normal[i]).clamp(1.0 / 16.0, 1.0);
                let tan = (1.0 - cos * cos).sqrt() / cos;
                let t0 = START_SLOPES * g.depth[i] * pixel_angle * tan;
                let screen_ray = Ray {
                    origin: g.position[i] + g.geo_normal[i] * bias + dir * t0,
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

/// A screen-space reflection kernel of refl-core with its setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScreenMethod {
    /// Per-pixel stepping ([`refl_core::try_step`], seed 003 Sec. 3.4).
    Step(refl_core::StepOptions),
    /// Hi-Z traversal ([`refl_core::hiz::try_trace_hiz`], seed 004); the
    /// timed pass includes building the pyramid.
    HiZ(refl_core::hiz::HiZOptions),
}

impl ScreenMethod {
    /// Caller-buffer bytes per pixel the kernel reads: the depth buffer
    /// (4 bytes), plus the Hi-Z pyramid (two f32 per texel, all levels).
    pub fn bytes_per_pixel(&self, width: u32, height: u32) -> f64 {
        let pixels = f64::from(width) * f64::from(height);
        match self {
            ScreenMethod::Step(_) => 4.0,
            ScreenMethod::HiZ(_) => {
                let texels = refl_core::hiz::try_hiz_len(width, height).unwrap_or(0) as f64;
                4.0 + texels * std::mem::size_of::<refl_core::hiz::HiZTexel>() as f64 / pixels
            }
        }
    }
}

/// Builds the Hi-Z pyramid of `depth` into `dst` on `pool`: level 0 and
/// then every coarser level split into row bands of 16 rows.
///
/// # Errors
/// As [`refl_core::hiz::try_build_hiz`].
pub fn build_hiz(
    dst: &mut [refl_core::hiz::HiZTexel],
    depth: &DepthImage<'_>,
    pool: &rayon::ThreadPool,
) -> Result<(), refl_core::Error> {
    use refl_core::hiz::{try_build_hiz_level0_rows, try_build_hiz_level_rows, HiZLayout};
    let layout = HiZLayout::try_new(depth.width(), depth.height())?;
    if dst.len() < refl_core::hiz::try_hiz_len(depth.width(), depth.height())? {
        return Err(refl_core::Error::InsufficientSize);
    }
    build_pyramid_banded(
        dst,
        &layout,
        true,
        pool,
        |band, rows| try_build_hiz_level0_rows(band, depth, rows),
        |band, finer, level, rows| try_build_hiz_level_rows(band, finer, &layout, level, rows),
    )?;
    refl_core::hiz::try_stamp_hiz(dst, depth.camera())
}

/// Rows per band of [`build_pyramid_banded`].
pub const PYRAMID_BAND: u32 = 16;

/// Builds a pyramid laid out as `layout` into `dst` in row bands of
/// [`PYRAMID_BAND`] rows on `pool`: level 0 with `level0(band, rows)`, then
/// (with `all_levels`) each coarser level from the finished finer one with
/// `level(band, finer, level, rows)`. The driver of every banded pyramid
/// build of the root package (Hi-Z, convolved color, visibility); the
/// kernels are refl-core's `*_level0_rows` / `*_level_rows`.
///
/// # Errors
/// The first error of a kernel or of a row range.
pub fn build_pyramid_banded<T: Send + Sync>(
    dst: &mut [T],
    layout: &refl_core::hiz::HiZLayout,
    all_levels: bool,
    pool: &rayon::ThreadPool,
    level0: impl Fn(&mut [T], refl_core::RowRange) -> Result<(), refl_core::Error> + Sync,
    level: impl Fn(&mut [T], &[T], u32, refl_core::RowRange) -> Result<(), refl_core::Error> + Sync,
) -> Result<(), refl_core::Error> {
    use refl_core::RowRange;
    const BAND: u32 = PYRAMID_BAND;
    pool.install(|| -> Result<(), refl_core::Error> {
        let l0 = layout.level(0).ok_or(refl_core::Error::InvalidArgument)?;
        dst[l0.range()]
            .par_chunks_mut(BAND as usize * l0.width as usize)
            .enumerate()
            .try_for_each(|(k, band)| {
                let y0 = k as u32 * BAND;
                let rows = RowRange::try_new(y0, (y0 + BAND).min(l0.height), l0.height)?;
                level0(band, rows)
            })?;
        if !all_levels {
            return Ok(());
        }
        for lv in 1..layout.level_count() {
            let (f, c) = (
                layout
                    .level(lv - 1)
                    .ok_or(refl_core::Error::InvalidArgument)?,
                layout.level(lv).ok_or(refl_core::Error::InvalidArgument)?,
            );
            let (head, tail) = dst.split_at_mut(c.offset);
            let finer = &head[f.range()];
            tail[..c.len()]
                .par_chunks_mut(BAND as usize * c.width as usize)
                .enumerate()
                .try_for_each(|(k, band)| {
                    let y0 = k as u32 * BAND;
                    let rows = RowRange::try_new(y0, (y0 + BAND).min(c.height), c.height)?;
                    level(band, finer, lv, rows)
                })?;
        }
        Ok(())
    })
}

/// Runs `method` on every ray of `rays` against `depth` on `pool`, timed
/// (Hi-Z: pyramid build included; the pyramid buffer is allocated outside
/// the timed part, as an engine keeps it across frames). With `refine`,
/// every hit goes through [`refl_core::trace::refine_hit`] (inside the
/// timed part).
///
/// # Errors
/// A refl-core error (a bad ray or setting).
pub fn run(
    method: ScreenMethod,
    refine: bool,
    depth: &DepthImage<'_>,
    thickness: refl_core::Thickness<'_>,
    rays: &[Ray],
    pool: &rayon::ThreadPool,
) -> Result<crate::render::Timed<Vec<Trace>>, refl_core::Error> {
    const CHUNK: usize = 256;
    let miss = Trace::Miss {
        reason: refl_core::Miss::EndOfRay,
        work: refl_core::Work::default(),
    };
    let mut out = vec![miss; rays.len()];
    let mut pyramid = match method {
        ScreenMethod::HiZ(_) => {
            vec![[0.0f32; 2]; refl_core::hiz::try_hiz_len(depth.width(), depth.height())?]
        }
        ScreenMethod::Step(_) => Vec::new(),
    };
    let t = crate::render::timed(|| -> Result<(), refl_core::Error> {
        match method {
            ScreenMethod::Step(opts) => pool.install(|| {
                out.par_chunks_mut(CHUNK)
                    .zip(rays.par_chunks(CHUNK))
                    .try_for_each(|(o, r)| {
                        refl_core::try_step_rays(o, depth, thickness, r, &[f32::INFINITY], opts)
                    })
            }),
            ScreenMethod::HiZ(opts) => {
                build_hiz(&mut pyramid, depth, pool)?;
                let hiz =
                    refl_core::hiz::HiZ::try_new(&pyramid, *depth.camera(), depth.convention())?;
                pool.install(|| {
                    out.par_chunks_mut(CHUNK)
                        .zip(rays.par_chunks(CHUNK))
                        .try_for_each(|(o, r)| {
                            refl_core::hiz::try_trace_hiz_rays(
                                o,
                                &hiz,
                                thickness,
                                r,
                                &[f32::INFINITY],
                                &opts,
                            )
                        })
                })
            }
        }?;
        if refine {
            pool.install(|| {
                out.par_chunks_mut(CHUNK)
                    .zip(rays.par_chunks(CHUNK))
                    .for_each(|(o, r)| {
                        for (t, ray) in o.iter_mut().zip(r) {
                            if let Trace::Hit(h) = t {
                                *h = refl_core::trace::refine_hit(depth, ray, f32::INFINITY, h);
                            }
                        }
                    })
            });
        }
        Ok(())
    });
    t.value?;
    Ok(crate::render::Timed {
        value: out,
        ms: t.ms,
    })
}

/// What the screen-space methods of one frame share: the reflection rays
/// with their reference hits, the obvhs time on the same rays (all threads
/// and one thread) and the depth buffers per convention.
pub struct ScreenFrame {
    /// The frame's reflection rays.
    pub rays: ReflectionRays,
    /// obvhs closest-hit time on the rays, `pool`'s threads, ms (median).
    pub obvhs_ms: f64,
    /// The same on one thread, ms (median).
    pub obvhs_ms_1t: f64,
    /// Surface thickness (linear depth, world units) of every kernel run.
    pub thickness: f32,
    depth: Vec<DepthBuffer>,
}

/// Relative surface thickness of the report's screen-space runs: a
/// fraction of the scene diameter.
pub const THICKNESS_OF_DIAMETER: f32 = 0.005;

impl ScreenFrame {
    /// Rays, reference hits and obvhs timings (median of `runs`) for `g`.
    pub fn new(
        scene: &Scene,
        tracer: &Tracer,
        shader: &Shader,
        g: &GBuffer,
        pool: &rayon::ThreadPool,
        pool_1t: &rayon::ThreadPool,
        runs: usize,
    ) -> Self {
        let rays = reflection_rays(scene, tracer, shader, g, pool);
        let time = |p: &rayon::ThreadPool| {
            crate::render::median(
                (0..runs.max(1))
                    .map(|_| {
                        crate::render::timed(|| {
                            trace_reference(tracer, &rays.ray, shader.epsilon, p)
                        })
                        .ms
                    })
                    .collect(),
            )
        };
        let (obvhs_ms, obvhs_ms_1t) = (time(pool), time(pool_1t));
        Self {
            rays,
            obvhs_ms,
            obvhs_ms_1t,
            thickness: scene.diameter() * THICKNESS_OF_DIAMETER,
            depth: Vec::new(),
        }
    }

    /// Makes the depth buffer of `g` in convention `c` (reversed-Z with an
    /// infinite far plane, the others with the camera's far plane) unless it
    /// exists.
    ///
    /// # Errors
    /// As [`DepthBuffer::new`].
    pub fn prepare_depth(
        &mut self,
        g: &GBuffer,
        c: DepthConvention,
    ) -> Result<(), refl_core::Error> {
        if self.depth(c).is_none() {
            let far = if c == DepthConvention::ReversedZ {
                f32::INFINITY
            } else {
                g.camera.far()
            };
            self.depth.push(DepthBuffer::new(g, c, far)?);
        }
        Ok(())
    }

    /// The depth buffer in convention `c`, once prepared.
    pub fn depth(&self, c: DepthConvention) -> Option<&DepthBuffer> {
        self.depth.iter().find(|d| d.convention == c)
    }
}
