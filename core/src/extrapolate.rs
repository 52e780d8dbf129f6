//! Extrapolation of surfaces (seed 004 Sec. 4.6.2): a bilateral dilation
//! that fills the reflection of a pixel whose ray the screen could not
//! answer from the answered pixels around it on the same surface, so that
//! the host traces fewer rays.
//!
//! The seed: "Since the ray-marching step might not find a true
//! intersection, we could potentially extrapolate the missing information
//! ... run a bilateral dilation filter, which basically means take the
//! surface normal and depth into account when extrapolating the missing
//! color (i.e., flood-filling the holes). For any surface other than rough
//! surfaces, the dilation filter might fail horribly because of potential
//! high-frequency reflection colors." And: "The tile-based approach should
//! work well for running the dilation only on the needed pixels."
//!
//! Described once ([`ExtrapolatePass::try_new`]: the G-buffer, the mirror
//! pass's texels and colors, the options), executed over row bands
//! ([`ExtrapolatePass::try_run`]; bands are independent: every band reads
//! the whole input). Only holes cost more than a copy: the dilation runs
//! on the pixels that need it, as the seed asks.
//!
//! # Per pixel
//! 1. **Hole.** A pixel is a hole if its texel's status is
//!    [`MirrorStatus::LeftImage`] (the ray left the screen: the seed's case,
//!    where the surface it would reach is just off the image), or with
//!    [`ExtrapolateOptions::all_host_rays`] any status the host would trace
//!    ([`MirrorStatus::needs_host`]), and it has a usable surface
//!    ([`GBuffer::surface`]). Any other pixel keeps its color
//!    ([`ExtrapolateStatus::Kept`]).
//! 2. **Roughness.** A hole smoother than
//!    [`ExtrapolateOptions::min_roughness`] (the G-buffer's roughness; `0`
//!    without a roughness image; NaN counts as smooth) is left to the host
//!    ([`ExtrapolateStatus::TooSmooth`]): on a mirror the dilation smears
//!    a sharp reflection (the seed's "might fail horribly").
//! 3. **Dilation.** Each answered pixel `q` ([`MirrorStatus::Hit`] or
//!    [`MirrorStatus::Sky`], finite color, usable surface) within
//!    [`ExtrapolateOptions::radius`] pixels (a square window) of the hole
//!    `p` weighs
//!
//!    `w_q = exp(-|p - q|^2 / (2 s^2)) D(|z_q - z_p| / z_p) N(n_q . n_p)`,
//!
//!    a Gaussian in pixels of width `s` =
//!    [`ExtrapolateOptions::spatial_sigma`] times the range weights of the
//!    seed's "surface normal and depth": `D` and `N` are the upsampler's
//!    (Kopf et al. 2007 Eq. 2's range kernel `g` on the relative depth,
//!    cut at [`ExtrapolateOptions::depth_threshold`], and the normal power;
//!    [`crate::upsample::UpsampleOptions`], "Weights"). The hole takes the
//!    normalized mean `sum w_q c_q / sum w_q` ([`ExtrapolateStatus::Filled`])
//!    or, if no pixel weighs anything, stays a hole for the host
//!    ([`ExtrapolateStatus::Unfilled`], listed).
//!
//! One run reaches `radius` pixels. The seed's flood fill over larger
//! holes is not iterated here: a filled pixel is not a source within the
//! same run (the result does not depend on the order of the pixels or the
//! bands).
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::extrapolate::{ExtrapolateOptions, ExtrapolatePass, ExtrapolateStatus};
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::{Camera, DepthConvention, DepthImage, GBuffer, ImageView, ImageViewMut};
//! use refl_core::{MirrorStatus, MirrorTexel, NormalSpace};
//!
//! // 8 x 8 pixels of a wall at linear depth 4; the mirror pass answered
//! // every pixel but (3, 3), whose ray left the image.
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 0.1, 100.0, 8, 8)?;
//! let (depth, normals) = (vec![4.0f32; 64], vec![[0.0, 0.0, 1.0f32]; 64]);
//! let depth_image = DepthImage::try_new(ImageView::try_new(&depth, 8, 8, 8)?, cam, DepthConvention::Linear)?;
//! let gbuffer = GBuffer::try_new(depth_image, ImageView::try_new(&normals, 8, 8, 8)?, NormalSpace::World)?;
//! let hit = MirrorTexel { status: MirrorStatus::Hit, pixel: Vec2::new(1.0, 1.0), t: 1.0, confidence: 1.0 };
//! let mut texels = vec![hit; 64];
//! texels[3 * 8 + 3] = MirrorTexel { status: MirrorStatus::LeftImage, ..MirrorTexel::default() };
//! let color = vec![[0.5f32, 0.25, 0.0]; 64];
//!
//! let pass = ExtrapolatePass::try_new(
//!     gbuffer,
//!     ImageView::try_new(&texels, 8, 8, 8)?,
//!     ImageView::try_new(&color, 8, 8, 8)?,
//!     ExtrapolateOptions::default(),
//! )?;
//! let mut out = vec![[0.0f32; 3]; 64];
//! let mut status = vec![0u8; 64];
//! let mut host = [[0u32; 2]; 4];
//! let stats = pass.try_run(
//!     &mut ImageViewMut::try_new(&mut out, 8, 8, 8)?,
//!     Some(&mut ImageViewMut::try_new(&mut status, 8, 8, 8)?),
//!     &mut host,
//! )?;
//! assert_eq!((stats.holes, stats.filled), (1, 1));
//! assert_eq!(status[3 * 8 + 3], ExtrapolateStatus::Filled as u8);
//! assert!((out[3 * 8 + 3][0] - 0.5).abs() < 1e-6);
//! # Ok::<(), refl_core::Error>(())
//! ```

use crate::upsample::{depth_weight, normal_weight, whole_power};
use crate::{Error, GBuffer, ImageView, ImageViewMut, MirrorStatus, MirrorTexel, RowRange};
use glam::Vec3;

/// The largest [`ExtrapolateOptions::radius`].
pub const MAX_EXTRAPOLATE_RADIUS: u32 = 16;

/// Settings of the dilation ([`ExtrapolatePass`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExtrapolateOptions {
    /// Half-size of the square window searched around a hole, in pixels
    /// (`1..=`[`MAX_EXTRAPOLATE_RADIUS`]). Default 4.
    pub radius: u32,
    /// Width of the Gaussian spatial weight, in pixels (`> 0`, not NaN;
    /// `+inf`: every pixel of the window weighs the same). Default 2.
    pub spatial_sigma: f32,
    /// The depth edge, as a fraction of the hole's linear depth: pixels
    /// further in depth get weight `0` (`> 0`, not NaN; `+inf` turns the
    /// edge off). Default 0.1, as the upsampler's.
    pub depth_threshold: f32,
    /// Width of the Gaussian depth weight, a fraction of the hole's depth
    /// (`> 0`, not NaN). Default 0.05.
    pub depth_sigma: f32,
    /// Exponent of the normal weight (finite, `>= 0`; `0` turns it off).
    /// Default 8.
    pub normal_power: f32,
    /// Holes smoother than this (the G-buffer's roughness) are left to the
    /// host (finite, `>= 0`; `0` fills every hole). Default 0.
    pub min_roughness: f32,
    /// Fill every status the host would trace, not only rays that left
    /// the image. Default `false`.
    pub all_host_rays: bool,
}

impl Default for ExtrapolateOptions {
    fn default() -> Self {
        Self {
            radius: 4,
            spatial_sigma: 2.0,
            depth_threshold: 0.1,
            depth_sigma: 0.05,
            normal_power: 8.0,
            min_roughness: 0.0,
            all_host_rays: false,
        }
    }
}

impl ExtrapolateOptions {
    /// # Errors
    /// [`Error::InvalidArgument`] if a field is NaN or outside its range.
    pub fn try_validate(&self) -> Result<(), Error> {
        let ok = (1..=MAX_EXTRAPOLATE_RADIUS).contains(&self.radius)
            && self.spatial_sigma > 0.0
            && self.depth_threshold > 0.0
            && self.depth_sigma > 0.0
            && self.normal_power >= 0.0
            && self.normal_power.is_finite()
            && self.min_roughness >= 0.0
            && self.min_roughness.is_finite();
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidArgument)
        }
    }
}

/// What the pass did with a pixel (per pixel of
/// [`ExtrapolatePass::try_run`]'s status image, as a byte).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum ExtrapolateStatus {
    /// Not a hole: the input color, unchanged.
    #[default]
    Kept = 0,
    /// A hole filled by the dilation.
    Filled = 1,
    /// A hole no answered pixel reaches: for the host (listed).
    Unfilled = 2,
    /// A hole smoother than [`ExtrapolateOptions::min_roughness`]: for the
    /// host (listed).
    TooSmooth = 3,
}

impl ExtrapolateStatus {
    /// `true` for the statuses whose pixels the host still traces.
    pub const fn needs_host(self) -> bool {
        matches!(self, Self::Unfilled | Self::TooSmooth)
    }
}

/// Counts of one run over a band.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExtrapolateStats {
    /// Holes (step 1 of the module docs).
    pub holes: u32,
    /// Holes filled ([`ExtrapolateStatus::Filled`]).
    pub filled: u32,
    /// Holes no answered pixel reaches ([`ExtrapolateStatus::Unfilled`]).
    pub unfilled: u32,
    /// Holes too smooth to fill ([`ExtrapolateStatus::TooSmooth`]).
    pub too_smooth: u32,
    /// Of the unfilled and too smooth holes, those stored in the host list
    /// (the rest did not fit).
    pub host_written: u32,
}

/// The dilation of one frame's mirror-pass results (module docs).
#[derive(Clone, Copy, Debug)]
pub struct ExtrapolatePass<'a> {
    gbuffer: GBuffer<'a>,
    texels: ImageView<'a, MirrorTexel>,
    color: ImageView<'a, [f32; 3]>,
    options: ExtrapolateOptions,
    /// [`ExtrapolateOptions::normal_power`] as a whole number, if it is one.
    whole_power: Option<u32>,
    /// The spatial weight per axis: `exp(-d^2 / (2 s^2))` for `d` in
    /// `0..=radius` (the 2-D weight is the product of two).
    spatial: [f32; MAX_EXTRAPOLATE_RADIUS as usize + 1],
}

impl<'a> ExtrapolatePass<'a> {
    /// Binds the G-buffer the mirror pass traced, its texels and colors
    /// (the host's answers may be in the colors: only the statuses say
    /// what a pixel is) and the options.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `texels` or `color` is not the
    /// G-buffer's size, or an option is out of range
    /// ([`ExtrapolateOptions::try_validate`]).
    pub fn try_new(
        gbuffer: GBuffer<'a>,
        texels: ImageView<'a, MirrorTexel>,
        color: ImageView<'a, [f32; 3]>,
        options: ExtrapolateOptions,
    ) -> Result<Self, Error> {
        options.try_validate()?;
        let (w, h) = (gbuffer.width(), gbuffer.height());
        if texels.width() != w || texels.height() != h || color.width() != w || color.height() != h
        {
            return Err(Error::InvalidArgument);
        }
        let mut spatial = [0.0f32; MAX_EXTRAPOLATE_RADIUS as usize + 1];
        let s = options.spatial_sigma;
        for (d, v) in spatial.iter_mut().enumerate() {
            let q = d as f32 / s;
            *v = if s.is_finite() {
                libm::expf(-0.5 * q * q)
            } else {
                1.0
            };
        }
        Ok(Self {
            gbuffer,
            texels,
            color,
            options,
            whole_power: whole_power(options.normal_power),
            spatial,
        })
    }

    /// The options.
    pub const fn options(&self) -> &ExtrapolateOptions {
        &self.options
    }

    /// Pixel `(x, y)`'s color and status, as [`ExtrapolatePass::try_run`]
    /// writes them; `(black, Kept)` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> ([f32; 3], ExtrapolateStatus) {
        let kept = |c: Option<[f32; 3]>| (c.unwrap_or([0.0; 3]), ExtrapolateStatus::Kept);
        let Some(texel) = self.texels.get(x, y) else {
            return kept(None);
        };
        let hole = if self.options.all_host_rays {
            texel.status.needs_host()
        } else {
            texel.status == MirrorStatus::LeftImage
        };
        if !hole {
            return kept(self.color.get(x, y));
        }
        let Some(surface) = self.gbuffer.surface(x, y) else {
            return kept(self.color.get(x, y));
        };
        let roughness = match self.gbuffer.roughness() {
            Some(r) => r.get(x, y).unwrap_or(f32::NAN),
            None => 0.0,
        };
        // NaN counts as smooth: `!(NaN >= m)`.
        if !(roughness >= self.options.min_roughness) {
            return (
                self.color.get(x, y).unwrap_or([0.0; 3]),
                ExtrapolateStatus::TooSmooth,
            );
        }
        match self.dilate(x, y, surface.depth, surface.normal) {
            Some(c) => (c, ExtrapolateStatus::Filled),
            None => (
                self.color.get(x, y).unwrap_or([0.0; 3]),
                ExtrapolateStatus::Unfilled,
            ),
        }
    }

    /// The weighted mean of the answered pixels around hole `(x, y)` of
    /// linear depth `z` and unit normal `n` (step 3), if any weighs
    /// anything.
    fn dilate(&self, x: u32, y: u32, z: f32, n: Vec3) -> Option<[f32; 3]> {
        let o = &self.options;
        let r = o.radius;
        let (w, h) = (self.gbuffer.width(), self.gbuffer.height());
        let (x0, x1) = (x.saturating_sub(r), (x + r).min(w - 1));
        let (y0, y1) = (y.saturating_sub(r), (y + r).min(h - 1));
        let mut sum = Vec3::ZERO;
        let mut weight = 0.0f32;
        for qy in y0..=y1 {
            let wy = self.spatial[qy.abs_diff(y) as usize];
            for qx in x0..=x1 {
                let Some(t) = self.texels.get(qx, qy) else {
                    continue;
                };
                if !matches!(t.status, MirrorStatus::Hit | MirrorStatus::Sky) {
                    continue;
                }
                let Some(c) = self.color.get(qx, qy).map(Vec3::from_array) else {
                    continue;
                };
                if !c.is_finite() {
                    continue;
                }
                let Some(s) = self.gbuffer.surface(qx, qy) else {
                    continue;
                };
                let Some(d) =
                    depth_weight((s.depth - z).abs() / z, o.depth_threshold, o.depth_sigma)
                else {
                    continue;
                };
                let nw = normal_weight(s.normal.dot(n), o.normal_power, self.whole_power);
                let wq = wy * self.spatial[qx.abs_diff(x) as usize] * d * nw;
                if wq > 0.0 {
                    sum += c * wq;
                    weight += wq;
                }
            }
        }
        let mean = sum / weight;
        (weight > 0.0 && mean.is_finite()).then(|| mean.to_array())
    }

    /// Runs the dilation over the rows `color` owns (a band of the
    /// G-buffer's size, [`ImageViewMut::try_band`], or the whole image):
    /// every pixel's color (the input's where it is kept or left to the
    /// host), its [`ExtrapolateStatus`] into `status` when given, and the
    /// holes still for the host, `[x, y]` in row-major order, into `host`
    /// as far as it has room (its texel's status and
    /// [`crate::MirrorPass::host_ray`] give the ray). Two bands give what
    /// one call over both gives (the list restarts at each call).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `color` or `status` is not the
    /// G-buffer's size, or their bands differ. Nothing is written then.
    pub fn try_run(
        &self,
        color: &mut ImageViewMut<'_, [f32; 3]>,
        mut status: Option<&mut ImageViewMut<'_, u8>>,
        host: &mut [[u32; 2]],
    ) -> Result<ExtrapolateStats, Error> {
        let (w, h) = (self.gbuffer.width(), self.gbuffer.height());
        let Some(rows) = crate::image::try_output_rows(color, status.as_deref(), w, h)? else {
            return Ok(ExtrapolateStats::default());
        };
        Ok(self.run_rows(
            rows,
            |x, y, c, s| crate::image::put_pixel(color, status.as_deref_mut(), x, y, c, s as u8),
            host,
        ))
    }

    fn run_rows(
        &self,
        rows: RowRange,
        mut write: impl FnMut(u32, u32, [f32; 3], ExtrapolateStatus),
        host: &mut [[u32; 2]],
    ) -> ExtrapolateStats {
        let mut stats = ExtrapolateStats::default();
        for y in rows.rows() {
            for x in 0..self.gbuffer.width() {
                let (c, s) = self.pixel(x, y);
                match s {
                    ExtrapolateStatus::Kept => {}
                    ExtrapolateStatus::Filled => stats.filled += 1,
                    ExtrapolateStatus::Unfilled => stats.unfilled += 1,
                    ExtrapolateStatus::TooSmooth => stats.too_smooth += 1,
                }
                if s != ExtrapolateStatus::Kept {
                    stats.holes += 1;
                }
                if s.needs_host() {
                    if let Some(slot) = host.get_mut(stats.host_written as usize) {
                        *slot = [x, y];
                        stats.host_written += 1;
                    }
                }
                write(x, y, c, s);
            }
        }
        stats
    }
}
