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
//!    [`HiZLayout`](crate::hiz::HiZLayout)), into a caller buffer of [`try_color_pyramid_len`] texels
//!    ending with its [`PyramidStamp`](crate::hiz::PyramidStamp).
//! 3. [`try_build_visibility_pyramid`]: per texel, the pre-integrated share
//!    of the cell that blocks rays (module section "Visibility"), into a
//!    caller buffer of [`try_visibility_pyramid_len`] floats ending with its
//!    [`PyramidStamp`](crate::hiz::PyramidStamp); [`ConePyramids::try_new`] checks both stamps
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

mod fade;
mod multiray;
mod pyramid;
mod trace;

pub use fade::{blend_fade, FadeRange, Fades};
pub use multiray::{try_multiray, MultiRayOptions, MultiRayResult};
pub use pyramid::{
    convolution_weights, try_build_color_level0_rows, try_build_color_level_rows,
    try_build_color_pyramid, try_build_visibility_level0_rows, try_build_visibility_level_rows,
    try_build_visibility_pyramid, try_color_pyramid_len, try_stamp_color_pyramid,
    try_stamp_visibility_pyramid, try_visibility_pyramid_len, COLOR_STAMP_TEXELS, DEFAULT_SIGMA,
    KERNEL_RADIUS, VISIBILITY_STAMP_LEN,
};
pub use trace::{
    cone_mip_level, isosceles_inradius, isosceles_opposite, try_cone_trace, Cone, ConeCircle,
    ConeCircles, ConeOptions, ConePyramids, ConeResult, MAX_CIRCLES, MAX_STRETCH_SAMPLES,
    MAX_VIEW_THETA,
};

/// One color texel, linear RGB.
pub type ColorTexel = [f32; 3];

// ------------------------------------------------------------ cone angle

/// The lobe math of the cone angle and the multi-ray directions lives in
/// [`crate::lobe`]; these are its names in the cone family.
pub use crate::lobe::{
    cone_ray_direction, phong_lobe_weight, try_cone_angle_from_phong,
    try_cone_angle_from_roughness, try_phong_power_from_roughness, CONE_XI, MIRROR_POWER_END,
    MIRROR_POWER_START,
};
