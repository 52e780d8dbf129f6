//! Lobe math shared by the glossy methods and the root package's shading:
//! roughness to Phong power, the Phong lobe's inverse CDF in a form that
//! stays accurate for narrow lobes, the cone angle of seed 004, the
//! low-discrepancy points and per-pixel rotations the multi-ray methods
//! sample with, and directions drawn from a lobe or a cone.
//!
//! One implementation of each, used by `crate::cone` (cone angle,
//! multi-ray), `crate::glossy` (per-pixel rotation), `crate::cluster`
//! (the truncated lobe of the cluster pass) and the root package's
//! reference renderer and probes.
//!
//! # The Phong lobe
//! The normalized Phong lobe around a unit axis has the density
//! `p(w) = (n + 1) / (2 pi) cos^n theta` over the hemisphere, so
//! `P(cos theta >= c) = 1 - c^(n + 1)` and the inverse CDF is
//! `cos theta = xi^(1 / (n + 1))` (design.md's erratum to seed 004
//! Eq. 4.1, which prints `cos` for `acos`). For large `n`, `cos theta` is
//! within a few f32 steps of 1, where `acos` and `1 - cos^2` lose every
//! digit; the functions here carry `u = 1 - cos theta =
//! -expm1(ln(xi) / (n + 1))` (exact to rounding) instead and take
//! `theta = 2 asin(sqrt(u / 2))`, `sin theta = sqrt(u (2 - u))`.
//!
//! # Example
//! ```rust
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::lobe::{hammersley, hash_rotation, pixel_hash, sample_phong_lobe};
//! use refl_core::lobe::{try_phong_lobe_angle, try_phong_power_from_roughness};
//!
//! // Roughness 0.3: Phong power 2 / 0.3^4 - 2 = 244.9.
//! let n = try_phong_power_from_roughness(0.3)?;
//! // Half of the lobe's directions lie within this angle of the axis.
//! let half = try_phong_lobe_angle(n, 0.5)?;
//! // 16 directions of the lobe around +Z, rotated per pixel.
//! let rot = hash_rotation(pixel_hash(7));
//! let inside = (0..16)
//!     .map(|i| sample_phong_lobe(Vec3::Z, n, (hammersley(i, 16) + rot).fract()))
//!     .filter(|d| d.z >= half.cos())
//!     .count();
//! assert!((7..=9).contains(&inside));
//! # Ok::<(), refl_core::Error>(())
//! ```

use crate::Error;
use glam::{Vec2, Vec3};

/// The `xi` of seed 004 Eq. 4.1 (hard-coded 0.244 in the seed): the cone
/// of [`try_cone_angle_from_phong`] holds the directions of the lobe
/// whose `cos theta >= 0.244^(1 / (n + 1))`, i.e. `1 - 0.244 = 75.6%` of
/// its samples.
pub const CONE_XI: f32 = 0.244;

/// Phong power at which [`try_cone_angle_from_phong`] starts blending the
/// angle down to 0 (seed 004 Sec. 4.4.5: "any specular power in the range
/// of 1024-2048 should be interpolated down to an angle of 0").
pub const MIRROR_POWER_START: f32 = 1024.0;

/// Phong power at and above which the cone angle is 0 (a mirror).
pub const MIRROR_POWER_END: f32 = 2048.0;

/// `1 - cos theta` of the Phong lobe of power `n` at the CDF value `xi`
/// in `(0, 1]`: `-expm1(ln(xi) / (n + 1))` (see the module docs). `xi = 0`
/// gives 1 (the horizon), `xi = 1` and `n = +inf` give 0 (the axis).
#[inline]
fn one_minus_cos(n: f32, xi: f32) -> f32 {
    if n == f32::INFINITY {
        return 0.0;
    }
    -libm::expm1f(libm::logf(xi) / (n + 1.0))
}

/// The angle `theta` with `cos theta = 1 - u`, as `2 asin(sqrt(u / 2))`.
#[inline]
fn angle_of(u: f32) -> f32 {
    2.0 * libm::asinf(libm::sqrtf((0.5 * u).clamp(0.0, 1.0)))
}

/// The Phong power for a perceptual ("GGX") roughness `r` in `[0, 1]`:
/// `alpha = r^2` (Burley 2012, "Physically-Based Shading at Disney",
/// Sec. 5.4: the artist-facing roughness is squared) and the Beckmann to
/// Phong equivalence `power = 2 / alpha^2 - 2` (Walter et al. 2007,
/// "Microfacet Models for Refraction through Rough Surfaces", Eq. 30),
/// so `power = 2 / r^4 - 2`. `r = 0` gives `+inf` (a mirror), `r = 1`
/// gives 0; 0.25 gives 510, 0.3 gives 244.9. This is also the mapping of
/// the root package's scenes.
///
/// # Errors
/// [`Error::InvalidArgument`] for NaN or `r` outside `[0, 1]`.
pub fn try_phong_power_from_roughness(roughness: f32) -> Result<f32, Error> {
    if !(0.0..=1.0).contains(&roughness) {
        return Err(Error::InvalidArgument);
    }
    if roughness == 0.0 {
        return Ok(f32::INFINITY);
    }
    let a2 = roughness * roughness * roughness * roughness;
    Ok((2.0 / a2 - 2.0).max(0.0))
}

/// The half-angle of the Phong lobe of power `power` that holds the share
/// `energy` of its directions: `P(cos theta >= c) = 1 - c^(n + 1)`, so
/// `theta = acos((1 - energy)^(1 / (n + 1)))` (the inverse CDF of
/// design.md's erratum to seed 004 Eq. 4.1), evaluated as
/// `2 asin(sqrt(u / 2))` with `u = -expm1(ln(1 - energy) / (n + 1))`,
/// which keeps its relative accuracy for narrow lobes where `acos` of a
/// cosine next to 1 does not. A power of `+inf` gives 0.
///
/// # Errors
/// [`Error::InvalidArgument`] for a NaN or negative power, or an `energy`
/// outside `(0, 1)`.
pub fn try_phong_lobe_angle(power: f32, energy: f32) -> Result<f32, Error> {
    if !(power >= 0.0 && energy > 0.0 && energy < 1.0) {
        return Err(Error::InvalidArgument);
    }
    Ok(angle_of(one_minus_cos(power, 1.0 - energy)))
}

/// The cone half-angle for a Phong specular power `power` (seed 004
/// Eq. 4.1, design.md erratum: `theta = acos(xi^(1 / (power + 1)))`, the
/// inverse CDF of the normalized Phong lobe at `xi =` [`CONE_XI`], in the
/// form of [`try_phong_lobe_angle`]). Between [`MIRROR_POWER_START`] and
/// [`MIRROR_POWER_END`] the angle is scaled linearly down to 0; at and
/// above the end (and for `+inf`) it is 0.
///
/// # Errors
/// [`Error::InvalidArgument`] for a NaN or negative power.
pub fn try_cone_angle_from_phong(power: f32) -> Result<f32, Error> {
    if !(power >= 0.0) {
        return Err(Error::InvalidArgument);
    }
    if power >= MIRROR_POWER_END {
        return Ok(0.0);
    }
    let theta = angle_of(one_minus_cos(power, CONE_XI));
    let blend = if power > MIRROR_POWER_START {
        (MIRROR_POWER_END - power) / (MIRROR_POWER_END - MIRROR_POWER_START)
    } else {
        1.0
    };
    Ok(theta * blend)
}

/// The cone half-angle for a perceptual roughness:
/// [`try_cone_angle_from_phong`] of [`try_phong_power_from_roughness`].
///
/// # Errors
/// As [`try_phong_power_from_roughness`].
pub fn try_cone_angle_from_roughness(roughness: f32) -> Result<f32, Error> {
    try_cone_angle_from_phong(try_phong_power_from_roughness(roughness)?)
}

/// The Phong lobe weight `cos^power` of a direction at cosine `cos` from
/// the axis (0 for `cos <= 0`); the multi-ray average of seed 003
/// Sec. 3.5 weights by it.
pub fn phong_lobe_weight(cos: f32, power: f32) -> f32 {
    if cos > 0.0 {
        libm::powf(cos.min(1.0), power)
    } else {
        0.0
    }
}

/// Point `i` of the `n`-point Hammersley set in `[0, 1)^2`:
/// `(i / n, phi_2(i))`, `phi_2` the base-2 radical inverse (the bits of
/// `i` mirrored about the binary point). `n = 0` reads as 1.
#[inline]
pub fn hammersley(i: u32, n: u32) -> Vec2 {
    Vec2::new(
        i as f32 / n.max(1) as f32,
        i.reverse_bits() as f32 * (1.0 / 4_294_967_296.0),
    )
}

/// A 32-bit integer hash (Wellons' "lowbias32"): the per-pixel seed of
/// every sample rotation in refl (the glossy pass hashes the pixel index,
/// the cluster pass the pixel index with its seed).
#[inline]
pub const fn pixel_hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The rotation (Cranley-Patterson shift) in `[0, 1)^2` of a hash: its
/// low and high 16-bit halves over 65536. Added to a Hammersley point
/// modulo 1, it decorrelates neighbouring pixels' sample sets.
#[inline]
pub fn hash_rotation(h: u32) -> Vec2 {
    Vec2::new((h & 0xffff) as f32 / 65_536.0, (h >> 16) as f32 / 65_536.0)
}

/// The unit direction at angle `acos(1 - u)` from the unit `axis` and
/// azimuth `2 pi phi` (`u` in `[0, 2]`).
#[inline]
fn around(axis: Vec3, u: f32, phi: f32) -> Vec3 {
    let cos_t = 1.0 - u;
    let sin_t = libm::sqrtf((u * (2.0 - u)).max(0.0));
    let (s, c) = libm::sincosf(core::f32::consts::TAU * phi);
    let (t, b) = axis.any_orthonormal_pair();
    (axis * cos_t + (t * c + b * s) * sin_t).normalize()
}

/// A direction of the Phong lobe of power `power` around the unit `axis`
/// for the uniform sample `xi` in `[0, 1)^2`: `cos theta = xi.x^(1 /
/// (power + 1))` (the inverse CDF of the module docs, design.md's erratum
/// to seed 004 Eq. 4.1), `phi = 2 pi xi.y`; density `(power + 1) / (2 pi)
/// cos^power theta`. A power of `+inf` gives the axis.
pub fn sample_phong_lobe(axis: Vec3, power: f32, xi: Vec2) -> Vec3 {
    around(axis, one_minus_cos(power, xi.x), xi.y)
}

/// A direction of the Phong lobe of power `power` truncated to the cone of
/// half-angle `max_angle` (in `[0, pi / 2]`) around the unit `axis`: the
/// lobe's inverse CDF over `[cos(max_angle), 1]`, `cos theta = (c^(n+1) +
/// xi.x (1 - c^(n+1)))^(1 / (n + 1))` with `c = cos(max_angle)`, `phi = 2
/// pi xi.y` (the glossy rays of seed 003 Sec. 3.5 item 3, kept within the
/// far plane's reach). `max_angle = pi / 2` is [`sample_phong_lobe`].
pub fn sample_truncated_phong_lobe(axis: Vec3, power: f32, max_angle: f32, xi: Vec2) -> Vec3 {
    if power == f32::INFINITY {
        return axis;
    }
    // y = c^(n+1) + xi.x (1 - c^(n+1)), ln c = log1p(-2 sin^2(max_angle /
    // 2)). Next to 1 (a narrow cone) y itself keeps no digits of 1 - y:
    // carry 1 - y = w (1 - xi.x) with w = 1 - c^(n+1) = -expm1((n + 1) ln
    // c). Far from 1, ln y = ln(e^k + xi.x w) is taken in log space (e^k
    // underflows for a wide cone and a high power, where ln y is still
    // about k).
    let s = libm::sinf(0.5 * max_angle.clamp(0.0, core::f32::consts::FRAC_PI_2));
    let k = (power + 1.0) * libm::log1pf(-2.0 * s * s);
    let w = -libm::expm1f(k);
    let one_minus_y = w * (1.0 - xi.x);
    let ln_y = if one_minus_y < 0.5 {
        libm::log1pf(-one_minus_y)
    } else {
        let b = libm::logf(xi.x * w);
        let (hi, lo) = if k > b { (k, b) } else { (b, k) };
        if lo == f32::NEG_INFINITY {
            hi
        } else {
            hi + libm::log1pf(libm::expf(lo - hi))
        }
    };
    around(axis, -libm::expm1f(ln_y / (power + 1.0)), xi.y)
}

/// Direction `xi` (in `[0, 1)^2`) of the rays sampling the cone of
/// half-angle `theta` around the unit `axis` uniformly in solid angle (seed
/// 003 Sec. 3.5: "the reflected rays sample uniformly a cone"): `cos t = 1 -
/// xi.x (1 - cos theta)`, `phi = 2 pi xi.y`, with `1 - cos theta = 2
/// sin^2(theta / 2)` so that narrow cones keep their width.
pub fn cone_ray_direction(axis: Vec3, theta: f32, xi: Vec2) -> Vec3 {
    let s = libm::sinf(0.5 * theta);
    around(axis, xi.x * 2.0 * s * s, xi.y)
}
