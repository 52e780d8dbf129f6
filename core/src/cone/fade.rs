//! The fades of seed 004 Sec. 4.6.1 ([`FadeRange`], [`Fades`]) and the
//! blend toward the fallback color ([`blend_fade`]).

use super::ColorTexel;
use crate::Error;
use glam::{Vec2, Vec3};

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
