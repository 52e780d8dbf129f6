//! Reflection warping, the re-trace mask and list, and output composition
//! (seed 000 Sec. 3.3).
//!
//! # Example
//! ```rust
//! use refl_core::tcrr::{try_retrace_list, try_warp, CurrentView, COVERAGE_REUSE};
//! use refl_core::tcrr::{MASK_RETRACE, MASK_REUSED};
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::{Camera, DepthConvention, ImageView, ImageViewMut, ReflectionBuffers, TcrrOptions};
//!
//! // The key frame: 8 x 8 pixels looking straight down from (0, 2, 0) at the mirror
//! // floor y = 0, 1/4 unit per pixel (x right, z down the image). The reflected rays
//! // end on a ceiling at y = 4: at twice the distance from the eye to the floor point.
//! let look = |x: f32| {
//!     let eye = Vec3::new(x, 2.0, 0.0);
//!     Camera::try_look_at(eye, eye - Vec3::Y, Vec3::NEG_Z, 2.0 * 0.5f32.atan(), 0.1, 100.0, 8, 8)
//! };
//! let key = look(0.0)?;
//! let center = |i: usize| Vec2::new((i % 8) as f32 + 0.5, (i / 8) as f32 + 0.5);
//! let floor = |i: usize| key.unproject(center(i), 2.0, DepthConvention::Linear);
//! let distance: Vec<f32> = (0..64).map(|i| 2.0 * (floor(i) - key.eye()).length()).collect();
//! let color: Vec<[f32; 3]> = (0..64).map(|i| [(i % 8) as f32 / 8.0, (i / 8) as f32 / 8.0, 0.5]).collect();
//! let (depth, normal, specular) = ([2.0f32; 64], [[0.0f32, 1.0, 0.0]; 64], [1.0f32; 64]);
//! fn view<T: Copy>(data: &[T]) -> Result<ImageView<'_, T>, refl_core::Error> {
//!     ImageView::try_new(data, 8, 8, 8)
//! }
//! let (depth, normal, specular) = (view(&depth)?, view(&normal)?, view(&specular)?);
//! let buffers = ReflectionBuffers::try_new(
//!     key, DepthConvention::Linear, depth, normal, specular, view(&color)?, view(&distance)?,
//! )?;
//!
//! // The current frame: the eye moved to (0.25, 2, 0), one key pixel to the right;
//! // it sees the same floor at depth 2, all reflective.
//! let current = CurrentView::try_new(look(0.25)?, DepthConvention::Linear, depth, specular)?;
//! // The seed's naive baseline: warp the key frame's own reflections (every texel
//! // reusable, no contrast test).
//! let path: Vec<f32> = distance.iter().map(|r| 2.0 + r).collect();
//! let reusable = [COVERAGE_REUSE; 64];
//! let options = TcrrOptions { retrace_contrast: f32::INFINITY, ..TcrrOptions::default() };
//! let (mut warped, mut mask) = ([[0.0f32; 3]; 64], [0u8; 64]);
//! let stats = try_warp(
//!     &mut ImageViewMut::try_new(&mut warped, 8, 8, 8)?,
//!     &mut ImageViewMut::try_new(&mut mask, 8, 8, 8)?,
//!     &current,
//!     &buffers,
//!     &view(&color)?,
//!     &view(&path)?,
//!     &view(&reusable)?,
//!     &options,
//! )?;
//! assert_eq!((stats.reused, stats.retrace), (56, 8));
//! // Pixel (x, y) sees key pixel (x + 1, y)'s surface and takes its reflection; the
//! // last column sees floor beyond the key frame: re-trace.
//! for i in 0..64 {
//!     match i % 8 {
//!         7 => assert_eq!(mask[i], MASK_RETRACE),
//!         _ => assert_eq!((mask[i], warped[i]), (MASK_REUSED, color[i + 1])),
//!     }
//! }
//! let mut list = [0u32; 64];
//! let n = try_retrace_list(&mut list, &view(&mask)?)?;
//! assert_eq!(&list[..n], &[7, 15, 23, 31, 39, 47, 55, 63]);
//! # Ok::<(), refl_core::Error>(())
//! ```

use super::{ReflectionBuffers, Surf, TcrrOptions, SNAP_PX};
use crate::{Camera, DepthConvention, Error, ImageView, ImageViewMut};
use glam::{Vec2, Vec3};

/// Re-trace mask value: not a reflective pixel of the current frame.
pub const MASK_NONE: u8 = 0;
/// Re-trace mask value: reflection reused from the key frame.
pub const MASK_REUSED: u8 = 1;
/// Re-trace mask value: the host must trace this pixel's reflection.
pub const MASK_RETRACE: u8 = 2;

/// The current frame as TCRR reads it: its camera (`E_cur` is its eye),
/// its depth buffer in `convention` and its specular factors (`> 0` marks
/// the reflective pixels that need a reflection).
#[derive(Clone, Copy, Debug)]
pub struct CurrentView<'a> {
    camera: Camera,
    convention: DepthConvention,
    depth: ImageView<'a, f32>,
    specular: ImageView<'a, f32>,
}

impl<'a> CurrentView<'a> {
    /// Binds the current frame's depth and specular views to its camera.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if a view's size differs from the
    /// camera's.
    pub fn try_new(
        camera: Camera,
        convention: DepthConvention,
        depth: ImageView<'a, f32>,
        specular: ImageView<'a, f32>,
    ) -> Result<Self, Error> {
        let (w, h) = (camera.width(), camera.height());
        if depth.width() != w
            || depth.height() != h
            || specular.width() != w
            || specular.height() != h
        {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            camera,
            convention,
            depth,
            specular,
        })
    }

    /// The current camera.
    pub const fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Width in pixels.
    pub const fn width(&self) -> u32 {
        self.camera.width()
    }

    /// Height in pixels.
    pub const fn height(&self) -> u32 {
        self.camera.height()
    }

    /// `true` if pixel `(x, y)` is reflective.
    #[inline]
    fn reflective(&self, x: u32, y: u32) -> bool {
        self.specular.get(x, y).is_some_and(|s| s > 0.0)
    }

    /// World point seen through pixel `(x, y)`, if its depth is a positive
    /// distance in front of the far plane.
    #[inline]
    fn point(&self, x: u32, y: u32) -> Option<(Vec3, f32)> {
        let d = self.depth.get(x, y)?;
        let z = self.camera.decode_depth(d, self.convention);
        // A surface lies in front of the far plane: a depth at the far
        // plane (a cleared depth buffer, the background) or beyond holds
        // none (fuzz finding F9).
        if !(z > 0.0 && z.is_finite() && z < self.camera.far()) {
            return None;
        }
        let p = self.camera.unproject(
            Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
            d,
            self.convention,
        );
        p.is_finite().then_some((p, z))
    }
}

/// Counts of one warping pass over its band.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WarpStats {
    /// Reflective pixels of the current frame.
    pub reflective: u32,
    /// Pixels whose reflection was reused.
    pub reused: u32,
    /// Pixels marked [`MASK_RETRACE`].
    pub retrace: u32,
}

impl WarpStats {
    /// Sums two bands' counts.
    pub fn merged(self, other: WarpStats) -> WarpStats {
        WarpStats {
            reflective: self.reflective + other.reflective,
            reused: self.reused + other.reused,
            retrace: self.retrace + other.retrace,
        }
    }
}

/// Warps an image attached to the key frame's surfaces into the current
/// view by depth (seed 000 Sec. 3.3: "a common depth-based warping"),
/// reverse-reprojection style, over the rows `color` and `mask` own (the
/// same band).
///
/// For TCRR `source`, `source_depth` and `coverage` are the intermediate
/// reflection image, its depth (`s.d + s.r`) and its coverage from
/// [`super::try_shift`]; for the naive baseline of the seed (Figs. 1, 6) they
/// are the key frame's own reflected colors (B.3), its linear depth plus
/// reflected distance, and its reflective mask (with
/// [`TcrrOptions::retrace_contrast`] `= +inf`).
///
/// Per current pixel: not reflective -> [`MASK_NONE`], color 0. Otherwise
/// its surface point `P` (current depth) is projected into the key camera;
/// if it lands outside the key image, or the key texel nearest to it is
/// not [`super::shift::COVERAGE_REUSE`] or does not see `P`'s surface (`P` farther than
/// [`TcrrOptions::discontinuity`]` * z` from the texel's tangent plane:
/// disocclusion), the pixel is marked [`MASK_RETRACE`] (color 0). Otherwise
/// it is [`MASK_REUSED`] with the bilinear interpolation of the covered
/// texels around the projection that see the same surface (weights
/// renormalized); if one of them is not reusable (a gap of the shifted mesh on
/// `P`'s surface) or has a `source_depth` discontinuous with the nearest
/// texel's (beyond [`TcrrOptions::reflected_discontinuity`]), the pixel
/// straddles a reflection edge and is marked [`MASK_RETRACE`] too, as is a
/// pixel whose taps' colors differ by more than
/// [`TcrrOptions::retrace_contrast`] in a channel (a reflected edge inside
/// the reflection, an addition to the seed). A projection within
/// [`SNAP_PX`] of a texel center takes that texel exactly.
///
/// # Errors
/// [`Error::InvalidArgument`] (nothing written) if the current view's size
/// differs from `color`'s or `mask`'s, `source`'s, `source_depth`'s or
/// `coverage`'s from the key buffers', the outputs own different bands, or `options` is out of
/// range.
#[allow(clippy::too_many_arguments)]
pub fn try_warp(
    color: &mut ImageViewMut<'_, [f32; 3]>,
    mask: &mut ImageViewMut<'_, u8>,
    current: &CurrentView<'_>,
    buffers: &ReflectionBuffers<'_>,
    source: &ImageView<'_, [f32; 3]>,
    source_depth: &ImageView<'_, f32>,
    coverage: &ImageView<'_, u8>,
    options: &TcrrOptions,
) -> Result<WarpStats, Error> {
    options.try_validate()?;
    let (w, h) = (current.width(), current.height());
    let (kw, kh) = (buffers.width(), buffers.height());
    if color.width() != w
        || color.height() != h
        || mask.width() != w
        || mask.height() != h
        || source.width() != kw
        || source.height() != kh
        || coverage.width() != kw
        || coverage.height() != kh
        || source_depth.width() != kw
        || source_depth.height() != kh
        || color.owned_rows() != mask.owned_rows()
    {
        return Err(Error::InvalidArgument);
    }
    let mut stats = WarpStats::default();
    let Some(rows) = color.owned_rows() else {
        return Ok(stats);
    };
    let key = buffers.camera();
    for y in rows.rows() {
        for x in 0..w {
            let (m, c) = if current.reflective(x, y) {
                stats.reflective += 1;
                match warp_pixel(
                    current,
                    x,
                    y,
                    key,
                    buffers,
                    (source, source_depth, coverage),
                    options,
                ) {
                    Some(c) => {
                        stats.reused += 1;
                        (MASK_REUSED, c)
                    }
                    None => {
                        stats.retrace += 1;
                        (MASK_RETRACE, [0.0; 3])
                    }
                }
            } else {
                (MASK_NONE, [0.0; 3])
            };
            if let Some(v) = mask.get_mut(x, y) {
                *v = m;
            }
            if let Some(v) = color.get_mut(x, y) {
                *v = c;
            }
        }
    }
    Ok(stats)
}

/// `true` if key texel surface `k` sees the current point `p` (depth `z`).
#[inline]
fn sees(k: &Surf, p: Vec3, z: f32, tol: f32) -> bool {
    k.normal.dot(p - k.pos).abs() <= tol * z.min(k.z)
}

#[allow(clippy::too_many_arguments)]
#[inline]
fn warp_pixel(
    current: &CurrentView<'_>,
    x: u32,
    y: u32,
    key: &Camera,
    buffers: &ReflectionBuffers<'_>,
    (source, source_depth, coverage): (
        &ImageView<'_, [f32; 3]>,
        &ImageView<'_, f32>,
        &ImageView<'_, u8>,
    ),
    options: &TcrrOptions,
) -> Option<[f32; 3]> {
    let (p, z) = current.point(x, y)?;
    let q = key.project(p)?;
    let (kw, kh) = (buffers.width() as f32, buffers.height() as f32);
    if !(q.x >= 0.0 && q.x < kw && q.y >= 0.0 && q.y < kh) {
        return None;
    }
    // Texel-space position: texel (i, j) has its center at (i + .5, j + .5).
    let (fx, fy) = (q.x - 0.5, q.y - 0.5);
    let snap = |f: f32| {
        // f lies in [-0.5, size - 0.5): floor_small is exact there.
        let i = super::shift::floor_small(f);
        let t = f - i;
        if t < SNAP_PX {
            (i, 0.0)
        } else if t > 1.0 - SNAP_PX {
            (i + 1.0, 0.0)
        } else {
            (i, t)
        }
    };
    let ((ix, tx), (iy, ty)) = (snap(fx), snap(fy));
    // Per texel: `None` if it shows another surface (or lies outside),
    // `Some(None)` if it shows P's surface but holds no reflection (a gap
    // of the shifted mesh), `Some(Some(color, depth))` otherwise.
    let texel = |i: f32, j: f32| -> Option<Option<([f32; 3], f32)>> {
        if i < 0.0 || j < 0.0 || i >= kw || j >= kh {
            return None;
        }
        let (i, j) = (i as u32, j as u32);
        let k = buffers.surface(i, j)?;
        sees(&k, p, z, options.discontinuity).then_some(())?;
        if coverage.get(i, j)? != super::shift::COVERAGE_REUSE {
            return Some(None);
        }
        Some(Some((source.get(i, j)?, source_depth.get(i, j)?)))
    };
    // The nearest texel decides whether the pixel is reused.
    let (nx, ny) = (ix + f32::from(tx >= 0.5), iy + f32::from(ty >= 0.5));
    let (nearest, nd) = texel(nx, ny)??;
    if tx == 0.0 && ty == 0.0 {
        return Some(nearest);
    }
    // Texels across a discontinuity of the reflected path from the nearest
    // one, or gaps: the pixel straddles a reflection edge whose position
    // inside it is unknown, so it is re-traced.
    let tol = options.reflected_discontinuity;
    let same_path = |d: f32| match (d.is_finite(), nd.is_finite()) {
        (true, true) => (d - nd).abs() <= tol * d.min(nd),
        (false, false) => true,
        _ => false,
    };
    let mut sum = Vec3::ZERO;
    let mut wsum = 0.0f32;
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for (i, j, wt) in [
        (ix, iy, (1.0 - tx) * (1.0 - ty)),
        (ix + 1.0, iy, tx * (1.0 - ty)),
        (ix, iy + 1.0, (1.0 - tx) * ty),
        (ix + 1.0, iy + 1.0, tx * ty),
    ] {
        if wt > 0.0 {
            // The nearest texel was fetched above.
            let tap = if (i, j) == (nx, ny) {
                Some(Some((nearest, nd)))
            } else {
                texel(i, j)
            };
            match tap {
                None => {}
                Some(None) => return None,
                Some(Some((c, d))) => {
                    if !same_path(d) {
                        return None;
                    }
                    let c = Vec3::from_array(c);
                    sum += c * wt;
                    wsum += wt;
                    lo = lo.min(c);
                    hi = hi.max(c);
                }
            }
        }
    }
    // A reflected edge between the taps: the ray-traced frame point-samples
    // it, resampling the key frame blurs it (the error of reuse
    // concentrates there), so the pixel is re-traced.
    if (hi - lo).max_element() > options.retrace_contrast {
        return None;
    }
    (wsum > 0.0).then(|| (sum / wsum).to_array())
}

/// Number of [`MASK_RETRACE`] pixels in `mask`.
pub fn retrace_count(mask: &ImageView<'_, u8>) -> usize {
    (0..mask.height())
        .filter_map(|y| mask.row(y))
        .map(|r| r.iter().filter(|&&m| m == MASK_RETRACE).count())
        .sum()
}

/// Writes the pixel indices `y * width + x` of the [`MASK_RETRACE`] pixels
/// of `mask`, in row-major order, to the front of `list` (the compact list
/// of pixels for the host's ray tracer, seed 000 Sec. 3.3) and returns how
/// many it wrote. Size `list` with [`retrace_count`] (or `width * height`).
///
/// # Errors
/// [`Error::InvalidArgument`] if `width * height` does not fit in `u32`;
/// [`Error::InsufficientSize`] (nothing written) if `list` is shorter than
/// the count.
pub fn try_retrace_list(list: &mut [u32], mask: &ImageView<'_, u8>) -> Result<usize, Error> {
    if u64::from(mask.width()) * u64::from(mask.height()) > u64::from(u32::MAX) {
        return Err(Error::InvalidArgument);
    }
    let n = retrace_count(mask);
    if list.len() < n {
        return Err(Error::InsufficientSize);
    }
    let mut k = 0usize;
    for y in 0..mask.height() {
        let Some(row) = mask.row(y) else { continue };
        for (x, &m) in row.iter().enumerate() {
            if m == MASK_RETRACE {
                list[k] = y * mask.width() + x as u32;
                k += 1;
            }
        }
    }
    Ok(k)
}

/// How [`try_compose`] weights the reflection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fresnel {
    /// The specular factor itself: `w = f`.
    Off,
    /// Schlick's approximation with the specular factor as the reflectance
    /// at normal incidence: `w = f + (1 - f) (1 - cos theta)^5`.
    Schlick,
}

/// The reflection weight of seed 000 Sec. 3.3 ("interpolating the diffuse
/// component and reflection component with weights defined by Fresnel
/// terms computed from camera position, the geometry normal and the pixel's
/// specular level"): for specular factor `f` (clamped to `[0, 1]`) and
/// `cos_theta = n . v` (clamped to `[0, 1]`), `f` for [`Fresnel::Off`] and
/// `f + (1 - f) (1 - cos_theta)^5` for [`Fresnel::Schlick`]. Zero for a
/// non-positive or NaN `f`.
pub fn fresnel_weight(f: f32, cos_theta: f32, mode: Fresnel) -> f32 {
    if !(f > 0.0) {
        return 0.0;
    }
    let f = f.min(1.0);
    match mode {
        Fresnel::Off => f,
        Fresnel::Schlick => {
            let c = if cos_theta.is_nan() {
                0.0
            } else {
                cos_theta.clamp(0.0, 1.0)
            };
            let m = 1.0 - c;
            let m2 = m * m;
            f + (1.0 - f) * m2 * m2 * m
        }
    }
}

/// Output composition (seed 000 Alg. 1 line 7, Sec. 3.3): over the rows
/// `out` owns, `out = (1 - w) diffuse + w reflection` at the current
/// frame's reflective pixels with `w =` [`fresnel_weight`] of the specular
/// factor and `cos_theta = n . normalize(E_cur - P)` (`P` from the current
/// depth, `n` the current normal), and `out = diffuse` elsewhere (and where
/// the depth has no surface).
///
/// # Errors
/// [`Error::InvalidArgument`] (nothing written) if a view's size differs
/// from the current view's.
pub fn try_compose(
    out: &mut ImageViewMut<'_, [f32; 3]>,
    diffuse: &ImageView<'_, [f32; 3]>,
    reflection: &ImageView<'_, [f32; 3]>,
    normal: &ImageView<'_, [f32; 3]>,
    current: &CurrentView<'_>,
    mode: Fresnel,
) -> Result<(), Error> {
    let (w, h) = (current.width(), current.height());
    let sized = |vw: u32, vh: u32| vw == w && vh == h;
    if !(sized(out.width(), out.height())
        && sized(diffuse.width(), diffuse.height())
        && sized(reflection.width(), reflection.height())
        && sized(normal.width(), normal.height()))
    {
        return Err(Error::InvalidArgument);
    }
    let Some(rows) = out.owned_rows() else {
        return Ok(());
    };
    let eye = current.camera().eye();
    for y in rows.rows() {
        for x in 0..w {
            let (Some(d), Some(r)) = (diffuse.get(x, y), reflection.get(x, y)) else {
                continue;
            };
            let (d, r) = (Vec3::from_array(d), Vec3::from_array(r));
            let f = current.specular.get(x, y).unwrap_or(0.0);
            let weight = match (f > 0.0, current.point(x, y)) {
                (true, Some((p, _))) => {
                    let n = normal
                        .get(x, y)
                        .map(Vec3::from_array)
                        .and_then(Vec3::try_normalize);
                    let v = (eye - p).try_normalize();
                    let cos = match (n, v) {
                        (Some(n), Some(v)) => n.dot(v),
                        _ => 1.0,
                    };
                    fresnel_weight(f, cos, mode)
                }
                _ => 0.0,
            };
            if let Some(o) = out.get_mut(x, y) {
                *o = if weight > 0.0 {
                    (d * (1.0 - weight) + r * weight).to_array()
                } else {
                    d.to_array()
                };
            }
        }
    }
    Ok(())
}
