//! Finalization of a cluster (seed 003 Sec. 3.4, glossy bundles of
//! Sec. 3.5): each pixel's reflected ray, or its lobe of rays, stepped
//! through the cluster's depth image, hits colored from its color image,
//! misses handed to the host's environment.

use super::camera::reflected;
use super::{validate_pixels, ClusterCamera, ClusterInput, Surfaces};
use crate::step::{try_step, StepOptions};
use crate::trace::{refine_hit, REFINE_CONTINUITY};
use crate::{DepthImage, Error, ImageView, MirrorPass, Miss, Ray, Thickness, Trace};
use glam::{Vec2, Vec3};

/// Most rays per pixel of a [`Lobe`] (the seed uses 8 to 49).
pub const MAX_LOBE_RAYS: u32 = 64;

/// The reflected rays of one pixel (seed 003 Sec. 3.5 item 3: "the
/// reflected rays sample ... a cone with apex at the surface point and with
/// an axis defined by the reflected ray"; the blend `G(d_i, p.g)` is the
/// application's BRDF, here a Phong lobe). `repr(C)` (a `u32` and two
/// `f32`), so that a C host's array of lobes is read in place.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Lobe {
    /// Rays per pixel: 1 traces the mirror direction only; `2..=64` sample
    /// the lobe (seed: 8..49).
    pub rays: u32,
    /// Phong exponent `n` of the lobe `cos^n` around the mirror direction
    /// (ignored for one ray).
    pub exponent: f32,
    /// Half-angle (radians) the lobe is truncated to: directions are drawn
    /// from `cos^n` restricted to `theta <= max_angle` (so that the cluster
    /// camera's frame, widened by the same angle, holds them). Use
    /// [`try_lobe_angle`] for the angle holding a share of the lobe's energy.
    pub max_angle: f32,
}

impl Lobe {
    /// One mirror ray per pixel.
    pub const MIRROR: Lobe = Lobe {
        rays: 1,
        exponent: 0.0,
        max_angle: 0.0,
    };

    pub(super) fn validate(&self) -> Result<(), Error> {
        if self.rays == 0 || self.rays > MAX_LOBE_RAYS {
            return Err(Error::InvalidArgument);
        }
        if self.rays > 1
            && !(self.exponent >= 0.0
                && self.exponent.is_finite()
                && self.max_angle > 0.0
                && self.max_angle < 1.5)
        {
            return Err(Error::InvalidArgument);
        }
        Ok(())
    }
}

/// The half-angle of the Phong lobe `cos^n` that holds the share
/// `energy` of its samples ([`crate::lobe::try_phong_lobe_angle`], here
/// also refusing an infinite exponent: a cluster lobe of several rays has a
/// finite one).
///
/// # Errors
/// [`Error::InvalidArgument`] for a negative or non-finite exponent or an
/// `energy` outside `(0, 1)`.
pub fn try_lobe_angle(exponent: f32, energy: f32) -> Result<f32, Error> {
    if !exponent.is_finite() {
        return Err(Error::InvalidArgument);
    }
    crate::lobe::try_phong_lobe_angle(exponent, energy)
}

/// What [`try_finalize_cluster`] needs besides the cluster's pixels, its
/// camera and its images: the depth image's thickness and how to trace
/// and weight each pixel's rays. A bundle of per-call inputs (it holds a
/// borrowed back-face image), not settings with defaults.
#[derive(Clone, Copy, Debug)]
pub struct FinalizeInput<'a> {
    /// Surface thickness of the depth image (as [`try_step`]).
    pub thickness: Thickness<'a>,
    /// Stepping options.
    pub step: StepOptions,
    /// Refine hits to sub-texel accuracy ([`refine_hit`]).
    pub refine: bool,
    /// The rays per pixel.
    pub lobe: Lobe,
    /// Glossy fade (Sec. 3.5 item 2): a hit's weight falls linearly from 1
    /// on the image plane to 0 at the far plane; the missing weight is left
    /// to the host (its diffuse color).
    pub fade: bool,
    /// Rotates each pixel's lobe samples (hashed with the pixel index).
    pub seed: u32,
    /// Seed 003 Sec. 4.2.2's cheaper glossy reflection: a pixel whose lobe
    /// samples several rays traces its mirror ray alone and takes the
    /// lobe-weighted mean of the color image around the hit
    /// ([`GLOSSY_NEIGHBORHOOD`]) instead of tracing [`Lobe::rays`] rays.
    /// No effect on mirror lobes.
    pub single_ray: bool,
}

/// Samples per side of the neighborhood grid of the single-ray glossy
/// reflection ([`FinalizeInput::single_ray`]): at most 7 x 7 = 49 texels
/// (the seed's largest ray count) spread over the lobe's footprint, one
/// texel apart where the footprint is smaller.
pub const GLOSSY_NEIGHBORHOOD: u32 = 7;

/// The reflection of one cluster pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ClusterShade {
    /// Sum of the hit colors times their weights, over the traced rays:
    /// the reflection is `rgb + env_weight * env(env_dir) + (1 - hit_weight
    /// - env_weight) * diffuse`.
    pub rgb: Vec3,
    /// Sum of the hit weights over the traced rays (1 per hit without fade).
    pub hit_weight: f32,
    /// Share of the traced rays that found nothing in the depth image: the
    /// host adds its environment there (the pixel fell back if `> 0`).
    pub env_weight: f32,
    /// The normalized mean direction of the rays that fell back (the mirror
    /// direction if none did).
    pub env_dir: Vec3,
    /// The mirror direction of the pixel.
    pub mirror_dir: Vec3,
    /// Rays traced (lobe samples above the surface, or the mirror ray).
    pub rays: u32,
    /// Rays that hit.
    pub hits: u32,
    /// Depth texels read, summed over the rays.
    pub fetches: u32,
    /// Steps, summed over the rays.
    pub steps: u32,
    /// Rays answered by the reflector itself (seed 003 Sec. 4.4, the
    /// cluster pass's `second_intersection`): their color, within `rgb`
    /// and counted in `hits`, is the reflector's diffuse color where the
    /// ray meets it again.
    pub self_hits: u32,
}

/// Direction `k` of `lobe` around the unit `axis` for a pixel with sample
/// rotation `rot`: Hammersley points, rotated, through the inverse CDF of
/// the truncated Phong lobe ([`crate::lobe::sample_truncated_phong_lobe`]).
fn lobe_dir(lobe: &Lobe, axis: Vec3, k: u32, rot: Vec2) -> Vec3 {
    let xi = crate::lobe::hammersley(k, lobe.rays) + rot;
    let xi = xi - xi.floor();
    crate::lobe::sample_truncated_phong_lobe(axis, lobe.exponent, lobe.max_angle, xi)
}

/// The color at a hit: bilinear between the 2x2 texel centers around
/// `pixel`, using only texels whose depth continues the hit texel's surface
/// (within [`REFINE_CONTINUITY`] relative), renormalized.
fn sample_color(depth: &DepthImage<'_>, color: &ImageView<'_, [f32; 3]>, pixel: Vec2) -> Vec3 {
    let (w, h) = (depth.width(), depth.height());
    let hx = (pixel.x as u32).min(w - 1);
    let hy = (pixel.y as u32).min(h - 1);
    let z0 = depth.linear_at(hx, hy).unwrap_or(f32::NAN);
    let base = color.get(hx, hy).map_or(Vec3::ZERO, Vec3::from_array);
    if !(z0 > 0.0 && z0.is_finite()) {
        return base;
    }
    let p = pixel - Vec2::splat(0.5);
    let (fx, fy) = (libm::floorf(p.x), libm::floorf(p.y));
    let (ax, ay) = (p.x - fx, p.y - fy);
    let (mut sum, mut wsum) = (Vec3::ZERO, 0.0f32);
    for (dx, dy, wt) in [
        (0i64, 0i64, (1.0 - ax) * (1.0 - ay)),
        (1, 0, ax * (1.0 - ay)),
        (0, 1, (1.0 - ax) * ay),
        (1, 1, ax * ay),
    ] {
        let (x, y) = (fx as i64 + dx, fy as i64 + dy);
        if x < 0 || y < 0 || x >= i64::from(w) || y >= i64::from(h) || !(wt > 0.0) {
            continue;
        }
        let (x, y) = (x as u32, y as u32);
        let Some(z) = depth.linear_at(x, y) else {
            continue;
        };
        if !((z - z0).abs() <= REFINE_CONTINUITY * z0) {
            continue;
        }
        if let Some(c) = color.get(x, y) {
            sum += Vec3::from_array(c) * wt;
            wsum += wt;
        }
    }
    if wsum > 0.0 {
        sum / wsum
    } else {
        base
    }
}

fn validate_thickness(depth: &DepthImage<'_>, t: &Thickness<'_>) -> Result<(), Error> {
    match t {
        Thickness::Constant(c) if !(*c >= 0.0) => Err(Error::InvalidArgument),
        Thickness::BackFaces(v) if v.width() != depth.width() || v.height() != depth.height() => {
            Err(Error::InvalidArgument)
        }
        _ => Ok(()),
    }
}

/// Finalizes the reflection of the pixels `pixels` of one cluster (seed 003
/// Sec. 3.1 step 3c, Sec. 3.4, Sec. 3.5): for each pixel, the mirror ray
/// from its surface point (or [`Lobe::rays`] lobe samples above its
/// surface) is traced through the cluster's depth image `depth` (rendered
/// through `cam.camera`, any [`crate::DepthConvention`]) with the stepping
/// kernel [`try_step`], ending at the far plane `D` of the cluster camera.
/// For a planar cluster the mirror ray's line passes through the camera eye
/// and projects to one texel: one step, one fetch (Sec. 4.3). A hit takes
/// the bilinear color of `color` (same size as `depth`) over the texels
/// continuing the hit surface; a miss (left the frame, passed behind
/// geometry, reached the far plane) is a fallback ray whose direction goes
/// to [`ClusterShade::env_dir`]. `out[k]` is written for `pixels[k]`;
/// `out` holds [`ClusterShade`]s or any type made from one
/// (`From<ClusterShade>`, a host's or the C ABI's own record).
/// Lobe samples below the pixel's surface (normal) are not traced; if none
/// is above, the mirror ray is traced alone.
///
/// Returns the number of pixels that fell back (at least one ray missed).
///
/// # Errors
/// * [`Error::InsufficientSize`]: `out.len() < pixels.len()`.
/// * [`Error::InvalidArgument`]: a non-finite `eye`, an invalid lobe,
///   thickness or stride, a camera whose centroid, unit normal or far
///   distance is not finite (or not positive), a `color` image of another size than `depth`, or
///   a listed pixel outside the input or with a non-finite position or a
///   non-unit normal (as [`try_cluster_camera`](super::try_cluster_camera)).
///
/// `out` is untouched on error.
///
/// # Panics
/// Never.
#[allow(clippy::too_many_arguments)]
pub fn try_finalize_cluster<O: From<ClusterShade>>(
    out: &mut [O],
    input: &ClusterInput<'_>,
    pixels: &[u32],
    eye: Vec3,
    cam: &ClusterCamera,
    depth: &DepthImage<'_>,
    color: &ImageView<'_, [f32; 3]>,
    finalize: &FinalizeInput<'_>,
) -> Result<u32, Error> {
    if out.len() < pixels.len() {
        return Err(Error::InsufficientSize);
    }
    input.validate_sizes()?;
    check_finalize(input, pixels, eye, cam, depth, color, finalize)?;
    let mut fallbacks = 0u32;
    for (o, &p) in out.iter_mut().zip(pixels) {
        let (shade, _) = finalize_pixel(input, p, eye, cam, depth, color, finalize, None);
        if shade.env_weight > 0.0 {
            fallbacks += 1;
        }
        *o = shade.into();
    }
    Ok(fallbacks)
}

/// The checks of [`try_finalize_cluster`] after the output length and the
/// input's sizes (its `# Errors`), over any [`Surfaces`].
pub(crate) fn check_finalize(
    input: &impl Surfaces,
    pixels: &[u32],
    eye: Vec3,
    cam: &ClusterCamera,
    depth: &DepthImage<'_>,
    color: &ImageView<'_, [f32; 3]>,
    finalize: &FinalizeInput<'_>,
) -> Result<(), Error> {
    if !eye.is_finite() || color.width() != depth.width() || color.height() != depth.height() {
        return Err(Error::InvalidArgument);
    }
    finalize.lobe.validate()?;
    validate_thickness(depth, &finalize.thickness)?;
    if finalize.step.stride == 0 {
        return Err(Error::InvalidArgument);
    }
    validate_pixels(input, pixels)?;
    let (pc, nc, d_far) = (cam.centroid, cam.normal, cam.far_distance);
    if !(pc.is_finite()
        && nc.is_finite()
        && (nc.length_squared() - 1.0).abs() <= 1e-3
        && d_far > 0.0
        && d_far.is_finite())
    {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

/// Why a ray of a cluster pixel found nothing in the depth image, when the
/// image cannot answer it: it left the image, passed behind geometry, ran
/// out of steps, or had no usable projection (the kernel refused it). A
/// ray that reached the far plane `D` in front of every surface (or
/// started beyond it) is answered: nothing lies within `D` there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Unanswered {
    /// [`Miss::LeftImage`].
    LeftImage,
    /// [`Miss::BehindGeometry`].
    BehindGeometry,
    /// [`Miss::OutOfSteps`].
    OutOfSteps,
    /// [`Miss::DegenerateProjection`], or a ray the kernel refused.
    NoProjection,
}

/// The second intersection of a concave cluster's rays with its reflector
/// (seed 003 Sec. 4.4: "intersect reflected rays with the cluster itself
/// to detect a possible second intersection. When such a second
/// intersection occurs, the ray color is set to the diffuse component of
/// the cluster sample"). Ours tests the cluster's whole object, as the
/// issue puts it ("the second intersection with the reflector"): clusters
/// gather similar normals, so a ray's second intersection is mostly on
/// another cluster of the same reflector (measured on a mirror bowl in
/// `tests/cluster_concave.rs`). The reflector is the part of the output
/// view's depth image its pixels cover, so a ray meets it where stepping
/// through that depth image ([`try_step`]) hits one of the object's pixels
/// from its front: the mirror pass's stepping of the output view, limited
/// to the reflector.
pub(crate) struct SelfHits<'p, 'a> {
    /// The mirror pass over the output view (its G-buffer, start rule,
    /// thickness and hidden-hit test).
    pub mirror: &'p MirrorPass<'a>,
    /// The object id of every output pixel.
    pub ids: &'p ImageView<'a, u32>,
    /// The reflector's object id.
    pub object: u32,
    /// The diffuse component of every output pixel.
    pub diffuse: &'p ImageView<'a, [f32; 3]>,
}

impl SelfHits<'_, '_> {
    /// The diffuse color of the reflector's pixel `ray` meets first within
    /// `t_max`, visible and from its front, with the ray parameter there.
    fn trace(&self, input: &impl Surfaces, ray: &Ray, t_max: f32) -> Option<([f32; 3], f32)> {
        let hit = self.mirror.trace_visible(ray, t_max)?;
        let g = self.mirror.gbuffer();
        let (x, y) = (hit.pixel.x as u32, hit.pixel.y as u32);
        let (x, y) = (x.min(g.width() - 1), y.min(g.height() - 1));
        if self.ids.get(x, y) != Some(self.object) {
            return None;
        }
        // Its front: the surface faces the ray (normals face the eye).
        let (_, n) = input.at(y * g.width() + x)?;
        if !(n.dot(ray.dir) < 0.0) {
            return None;
        }
        Some((self.diffuse.get(x, y)?, hit.t))
    }
}

/// Seed 003 Sec. 4.2.2's cheaper glossy reflection ("intersecting a single
/// ray with the cluster depth image and averaging samples in a
/// neighborhood centered at the intersection"): the color of the texels
/// around the mirror ray's hit `hit`, over the lobe's footprint there (a
/// disc of radius `t tan(max_angle)`), each texel's point `q` weighted by
/// the lobe in its direction from the surface point `pos`,
/// `cos^n(angle(q - pos, axis))` if that angle is within the lobe's
/// `max_angle` and `q` lies above the surface (normal `n`); a grid of at
/// most [`GLOSSY_NEIGHBORHOOD`] texels a side, at least one texel apart.
/// The bilinear hit color if no texel has weight.
fn lobe_neighborhood(
    depth: &DepthImage<'_>,
    color: &ImageView<'_, [f32; 3]>,
    (pos, n, axis): (Vec3, Vec3, Vec3),
    lobe: &Lobe,
    hit: &crate::DepthHit,
) -> Vec3 {
    let cam = depth.camera();
    let (w, h) = (depth.width(), depth.height());
    // Texel size (world units) at the hit's depth, and the footprint's
    // radius in texels.
    let texel = hit.depth * 2.0 * libm::tanf(0.5 * cam.fov_y()) / h as f32;
    let radius = hit.t * libm::tanf(lobe.max_angle) / texel;
    let half = (GLOSSY_NEIGHBORHOOD / 2) as i32;
    if !(radius >= 1.0 && radius.is_finite()) {
        return sample_color(depth, color, hit.pixel);
    }
    let spacing = (radius / half as f32).max(1.0);
    let m = ((radius / spacing) as i32).min(half);
    let cos_max = libm::cosf(lobe.max_angle);
    let (mut sum, mut wsum) = (Vec3::ZERO, 0.0f32);
    for j in -m..=m {
        for i in -m..=m {
            let (dx, dy) = (i as f32 * spacing, j as f32 * spacing);
            if dx * dx + dy * dy > radius * radius {
                continue;
            }
            let px = hit.pixel + Vec2::new(dx, dy);
            if !(px.x >= 0.0 && px.y >= 0.0 && px.x < w as f32 && px.y < h as f32) {
                continue;
            }
            let (x, y) = (px.x as u32, px.y as u32);
            let (Some(z), Some(c)) = (depth.linear_at(x, y), color.get(x, y)) else {
                continue;
            };
            if !(z > 0.0 && z.is_finite()) {
                continue;
            }
            let center = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let q = cam.unproject(center, z, crate::DepthConvention::Linear);
            let Some(d) = (q - pos).try_normalize() else {
                continue;
            };
            let cos = d.dot(axis);
            if !(cos >= cos_max) || !(d.dot(n) > 0.0) {
                continue;
            }
            let wt = libm::powf(cos, lobe.exponent);
            sum += Vec3::from_array(c) * wt;
            wsum += wt;
        }
    }
    if wsum > 0.0 {
        sum / wsum
    } else {
        sample_color(depth, color, hit.pixel)
    }
}

/// One pixel of [`try_finalize_cluster`] (checked by [`check_finalize`]):
/// its shade and, if one of its rays found nothing the depth image can
/// answer, the first such ray's reason. With `self_hits` (a concave
/// cluster of the pass), each ray is also traced against the cluster
/// itself up to its depth-image hit.
#[allow(clippy::too_many_arguments)]
pub(crate) fn finalize_pixel(
    input: &impl Surfaces,
    p: u32,
    eye: Vec3,
    cam: &ClusterCamera,
    depth: &DepthImage<'_>,
    color: &ImageView<'_, [f32; 3]>,
    finalize: &FinalizeInput<'_>,
    self_hits: Option<&SelfHits<'_, '_>>,
) -> (ClusterShade, Option<Unanswered>) {
    let (pc, nc, d_far) = (cam.centroid, cam.normal, cam.far_distance);
    let (pos, n) = input.at(p).unwrap_or((Vec3::ZERO, Vec3::Y));
    let axis = reflected(eye, pos, n).unwrap_or(n);
    let s = (pos - pc).dot(nc);
    let mut shade = ClusterShade {
        mirror_dir: axis,
        ..ClusterShade::default()
    };
    let (mut env_dir, mut misses) = (Vec3::ZERO, 0u32);
    let mut unanswered = None;
    let hash = crate::lobe::pixel_hash;
    let rot = crate::lobe::hash_rotation(hash(p ^ hash(finalize.seed)));
    let glossy = finalize.lobe.rays > 1;
    let single = glossy && finalize.single_ray;
    let mut trace = |dir: Vec3, shade: &mut ClusterShade| {
        shade.rays += 1;
        let dn = dir.dot(nc);
        let t_max = if dn > 1e-6 {
            (d_far - s) / dn
        } else {
            f32::INFINITY
        };
        let ray = Ray { origin: pos, dir };
        let result = if t_max > 0.0 {
            Some(try_step(
                depth,
                finalize.thickness,
                ray,
                t_max,
                finalize.step,
            ))
        } else {
            None
        };
        let why = match &result {
            Some(Ok(Trace::Miss { reason, .. })) => match reason {
                Miss::EndOfRay => None,
                Miss::LeftImage => Some(Unanswered::LeftImage),
                Miss::BehindGeometry => Some(Unanswered::BehindGeometry),
                Miss::OutOfSteps => Some(Unanswered::OutOfSteps),
                Miss::DegenerateProjection => Some(Unanswered::NoProjection),
            },
            Some(Err(_)) => Some(Unanswered::NoProjection),
            _ => None,
        };
        let result = result.and_then(Result::ok);
        let hit = match result {
            Some(Trace::Hit(hit)) => Some(if finalize.refine {
                refine_hit(depth, &ray, t_max, &hit)
            } else {
                hit
            }),
            _ => None,
        };
        if let Some(tr) = result {
            let w = tr.work();
            shade.fetches = shade.fetches.saturating_add(w.fetches);
            shade.steps = shade.steps.saturating_add(w.steps);
        }
        // Sec. 4.4: the reflector itself, nearer than the depth image's hit.
        let own =
            self_hits.and_then(|sh| sh.trace(input, &ray, hit.map_or(f32::INFINITY, |h| h.t)));
        if own.is_none() && unanswered.is_none() {
            unanswered = why;
        }
        let weight = |t: f32| {
            if finalize.fade {
                (1.0 - (s + dn * t) / d_far).clamp(0.0, 1.0)
            } else {
                1.0
            }
        };
        match (own, hit) {
            (Some((c, t)), _) => {
                let wgt = weight(t);
                shade.rgb += Vec3::from_array(c) * wgt;
                shade.hit_weight += wgt;
                shade.hits += 1;
                shade.self_hits += 1;
            }
            (None, Some(hit)) => {
                let wgt = weight(hit.t);
                let c = if single {
                    lobe_neighborhood(depth, color, (pos, n, axis), &finalize.lobe, &hit)
                } else {
                    sample_color(depth, color, hit.pixel)
                };
                shade.rgb += c * wgt;
                shade.hit_weight += wgt;
                shade.hits += 1;
            }
            (None, None) => {
                env_dir += dir;
                misses += 1;
            }
        }
    };
    if glossy && !single {
        for k in 0..finalize.lobe.rays {
            let dir = lobe_dir(&finalize.lobe, axis, k, rot);
            if dir.dot(n) > 0.0 && dir.is_finite() {
                trace(dir, &mut shade);
            }
        }
    }
    if shade.rays == 0 {
        trace(axis, &mut shade);
    }
    let inv = 1.0 / shade.rays as f32;
    shade.rgb *= inv;
    shade.hit_weight *= inv;
    shade.env_weight = misses as f32 * inv;
    shade.env_dir = env_dir.try_normalize().unwrap_or(axis);
    (shade, unanswered)
}
