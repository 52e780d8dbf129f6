//! The glossy reflection pass: G-buffer and lit color in, per reflective
//! pixel a pre-convolved reflection color by screen-space cone tracing
//! (seed 004 Sec. 4.4 / 4.5: Hi-Z trace of the mirror ray, cone over the
//! pre-convolved color pyramid and the pre-integrated visibility pyramid,
//! fades of Sec. 4.6.1) or by several Hi-Z rays in the cone (seed 003
//! Sec. 3.5), the weight the host's probe must take where the screen does
//! not cover the lobe, and the pixels the screen cannot answer as world
//! rays for the host's own tracer (design.md, "Passes"; issue 13).
//!
//! The pass is the sequence `crate::cone` documents, with its glue: an
//! engine calls [`try_glossy_scratch_len`] (caller memory for the three
//! pyramids), [`try_prepare_glossy`] once per frame (validation, the
//! pyramids), then [`GlossyPass::try_new`] and [`GlossyPass::try_run`] (or
//! [`GlossyPass::try_run_rows`]) over row bands from its threads.
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::{try_glossy_scratch_len, try_prepare_glossy, Camera, DepthConvention};
//! use refl_core::{DepthImage, GBuffer, GlossyOptions, GlossyPass, GlossyScratch};
//! use refl_core::{GlossyScratchMut, GlossyTexel, ImageView, ImageViewMut, MirrorStatus, NormalSpace};
//!
//! // 16 x 16 pixels: the eye 1 above the floor y = 0, looking down -Z at a wall at z = -4.
//! let cam = Camera::try_look_at(Vec3::Y, Vec3::new(0.0, 1.0, -1.0), Vec3::Y, FRAC_PI_2, 0.1, 100.0, 16, 16)?;
//! let (mut depth, mut normals) = (vec![4.0f32; 256], vec![[0.0, 0.0, 1.0f32]; 256]);
//! for (i, (d, n)) in depth.iter_mut().zip(&mut normals).enumerate() {
//!     // Row y looks along NDC y = 1 - (2 y + 1) / 16 and meets the floor at depth -1 / NDC y.
//!     let floor = -1.0 / (1.0 - (2 * (i / 16) + 1) as f32 / 16.0);
//!     if (0.0..4.0).contains(&floor) {
//!         (*d, *n) = (floor, [0.0, 1.0, 0.0]);
//!     }
//! }
//! // One lit color; roughness 0.5, except pixel (9, 13), left to the mirror pass.
//! let (lit, mut rough) = (vec![[0.2f32, 0.4, 0.6]; 256], vec![0.5f32; 256]);
//! rough[13 * 16 + 9] = 0.05;
//! let depth = DepthImage::try_new(ImageView::try_new(&depth, 16, 16, 16)?, cam, DepthConvention::Linear)?;
//! let gbuffer = GBuffer::try_new(depth, ImageView::try_new(&normals, 16, 16, 16)?, NormalSpace::World)?
//!     .try_with_color(ImageView::try_new(&lit, 16, 16, 16)?)?
//!     .try_with_roughness(ImageView::try_new(&rough, 16, 16, 16)?)?;
//!
//! // Once per frame: the pyramids in caller memory.
//! let options = GlossyOptions::default();
//! let len = try_glossy_scratch_len(16, 16, &options)?;
//! let mut hiz = vec![[0.0f32; 2]; len.hiz];
//! let (mut color, mut visibility) = (vec![[0.0f32; 3]; len.color], vec![0.0f32; len.visibility]);
//! let scratch = GlossyScratchMut { hiz: &mut hiz, color: &mut color, visibility: &mut visibility };
//! try_prepare_glossy(scratch, &gbuffer, &options)?;
//! let scratch = GlossyScratch { hiz: &hiz, color: &color, visibility: &visibility };
//! let pass = GlossyPass::try_new(gbuffer, options, scratch)?;
//! let (mut out, mut rgb) = (vec![GlossyTexel::default(); 256], vec![[0.0f32; 3]; 256]);
//! let mut rgb_view = ImageViewMut::try_new(&mut rgb, 16, 16, 16)?;
//! pass.try_run(&mut ImageViewMut::try_new(&mut out, 16, 16, 16)?, Some(&mut rgb_view), &mut [])?;
//!
//! // Pixel (8, 13): the axis from the floor point P hits the wall at Q, pixel
//! // (8.5, 6.5), as in the mirror pass; the cone, all on the wall, returns its
//! // color and leaves nothing to the probe.
//! let (p, q) = (Vec3::new(1.0 / 11.0, 0.0, -16.0 / 11.0), Vec3::new(0.25, 1.75, -4.0));
//! let texel = out[13 * 16 + 8];
//! assert_eq!(texel.status, MirrorStatus::Hit);
//! assert!((texel.pixel - Vec2::new(8.5, 6.5)).length() < 0.05);
//! assert!((texel.dir - (q - p).normalize()).length() < 1e-4);
//! assert!((Vec3::from(rgb[13 * 16 + 8]) - Vec3::new(0.2, 0.4, 0.6)).length() < 1e-4);
//! assert_eq!(texel.fallback_weight, 0.0);
//! assert_eq!(out[13 * 16 + 9].status, MirrorStatus::Skipped);
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! # Per pixel
//! 1. **Glossy?** A pixel is traced when its mask (if any) is non-zero and
//!    its roughness lies in `(min_roughness, max_roughness]`
//!    ([`GlossyOptions::min_roughness`], [`GlossyOptions::max_roughness`]);
//!    otherwise (NaN roughness included) [`MirrorStatus::Skipped`]. By
//!    default pixels at or below roughness 0.1 are left to the mirror pass
//!    (`crate::ssr`, whose default `max_roughness` is the same 0.1): with
//!    both passes at their defaults every reflective pixel is handled by
//!    exactly one. A negative `min_roughness` traces every roughness;
//!    roughness 0 then gets a cone of angle 0, which samples the color
//!    pyramid's level 0 bilinearly at the mirror pass's hit (normalized:
//!    that sample with weight 0 for the probe, unless the hit lies more
//!    than the cone's depth tolerance in front of its texel's stored depth,
//!    where the seed's sphere weight is 0 and the probe takes the pixel:
//!    8.6% of the hits on the test scene of `core/tests/glossy.rs`).
//! 2. **Axis.** The mirror ray is generated, started, traced with the Hi-Z
//!    and validated exactly as the mirror pass does it (`crate::ssr`, module
//!    docs, steps 2 to 7; the same code: a `MirrorPass` with
//!    [`GlossyOptions::mirror_options`]). Its status, hit pixel and `t` are
//!    the texel's; the statuses that need the host append the same
//!    [`HostRay`] the mirror pass would.
//! 3. **Cone** ([`GlossyMethod::Cone`], on a validated hit): half-angle
//!    `theta` from the roughness ([`crate::cone::try_cone_angle_from_roughness`],
//!    roughness clamped to `[0, 1]`), apex at the ray's start
//!    `P + t_start r` projected ([`crate::Camera::project`]: pixel and
//!    linear depth), hit at the validated hit pixel with the linear depth of
//!    `P + t r` ([`crate::Camera::linear_depth`]), `n_dot_v` the normal
//!    (facing the eye) against the unit direction toward the eye, travel
//!    `t - t_start` when [`GlossyOptions::view_space`] is set (0 else);
//!    [`crate::cone::try_cone_trace`] with a black fallback gives the
//!    covered color `S` and the coverage `A`.
//! 4. **Fades** ([`GlossyOptions::fades`], seed 004 Sec. 4.6.1): the factor
//!    `f` of [`crate::cone::Fades::try_factor`] for the ray direction, the
//!    direction toward the eye, the hit pixel and the travel `t - t_start`.
//! 5. **Out.** Color `f S` ([`crate::cone::blend_fade`] toward black) and
//!    the probe's weight `1 - f A` (seed's rule) or `1 - f` (with
//!    [`crate::cone::ConeOptions::normalize`] and `A > 0`, where `S` is
//!    already a mean): the host's final color is `color + fallback_weight *
//!    probe`, with its probe sampled in [`GlossyTexel::dir`] at the pixel's
//!    roughness. This is `fallback + f (C - fallback)` for the cone result
//!    `C` with the probe as its fallback (what the root package blended)
//!    in another order of the f32 operations. A pixel without a hit has
//!    color 0 and weight 1.
//!
//! [`GlossyMethod::MultiRay`] replaces 3 and 4 on every pixel whose axis
//! was traced (hit or not): [`crate::cone::try_multiray`] from the axis's
//! start point (`P + t_start r`, up to `t_max - t_start`) with
//! [`GlossyOptions::rays`] rays, the Phong power of the roughness (capped at
//! [`MULTIRAY_MAX_POWER`]), a per-pixel rotation ([`multiray_rotation`])
//! and a black fallback; the color is the mean over the rays that hit and
//! the weight the missed share of the lobe
//! ([`crate::cone::MultiRayResult::fallback_weight`]). Its rays are not
//! validated (the kernel's own hits, as seed 003 takes them).
//!
//! Pixels the pass does not handle ([`MirrorStatus::Skipped`],
//! [`MirrorStatus::NoSurface`]) have color 0 and weight 0.

use crate::cone::{
    blend_fade, try_build_color_level0_rows, try_build_visibility_pyramid, try_color_pyramid_len,
    try_cone_angle_from_roughness, try_cone_trace, try_multiray, try_phong_power_from_roughness,
    try_stamp_color_pyramid, try_visibility_pyramid_len, ColorTexel, Cone, ConeOptions,
    ConePyramids, Fades, MultiRayOptions, DEFAULT_SIGMA,
};
use crate::hiz::{try_build_hiz, try_hiz_len, HiZ, HiZLayout, HiZOptions, HiZTexel};
use crate::ssr::{AxisTrace, ImageSink};
use crate::{
    Error, GBuffer, HostRay, ImageViewMut, MirrorMethod, MirrorOptions, MirrorPass, MirrorRay,
    MirrorStatus, RowRange, Thickness,
};
use glam::{Vec2, Vec3};

/// Highest Phong power the multi-ray method weights with (roughness near 0
/// gives powers up to `+inf`, whose `cos^power` is 0 off the axis).
pub const MULTIRAY_MAX_POWER: f32 = 1e6;

/// How the pass integrates the lobe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GlossyMethod {
    /// Cone tracing over the pyramids (seed 004 Sec. 4.4.5).
    Cone,
    /// Several Hi-Z rays in the cone, Phong-weighted (seed 003 Sec. 3.5).
    MultiRay,
}

/// Settings of the glossy pass. [`GlossyOptions::default`] is the best
/// cone setting `refl report` measured on the room's glossy variants
/// (README, "The report": 8 circles, normalized, visibility off) with the
/// mirror pass's axis settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlossyOptions {
    /// Cone tracing or multi-ray.
    pub method: GlossyMethod,
    /// Cone-trace settings ([`GlossyMethod::Cone`]).
    pub cone: ConeOptions,
    /// Fades toward the probe (seed 004 Sec. 4.6.1; [`GlossyMethod::Cone`]).
    pub fades: Fades,
    /// Size the cone from its world travel ([`crate::cone::Cone::travel`])
    /// instead of the seed's screen-space triangle.
    pub view_space: bool,
    /// Standard deviation of the color pyramid's Gaussian, finer texels
    /// (finite, `> 0`; [`DEFAULT_SIGMA`]).
    pub sigma: f32,
    /// Rays per pixel of [`GlossyMethod::MultiRay`] (`> 0`).
    pub rays: u32,
    /// Hi-Z settings of the axis (and of every multi-ray ray).
    pub hiz: HiZOptions,
    /// Surface thickness without a back-face image, relative to the
    /// reflecting pixel's linear depth (finite, `>= 0`), as
    /// [`MirrorOptions::thickness`].
    pub thickness: f32,
    /// Where a ray starts (finite, `>= 0`), as
    /// [`MirrorOptions::start_pixels`].
    pub start_pixels: f32,
    /// The ray starts no earlier (finite, `>= 0`).
    pub t_min: f32,
    /// The longest ray (`> t_min`; `+inf` allowed).
    pub t_max: f32,
    /// Pixels with a roughness at or below this are not traced (left to
    /// the mirror pass; module docs, step 1). Not NaN, `< max_roughness`.
    pub min_roughness: f32,
    /// Pixels with a roughness above this are not traced. Not NaN.
    pub max_roughness: f32,
    /// Refine axis hits to sub-pixel precision.
    pub refine: bool,
    /// Refuse axis hits on surfaces that face along the ray.
    pub reject_back_faces: bool,
    /// Refuse axis hits inside the thickness that are not on the visible
    /// surface.
    pub reject_hidden_hits: bool,
}

impl Default for GlossyOptions {
    /// Cone tracing with 8 circles, normalized, without visibility
    /// weighting, no fades, the seed's screen-space triangle, sigma
    /// [`DEFAULT_SIGMA`]; 8 rays for multi-ray; roughness in `(0.1, 1]`;
    /// the mirror pass's defaults for the axis (Hi-Z defaults, thickness
    /// 0.5, start after 1 pixel, `t_min = 0`, `t_max = +inf`, refined hits,
    /// back faces and hidden hits refused).
    fn default() -> Self {
        let m = MirrorOptions::default();
        Self {
            method: GlossyMethod::Cone,
            cone: ConeOptions {
                max_circles: 8,
                normalize: true,
                use_visibility: false,
                ..ConeOptions::default()
            },
            fades: Fades::default(),
            view_space: false,
            sigma: DEFAULT_SIGMA,
            rays: 8,
            hiz: HiZOptions::default(),
            thickness: m.thickness,
            start_pixels: m.start_pixels,
            t_min: m.t_min,
            t_max: m.t_max,
            min_roughness: m.max_roughness,
            max_roughness: 1.0,
            refine: m.refine,
            reject_back_faces: m.reject_back_faces,
            reject_hidden_hits: m.reject_hidden_hits,
        }
    }
}

impl GlossyOptions {
    /// The mirror pass's options the axis is traced with: Hi-Z with
    /// [`GlossyOptions::hiz`], the same thickness, start, `t_min`, `t_max`,
    /// refinement and validation, no roughness limit (the glossy pass
    /// selects its pixels itself) and no border fade (the cone's fades
    /// apply instead).
    pub fn mirror_options(&self) -> MirrorOptions {
        MirrorOptions {
            method: MirrorMethod::HiZ,
            hiz: self.hiz,
            thickness: self.thickness,
            start_pixels: self.start_pixels,
            t_min: self.t_min,
            t_max: self.t_max,
            max_roughness: f32::INFINITY,
            border_fade: 0.0,
            refine: self.refine,
            reject_back_faces: self.reject_back_faces,
            reject_hidden_hits: self.reject_hidden_hits,
            ..MirrorOptions::default()
        }
    }

    /// Whether the pass reads a visibility pyramid.
    pub fn uses_visibility(&self) -> bool {
        self.method == GlossyMethod::Cone && self.cone.use_visibility
    }

    /// Checks every option's range (see the fields); the pass's calls do
    /// it themselves.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for an option out of its range.
    pub fn try_validate(&self) -> Result<(), Error> {
        let c = &self.cone;
        let fades_ok = [
            self.fades.toward_camera,
            self.fades.border,
            self.fades.travel,
        ]
        .iter()
        .flatten()
        .all(|r| r.start.is_finite() && r.end.is_finite() && r.end > r.start);
        let ok = self.sigma > 0.0
            && self.sigma.is_finite()
            && self.rays > 0
            && !self.min_roughness.is_nan()
            && self.min_roughness < self.max_roughness
            && c.level_bias.is_finite()
            && c.max_stretch >= 1.0
            && c.max_stretch.is_finite()
            && c.depth_tolerance >= 0.0
            && c.depth_tolerance.is_finite()
            && fades_ok;
        if !ok {
            return Err(Error::InvalidArgument);
        }
        // The axis options (thickness, start, t_min, t_max) as the mirror
        // pass checks them.
        crate::ssr::validate_options(&self.mirror_options())
    }
}

/// Elements of each part of a glossy pass's caller memory
/// ([`try_glossy_scratch_len`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct GlossyScratchLen {
    /// Hi-Z texels ([`crate::hiz::try_hiz_len`]).
    pub hiz: usize,
    /// Color pyramid texels ([`crate::cone::try_color_pyramid_len`]).
    pub color: usize,
    /// Visibility pyramid floats ([`crate::cone::try_visibility_pyramid_len`],
    /// or 0 when the options read none: [`GlossyOptions::uses_visibility`]).
    pub visibility: usize,
}

impl GlossyScratchLen {
    /// The three parts back to back in one buffer of `f32`s (Hi-Z, color,
    /// visibility; what the C ABI's scratch holds), or `None` on overflow.
    pub fn floats(&self) -> Option<usize> {
        self.hiz
            .checked_mul(2)?
            .checked_add(self.color.checked_mul(3)?)?
            .checked_add(self.visibility)
    }
}

/// The caller memory of a glossy pass for [`try_prepare_glossy`]: each
/// part at least its [`GlossyScratchLen`] long.
#[derive(Debug)]
pub struct GlossyScratchMut<'s> {
    /// The Hi-Z pyramid.
    pub hiz: &'s mut [HiZTexel],
    /// The color pyramid.
    pub color: &'s mut [ColorTexel],
    /// The visibility pyramid (may be empty when not used).
    pub visibility: &'s mut [f32],
}

/// The prepared caller memory of a glossy pass, for [`GlossyPass::try_new`].
#[derive(Clone, Copy, Debug)]
pub struct GlossyScratch<'s> {
    /// The Hi-Z pyramid.
    pub hiz: &'s [HiZTexel],
    /// The color pyramid.
    pub color: &'s [ColorTexel],
    /// The visibility pyramid (empty when not used).
    pub visibility: &'s [f32],
}

/// Elements of the caller memory a glossy pass over a `width x height`
/// frame needs with `options`.
///
/// # Errors
/// [`Error::InvalidArgument`] for a zero or overflowing size.
pub fn try_glossy_scratch_len(
    width: u32,
    height: u32,
    options: &GlossyOptions,
) -> Result<GlossyScratchLen, Error> {
    Ok(GlossyScratchLen {
        hiz: try_hiz_len(width, height)?,
        color: try_color_pyramid_len(width, height)?,
        visibility: if options.uses_visibility() {
            try_visibility_pyramid_len(width, height)?
        } else {
            0
        },
    })
}

fn gbuffer_inputs(gbuffer: &GBuffer<'_>) -> Result<(), Error> {
    if gbuffer.color().is_none() || gbuffer.roughness().is_none() {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

/// Prepares a frame: validates `gbuffer` (it must carry a lit color and a
/// roughness image) and `options`, and builds into `dst` the Hi-Z pyramid
/// of the depth, the color pyramid of the lit color (every level for the
/// cone; level 0 only, still stamped, for multi-ray, which reads no other)
/// and, when the options read it, the visibility pyramid. Each ends with
/// its stamp, which [`GlossyPass::try_new`] checks.
///
/// The build is serial; a host that builds pyramids on its threads can
/// use the row-band kernels (`crate::hiz::try_build_hiz_level_rows`,
/// `crate::cone::try_build_color_level_rows`,
/// `crate::cone::try_build_visibility_level_rows` and the stamps) into
/// the same parts instead.
///
/// # Errors
/// * [`Error::InvalidArgument`]: an option out of its range (see
///   [`GlossyOptions`]); a G-buffer without color or roughness; a
///   non-finite lit color texel.
/// * [`Error::InsufficientSize`]: a part shorter than
///   [`try_glossy_scratch_len`] says.
///
/// Nothing is written on error.
pub fn try_prepare_glossy(
    dst: GlossyScratchMut<'_>,
    gbuffer: &GBuffer<'_>,
    options: &GlossyOptions,
) -> Result<(), Error> {
    options.try_validate()?;
    gbuffer_inputs(gbuffer)?;
    let (w, h) = (gbuffer.width(), gbuffer.height());
    let need = try_glossy_scratch_len(w, h, options)?;
    if dst.hiz.len() < need.hiz
        || dst.color.len() < need.color
        || dst.visibility.len() < need.visibility
    {
        return Err(Error::InsufficientSize);
    }
    let color = gbuffer.color().ok_or(Error::InvalidArgument)?;
    // The color first: its build validates every texel before it writes.
    if options.method == GlossyMethod::Cone {
        crate::cone::try_build_color_pyramid(dst.color, color, options.sigma)?;
    } else {
        let l0 = HiZLayout::try_new(w, h)?
            .level(0)
            .ok_or(Error::InvalidArgument)?;
        try_build_color_level0_rows(&mut dst.color[l0.range()], color, RowRange::try_all(h)?)?;
        try_stamp_color_pyramid(dst.color, w, h)?;
    }
    try_build_hiz(dst.hiz, gbuffer.depth())?;
    if options.uses_visibility() {
        let hiz = HiZ::try_new(dst.hiz, *gbuffer.camera(), gbuffer.convention())?;
        try_build_visibility_pyramid(dst.visibility, &hiz)?;
    }
    Ok(())
}

/// The rotation of the multi-ray Hammersley set at pixel `(x, y)` of an
/// image `width` pixels wide: [`crate::lobe::hash_rotation`] of
/// [`pixel_hash`] of the pixel index, in `[0, 1)^2` (decorrelates
/// neighboring pixels).
pub fn multiray_rotation(x: u32, y: u32, width: u32) -> Vec2 {
    crate::lobe::hash_rotation(pixel_hash(y.wrapping_mul(width).wrapping_add(x)))
}

/// The per-pixel hash of the multi-ray rotation ([`crate::lobe::pixel_hash`]).
pub use crate::lobe::pixel_hash;

/// One pixel of the glossy pass's output.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GlossyTexel {
    /// What happened to the pixel's mirror ray (the cone's axis; module
    /// docs, step 2).
    pub status: MirrorStatus,
    /// Sub-pixel position of the axis hit; `[0, 0]` without a hit.
    pub pixel: Vec2,
    /// Distance from the surface point to the axis hit; 0 without a hit.
    pub t: f32,
    /// Share of the lobe the screen covered: the cone's coverage `A`, or
    /// multi-ray's `1 - fallback_weight`; 0 without a result.
    pub coverage: f32,
    /// The fades' factor (cone with a hit; 1 for multi-ray, 0 otherwise).
    pub fade: f32,
    /// The weight of the host's probe: final color `color +
    /// fallback_weight * probe` (module docs, step 5). 1 where the screen
    /// answered nothing, 0 for pixels the pass does not handle.
    pub fallback_weight: f32,
    /// The unit mirror direction, where to sample the probe; 0 for pixels
    /// the pass does not handle.
    pub dir: Vec3,
}

/// Counts of one run over a band.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GlossyStats {
    /// Pixels traced (glossy, with a surface).
    pub traced: u32,
    /// Validated axis hits.
    pub hits: u32,
    /// Axes answered as sky.
    pub sky: u32,
    /// Pixels that need the host's tracer.
    pub host_rays: u32,
    /// Of those, the ones written to the host list.
    pub host_rays_written: u32,
    /// Cone circles taken, summed over the pixels.
    pub circles: u64,
    /// Multi-ray rays traced (not below the surface), summed.
    pub lobe_rays: u64,
    /// Multi-ray rays that hit in screen space, summed.
    pub lobe_hits: u64,
}

/// Where [`GlossyPass::try_run_rows`] puts its results.
pub trait GlossySink {
    /// Pixel `(x, y)`'s texel and reflection color (module docs, step 5).
    fn texel(&mut self, x: u32, y: u32, texel: &GlossyTexel, color: ColorTexel);
    /// Host ray number `index` of this run (row-major, counting only those
    /// stored); returns `false` if it was not stored (the list is full).
    fn host(&mut self, index: u32, ray: &HostRay) -> bool;
}

/// One pixel's result with the work it took.
#[derive(Clone, Copy, Debug, Default)]
struct PixelOut {
    texel: GlossyTexel,
    color: ColorTexel,
    host: Option<HostRay>,
    circles: u32,
    lobe_rays: u32,
    lobe_hits: u32,
}

/// The glossy pass over one prepared frame (module docs).
#[derive(Clone, Copy, Debug)]
pub struct GlossyPass<'a> {
    axis: MirrorPass<'a>,
    pyramids: ConePyramids<'a>,
    options: GlossyOptions,
}

impl<'a> GlossyPass<'a> {
    /// Describes the pass over `gbuffer` with `options` and the pyramids
    /// [`try_prepare_glossy`] built into `scratch`.
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: an option out of its range; a
    ///   G-buffer without color or roughness; a pyramid not prepared for
    ///   this G-buffer (another camera, size or depth convention, or never
    ///   built: its stamp), or no visibility pyramid where the options read
    ///   one.
    /// * [`Error::InsufficientSize`]: a part shorter than
    ///   [`try_glossy_scratch_len`] says.
    pub fn try_new(
        gbuffer: GBuffer<'a>,
        options: GlossyOptions,
        scratch: GlossyScratch<'a>,
    ) -> Result<Self, Error> {
        options.try_validate()?;
        gbuffer_inputs(&gbuffer)?;
        let need = try_glossy_scratch_len(gbuffer.width(), gbuffer.height(), &options)?;
        if scratch.hiz.len() < need.hiz
            || scratch.color.len() < need.color
            || scratch.visibility.len() < need.visibility
        {
            return Err(Error::InsufficientSize);
        }
        let hiz = HiZ::try_new(scratch.hiz, *gbuffer.camera(), gbuffer.convention())?;
        let vis = if options.uses_visibility() {
            scratch.visibility
        } else {
            &[]
        };
        let pyramids = ConePyramids::try_new(hiz, scratch.color, vis)?;
        let axis = MirrorPass::try_new(gbuffer, options.mirror_options(), Some(hiz))?;
        Ok(Self {
            axis,
            pyramids,
            options,
        })
    }

    /// The G-buffer.
    pub const fn gbuffer(&self) -> &GBuffer<'a> {
        self.axis.gbuffer()
    }

    /// The options.
    pub const fn options(&self) -> &GlossyOptions {
        &self.options
    }

    /// The mirror pass that traces the axes.
    pub const fn axis_pass(&self) -> &MirrorPass<'a> {
        &self.axis
    }

    /// The pyramids the pass reads.
    pub const fn pyramids(&self) -> &ConePyramids<'a> {
        &self.pyramids
    }

    /// The roughness of pixel `(x, y)` if the pass traces it (module docs,
    /// step 1; the mask is the mirror pass's).
    fn glossy_roughness(&self, x: u32, y: u32) -> Option<f32> {
        let r = self.gbuffer().roughness()?.get(x, y)?;
        (r > self.options.min_roughness && r <= self.options.max_roughness).then_some(r)
    }

    /// The host ray of pixel `(x, y)` as the pass would hand it over with
    /// `status`, or `None` for a pixel the pass does not trace or that has
    /// no reflection ray.
    pub fn host_ray(&self, x: u32, y: u32, status: MirrorStatus) -> Option<HostRay> {
        self.glossy_roughness(x, y)?;
        self.axis.host_ray(x, y, status)
    }

    /// Traces one pixel: its texel, its reflection color and, for the
    /// statuses of [`MirrorStatus::needs_host`], its host ray.
    pub fn pixel(&self, x: u32, y: u32) -> (GlossyTexel, ColorTexel, Option<HostRay>) {
        let p = self.pixel_out(x, y);
        (p.texel, p.color, p.host)
    }

    fn pixel_out(&self, x: u32, y: u32) -> PixelOut {
        let Some(roughness) = self.glossy_roughness(x, y) else {
            return PixelOut::default();
        };
        self.pixel_from_axis(x, y, roughness, self.axis.trace_axis(x, y))
    }

    /// [`Self::pixel_out`] of a glossy pixel of roughness `roughness`
    /// whose mirror axis was traced as `a`.
    fn pixel_from_axis(&self, x: u32, y: u32, roughness: f32, a: AxisTrace) -> PixelOut {
        let mut out = PixelOut::default();
        out.texel.status = a.texel.status;
        out.host = a.host;
        let Some(ray) = a.ray else {
            return out;
        };
        out.texel.dir = ray.dir;
        out.texel.fallback_weight = 1.0;
        let roughness = roughness.clamp(0.0, 1.0);
        let done = match self.options.method {
            GlossyMethod::Cone if a.texel.status == MirrorStatus::Hit => {
                out.texel.pixel = a.texel.pixel;
                out.texel.t = a.texel.t;
                self.cone(&ray, a.texel.pixel, a.texel.t, roughness, &mut out)
            }
            GlossyMethod::MultiRay if a.traced => {
                out.texel.pixel = a.texel.pixel;
                out.texel.t = a.texel.t;
                self.multiray(&ray, x, y, roughness, &mut out)
            }
            _ => Ok(()),
        };
        if done.is_err() {
            // Not reached for a validated pass (a unit direction, a start
            // in front of the camera, validated options); handed over
            // rather than lost, as the mirror pass does.
            out.texel = GlossyTexel {
                status: MirrorStatus::NoProjection,
                fallback_weight: 1.0,
                dir: ray.dir,
                ..GlossyTexel::default()
            };
            out.color = [0.0; 3];
            out.host = self.axis.host_ray(x, y, MirrorStatus::NoProjection);
        }
        out
    }

    /// Module docs, steps 3 to 5.
    fn cone(
        &self,
        ray: &MirrorRay,
        hit: Vec2,
        t: f32,
        roughness: f32,
        out: &mut PixelOut,
    ) -> Result<(), Error> {
        let cam = self.gbuffer().camera();
        let theta = try_cone_angle_from_roughness(roughness)?;
        let apex = cam
            .project(ray.origin + ray.dir * ray.t_start)
            .ok_or(Error::DegenerateGeometry)?;
        let toward_eye = (cam.eye() - ray.origin).normalize_or_zero();
        let travel = t - ray.t_start;
        let cone = Cone {
            apex: apex.truncate(),
            apex_depth: apex.z,
            hit,
            hit_depth: cam.linear_depth(ray.origin + ray.dir * t),
            theta,
            n_dot_v: ray.normal.dot(toward_eye),
            travel: if self.options.view_space { travel } else { 0.0 },
        };
        let r = try_cone_trace(&self.pyramids, &cone, [0.0; 3], &self.options.cone)?;
        let (w, h) = (self.gbuffer().width(), self.gbuffer().height());
        let f = self
            .options
            .fades
            .try_factor(ray.dir, toward_eye, hit, w, h, travel)?;
        let covered = if self.options.cone.normalize && r.coverage > 0.0 {
            1.0
        } else {
            r.coverage
        };
        out.color = blend_fade(r.color, [0.0; 3], f);
        out.texel.coverage = r.coverage;
        out.texel.fade = f;
        out.texel.fallback_weight = 1.0 - f * covered;
        out.circles = r.circles;
        Ok(())
    }

    /// The multi-ray variant (module docs).
    fn multiray(
        &self,
        ray: &MirrorRay,
        x: u32,
        y: u32,
        roughness: f32,
        out: &mut PixelOut,
    ) -> Result<(), Error> {
        let theta = try_cone_angle_from_roughness(roughness)?;
        let power = try_phong_power_from_roughness(roughness)?.min(MULTIRAY_MAX_POWER);
        let thickness = match self.gbuffer().back_depth() {
            Some(b) => Thickness::BackFaces(*b),
            None => Thickness::Constant(ray.thickness),
        };
        let opts = MultiRayOptions {
            rays: self.options.rays,
            rotation: multiray_rotation(x, y, self.gbuffer().width()),
            hiz: self.options.hiz,
        };
        let r = try_multiray(
            &self.pyramids,
            thickness,
            ray.kernel_ray(),
            ray.normal,
            self.options.t_max - ray.t_start,
            theta,
            power,
            &opts,
            |_| [0.0; 3],
        )?;
        out.color = r.color;
        out.texel.coverage = 1.0 - r.fallback_weight;
        out.texel.fade = 1.0;
        out.texel.fallback_weight = r.fallback_weight;
        out.lobe_rays = r.traced;
        out.lobe_hits = r.hits;
        Ok(())
    }

    /// Runs the pass over the rows `out` owns (a whole image or a band
    /// from [`ImageViewMut::try_band`]): writes every pixel's
    /// [`GlossyTexel`], its reflection color into `color` if given, and
    /// appends the pixels that need the host's tracer to `host` in
    /// row-major order, as far as `host` holds them.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `out` or `color` is not the
    /// G-buffer's size, or their bands differ. Nothing is written then.
    pub fn try_run(
        &self,
        out: &mut ImageViewMut<'_, GlossyTexel>,
        color: Option<&mut ImageViewMut<'_, ColorTexel>>,
        host: &mut [HostRay],
    ) -> Result<GlossyStats, Error> {
        let (w, h) = (self.gbuffer().width(), self.gbuffer().height());
        match ImageSink::try_new(out, color, host, w, h)? {
            Some((rows, mut sink)) => Ok(self.run_rows(rows, &mut sink)),
            None => Ok(GlossyStats::default()),
        }
    }

    /// Runs the pass over `rows` and hands every pixel's texel and color,
    /// and every host ray in row-major order, to `sink` (the loop of
    /// [`GlossyPass::try_run`] for buffers that are not
    /// [`ImageViewMut`]s; refl-ffi writes C structs through it).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `rows` ends beyond the G-buffer's
    /// height. Nothing is handed to `sink` then.
    pub fn try_run_rows(
        &self,
        rows: RowRange,
        sink: &mut impl GlossySink,
    ) -> Result<GlossyStats, Error> {
        if rows.end() > self.gbuffer().height() {
            return Err(Error::InvalidArgument);
        }
        Ok(self.run_rows(rows, sink))
    }

    fn run_rows(&self, rows: RowRange, sink: &mut impl GlossySink) -> GlossyStats {
        let mut stats = GlossyStats::default();
        // A Hi-Z axis with constant thickness: the mirror axes of a row's
        // glossy pixels are traced in batches (`MirrorPass::axes_batched`),
        // the same traces as pixel by pixel.
        if let Some(hiz) = self.axis.batch_hiz() {
            for y in rows.rows() {
                self.axis.axes_batched(
                    hiz,
                    y,
                    |x| self.glossy_roughness(x, y).is_some(),
                    |x, a| {
                        let p = match (a, self.glossy_roughness(x, y)) {
                            (Some(a), Some(r)) => self.pixel_from_axis(x, y, r, a),
                            _ => PixelOut::default(),
                        };
                        Self::tally(&mut stats, sink, x, y, &p);
                    },
                );
            }
            return stats;
        }
        for y in rows.rows() {
            for x in 0..self.gbuffer().width() {
                let p = self.pixel_out(x, y);
                Self::tally(&mut stats, sink, x, y, &p);
            }
        }
        stats
    }

    /// Counts pixel `(x, y)`'s outcome `p` into `stats` and hands its
    /// texel, color and host ray to `sink`.
    fn tally(stats: &mut GlossyStats, sink: &mut impl GlossySink, x: u32, y: u32, p: &PixelOut) {
        let s = p.texel.status;
        if !matches!(s, MirrorStatus::Skipped | MirrorStatus::NoSurface) {
            stats.traced += 1;
        }
        match s {
            MirrorStatus::Hit => stats.hits += 1,
            MirrorStatus::Sky => stats.sky += 1,
            _ => {}
        }
        if let Some(hr) = p.host {
            if sink.host(stats.host_rays_written, &hr) {
                stats.host_rays_written += 1;
            }
            stats.host_rays += 1;
        }
        stats.circles += u64::from(p.circles);
        stats.lobe_rays += u64::from(p.lobe_rays);
        stats.lobe_hits += u64::from(p.lobe_hits);
        sink.texel(x, y, &p.texel, p.color);
    }
}

impl GlossySink for ImageSink<'_, '_, '_, '_, '_, GlossyTexel> {
    fn texel(&mut self, x: u32, y: u32, texel: &GlossyTexel, color: ColorTexel) {
        self.put(x, y, texel, color);
    }
    fn host(&mut self, index: u32, ray: &HostRay) -> bool {
        self.put_host(index, ray)
    }
}
