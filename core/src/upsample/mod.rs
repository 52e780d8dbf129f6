//! Fewer rays for the screen-space mirror pass (seed 004 Sec. 4.7.3,
//! 4.7.4): trace one pixel of every 2x2 block, reconstruct the other three
//! from the traced neighbors guided by the full-resolution G-buffer
//! (cross-bilateral upsampling, Kopf et al. 2007), re-trace at full
//! resolution where no neighbor is on the same surface, and cycle the
//! traced pixel over four frames so that the temporal filter
//! (`crate::temporal`) holds the full-resolution result after four frames
//! of a static camera (temporal super-sampling).
//!
//! Three parts, each over caller memory and row bands:
//!
//! 1. **Which pixels** ([`Subsample`]): 2x2 blocks of the full image,
//!    block `(bx, by)` covering pixels `(2 bx, 2 by)` to `(2 bx + 1, 2 by
//!    + 1)`; each block traces one of its pixels, its [`SubPixel`]. With
//!    [`Pattern::Uniform`] every block traces the same sub-pixel, the
//!    frame's ([`frame_sub_pixel`]): the traced pixels form a regular
//!    half-resolution grid, what a half-resolution trace is (Sec. 4.7.4,
//!    "we run the ray tracing at half-resolution"; Sec. 4.7.3, "shoot
//!    rays every other pixel ... twice horizontally, twice vertically").
//!    With [`Pattern::Staggered`] every other block row traces the
//!    horizontally mirrored sub-pixel, so that the rows of traced pixels
//!    interleave: a staggered lattice (spanned by `(2, 0)` and `(1, 2)`)
//!    that samples every pixel column in two block rows, where the grid
//!    samples every other one. Both are lattices whose tent weights
//!    ([`UpsampleOptions`]) center on every pixel they reach, so the
//!    reconstruction reproduces a linear signal on either. A block at
//!    an odd right or bottom border that lacks the sub-pixel's column or
//!    row traces its last one ([`Subsample::traced_pixel`]).
//! 2. **Tracing** ([`HalfPass`]): the mirror pass ([`crate::MirrorPass`])
//!    on the traced pixels only, each traced exactly as the full pass
//!    traces it (the same [`crate::MirrorTexel`], color and host ray), the
//!    results written into a half-resolution image indexed by block
//!    ([`try_half_size`], [`try_half_len`]): a quarter of the rays.
//! 3. **Reconstruction** ([`UpsamplePass`]): every full-resolution pixel
//!    from the traced samples around it, weighted by bilinear distance,
//!    depth similarity and normal similarity, with a hard depth-edge
//!    threshold; pixels no sample reaches are listed for a
//!    full-resolution re-trace or traced at once (Sec. 4.7.4, "append the
//!    pixels at depth discontinuities to an append/consume buffer and
//!    re-trace only those pixels at high resolution"). The weights are
//!    documented on [`UpsampleOptions`].
//!
//! # Temporal super-sampling (Sec. 4.7.4)
//!
//! "A temporal super-sampling algorithm is even better: after four frames
//! we will have full-resolution traced results using the temporal
//! re-projection". Frame `f` traces with `Subsample { pattern, frame: f }`:
//! each block's sub-pixel steps through [`FRAME_CYCLE`], so in four
//! consecutive frames every pixel is traced once. Combined with
//! [`crate::temporal::TemporalPass`]:
//!
//! * `current`: the upsampled color ([`UpsamplePass::try_run`]; the
//!   reconstructed pixels are the fallback of pixels without history);
//! * `answered`: non-zero only where the pixel was traced this frame and
//!   answered ([`UpsampleStatus::answers`]: a traced
//!   [`crate::MirrorStatus::Hit`] or [`crate::MirrorStatus::Sky`]), so
//!   that reconstructed values never enter the history;
//! * distances (optional, [`crate::temporal::TemporalPass::try_with_distance`]):
//!   the texels' `t`.
//!
//! A pixel traced this frame resets or blends its history; the other
//! three of its block recover theirs. With a static camera a pixel's
//! history then holds its own traced result from the frame that traced
//! it, so from the fourth frame on the history equals the
//! full-resolution pass's result wherever it is valid (the test
//! `core/tests/upsample.rs` checks it). Any
//! [`crate::temporal::TemporalOptions::max_frames`] works (the running mean
//! of equal values is that value); with a moving camera `max_frames = 1`
//! keeps the most recent trace.
//!
//! # Example
//! ```rust
//! # #[cfg(feature = "depth-image")] {
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::glam::Vec3;
//! use refl_core::upsample::{try_half_size, HalfPass, Subsample, UpsampleOptions, UpsamplePass, UpsampleStatus};
//! use refl_core::{Camera, DepthConvention, DepthImage, GBuffer, HostRay, ImageView, ImageViewMut};
//! use refl_core::{MirrorOptions, MirrorPass, MirrorStatus, MirrorTexel, NormalSpace};
//!
//! // 16 x 16 pixels: the eye 1 above the floor y = 0, looking down -Z at a wall at z = -4.
//! let cam = Camera::try_look_at(Vec3::Y, Vec3::new(0.0, 1.0, -1.0), Vec3::Y, FRAC_PI_2, 0.1, 100.0, 16, 16)?;
//! let (mut depth, mut normals) = (vec![4.0f32; 256], vec![[0.0, 0.0, 1.0f32]; 256]);
//! for (i, (d, n)) in depth.iter_mut().zip(&mut normals).enumerate() {
//!     let floor = -1.0 / (1.0 - (2 * (i / 16) + 1) as f32 / 16.0);
//!     if (0.0..4.0).contains(&floor) {
//!         (*d, *n) = (floor, [0.0, 1.0, 0.0]);
//!     }
//! }
//! let depth = DepthImage::try_new(ImageView::try_new(&depth, 16, 16, 16)?, cam, DepthConvention::Linear)?;
//! let gbuffer = GBuffer::try_new(depth, ImageView::try_new(&normals, 16, 16, 16)?, NormalSpace::World)?;
//! # #[cfg(feature = "hiz")]
//! let pass = MirrorPass::try_new(gbuffer, MirrorOptions::default(), None)?;
//! # #[cfg(not(feature = "hiz"))]
//! # let pass = MirrorPass::try_new(gbuffer, MirrorOptions::default())?;
//!
//! // Frame 0 traces the top-left pixel of every 2x2 block: 64 rays for 256 pixels.
//! let sub = Subsample::uniform(0);
//! let (hw, hh) = try_half_size(16, 16)?;
//! let mut half = vec![MirrorTexel::default(); (hw * hh) as usize];
//! let stats = HalfPass::new(pass, sub).try_run(&mut ImageViewMut::try_new(&mut half, hw, hh, hw)?, None, &mut [])?;
//! assert_eq!(stats.traced, 64);
//! // Half-resolution texel (4, 6) is full-resolution pixel (8, 12), traced as the full pass does.
//! assert_eq!(half[6 * 8 + 4], pass.pixel(8, 12).0);
//!
//! // Upsampled to 16 x 16: the traced pixels keep their result, the others are reconstructed
//! // from the samples on their own surface (never across the wall's bottom edge, a depth step).
//! let run = |options: UpsampleOptions| {
//!     let up = UpsamplePass::try_new(pass, sub, ImageView::try_new(&half, hw, hh, hw)?, None, options)?;
//!     let (mut full, mut status, mut retrace) = (vec![MirrorTexel::default(); 256], vec![0u8; 256], [[0u32; 2]; 256]);
//!     let s = up.try_run(
//!         &mut ImageViewMut::try_new(&mut full, 16, 16, 16)?,
//!         None,
//!         Some(&mut ImageViewMut::try_new(&mut status, 16, 16, 16)?),
//!         &mut retrace,
//!     )?;
//!     assert_eq!(s.copied, 64);
//!     assert_eq!(s.copied + s.interpolated + s.retrace, 256);
//!     assert_eq!(status[12 * 16 + 8], UpsampleStatus::Copied as u8);
//!     assert_eq!(full[12 * 16 + 8], half[6 * 8 + 4]);
//!     Ok::<_, refl_core::Error>((full, status, retrace[..s.retrace_written as usize].to_vec()))
//! };
//! // At this tiny size the floor's depth changes by 22% from row 13 to row 12: more than the
//! // default depth edge (10%), so floor pixel (9, 13) is listed for a full-resolution trace...
//! let (_, status, list) = run(UpsampleOptions::default())?;
//! assert_eq!(status[13 * 16 + 9], UpsampleStatus::Retrace as u8);
//! assert!(list.contains(&[9, 13]));
//! // ... unless depths are compared along the floor's tangent plane: the floor reflects the wall.
//! let (full, _, _) = run(UpsampleOptions { plane_depth: true, ..UpsampleOptions::default() })?;
//! assert_eq!(full[13 * 16 + 9].status, MirrorStatus::Hit);
//! # }
//! # Ok::<(), refl_core::Error>(())
//! ```

mod bilateral;
mod half;

pub(crate) use bilateral::{depth_weight, normal_weight, whole_power};
pub use bilateral::{UpsampleOptions, UpsamplePass, UpsampleSink, UpsampleStats, UpsampleStatus};
pub use half::HalfPass;

use crate::Error;

/// The pixel of a 2x2 block a [`Subsample`] traces: column `x` and row
/// `y` within the block, each `0` or `1`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct SubPixel {
    /// Column in the block (`0` left, `1` right).
    pub x: u32,
    /// Row in the block (`0` top, `1` bottom).
    pub y: u32,
}

/// The sub-pixels of four consecutive frames (Sec. 4.7.4 temporal
/// super-sampling, "after four frames we will have full-resolution traced
/// results"): top-left, bottom-right, top-right, bottom-left. The second
/// frame traces the diagonal opposite of the first, so that two frames
/// already hold a checkerboard (quincunx) of traced pixels, the densest
/// even coverage two samples per block can give; four frames hold every
/// pixel.
pub const FRAME_CYCLE: [SubPixel; 4] = [
    SubPixel { x: 0, y: 0 },
    SubPixel { x: 1, y: 1 },
    SubPixel { x: 1, y: 0 },
    SubPixel { x: 0, y: 1 },
];

/// The sub-pixel frame `frame` traces with [`Pattern::Uniform`]:
/// [`FRAME_CYCLE`]`[frame % 4]`.
pub const fn frame_sub_pixel(frame: u32) -> SubPixel {
    FRAME_CYCLE[(frame % 4) as usize]
}

/// How the traced pixels are arranged over the blocks (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Pattern {
    /// Every block traces the frame's sub-pixel: a regular
    /// half-resolution grid (Sec. 4.7.4).
    #[default]
    Uniform,
    /// Block `(bx, by)` traces the frame's sub-pixel `s`
    /// ([`frame_sub_pixel`]) on even block rows and `(1 - s.x, s.y)` on
    /// odd ones: the rows of traced pixels interleave (a staggered
    /// lattice; interleaved sampling, Sec. 4.7.3).
    Staggered,
}

/// Which pixel of each 2x2 block a frame traces: the pattern and the
/// frame number that selects the sub-pixel (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Subsample {
    /// The arrangement over the blocks.
    pub pattern: Pattern,
    /// The frame number: steps the sub-pixels through [`FRAME_CYCLE`]
    /// (any value; only `frame % 4` matters).
    pub frame: u32,
}

impl Subsample {
    /// [`Pattern::Uniform`] at frame `frame`.
    pub const fn uniform(frame: u32) -> Self {
        Self {
            pattern: Pattern::Uniform,
            frame,
        }
    }

    /// [`Pattern::Staggered`] at frame `frame`.
    pub const fn staggered(frame: u32) -> Self {
        Self {
            pattern: Pattern::Staggered,
            frame,
        }
    }

    /// The sub-pixel block `(bx, by)` traces.
    pub const fn sub_pixel(&self, bx: u32, by: u32) -> SubPixel {
        let _ = bx;
        let s = frame_sub_pixel(self.frame);
        match self.pattern {
            Pattern::Uniform => s,
            Pattern::Staggered => SubPixel {
                x: s.x ^ (by & 1),
                y: s.y,
            },
        }
    }

    /// The full-resolution pixel block `(bx, by)` of a `width x height`
    /// image traces: `(min(2 bx + s.x, width - 1), min(2 by + s.y, height
    /// - 1))` for its sub-pixel `s` (a block at an odd right or bottom
    /// border has one column or row); `None` for a block outside the
    /// image's [`try_half_size`] or an empty image.
    pub const fn traced_pixel(
        &self,
        bx: u32,
        by: u32,
        width: u32,
        height: u32,
    ) -> Option<(u32, u32)> {
        if width == 0 || height == 0 || bx >= half(width) || by >= half(height) {
            return None;
        }
        let s = self.sub_pixel(bx, by);
        let (x, y) = (2 * bx + s.x, 2 * by + s.y);
        Some((
            if x < width { x } else { width - 1 },
            if y < height { y } else { height - 1 },
        ))
    }

    /// Whether pixel `(x, y)` of a `width x height` image is the one its
    /// block traces.
    pub const fn is_traced(&self, x: u32, y: u32, width: u32, height: u32) -> bool {
        match self.traced_pixel(x / 2, y / 2, width, height) {
            Some((tx, ty)) => tx == x && ty == y,
            None => false,
        }
    }
}

/// `ceil(n / 2)` without overflow.
const fn half(n: u32) -> u32 {
    n / 2 + n % 2
}

/// The size of the half-resolution (per block) images of a `width x
/// height` frame: `(ceil(width / 2), ceil(height / 2))`.
///
/// # Errors
/// [`Error::InvalidArgument`] if `width` or `height` is zero.
pub fn try_half_size(width: u32, height: u32) -> Result<(u32, u32), Error> {
    if width == 0 || height == 0 {
        return Err(Error::InvalidArgument);
    }
    Ok((half(width), half(height)))
}

/// Texels of a tight (stride = width) half-resolution image of a `width
/// x height` frame ([`try_half_size`]).
///
/// # Errors
/// [`Error::InvalidArgument`] if `width` or `height` is zero, or the count
/// does not fit in `usize`.
pub fn try_half_len(width: u32, height: u32) -> Result<usize, Error> {
    let (w, h) = try_half_size(width, height)?;
    crate::image::try_required_len(w, h, w)
}
