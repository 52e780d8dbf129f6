//! Screen-space mirror reflections over the primary view's depth buffer
//! with refl-core's mirror pass ([`refl_core::MirrorPass`]: ray
//! generation, the ray start rule, thickness, hit validation and shading
//! all live there; the root package only fills its G-buffer and drives its
//! row bands), and the measurements of that pass against the reference
//! tracer.
//!
//! * [`ReflectionRays`]: the pass's mirror ray of every reflective pixel of
//!   a [`GBuffer`] ([`refl_core::MirrorPass::host_ray`]), with the
//!   reference tracer's hit of the same ray and whether that hit is visible
//!   in the depth buffer. The layered maps and the glossy study trace the
//!   same rays.
//! * [`run`]: the pass over a frame ([`ScreenMethod`] picks the kernel),
//!   timed; [`kernel_work`]: its kernels' work on the same frame.
//! * [`evaluate`]: hit rate, false-hit rate and hit error in pixels of the
//!   pass's validated hits against the reference hits.
//! * [`shade`]: the reflection image of the pass: its color output (the lit
//!   frame's color at the hit texel) on the mirror pixels it hit.
//!
//! Visible (evaluation only, not part of the pass): the reference hit point
//! projects into the image, and the pixel it projects to sees the same
//! object at a linear depth within [`VISIBLE_DEPTH_TOLERANCE`] (relative)
//! of the hit's. Found: a pass hit within [`FOUND_RADIUS_PX`] of the
//! reference hit's projection. A false hit is a hit reported for a ray
//! whose reference hit is not visible (the true surface is elsewhere:
//! occluded, off screen, or nothing at all).

use crate::gbuffer::GBuffer;
use crate::scene::Scene;
use crate::shade::Shader;
use crate::tracer::{Hit, Tracer};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use refl_core::{
    Camera, DepthConvention, DepthImage, ImageView, ImageViewMut, MirrorMethod, MirrorOptions,
    MirrorPass, MirrorStats, MirrorStatus, MirrorTexel, NormalSpace, Ray, RowRange, Work,
};

/// Relative linear-depth tolerance of the visibility test (evaluation).
pub const VISIBLE_DEPTH_TOLERANCE: f32 = 0.02;

/// A pass hit within this many pixels (Euclidean) of the reference hit's
/// projection counts as found.
pub const FOUND_RADIUS_PX: f32 = 1.0;

/// The reflection rays of a G-buffer and their reference hits.
#[derive(Clone, Debug, Default)]
pub struct ReflectionRays {
    /// Pixel index (into the G-buffer) of each ray.
    pub pixel: Vec<u32>,
    /// The pass's ray: origin on the surface (the point the pass
    /// reconstructs from the pixel's depth), the pass's mirror direction.
    /// The reference traces it from `tmin =` [`Shader::epsilon`].
    pub ray: Vec<Ray>,
    /// The reference (obvhs) hit of each ray.
    pub reference: Vec<Option<Hit>>,
    /// Projection `(px, py)` of the reference hit into the primary view,
    /// `None` for a miss or a point behind the eye.
    pub reference_pixel: Vec<Option<Vec2>>,
    /// Whether the reference hit is visible in the depth buffer (see the
    /// module docs).
    pub visible: Vec<bool>,
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

/// The G-buffer images the mirror pass reads besides the depth, as
/// refl-core takes them: world normals (the G-buffer's shading normals),
/// the mask of reflective pixels and, optionally, the lit frame.
///
/// Every reflective pixel is traced, glossy ones included (no roughness
/// image: [`MirrorOptions::max_roughness`] does not apply), so that the
/// pass's rays are [`ReflectionRays`]'s.
pub struct PassImages {
    width: u32,
    height: u32,
    normals: Vec<[f32; 3]>,
    mask: Vec<u8>,
    lit: Option<Vec<[f32; 3]>>,
}

impl PassImages {
    /// The images of `g`, with `lit` (one color per pixel) as the color the
    /// pass shades its hits with.
    pub fn new(g: &GBuffer, lit: Option<&[Vec3]>) -> Self {
        Self {
            width: g.width(),
            height: g.height(),
            normals: g.normal.iter().map(|n| n.to_array()).collect(),
            mask: (0..g.len()).map(|i| u8::from(g.is_reflective(i))).collect(),
            lit: lit.map(|l| l.iter().map(|c| c.to_array()).collect()),
        }
    }

    /// [`PassImages::new`] with the mask narrowed to the reflective pixels
    /// where `mask` is true (the pass traces only those: a planner's
    /// group).
    ///
    /// # Panics
    /// If `mask` is shorter than the G-buffer.
    pub fn with_mask(g: &GBuffer, lit: Option<&[Vec3]>, mask: &[bool]) -> Self {
        assert!(
            mask.len() >= g.len(),
            "PassImages::with_mask: mask shorter than the G-buffer"
        );
        let mut images = Self::new(g, lit);
        for (m, &keep) in images.mask.iter_mut().zip(mask) {
            *m &= u8::from(keep);
        }
        images
    }

    /// The refl-core G-buffer over `depth` (this frame's depth in any
    /// convention).
    ///
    /// # Errors
    /// As [`refl_core::GBuffer::try_new`] (an image of another size than
    /// `depth`'s camera).
    pub fn gbuffer<'a>(
        &'a self,
        depth: DepthImage<'a>,
    ) -> Result<refl_core::GBuffer<'a>, refl_core::Error> {
        let (w, h) = (self.width, self.height);
        let g = refl_core::GBuffer::try_new(
            depth,
            ImageView::try_new(&self.normals, w, h, w)?,
            NormalSpace::World,
        )?
        .try_with_mask(ImageView::try_new(&self.mask, w, h, w)?)?;
        match &self.lit {
            Some(l) => g.try_with_color(ImageView::try_new(l, w, h, w)?),
            None => Ok(g),
        }
    }
}

/// The mirror pass's rays of every reflective pixel of `g` (stepping
/// setup over `g`'s linear depth; the ray of a pixel does not depend on the
/// kernel), traced with the reference tracer. A reflective pixel without a
/// ray (a zero normal) has none here either.
///
/// # Panics
/// Only if `g`'s buffers do not match its camera (never for a rendered
/// one).
pub fn reflection_rays(
    scene: &Scene,
    tracer: &Tracer,
    shader: &Shader,
    g: &GBuffer,
    pool: &rayon::ThreadPool,
) -> ReflectionRays {
    with_linear_pass(g, |pass| trace_rays(scene, tracer, shader, g, pass, pool))
}

/// `f` of the stepping mirror pass with default options over `g`'s linear
/// depth (what [`reflection_rays`] and [`kernel_rays`] take the rays from).
///
/// # Panics
/// Only if `g`'s buffers do not match its camera.
fn with_linear_pass<R>(g: &GBuffer, f: impl FnOnce(&MirrorPass<'_>) -> R) -> R {
    let (w, h) = (g.width(), g.height());
    let images = PassImages::new(g, None);
    let depth = ImageView::try_new(&g.depth, w, h, w)
        .and_then(|v| DepthImage::try_new(v, g.camera, DepthConvention::Linear))
        .expect("G-buffer depth");
    let pass = MirrorPass::try_new(
        images.gbuffer(depth).expect("G-buffer images"),
        MirrorOptions {
            method: MirrorMethod::Step,
            ..MirrorOptions::default()
        },
        None,
    )
    .expect("mirror pass");
    f(&pass)
}

/// The rays of `pass` for the reflective pixels of `g` with their
/// reference hits (see [`reflection_rays`]).
fn trace_rays(
    scene: &Scene,
    tracer: &Tracer,
    shader: &Shader,
    g: &GBuffer,
    pass: &MirrorPass<'_>,
    pool: &rayon::ThreadPool,
) -> ReflectionRays {
    /// One ray's row: (pixel, ray, reference hit, its pixel, visible).
    type RayRow = (u32, Ray, Option<Hit>, Option<Vec2>, bool);
    let rows: Vec<RayRow> = pool.install(|| {
        (0..g.len())
            .into_par_iter()
            .with_min_len(256)
            .filter(|&i| g.is_reflective(i))
            .filter_map(|i| {
                let (x, y) = g.pixel(i);
                // Any status: only the ray is used.
                let r = pass.host_ray(x, y, MirrorStatus::NoProjection)?;
                let ray = Ray {
                    origin: r.origin,
                    dir: r.dir,
                };
                let hit = tracer.trace(ray.origin, ray.dir, shader.epsilon, f32::INFINITY);
                let (px, visible) = match hit {
                    Some(hh) => match g.camera.project(ray.at(hh.t)) {
                        Some(q) => {
                            let px = q.truncate();
                            (Some(px), visible_in(scene, g, hh.prim, px, q.z))
                        }
                        None => (None, false),
                    },
                    None => (None, false),
                };
                Some((i as u32, ray, hit, px, visible))
            })
            .collect()
    });
    let mut out = ReflectionRays::default();
    for (pixel, ray, hit, px, visible) in rows {
        out.pixel.push(pixel);
        out.ray.push(ray);
        out.reference.push(hit);
        out.reference_pixel.push(px);
        out.visible.push(visible);
    }
    out
}

/// The rays the mirror pass hands its kernel for `rays` (of `g`): each
/// pixel's [`refl_core::MirrorRay::kernel_ray`], started by the pass's
/// start rule; pixels whose ray the pass does not trace (it hands them to
/// the host at once) are left out. For benchmarks of the bare kernels on
/// the pass's rays.
///
/// # Panics
/// Only if `g`'s buffers do not match its camera.
pub fn kernel_rays(g: &GBuffer, rays: &ReflectionRays) -> Vec<Ray> {
    with_linear_pass(g, |pass| {
        rays.pixel
            .iter()
            .filter_map(|&i| {
                let (x, y) = g.pixel(i as usize);
                pass.ray(x, y).map(|r| r.kernel_ray())
            })
            .collect()
    })
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

/// Hit statistics of a method's hits (the mirror pass's, or the layered
/// maps' in the report) against the reference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayStats {
    /// Rays traced.
    pub rays: usize,
    /// Rays whose reference hit is visible in the depth buffer.
    pub visible: usize,
    /// Visible rays the method found within [`FOUND_RADIUS_PX`].
    pub found: usize,
    /// Visible rays the method hit somewhere else (farther than
    /// [`FOUND_RADIUS_PX`]).
    pub wrong: usize,
    /// Visible rays the method missed.
    pub missed: usize,
    /// Rays whose reference hit is not visible, for which the method still
    /// reported a hit.
    pub false_hits: usize,
    /// Sum over visible rays with a hit of the hit's distance in
    /// pixels to the reference hit's projection.
    pub err_px_sum: f64,
    /// Visible rays with a hit (the count behind `err_px_sum`).
    pub err_px_count: usize,
    /// Total depth fetches (of the kernels: [`kernel_work`]).
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

/// Compares the pass's output `texels` (the whole image, as [`run`] returns
/// it) with the reference hits of `rays`: a validated hit
/// ([`MirrorStatus::Hit`]) is the pass's hit, every other status none.
/// The work columns stay 0 (see [`kernel_work`]).
///
/// # Panics
/// If a ray's pixel is outside `texels`.
pub fn evaluate(rays: &ReflectionRays, texels: &[MirrorTexel]) -> RayStats {
    let mut s = RayStats {
        rays: rays.len(),
        ..RayStats::default()
    };
    for (k, &p) in rays.pixel.iter().enumerate() {
        let t = &texels[p as usize];
        let visible = rays.visible[k];
        s.visible += usize::from(visible);
        match (t.status == MirrorStatus::Hit, visible) {
            (true, true) => {
                let err = rays.reference_pixel[k].map_or(f32::INFINITY, |q| (t.pixel - q).length());
                s.err_px_sum += f64::from(err);
                s.err_px_count += 1;
                if err <= FOUND_RADIUS_PX {
                    s.found += 1;
                } else {
                    s.wrong += 1;
                }
            }
            (false, true) => s.missed += 1,
            (true, false) => s.false_hits += 1,
            (false, false) => {}
        }
    }
    s
}

/// The reflection image of the pass: every mirror pixel (roughness 0) the
/// pass hit takes the pass's color there (`color`, as [`run`] returns it:
/// the lit frame's color at the hit texel); other pixels are not handled
/// (glossy pixels need the cone tracer, the others the host's tracer or a
/// fallback).
pub fn shade(g: &GBuffer, out: &PassRun) -> crate::render::ReflectionImage {
    let mut img = crate::render::ReflectionImage::empty(g.width(), g.height());
    for (i, t) in out.texels.iter().enumerate() {
        if t.status == MirrorStatus::Hit && g.roughness[i] == 0.0 {
            img.rgb[i] = Vec3::from_array(out.color[i]);
            img.handled[i] = true;
        }
    }
    img
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

/// The kernel the mirror pass traces with, and its setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScreenMethod {
    /// Per-pixel stepping ([`refl_core::try_step`], seed 003 Sec. 3.4).
    Step(refl_core::StepOptions),
    /// Hi-Z traversal ([`refl_core::hiz::try_trace_hiz`], seed 004); the
    /// timed pass includes building the pyramid.
    HiZ(refl_core::hiz::HiZOptions),
}

impl ScreenMethod {
    /// The mirror pass's options for this kernel: [`MirrorOptions::default`]
    /// with the kernel, its setting and `refine`.
    pub fn options(&self, refine: bool) -> MirrorOptions {
        let base = MirrorOptions {
            refine,
            ..MirrorOptions::default()
        };
        match *self {
            ScreenMethod::Step(step) => MirrorOptions {
                method: MirrorMethod::Step,
                step,
                ..base
            },
            ScreenMethod::HiZ(hiz) => MirrorOptions {
                method: MirrorMethod::HiZ,
                hiz,
                ..base
            },
        }
    }

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

/// What [`run`] returns: the pass's output over the whole image.
#[derive(Clone, Debug)]
pub struct PassRun {
    /// Every pixel's [`MirrorTexel`], row-major.
    pub texels: Vec<MirrorTexel>,
    /// Every pixel's reflection color (the lit color at a hit, black
    /// elsewhere; all black without a lit image in the [`PassImages`]).
    pub color: Vec<[f32; 3]>,
    /// The counts of every band, summed.
    pub stats: MirrorStats,
}

/// The pass of `method` over `depth` and `images` (one frame), with the
/// Hi-Z pyramid (method [`ScreenMethod::HiZ`]) from `pyramid`'s storage.
pub(crate) fn with_pass<R>(
    method: ScreenMethod,
    refine: bool,
    depth: &DepthImage<'_>,
    images: &PassImages,
    pyramid: &mut [refl_core::HiZTexel],
    pool: &rayon::ThreadPool,
    f: impl FnOnce(&MirrorPass<'_>) -> R,
) -> Result<R, refl_core::Error> {
    let gb = images.gbuffer(*depth)?;
    let hiz = match method {
        ScreenMethod::HiZ(_) => {
            build_hiz(pyramid, depth, pool)?;
            Some(refl_core::HiZ::try_new(
                pyramid,
                *depth.camera(),
                depth.convention(),
            )?)
        }
        ScreenMethod::Step(_) => None,
    };
    let pass = MirrorPass::try_new(gb, method.options(refine), hiz)?;
    Ok(f(&pass))
}

/// Storage of the pyramid of `method` for a `width x height` frame (empty
/// for stepping).
pub(crate) fn pyramid_storage(
    method: ScreenMethod,
    width: u32,
    height: u32,
) -> Result<Vec<refl_core::HiZTexel>, refl_core::Error> {
    Ok(match method {
        ScreenMethod::HiZ(_) => vec![[0.0f32; 2]; refl_core::try_hiz_len(width, height)?],
        ScreenMethod::Step(_) => Vec::new(),
    })
}

/// Runs refl-core's mirror pass ([`ScreenMethod::options`]) over the frame
/// of `depth` and `images` on `pool` in bands of [`PYRAMID_BAND`] rows,
/// timed: Hi-Z's pyramid build, the pass's setup and every band (the
/// output and pyramid buffers are allocated outside the timed part, as an
/// engine keeps them across frames). Pixels the pass hands to the host are
/// only counted (`stats.host_rays`).
///
/// # Errors
/// A refl-core error (buffers that do not match the camera).
pub fn run(
    method: ScreenMethod,
    refine: bool,
    depth: &DepthImage<'_>,
    images: &PassImages,
    pool: &rayon::ThreadPool,
) -> Result<crate::render::Timed<PassRun>, refl_core::Error> {
    let (w, h) = (depth.width(), depth.height());
    let n = w as usize * h as usize;
    let mut texels = vec![MirrorTexel::default(); n];
    let mut color = vec![[0.0f32; 3]; n];
    let mut pyramid = pyramid_storage(method, w, h)?;
    let t = crate::render::timed(|| {
        with_pass(method, refine, depth, images, &mut pyramid, pool, |pass| {
            run_bands(pass, images.lit.is_some(), &mut texels, &mut color, pool)
        })
    });
    let stats = t.value??;
    Ok(crate::render::Timed {
        value: PassRun {
            texels,
            color,
            stats,
        },
        ms: t.ms,
    })
}

/// Runs `pass` over the whole image in bands of [`PYRAMID_BAND`] rows on
/// `pool`, into `texels` and (with `lit`) `color`; the counts summed.
///
/// # Errors
/// A refl-core error (buffers that do not match the pass's camera).
pub(crate) fn run_bands(
    pass: &MirrorPass<'_>,
    lit: bool,
    texels: &mut [MirrorTexel],
    color: &mut [[f32; 3]],
    pool: &rayon::ThreadPool,
) -> Result<MirrorStats, refl_core::Error> {
    let (w, h) = (pass.gbuffer().width(), pass.gbuffer().height());
    let band = PYRAMID_BAND as usize * w as usize;
    pool.install(|| {
        texels
            .par_chunks_mut(band)
            .zip(color.par_chunks_mut(band))
            .enumerate()
            .map(|(k, (t, c))| {
                let y0 = k as u32 * PYRAMID_BAND;
                let rows = RowRange::try_new(y0, (y0 + PYRAMID_BAND).min(h), h)?;
                let mut out = ImageViewMut::try_band(t, w, h, w, rows)?;
                let mut col = ImageViewMut::try_band(c, w, h, w, rows)?;
                pass.try_run(&mut out, lit.then_some(&mut col), &mut [])
            })
            .try_fold(MirrorStats::default, |a, b| Ok(add_stats(a, &b?)))
            .try_reduce(MirrorStats::default, |a, b| Ok(add_stats(a, &b)))
    })
}

/// [`run`] that also collects the pass's list of rays for the host's
/// tracer (issue 15, part 3: the hybrid): each band's [`MirrorPass::try_run`]
/// appends the pixels it cannot answer to its own part of one list of
/// `width * height` entries (a band hands over at most one ray per pixel,
/// so every ray fits); the rays come back in row-major order. Timed like
/// [`run`]; the list is allocated outside the time, as the other buffers.
///
/// # Errors
/// As [`run`].
pub fn run_with_host_rays(
    method: ScreenMethod,
    refine: bool,
    depth: &DepthImage<'_>,
    images: &PassImages,
    pool: &rayon::ThreadPool,
) -> Result<crate::render::Timed<(PassRun, Vec<refl_core::HostRay>)>, refl_core::Error> {
    let (w, h) = (depth.width(), depth.height());
    let n = w as usize * h as usize;
    let mut texels = vec![MirrorTexel::default(); n];
    let mut color = vec![[0.0f32; 3]; n];
    let mut host = vec![refl_core::HostRay::default(); n];
    let mut pyramid = pyramid_storage(method, w, h)?;
    let lit = images.lit.is_some();
    let band = PYRAMID_BAND as usize * w as usize;
    let t = crate::render::timed(|| {
        with_pass(method, refine, depth, images, &mut pyramid, pool, |pass| {
            pool.install(|| {
                texels
                    .par_chunks_mut(band)
                    .zip(color.par_chunks_mut(band))
                    .zip(host.par_chunks_mut(band))
                    .enumerate()
                    .map(|(k, ((t, c), list))| {
                        let y0 = k as u32 * PYRAMID_BAND;
                        let rows = RowRange::try_new(y0, (y0 + PYRAMID_BAND).min(h), h)?;
                        let mut out = ImageViewMut::try_band(t, w, h, w, rows)?;
                        let mut col = ImageViewMut::try_band(c, w, h, w, rows)?;
                        let stats = pass.try_run(&mut out, lit.then_some(&mut col), list)?;
                        Ok((k, stats))
                    })
                    .collect::<Result<Vec<_>, refl_core::Error>>()
            })
        })
    });
    let bands = t.value??;
    let mut stats = MirrorStats::default();
    let mut rays = Vec::new();
    for (k, b) in bands {
        assert_eq!(
            b.host_rays, b.host_rays_written,
            "a band's host list holds one ray per pixel"
        );
        let start = k * band;
        rays.extend_from_slice(&host[start..start + b.host_rays_written as usize]);
        stats = add_stats(stats, &b);
    }
    Ok(crate::render::Timed {
        value: (
            PassRun {
                texels,
                color,
                stats,
            },
            rays,
        ),
        ms: t.ms,
    })
}

/// The sum of two runs' counts.
pub(crate) fn add_stats(a: MirrorStats, b: &MirrorStats) -> MirrorStats {
    MirrorStats {
        traced: a.traced + b.traced,
        hits: a.hits + b.hits,
        sky: a.sky + b.sky,
        host_rays: a.host_rays + b.host_rays,
        host_rays_written: a.host_rays_written + b.host_rays_written,
    }
}

/// The work of the pass's kernel on each ray of `rays` (untimed): what the
/// kernel returns for the pass's ray of the pixel
/// ([`MirrorPass::try_trace_kernel`] of [`MirrorPass::ray`]; the first
/// segment only, before any resume past a hidden hit), summed into
/// `(fetches, steps, iterations)`.
///
/// # Errors
/// As [`run`].
pub fn kernel_work(
    method: ScreenMethod,
    depth: &DepthImage<'_>,
    images: &PassImages,
    rays: &ReflectionRays,
    pool: &rayon::ThreadPool,
) -> Result<(u64, u64, u64), refl_core::Error> {
    let (w, h) = (depth.width(), depth.height());
    let mut pyramid = pyramid_storage(method, w, h)?;
    with_pass(method, false, depth, images, &mut pyramid, pool, |pass| {
        pool.install(|| {
            rays.pixel
                .par_iter()
                .with_min_len(256)
                .map(|&p| {
                    let (x, y) = (p % w, p / w);
                    let work = match pass.ray(x, y).map(|r| pass.try_trace_kernel(&r)) {
                        Some(Ok(t)) => t.work(),
                        Some(Err(e)) => return Err(e),
                        None => Work::default(),
                    };
                    Ok((
                        u64::from(work.fetches),
                        u64::from(work.steps),
                        u64::from(work.iterations),
                    ))
                })
                .try_reduce(|| (0, 0, 0), |a, b| Ok((a.0 + b.0, a.1 + b.1, a.2 + b.2)))
        })
    })?
}

/// What the screen-space methods of one frame share: the reflection rays
/// with their reference hits, the obvhs time on the same rays (all threads
/// and one thread), the pass's G-buffer images and the depth buffers per
/// convention.
pub struct ScreenFrame {
    /// The frame's reflection rays.
    pub rays: ReflectionRays,
    /// obvhs closest-hit time on the rays, `pool`'s threads, ms (median).
    pub obvhs_ms: f64,
    /// The same on one thread, ms (median).
    pub obvhs_ms_1t: f64,
    /// The pass's G-buffer images, lit with the frame's direct light.
    pub images: PassImages,
    depth: Vec<DepthBuffer>,
}

/// Relative surface thickness of the cluster method's depth images
/// ([`crate::cluster`]): a fraction of the scene diameter. (The mirror
/// pass sets its own, relative to each pixel's depth.)
pub const THICKNESS_OF_DIAMETER: f32 = 0.005;

impl ScreenFrame {
    /// Rays, reference hits and obvhs timings (median of `runs`) for `g`;
    /// `lit` is the frame's direct-lit color the pass shades with.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        scene: &Scene,
        tracer: &Tracer,
        shader: &Shader,
        g: &GBuffer,
        lit: &[Vec3],
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
            images: PassImages::new(g, Some(lit)),
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
