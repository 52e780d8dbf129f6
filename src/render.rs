//! Reflection methods over a G-buffer, the final composite, and image error
//! metrics.
//!
//! Every method produces a [`ReflectionImage`]: the reflected radiance
//! (linear RGB) at the reflective pixels it handles, and the `handled` mask
//! saying which those are. Methods are timed on their reflection pass only;
//! the G-buffer is rendered (and timed) once, separately.
//!
//! | method | handles | how |
//! |---|---|---|
//! | [`Method::Reference`] | every reflective pixel | ray-traced, [`Shader::reference_reflection`] |
//! | [`Method::EnvMap`] | every reflective pixel | [`env_map`] in the mirror direction only: the baseline every seed criticizes |
//! | [`Method::PlanarMirror`] | pixels of planar perfect mirrors | refl-core's planar pass sets up and resolves a rasterization through the mirrored camera; exact at full resolution, visibility upsampled at reduced resolution |
//!
//! # Error metrics
//!
//! Images are compared the way the seeds report error, on 8-bit values:
//! each linear channel is clamped to `[0, 1]`, encoded with the sRGB transfer
//! function (IEC 61966-2-1: `12.92 c` below 0.0031308, else
//! `1.055 c^(1/2.4) - 0.055`) and rounded to `0..=255` ([`to_srgb8`]). Over the
//! pixels of a mask, with `d` the absolute 8-bit difference of one channel:
//!
//! * mean absolute difference = mean of `d` over all channels of all pixels
//!   (0..255 scale);
//! * PSNR = `10 log10(255^2 / mean(d^2))` in dB (`+inf` if identical);
//! * share over a threshold `t` = fraction of pixels whose largest channel
//!   `d` exceeds `t` (the report uses `t = 8`, a visible difference).

use crate::gbuffer::{pixel_center, GBuffer};
use crate::raster::{rasterize, PixelRect, RasterOptions, BAND_ROWS};
use crate::scene::NONE;
use crate::shade::{env_map, reflection_dir, Shader};
use crate::tracer::ray_triangle_plane;
use glam::Vec3;
use rayon::prelude::*;
use refl_core::{
    DepthConvention, DepthImage, Error, GBuffer as CoreGBuffer, ImageView, ImageViewMut,
    NormalSpace, PlanarOptions, PlanarPass, PlanarRect, PlanarRender, PlanarStats, PlanarStatus,
    PlanarTexel, RowRange,
};
use std::path::Path;
use std::time::Instant;

/// The reflected radiance of one method over the reflective pixels it
/// handles.
#[derive(Clone, Debug, PartialEq)]
pub struct ReflectionImage {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Reflected radiance, linear RGB; zero where not handled.
    pub rgb: Vec<Vec3>,
    /// `true` where the method produced a reflection.
    pub handled: Vec<bool>,
}

impl ReflectionImage {
    /// An image with nothing handled.
    pub fn empty(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            rgb: vec![Vec3::ZERO; n],
            handled: vec![false; n],
        }
    }

    /// Number of handled pixels.
    pub fn handled_count(&self) -> usize {
        self.handled.iter().filter(|&&h| h).count()
    }

    /// Fills the pixels selected by `select` (in parallel over rows on
    /// `pool`) with `f(i)` and marks them handled.
    pub(crate) fn fill(
        &mut self,
        pool: &rayon::ThreadPool,
        select: impl Fn(usize) -> bool + Sync,
        f: impl Fn(usize) -> Vec3 + Sync,
    ) {
        let w = self.width as usize;
        pool.install(|| {
            self.rgb
                .par_chunks_mut(w)
                .zip(self.handled.par_chunks_mut(w))
                .enumerate()
                .for_each(|(y, (rgb, handled))| {
                    for x in 0..w {
                        let i = y * w + x;
                        if select(i) {
                            rgb[x] = f(i);
                            handled[x] = true;
                        }
                    }
                });
        });
    }
}

/// A value with the wall-clock milliseconds it took to compute.
#[derive(Clone, Debug, PartialEq)]
pub struct Timed<T> {
    /// The result.
    pub value: T,
    /// Milliseconds.
    pub ms: f64,
}

/// The median of timings `v` (the upper one of an even count).
///
/// # Panics
/// If `v` is empty.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Runs `f` and measures it.
pub fn timed<T>(f: impl FnOnce() -> T) -> Timed<T> {
    let start = Instant::now();
    let value = f();
    Timed {
        value,
        ms: start.elapsed().as_secs_f64() * 1e3,
    }
}

/// A reflection method, with its settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Ray-traced reference; `samples` lobe samples per glossy pixel.
    Reference {
        /// Glossy sample count (mirror pixels always trace one ray).
        samples: u32,
    },
    /// Environment map in the mirror direction.
    EnvMap,
    /// Planar reflection by rasterizing through the mirrored camera at
    /// `1 / scale` of the resolution in each axis (1 = exact).
    PlanarMirror {
        /// Resolution divisor of the mirrored render (at least 1).
        scale: u32,
    },
}

impl Method {
    /// A short name for tables and file names (`reference-64`, `envmap`,
    /// `planar-mirror`).
    pub fn name(&self) -> String {
        match self {
            Method::Reference { samples } => format!("reference-{samples}"),
            Method::EnvMap => "envmap".to_owned(),
            Method::PlanarMirror { scale: 1 } => "planar-mirror".to_owned(),
            Method::PlanarMirror { scale } => format!("planar-mirror-1/{scale}"),
        }
    }

    /// Runs the method's reflection pass over `g` on `pool`, timed.
    ///
    /// # Errors
    /// As [`planar_mirror`].
    pub fn run(
        &self,
        shader: &Shader,
        g: &GBuffer,
        pool: &rayon::ThreadPool,
    ) -> Result<Timed<ReflectionImage>, Error> {
        let t = timed(|| match *self {
            Method::Reference { samples } => Ok(reference(shader, g, samples, pool)),
            Method::EnvMap => Ok(envmap(g, pool)),
            Method::PlanarMirror { scale } => planar_mirror(shader, g, scale, pool),
        });
        t.value.map(|value| Timed { value, ms: t.ms })
    }
}

/// The ray-traced reference reflection of every reflective pixel (see
/// [`Shader::reference_reflection`]; the pixel index seeds the glossy sample
/// rotation).
pub fn reference(
    shader: &Shader,
    g: &GBuffer,
    samples: u32,
    pool: &rayon::ThreadPool,
) -> ReflectionImage {
    reference_where(shader, g, samples, pool, |i| g.is_reflective(i))
}

/// [`reference()`] restricted to the reflective pixels where `mask` is true:
/// the reference time of a method that handles only some pixels is measured
/// on exactly those pixels.
///
/// # Panics
/// If `mask` is shorter than the G-buffer.
pub fn reference_masked(
    shader: &Shader,
    g: &GBuffer,
    samples: u32,
    mask: &[bool],
    pool: &rayon::ThreadPool,
) -> ReflectionImage {
    assert!(
        mask.len() >= g.len(),
        "reference_masked: mask shorter than the G-buffer"
    );
    reference_where(shader, g, samples, pool, |i| mask[i] && g.is_reflective(i))
}

fn reference_where(
    shader: &Shader,
    g: &GBuffer,
    samples: u32,
    pool: &rayon::ThreadPool,
    select: impl Fn(usize) -> bool + Sync,
) -> ReflectionImage {
    let mut out = ReflectionImage::empty(g.width(), g.height());
    out.fill(pool, select, |i| {
        let s = g.surface(i).expect("reflective pixels are hits");
        let view = -g.primary_ray(i).dir;
        shader.reference_reflection(&s, view, g.roughness[i], samples, i as u32)
    });
    out
}

/// The environment map in pixel `i`'s mirror direction (the fallback of a
/// reflection nothing answered).
pub fn mirror_env(g: &GBuffer, i: usize) -> Vec3 {
    let view = -g.primary_ray(i).dir;
    env_map(reflection_dir(view, g.normal[i], g.geo_normal[i]))
}

/// The environment map in the mirror direction of every reflective pixel:
/// no visibility at all.
pub fn envmap(g: &GBuffer, pool: &rayon::ThreadPool) -> ReflectionImage {
    let mut out = ReflectionImage::empty(g.width(), g.height());
    out.fill(pool, |i| g.is_reflective(i), |i| mirror_env(g, i));
    out
}

/// Planar reflections through refl-core's planar pass
/// ([`refl_core::PlanarPass`]): for each planar reflector object with a
/// perfect-mirror material, the pass's setup (the mirror plane oriented
/// toward the eye, the mirrored camera at `1 / scale` of the resolution,
/// the pixels the plane covers among the object's, by the object-id image,
/// and the render's scissor) drives the rasterizer ([`rasterize`], the
/// plane as clip plane, the reflector itself excluded); nothing is
/// rasterized for a mirror that covers no pixel. The pass's resolve then
/// says, per covered pixel, which texel of the mirrored render answers it
/// (the one its reflected ray crosses) or that the render has nothing
/// there; the pixel shades that texel's primitive intersected with its own
/// reflected ray (one-bounce rule), or the environment. Only covered pixels
/// are handled.
///
/// With `scale = 1` this is exact, pixel for pixel. With `scale > 1` the
/// mirrored image is rasterized at `ceil(w / scale) x ceil(h / scale)` (the
/// half- and quarter-resolution planar reflections engines ship) and each
/// full-resolution pixel reshades the primitive of the low-resolution
/// texel holding its reflection, with its own full-resolution ray: exact
/// inside surfaces, wrong only where a silhouette crosses the coarse pixel
/// (the pass's visibility rule; a host with only a color render gets the
/// pass's depth-guided bilinear color instead).
///
/// # Errors
/// The planar pass's and the rasterizer's image errors (a G-buffer whose
/// buffers do not match its camera; never for a rendered one),
/// [`refl_core::try_mirrored_camera`]'s error for a plane that produces a
/// non-finite camera; [`Error::InvalidArgument`] for `scale == 0`.
pub fn planar_mirror(
    shader: &Shader,
    g: &GBuffer,
    scale: u32,
    pool: &rayon::ThreadPool,
) -> Result<ReflectionImage, Error> {
    planar_mirror_of(shader, g, scale, &|_| true, pool)
}

/// [`planar_mirror`] for the planar mirrors whose object id `objects`
/// accepts (the planner's choice per reflector); the others are not
/// rendered and their pixels not handled.
///
/// # Errors
/// As [`planar_mirror`].
pub fn planar_mirror_of(
    shader: &Shader,
    g: &GBuffer,
    scale: u32,
    objects: &dyn Fn(u32) -> bool,
    pool: &rayon::ThreadPool,
) -> Result<ReflectionImage, Error> {
    planar_mirror_bounces(shader, g, scale, 1, objects, pool)
}

/// [`planar_mirror_of`] following perfect planar mirrors for `bounces`
/// reflections (1 or 2): with 2, a pixel whose mirrored render shows
/// another perfect planar mirror `M2` takes that mirror's direct term and
/// its own reflection composited as [`Shader::trace_reflection_bounces`]
/// composites them (`direct (1 - specular) + reflection specular`), the
/// reflection read from a second render through the twice-mirrored camera
/// (the mirrored camera mirrored about `M2`, clipped to `M2`'s side facing
/// the first mirrored eye, without `M2`): for planar mirrors the twice
/// reflected ray of a pixel is that camera's primary ray through the same
/// pixel, so at `scale = 1` the second bounce is exact pixel for pixel, as
/// the first is. The third hit shows its direct term (the two-bounce
/// reference's rule). One extra render per pair of facing mirrors that
/// see each other.
///
/// # Errors
/// As [`planar_mirror`]; [`Error::InvalidArgument`] for `bounces` not 1
/// or 2, or 2 bounces with `scale != 1`.
pub fn planar_mirror_bounces(
    shader: &Shader,
    g: &GBuffer,
    scale: u32,
    bounces: u32,
    objects: &dyn Fn(u32) -> bool,
    pool: &rayon::ThreadPool,
) -> Result<ReflectionImage, Error> {
    if scale == 0 || !(1..=2).contains(&bounces) || (bounces == 2 && scale != 1) {
        return Err(Error::InvalidArgument);
    }
    let scene = shader.scene;
    let (w, h) = (g.width(), g.height());
    let mut out = ReflectionImage::empty(w, h);
    // The G-buffer as the pass reads it: linear depth (+inf background),
    // world normals, object ids.
    let normals: Vec<[f32; 3]> =
        pool.install(|| g.normal.par_iter().map(|n| n.to_array()).collect());
    let depth = DepthImage::try_new(
        ImageView::try_new(&g.depth, w, h, w)?,
        g.camera,
        DepthConvention::Linear,
    )?;
    let gbuffer = CoreGBuffer::try_new(
        depth,
        ImageView::try_new(&normals, w, h, w)?,
        NormalSpace::World,
    )?;
    let ids = ImageView::try_new(&g.object, w, h, w)?;
    let options = PlanarOptions {
        scale,
        // The CPU rasterizer clips with the plane itself.
        oblique: false,
        ..PlanarOptions::default()
    };
    let mut texels = vec![PlanarTexel::default(); g.len()];
    // Per object id, the rows `[first, last + 1)` of its pixels.
    let mut object_rows: Vec<Option<(u32, u32)>> = vec![None; scene.objects.len()];
    for (i, &o) in g.object.iter().enumerate() {
        if let Some(r) = object_rows.get_mut(o as usize) {
            let y = (i / w as usize) as u32;
            let (a, b) = r.get_or_insert((y, y + 1));
            *a = (*a).min(y);
            *b = (*b).max(y + 1);
        }
    }
    for (id, object) in scene.objects.iter().enumerate() {
        let id = id as u32;
        let Some(plane) = object.planar else {
            continue;
        };
        if !scene.materials[object.material as usize].is_mirror() || !objects(id) {
            continue;
        }
        // Rows holding the object's pixels (the pass covers no other).
        let Some(rows) = object_rows[id as usize] else {
            continue;
        };
        let pass = PlanarPass::try_new(gbuffer, plane, options)?.try_with_ids(ids, id)?;
        // The coverage of those rows in bands on the pool, merged into the
        // setup.
        let bands: Vec<PlanarStats> = pool.install(|| {
            (rows.0..rows.1)
                .step_by(BAND_ROWS as usize)
                .collect::<Vec<_>>()
                .into_par_iter()
                .map(|y0| {
                    let rows = RowRange::try_new(y0, (y0 + BAND_ROWS).min(rows.1), h)?;
                    pass.try_cover_rows(rows, &mut |_, _, _| {})
                })
                .collect::<Result<_, Error>>()
        })?;
        let covered = bands.iter().map(|b| b.covered).sum();
        let rect = bands
            .iter()
            .fold(PlanarRect::default(), |r, b| r.union(&b.rect));
        let setup = pass.setup(covered, &rect);
        if !setup.covered {
            continue;
        }
        let s = setup.scissor;
        let raster = RasterOptions {
            clip_plane: Some(setup.clip_plane),
            exclude_object: Some(id),
            scissor: Some(PixelRect {
                x0: s.x0,
                y0: s.y0,
                x1: s.x1,
                y1: s.y1,
            }),
        };
        let vis = rasterize(scene, &setup.camera, &raster, pool);
        let (rw, rh) = pass.render_size();
        // The rasterizer's linear depth (+inf where nothing was drawn) is
        // the render's depth in the G-buffer's (linear) convention.
        let render = PlanarRender::try_new(ImageView::try_new(&vis.depth, rw, rh, rw)?, None)?;
        // The resolve of the covered rows only (the texels of other rows
        // may hold an earlier mirror's results: they are not selected).
        let band = BAND_ROWS as usize * w as usize;
        let (y0, y1) = (rect.y0 as usize, rect.y1 as usize);
        pool.install(|| {
            texels[y0 * w as usize..y1 * w as usize]
                .par_chunks_mut(band)
                .enumerate()
                .try_for_each(|(b, chunk)| {
                    let start = rect.y0 + b as u32 * BAND_ROWS;
                    let rows = RowRange::try_new(start, (start + BAND_ROWS).min(rect.y1), h)?;
                    let mut view = ImageViewMut::try_band(chunk, w, h, w, rows)?;
                    pass.try_resolve(&mut view, None, &mut [], &render)
                        .map(|_| ())
                })
        })?;
        let mirrored = pass.mirrored_camera();
        // Second bounces: the other perfect planar mirrors the render
        // shows, each rendered through the twice-mirrored camera.
        let mut second: Vec<(u32, refl_core::Camera, crate::raster::VisBuffer)> = Vec::new();
        if bounces == 2 {
            let mut seen = vec![false; scene.objects.len()];
            let first = rect.y0 as usize * w as usize;
            for t in &texels[first..rect.y1 as usize * w as usize] {
                if t.status == PlanarStatus::Hit {
                    let prim = vis.prim[t.texel[1] as usize * rw as usize + t.texel[0] as usize];
                    if prim != NONE {
                        seen[scene.tri_object[prim as usize] as usize] = true;
                    }
                }
            }
            for (m2, o2) in scene.objects.iter().enumerate() {
                let (Some(p2), true) = (o2.planar, seen[m2]) else {
                    continue;
                };
                if m2 as u32 == id || !scene.materials[o2.material as usize].is_mirror() {
                    continue;
                }
                let cam2 = refl_core::try_mirrored_camera(mirrored, &p2)?;
                // Keep M2's side facing the first mirrored eye.
                let (e1, n) = (mirrored.eye(), p2.normal());
                let d = p2.signed_distance(e1);
                let toward = if d >= 0.0 { n } else { -n };
                let clip = refl_core::Plane::try_from_point_normal(e1 - n * d, toward)?;
                let raster2 = RasterOptions {
                    clip_plane: Some(clip),
                    exclude_object: Some(m2 as u32),
                    scissor: raster.scissor,
                };
                second.push((m2 as u32, cam2, rasterize(scene, &cam2, &raster2, pool)));
            }
        }
        let texels = &texels;
        out.fill(
            pool,
            |i| (y0..y1).contains(&(i / w as usize)) && texels[i].status.is_covered(),
            |i| {
                let (x, y) = g.pixel(i);
                let ray = mirrored.primary_ray(pixel_center(x, y));
                let t = texels[i];
                let prim = match t.status {
                    PlanarStatus::Hit => {
                        vis.prim[t.texel[1] as usize * rw as usize + t.texel[0] as usize]
                    }
                    _ => NONE,
                };
                let hit = if prim == NONE {
                    None
                } else {
                    ray_triangle_plane(&scene.tris[prim as usize], prim, ray.origin, ray.dir)
                };
                let Some(hit) = hit else {
                    return env_map(ray.dir);
                };
                let m2 = scene.tri_object[hit.prim as usize];
                let Some((_, cam2, vis2)) = second.iter().find(|(o, _, _)| *o == m2) else {
                    return shader.shade_reflection_hit(ray.origin, ray.dir, &hit);
                };
                // The second bounce off M2 (the two-bounce reference's
                // composite), read at the same pixel of M2's render.
                let s2 = crate::shade::Surface::at_hit(scene, ray.origin, ray.dir, &hit);
                let spec = scene.materials[s2.material as usize].specular;
                let ray2 = cam2.primary_ray(pixel_center(x, y));
                let prim2 = vis2.prim[i];
                let hit2 = if prim2 == NONE {
                    None
                } else {
                    ray_triangle_plane(&scene.tris[prim2 as usize], prim2, ray2.origin, ray2.dir)
                };
                let reflected = match hit2 {
                    Some(h) => shader.shade_reflection_hit(ray2.origin, ray2.dir, &h),
                    None => env_map(ray2.dir),
                };
                shader.direct(&s2) * (1.0 - spec) + reflected * spec
            },
        );
    }
    Ok(out)
}

/// Direct shading ([`Shader::direct`]) of every pixel of `g`; background
/// pixels get the environment along their primary ray.
pub fn direct_image(shader: &Shader, g: &GBuffer, pool: &rayon::ThreadPool) -> Vec<Vec3> {
    let w = g.width() as usize;
    let mut out = vec![Vec3::ZERO; g.len()];
    pool.install(|| {
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, c) in row.iter_mut().enumerate() {
                let i = y * w + x;
                *c = match g.surface(i) {
                    Some(s) => shader.direct(&s),
                    None => env_map(g.primary_ray(i).dir),
                };
            }
        });
    });
    out
}

/// The final image: `(1 - specular) * direct + specular * reflection` where
/// `reflection` handles the pixel, `direct` elsewhere (so a method's
/// unhandled reflective pixels show their diffuse part only).
pub fn composite(g: &GBuffer, direct: &[Vec3], reflection: &ReflectionImage) -> Vec<Vec3> {
    (0..g.len())
        .map(|i| {
            if reflection.handled[i] {
                let s = g.specular[i];
                direct[i] * (1.0 - s) + reflection.rgb[i] * s
            } else {
                direct[i]
            }
        })
        .collect()
}

/// One linear channel in `[0, 1]` (clamped) to an 8-bit sRGB value.
pub fn srgb8(c: f32) -> u8 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

/// A linear RGB color to 8-bit sRGB (see the module docs).
pub fn to_srgb8(c: Vec3) -> [u8; 3] {
    [srgb8(c.x), srgb8(c.y), srgb8(c.z)]
}

/// Writes a linear RGB image as an 8-bit sRGB PNG.
///
/// # Errors
/// The encoder's or the file system's error; a buffer that does not hold
/// `width * height` pixels is an encoding error.
pub fn save_png(path: &Path, width: u32, height: u32, rgb: &[Vec3]) -> image::ImageResult<()> {
    let bytes: Vec<u8> = rgb.iter().flat_map(|&c| to_srgb8(c)).collect();
    image::save_buffer(path, &bytes, width, height, image::ExtendedColorType::Rgb8)
}

/// The difference of two images over a pixel mask, on 8-bit sRGB values
/// (definitions in the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct ImageError {
    /// Pixels compared (mask size).
    pub pixels: usize,
    /// Mean absolute difference per channel, 0..255 scale.
    pub mean_abs: f64,
    /// Peak signal-to-noise ratio in dB; `+inf` for identical images.
    pub psnr: f64,
    /// Largest channel difference.
    pub max_abs: u8,
    /// `histogram[d]` = pixels whose largest channel difference is `d`.
    histogram: [u64; 256],
}

impl ImageError {
    /// Fraction of the compared pixels whose largest channel difference
    /// exceeds `levels` (0 when no pixel was compared).
    pub fn share_over(&self, levels: u8) -> f64 {
        if self.pixels == 0 {
            return 0.0;
        }
        let over: u64 = self.histogram[levels as usize + 1..].iter().sum();
        over as f64 / self.pixels as f64
    }

    /// [`ImageError::share_over`] at the visible threshold of 8 levels.
    pub fn share_over_8(&self) -> f64 {
        self.share_over(8)
    }
}

/// Compares `a` and `b` (linear RGB, same size) over the pixels where
/// `mask` is true. With an empty mask the result has `pixels == 0`, zero
/// differences and infinite PSNR.
///
/// # Panics
/// If the three slices differ in length.
pub fn compare(a: &[Vec3], b: &[Vec3], mask: &[bool]) -> ImageError {
    assert!(
        a.len() == b.len() && a.len() == mask.len(),
        "compare: images and mask must have the same length"
    );
    let mut histogram = [0u64; 256];
    let (mut pixels, mut sum, mut sum_sq) = (0usize, 0u64, 0u64);
    for i in (0..a.len()).filter(|&i| mask[i]) {
        let (qa, qb) = (to_srgb8(a[i]), to_srgb8(b[i]));
        let mut largest = 0u8;
        for c in 0..3 {
            let d = qa[c].abs_diff(qb[c]);
            sum += u64::from(d);
            sum_sq += u64::from(d) * u64::from(d);
            largest = largest.max(d);
        }
        histogram[largest as usize] += 1;
        pixels += 1;
    }
    let channels = (3 * pixels).max(1) as f64;
    let mse = sum_sq as f64 / channels;
    ImageError {
        pixels,
        mean_abs: sum as f64 / channels,
        psnr: if mse == 0.0 {
            f64::INFINITY
        } else {
            10.0 * (255.0f64 * 255.0 / mse).log10()
        },
        max_abs: histogram.iter().rposition(|&n| n > 0).unwrap_or(0) as u8,
        histogram,
    }
}
