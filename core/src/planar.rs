//! The planar mirror pass: G-buffer and mirror plane in, everything a host
//! needs to render the planar reflection out, in one call, then the
//! reflection resolved per pixel from the host's mirrored render
//! (design.md, "Passes"; issue 13).
//!
//! A planar mirror is exact by rasterization: the scene drawn through the
//! mirrored camera (seed 001 appendix, [`try_mirrored_camera`]) shows at every
//! mirror pixel what the reflected primary ray sees, once geometry behind
//! the mirror is clipped away (an oblique near plane,
//! [`try_oblique_projection`], or a user clip plane). What a host still had to
//! work out itself, and what this pass does:
//!
//! 1. **Setup** ([`PlanarPass::try_new`], [`PlanarPass::prepare`], or
//!    [`PlanarPass::setup`] from coverage counted over bands): the
//!    plane oriented toward the eye, the mirrored camera at the render's
//!    resolution ([`PlanarOptions::scale`]), the projection the render must
//!    use (oblique, in the G-buffer's depth convention), the clip plane in
//!    world and render view space, whether the front-face test flips, and
//!    the pixels the plane covers with their rectangle (scissor) in the
//!    G-buffer and in the render. Nothing covered: skip the mirrored render.
//! 2. **Coverage** ([`PlanarPass::cover`], [`PlanarPass::try_cover`]): which
//!    pixels lie on the plane (rule below), per pixel, over row bands.
//! 3. **Resolve** ([`PlanarPass::try_resolve`], [`PlanarPass::try_resolve_rows`]):
//!    given the host's mirrored render (depth, optionally color), per
//!    covered pixel the render texel that answers it, the distance from the
//!    mirror to the reflected surface and the reflection color, upsampled
//!    with a depth guide at reduced resolution; pixels whose reflection the
//!    render has no surface for (the environment) are flagged and handed
//!    out as rays ([`PlanarRay`]) for the host's probe or tracer.
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::glam::Vec3;
//! use refl_core::{Camera, DepthConvention, DepthImage, GBuffer, ImageView, ImageViewMut};
//! use refl_core::{NormalSpace, PlanarOptions, PlanarPass, PlanarRect, PlanarRender};
//! use refl_core::{PlanarStatus, PlanarTexel, Plane};
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
//! let depth = DepthImage::try_new(ImageView::try_new(&depth, 16, 16, 16)?, cam, DepthConvention::Linear)?;
//! let gbuffer = GBuffer::try_new(depth, ImageView::try_new(&normals, 16, 16, 16)?, NormalSpace::World)?;
//!
//! // Setup: the floor covers rows 10 to 15 (depth -1 / NDC y below 4), and the
//! // render's eye is the mirrored eye (0, -1, 0).
//! let floor = Plane::try_from_point_normal(Vec3::ZERO, Vec3::Y)?;
//! let pass = PlanarPass::try_new(gbuffer, floor, PlanarOptions::default())?;
//! let setup = pass.prepare();
//! assert_eq!((setup.covered_pixels, setup.rect), (96, PlanarRect { x0: 0, y0: 10, x1: 16, y1: 16 }));
//! assert!(setup.flip_winding && (setup.camera.eye() - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-5);
//!
//! // The host's render through `setup.camera` sees the wall at linear depth 4.
//! let wall = vec![4.0f32; 256];
//! let render = PlanarRender::try_new(ImageView::try_new(&wall, 16, 16, 16)?, None)?;
//! let mut out = vec![PlanarTexel::default(); 256];
//! let stats = pass.try_resolve(&mut ImageViewMut::try_new(&mut out, 16, 16, 16)?, None, &mut [], &render)?;
//! assert_eq!(stats.hits, 96);
//! // Pixel (8, 13): from the floor point P (depth 16/11) to the wall point Q at
//! // height -1 + 4 (11/16), t = (4 - 16/11) |(1/16, -11/16, -1)|.
//! let (p, q) = (Vec3::new(1.0 / 11.0, 0.0, -16.0 / 11.0), Vec3::new(0.25, 1.75, -4.0));
//! let texel = out[13 * 16 + 8];
//! assert_eq!((texel.status, texel.texel), (PlanarStatus::Hit, [8, 13]));
//! assert!((texel.t - (q - p).length()).abs() < 1e-3);
//! assert_eq!(out[2 * 16 + 8].status, PlanarStatus::OffPlane); // the wall
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! # Coverage (ours)
//! A pixel is covered when it passes, in this order:
//! * its object id equals the mirror's (only with an id image,
//!   [`PlanarPass::try_with_ids`]) and its G-buffer mask (if any) is not 0,
//!   otherwise [`PlanarStatus::Skipped`] (roughness is not read);
//! * it has a surface: linear depth `L` in `[near, far)` and a usable
//!   normal, otherwise [`PlanarStatus::NoSurface`];
//! * its normal is within the angle of the plane's: `|n . n_plane| >=`
//!   [`PlanarOptions::normal_cos`] (either orientation; `0` turns the test
//!   off, e.g. for normal-mapped mirrors);
//! * its world point lies on the plane:
//!   `|dist| <= plane_tolerance L + COVER_DEPTH_ULPS q |k|`.
//!
//! Here the distance is taken eye-relative, so that a scene far from the
//! origin loses no precision: the point seen at linear depth `L` through
//! the pixel center is `eye + L w` with `w = V^-1 (s_x, s_y, -1)` the view
//! ray scaled to unit depth (`s_x = ndc_x tan(fov_x / 2)`, `s_y = ndc_y
//! tan(fov_y / 2)`), so `dist = n . (eye + L w) + d = d_v + L k` with
//! `d_v = n . eye + d` (the eye's distance, once per frame in f64) and
//! `k = n_v . (s_x, s_y, -1)` (`n_v` the plane normal in view space). The
//! tolerance has two parts: [`PlanarOptions::plane_tolerance`] times the
//! depth (how far off the plane a mirror surface may be: modeling noise,
//! displacement; scale-free), and the stored depth's own quantization `q`,
//! the largest change of `L` when the stored value moves by one f32 step
//! (one ulp; large for `[0, 1]` depth far from the near plane), which moves
//! the point along its ray and so its distance by `q |k|`. At grazing
//! angles `|k|` is small (the ray runs along the plane), so the same depth
//! error moves the point's distance less: the test stays tight where a
//! tolerance in depth units would have to grow without bound.
//!
//! # The render
//! The host draws the scene (without the mirror itself) through
//! [`PlanarSetup::camera`] with [`PlanarSetup::projection`], flipping its
//! front-face test when [`PlanarSetup::flip_winding`] is set, into a depth
//! image of the render's size, and optionally a color image. Its depth is
//! read in the G-buffer's convention **as that projection writes it**:
//! with [`PlanarOptions::oblique`] the near plane is the mirror
//! ([`try_oblique_projection`]: depth is the near value on the mirror and no
//! longer a function of view distance alone; the pass decodes it with the
//! matrix's depth row). Without it, the projection is the camera's own and
//! the host clips with [`PlanarSetup::clip_plane`] (world) or
//! [`PlanarSetup::view_clip_plane`] (render view space), keeping the
//! positive side. A linear-depth G-buffer gets the `[0, 1]` projection for
//! rasterizing, and its render stores the render camera's linear view
//! depth. A texel is empty (the reflected ray meets no surface there) when
//! its depth is NaN or at or beyond the far value (the cleared value: `1`
//! for `[0, 1]`, `0` for reversed-Z, `>= far` or `+inf` for linear), or
//! decodes to a depth that is not finite and positive.
//!
//! # Resolve (the upsampling the root package used, moved here)
//! The render camera has the mirrored view, the G-buffer camera's `fov_y`,
//! near and far, and `ceil(w / scale) x ceil(h / scale)` pixels, so pixel
//! `(x, y)`'s reflected ray crosses the render at
//! `q = (w_r / 2 + (x + 0.5 - w / 2) s, h_r / 2 + (y + 0.5 - h / 2) s)`
//! with `s = h_r / h` (equal vertical fields of view; exact when `scale`
//! divides both sides, and `q = (x + 0.5, y + 0.5)` exactly at `scale = 1`).
//! * The **anchor** is the render texel containing `q` (clamped to the
//!   render): the surface the pixel's reflection shows (the root
//!   package's visibility rule: a host with a visibility buffer reshades
//!   that texel's primitive along the pixel's own ray, which is exact
//!   inside surfaces). An empty anchor gives [`PlanarStatus::Environment`].
//! * The **color** is the bilinear mean over the four texel centers
//!   around `q` of those that are not empty and whose linear depth is
//!   within [`PlanarOptions::edge_threshold`] times the anchor's of the
//!   anchor's (the depth guide: never across a depth edge beyond the
//!   threshold), renormalized; texels of weight exactly `0` are not read,
//!   so at `scale = 1` the color is the texel's, bit for bit.
//! * `t`, the distance from the mirror to the reflected surface along the
//!   reflected ray, is `max(0, L_r - L) |w|` with `L_r` the same mean of
//!   the render's linear depths, or the anchor's depth for a render
//!   without color (whose host reshades the anchor; no other texel is
//!   read then). The mirror point has the same linear depth `L` in both
//!   cameras: the mirror matrix fixes it.

use crate::mirror::{try_mirrored_camera, try_oblique_projection, Plane};
use crate::{Camera, DepthConvention, Error, GBuffer, ImageView, ImageViewMut, RowRange};
use glam::{DVec4, Mat4, Vec2, Vec3, Vec4};

/// How many steps of the stored depth's quantization (one f32 ulp of the
/// stored value, decoded) the coverage test allows on top of
/// [`PlanarOptions::plane_tolerance`] (module docs): rasterizers
/// interpolate depth with a few ulps of error.
pub const COVER_DEPTH_ULPS: f32 = 4.0;

/// Settings of the planar pass. [`PlanarOptions::default`] is what the
/// tests and the root package's report use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarOptions {
    /// Resolution divisor of the mirrored render (`>= 1`): it has
    /// `ceil(w / scale) x ceil(h / scale)` pixels.
    pub scale: u32,
    /// Clip at the mirror with an oblique near plane ([`try_oblique_projection`]);
    /// `false`: the camera's own projection, and the host clips with
    /// [`PlanarSetup::clip_plane`].
    pub oblique: bool,
    /// Coverage: the largest distance of a pixel's point from the plane,
    /// relative to its linear depth (finite, `>= 0`; module docs).
    pub plane_tolerance: f32,
    /// Coverage: the smallest `|cos|` of the angle between a pixel's normal
    /// and the plane's (`[0, 1]`; `0` turns the test off).
    pub normal_cos: f32,
    /// Resolve: render texels whose linear depth differs from the anchor's
    /// by more than this fraction of it are not blended (`>= 0`, `+inf`
    /// blends every non-empty texel; not NaN).
    pub edge_threshold: f32,
}

impl Default for PlanarOptions {
    /// Full resolution, oblique clipping, points within `1e-3` of their
    /// depth of the plane, normals within about 8 degrees (`cos >= 0.99`),
    /// blending across depth changes up to 5%.
    fn default() -> Self {
        Self {
            scale: 1,
            oblique: true,
            plane_tolerance: 1e-3,
            normal_cos: 0.99,
            edge_threshold: 0.05,
        }
    }
}

/// What the pass says about one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum PlanarStatus {
    /// Not the mirror's object id, mask 0, or a row the call did not write.
    #[default]
    Skipped = 0,
    /// No usable surface: sky, NaN depth, zero or non-finite normal.
    NoSurface = 1,
    /// A surface not on the plane (distance or normal beyond the
    /// tolerances), or any surface when the eye lies on the plane (it is
    /// seen edge-on: nothing can be covered).
    OffPlane = 2,
    /// On the plane ([`PlanarPass::cover`]).
    Covered = 3,
    /// Covered, and the render has a surface at the pixel's reflection
    /// ([`PlanarPass::try_resolve`]).
    Hit = 4,
    /// Covered, and the render has no surface there: the reflection is the
    /// environment (the host's probe), and the pixel's ray is handed out.
    Environment = 5,
}

impl PlanarStatus {
    /// `true` for the statuses of covered pixels (`Covered`, `Hit`,
    /// `Environment`).
    pub const fn is_covered(self) -> bool {
        matches!(self, Self::Covered | Self::Hit | Self::Environment)
    }
}

/// A half-open pixel rectangle `[x0, x1) x [y0, y1)`; all zero when
/// empty.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct PlanarRect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl PlanarRect {
    /// `true` if the rectangle holds no pixel.
    pub const fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    /// The smallest rectangle holding both (for merging the rectangles of
    /// row bands).
    #[inline]
    pub fn union(&self, o: &PlanarRect) -> PlanarRect {
        if self.is_empty() {
            return *o;
        }
        if o.is_empty() {
            return *self;
        }
        PlanarRect {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }

    #[inline]
    fn add(&mut self, x: u32, y: u32) {
        *self = self.union(&PlanarRect {
            x0: x,
            y0: y,
            x1: x + 1,
            y1: y + 1,
        });
    }
}

/// Everything the host needs to render the reflection (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarSetup {
    /// The camera to render the reflection with: the mirrored view
    /// ([`try_mirrored_camera`]), the G-buffer camera's `fov_y`, near and far,
    /// the render's size.
    pub camera: Camera,
    /// The projection (view to clip space) the render must use: the
    /// oblique one ([`try_oblique_projection`] of [`PlanarSetup::camera`] and
    /// [`PlanarSetup::clip_plane`]) in the G-buffer's convention (`[0, 1]`
    /// for a linear G-buffer), or the camera's own without
    /// [`PlanarOptions::oblique`] or when nothing is covered.
    pub projection: Mat4,
    /// The mirror plane, oriented toward the eye: keep what lies on its
    /// positive side.
    pub clip_plane: Plane,
    /// The same plane in the render camera's view space, `(n, d)` with
    /// `n . p + d = 0`: for a user clip plane in view space.
    pub view_clip_plane: Vec4,
    /// The render's view contains a reflection: flip the front-face test
    /// (or cull nothing).
    pub flip_winding: bool,
    /// Some pixel is covered; `false`: skip the mirrored render.
    pub covered: bool,
    /// Number of covered pixels.
    pub covered_pixels: u32,
    /// The covered pixels' bounding rectangle, G-buffer pixels.
    pub rect: PlanarRect,
    /// The render texels the resolve of those pixels reads (scissor),
    /// render pixels.
    pub scissor: PlanarRect,
}

/// Counts of one run over a band.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlanarStats {
    /// Covered pixels.
    pub covered: u32,
    /// Resolve: pixels whose reflection the render has a surface for.
    pub hits: u32,
    /// Resolve: pixels whose reflection is the environment.
    pub environment: u32,
    /// Resolve: rays handed out (the environment pixels).
    pub host_rays: u32,
    /// Of those, the ones stored in the host list (the first ones in
    /// row-major order).
    pub host_rays_written: u32,
    /// Bounding rectangle of the band's covered pixels (merge bands with
    /// [`PlanarRect::union`]).
    pub rect: PlanarRect,
}

/// One pixel of the resolve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlanarTexel {
    /// What the pass did.
    pub status: PlanarStatus,
    /// Where the pixel's reflected ray crosses the render (render pixels,
    /// module docs); `[0, 0]` unless `Hit` or `Environment`.
    pub pixel: Vec2,
    /// The anchor: the render texel that answers the pixel (module docs).
    /// `[0, 0]` unless `Hit` or `Environment`.
    pub texel: [u32; 2],
    /// Distance along the reflected ray from the mirror to the reflected
    /// surface (world units); `0` unless `Hit`. Finite: a distance beyond
    /// the f32 range (a render depth near `f32::MAX`) saturates at
    /// `f32::MAX`.
    pub t: f32,
}

/// A covered pixel whose reflection the render has no surface for: its
/// reflected ray, for the host's probe or tracer (C: `refl_host_ray` with
/// status `REFL_PLANAR_STATUS_ENVIRONMENT`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlanarRay {
    /// Pixel column.
    pub x: u32,
    /// Pixel row.
    pub y: u32,
    /// The point on the mirror (add the host tracer's own offset).
    pub origin: Vec3,
    /// Unit direction: the mirrored camera's primary ray direction through
    /// the pixel center (the reflected direction).
    pub dir: Vec3,
}

/// The host's mirrored render, as the resolve reads it (module docs, "The
/// render").
#[derive(Clone, Copy, Debug)]
pub struct PlanarRender<'a> {
    depth: ImageView<'a, f32>,
    color: Option<ImageView<'a, [f32; 3]>>,
}

impl<'a> PlanarRender<'a> {
    /// Binds the render's depth and, optionally, its color (linear RGB).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `color` is not `depth`'s size.
    pub fn try_new(
        depth: ImageView<'a, f32>,
        color: Option<ImageView<'a, [f32; 3]>>,
    ) -> Result<Self, Error> {
        if let Some(c) = &color {
            if c.width() != depth.width() || c.height() != depth.height() {
                return Err(Error::InvalidArgument);
            }
        }
        Ok(Self { depth, color })
    }

    /// The depth.
    pub const fn depth(&self) -> &ImageView<'a, f32> {
        &self.depth
    }

    /// The color, if any.
    pub const fn color(&self) -> Option<&ImageView<'a, [f32; 3]>> {
        self.color.as_ref()
    }
}

/// Where [`PlanarPass::try_resolve_rows`] puts its results.
pub trait PlanarSink {
    /// Pixel `(x, y)`'s texel and reflection color (black unless `Hit`
    /// with a render color).
    fn texel(&mut self, x: u32, y: u32, texel: &PlanarTexel, color: [f32; 3]);
    /// Ray number `index` of this run (0, 1, ... in row-major order,
    /// counting only those stored); returns `false` if it was not stored.
    fn host(&mut self, index: u32, ray: &PlanarRay) -> bool;
}

/// A covered pixel's geometry, kept for the resolve.
#[derive(Clone, Copy)]
struct Cover {
    /// Linear depth.
    depth: f32,
    /// `|w|`: length of the view ray scaled to unit depth.
    ray_len: f32,
}

impl Cover {
    /// The distance from the mirror to a reflected surface at linear depth
    /// `z` of the mirrored view: `(z - depth) |w|`, at least 0, saturated
    /// at `f32::MAX` (a depth near `f32::MAX` times `|w| > 1` overflows).
    fn distance_to(&self, z: f32) -> f32 {
        ((z - self.depth).max(0.0) * self.ray_len).min(f32::MAX)
    }
}

/// The planar mirror pass over one frame (module docs).
#[derive(Clone, Copy, Debug)]
pub struct PlanarPass<'a> {
    gbuffer: GBuffer<'a>,
    options: PlanarOptions,
    ids: Option<(ImageView<'a, u32>, u32)>,
    plane: Plane,
    mirrored: Camera,
    render: Camera,
    projection: Mat4,
    view_clip_plane: Vec4,
    /// The plane in the G-buffer camera's view space, `(n_v, d_v)`.
    gview_plane: Vec4,
    /// `tan(fov / 2)` of the G-buffer camera, x and y.
    tan: Vec2,
    /// The oblique projection's depth row and `1 / P00`, `1 / P11`, when
    /// the render's depth is oblique.
    oblique_row: Option<(Vec4, Vec2)>,
    /// The eye is not on the plane and the projection could be built.
    usable: bool,
}

fn validate_options(o: &PlanarOptions) -> Result<(), Error> {
    let ok = o.scale >= 1
        && o.plane_tolerance >= 0.0
        && o.plane_tolerance.is_finite()
        && (0.0..=1.0).contains(&o.normal_cos)
        && o.edge_threshold >= 0.0;
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidArgument)
    }
}

/// `libm::floorf(v)` for `|v| < 2^63` (0 for NaN), without libm's
/// out-of-line software floor (`no_std` on baseline x86-64 has no
/// `roundss`; in the resolve it was 7% of the instructions). `v as i64` is
/// `trunc(v)`, an f32 value, so `(v as i64) as f32` compares exactly with
/// `v` and one step down fixes negative non-integers (as in `hiz`).
#[inline]
fn floor_f32(v: f32) -> f32 {
    let i = v as i64;
    (i - i64::from((i as f32) > v)) as f32
}

/// The neighbors of a finite, non-negative-or-negative f32 one step up and
/// down (`f32::next_up` / `next_down`, which need Rust 1.86).
fn ulp_neighbors(d: f32) -> [f32; 2] {
    let up = |v: f32| {
        if v == 0.0 {
            f32::from_bits(1)
        } else if v > 0.0 {
            f32::from_bits(v.to_bits() + 1)
        } else {
            f32::from_bits(v.to_bits() - 1)
        }
    };
    [up(d), -up(-d)]
}

impl<'a> PlanarPass<'a> {
    /// Describes the pass for the mirror `plane` (either orientation) over
    /// `gbuffer` with `options`: orients the plane toward the eye, builds
    /// the mirrored camera at the render's size and the render's projection
    /// ([`PlanarPass::prepare`] adds the coverage). Cheap: no pixel is
    /// read.
    ///
    /// When the eye lies on the plane, or the oblique projection finds the
    /// plane outside the mirrored frustum, the pass is built but covers no
    /// pixel ([`PlanarStatus::OffPlane`]).
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: an option out of its range (see
    ///   [`PlanarOptions`]).
    /// * [`try_mirrored_camera`]'s errors (a mirrored or render camera that is
    ///   not finite: huge coordinates).
    pub fn try_new(
        gbuffer: GBuffer<'a>,
        plane: Plane,
        options: PlanarOptions,
    ) -> Result<Self, Error> {
        validate_options(&options)?;
        let cam = *gbuffer.camera();
        let eye = cam.inverse_view().as_dmat4().w_axis;
        let n = plane.normal().as_dvec3();
        let side = n.dot(eye.truncate()) + f64::from(plane.d());
        let plane = if side < 0.0 { plane.flipped() } else { plane };
        let mut usable = side != 0.0 && side.is_finite();
        let mirrored = try_mirrored_camera(&cam, &plane)?;
        let (w, h) = (cam.width(), cam.height());
        let render = if options.scale == 1 {
            mirrored
        } else {
            Camera::try_new(
                mirrored.view(),
                mirrored.fov_y(),
                mirrored.near(),
                mirrored.far(),
                w.div_ceil(options.scale),
                h.div_ceil(options.scale),
            )?
        };
        let conv = match gbuffer.convention() {
            DepthConvention::Linear => DepthConvention::ZeroToOne,
            c => c,
        };
        let mut oblique_row = None;
        let projection = match usable && options.oblique {
            true => match try_oblique_projection(&render, &plane, conv) {
                Ok(m) => {
                    if gbuffer.convention() != DepthConvention::Linear {
                        let inv = Vec2::new(1.0 / m.x_axis.x, 1.0 / m.y_axis.y);
                        oblique_row = Some((m.row(2), inv));
                    }
                    m
                }
                Err(_) => {
                    usable = false;
                    render.try_projection(conv)?
                }
            },
            false => render.try_projection(conv)?,
        };
        // The plane toward the eye (already flipped above when it faced
        // away: its normal and `d` together; finding F24 was the normal of
        // the input with the `d` of the flipped plane).
        let pn = plane.normal().as_dvec3();
        let world = DVec4::new(pn.x, pn.y, pn.z, f64::from(plane.d()));
        let to_view = |c: &Camera| (c.inverse_view().as_dmat4().transpose() * world).as_vec4();
        let ty = libm::tan(f64::from(cam.fov_y()) * 0.5);
        let tx = ty * f64::from(w) / f64::from(h);
        Ok(Self {
            gbuffer,
            options,
            ids: None,
            plane,
            mirrored,
            render,
            projection,
            view_clip_plane: to_view(&render),
            gview_plane: to_view(&cam),
            tan: Vec2::new(tx as f32, ty as f32),
            oblique_row,
            usable,
        })
    }

    /// Restricts the coverage to the pixels whose object id in `ids` is
    /// `id` (the mirror's), on top of the plane test.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `ids` is not the G-buffer's size.
    pub fn try_with_ids(mut self, ids: ImageView<'a, u32>, id: u32) -> Result<Self, Error> {
        if ids.width() != self.gbuffer.width() || ids.height() != self.gbuffer.height() {
            return Err(Error::InvalidArgument);
        }
        self.ids = Some((ids, id));
        Ok(self)
    }

    /// The G-buffer.
    pub const fn gbuffer(&self) -> &GBuffer<'a> {
        &self.gbuffer
    }

    /// The options.
    pub const fn options(&self) -> &PlanarOptions {
        &self.options
    }

    /// The mirrored camera at the G-buffer's resolution: its primary ray
    /// through pixel `p` is pixel `p`'s reflected ray (from the mirrored
    /// eye; it crosses the mirror at the pixel's point).
    pub const fn mirrored_camera(&self) -> &Camera {
        &self.mirrored
    }

    /// The render's camera ([`PlanarSetup::camera`]).
    pub const fn render_camera(&self) -> &Camera {
        &self.render
    }

    /// The render's size `(width, height)`.
    pub const fn render_size(&self) -> (u32, u32) {
        (self.render.width(), self.render.height())
    }

    /// The coverage of pixel `(x, y)` (module docs): `Skipped`,
    /// `NoSurface`, `OffPlane` or `Covered`; `Skipped` outside the image.
    pub fn cover(&self, x: u32, y: u32) -> PlanarStatus {
        self.cover_pixel(x, y).0
    }

    fn cover_pixel(&self, x: u32, y: u32) -> (PlanarStatus, Option<Cover>) {
        let g = &self.gbuffer;
        if let Some((ids, id)) = &self.ids {
            if ids.get(x, y) != Some(*id) {
                return (PlanarStatus::Skipped, None);
            }
        }
        if let Some(m) = g.mask() {
            if !matches!(m.get(x, y), Some(v) if v != 0) {
                return (PlanarStatus::Skipped, None);
            }
        }
        let Some(stored) = g.depth().depth().get(x, y) else {
            return (PlanarStatus::Skipped, None);
        };
        let cam = g.camera();
        let conv = g.convention();
        let z = cam.decode_depth(stored, conv);
        if !(z >= cam.near() && z < cam.far()) {
            return (PlanarStatus::NoSurface, None);
        }
        let Some(n) = g.world_normal(x, y) else {
            return (PlanarStatus::NoSurface, None);
        };
        if !self.usable || !(n.dot(self.plane.normal()).abs() >= self.options.normal_cos) {
            return (PlanarStatus::OffPlane, None);
        }
        let (w, h) = (cam.width() as f32, cam.height() as f32);
        let sx = (2.0 * (x as f32 + 0.5) / w - 1.0) * self.tan.x;
        let sy = (1.0 - 2.0 * (y as f32 + 0.5) / h) * self.tan.y;
        let p = self.gview_plane;
        let k = p.x * sx + p.y * sy - p.z;
        let dist = p.w + z * k;
        // Within the relative tolerance alone: covered whatever the
        // quantization term adds (it is never negative), so the two decodes
        // it takes are skipped for most on-plane pixels.
        let near = self.options.plane_tolerance * z;
        if !(dist.abs() <= near) {
            // The stored depth's quantization: the largest finite change
            // of the decoded depth one f32 step away.
            let mut q = 0.0f32;
            for d in ulp_neighbors(stored) {
                let dz = (cam.decode_depth(d, conv) - z).abs();
                if dz.is_finite() {
                    q = q.max(dz);
                }
            }
            let tol = near + COVER_DEPTH_ULPS * q * k.abs();
            if !(dist.abs() <= tol) {
                return (PlanarStatus::OffPlane, None);
            }
        }
        let ray_len = libm::sqrtf(sx * sx + sy * sy + 1.0);
        (PlanarStatus::Covered, Some(Cover { depth: z, ray_len }))
    }

    /// Where pixel `(x, y)`'s reflected ray crosses the render (module
    /// docs, "Resolve").
    pub fn render_position(&self, x: u32, y: u32) -> Vec2 {
        let (w, h) = (self.gbuffer.width() as f32, self.gbuffer.height() as f32);
        let (rw, rh) = (self.render.width() as f32, self.render.height() as f32);
        let s = rh / h;
        Vec2::new(
            0.5 * rw + (x as f32 + 0.5 - 0.5 * w) * s,
            0.5 * rh + (y as f32 + 0.5 - 0.5 * h) * s,
        )
    }

    /// The anchor texel of render position `q` (clamped to the render).
    fn anchor(&self, q: Vec2) -> [u32; 2] {
        // `v as u32` is `floor(v)` for `0 <= v < 2^32`, 0 below and for
        // NaN, `u32::MAX` above: what `floorf(v).max(0.0) as u32` gives.
        let cl = |v: f32, n: u32| (v as u32).min(n - 1);
        [cl(q.x, self.render.width()), cl(q.y, self.render.height())]
    }

    /// The render texels a pixel at render position `q` reads, per axis:
    /// `(first, last)` (inclusive, clamped).
    fn read_span(q: f32, n: u32) -> (u32, u32) {
        let cl = |v: f32| (v.max(0.0) as u32).min(n - 1);
        let a = cl(q);
        let b = floor_f32(q - 0.5);
        let last = if q - 0.5 - b > 0.0 { b + 1.0 } else { b };
        (a.min(cl(b)), a.max(cl(last)))
    }

    /// The setup of the frame: [`PlanarPass::try_new`]'s cameras and
    /// planes with the coverage of every pixel counted (a pass over the
    /// whole G-buffer, one [`PlanarPass::cover`] per pixel, on the calling
    /// thread). A host that splits this over threads runs
    /// [`PlanarPass::try_cover_rows`] on bands and hands the merged counts
    /// to [`PlanarPass::setup`] instead.
    pub fn prepare(&self) -> PlanarSetup {
        let mut rect = PlanarRect::default();
        let mut covered = 0u32;
        for y in 0..self.gbuffer.height() {
            for x in 0..self.gbuffer.width() {
                if self.cover_pixel(x, y).0 == PlanarStatus::Covered {
                    covered += 1;
                    rect.add(x, y);
                }
            }
        }
        self.setup(covered, &rect)
    }

    /// The setup for `covered` covered pixels within `rect` (G-buffer
    /// pixels), as [`PlanarPass::prepare`] counts them: the sums and the
    /// [`PlanarRect::union`] of the [`PlanarStats`] of
    /// [`PlanarPass::try_cover_rows`] over bands that split the image.
    pub fn setup(&self, covered: u32, rect: &PlanarRect) -> PlanarSetup {
        let covered = if rect.is_empty() { 0 } else { covered };
        let projection = if covered > 0 {
            self.projection
        } else {
            // Nothing to render: the camera's own projection (the oblique
            // one may not exist for this frame).
            let conv = match self.gbuffer.convention() {
                DepthConvention::Linear => DepthConvention::ZeroToOne,
                c => c,
            };
            self.render.try_projection(conv).unwrap_or(self.projection)
        };
        PlanarSetup {
            camera: self.render,
            projection,
            clip_plane: self.plane,
            view_clip_plane: self.view_clip_plane,
            flip_winding: self.render.is_mirrored(),
            covered: covered > 0,
            covered_pixels: covered,
            rect: if covered > 0 {
                *rect
            } else {
                PlanarRect::default()
            },
            scissor: if covered > 0 {
                self.scissor(rect)
            } else {
                PlanarRect::default()
            },
        }
    }

    /// The render texels the resolve reads for the G-buffer pixels of
    /// `rect` (the scissor of [`PlanarSetup`]); empty for an empty `rect`.
    pub fn scissor(&self, rect: &PlanarRect) -> PlanarRect {
        if rect.is_empty() {
            return PlanarRect::default();
        }
        let lo = self.render_position(rect.x0, rect.y0);
        let hi = self.render_position(rect.x1 - 1, rect.y1 - 1);
        let (rw, rh) = self.render_size();
        let (x0, _) = Self::read_span(lo.x, rw);
        let (y0, _) = Self::read_span(lo.y, rh);
        let (_, x1) = Self::read_span(hi.x, rw);
        let (_, y1) = Self::read_span(hi.y, rh);
        PlanarRect {
            x0,
            y0,
            x1: x1 + 1,
            y1: y1 + 1,
        }
    }

    /// Writes the coverage of the rows `out` owns (a whole image or a band
    /// from [`ImageViewMut::try_band`]).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `out` is not the G-buffer's size;
    /// nothing is written then.
    pub fn try_cover(
        &self,
        out: &mut ImageViewMut<'_, PlanarStatus>,
    ) -> Result<PlanarStats, Error> {
        if out.width() != self.gbuffer.width() || out.height() != self.gbuffer.height() {
            return Err(Error::InvalidArgument);
        }
        let Some(rows) = out.owned_rows() else {
            return Ok(PlanarStats::default());
        };
        self.try_cover_rows(rows, &mut |x, y, s| {
            if let Some(p) = out.get_mut(x, y) {
                *p = s;
            }
        })
    }

    /// The coverage of `rows`, pixel by pixel to `sink(x, y, status)` (for
    /// hosts whose buffers are not [`ImageViewMut`]s).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `rows` ends beyond the G-buffer's
    /// height; nothing is handed to `sink` then.
    pub fn try_cover_rows(
        &self,
        rows: RowRange,
        sink: &mut impl FnMut(u32, u32, PlanarStatus),
    ) -> Result<PlanarStats, Error> {
        if rows.end() > self.gbuffer.height() {
            return Err(Error::InvalidArgument);
        }
        let mut st = PlanarStats::default();
        for y in rows.rows() {
            for x in 0..self.gbuffer.width() {
                let s = self.cover(x, y);
                if s == PlanarStatus::Covered {
                    st.covered += 1;
                    st.rect.add(x, y);
                }
                sink(x, y, s);
            }
        }
        Ok(st)
    }

    /// The linear depth of render texel `(i, j)`, or `None` for an empty
    /// texel (module docs, "The render").
    fn render_depth(&self, render: &PlanarRender<'_>, i: u32, j: u32) -> Option<f32> {
        let d = render.depth.get(i, j)?;
        let far = self.render.far();
        let z = match self.gbuffer.convention() {
            DepthConvention::Linear => {
                if !(d < far) {
                    return None;
                }
                d
            }
            c => {
                let cleared = match c {
                    DepthConvention::ReversedZ => !(d > 0.0),
                    _ => !(d < 1.0),
                };
                if cleared {
                    return None;
                }
                match self.oblique_row {
                    // d = k + r.w / L with k = r.x s_x + r.y s_y - r.z
                    // (clip.w = L: the w row is the standard one).
                    Some((r, inv)) => {
                        let (rw, rh) = (self.render.width() as f32, self.render.height() as f32);
                        let sx = (2.0 * (i as f32 + 0.5) / rw - 1.0) * inv.x;
                        let sy = (1.0 - 2.0 * (j as f32 + 0.5) / rh) * inv.y;
                        let k = r.x * sx + r.y * sy - r.z;
                        r.w / (d - k)
                    }
                    None => self.render.decode_depth(d, c),
                }
            }
        };
        (z > 0.0 && z.is_finite()).then_some(z)
    }

    /// Resolves pixel `(x, y)` against `render` (module docs): its texel,
    /// its reflection color (black unless `Hit` with a render color) and,
    /// for [`PlanarStatus::Environment`], its ray.
    pub fn pixel(
        &self,
        render: &PlanarRender<'_>,
        x: u32,
        y: u32,
    ) -> (PlanarTexel, [f32; 3], Option<PlanarRay>) {
        let mut out = PlanarTexel::default();
        let (status, cover) = self.cover_pixel(x, y);
        let Some(cover) = cover else {
            out.status = status;
            return (out, [0.0; 3], None);
        };
        let q = self.render_position(x, y);
        let a = self.anchor(q);
        out.pixel = q;
        out.texel = a;
        let Some(za) = self.render_depth(render, a[0], a[1]) else {
            out.status = PlanarStatus::Environment;
            let center = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let cam = self.gbuffer.camera();
            let stored = self.gbuffer.depth().depth().get(x, y).unwrap_or(0.0);
            let ray = PlanarRay {
                x,
                y,
                origin: cam.unproject(center, stored, self.gbuffer.convention()),
                dir: self.mirrored.primary_ray(center).dir,
            };
            return (out, [0.0; 3], Some(ray));
        };
        out.status = PlanarStatus::Hit;
        let Some(rc) = render.color.as_ref() else {
            // No color to blend: the anchor answers (a visibility host).
            out.t = cover.distance_to(za);
            return (out, [0.0; 3], None);
        };
        // The depth-guided bilinear mean around q.
        let bx = floor_f32(q.x - 0.5);
        let by = floor_f32(q.y - 0.5);
        let (fx, fy) = (q.x - 0.5 - bx, q.y - 0.5 - by);
        let taps = [
            (bx, by, (1.0 - fx) * (1.0 - fy)),
            (bx + 1.0, by, fx * (1.0 - fy)),
            (bx, by + 1.0, (1.0 - fx) * fy),
            (bx + 1.0, by + 1.0, fx * fy),
        ];
        let (rw, rh) = self.render_size();
        let color_at = |i: u32, j: u32| rc.get(i, j).unwrap_or([0.0; 3]);
        let limit = self.options.edge_threshold * za;
        let (mut sw, mut sz, mut sc) = (0.0f32, 0.0f32, [0.0f32; 3]);
        let mut first: Option<(f32, [f32; 3])> = None;
        let mut count = 0;
        for (tx, ty, wt) in taps {
            if !(wt > 0.0) || tx < 0.0 || ty < 0.0 || tx >= rw as f32 || ty >= rh as f32 {
                continue;
            }
            let (i, j) = (tx as u32, ty as u32);
            // The anchor is one of the four taps on each axis (`bx` is
            // `floor(q) - 1` or `floor(q)`): its depth is known.
            let z = if [i, j] == a {
                za
            } else {
                let Some(z) = self.render_depth(render, i, j) else {
                    continue;
                };
                z
            };
            if !((z - za).abs() <= limit) {
                continue;
            }
            let c = color_at(i, j);
            if first.is_none() {
                first = Some((z, c));
            }
            count += 1;
            sw += wt;
            sz += wt * z;
            for (s, v) in sc.iter_mut().zip(c) {
                *s += wt * v;
            }
        }
        let (zr, color) = match (count, first) {
            (1, Some(one)) => one,
            (0, _) | (_, None) => (za, color_at(a[0], a[1])),
            _ => (sz / sw, sc.map(|v| v / sw)),
        };
        out.t = cover.distance_to(zr);
        (out, color, None)
    }

    fn check_render(&self, render: &PlanarRender<'_>) -> Result<(), Error> {
        let (rw, rh) = self.render_size();
        if render.depth.width() != rw || render.depth.height() != rh {
            return Err(Error::InvalidArgument);
        }
        Ok(())
    }

    /// Resolves the rows `out` owns (a whole image or a band): writes every
    /// pixel's [`PlanarTexel`], the reflection color into `color` (needs a
    /// render color; black where not `Hit`), and appends the
    /// [`PlanarStatus::Environment`] pixels' rays to `host` in row-major
    /// order as far as it holds them (`host` may be empty).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `out` or `color` is not the G-buffer's
    /// size or their bands differ, `color` is given without a render
    /// color, or `render` is not the render's size
    /// ([`PlanarPass::render_size`]). Nothing is written then.
    pub fn try_resolve(
        &self,
        out: &mut ImageViewMut<'_, PlanarTexel>,
        color: Option<&mut ImageViewMut<'_, [f32; 3]>>,
        host: &mut [PlanarRay],
        render: &PlanarRender<'_>,
    ) -> Result<PlanarStats, Error> {
        let (w, h) = (self.gbuffer.width(), self.gbuffer.height());
        if out.width() != w || out.height() != h {
            return Err(Error::InvalidArgument);
        }
        if let Some(c) = color.as_deref() {
            if c.width() != w
                || c.height() != h
                || c.owned_rows() != out.owned_rows()
                || render.color.is_none()
            {
                return Err(Error::InvalidArgument);
            }
        }
        self.check_render(render)?;
        let Some(rows) = out.owned_rows() else {
            return Ok(PlanarStats::default());
        };
        struct Views<'o, 'c, 'h, 'x, 'y> {
            out: &'o mut ImageViewMut<'x, PlanarTexel>,
            color: Option<&'c mut ImageViewMut<'y, [f32; 3]>>,
            host: &'h mut [PlanarRay],
        }
        impl PlanarSink for Views<'_, '_, '_, '_, '_> {
            fn texel(&mut self, x: u32, y: u32, texel: &PlanarTexel, color: [f32; 3]) {
                if let Some(p) = self.out.get_mut(x, y) {
                    *p = *texel;
                }
                if let Some(c) = self.color.as_deref_mut().and_then(|c| c.get_mut(x, y)) {
                    *c = color;
                }
            }
            fn host(&mut self, index: u32, ray: &PlanarRay) -> bool {
                match self.host.get_mut(index as usize) {
                    Some(slot) => {
                        *slot = *ray;
                        true
                    }
                    None => false,
                }
            }
        }
        let mut views = Views { out, color, host };
        Ok(self.resolve_rows(render, rows, &mut views))
    }

    /// Resolves `rows` and hands every pixel's texel and color, and every
    /// ray in row-major order, to `sink`: the loop of
    /// [`PlanarPass::try_resolve`] for hosts whose buffers are not
    /// [`ImageViewMut`]s (refl-ffi writes C structs through it).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `rows` ends beyond the G-buffer's
    /// height or `render` is not the render's size. Nothing is handed to
    /// `sink` then.
    pub fn try_resolve_rows(
        &self,
        render: &PlanarRender<'_>,
        rows: RowRange,
        sink: &mut impl PlanarSink,
    ) -> Result<PlanarStats, Error> {
        if rows.end() > self.gbuffer.height() {
            return Err(Error::InvalidArgument);
        }
        self.check_render(render)?;
        Ok(self.resolve_rows(render, rows, sink))
    }

    fn resolve_rows(
        &self,
        render: &PlanarRender<'_>,
        rows: RowRange,
        sink: &mut impl PlanarSink,
    ) -> PlanarStats {
        let mut st = PlanarStats::default();
        for y in rows.rows() {
            for x in 0..self.gbuffer.width() {
                let (t, c, ray) = self.pixel(render, x, y);
                match t.status {
                    PlanarStatus::Hit => st.hits += 1,
                    PlanarStatus::Environment => st.environment += 1,
                    _ => {}
                }
                if t.status.is_covered() {
                    st.covered += 1;
                    st.rect.add(x, y);
                }
                if let Some(r) = ray {
                    if sink.host(st.host_rays_written, &r) {
                        st.host_rays_written += 1;
                    }
                    st.host_rays += 1;
                }
                sink.texel(x, y, &t, c);
            }
        }
        st
    }
}

#[cfg(test)]
mod tests {
    use super::floor_f32;

    /// [`floor_f32`] against libm's `floorf` (the oracle it replaces) on
    /// fractions, integers, both signs, `-0`, subnormals, the edges of
    /// f32's fractional range (2^23) and of the i32/u32/i64 ranges below
    /// 2^63, and a sweep of bit patterns.
    #[test]
    fn floor_f32_equals_libm_floorf() {
        let fixed = [
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            0.999_999_94,
            -0.999_999_94,
            1e-45,
            -1e-45,
            f32::MIN_POSITIVE,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            -8_388_609.0,
            2_147_483_648.0,
            -2_147_483_648.0,
            4_294_967_296.0,
            9.2e18,
            -9.2e18,
        ];
        let check = |v: f32| {
            let (got, want) = (floor_f32(v), libm::floorf(v));
            assert!(got == want, "floor({v:e}): {got:e} vs libm {want:e}");
        };
        fixed.into_iter().for_each(check);
        let mut bits = 0x3000_0000u32;
        while bits < 0x5e80_0000 {
            let v = f32::from_bits(bits);
            [v, -v, v + 0.5, -(v + 0.5)].into_iter().for_each(check);
            bits += 0x0001_3579;
        }
        assert_eq!(floor_f32(f32::NAN), 0.0);
    }
}
