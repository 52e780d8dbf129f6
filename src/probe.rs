//! A roughness-prefiltered environment probe: the cone tracer's fallback for
//! the part of a glossy lobe the screen cannot answer (seed 004 Sec. 4.4.5:
//! "blend in the rest of the visibility using, say, cube-maps"; engines use
//! probes pre-filtered per roughness level).
//!
//! # Table
//!
//! [`PrefilteredEnv`] holds `levels` latitude-longitude tables of an
//! environment `env(dir)`. Level `k` is for roughness `r_k = k * max_roughness
//! / (levels - 1)` and stores, per texel direction `d`, the mean of `env`
//! over the normalized Phong lobe `(n + 1) / (2 pi) cos^n theta` around `d`
//! with `n =` [`crate::scene::phong_exponent`]`(r_k)`: the same lobe the
//! reference samples ([`refl_core::lobe::sample_phong_lobe`]), without the
//! reference's rejection of directions below the surface (a probe knows no
//! surface). Level 0 stores `env` itself (unfiltered).
//!
//! The integral is estimated with `samples` Hammersley points
//! ([`refl_core::lobe::hammersley`]) under a per-texel Cranley-Patterson
//! rotation, importance-sampling the lobe. With the report's default
//! ([`ProbeSizes::DEFAULT`]: 512 samples) the table's own Monte-Carlo noise is
//! measured by `tests/probe.rs` against a second table with a different
//! rotation: mean absolute difference over the filtered texels 0.09/255 on
//! the 8-bit sRGB scale (asserted < 0.2), so the noise of one table is about
//! 0.07/255; `--quick` ([`ProbeSizes::QUICK`]) uses 64 samples and small
//! tables and is noisier.
//!
//! Level `k`'s resolution follows its lobe width: the lobe's angular
//! standard deviation is about `1 / sqrt(n + 2)` radians; the table width is
//! the largest power of two with a texel at most half that (so the bilinear
//! blur stays under the lobe), clamped to `32..=max_width`, height half the
//! width. Level 0 and the narrow levels use `max_width`.
//!
//! # Lookup
//!
//! [`PrefilteredEnv::sample`]: bilinear in direction within a level
//! (texel centers at `(i + 0.5, j + 0.5)`, wrapping in azimuth, clamped at
//! the poles), linear between the two levels around the roughness
//! (roughness beyond `max_roughness` clamps to the last level).
//!
//! Mapping: `u = (atan2(z, x) / (2 pi) + 1/2) * width`, `v = acos(y) / pi *
//! height` (row 0 at the zenith).

use crate::scene::phong_exponent;
use glam::Vec3;
use rayon::prelude::*;
use refl_core::lobe::{hammersley, hash_rotation, pixel_hash, sample_phong_lobe};
use std::f32::consts::{PI, TAU};

/// Table sizes of a [`PrefilteredEnv`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeSizes {
    /// Number of roughness levels (at least 2; level 0 is unfiltered).
    pub levels: u32,
    /// Roughness of the last level (levels are evenly spaced in roughness).
    pub max_roughness: f32,
    /// Width of the widest (level 0) table, a power of two >= 32.
    pub max_width: u32,
    /// Lobe samples per texel of the filtered levels.
    pub samples: u32,
}

impl ProbeSizes {
    /// The report's probe: 11 levels over roughness 0..0.5 (step 0.05),
    /// level 0 at 256 x 128, 512 samples per texel.
    pub const DEFAULT: ProbeSizes = ProbeSizes {
        levels: 11,
        max_roughness: 0.5,
        max_width: 256,
        samples: 512,
    };
    /// `--quick`: 11 levels, 64 x 32 at most, 64 samples per texel.
    pub const QUICK: ProbeSizes = ProbeSizes {
        levels: 11,
        max_roughness: 0.5,
        max_width: 64,
        samples: 64,
    };
}

#[derive(Clone, Debug)]
struct Level {
    width: u32,
    height: u32,
    texels: Vec<Vec3>,
}

impl Level {
    fn texel(&self, x: u32, y: u32) -> Vec3 {
        self.texels[(y * self.width + x) as usize]
    }

    /// Bilinear lookup at `(s, t)`: azimuth and polar angle as fractions of
    /// a turn and of a half turn (see [`LatLong`]).
    fn sample(&self, at: LatLong) -> Vec3 {
        let u = at.s * self.width as f32 - 0.5;
        let v = at.t * self.height as f32 - 0.5;
        let (u0, v0) = (u.floor(), v.floor());
        let (fu, fv) = (u - u0, v - v0);
        let wrap = |x: f32| (x as i64).rem_euclid(i64::from(self.width)) as u32;
        let clampy = |y: f32| (y.max(0.0) as u32).min(self.height - 1);
        let (x0, x1) = (wrap(u0), wrap(u0 + 1.0));
        let (y0, y1) = (clampy(v0), clampy(v0 + 1.0));
        let top = self.texel(x0, y0).lerp(self.texel(x1, y0), fu);
        let bottom = self.texel(x0, y1).lerp(self.texel(x1, y1), fu);
        top.lerp(bottom, fv)
    }
}

/// A unit direction's lat-long coordinates in `[0, 1]`: `s = atan2(z, x) /
/// (2 pi) + 1/2`, `t = acos(y) / pi` (computed once per lookup, shared by
/// the two levels).
#[derive(Clone, Copy)]
struct LatLong {
    s: f32,
    t: f32,
}

impl LatLong {
    fn of(d: Vec3) -> Self {
        Self {
            s: d.z.atan2(d.x) / TAU + 0.5,
            t: d.y.clamp(-1.0, 1.0).acos() / PI,
        }
    }
}

/// The unit direction of lat-long texel `(x, y)` of a `width x height`
/// table (its center).
pub fn texel_direction(x: u32, y: u32, width: u32, height: u32) -> Vec3 {
    let phi = ((x as f32 + 0.5) / width as f32 - 0.5) * TAU;
    let theta = (y as f32 + 0.5) / height as f32 * PI;
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(st * cp, ct, st * sp)
}

/// The environment pre-filtered with the Phong lobe at several roughness
/// levels; see the module docs.
#[derive(Clone, Debug)]
pub struct PrefilteredEnv {
    sizes: ProbeSizes,
    levels: Vec<Level>,
}

impl PrefilteredEnv {
    /// Builds the table of `env` (a function of the unit direction) with
    /// `sizes` on the current rayon pool (call inside `pool.install` to pick
    /// one). Sizes are sanitized: at least 2 levels, `max_width` a power of
    /// two in `32..=4096`, at least 1 sample, `max_roughness` in `(0, 1]`
    /// (0.5 if not).
    pub fn build(env: impl Fn(Vec3) -> Vec3 + Sync, sizes: ProbeSizes) -> Self {
        Self::build_seeded(env, sizes, 0)
    }

    /// As [`PrefilteredEnv::build`] with the per-texel rotations drawn from
    /// `seed` (two seeds give independent estimates, to measure the table's
    /// own noise).
    pub fn build_seeded(env: impl Fn(Vec3) -> Vec3 + Sync, sizes: ProbeSizes, seed: u32) -> Self {
        let sizes = ProbeSizes {
            levels: sizes.levels.max(2),
            max_roughness: if sizes.max_roughness > 0.0 && sizes.max_roughness <= 1.0 {
                sizes.max_roughness
            } else {
                0.5
            },
            max_width: sizes.max_width.clamp(32, 4096).next_power_of_two(),
            samples: sizes.samples.max(1),
        };
        let levels = (0..sizes.levels)
            .map(|k| {
                let r = Self::level_roughness_of(&sizes, k);
                let width = level_width(r, sizes.max_width);
                let height = width / 2;
                let exponent = phong_exponent(r);
                let texels: Vec<Vec3> = (0..width * height)
                    .into_par_iter()
                    .with_min_len(64)
                    .map(|t| {
                        let (x, y) = (t % width, t / width);
                        let d = texel_direction(x, y, width, height);
                        if k == 0 {
                            return env(d);
                        }
                        let hsh = pixel_hash(t ^ k.wrapping_mul(0x9e37_79b9) ^ pixel_hash(seed));
                        let rot = hash_rotation(hsh);
                        let mut sum = Vec3::ZERO;
                        for i in 0..sizes.samples {
                            let xi = (hammersley(i, sizes.samples) + rot).fract();
                            sum += env(sample_phong_lobe(d, exponent, xi));
                        }
                        sum / sizes.samples as f32
                    })
                    .collect();
                Level {
                    width,
                    height,
                    texels,
                }
            })
            .collect();
        Self { sizes, levels }
    }

    fn level_roughness_of(sizes: &ProbeSizes, k: u32) -> f32 {
        sizes.max_roughness * k as f32 / (sizes.levels - 1) as f32
    }

    /// The (sanitized) sizes the table was built with.
    pub fn sizes(&self) -> ProbeSizes {
        self.sizes
    }

    /// The roughness of level `k`.
    pub fn level_roughness(&self, k: u32) -> f32 {
        Self::level_roughness_of(&self.sizes, k)
    }

    /// Number of levels.
    pub fn level_count(&self) -> u32 {
        self.levels.len() as u32
    }

    /// The stored texel `(x, y)` of level `k` (`None` out of range).
    pub fn texel(&self, k: u32, x: u32, y: u32) -> Option<Vec3> {
        let l = self.levels.get(k as usize)?;
        (x < l.width && y < l.height).then(|| l.texel(x, y))
    }

    /// `(width, height)` of each level.
    pub fn level_dims(&self) -> Vec<(u32, u32)> {
        self.levels.iter().map(|l| (l.width, l.height)).collect()
    }

    /// Texels over all levels.
    pub fn texel_count(&self) -> usize {
        self.levels.iter().map(|l| l.texels.len()).sum()
    }

    /// Bytes of the table (three f32 per texel).
    pub fn bytes(&self) -> usize {
        self.texel_count() * 12
    }

    /// The pre-filtered environment in direction `dir` (need not be unit; a
    /// zero or non-finite direction gives the table's zenith texel row) for
    /// `roughness` (NaN or negative counts as 0): bilinear within a level,
    /// linear between levels.
    pub fn sample(&self, dir: Vec3, roughness: f32) -> Vec3 {
        let d = dir.normalize_or(Vec3::Y);
        let top = (self.sizes.levels - 1) as f32;
        let s = if roughness > 0.0 {
            (roughness / self.sizes.max_roughness * top).min(top)
        } else {
            0.0
        };
        let k0 = (s.floor() as usize).min(self.levels.len() - 1);
        let f = s - k0 as f32;
        let at = LatLong::of(d);
        let a = self.levels[k0].sample(at);
        if f > 0.0 && k0 + 1 < self.levels.len() {
            a.lerp(self.levels[k0 + 1].sample(at), f)
        } else {
            a
        }
    }
}

/// The table width for roughness `r` (see the module docs).
fn level_width(r: f32, max_width: u32) -> u32 {
    let n = phong_exponent(r);
    if !n.is_finite() {
        return max_width;
    }
    let sigma = 1.0 / (n + 2.0).sqrt();
    let wanted = (TAU / (0.5 * sigma)).max(1.0) as u32;
    // Largest power of two <= wanted.
    let w = 1u32 << (31 - wanted.leading_zeros());
    w.clamp(32, max_width)
}
