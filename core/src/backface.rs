//! Back-face depth images for the G-buffer ([`crate::GBuffer::try_with_back_depth`],
//! [`crate::Thickness::BackFaces`]): a hit test against the depth buffer needs to
//! know how far behind each front surface the object ends, and a back-face
//! image answers that far better than a constant thickness (issue 13: 99.3%
//! of the visible hits found within one pixel against 95.6-97.1% for
//! constants). Two ways to build one, both writing the image the G-buffer
//! expects (same camera, size and convention as the front depth):
//!
//! * [`try_back_depth`], from the host's **second depth pass**: the scene
//!   drawn again with front faces culled (back faces only, depth test as
//!   usual), so each texel holds the nearest back face; where nothing is
//!   behind it holds the cleared value. The pass validates it against the
//!   front depth and clamps it so that the back is never in front of the
//!   front.
//! * `try_back_depth_layered` (feature `layered`), from **layered depth
//!   cube maps** (seed 001) of the objects: per pixel, the depth where the
//!   primary ray leaves the object whose front surface the pixel sees
//!   (`crate::layered::LayeredMap::exit`), for hosts that build maps but have no second
//!   pass, or to refine one.
//!
//! # Example
//! ```rust
//! use refl_core::glam::Vec3;
//! use refl_core::{try_back_depth, BackDepthStats, Camera, DepthConvention, DepthImage};
//! use refl_core::{ImageView, ImageViewMut};
//!
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 1.0, 101.0, 2, 2)?;
//! let d = |z: f32| cam.encode_depth(z, DepthConvention::ZeroToOne);
//! // Front surfaces at depth 2, except the sky texel (the cleared value 1).
//! let front = [d(2.0), d(2.0), d(2.0), 1.0];
//! // The back-face pass: behind the front, in front of it (noise), cleared, under the sky.
//! let back = [d(3.0), d(1.5), 1.0, 0.7];
//! let front = DepthImage::try_new(ImageView::try_new(&front, 2, 2, 2)?, cam, DepthConvention::ZeroToOne)?;
//! let back = ImageView::try_new(&back, 2, 2, 2)?;
//! let mut out = [0.0f32; 4];
//! let stats = try_back_depth(&mut ImageViewMut::try_new(&mut out, 2, 2, 2)?, &front, &back)?;
//! // Kept, clamped to the front, kept (solid to the far plane), kept (no surface).
//! assert_eq!(out, [d(3.0), d(2.0), 1.0, 0.7]);
//! assert_eq!(stats, BackDepthStats { surfaces: 3, clamped: 1, cleared: 1, exits: 0 });
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! # The cleared-value rule (as [`crate::Thickness::BackFaces`] reads it)
//! A back texel behind its front texel is kept as stored, bit for bit, the
//! cleared value included (`1` for `[0, 1]` depth, `0` for reversed-Z,
//! `far` or `+inf` for linear): a surface with nothing behind it in the
//! back-face pass (a one-sided floor or wall, a mesh open at the back) is
//! then **solid to the far plane**, so rays passing behind it are hits, as
//! for any wall. A back texel in front of its front texel (a back face of
//! a nearer object, depth-precision noise) or NaN is replaced by the front
//! depth: a zero-thick shell there. Pixels without a front surface (NaN,
//! not in front of the far plane) keep the back value as stored: the
//! kernels never read it there.
//!
//! The layered rule writes, where a map finds the pixel's exit, the
//! nearer of that exit and the value already in the image if that value
//! is a valid back depth (not NaN, not in front of the front), else the
//! exit; the image holds [`try_back_depth`]'s result or the cleared value
//! beforehand (so several maps, and a second pass, combine: the back depth
//! is the nearest exit any of them knows).

#[cfg(feature = "layered")]
use crate::{layered::LayeredMap, Ray};
use crate::{DepthImage, Error, ImageView, ImageViewMut};
#[cfg(feature = "layered")]
use glam::Vec2;

/// Counts of one back-depth call over a band.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BackDepthStats {
    /// Pixels with a front surface.
    pub surfaces: u32,
    /// Of those, pixels whose back value was NaN or in front of the front
    /// and was replaced by the front depth ([`try_back_depth`]).
    pub clamped: u32,
    /// Of those, pixels whose back value is the cleared value (solid to the
    /// far plane; [`try_back_depth`]).
    pub cleared: u32,
    /// Pixels where a layered map found the exit and wrote it
    /// (`try_back_depth_layered`; counted also where the value already
    /// there was nearer and was kept).
    pub exits: u32,
}

/// `true` if stored depth `b` is at or behind `f` (convention `c`).
fn behind(b: f32, f: f32, closer_is_greater: bool) -> bool {
    if closer_is_greater {
        b <= f
    } else {
        b >= f
    }
}

/// The front texel's stored depth if it is a surface: decodes to a linear
/// depth in `[near, far)`.
fn front_surface(front: &DepthImage<'_>, x: u32, y: u32) -> Option<f32> {
    let f = front.depth().get(x, y)?;
    let cam = front.camera();
    let z = cam.decode_depth(f, front.convention());
    (z >= cam.near() && z < cam.far()).then_some(f)
}

fn check_sizes(dst: &ImageViewMut<'_, f32>, front: &DepthImage<'_>) -> Result<(), Error> {
    if dst.width() != front.width() || dst.height() != front.height() {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

/// Builds the G-buffer's back-face image from the host's back-face depth
/// pass `back` (same camera, size and convention as `front`, module docs)
/// over the rows `dst` owns (a whole image or a band from
/// [`ImageViewMut::try_band`]): per pixel with a front surface, the back
/// value if it lies at or behind the front (the cleared value included:
/// solid to the far plane), else the front value; elsewhere the back value
/// as stored.
///
/// # Errors
/// [`Error::InvalidArgument`] if `dst` or `back` is not `front`'s size.
/// Nothing is written then.
pub fn try_back_depth(
    dst: &mut ImageViewMut<'_, f32>,
    front: &DepthImage<'_>,
    back: &ImageView<'_, f32>,
) -> Result<BackDepthStats, Error> {
    check_sizes(dst, front)?;
    if back.width() != front.width() || back.height() != front.height() {
        return Err(Error::InvalidArgument);
    }
    let mut st = BackDepthStats::default();
    let Some(rows) = dst.owned_rows() else {
        return Ok(st);
    };
    let c = front.convention();
    let cam = front.camera();
    for y in rows.rows() {
        for x in 0..front.width() {
            let Some(b) = back.get(x, y) else { continue };
            let v = match front_surface(front, x, y) {
                None => b,
                Some(f) => {
                    st.surfaces += 1;
                    if behind(b, f, c.closer_is_greater()) {
                        if !(cam.decode_depth(b, c) < cam.far()) {
                            st.cleared += 1;
                        }
                        b
                    } else {
                        st.clamped += 1;
                        f
                    }
                }
            };
            if let Some(p) = dst.get_mut(x, y) {
                *p = v;
            }
        }
    }
    Ok(st)
}

/// Writes into the rows `dst` owns, for every pixel whose front surface
/// lies on the object of `map` (the primary ray enters the object within
/// [`crate::layered::EXIT_ENTRY_TEXELS`] texels behind the front point),
/// the depth where the primary ray leaves it ([`LayeredMap::exit`]),
/// encoded in `front`'s convention (clamped to the far plane and to the
/// front), where it is nearer than the valid back depth already there
/// (module docs); other pixels are left as they are.
///
/// # Errors
/// [`Error::InvalidArgument`] if `dst` is not `front`'s size. Nothing is
/// written then.
#[cfg(feature = "layered")]
pub fn try_back_depth_layered(
    dst: &mut ImageViewMut<'_, f32>,
    front: &DepthImage<'_>,
    map: &LayeredMap<'_>,
) -> Result<BackDepthStats, Error> {
    check_sizes(dst, front)?;
    let mut st = BackDepthStats::default();
    let Some(rows) = dst.owned_rows() else {
        return Ok(st);
    };
    let c = front.convention();
    let cam = front.camera();
    let greater = c.closer_is_greater();
    // World direction of the view axis (-z of the view).
    let forward = -cam.inverse_view().z_axis.truncate();
    for y in rows.rows() {
        for x in 0..front.width() {
            let Some(f) = front_surface(front, x, y) else {
                continue;
            };
            st.surfaces += 1;
            let center = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let dir = cam.primary_ray(center).dir;
            let ray = Ray {
                origin: cam.unproject(center, f, c),
                dir,
            };
            let Some(t) = map.exit(&ray) else { continue };
            st.exits += 1;
            let z = cam.decode_depth(f, c) + t * dir.dot(forward);
            let mut e = cam.encode_depth(z.min(cam.far()), c);
            if !behind(e, f, greater) || e.is_nan() {
                e = f;
            }
            let Some(p) = dst.get_mut(x, y) else { continue };
            let old = *p;
            let valid_old = !old.is_nan() && behind(old, f, greater);
            if !valid_old || (behind(old, e, greater) && old != e) {
                *p = e;
            }
        }
    }
    Ok(st)
}
