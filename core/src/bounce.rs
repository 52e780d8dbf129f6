//! Approximate multiple reflection bounces (seed 004 Sec. 4.6.4, Listing
//! 4.9): the source color the reflection pass reads this frame is the
//! previous frame's **final** image (reflections included), re-projected
//! into this frame, so a mirror that sees a mirror shows that mirror's
//! reflection, one bounce more every frame ("If we compute the reflection
//! of an already reflected image, we'll accumulate multiple bounces over
//! time").
//!
//! Described once ([`BouncePass::try_new`]: this frame's G-buffer with its
//! lit color, the previous frame's final color with its depth and camera
//! ([`PreviousFrame`]), the options), executed over row bands
//! ([`BouncePass::try_run`] into a color image; bands are independent).
//!
//! # How a host uses it
//! 1. Render the G-buffer and the lit color (`lit`) of frame `k`.
//! 2. Run this pass with the previous frame's final image (`final_{k-1}`,
//!    its depth and camera) into `source_k`; on the first frame, or after
//!    a cut, use `source_k = lit`.
//! 3. Give `source_k` as the G-buffer's color
//!    ([`GBuffer::try_with_color`]) to the reflection pass (e.g.
//!    [`crate::MirrorPass`], which shades a hit with the color at its hit
//!    texel): its reflections then show, at a mirror seen in a mirror, the
//!    reflection that mirror showed last frame.
//! 4. Compose the frame's final image (e.g. `final = lit + specular
//!    (reflection - lit)` on reflectors) and keep it, with this frame's
//!    depth and camera, as the next frame's [`PreviousFrame`].
//!
//! # Per pixel
//! 1. **Surface.** A pixel without a usable surface ([`GBuffer::surface`]:
//!    sky, NaN depth, unusable normal) takes `lit`
//!    ([`BounceStatus::NoSurface`]). The reflective mask and roughness are
//!    not read: any pixel may be what a reflection ray hits.
//! 2. **Re-projection** (Sec. 4.6.4, `M' = VP_curr^-1 VP_prev` of Listing
//!    4.9, applied as its two factors so that linear depth works too): the
//!    pixel's world point `P` (the G-buffer's unprojection of the pixel
//!    center) is projected by the previous camera to a sub-pixel position
//!    `q` and depth `z_prev`. `P` behind that camera or `q` outside its
//!    image: `lit` ([`BounceStatus::OffScreen`]).
//! 3. **Validation** (the seed's "store the previous frame's depth buffer
//!    ... compare them by an epsilon"): the 2x2 previous texels around `q`
//!    (bilinear, texel centers at `i + 0.5`) are each kept only if their
//!    depth decodes to a surface (in `[near, far)`), their final color is
//!    finite, and their surface point (the previous camera's unprojection
//!    of the texel center at its stored depth) lies within
//!    [`BounceOptions::depth_tolerance`] `* z_prev` of the current surface's
//!    tangent plane (the same test as the temporal filter's,
//!    `crate::temporal`: a depth comparison for a surface facing the
//!    camera, and one that keeps a floor seen at a grazing angle). The
//!    kept texels' bilinear weights are renormalized; if they sum to less
//!    than [`MIN_PREVIOUS_WEIGHT`] the point was not visible last frame
//!    (disoccluded): `lit` ([`BounceStatus::Rejected`]).
//! 4. **Source.** `source = lit + attenuation (previous - lit)` with
//!    `previous` the kept texels' renormalized bilinear mean and
//!    `attenuation` = [`BounceOptions::attenuation`]
//!    ([`BounceStatus::Reprojected`]): `1` reads the previous final image
//!    as the seed's demo does, `0` the one-bounce source (`lit`, exactly),
//!    values between weaken each further bounce ("the reflections lose
//!    intensity the further in reflection depth it gets", Fig. 4.25). A
//!    non-finite `lit` is passed through as it is; a result that overflows
//!    takes `lit`.
//!
//! Static scenes and a static camera reproduce the previous image texel
//! for texel (up to the f32 round trip of the re-projection: a neighbor
//! texel may get a bilinear weight of ~1e-5, under 0.001/255 in
//! `core/tests/bounce.rs`); under motion the re-projection is that of the reflector's
//! surface point, exact for what the mirror pass reads (a surface's own
//! color), so the source of a moving mirror's reflection lags by the
//! reflection's parallax, as in the seed.
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::glam::Vec3;
//! use refl_core::bounce::{BounceOptions, BouncePass, BounceStatus, PreviousFrame};
//! use refl_core::{Camera, DepthConvention, DepthImage, GBuffer, ImageView, ImageViewMut, NormalSpace};
//!
//! // 8 x 8 pixels of a wall at linear depth 4, lit grey; the camera did not move.
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 0.1, 100.0, 8, 8)?;
//! let (depth, normals) = (vec![4.0f32; 64], vec![[0.0, 0.0, 1.0f32]; 64]);
//! let lit = vec![[0.5f32; 3]; 64];
//! let depth_image = DepthImage::try_new(ImageView::try_new(&depth, 8, 8, 8)?, cam, DepthConvention::Linear)?;
//! let gbuffer = GBuffer::try_new(depth_image, ImageView::try_new(&normals, 8, 8, 8)?, NormalSpace::World)?
//!     .try_with_color(ImageView::try_new(&lit, 8, 8, 8)?)?;
//!
//! // Last frame's final image showed red reflected on the wall.
//! let last = vec![[1.0f32, 0.0, 0.0]; 64];
//! let previous = PreviousFrame::try_new(depth_image, ImageView::try_new(&last, 8, 8, 8)?)?;
//! let options = BounceOptions { attenuation: 0.5, ..BounceOptions::default() };
//! let pass = BouncePass::try_new(gbuffer, previous, options)?;
//! let mut source = vec![[0.0f32; 3]; 64];
//! let stats = pass.try_run(&mut ImageViewMut::try_new(&mut source, 8, 8, 8)?, None)?;
//! assert_eq!(stats.reprojected, 64);
//! // Half-way from the lit grey to the previous final red.
//! assert_eq!(source[9], [0.75, 0.25, 0.25]);
//! assert_eq!(pass.pixel(1, 1).1, BounceStatus::Reprojected);
//! // The mirror pass then reads `source` as its G-buffer's color.
//! let gbuffer = gbuffer.try_with_color(ImageView::try_new(&source, 8, 8, 8)?)?;
//! # let _ = gbuffer;
//! # Ok::<(), refl_core::Error>(())
//! ```

use crate::temporal::{bilinear_footprint, on_tangent_plane};
use crate::{DepthImage, Error, GBuffer, ImageView, ImageViewMut, RowRange};
use glam::Vec3;

/// The previous frame's final image (reflections composed in) with the
/// depth image (and so the camera and convention) it was rendered with.
#[derive(Clone, Copy, Debug)]
pub struct PreviousFrame<'a> {
    depth: DepthImage<'a>,
    color: ImageView<'a, [f32; 3]>,
}

impl<'a> PreviousFrame<'a> {
    /// Binds the previous frame's final color to its depth image.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `color` is not the depth image's
    /// camera's size.
    pub fn try_new(depth: DepthImage<'a>, color: ImageView<'a, [f32; 3]>) -> Result<Self, Error> {
        let cam = depth.camera();
        if color.width() != cam.width() || color.height() != cam.height() {
            return Err(Error::InvalidArgument);
        }
        Ok(Self { depth, color })
    }

    /// The previous frame's depth image (its camera and convention).
    pub const fn depth(&self) -> &DepthImage<'a> {
        &self.depth
    }

    /// The previous frame's final color.
    pub const fn color(&self) -> &ImageView<'a, [f32; 3]> {
        &self.color
    }
}

/// Least sum of the kept texels' bilinear weights that still counts as a
/// re-projection (module docs, step 3): a sample whose surviving texels
/// carry less than this share of the bilinear footprint sits on the
/// silhouette of what the previous frame showed. The value of the temporal
/// filter's `MIN_HISTORY_WEIGHT`.
pub const MIN_PREVIOUS_WEIGHT: f32 = 0.05;

/// Settings of the bounce pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BounceOptions {
    /// Weight of the previous final image in the source (in `[0, 1]`):
    /// `source = lit + attenuation (previous - lit)`. `1` is the seed's
    /// demo (the previous final image as it is); `0` is one bounce
    /// (`source = lit`). Default 1.
    pub attenuation: f32,
    /// Relative tolerance of the validation (`>= 0`, finite): a previous
    /// texel is kept when its surface point lies within `depth_tolerance *
    /// z_prev` of the current surface's tangent plane (module docs, step
    /// 3). Default 0.02, the temporal filter's.
    pub depth_tolerance: f32,
}

impl Default for BounceOptions {
    fn default() -> Self {
        Self {
            attenuation: 1.0,
            depth_tolerance: 0.02,
        }
    }
}

impl BounceOptions {
    /// # Errors
    /// [`Error::InvalidArgument`] if a field is NaN, infinite or outside
    /// its range.
    pub fn try_validate(&self) -> Result<(), Error> {
        let ok = (0.0..=1.0).contains(&self.attenuation)
            && self.depth_tolerance >= 0.0
            && self.depth_tolerance.is_finite();
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidArgument)
        }
    }
}

/// Where a pixel's source color came from (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum BounceStatus {
    /// No usable surface: `lit`.
    #[default]
    NoSurface = 0,
    /// Re-projected into the previous frame and validated: `lit +
    /// attenuation (previous - lit)`.
    Reprojected = 1,
    /// Behind the previous camera or outside its image: `lit`.
    OffScreen = 2,
    /// Every previous texel around the re-projection was rejected
    /// (disoccluded, no surface, non-finite color): `lit`.
    Rejected = 3,
}

/// Counts of one run over a band (saturating at `u32::MAX`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BounceStats {
    /// Pixels that read the previous final image ([`BounceStatus::Reprojected`]).
    pub reprojected: u32,
    /// Pixels whose previous texels were all rejected ([`BounceStatus::Rejected`]).
    pub rejected: u32,
    /// Pixels re-projected behind the previous camera or outside its
    /// image ([`BounceStatus::OffScreen`]).
    pub off_screen: u32,
    /// Pixels without a usable surface ([`BounceStatus::NoSurface`]).
    pub no_surface: u32,
}

/// The bounce pass over one frame (module docs).
#[derive(Clone, Copy, Debug)]
pub struct BouncePass<'a> {
    gbuffer: GBuffer<'a>,
    lit: ImageView<'a, [f32; 3]>,
    previous: PreviousFrame<'a>,
    options: BounceOptions,
}

impl<'a> BouncePass<'a> {
    /// Binds this frame's G-buffer, whose color ([`GBuffer::try_with_color`])
    /// is the frame's lit color without reflections, the previous frame's
    /// final image and the options.
    ///
    /// Contract (seed 004 Sec. 4.6.4, Listing 4.9): `previous` is the image
    /// the host composed last frame, reflections included, with the depth
    /// and camera of that frame; its size may differ from this frame's.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if the G-buffer has no color or the
    /// options are out of range.
    pub fn try_new(
        gbuffer: GBuffer<'a>,
        previous: PreviousFrame<'a>,
        options: BounceOptions,
    ) -> Result<Self, Error> {
        options.try_validate()?;
        let lit = *gbuffer.color().ok_or(Error::InvalidArgument)?;
        Ok(Self {
            gbuffer,
            lit,
            previous,
            options,
        })
    }

    /// The options.
    pub const fn options(&self) -> &BounceOptions {
        &self.options
    }

    /// The previous frame's final color fetched for the world point `p`
    /// with unit normal `n` (module docs, steps 2 and 3): `q = project_prev(p)`
    /// (seed 004 Sec. 4.6.4, Listing 4.9: `M' = VP_curr^-1 VP_prev`, here its
    /// second factor, `p` being the first's result), then the listing's
    /// `linearSampler` read of the previous color at `q` (bilinear, texel
    /// centers at `i + 0.5`) over the texels that pass Sec. 4.6.4's depth
    /// test ("compare them by an epsilon", [`crate::temporal`]'s
    /// tangent-plane form, tolerance `depth_tolerance * z_prev`),
    /// renormalized: `sum(w_i c_i) / sum(w_i)` with `sum(w_i) >=`
    /// [`MIN_PREVIOUS_WEIGHT`].
    fn fetch(&self, p: Vec3, n: Vec3) -> Result<Vec3, BounceStatus> {
        let prev = &self.previous;
        let cam = prev.depth.camera();
        let q = cam.project(p).ok_or(BounceStatus::OffScreen)?;
        let (w, h) = (cam.width() as f32, cam.height() as f32);
        if !(q.x >= 0.0 && q.x <= w && q.y >= 0.0 && q.y <= h && q.z > 0.0) {
            return Err(BounceStatus::OffScreen);
        }
        let tol = self.options.depth_tolerance * q.z;
        let (mut sum, mut wsum) = (Vec3::ZERO, 0.0f32);
        for (x, y, wt) in bilinear_footprint(q.x, q.y) {
            if !(wt > 0.0) {
                continue;
            }
            if x < 0 || y < 0 || x > u32::MAX as i64 || y > u32::MAX as i64 {
                continue;
            }
            let (x, y) = (x as u32, y as u32);
            let Some(c) = prev.color.get(x, y).map(Vec3::from_array) else {
                continue;
            };
            let Some(z) = prev.depth.linear_at(x, y) else {
                continue;
            };
            if !(c.is_finite() && z >= cam.near() && z < cam.far()) {
                continue;
            }
            if on_tangent_plane(cam, x, y, z, p, n, tol).1 {
                sum += c * wt;
                wsum += wt;
            }
        }
        if !(wsum >= MIN_PREVIOUS_WEIGHT) {
            return Err(BounceStatus::Rejected);
        }
        let color = sum / wsum;
        // A weighted mean of finite colors is finite unless the sum
        // overflowed; such a fetch is dropped rather than propagated.
        if color.is_finite() {
            Ok(color)
        } else {
            Err(BounceStatus::Rejected)
        }
    }

    /// Pixel `(x, y)`'s source color and where it came from (what
    /// [`BouncePass::try_run`] writes); `([0; 3], NoSurface)` outside the
    /// image. The source is `lit + attenuation (previous - lit)` (module
    /// docs, step 4): seed 004 Sec. 4.6.4 reads the previous final image
    /// as it is (attenuation 1); the attenuation, which weakens each
    /// further bounce as Fig. 4.24-4.25 describe, is this crate's.
    pub fn pixel(&self, x: u32, y: u32) -> ([f32; 3], BounceStatus) {
        let Some(lit) = self.lit.get(x, y) else {
            return ([0.0; 3], BounceStatus::NoSurface);
        };
        let Some(s) = self.gbuffer.surface(x, y) else {
            return (lit, BounceStatus::NoSurface);
        };
        match self.fetch(s.position, s.normal) {
            Ok(prev) => {
                let l = Vec3::from_array(lit);
                if !l.is_finite() {
                    return (lit, BounceStatus::Reprojected);
                }
                let a = self.options.attenuation;
                let out = l + (prev - l) * a;
                // lit and previous finite: so is the blend, unless
                // `previous - lit` overflows; lit then.
                let out = if out.is_finite() { out.to_array() } else { lit };
                (out, BounceStatus::Reprojected)
            }
            Err(why) => (lit, why),
        }
    }

    /// Runs the pass over the rows `out` owns (a whole image or a band from
    /// [`ImageViewMut::try_band`]): writes every pixel's source color and,
    /// if given, its [`BounceStatus`] as a byte into `status`.
    ///
    /// Contract: `out` is this frame's source image, which the host then
    /// gives the reflection pass as its G-buffer's color; it is not the
    /// previous frame's final image (Rust's borrows guarantee it); `out`
    /// and `status` are the G-buffer's size and own the same rows.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `out` or `status` is not the
    /// G-buffer's size or their bands differ. Nothing is written then.
    pub fn try_run(
        &self,
        out: &mut ImageViewMut<'_, [f32; 3]>,
        mut status: Option<&mut ImageViewMut<'_, u8>>,
    ) -> Result<BounceStats, Error> {
        let (w, h) = (self.gbuffer.width(), self.gbuffer.height());
        let Some(rows) = crate::image::try_output_rows(out, status.as_deref(), w, h)? else {
            return Ok(BounceStats::default());
        };
        Ok(self.run_rows(rows, &mut |x, y, c, st| {
            crate::image::put_pixel(out, status.as_deref_mut(), x, y, c, st as u8);
        }))
    }

    /// Runs the pass over `rows` (checked against the G-buffer's height)
    /// and hands every pixel's source color and status to `sink`: the loop
    /// of [`BouncePass::try_run`] for hosts whose buffers are not
    /// [`ImageViewMut`]s.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `rows` ends beyond the G-buffer's
    /// height. Nothing is handed to `sink` then.
    pub fn try_run_rows(
        &self,
        rows: RowRange,
        sink: &mut impl FnMut(u32, u32, [f32; 3], BounceStatus),
    ) -> Result<BounceStats, Error> {
        if rows.end() > self.gbuffer.height() {
            return Err(Error::InvalidArgument);
        }
        Ok(self.run_rows(rows, sink))
    }

    fn run_rows(
        &self,
        rows: RowRange,
        sink: &mut impl FnMut(u32, u32, [f32; 3], BounceStatus),
    ) -> BounceStats {
        let mut stats = BounceStats::default();
        for y in rows.rows() {
            for x in 0..self.gbuffer.width() {
                let (c, s) = self.pixel(x, y);
                let n = match s {
                    BounceStatus::NoSurface => &mut stats.no_surface,
                    BounceStatus::Reprojected => &mut stats.reprojected,
                    BounceStatus::OffScreen => &mut stats.off_screen,
                    BounceStatus::Rejected => &mut stats.rejected,
                };
                *n = n.saturating_add(1);
                sink(x, y, c, s);
            }
        }
        stats
    }
}
