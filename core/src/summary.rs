//! A frame summary for choosing methods and skipping passes (issue 15,
//! part 1): one pass over a G-buffer, row band by row band, that says
//! which objects reflect, how much, how rough, whether each reflector is a
//! plane, how much of the reflective area touches the image border, and
//! how the image's 8x8 tiles split between roughness classes (the
//! classification production screen-space reflections run before tracing,
//! FidelityFX SSSR's tile classifier).
//!
//! The summary is measurements, not decisions: the planner that turns it
//! into methods, settings and skipped passes reads it with a calibrated
//! cost and error model.
//!
//! * A pixel is **reflective** when it has a surface
//!   ([`GBuffer::surface`]: a depth in front of the far plane and a usable
//!   normal), the mask (if any) is not 0, its roughness (if any) is not NaN,
//!   and its object id (if any) is not [`NO_OBJECT`].
//! * Its **class** ([`RoughnessClass`]) comes from its roughness (0 without
//!   a roughness image) and the options' two bounds.
//! * A **tile** (`TILE x TILE` pixels, the last row and column of tiles
//!   possibly smaller) takes the class of its sharpest reflective pixel
//!   (a mirror pixel makes a mirror tile), or none.
//! * An object is **planar** when its reflective pixels' normals agree
//!   (the length of their mean, `|sum n| / N`, is at least
//!   [`SummaryOptions::normal_cos`]) and their points lie on one plane:
//!   the root mean square distance of the points from the best plane
//!   through their mean with the mean normal is at most
//!   [`SummaryOptions::plane_tolerance`] times their mean depth. These
//!   are the planar pass's tests (`PlanarOptions`) applied
//!   to the object as a whole. Sums are kept in f64 relative to the
//!   object's first point, so a plane far from the origin is found as
//!   well as one through it.
//!
//! ```
//! use refl_core::summary::{try_summarize_rows, FrameSummary, ObjectSummary, SummaryOptions};
//! use refl_core::{Camera, DepthConvention, DepthImage, GBuffer, ImageView, NormalSpace};
//! use refl_core::glam::Vec3;
//! # fn main() -> Result<(), refl_core::Error> {
//! // A camera looking down at a floor y = 0 filling the image.
//! let cam = Camera::try_look_at(Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, Vec3::Z, 1.0, 0.1, 50.0, 16, 16)?;
//! let depth = vec![2.0f32; 256];
//! let normals = vec![[0.0f32, 1.0, 0.0]; 256];
//! let d = DepthImage::try_new(ImageView::try_new(&depth, 16, 16, 16)?, cam, DepthConvention::Linear)?;
//! let g = GBuffer::try_new(d, ImageView::try_new(&normals, 16, 16, 16)?, NormalSpace::World)?;
//! let (mut frame, mut objects) = (FrameSummary::default(), [ObjectSummary::default()]);
//! let o = SummaryOptions::default();
//! try_summarize_rows(&mut frame, &mut objects, &g, None, g.depth().depth().all_rows(), &o)?;
//! assert_eq!(frame.reflective, 256);
//! assert!(objects[0].is_planar(&o));
//! # Ok(())
//! # }
//! ```

use crate::gbuffer::GBuffer;
use crate::{Error, ImageView, RowRange};
use glam::DVec3;

/// Side of a classification tile in pixels (FidelityFX SSSR's 8x8).
pub const TILE: u32 = 8;

/// The object id of a pixel that belongs to no object (sky, or geometry
/// the host does not list).
pub const NO_OBJECT: u32 = u32::MAX;

/// How rough a reflective pixel or tile is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum RoughnessClass {
    /// Roughness at most [`SummaryOptions::mirror_roughness`]: one mirror
    /// ray answers it (the mirror and planar passes).
    Mirror = 0,
    /// Above that, at most [`SummaryOptions::glossy_roughness`]: a cone or
    /// several rays (the glossy and cluster passes).
    Glossy = 1,
    /// Above that: rough enough for a prefiltered probe.
    Rough = 2,
}

/// Settings of the summary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SummaryOptions {
    /// Upper roughness bound of [`RoughnessClass::Mirror`]; default 0.1,
    /// the mirror pass's default `max_roughness`
    /// (`MirrorOptions`), so that a mirror pixel
    /// is one that pass traces. Finite, at least 0.
    pub mirror_roughness: f32,
    /// Upper roughness bound of [`RoughnessClass::Glossy`]; default 1.0,
    /// the glossy pass's default `max_roughness`: until a calibrated error
    /// model says where the probe is as good as the glossy pass, no pixel
    /// is left to the probe. At least `mirror_roughness`, `+inf` allowed.
    pub glossy_roughness: f32,
    /// Reflective pixels within this many pixels of the image border count
    /// as touching it ([`ObjectSummary::border_pixels`]): their reflections
    /// leave the screen soonest. Default [`TILE`].
    pub border_pixels: u32,
    /// Plane test: the points' RMS distance from their plane, relative to
    /// their mean depth; default 1e-3, the planar pass's
    /// `plane_tolerance`. Finite, at least 0.
    pub plane_tolerance: f32,
    /// Plane test: the least length of the normals' mean (the cosine of
    /// their spread); default 0.99, the planar pass's `normal_cos`. In
    /// `[0, 1]`.
    pub normal_cos: f32,
}

impl Default for SummaryOptions {
    fn default() -> Self {
        Self {
            mirror_roughness: 0.1,
            glossy_roughness: 1.0,
            border_pixels: TILE,
            plane_tolerance: 1e-3,
            normal_cos: 0.99,
        }
    }
}

impl SummaryOptions {
    /// # Errors
    /// [`Error::InvalidArgument`] for a bound out of its documented range.
    pub fn try_validate(&self) -> Result<(), Error> {
        let ok = self.mirror_roughness >= 0.0
            && self.mirror_roughness.is_finite()
            && self.glossy_roughness >= self.mirror_roughness
            && self.plane_tolerance >= 0.0
            && self.plane_tolerance.is_finite()
            && (0.0..=1.0).contains(&self.normal_cos);
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidArgument)
        }
    }

    /// The class of a (non-NaN) roughness.
    pub fn class(&self, roughness: f32) -> RoughnessClass {
        if roughness <= self.mirror_roughness {
            RoughnessClass::Mirror
        } else if roughness <= self.glossy_roughness {
            RoughnessClass::Glossy
        } else {
            RoughnessClass::Rough
        }
    }
}

/// Counts over the whole image (or the bands summarized so far).
/// `repr(C)`: the C ABI's `refl_frame_summary` is this struct.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(C)]
pub struct FrameSummary {
    /// Pixels summarized.
    pub pixels: u64,
    /// Of them, pixels with a surface ([`GBuffer::surface`]).
    pub surfaces: u64,
    /// Reflective pixels (module docs).
    pub reflective: u64,
    /// Reflective pixels per [`RoughnessClass`] (indexed by its value).
    pub classes: [u64; 3],
    /// Reflective pixels within [`SummaryOptions::border_pixels`] of the
    /// border.
    pub border: u64,
    /// Reflective pixels whose object id has no entry in the caller's
    /// object list (an id past its end): counted here, in no object.
    pub unlisted: u64,
    /// Tiles without a reflective pixel, then tiles per
    /// [`RoughnessClass`] of their sharpest reflective pixel.
    pub tiles: [u64; 4],
}

impl FrameSummary {
    /// Adds the counts of `other` (another band of the same frame).
    pub fn merge(&mut self, other: &FrameSummary) {
        self.pixels += other.pixels;
        self.surfaces += other.surfaces;
        self.reflective += other.reflective;
        self.border += other.border;
        self.unlisted += other.unlisted;
        for k in 0..3 {
            self.classes[k] += other.classes[k];
        }
        for k in 0..4 {
            self.tiles[k] += other.tiles[k];
        }
    }
}

/// What one object's reflective pixels add up to. Caller memory: one per
/// object id, [`Default`] (all zero) before the first band. `repr(C)`:
/// the C ABI's `refl_object_summary` is this struct.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct ObjectSummary {
    /// Reflective pixels.
    pub pixels: u64,
    /// Of them, per [`RoughnessClass`].
    pub classes: [u64; 3],
    /// Of them, within [`SummaryOptions::border_pixels`] of the border.
    pub border_pixels: u64,
    /// Bounding rectangle `[x0, y0, x1, y1)` of the reflective pixels
    /// (all zero while there are none).
    pub rect: [u32; 4],
    /// The first point seen: the origin of the sums below.
    pub origin: DVec3,
    /// Sum of the unit normals.
    pub normal_sum: DVec3,
    /// Sum of the points, relative to `origin`.
    pub point_sum: DVec3,
    /// Sums of the products of the relative coordinates: `xx, yy, zz, xy,
    /// xz, yz`.
    pub point_products: [f64; 6],
    /// Sum of the linear depths.
    pub depth_sum: f64,
}

/// The best plane through an object's reflective points
/// ([`ObjectSummary::plane`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneFit {
    /// Unit mean normal.
    pub normal: DVec3,
    /// The mean point.
    pub point: DVec3,
    /// `|sum n| / N`: 1 when every normal is the same (up to the f32
    /// rounding of the unit normals, so it may exceed 1 by about 1e-7).
    pub coherence: f64,
    /// Root mean square distance of the points from the plane through
    /// `point` with `normal`.
    pub rms_distance: f64,
    /// Mean linear depth of the points.
    pub mean_depth: f64,
}

impl ObjectSummary {
    fn add(&mut self, x: u32, y: u32, p: DVec3, n: DVec3, depth: f64) {
        if self.pixels == 0 {
            self.origin = p;
            self.rect = [x, y, x + 1, y + 1];
        }
        self.pixels += 1;
        self.rect[0] = self.rect[0].min(x);
        self.rect[1] = self.rect[1].min(y);
        self.rect[2] = self.rect[2].max(x + 1);
        self.rect[3] = self.rect[3].max(y + 1);
        let q = p - self.origin;
        self.normal_sum += n;
        self.point_sum += q;
        let pp = &mut self.point_products;
        pp[0] += q.x * q.x;
        pp[1] += q.y * q.y;
        pp[2] += q.z * q.z;
        pp[3] += q.x * q.y;
        pp[4] += q.x * q.z;
        pp[5] += q.y * q.z;
        self.depth_sum += depth;
    }

    /// Adds `other` (the same object in another band). The point sums are
    /// moved to this summary's origin first.
    pub fn merge(&mut self, other: &ObjectSummary) {
        if other.pixels == 0 {
            return;
        }
        if self.pixels == 0 {
            *self = *other;
            return;
        }
        // Sums of q' = q + s, s = other.origin - self.origin.
        let s = other.origin - self.origin;
        let (n, q) = (other.pixels as f64, other.point_sum);
        let pp = &other.point_products;
        let moved = [
            pp[0] + 2.0 * s.x * q.x + n * s.x * s.x,
            pp[1] + 2.0 * s.y * q.y + n * s.y * s.y,
            pp[2] + 2.0 * s.z * q.z + n * s.z * s.z,
            pp[3] + s.x * q.y + s.y * q.x + n * s.x * s.y,
            pp[4] + s.x * q.z + s.z * q.x + n * s.x * s.z,
            pp[5] + s.y * q.z + s.z * q.y + n * s.y * s.z,
        ];
        for (a, b) in self.point_products.iter_mut().zip(moved) {
            *a += b;
        }
        self.point_sum += q + s * n;
        self.pixels += other.pixels;
        for k in 0..3 {
            self.classes[k] += other.classes[k];
        }
        self.border_pixels += other.border_pixels;
        self.rect[0] = self.rect[0].min(other.rect[0]);
        self.rect[1] = self.rect[1].min(other.rect[1]);
        self.rect[2] = self.rect[2].max(other.rect[2]);
        self.rect[3] = self.rect[3].max(other.rect[3]);
        self.normal_sum += other.normal_sum;
        self.depth_sum += other.depth_sum;
    }

    /// The best plane through the points with the mean normal, or `None`
    /// without pixels or when the normals cancel out.
    pub fn plane(&self) -> Option<PlaneFit> {
        if self.pixels == 0 {
            return None;
        }
        let n = self.pixels as f64;
        let len = self.normal_sum.length();
        if !(len > 0.0) {
            return None;
        }
        let m = self.normal_sum / len;
        let mean = self.point_sum / n;
        let pp = &self.point_products;
        // m^T (S2 / N - mean mean^T) m: the variance along m.
        let s2 = m.x * m.x * pp[0]
            + m.y * m.y * pp[1]
            + m.z * m.z * pp[2]
            + 2.0 * (m.x * m.y * pp[3] + m.x * m.z * pp[4] + m.y * m.z * pp[5]);
        let var = (s2 / n - m.dot(mean) * m.dot(mean)).max(0.0);
        Some(PlaneFit {
            normal: m,
            point: self.origin + mean,
            coherence: len / n,
            rms_distance: libm::sqrt(var),
            mean_depth: self.depth_sum / n,
        })
    }

    /// Whether the object's reflective pixels form one plane (module
    /// docs): at least three pixels, normals within `normal_cos`, points
    /// within `plane_tolerance` of the mean depth.
    pub fn is_planar(&self, options: &SummaryOptions) -> bool {
        self.pixels >= 3
            && self.plane().is_some_and(|f| {
                f.coherence >= f64::from(options.normal_cos)
                    && f.rms_distance <= f64::from(options.plane_tolerance) * f.mean_depth
            })
    }
}

/// Summarizes rows `rows` of `gbuffer` into `frame` and `objects` (adding
/// to what they hold, so bands may be summarized one after the other or
/// into separate summaries that are then merged). `ids` gives each pixel's
/// object (an index into `objects`, or [`NO_OBJECT`]); without it every
/// pixel belongs to object 0. Tiles are counted whole, so a band must
/// start on a tile row (`rows.start()` a multiple of [`TILE`]) and end on
/// one or at the bottom of the image.
///
/// # Errors
/// * [`Error::InvalidArgument`]: `options` out of range, `ids` not of the
///   G-buffer's size, rows beyond the height or not on tile rows.
/// * [`Error::InsufficientSize`]: `objects` empty.
///
/// Nothing is written on error.
pub fn try_summarize_rows(
    frame: &mut FrameSummary,
    objects: &mut [ObjectSummary],
    gbuffer: &GBuffer<'_>,
    ids: Option<&ImageView<'_, u32>>,
    rows: RowRange,
    options: &SummaryOptions,
) -> Result<(), Error> {
    options.try_validate()?;
    let (w, h) = (gbuffer.width(), gbuffer.height());
    if ids.is_some_and(|v| v.width() != w || v.height() != h)
        || rows.end() > h
        || rows.start() % TILE != 0
        || (rows.end() % TILE != 0 && rows.end() != h)
    {
        return Err(Error::InvalidArgument);
    }
    if objects.is_empty() {
        return Err(Error::InsufficientSize);
    }
    let b = options.border_pixels;
    let near_border = |x: u32, y: u32| x < b || y < b || w - 1 - x < b || h - 1 - y < b;
    let tiles_x = w.div_ceil(TILE);
    let mut ty = rows.start();
    while ty < rows.end() {
        let y1 = (ty + TILE).min(rows.end());
        for tx in 0..tiles_x {
            // The sharpest class in the tile (0 mirror .. 2 rough), 3: none.
            let mut sharpest = 3usize;
            for y in ty..y1 {
                for x in tx * TILE..((tx + 1) * TILE).min(w) {
                    frame.pixels += 1;
                    let Some(s) = gbuffer.surface(x, y) else {
                        continue;
                    };
                    frame.surfaces += 1;
                    if gbuffer.mask().is_some_and(|m| m.get(x, y) == Some(0)) {
                        continue;
                    }
                    let r = match gbuffer.roughness() {
                        Some(v) => v.get(x, y).unwrap_or(f32::NAN),
                        None => 0.0,
                    };
                    if r.is_nan() {
                        continue;
                    }
                    let id = ids.map_or(0, |v| v.get(x, y).unwrap_or(NO_OBJECT));
                    if id == NO_OBJECT {
                        continue;
                    }
                    let class = options.class(r) as usize;
                    let border = near_border(x, y);
                    frame.reflective += 1;
                    frame.classes[class] += 1;
                    frame.border += u64::from(border);
                    sharpest = sharpest.min(class);
                    let Some(o) = objects.get_mut(id as usize) else {
                        frame.unlisted += 1;
                        continue;
                    };
                    o.classes[class] += 1;
                    o.border_pixels += u64::from(border);
                    o.add(
                        x,
                        y,
                        s.position.as_dvec3(),
                        s.normal.as_dvec3(),
                        f64::from(s.depth),
                    );
                }
            }
            // Index 0: no reflective pixel; 1 + class otherwise.
            frame.tiles[(sharpest + 1) % 4] += 1;
        }
        ty = y1;
    }
    Ok(())
}
