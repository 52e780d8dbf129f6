//! Glossy reflections by screen-space cone tracing over a pre-convolved
//! color pyramid and a pre-integrated visibility pyramid (seed 004,
//! Sec. 4.4.2 / 4.5.2 pre-integration, Sec. 4.4.4 / 4.5.4 pre-convolution,
//! Sec. 4.4.5 / 4.5.5 cone tracing, Sec. 4.6.1 fades, Sec. 4.6.8 anisotropic
//! stretching), and the multi-ray alternative of seed 003 Sec. 3.5.
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::cone::DEFAULT_SIGMA;
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::{try_build_color_pyramid, try_build_hiz, try_build_visibility_pyramid};
//! use refl_core::{try_color_pyramid_len, try_cone_angle_from_roughness, try_cone_trace};
//! use refl_core::{try_hiz_len, try_visibility_pyramid_len, Camera, Cone, ConeOptions};
//! use refl_core::{ConePyramids, DepthConvention, DepthImage, HiZ, ImageView};
//!
//! // 16 x 16 pixels of a wall at linear depth 4, lit in one color.
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 0.1, 100.0, 16, 16)?;
//! let (depth, lit) = (vec![4.0f32; 256], vec![[0.2f32, 0.4, 0.6]; 256]);
//! let image = DepthImage::try_new(ImageView::try_new(&depth, 16, 16, 16)?, cam, DepthConvention::Linear)?;
//! let mut hiz = vec![[0.0f32; 2]; try_hiz_len(16, 16)?];
//! try_build_hiz(&mut hiz, &image)?;
//! let hiz = HiZ::try_new(&hiz, cam, DepthConvention::Linear)?;
//! let mut color = vec![[0.0f32; 3]; try_color_pyramid_len(16, 16)?];
//! try_build_color_pyramid(&mut color, &ImageView::try_new(&lit, 16, 16, 16)?, DEFAULT_SIGMA)?;
//! let mut visibility = vec![0.0f32; try_visibility_pyramid_len(16, 16)?];
//! try_build_visibility_pyramid(&mut visibility, &hiz)?;
//! let pyramids = ConePyramids::try_new(hiz, &color, &visibility)?;
//!
//! // Roughness 0.5: Phong power 2 / 0.5^4 - 2 = 30, angle acos(0.244^(1/31)).
//! let theta = try_cone_angle_from_roughness(0.5)?;
//! assert!((theta - 0.244f32.powf(1.0 / 31.0).acos()).abs() < 1e-5);
//! // A cone from (8.5, 12.5) at depth 2 to its hit on the wall at (8.5, 4.5): the
//! // first circle reaches the wall, which covers it, so the wall's color comes back.
//! let (apex, hit) = (Vec2::new(8.5, 12.5), Vec2::new(8.5, 4.5));
//! let cone = Cone { apex, apex_depth: 2.0, hit, hit_depth: 4.0, theta, n_dot_v: 1.0, travel: 0.0 };
//! let on_wall = try_cone_trace(&pyramids, &cone, [1.0; 3], &ConeOptions::default())?;
//! assert_eq!(on_wall.coverage, 1.0);
//! assert!((Vec3::from(on_wall.color) - Vec3::new(0.2, 0.4, 0.6)).length() < 1e-6);
//! // An axis ending at depth 3, in front of the wall, meets nothing: the fallback.
//! let short = Cone { hit_depth: 3.0, ..cone };
//! let in_front = try_cone_trace(&pyramids, &short, [1.0; 3], &ConeOptions::default())?;
//! assert_eq!((in_front.coverage, in_front.color), (0.0, [1.0; 3]));
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! # Pipeline
//!
//! 1. Hi-Z pyramid of the frame's depth ([`crate::hiz`]).
//! 2. [`try_build_color_pyramid`]: the lit frame, blurred with a normalized
//!    Gaussian and halved per level (same level sizes as the Hi-Z,
//!    [`HiZLayout`]), into a caller buffer of [`try_color_pyramid_len`] texels
//!    ending with its [`PyramidStamp`].
//! 3. [`try_build_visibility_pyramid`]: per texel, the pre-integrated share
//!    of the cell that blocks rays (module section "Visibility"), into a
//!    caller buffer of [`try_visibility_pyramid_len`] floats ending with its
//!    [`PyramidStamp`]; [`ConePyramids::try_new`] checks both stamps
//!    against the Hi-Z's camera.
//! 4. Per glossy pixel: trace the mirror ray with [`crate::try_trace_hiz`];
//!    from its hit, [`try_cone_trace`] integrates the cone of half-angle
//!    `theta` ([`try_cone_angle_from_phong`],
//!    [`try_cone_angle_from_roughness`]) by sampling in-radius circles of the
//!    screen-space isosceles triangle ([`ConeCircles`]); the uncovered rest
//!    blends a caller fallback color (environment / probe). [`Fades`]
//!    (Sec. 4.6.1) blend toward the fallback where screen space is
//!    unreliable.
//!
//! # Visibility
//!
//! Listing 4.4 prints `fineZ * coarseVolume * visibility` with `coarseVolume
//! = 1 / (maxZ - minZ)`, which is not a ratio (a depth times an inverse
//! depth range); the prose asks for "the percentage of empty volume" between
//! the cell's minimum and maximum depth, modulated by the finer visibility,
//! with `Visibility_n <= Visibility_{n-1}`. This module reads it as: level-0
//! texels with a foreground surface (a decoded depth below the far plane)
//! have visibility 1, texels without one (no surface, background) 0; a
//! coarse texel is the mean over its children (the 2x2, or up to 3x3 at an
//! odd edge, of [`crate::hiz`]) of `V_child * (1 - e_child)`, with
//! `e_child = (closest_child - closest_cell) / (farthest_cell -
//! closest_cell)` the empty share of the cell's depth slab in front of the
//! child (the cell's slab: closest over its foreground children, farthest
//! over the same children's Hi-Z farthest, background included); a cell whose
//! slab is flat (range below `1e-6` of its depth) keeps the mean. The
//! value is then "how much of the cell blocks a ray entering its slab at the
//! front", `<=` the children's mean. [`ConeOptions::use_visibility`] turns
//! the weighting off (the report measures both).
//!
//! # Cone size
//!
//! The seed builds the isosceles triangle in screen space from the cone
//! angle and the ray's screen length `l` (Sec. 4.4.5); a ray that travels
//! mostly in depth has a short `l` and gets a far too narrow footprint.
//! The seed's closing remark suggests the view-space alternative: "use the
//! cone angle with the view-space Z distance to find the sphere size and
//! then project this using perspective division into screen space". With
//! [`Cone::travel`] `= t > 0` the triangle's half-angle becomes
//! `atan(r / l)` with `r = f t tan(theta) / z_hit` the cone's radius at the
//! hit projected at the hit's depth (`f` the focal length in pixels), so
//! the first circles cover the projected footprint; `travel = 0` keeps the
//! seed's triangle.
//!
//! # Cone trace
//!
//! The cone's apex is the reflection ray's start `P1` (pixel, linear depth)
//! and its axis runs to the Hi-Z hit `P2`; `l = |P2 - P1|` in pixels is the
//! adjacent side (Sec. 4.4.5). Circle `k` has in-radius `r_k` of the
//! isosceles triangle with height `adj_k` and base `2 tan(theta) adj_k`
//! (Eq. 4.2), center at `adj_k - r_k` from the apex, and `adj_{k+1} =
//! adj_k - 2 r_k` (Listing 4.7 order: largest circle at the hit first). Each
//! circle samples, at mip level `log2(2 r) + level_bias` (the circle's
//! diameter in pixels matches a level-`L` texel of `2^L` pixels; Listing 4.7
//! uses `log2(r)`, i.e. `level_bias = -1`):
//!
//! * the color pyramid, trilinearly (bilinear in both neighboring levels,
//!   linear across them);
//! * the visibility pyramid, likewise (or 1 without visibility weighting);
//! * the Hi-Z cell under the center at both levels: the cone's sphere there
//!   has center depth `z` (`1/z` interpolated linearly from `P1` to `P2`,
//!   the perspective-correct depth of the axis, taken at the deeper of the
//!   circle's two edges along the axis, so that the first circle, whose
//!   front edge is the hit, reaches the hit surface) and depth radius
//!   `r z / f` (`f` the focal length in pixels) plus
//!   [`ConeOptions::depth_tolerance`] `* z`; its weight is
//!   `clamp((z + rz - closest) / rz, 0, 1)`: 0 when the sphere lies entirely
//!   above (in front of) the cell's closest depth, 1 when its center is at
//!   or below it (the cone's axis has reached the surface), linear in
//!   between; 0 for cells without foreground.
//!
//! The sample weight `a = visibility * sphere weight` is accumulated front
//! to back in Listing 4.7's order, clipped so that the total `A <= 1`; the
//! loop stops at `A = 1` or after [`ConeOptions::max_circles`]. The result
//! is `fallback + sum a_k (c_k - fallback)`: every sample and the fallback
//! enter as differences, so a uniformly colored scene with a fallback of the
//! same color returns that color bit for bit, whatever the weights. With
//! [`ConeOptions::normalize`] the sum is divided by `A` (a weighted mean of
//! the samples; the fallback then only answers cones with `A = 0`).
//!
//! Bias (measured by `refl report`): the circles march from the hit back
//! toward the apex, where the axis lies in front of the surfaces, so after
//! the first circle or two the sphere weights are 0; coverage then stays
//! below 1 wherever the visibility of the first circle's cells is below 1
//! (slanted surfaces at coarse levels, silhouettes), and the seed's rule
//! gives the rest to the fallback.

use crate::hiz::{
    try_pyramid_len, try_trace_hiz, HiZ, HiZLayout, HiZOptions, HiZTexel, PyramidStamp,
};
use crate::trace::Thickness;
use crate::{Error, ImageView, Ray, RowRange};
use glam::{Vec2, Vec3};

/// One color texel, linear RGB.
pub type ColorTexel = [f32; 3];

/// Default Gaussian standard deviation of the pre-convolution, in texels of
/// the finer level. The seed's 7-tap weights (Sec. 4.5.4: 0.001, 0.028,
/// 0.233, 0.474, ...) correspond to about 0.84; 1.0 suppresses more
/// aliasing on the halving step.
pub const DEFAULT_SIGMA: f32 = 1.0;

/// Half-width of the pre-convolution kernel in finer texels (the seed's
/// 7x7 kernel has 3).
pub const KERNEL_RADIUS: i64 = 3;

/// Largest screen-triangle half-angle the view-space cone size
/// ([`Cone::travel`]) produces (89 degrees).
pub const MAX_VIEW_THETA: f32 = 1.553_343;

/// Most circles [`try_cone_trace`] takes, whatever the options say.
pub const MAX_CIRCLES: u32 = 64;

/// Most samples one anisotropic (stretched) circle takes.
pub const MAX_STRETCH_SAMPLES: u32 = 8;

// ------------------------------------------------------------ cone angle

/// The lobe math of the cone angle and the multi-ray directions lives in
/// [`crate::lobe`]; these are its names in the cone family.
pub use crate::lobe::{
    cone_ray_direction, phong_lobe_weight, try_cone_angle_from_phong,
    try_cone_angle_from_roughness, try_phong_power_from_roughness, CONE_XI, MIRROR_POWER_END,
    MIRROR_POWER_START,
};

// ------------------------------------------------ isosceles triangle

/// The base (opposite side) of the isosceles triangle of half-angle `theta`
/// at the apex and height `adjacent`: `2 tan(theta) adjacent` (seed 004
/// Eq. 4.2).
#[inline]
pub fn isosceles_opposite(adjacent: f32, theta: f32) -> f32 {
    2.0 * libm::tanf(theta) * adjacent
}

/// The in-radius of the isosceles triangle with base `a` and height `h`, in
/// the cancellation-free form `a h / (sqrt(a^2 + 4 h^2) + a)` (design.md
/// erratum). The seed's `a (sqrt(a^2 + 4 h^2) - a) / (4 h)` subtracts two
/// nearly equal numbers when `a >> h`, i.e. for *wide* cones (design.md
/// says narrow; for `a << h` the seed's form is merely slower): at 89.9
/// degrees it loses about half of the f32 digits (tested). 0 when `a` or
/// `h` is 0; the sum under the root is formed scaled so that it does not
/// overflow.
#[inline]
pub fn isosceles_inradius(a: f32, h: f32) -> f32 {
    if !(a > 0.0 && h > 0.0) {
        return 0.0;
    }
    // a h / (sqrt(a^2 + 4h^2) + a) = h x / (sqrt(x^2 + y^2) + x) with
    // x = a / m, y = 2 h / m, m = max(a, h): no overflow, ratio in (0, 1/2].
    let m = a.max(h);
    let (x, y) = (a / m, 2.0 * (h / m));
    (x / (libm::sqrtf(x * x + y * y) + x)) * h
}

/// One sample circle of a cone (all lengths in level-0 pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeCircle {
    /// Distance of the circle's center from the apex along the axis.
    pub center: f32,
    /// The in-radius.
    pub radius: f32,
}

/// The sample circles of a screen-space cone (seed 004 Sec. 4.4.5, Listing
/// 4.7): starting with `adj = length`, each circle is the in-radius `r` of
/// the triangle of height `adj`, centered at `adj - r`; the next triangle
/// has height `adj - 2 r`. Yields at most `max` circles and stops when the
/// height reaches 0.
#[derive(Clone, Copy, Debug)]
pub struct ConeCircles {
    adjacent: f32,
    two_tan: f32,
    left: u32,
}

impl ConeCircles {
    /// The circles of a cone of half-angle `theta` whose axis is `length`
    /// pixels long, at most `max` of them.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a NaN/Inf or negative length, or
    /// `theta` outside `[0, pi/2)`.
    pub fn try_new(length: f32, theta: f32, max: u32) -> Result<Self, Error> {
        if !(length >= 0.0 && length.is_finite() && valid_theta(theta)) {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            adjacent: length,
            two_tan: 2.0 * libm::tanf(theta),
            left: max,
        })
    }
}

impl Iterator for ConeCircles {
    type Item = ConeCircle;

    fn next(&mut self) -> Option<ConeCircle> {
        if self.left == 0 || !(self.adjacent > 0.0) {
            return None;
        }
        self.left -= 1;
        let h = self.adjacent;
        let r = isosceles_inradius(self.two_tan * h, h);
        self.adjacent = h - 2.0 * r;
        Some(ConeCircle {
            center: h - r,
            radius: r,
        })
    }
}

fn valid_theta(theta: f32) -> bool {
    (0.0..core::f32::consts::FRAC_PI_2).contains(&theta) && libm::tanf(theta).is_finite()
}

/// The mip level a circle of radius `radius` pixels samples:
/// `max(0, log2(2 radius) + bias)` (module docs; Listing 4.7 is `bias =
/// -1`). 0 for a zero or NaN radius.
#[inline]
pub fn cone_mip_level(radius: f32, bias: f32) -> f32 {
    if !(radius > 0.0) {
        return 0.0;
    }
    let l = libm::log2f(2.0 * radius) + bias;
    if l > 0.0 {
        l
    } else {
        0.0
    }
}

// ------------------------------------------------------------ pyramids

/// Texels of the color pyramid of a `width x height` frame: the levels
/// (same layout as the Hi-Z pyramid, [`HiZLayout`]), then
/// [`COLOR_STAMP_TEXELS`] for its [`PyramidStamp`].
///
/// # Errors
/// As [`HiZLayout::try_new`].
pub fn try_color_pyramid_len(width: u32, height: u32) -> Result<usize, Error> {
    try_pyramid_len::<ColorTexel>(width, height)
}

/// Floats of the visibility pyramid of a `width x height` frame: the
/// levels (same layout as the Hi-Z pyramid), then
/// [`VISIBILITY_STAMP_LEN`] for its [`PyramidStamp`].
///
/// # Errors
/// As [`HiZLayout::try_new`].
pub fn try_visibility_pyramid_len(width: u32, height: u32) -> Result<usize, Error> {
    try_pyramid_len::<f32>(width, height)
}

/// Texels after the color pyramid's last level that hold its stamp (the
/// frame size: the color image has no camera).
pub const COLOR_STAMP_TEXELS: usize = <ColorTexel as crate::hiz::PyramidTexel>::STAMP_TEXELS;

/// Floats after the visibility pyramid's last level that hold its stamp
/// (the size and camera of the Hi-Z it was built from).
pub const VISIBILITY_STAMP_LEN: usize = <f32 as crate::hiz::PyramidTexel>::STAMP_TEXELS;

/// Stamps a row-band-built color pyramid of a `width x height` frame
/// ([`try_build_color_level0_rows`], [`try_build_color_level_rows`]; the
/// whole build [`try_build_color_pyramid`] does it itself).
///
/// # Errors
/// [`Error::InsufficientSize`] if `dst` is shorter than
/// [`try_color_pyramid_len`]; [`Error::InvalidArgument`] for a zero size.
pub fn try_stamp_color_pyramid(
    dst: &mut [ColorTexel],
    width: u32,
    height: u32,
) -> Result<(), Error> {
    PyramidStamp::of_size(width, height).try_write(dst)
}

/// Stamps a row-band-built visibility pyramid of `hiz`
/// ([`try_build_visibility_level0_rows`], [`try_build_visibility_level_rows`];
/// the whole build [`try_build_visibility_pyramid`] does it itself).
///
/// # Errors
/// [`Error::InsufficientSize`] if `dst` is shorter than
/// [`try_visibility_pyramid_len`].
pub fn try_stamp_visibility_pyramid(dst: &mut [f32], hiz: &HiZ<'_>) -> Result<(), Error> {
    PyramidStamp::of(hiz.camera()).try_write(dst)
}

fn validate_sigma(sigma: f32) -> Result<(), Error> {
    if sigma > 0.0 && sigma.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidArgument)
    }
}

fn finite3(c: ColorTexel) -> bool {
    c[0].is_finite() && c[1].is_finite() && c[2].is_finite()
}

/// Copies rows `rows` of the frame `color` into `band` (level 0 of the color
/// pyramid, row stride = width).
///
/// # Errors
/// [`Error::InvalidArgument`] if `rows` exceed the height or a texel is not
/// finite; [`Error::InsufficientSize`] if `band` is too short. Nothing is
/// written on error.
///
/// # Panics
/// Never.
pub fn try_build_color_level0_rows(
    band: &mut [ColorTexel],
    color: &ImageView<'_, ColorTexel>,
    rows: RowRange,
) -> Result<(), Error> {
    if rows.end() > color.height() {
        return Err(Error::InvalidArgument);
    }
    let w = color.width() as usize;
    if band.len() < rows.len() as usize * w {
        return Err(Error::InsufficientSize);
    }
    for y in rows.rows() {
        if let Some(src) = color.row(y) {
            if !src.iter().all(|&c| finite3(c)) {
                return Err(Error::InvalidArgument);
            }
        }
    }
    for (dst, y) in band.chunks_exact_mut(w).zip(rows.rows()) {
        if let Some(src) = color.row(y) {
            dst.copy_from_slice(src);
        }
    }
    Ok(())
}

/// Normalized Gaussian weight of finer texel `t` (center `t + 0.5`) for a
/// coarse texel whose footprint center is `c`, unnormalized.
#[inline]
fn gauss(t: i64, c: f32, inv_two_sigma2: f32) -> f32 {
    let d = t as f32 + 0.5 - c;
    libm::expf(-d * d * inv_two_sigma2)
}

/// The normalized 1D weights of the pre-convolution for coarse texel `i`
/// along an axis (`coarse` texels over `fine` finer texels): taps
/// `first..first + n` of the finer level (clamped to the edge when
/// fetched), Gaussian of standard deviation `sigma` centered on the
/// footprint of `i` (`[2i, 2i + 2)`, the last texel reaching the finer
/// edge, as in [`crate::hiz`]). The weights are divided by their sum and
/// rounded to multiples of `2^-24`, the rest going to the largest, so that
/// they sum to exactly 1 in f32 (Sec. 4.5.4: "weights must equal 1.0 when
/// summed").
///
/// Returns `(first, n, weights)`; `n <= 2 * KERNEL_RADIUS + 3`.
pub fn convolution_weights(i: u32, coarse: u32, fine: u32, sigma: f32) -> (i64, usize, [f32; 9]) {
    let lo = 2 * i64::from(i);
    let hi = if i + 1 >= coarse {
        i64::from(fine)
    } else {
        lo + 2
    };
    let c = (lo + hi) as f32 * 0.5;
    let first = lo - KERNEL_RADIUS;
    let last = hi - 1 + KERNEL_RADIUS;
    let n = ((last - first + 1) as usize).min(9);
    let inv = 0.5 / (sigma * sigma);
    let mut w = [0.0f32; 9];
    let mut sum = 0.0f32;
    for (k, wk) in w.iter_mut().enumerate().take(n) {
        *wk = gauss(first + k as i64, c, inv);
        sum += *wk;
    }
    // Quantize to multiples of 2^-24 and give the rounding rest to the
    // largest weight: the integers sum to 2^24, and every partial sum of
    // such dyadic weights (at most 2^24 units) is exact in f32, so the sum
    // is exactly 1 in any order.
    const UNIT: f32 = 16_777_216.0;
    let mut q = [0u32; 9];
    let (mut big, mut total) = (0, 0u32);
    for k in 0..n {
        q[k] = libm::roundf(w[k] / sum * UNIT) as u32;
        total += q[k];
        if q[k] > q[big] {
            big = k;
        }
    }
    q[big] = (q[big] + (1 << 24)).saturating_sub(total);
    for k in 0..n {
        w[k] = q[k] as f32 / UNIT;
    }
    (first, n, w)
}

/// Builds rows `rows` of color level `level >= 1` from the complete level
/// `level - 1` (seed 004 Sec. 4.4.4 / 4.5.4: separable normalized Gaussian,
/// then half size): texel `(i, j)` is `sum_u sum_v wx(u) wy(v) finer(u, v)`
/// with the weights of [`convolution_weights`] (edge texels clamped). The
/// sum is formed as `c0 + sum w (finer - c0)`, `c0` the finer texel under
/// the footprint's corner, so a constant image stays exactly constant.
///
/// # Errors
/// [`Error::InvalidArgument`] for `level` 0 or past the last level, rows
/// past the level's height, or `sigma` not finite and positive;
/// [`Error::InsufficientSize`] if `finer` or `band` is too short. Nothing is
/// written on error.
///
/// # Panics
/// Never.
pub fn try_build_color_level_rows(
    band: &mut [ColorTexel],
    finer: &[ColorTexel],
    layout: &HiZLayout,
    level: u32,
    rows: RowRange,
    sigma: f32,
) -> Result<(), Error> {
    validate_sigma(sigma)?;
    let (f, c) = layout.try_band_levels(level, rows, finer.len(), band.len())?;
    let cw = c.width as usize;
    let (fw, fh) = (i64::from(f.width), i64::from(f.height));
    let at = |x: i64, y: i64| -> ColorTexel {
        let x = x.clamp(0, fw - 1) as usize;
        let y = y.clamp(0, fh - 1) as usize;
        finer[y * fw as usize + x]
    };
    for (dst, y) in band.chunks_exact_mut(cw).zip(rows.rows()) {
        let (fy, ny, wy) = convolution_weights(y, c.height, f.height, sigma);
        for (x, o) in dst.iter_mut().enumerate() {
            let (fx, nx, wx) = convolution_weights(x as u32, c.width, f.width, sigma);
            let c0 = at(2 * x as i64, 2 * i64::from(y));
            let mut acc = [0.0f32; 3];
            for (v, wv) in wy.iter().enumerate().take(ny) {
                let mut row = [0.0f32; 3];
                for (u, wu) in wx.iter().enumerate().take(nx) {
                    let t = at(fx + u as i64, fy + v as i64);
                    for k in 0..3 {
                        row[k] += wu * (t[k] - c0[k]);
                    }
                }
                for k in 0..3 {
                    acc[k] += wv * row[k];
                }
            }
            *o = [c0[0] + acc[0], c0[1] + acc[1], c0[2] + acc[2]];
        }
    }
    Ok(())
}

/// Builds the whole color pyramid of `color` into `dst` (level 0 a copy,
/// then [`try_build_color_level_rows`] level by level).
///
/// # Errors
/// [`Error::InsufficientSize`] if `dst` is shorter than
/// [`try_color_pyramid_len`]; [`Error::InvalidArgument`] for a non-finite
/// texel or sigma. Nothing is written on error.
///
/// # Panics
/// Never.
pub fn try_build_color_pyramid(
    dst: &mut [ColorTexel],
    color: &ImageView<'_, ColorTexel>,
    sigma: f32,
) -> Result<(), Error> {
    validate_sigma(sigma)?;
    let layout = HiZLayout::try_new(color.width(), color.height())?;
    if dst.len() < try_color_pyramid_len(color.width(), color.height())? {
        return Err(Error::InsufficientSize);
    }
    let l0 = layout.level(0).ok_or(Error::InvalidArgument)?;
    // Validate every texel before writing anything.
    for y in 0..color.height() {
        if let Some(row) = color.row(y) {
            if !row.iter().all(|&c| finite3(c)) {
                return Err(Error::InvalidArgument);
            }
        }
    }
    try_build_color_level0_rows(&mut dst[l0.range()], color, RowRange::try_all(l0.height)?)?;
    for level in 1..layout.level_count() {
        let (f, c) = match (layout.level(level - 1), layout.level(level)) {
            (Some(f), Some(c)) => (f, c),
            _ => return Err(Error::InvalidArgument),
        };
        let (head, tail) = dst.split_at_mut(c.offset);
        try_build_color_level_rows(
            &mut tail[..c.len()],
            &head[f.range()],
            &layout,
            level,
            RowRange::try_all(c.height)?,
            sigma,
        )?;
    }
    try_stamp_color_pyramid(dst, color.width(), color.height())
}

/// Whether a Hi-Z closest depth is a foreground surface (not NaN, below the
/// far plane).
#[inline]
fn foreground(z: f32, far: f32) -> bool {
    z > 0.0 && z < far
}

/// Builds rows `rows` of visibility level 0 from the Hi-Z: 1 where the
/// pixel has a foreground surface (closest depth below the far plane), 0
/// where it has none (module docs, "Visibility").
///
/// # Errors
/// [`Error::InvalidArgument`] if rows exceed the height;
/// [`Error::InsufficientSize`] if `band` is shorter than `rows.len() *
/// width`. Nothing is written on error.
///
/// # Panics
/// Never.
pub fn try_build_visibility_level0_rows(
    band: &mut [f32],
    hiz: &HiZ<'_>,
    rows: RowRange,
) -> Result<(), Error> {
    let l = hiz.layout().level(0).ok_or(Error::InvalidArgument)?;
    if rows.end() > l.height {
        return Err(Error::InvalidArgument);
    }
    let w = l.width as usize;
    if band.len() < rows.len() as usize * w {
        return Err(Error::InsufficientSize);
    }
    let far = hiz.camera().far();
    for (dst, y) in band.chunks_exact_mut(w).zip(rows.rows()) {
        for (x, o) in dst.iter_mut().enumerate() {
            let t = hiz.texel(0, x as u32, y).unwrap_or([f32::NAN; 2]);
            *o = if foreground(t[0], far) { 1.0 } else { 0.0 };
        }
    }
    Ok(())
}

/// Builds rows `rows` of visibility level `level >= 1` from the complete
/// visibility level `level - 1` (`finer`) and the Hi-Z's level `level - 1`
/// (seed 004 Sec. 4.4.2 / Listing 4.4 as read in the module docs: the mean
/// over the children of `V_child * (1 - e_child)`).
///
/// # Errors
/// [`Error::InvalidArgument`] for `level` 0 or past the last level, or rows
/// past the level's height; [`Error::InsufficientSize`] if `finer` or
/// `band` is too short. Nothing is written on error.
///
/// # Panics
/// Never.
pub fn try_build_visibility_level_rows(
    band: &mut [f32],
    finer: &[f32],
    hiz: &HiZ<'_>,
    level: u32,
    rows: RowRange,
) -> Result<(), Error> {
    let layout = hiz.layout();
    let (f, c) = layout.try_band_levels(level, rows, finer.len(), band.len())?;
    let cw = c.width as usize;
    let far = hiz.camera().far();
    let fw = f.width as usize;
    for (dst, y) in band.chunks_exact_mut(cw).zip(rows.rows()) {
        let ys = children(y, c.height, f.height);
        for (x, o) in dst.iter_mut().enumerate() {
            let xs = children(x as u32, c.width, f.width);
            // The cell's slab over its foreground children.
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for yy in ys.clone() {
                for xx in xs.clone() {
                    let t = hiz.texel(level - 1, xx, yy).unwrap_or([f32::NAN; 2]);
                    if foreground(t[0], far) {
                        lo = lo.min(t[0]);
                        hi = hi.max(t[1]);
                    }
                }
            }
            let range = hi - lo;
            let flat = !(range > 1e-6 * hi);
            let (mut sum, mut n) = (0.0f32, 0u32);
            for yy in ys.clone() {
                for xx in xs.clone() {
                    n += 1;
                    let v = finer[yy as usize * fw + xx as usize];
                    let t = hiz.texel(level - 1, xx, yy).unwrap_or([f32::NAN; 2]);
                    if !foreground(t[0], far) {
                        continue;
                    }
                    let keep = if flat {
                        1.0
                    } else {
                        1.0 - ((t[0] - lo) / range).clamp(0.0, 1.0)
                    };
                    sum += v * keep;
                }
            }
            *o = if n > 0 { sum / n as f32 } else { 0.0 };
        }
    }
    Ok(())
}

#[inline]
fn children(c: u32, coarse: u32, fine: u32) -> core::ops::Range<u32> {
    let hi = if c + 1 >= coarse { fine } else { 2 * c + 2 };
    2 * c..hi
}

/// Builds the whole visibility pyramid of `hiz` into `dst`.
///
/// # Errors
/// [`Error::InsufficientSize`] if `dst` is shorter than
/// [`try_visibility_pyramid_len`]. Nothing is written on error.
///
/// # Panics
/// Never.
pub fn try_build_visibility_pyramid(dst: &mut [f32], hiz: &HiZ<'_>) -> Result<(), Error> {
    let layout = *hiz.layout();
    if dst.len() < try_visibility_pyramid_len(layout.width(), layout.height())? {
        return Err(Error::InsufficientSize);
    }
    let l0 = layout.level(0).ok_or(Error::InvalidArgument)?;
    try_build_visibility_level0_rows(&mut dst[l0.range()], hiz, RowRange::try_all(l0.height)?)?;
    for level in 1..layout.level_count() {
        let (f, c) = match (layout.level(level - 1), layout.level(level)) {
            (Some(f), Some(c)) => (f, c),
            _ => return Err(Error::InvalidArgument),
        };
        let (head, tail) = dst.split_at_mut(c.offset);
        try_build_visibility_level_rows(
            &mut tail[..c.len()],
            &head[f.range()],
            hiz,
            level,
            RowRange::try_all(c.height)?,
        )?;
    }
    try_stamp_visibility_pyramid(dst, hiz)
}

// ------------------------------------------------------------ cone trace

/// The three pyramids a cone trace reads, bound together.
#[derive(Clone, Copy, Debug)]
pub struct ConePyramids<'a> {
    hiz: HiZ<'a>,
    color: &'a [ColorTexel],
    visibility: &'a [f32],
    focal: f32,
}

impl<'a> ConePyramids<'a> {
    /// Binds a Hi-Z, a color pyramid ([`try_build_color_pyramid`]) and a
    /// visibility pyramid ([`try_build_visibility_pyramid`]) of one frame.
    /// An empty `visibility` binds none: enough for [`try_multiray`] and
    /// for [`try_cone_trace`] with [`ConeOptions::use_visibility`] off
    /// (with it on, the trace is refused).
    ///
    /// # Errors
    /// * [`Error::InsufficientSize`] if `color` is shorter than
    ///   [`try_color_pyramid_len`] or a non-empty `visibility` than
    ///   [`try_visibility_pyramid_len`] for the Hi-Z's size.
    /// * [`Error::InvalidArgument`] if a pyramid's [`PyramidStamp`] is not
    ///   this frame's: the color pyramid built for another size, the
    ///   visibility pyramid from another Hi-Z camera, or either not built.
    pub fn try_new(
        hiz: HiZ<'a>,
        color: &'a [ColorTexel],
        visibility: &'a [f32],
    ) -> Result<Self, Error> {
        let cam = hiz.camera();
        let (w, h) = (cam.width(), cam.height());
        let with_vis = !visibility.is_empty();
        if color.len() < try_color_pyramid_len(w, h)?
            || (with_vis && visibility.len() < try_visibility_pyramid_len(w, h)?)
        {
            return Err(Error::InsufficientSize);
        }
        if PyramidStamp::read(color, w, h) != Some(PyramidStamp::of_size(w, h))
            || (with_vis && PyramidStamp::read(visibility, w, h) != Some(PyramidStamp::of(cam)))
        {
            return Err(Error::InvalidArgument);
        }
        let focal = cam.height() as f32 / (2.0 * libm::tanf(cam.fov_y() * 0.5));
        Ok(Self {
            hiz,
            color,
            visibility,
            focal,
        })
    }

    /// The Hi-Z.
    pub const fn hiz(&self) -> &HiZ<'a> {
        &self.hiz
    }

    /// Focal length in pixels, `height / (2 tan(fov_y / 2))`.
    pub const fn focal(&self) -> f32 {
        self.focal
    }

    /// Bilinear sample of level `level` of a pyramid at level-0 pixel
    /// position `p` (texel centers at `(i + 0.5) w_L / W`, edges clamped).
    fn bilinear<T: Copy, const N: usize>(
        data: &[T],
        layout: &HiZLayout,
        level: u32,
        p: Vec2,
        get: impl Fn(T) -> [f32; N],
        fetches: &mut u32,
    ) -> [f32; N] {
        let l = match layout.level(level) {
            Some(l) => l,
            None => return [0.0; N],
        };
        let sx = l.width as f32 / layout.width() as f32;
        let sy = l.height as f32 / layout.height() as f32;
        let u = p.x * sx - 0.5;
        let v = p.y * sy - 0.5;
        let (x0, y0) = (libm::floorf(u), libm::floorf(v));
        let (fx, fy) = (u - x0, v - y0);
        let (wm, hm) = (i64::from(l.width) - 1, i64::from(l.height) - 1);
        // Clamped first: a position far outside the image (or +-inf)
        // saturates the cast at i64::MAX, where `xi + 1` overflowed (fuzz
        // finding F13); every index is clamped into the level anyway.
        let (xi, yi) = ((x0 as i64).clamp(-1, wm), (y0 as i64).clamp(-1, hm));
        let fetch = |x: i64, y: i64| -> [f32; N] {
            let x = x.clamp(0, wm) as usize;
            let y = y.clamp(0, hm) as usize;
            data.get(l.offset + y * l.width as usize + x)
                .map(|&t| get(t))
                .unwrap_or([0.0; N])
        };
        *fetches += 4;
        let (a, b, c, d) = (
            fetch(xi, yi),
            fetch(xi + 1, yi),
            fetch(xi, yi + 1),
            fetch(xi + 1, yi + 1),
        );
        let mut out = [0.0; N];
        for k in 0..N {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bot = c[k] + (d[k] - c[k]) * fx;
            out[k] = top + (bot - top) * fy;
        }
        out
    }

    /// Trilinear sample of a pyramid: bilinear in levels `floor(level)` and
    /// the next, linear across.
    fn trilinear<T: Copy, const N: usize>(
        &self,
        data: &[T],
        level: f32,
        p: Vec2,
        get: impl Fn(T) -> [f32; N] + Copy,
        fetches: &mut u32,
    ) -> [f32; N] {
        let layout = self.hiz.layout();
        let last = layout.level_count() - 1;
        let l0 = (libm::floorf(level) as u32).min(last);
        let t = if l0 >= last { 0.0 } else { level - l0 as f32 };
        let a = Self::bilinear(data, layout, l0, p, get, fetches);
        if t <= 0.0 {
            return a;
        }
        let b = Self::bilinear(data, layout, l0 + 1, p, get, fetches);
        let mut out = a;
        for k in 0..N {
            out[k] = a[k] + (b[k] - a[k]) * t;
        }
        out
    }

    /// The sphere weight (module docs) at level `level` (integer) for a
    /// sphere of depth center `z` and depth radius `rz` at pixel `p`.
    #[allow(clippy::too_many_arguments)]
    fn sphere_weight_at(
        &self,
        level: u32,
        p: Vec2,
        z: f32,
        rz: f32,
        tolerance: f32,
        fetches: &mut u32,
    ) -> f32 {
        let layout = self.hiz.layout();
        let l = match layout.level(level) {
            Some(l) => l,
            None => return 0.0,
        };
        // Cell under p, as the Hi-Z footprints define it (the last cell
        // reaches the edge).
        let cx = ((p.x.max(0.0) as u64) >> level).min(u64::from(l.width) - 1) as u32;
        let cy = ((p.y.max(0.0) as u64) >> level).min(u64::from(l.height) - 1) as u32;
        *fetches += 1;
        let t: HiZTexel = self.hiz.texel(level, cx, cy).unwrap_or([f32::NAN; 2]);
        let closest = t[0];
        if !foreground(closest, self.hiz.camera().far()) {
            return 0.0;
        }
        let reach = rz + tolerance * z;
        if reach > 0.0 {
            ((z + reach - closest) / reach).clamp(0.0, 1.0)
        } else if z >= closest {
            1.0
        } else {
            0.0
        }
    }

    fn sphere_weight(
        &self,
        level: f32,
        p: Vec2,
        z: f32,
        rz: f32,
        tolerance: f32,
        fetches: &mut u32,
    ) -> f32 {
        let last = self.hiz.layout().level_count() - 1;
        let l0 = (libm::floorf(level) as u32).min(last);
        let t = if l0 >= last { 0.0 } else { level - l0 as f32 };
        let a = self.sphere_weight_at(l0, p, z, rz, tolerance, fetches);
        if t <= 0.0 {
            return a;
        }
        let b = self.sphere_weight_at(l0 + 1, p, z, rz, tolerance, fetches);
        a + (b - a) * t
    }

    /// Trilinear color at level-0 pixel `p`, mip `level`.
    pub fn sample_color(&self, p: Vec2, level: f32) -> ColorTexel {
        let mut f = 0;
        self.trilinear(self.color, level, p, |c| c, &mut f)
    }

    /// Trilinear visibility at level-0 pixel `p`, mip `level`.
    pub fn sample_visibility(&self, p: Vec2, level: f32) -> f32 {
        let mut f = 0;
        self.trilinear(self.visibility, level, p, |v| [v], &mut f)[0]
    }
}

/// Settings of [`try_cone_trace`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeOptions {
    /// Most circles (clamped to [`MAX_CIRCLES`]); Listing 4.7 takes 7.
    pub max_circles: u32,
    /// Added to the circle's mip level `log2(2 r)`; `-1` is Listing 4.7's
    /// `log2(r)`.
    pub level_bias: f32,
    /// Weight samples by the pre-integrated visibility (Sec. 4.4.2);
    /// without it only the sphere weight counts.
    pub use_visibility: bool,
    /// Largest anisotropic stretch (Sec. 4.6.8): a circle becomes an
    /// ellipse elongated along the cone axis by `min(1 / n_dot_v,
    /// max_stretch)`, sampled by up to [`MAX_STRETCH_SAMPLES`] points along
    /// the axis at the mip level of the minor radius. `1` is isotropic.
    pub max_stretch: f32,
    /// Relative depth tolerance of the sphere weight: the sphere reaches
    /// `rz + depth_tolerance * z` in depth (the hit lies on the surface,
    /// and f32 rounding or a neighboring texel must not put a narrow
    /// cone's sphere just in front of it).
    pub depth_tolerance: f32,
    /// Divide the accumulated color by the accumulated coverage when it is
    /// positive (a weighted mean of the samples), so the fallback only
    /// takes cones no sample covered. Off (the seed's rule): the uncovered
    /// rest `1 - A` blends the fallback.
    pub normalize: bool,
}

impl Default for ConeOptions {
    /// 8 circles, bias 0, visibility on, isotropic, 1% depth tolerance, no
    /// normalization.
    fn default() -> Self {
        Self {
            max_circles: 8,
            level_bias: 0.0,
            use_visibility: true,
            max_stretch: 1.0,
            depth_tolerance: 0.01,
            normalize: false,
        }
    }
}

/// A screen-space cone: apex at the reflection ray's start, axis to its
/// Hi-Z hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// Apex (the ray's start projected), level-0 pixels.
    pub apex: Vec2,
    /// Linear depth of the apex.
    pub apex_depth: f32,
    /// The hit pixel (e.g. [`crate::DepthHit::pixel`]).
    pub hit: Vec2,
    /// Linear depth of the hit (e.g. [`crate::DepthHit::depth`]).
    pub hit_depth: f32,
    /// Half-angle, radians, in `[0, pi/2)`.
    pub theta: f32,
    /// `dot(n, v)` of the reflector (normal and direction toward the eye),
    /// for the anisotropic stretch; use 1 when it is off.
    pub n_dot_v: f32,
    /// World distance from the apex to the hit (e.g. [`crate::DepthHit::t`])
    /// for the view-space cone size, or 0 for the seed's screen-space
    /// triangle (module docs, "Cone size").
    pub travel: f32,
}

/// What [`try_cone_trace`] returns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeResult {
    /// The integrated color, the uncovered rest blended with the fallback.
    pub color: ColorTexel,
    /// Accumulated coverage `A` in `[0, 1]` (1 - weight of the fallback).
    pub coverage: f32,
    /// Circles taken.
    pub circles: u32,
    /// Pyramid texels read.
    pub fetches: u32,
}

/// Integrates the cone `cone` over the pyramids (seed 004 Sec. 4.4.5,
/// Listing 4.7; module docs, "Cone trace").
///
/// # Errors
/// [`Error::InvalidArgument`] for non-finite or non-positive depths,
/// non-finite pixels, `theta` outside `[0, pi/2)`, a non-finite fallback,
/// `n_dot_v` NaN, options with a non-finite bias or a `max_stretch`
/// below 1 or not finite, or `use_visibility` on with pyramids bound
/// without a visibility pyramid.
///
/// # Panics
/// Never.
pub fn try_cone_trace(
    pyramids: &ConePyramids<'_>,
    cone: &Cone,
    fallback: ColorTexel,
    options: &ConeOptions,
) -> Result<ConeResult, Error> {
    let depths_ok = cone.apex_depth > 0.0
        && cone.apex_depth.is_finite()
        && cone.hit_depth > 0.0
        && cone.hit_depth.is_finite();
    let ok = cone.apex.is_finite()
        && cone.hit.is_finite()
        && depths_ok
        && valid_theta(cone.theta)
        && !cone.n_dot_v.is_nan()
        && cone.travel >= 0.0
        && cone.travel.is_finite()
        && finite3(fallback)
        && options.level_bias.is_finite()
        && options.max_stretch >= 1.0
        && options.max_stretch.is_finite()
        && options.depth_tolerance >= 0.0
        && options.depth_tolerance.is_finite();
    if !ok || (options.use_visibility && pyramids.visibility.is_empty()) {
        return Err(Error::InvalidArgument);
    }
    let axis = cone.hit - cone.apex;
    let length = axis.length();
    if !length.is_finite() {
        return Err(Error::InvalidArgument);
    }
    let unit = if length > 0.0 { axis / length } else { Vec2::X };
    // View-space cone size (module docs): the triangle's angle that makes
    // the cone's width at the hit, `2 travel tan(theta)` projected at the
    // hit's depth, the base of the screen triangle.
    let theta = if cone.travel > 0.0 && length > 0.0 && cone.theta > 0.0 {
        let r_px = pyramids.focal * cone.travel * libm::tanf(cone.theta) / cone.hit_depth;
        libm::atanf(r_px / length).min(MAX_VIEW_THETA)
    } else {
        cone.theta
    };
    let max = options.max_circles.min(MAX_CIRCLES);
    let stretch = if cone.n_dot_v > 0.0 {
        (1.0 / cone.n_dot_v).clamp(1.0, options.max_stretch)
    } else {
        options.max_stretch
    };
    let (q1, q2) = (1.0 / cone.apex_depth, 1.0 / cone.hit_depth);
    // Color differences and their weighted sum in f64: a color near
    // f32::MAX against a fallback of the other sign overflows f32 (fuzz
    // finding F19), though the result, a convex combination of the
    // fallback and the pyramid's colors, is finite.
    let mut acc = [0.0f64; 3];
    let mut coverage = 0.0f32;
    let mut fetches = 0u32;
    let mut circles = 0u32;
    // A zero-length axis (the hit at the apex) is one sample at the hit.
    let single = ConeCircle {
        center: 0.0,
        radius: 0.0,
    };
    let mut iter = ConeCircles::try_new(length, theta, max)?;
    let mut first = true;
    loop {
        let circle = match iter.next() {
            Some(c) => c,
            None if first && max > 0 => single,
            None => break,
        };
        first = false;
        circles += 1;
        let level = cone_mip_level(circle.radius, options.level_bias);
        let s = if length > 0.0 {
            (circle.center / length).clamp(0.0, 1.0)
        } else {
            1.0
        };
        // The axis depth over the circle's extent along the axis: the
        // sphere is placed at the deeper of its two edges (the first
        // circle's front edge is the hit itself).
        let axis_depth = |s: f32| 1.0 / (q1 + (q2 - q1) * s.clamp(0.0, 1.0));
        let ds = if length > 0.0 {
            circle.radius / length
        } else {
            0.0
        };
        let z = axis_depth(s - ds).max(axis_depth(s + ds));
        let rz = circle.radius * z / pyramids.focal;
        let n = if stretch > 1.0 {
            (libm::ceilf(stretch) as u32).clamp(1, MAX_STRETCH_SAMPLES)
        } else {
            1
        };
        let (mut c, mut a) = ([0.0f64; 3], 0.0f32);
        for j in 0..n {
            let off = if n > 1 {
                (j as f32 / (n - 1) as f32 * 2.0 - 1.0) * circle.radius * (stretch - 1.0)
            } else {
                0.0
            };
            let p = cone.apex + unit * (circle.center + off);
            let col = pyramids.trilinear(pyramids.color, level, p, |t| t, &mut fetches);
            let vis = if options.use_visibility {
                pyramids.trilinear(pyramids.visibility, level, p, |v| [v], &mut fetches)[0]
            } else {
                1.0
            };
            let w = pyramids.sphere_weight(level, p, z, rz, options.depth_tolerance, &mut fetches);
            let aj = (vis * w).clamp(0.0, 1.0);
            for k in 0..3 {
                c[k] += f64::from(aj) * (f64::from(col[k]) - f64::from(fallback[k]));
            }
            a += aj;
        }
        let inv = 1.0 / n as f32;
        let a = a * inv;
        if a > 0.0 {
            let take = a.min(1.0 - coverage);
            // c / n is the weighted color difference of this circle; its
            // share is scaled down to the weight actually taken.
            let scale = f64::from(take / a * inv);
            for k in 0..3 {
                acc[k] += c[k] * scale;
            }
            coverage += take;
        }
        if coverage >= 1.0 {
            coverage = 1.0;
            break;
        }
    }
    if options.normalize && coverage > 0.0 {
        for a in &mut acc {
            *a /= f64::from(coverage);
        }
    }
    Ok(ConeResult {
        color: [
            (f64::from(fallback[0]) + acc[0]) as f32,
            (f64::from(fallback[1]) + acc[1]) as f32,
            (f64::from(fallback[2]) + acc[2]) as f32,
        ],
        coverage,
        circles,
        fetches,
    })
}

// ------------------------------------------------------------ fades

/// A linear fade: 1 at or below `start`, 0 at or above `end` (seed 004
/// Listing 4.8, `1 - saturate((x - start) / (end - start))`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FadeRange {
    /// Where the fade begins.
    pub start: f32,
    /// Where it reaches 0; must exceed `start`.
    pub end: f32,
}

impl FadeRange {
    /// The fade factor at `x`.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a NaN `x`, non-finite bounds or
    /// `end <= start`.
    pub fn try_at(&self, x: f32) -> Result<f32, Error> {
        if !(self.start.is_finite() && self.end.is_finite() && self.end > self.start) || x.is_nan()
        {
            return Err(Error::InvalidArgument);
        }
        Ok(1.0 - ((x - self.start) / (self.end - self.start)).clamp(0.0, 1.0))
    }
}

/// The fades of seed 004 Sec. 4.6.1; `None` disables one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Fades {
    /// Over `dot(reflected, toward_eye)` in `[-1, 1]`: rays pointing back
    /// toward the camera (large values) fade out (screen space cannot see
    /// what is behind the camera). Listing 4.8 multiplies by
    /// `dot(viewReflect, viewDir)` directly.
    pub toward_camera: Option<FadeRange>,
    /// Over the hit's distance from the screen center, `max(|2u - 1|, |2v -
    /// 1|)` with `(u, v)` the normalized hit position (1 on the border; the
    /// seed's Euclidean distance reaches 1 at edge midpoints but 1.41 in
    /// the corners, the max-norm treats every border alike).
    pub border: Option<FadeRange>,
    /// Over the ray's travel distance (world units, the hit's `t`; the
    /// seed's listing uses screen distance "for simplicity but should be"
    /// world space).
    pub travel: Option<FadeRange>,
}

impl Fades {
    /// The product of the enabled fades for a reflection ray of unit
    /// direction `reflected`, `toward_eye` the unit direction from the
    /// reflector to the eye, hitting at pixel `hit` of a `width x height`
    /// image after traveling `t`.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a zero size, non-finite inputs or a
    /// bad [`FadeRange`].
    pub fn try_factor(
        &self,
        reflected: Vec3,
        toward_eye: Vec3,
        hit: Vec2,
        width: u32,
        height: u32,
        t: f32,
    ) -> Result<f32, Error> {
        if width == 0
            || height == 0
            || !reflected.is_finite()
            || !toward_eye.is_finite()
            || !hit.is_finite()
            || !t.is_finite()
        {
            return Err(Error::InvalidArgument);
        }
        let mut f = 1.0;
        if let Some(r) = self.toward_camera {
            f *= r.try_at(reflected.dot(toward_eye))?;
        }
        if let Some(r) = self.border {
            let u = (2.0 * hit.x / width as f32 - 1.0).abs();
            let v = (2.0 * hit.y / height as f32 - 1.0).abs();
            f *= r.try_at(u.max(v))?;
        }
        if let Some(r) = self.travel {
            f *= r.try_at(t)?;
        }
        Ok(f)
    }
}

/// `fallback + fade (color - fallback)`: a faded screen-space result blends
/// toward the fallback (energy-preserving, unlike Listing 4.8's fade to
/// black).
pub fn blend_fade(color: ColorTexel, fallback: ColorTexel, fade: f32) -> ColorTexel {
    [
        fallback[0] + fade * (color[0] - fallback[0]),
        fallback[1] + fade * (color[1] - fallback[1]),
        fallback[2] + fade * (color[2] - fallback[2]),
    ]
}

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
/// is traced with [`try_trace_hiz`] from `ray.origin`; a hit reads the
/// level-0 color under the hit pixel, a miss `fallback(dir)`. The result
/// is the mean weighted by [`phong_lobe_weight`] of each direction
/// (`power` the Phong power; with no ray traced, the axis's
/// `fallback`).
///
/// # Errors
/// [`Error::InvalidArgument`] for a ray, `t_max` or thickness rejected by
/// [`try_trace_hiz`], a non-finite normal or rotation, `theta` outside `[0,
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
    for i in 0..n {
        let xi = crate::lobe::hammersley(i, n) + options.rotation;
        let xi = xi - xi.floor();
        let dir = cone_ray_direction(axis, theta, xi);
        if dir.dot(normal) <= 0.0 {
            continue;
        }
        traced += 1;
        let trace = try_trace_hiz(
            hiz,
            thickness,
            Ray {
                origin: ray.origin,
                dir,
            },
            t_max,
            &options.hiz,
        )?;
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
