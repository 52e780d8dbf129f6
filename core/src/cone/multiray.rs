//! The multi-ray alternative to cone tracing (seed 003 Sec. 3.5): several
//! Hi-Z rays over the Phong lobe, weighted and averaged
//! ([`try_multiray`]).

use super::trace::valid_theta;
use super::{cone_ray_direction, phong_lobe_weight, ColorTexel, ConePyramids};
use crate::hiz::{try_trace_hiz_rays, HiZOptions};
use crate::trace::{Thickness, Trace};
use crate::{Error, Ray};
use glam::{Vec2, Vec3};

// ------------------------------------------------------------ multi-ray

/// Settings of [`try_multiray`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultiRayOptions {
    /// Rays per pixel (seed 003 uses 8 to 49).
    pub rays: u32,
    /// Cranley-Patterson rotation of the Hammersley set, in `[0, 1)^2`
    /// (e.g. hashed from the pixel index).
    pub rotation: Vec2,
    /// Hi-Z settings of each ray.
    pub hiz: HiZOptions,
}

impl Default for MultiRayOptions {
    /// 8 rays (the low end of seed 003 Sec. 3.5's 8 to 49), no rotation,
    /// the Hi-Z defaults.
    fn default() -> Self {
        Self {
            rays: 8,
            rotation: Vec2::ZERO,
            hiz: HiZOptions::default(),
        }
    }
}

/// What [`try_multiray`] returns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultiRayResult {
    /// The Phong-weighted mean color.
    pub color: ColorTexel,
    /// Rays traced (not below the surface).
    pub traced: u32,
    /// Rays that hit in screen space.
    pub hits: u32,
    /// Hi-Z iterations summed over the rays.
    pub iterations: u32,
    /// The share of the lobe weight that went to `fallback`: the weights of
    /// the rays that missed over the weights of all traced rays (1 with no
    /// traced ray, when `color` is the axis's fallback). With a black
    /// fallback, `color + fallback_weight * probe` blends a probe the
    /// caller samples once (what `crate::glossy` does).
    pub fallback_weight: f32,
}

/// The multi-ray glossy reflection (seed 003 Sec. 3.5): `options.rays`
/// directions sample the cone of half-angle `theta` around `ray.dir`
/// uniformly ([`cone_ray_direction`] over a rotated Hammersley set), rays
/// below the surface (`dot(dir, normal) <= 0`) are skipped, each other ray
/// is traced as [`crate::try_trace_hiz`] would from `ray.origin` (in
/// batches of up to 32, [`try_trace_hiz_rays`]); a hit reads the
/// level-0 color under the hit pixel, a miss `fallback(dir)`. The result
/// is the mean weighted by [`phong_lobe_weight`] of each direction
/// (`power` the Phong power; with no ray traced, the axis's
/// `fallback`).
///
/// # Errors
/// [`Error::InvalidArgument`] for a ray, `t_max` or thickness rejected by
/// [`crate::try_trace_hiz`], a non-finite normal or rotation, `theta` outside `[0,
/// pi/2)`, a NaN or negative power, or zero rays.
///
/// # Panics
/// Never.
#[allow(clippy::too_many_arguments)]
pub fn try_multiray(
    pyramids: &ConePyramids<'_>,
    thickness: Thickness<'_>,
    ray: Ray,
    normal: Vec3,
    t_max: f32,
    theta: f32,
    power: f32,
    options: &MultiRayOptions,
    mut fallback: impl FnMut(Vec3) -> ColorTexel,
) -> Result<MultiRayResult, Error> {
    if options.rays == 0
        || !valid_theta(theta)
        || !(power >= 0.0)
        || !normal.is_finite()
        || !options.rotation.is_finite()
    {
        return Err(Error::InvalidArgument);
    }
    crate::trace::try_validate_ray(&ray, t_max)?;
    let axis = ray.dir.normalize();
    let hiz = pyramids.hiz();
    let l0 = hiz.layout().level(0).ok_or(Error::InvalidArgument)?;
    // The weighted mean in f64: weights up to (power + 1) / (2 pi) times
    // colors near f32::MAX overflow an f32 sum (fuzz finding F18); the
    // mean of finite colors lies between them and fits f32 again.
    let mut sum = [0.0f64; 3];
    let mut wsum = 0.0f64;
    let mut missed = 0.0f64;
    let (mut traced, mut hits, mut iterations) = (0u32, 0u32, 0u32);
    let n = options.rays;
    // The rays go to the Hi-Z walk in batches of up to `CHUNK` (the AVX2
    // ray stream where the CPU has it: the same traces as one
    // `try_trace_hiz` per ray), then are weighted in ray order.
    const CHUNK: u32 = 32;
    let none = Trace::Miss {
        reason: crate::trace::Miss::DegenerateProjection,
        work: crate::trace::Work::default(),
    };
    let mut first = 0;
    while first < n {
        let end = first.saturating_add(CHUNK).min(n);
        let mut rays = [ray; CHUNK as usize];
        let mut k = 0;
        for i in first..end {
            let xi = crate::lobe::hammersley(i, n) + options.rotation;
            let xi = xi - xi.floor();
            let dir = cone_ray_direction(axis, theta, xi);
            if dir.dot(normal) <= 0.0 {
                continue;
            }
            rays[k] = Ray {
                origin: ray.origin,
                dir,
            };
            k += 1;
        }
        let mut traces = [none; CHUNK as usize];
        try_trace_hiz_rays(
            &mut traces[..k],
            hiz,
            thickness,
            &rays[..k],
            &[t_max],
            &options.hiz,
        )?;
        for (r, trace) in rays[..k].iter().zip(&traces[..k]) {
            let dir = r.dir;
            traced += 1;
            iterations = iterations.saturating_add(trace.work().iterations);
            let w = f64::from(phong_lobe_weight(dir.dot(axis), power));
            let c = match trace.hit() {
                Some(h) => {
                    hits += 1;
                    let x = (h.pixel.x.max(0.0) as usize).min(l0.width as usize - 1);
                    let y = (h.pixel.y.max(0.0) as usize).min(l0.height as usize - 1);
                    pyramids.color[y * l0.width as usize + x]
                }
                None => {
                    missed += w;
                    fallback(dir)
                }
            };
            for k in 0..3 {
                sum[k] += w * f64::from(c[k]);
            }
            wsum += w;
        }
        first = end;
    }
    let (color, fallback_weight) = if wsum > 0.0 {
        (
            [
                (sum[0] / wsum) as f32,
                (sum[1] / wsum) as f32,
                (sum[2] / wsum) as f32,
            ],
            (missed / wsum) as f32,
        )
    } else {
        (fallback(axis), 1.0)
    };
    Ok(MultiRayResult {
        color,
        traced,
        hits,
        iterations,
        fallback_weight,
    })
}
