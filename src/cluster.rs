//! Second-order feed-forward reflections (seed 003) as a whole renderer:
//! the `cluster` method of `refl report`.
//!
//! Per frame, over a G-buffer (the seed's first pass, Sec. 3.1 step 1),
//! with refl-core's cluster pass ([`refl_core::cluster::ClusterPass`]: the
//! G-buffer as refl-core reads it, linear depth, world normals, the
//! reflective mask, the object ids and one [`Lobe`] per object):
//!
//! 1. **Plan** ([`ClusterPass::try_plan`], one call, serial): clustering
//!    (Sec. 3.2: screen shares, bin layout, cluster ids, pixel lists) and
//!    (2.) one camera per non-empty cluster (Sec. 3.3) with its frustum;
//!    the far plane is at the scene diameter, glossy clusters widen their
//!    frame by the lobe's 95 % angle ([`LOBE_ENERGY`]).
//! 3. **Depth images** (Sec. 3.1 step 3b), one cluster at a time into one
//!    reused visibility buffer and color buffer: the scene rasterized with
//!    the CPU rasterizer ([`rasterize_into_culled`]: object-level frustum and
//!    clip-plane culling, then the same per 4096-triangle chunk, with chunk
//!    bounds computed once per frame)
//!    through the cluster camera, keeping only what lies in front of the
//!    cluster's clip plane (a planar cluster also skips its own object);
//!    every covered texel is shaded (the direct term of its surface, as the
//!    reference shades a reflected hit).
//! 4. **Intersection** (Sec. 3.4, 3.5): [`ClusterPass::try_finalize_rows`]
//!    over row bands of the cluster, in parallel: the pixels' mirror rays,
//!    or 8..49 lobe samples for glossy pixels, stepped through the depth
//!    image; the missed share (and every pixel of a cluster without a
//!    camera) takes the environment map in the pass's direction (the
//!    seed's callback-free fallback; the pass's host rays are not traced).
//!
//! Diagnostics (not timed): the **disocclusion** mask marks pixels whose
//! ray-traced mirror hit (obvhs) is not captured by their cluster's depth
//! image (Sec. 4.1.1: "surfaces that should be visible in the reflection at
//! a cluster but that are not captured by the cluster depth image").

use crate::gbuffer::GBuffer;
use crate::raster::{rasterize_into_culled, ChunkBounds, RasterOptions, VisBuffer};
use crate::render::{self, compare, composite, direct_image, median, timed, ReflectionImage};
use crate::scene::{phong_exponent, NONE};
use crate::shade::{env_map, reflection_dir, Shader};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use refl_core::cluster::{
    self, ClusterCamera, ClusterCameraOptions, ClusterObjects, ClusterOptions, ClusterPass,
    ClusterPassOptions, ClusterPlanEntry, ClusterRender, ClusterScratchMut, ClusterSink,
    ClusterTexel, Lobe, ObjectBins, NO_CLUSTER,
};
use refl_core::{
    DepthConvention, DepthImage, Error, GBuffer as CoreGBuffer, HostRay, ImageView, NormalSpace,
    Plane, RowRange,
};
use std::fmt::Write as _;
use std::io;
use std::path::Path;
use std::time::Instant;

/// Share of a glossy lobe's samples its cluster camera frame must hold.
pub const LOBE_ENERGY: f32 = 0.95;

/// Rows per clustering band (the unit of parallel work).
const BAND_ROWS: u32 = 16;

/// One setting of the cluster method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterSettings {
    /// Gain of the bin modulation `a_R / n_v` (the cluster-count knob; 1 is
    /// the seed's formula).
    pub gain: f32,
    /// Depth-image resolution relative to the cluster's pixel spacing (seed
    /// Table 5 sweeps 1/2, 1, 2).
    pub resolution_scale: f32,
    /// Rays per glossy pixel (seed: 8..49); mirror pixels trace one.
    pub glossy_rays: u32,
    /// With `Some(sr)`, the rays per glossy pixel follow the glossiness
    /// (seed 003 Sec. 3.5 item 3) instead of `glossy_rays`: one ray per
    /// `sr` steradians of the lobe's cone ([`rays_for_lobe`]), 8 to 49.
    pub steradians_per_ray: Option<f32>,
    /// With `Some(k)`, glossy clusters bring their far plane in (seed 003
    /// Sec. 3.5 item 2): to where the lobe's cone spreads over a disc of
    /// radius `k` times the scene diameter
    /// ([`ClusterCameraOptions::glossy_blur_radius`]), and their hits fade
    /// to the surface's own color at that far plane (the pass's `fade`).
    pub glossy_far: Option<f32>,
    /// Seed 003 Sec. 4.4's second way for concave clusters: their rays
    /// also meet their own reflector, which then shows its diffuse color
    /// (the pass's `second_intersection`; the G-buffer's direct image is
    /// the diffuse component the seed's first pass computes, not timed).
    pub second_intersection: bool,
    /// Seed 003 Sec. 4.2.2: glossy pixels trace one ray and average the
    /// lobe's neighborhood of its hit (the pass's `glossy_single_ray`).
    pub glossy_single_ray: bool,
}

/// The fewest and most rays per glossy pixel of seed 003 Sec. 3.5 item 3
/// ("the number of rays per glossy pixel ranges from 8 to 49").
pub const GLOSSY_RAYS_RANGE: (u32, u32) = (8, 49);

/// Rays for a glossy pixel whose lobe's cone has half-angle `max_angle`
/// (radians; the lobe's [`LOBE_ENERGY`] angle) at one ray per
/// `steradians_per_ray`: `ceil(Omega / steradians_per_ray)` for the cone's
/// solid angle `Omega = 2 pi (1 - cos max_angle)`, clamped to
/// [`GLOSSY_RAYS_RANGE`] (seed 003 Sec. 3.5 item 3: "For surfaces close to
/// specular, the angle is small, and therefore the number of rays is
/// small. For a more matte surface the angle is larger requiring
/// additional rays"). The density is the setting the report sweeps: the
/// seed gives only the range.
pub fn rays_for_lobe(max_angle: f32, steradians_per_ray: f32) -> u32 {
    let omega = 2.0 * std::f64::consts::PI * (1.0 - f64::from(max_angle).cos());
    let n = (omega / f64::from(steradians_per_ray)).ceil();
    let (lo, hi) = GLOSSY_RAYS_RANGE;
    if n.is_nan() {
        return lo;
    }
    n.clamp(f64::from(lo), f64::from(hi)) as u32
}

impl Default for ClusterSettings {
    /// Gain 64, resolution 1x, 8 glossy rays.
    fn default() -> Self {
        Self {
            gain: 64.0,
            resolution_scale: 1.0,
            glossy_rays: 8,
            steradians_per_ray: None,
            glossy_far: None,
            second_intersection: false,
            glossy_single_ray: false,
        }
    }
}

impl ClusterSettings {
    /// The report's setting label.
    pub fn label(&self) -> String {
        let far = match self.glossy_far {
            Some(k) => format!(";glossy_far={k};fade"),
            None => String::new(),
        };
        let rays = match self.steradians_per_ray {
            None => format!(
                "gain={};res={};glossy_rays={}",
                self.gain, self.resolution_scale, self.glossy_rays
            ),
            Some(sr) => format!(
                "gain={};res={};glossy_rays=auto;sr_per_ray={sr}",
                self.gain, self.resolution_scale
            ),
        };
        let concave = if self.second_intersection {
            ";concave=second"
        } else {
            ""
        };
        let single = if self.glossy_single_ray {
            ";glossy=single_ray"
        } else {
            ""
        };
        rays + &far + concave + single
    }
}

/// Milliseconds per stage of one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageMs {
    /// The pass's plan: clustering (step 2) and camera construction (step
    /// 3a), one call.
    pub clustering: f64,
    /// Camera construction alone: 0 since the plan does it (the column is
    /// kept; the cameras' time is in `clustering`).
    pub cameras: f64,
    /// Depth (and color) images (step 3b).
    pub depth_images: f64,
    /// Ray / depth-image intersection and composite (step 3c).
    pub intersection: f64,
}

impl StageMs {
    /// The frame: the sum of the stages.
    pub fn total(&self) -> f64 {
        self.clustering + self.cameras + self.depth_images + self.intersection
    }

    /// The stage with the largest time.
    pub fn dominant(&self) -> &'static str {
        let v = [
            (self.clustering, "clustering"),
            (self.cameras, "cameras"),
            (self.depth_images, "depth images"),
            (self.intersection, "intersection"),
        ];
        v.iter()
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map_or("none", |x| x.1)
    }

    /// Per-field median of `runs`.
    pub fn median_of(runs: &[StageMs]) -> StageMs {
        let m = |f: fn(&StageMs) -> f64| median(runs.iter().map(f).collect());
        StageMs {
            clustering: m(|s| s.clustering),
            cameras: m(|s| s.cameras),
            depth_images: m(|s| s.depth_images),
            intersection: m(|s| s.intersection),
        }
    }
}

/// One frame of the cluster method.
#[derive(Clone, Debug)]
pub struct ClusterFrame {
    /// The reflection of every reflective pixel.
    pub image: ReflectionImage,
    /// Per pixel, the weight of the reflection left to the surface's own
    /// (lit) color: with the glossy fade (seed 003 Sec. 3.5 item 2, "the
    /// glossy reflection is blended with the diffuse color of the surface
    /// with a weight that decreases to 0 as the distance to the reflected
    /// surface becomes the distance to the far plane"), `1 - hit_weight -
    /// env_weight`; 0 without fade. [`ClusterFrame::blend_remainder`]
    /// adds it.
    pub remainder: Vec<f32>,
    /// Cluster id per pixel ([`NO_CLUSTER`] for non-reflective pixels).
    pub cluster_of: Vec<u32>,
    /// Pixels that used the environment (a missed ray, or a cluster
    /// without camera).
    pub fallback: Vec<bool>,
    /// Non-empty clusters.
    pub clusters: usize,
    /// Clusters with a camera (a depth image rendered).
    pub cameras: usize,
    /// Clusters with a camera that are planar (`f = 1`, one lookup).
    pub planar: usize,
    /// Depth-image texels rendered over all clusters.
    pub texels: u64,
    /// Triangles sent to the rasterizer's bands over all clusters.
    pub triangles_rasterized: usize,
    /// Time per stage.
    pub stages: StageMs,
    /// Of the depth images, the ms spent shading their texels (the color
    /// pass; the rest is rasterization and chunk bounds).
    pub color_ms: f64,
    /// With diagnostics: pixels whose ray-traced mirror hit is not in their
    /// cluster's depth image.
    pub disoccluded: Option<Vec<bool>>,
    /// With diagnostics: pixels whose ray-traced mirror ray hits the scene
    /// (elsewhere the environment is the right answer).
    pub reference_hit: Option<Vec<bool>>,
}

impl ClusterFrame {
    /// Adds to each reflection its [`ClusterFrame::remainder`] of the
    /// surface's lit color `lit` (one per pixel).
    pub fn blend_remainder(&mut self, lit: &[Vec3]) {
        for (i, &r) in self.remainder.iter().enumerate() {
            if r > 0.0 && self.image.handled[i] {
                self.image.rgb[i] += lit[i] * r;
            }
        }
    }

    /// Reflective pixels.
    pub fn reflective(&self) -> usize {
        self.image.handled_count()
    }

    /// Reflective pixels that fell back.
    pub fn fallback_count(&self) -> usize {
        self.fallback.iter().filter(|&&f| f).count()
    }

    /// Reflective pixels that fell back although their ray-traced mirror
    /// ray hits the scene (0 without diagnostics): the fallbacks that are
    /// errors.
    pub fn wrong_fallback_count(&self) -> usize {
        self.reference_hit.as_ref().map_or(0, |r| {
            r.iter()
                .zip(&self.fallback)
                .filter(|(&h, &f)| h && f)
                .count()
        })
    }

    /// Disocclusion pixels (0 without diagnostics).
    pub fn disoccluded_count(&self) -> usize {
        self.disoccluded
            .as_ref()
            .map_or(0, |d| d.iter().filter(|&&x| x).count())
    }

    fn share(&self, count: usize) -> f64 {
        count as f64 / self.reflective().max(1) as f64
    }

    /// Share of the reflective pixels that fell back.
    pub fn fallback_share(&self) -> f64 {
        self.share(self.fallback_count())
    }

    /// [`ClusterFrame::wrong_fallback_count`] as a share of the reflective
    /// pixels.
    pub fn wrong_fallback_share(&self) -> f64 {
        self.share(self.wrong_fallback_count())
    }

    /// Share of the reflective pixels with a disocclusion (0 without
    /// diagnostics).
    pub fn disocclusion_share(&self) -> f64 {
        self.share(self.disoccluded_count())
    }
}

/// The lobe of an object of material `m` (module docs, step 4); a mirror
/// for a material that does not reflect (its pixels are not in the pass).
fn lobe_of(m: &crate::scene::Material, settings: &ClusterSettings) -> Result<Lobe, Error> {
    if m.specular > 0.0 && m.roughness > 0.0 && settings.glossy_rays > 1 {
        let exponent = phong_exponent(m.roughness);
        let max_angle = cluster::try_lobe_angle(exponent, LOBE_ENERGY)?;
        Ok(Lobe {
            rays: match settings.steradians_per_ray {
                Some(sr) => rays_for_lobe(max_angle, sr),
                None => settings.glossy_rays,
            },
            exponent,
            max_angle,
        })
    } else {
        Ok(Lobe::MIRROR)
    }
}

/// The cluster pass's options for `settings` on a scene of diameter
/// `diameter`: the far plane at the diameter, thickness 0.005 of it.
pub fn pass_options(settings: &ClusterSettings, diameter: f32) -> ClusterPassOptions {
    ClusterPassOptions {
        cluster: ClusterOptions {
            gain: settings.gain,
            ..ClusterOptions::default()
        },
        camera: ClusterCameraOptions {
            far_distance: diameter,
            resolution_scale: settings.resolution_scale,
            glossy_blur_radius: settings.glossy_far.map_or(f32::INFINITY, |k| k * diameter),
            ..ClusterCameraOptions::default()
        },
        fade: settings.glossy_far.is_some(),
        second_intersection: settings.second_intersection,
        glossy_single_ray: settings.glossy_single_ray,
        thickness: crate::screen::THICKNESS_OF_DIAMETER,
        ..ClusterPassOptions::default()
    }
}

/// Collects a finalize band's texels (the host rays are not traced here:
/// the environment answers them, as the seed's fallback does).
#[derive(Default)]
struct Texels(Vec<(u32, u32, ClusterTexel)>);

impl ClusterSink for Texels {
    fn texel(&mut self, x: u32, y: u32, texel: &ClusterTexel) {
        self.0.push((x, y, *texel));
    }
    fn host(&mut self, _: u32, _: &HostRay) -> bool {
        false
    }
}

/// Renders the reflections of `g` with seed 003's method on `pool`;
/// with `diagnose`, also the disocclusion mask (ray traced with `shader`'s
/// tracer, outside the stage timers).
///
/// # Errors
/// A refl-core error (invalid G-buffer data).
pub fn run(
    shader: &Shader,
    g: &GBuffer,
    settings: &ClusterSettings,
    pool: &rayon::ThreadPool,
    diagnose: bool,
) -> Result<ClusterFrame, Error> {
    let scene = shader.scene;
    let (w, h) = (g.width(), g.height());
    let n = g.len();
    let mut stages = StageMs::default();

    // The diffuse component of every pixel (the seed's first pass, Sec.
    // 3.1 step 1; the reference's one-bounce shading of a reflected hit),
    // for the second intersections of concave clusters. Not timed: the
    // host has it already.
    let diffuse: Vec<[f32; 3]> = if settings.second_intersection {
        direct_image(shader, g, pool)
            .iter()
            .map(|c| c.to_array())
            .collect()
    } else {
        Vec::new()
    };

    // 1 + 2. The plan (clustering and cameras in one call of the pass).
    let t0 = Instant::now();
    let normals: Vec<[f32; 3]> =
        pool.install(|| g.normal.par_iter().map(|v| v.to_array()).collect());
    let mask: Vec<u8> = (0..n).map(|i| u8::from(g.is_reflective(i))).collect();
    let gbuffer = CoreGBuffer::try_new(
        DepthImage::try_new(
            ImageView::try_new(&g.depth, w, h, w)?,
            g.camera,
            DepthConvention::Linear,
        )?,
        ImageView::try_new(&normals, w, h, w)?,
        NormalSpace::World,
    )?
    .try_with_mask(ImageView::try_new(&mask, w, h, w)?)?;
    let lobes = scene
        .objects
        .iter()
        .map(|o| lobe_of(&scene.materials[o.material as usize], settings))
        .collect::<Result<Vec<_>, _>>()?;
    let objects = ClusterObjects {
        ids: ImageView::try_new(&g.object, w, h, w)?,
        lobes: &lobes,
    };
    let options = pass_options(settings, scene.diameter());
    let pass = ClusterPass::try_new(gbuffer, options)?;
    let len = cluster::try_cluster_plan_len(w, h, lobes.len(), &options)?;
    let mut ids = vec![NO_CLUSTER; len.ids];
    let mut order = vec![0u32; len.order];
    let mut offsets = vec![0u32; len.offsets];
    let mut counts = vec![0u32; len.counts];
    let mut layout = vec![ObjectBins::default(); len.layout];
    let mut entries: Vec<Option<ClusterPlanEntry>> = vec![None; len.clusters];
    let plan = pass.try_plan(
        &mut entries,
        ClusterScratchMut {
            ids: &mut ids,
            order: &mut order,
            offsets: &mut offsets,
            counts: &mut counts,
            layout: &mut layout,
        },
        &objects,
    )?;
    let entries: Vec<ClusterPlanEntry> = entries.into_iter().flatten().collect();
    stages.clustering = t0.elapsed().as_secs_f64() * 1e3;

    // 3 + 4, one cluster at a time, buffers reused.
    let mut image = ReflectionImage::empty(w, h);
    let mut fallback = vec![false; n];
    let mut remainder = vec![0.0f32; n];
    let mut disoccluded = diagnose.then(|| vec![false; n]);
    let mut reference_hit = diagnose.then(|| vec![false; n]);
    let mut vis = VisBuffer {
        width: 0,
        height: 0,
        prim: Vec::new(),
        depth: Vec::new(),
        stats: Default::default(),
    };
    let mut color: Vec<[f32; 3]> = Vec::new();
    let (mut texels, mut tris) = (0u64, 0usize);
    let mut color_ms = 0.0f64;
    // Chunk bounds once per frame (a dynamic scene's triangles moved),
    // charged to the depth images.
    let tb = Instant::now();
    let chunk_bounds = ChunkBounds::new(scene, pool);
    stages.depth_images += tb.elapsed().as_secs_f64() * 1e3;
    // The finalized texels: reflection color, environment for the missed
    // share (module docs, step 4).
    let fade = options.fade;
    // With fade, the share neither hit nor missed is the surface's own
    // color's (`ClusterShade`: `1 - hit_weight - env_weight`), added by
    // the caller, which has the lit image ([`ClusterFrame::remainder`]).
    let put = |texels: Vec<Texels>,
               image: &mut ReflectionImage,
               fallback: &mut [bool],
               remainder: &mut [f32]| {
        for (x, y, t) in texels.into_iter().flat_map(|t| t.0) {
            let i = (y * w + x) as usize;
            let s = &t.shade;
            let mut rgb = s.rgb;
            if s.env_weight > 0.0 {
                rgb += env_map(s.env_dir) * s.env_weight;
                fallback[i] = true;
            }
            image.rgb[i] = rgb;
            image.handled[i] = true;
            if fade {
                remainder[i] = (1.0 - s.hit_weight - s.env_weight).max(0.0);
            }
        }
    };
    let bands_of = |rows: RowRange| -> Vec<RowRange> {
        (rows.start()..rows.end())
            .step_by(BAND_ROWS as usize)
            .filter_map(|y| RowRange::try_new(y, (y + BAND_ROWS).min(rows.end()), h).ok())
            .collect()
    };
    for e in &entries {
        let px = &order[e.first as usize..(e.first + e.len) as usize];
        let t2 = Instant::now();
        let Some(cc) = e.camera() else {
            // No camera: the environment in the mirror direction.
            let mut sink = Texels::default();
            pass.try_finalize_rows(e, &order, None, e.rows, &mut sink)?;
            put(vec![sink], &mut image, &mut fallback, &mut remainder);
            stages.intersection += t2.elapsed().as_secs_f64() * 1e3;
            if let Some(r) = reference_hit.as_mut() {
                for &p in px {
                    r[p as usize] = reference_mirror_hit(shader, g, p as usize).is_some();
                }
            }
            continue;
        };
        // 3. Depth and color image.
        let cam = cc.camera;
        let clip = Plane::try_from_point_normal(cc.clip.point, cc.clip.normal)?;
        let raster = RasterOptions {
            clip_plane: Some(clip),
            exclude_object: cc.planar.then_some(e.object),
            scissor: None,
        };
        rasterize_into_culled(&mut vis, scene, &cam, &raster, &chunk_bounds, pool);
        tris += vis.stats.triangles_rasterized;
        let (dw, dh) = (cam.width(), cam.height());
        texels += u64::from(dw) * u64::from(dh);
        let tc = Instant::now();
        color.clear();
        color.resize(vis.prim.len(), [0.0; 3]);
        pool.install(|| {
            color
                .par_chunks_mut(dw as usize)
                .enumerate()
                .for_each(|(y, row)| {
                    for (x, out) in row.iter_mut().enumerate() {
                        let i = y * dw as usize + x;
                        if vis.prim[i] == NONE {
                            continue;
                        }
                        let ray = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                        if let Some(hit) = vis.hit(scene, &cam, i) {
                            *out = shader
                                .shade_reflection_hit(ray.origin, ray.dir, &hit)
                                .to_array();
                        }
                    }
                });
        });
        let t3 = Instant::now();
        color_ms += (t3 - tc).as_secs_f64() * 1e3;
        stages.depth_images += (t3 - t2).as_secs_f64() * 1e3;

        // 4. Intersection: the pass over row bands of the cluster.
        let render = ClusterRender::try_new(
            DepthImage::try_new(
                ImageView::try_new(&vis.depth, dw, dh, dw)?,
                cam,
                DepthConvention::Linear,
            )?,
            ImageView::try_new(&color, dw, dh, dw)?,
        )?;
        let render = if settings.second_intersection {
            render.with_reflector(
                ImageView::try_new(&diffuse, w, h, w)?,
                ImageView::try_new(&g.object, w, h, w)?,
            )
        } else {
            render
        };
        let bands = bands_of(e.rows);
        let done = pool.install(|| {
            bands
                .par_iter()
                .map(|&r| {
                    let mut sink = Texels::default();
                    pass.try_finalize_rows(e, &order, Some(&render), r, &mut sink)
                        .map(|_| sink)
                })
                .collect::<Result<Vec<_>, _>>()
        })?;
        put(done, &mut image, &mut fallback, &mut remainder);
        stages.intersection += t3.elapsed().as_secs_f64() * 1e3;

        if let (Some(dis), Some(r)) = (disoccluded.as_mut(), reference_hit.as_mut()) {
            mark_disocclusions(shader, g, cc, &vis, px, dis, r);
        }
    }
    // Reflective pixels the pass has no surface for (none on a rendered
    // G-buffer): the environment in the mirror direction.
    for (i, f) in fallback.iter_mut().enumerate() {
        if g.is_reflective(i) && !image.handled[i] {
            let v = -g.primary_ray(i).dir;
            image.rgb[i] = env_map(reflection_dir(v, g.normal[i], g.geo_normal[i]));
            image.handled[i] = true;
            *f = true;
        }
    }
    Ok(ClusterFrame {
        image,
        remainder,
        cluster_of: ids,
        fallback,
        clusters: plan.clusters as usize,
        cameras: plan.cameras as usize,
        planar: plan.planar as usize,
        texels,
        triangles_rasterized: tris,
        stages,
        color_ms,
        disoccluded,
        reference_hit,
    })
}

/// Marks the pixels `px` of a cluster whose ray-traced mirror hit is not
/// captured by the cluster's depth image `vis` (rendered through
/// `cc.camera`): the hit lies behind the clip plane, outside the image, or
/// neither the texel it projects to nor one of its 8 neighbors holds its
/// primitive or a surface within 1 % of its depth.
fn mark_disocclusions(
    shader: &Shader,
    g: &GBuffer,
    cc: &ClusterCamera,
    vis: &VisBuffer,
    px: &[u32],
    dis: &mut [bool],
    reference_hit: &mut [bool],
) {
    let cam = &cc.camera;
    for &p in px {
        let i = p as usize;
        let Some((x, hit)) = reference_mirror_hit(shader, g, i) else {
            continue;
        };
        reference_hit[i] = true;
        let captured = cc.clip.signed_distance(x) > 0.0
            && cam.project(x).is_some_and(|q| {
                let (tx, ty) = (q.x.floor(), q.y.floor());
                if !(tx >= 0.0 && ty >= 0.0 && tx < cam.width() as f32 && ty < cam.height() as f32)
                {
                    return false;
                }
                // The texel or a neighbor (the depth image samples texel
                // centers, not the pixel's ray): resampling is not a
                // disocclusion.
                let (cx, cy) = (tx as i64, ty as i64);
                (cy - 1..=cy + 1).any(|y| {
                    (cx - 1..=cx + 1).any(|x| {
                        if x < 0
                            || y < 0
                            || x >= i64::from(cam.width())
                            || y >= i64::from(cam.height())
                        {
                            return false;
                        }
                        let t = y as usize * cam.width() as usize + x as usize;
                        vis.prim[t] == hit.prim || (vis.depth[t] - q.z).abs() <= 0.01 * q.z
                    })
                })
            });
        dis[i] = !captured;
    }
}

/// The ray-traced mirror hit of pixel `i` (point and hit), as the
/// reference traces it.
fn reference_mirror_hit(
    shader: &Shader,
    g: &GBuffer,
    i: usize,
) -> Option<(Vec3, crate::tracer::Hit)> {
    let v = -g.primary_ray(i).dir;
    let dir = reflection_dir(v, g.normal[i], g.geo_normal[i]);
    let origin = g.position[i];
    shader
        .tracer
        .trace(origin, dir, shader.epsilon, f32::INFINITY)
        .map(|hit| (origin + dir * hit.t, hit))
}

/// A false-color picture of the clusters: each cluster its own hue
/// (hashed id), diffuse pixels grey; disoccluded pixels red and fallback
/// pixels blue on top when `marks` is set.
pub fn cluster_image(g: &GBuffer, f: &ClusterFrame, marks: bool) -> Vec<Vec3> {
    (0..g.len())
        .map(|i| {
            if marks && f.disoccluded.as_ref().is_some_and(|d| d[i]) {
                return Vec3::new(1.0, 0.0, 0.0);
            }
            if marks && f.fallback[i] {
                return Vec3::new(0.0, 0.2, 1.0);
            }
            let c = f.cluster_of[i];
            if c == NO_CLUSTER {
                return Vec3::splat(0.25);
            }
            let hsh = refl_core::lobe::pixel_hash(c.wrapping_add(0x9e37_79b9));
            let ch = |s: u32| 0.25 + 0.75 * ((hsh >> s) & 0xff) as f32 / 255.0;
            let col = Vec3::new(ch(0), ch(8), ch(16));
            if marks {
                col * 0.45
            } else {
                col
            }
        })
        .collect()
}

/// One scene size of the cost-growth comparison (times in ms, one frame).
#[derive(Clone, Debug, PartialEq)]
pub struct ClusterGrowthRow {
    /// Triangles in the scene.
    pub triangles: usize,
    /// Reflective pixels.
    pub reflective: usize,
    /// BVH build (obvhs), the per-frame cost of ray tracing a dynamic scene.
    pub bvh_build_ms: f64,
    /// The ray-traced reflection pass (obvhs, same rays per pixel, same
    /// shading).
    pub reference_ms: f64,
    /// The cluster method's stages.
    pub stages: StageMs,
    /// Of the depth images, the texel shading (median).
    pub color_ms: f64,
    /// Non-empty clusters.
    pub clusters: usize,
    /// Mean absolute difference on 0..255 against the ray-traced
    /// reflection (64 glossy samples) over the reflective pixels.
    pub mad: f64,
    /// Disocclusion share.
    pub disocclusion: f64,
    /// Fallback share.
    pub fallback: f64,
}

impl ClusterGrowthRow {
    /// `(build + reference) / cluster`: above 1 the cluster pipeline is
    /// faster than ray tracing with a per-frame rebuild.
    pub fn ratio_with_build(&self) -> f64 {
        (self.bvh_build_ms + self.reference_ms) / self.stages.total()
    }
}

/// Measures the room at each of `sizes` triangles (camera pose 0,
/// `width x height`, median of `runs`) with shadows off (so that shading
/// needs no BVH: the BVH is the reflection's visibility structure only).
///
/// # Errors
/// A message for a refl-core error.
pub fn growth(
    sizes: &[usize],
    width: u32,
    height: u32,
    runs: usize,
    settings: &ClusterSettings,
    pool: &rayon::ThreadPool,
) -> Result<Vec<ClusterGrowthRow>, String> {
    let mut rows = Vec::new();
    for &n in sizes {
        let crate::growth::RoomAt {
            scene,
            bvh_build_ms,
            tracer,
            g,
        } = crate::growth::RoomAt::new(n, width, height, runs, pool)?;
        let mut shader = Shader::new(&scene, &tracer);
        shader.shadows = false;
        let reference_ms = median(
            (0..runs.max(1))
                .map(|_| timed(|| render::reference(&shader, &g, settings.glossy_rays, pool)).ms)
                .collect(),
        );
        let truth = render::reference(&shader, &g, 64, pool);
        let mut stage_runs = Vec::new();
        let mut color_runs = Vec::new();
        let mut frame = None;
        for k in 0..runs.max(1) {
            let f = run(&shader, &g, settings, pool, k == 0).map_err(|e| e.to_string())?;
            stage_runs.push(f.stages);
            color_runs.push(f.color_ms);
            if k == 0 {
                frame = Some(f);
            }
        }
        let f = frame.ok_or("no run")?;
        let direct = direct_image(&shader, &g, pool);
        let err = compare(
            &composite(&g, &direct, &truth),
            &composite(&g, &direct, &f.image),
            &f.image.handled,
        );
        rows.push(ClusterGrowthRow {
            triangles: scene.tri_count(),
            reflective: f.reflective(),
            bvh_build_ms,
            reference_ms,
            stages: StageMs::median_of(&stage_runs),
            color_ms: median(color_runs),
            clusters: f.clusters,
            mad: err.mean_abs,
            disocclusion: f.disocclusion_share(),
            fallback: f.fallback_share(),
        });
    }
    Ok(rows)
}

/// Writes `rows` as CSV.
///
/// # Errors
/// I/O errors.
pub fn write_growth_csv(path: &Path, rows: &[ClusterGrowthRow]) -> io::Result<()> {
    let mut w = csv::Writer::from_path(path)?;
    w.write_record([
        "triangles",
        "reflective_pixels",
        "bvh_build_ms",
        "reference_ms",
        "reference_with_build_ms",
        "cluster_ms",
        "clustering_ms",
        "cameras_ms",
        "depth_images_ms",
        "depth_color_ms",
        "intersection_ms",
        "ratio_with_build",
        "dominant_stage",
        "clusters",
        "mad_255",
        "disocclusion",
        "fallback",
    ])?;
    for r in rows {
        w.write_record([
            r.triangles.to_string(),
            r.reflective.to_string(),
            format!("{:.3}", r.bvh_build_ms),
            format!("{:.3}", r.reference_ms),
            format!("{:.3}", r.bvh_build_ms + r.reference_ms),
            format!("{:.3}", r.stages.total()),
            format!("{:.3}", r.stages.clustering),
            format!("{:.3}", r.stages.cameras),
            format!("{:.3}", r.stages.depth_images),
            format!("{:.3}", r.color_ms),
            format!("{:.3}", r.stages.intersection),
            format!("{:.3}", r.ratio_with_build()),
            r.stages.dominant().to_owned(),
            r.clusters.to_string(),
            format!("{:.3}", r.mad),
            format!("{:.4}", r.disocclusion),
            format!("{:.4}", r.fallback),
        ])?;
    }
    w.flush()
}

/// The Markdown table of `rows`.
pub fn growth_markdown(rows: &[ClusterGrowthRow]) -> String {
    let mut s = String::from(
        "| triangles | BVH build ms | obvhs reflections ms | cluster ms (clustering / cameras / depth images / \
         intersection) | of the depth images: texel shading ms | (build+obvhs)/cluster | dominant stage | clusters | \
         MAD /255 | disocclusion | fallback |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let st = &r.stages;
        let _ = writeln!(
            s,
            "| {} | {:.1} | {:.1} | {:.1} ({:.1} / {:.1} / {:.1} / {:.1}) | {:.1} | {:.2} | {} | {} | {:.2} | {:.2} % | {:.2} % |",
            r.triangles,
            r.bvh_build_ms,
            r.reference_ms,
            st.total(),
            st.clustering,
            st.cameras,
            st.depth_images,
            st.intersection,
            r.color_ms,
            r.ratio_with_build(),
            st.dominant(),
            r.clusters,
            r.mad,
            100.0 * r.disocclusion,
            100.0 * r.fallback,
        );
    }
    s
}
