//! Shared vocabulary of the ray / depth-image kernels: the depth image a ray
//! is traced against, surface thickness, the hit/miss result and the work
//! counters. Used by per-pixel stepping ([`crate::step`], seed 003 Sec. 3.4)
//! and Hi-Z traversal ([`crate::hiz`], seed 004 Sec. 4.4.1).
//!
//! Contract shared by every kernel that returns a [`Trace`]:
//! * the ray is a world-space [`Ray`] with a unit direction and a maximum
//!   distance `t_max` (`+inf` allowed: the far plane ends it);
//! * the depth image is the front-most surface seen by its camera, in one of
//!   the three [`DepthConvention`]s;
//! * a ray point "hits" texel `(x, y)` when its linear depth `z` lies in
//!   `[z_front, z_front + thickness]` (constant thickness) or in
//!   `[z_front, z_back]` (back-face image), where `z_front`/`z_back` are the
//!   texel's decoded linear depths;
//! * results are explicit: a [`DepthHit`] or a [`Miss`] with its reason,
//!   each with the [`Work`] spent, never a sentinel NaN.

use crate::{Camera, DepthConvention, Error, ImageView, Ray};
use glam::Vec2;

/// A depth image with the camera that rendered it and its convention.
///
/// The image size must equal the camera's; texel `(x, y)` holds the stored
/// depth of the surface seen through pixel center `(x + 0.5, y + 0.5)`.
#[derive(Clone, Copy, Debug)]
pub struct DepthImage<'a> {
    depth: ImageView<'a, f32>,
    camera: Camera,
    convention: DepthConvention,
}

impl<'a> DepthImage<'a> {
    /// Binds a depth view to its camera and convention.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if the view's size differs from the
    /// camera's.
    pub fn try_new(
        depth: ImageView<'a, f32>,
        camera: Camera,
        convention: DepthConvention,
    ) -> Result<Self, Error> {
        if depth.width() != camera.width() || depth.height() != camera.height() {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            depth,
            camera,
            convention,
        })
    }

    /// The stored depths.
    pub const fn depth(&self) -> &ImageView<'a, f32> {
        &self.depth
    }

    /// The camera that rendered the image.
    pub const fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The convention of the stored depths.
    pub const fn convention(&self) -> DepthConvention {
        self.convention
    }

    /// Width in pixels.
    pub const fn width(&self) -> u32 {
        self.depth.width()
    }

    /// Height in pixels.
    pub const fn height(&self) -> u32 {
        self.depth.height()
    }

    /// Linear depth of texel `(x, y)`, or `None` outside the image. A stored
    /// NaN decodes to NaN, which every kernel treats as "no surface".
    #[inline]
    pub fn linear_at(&self, x: u32, y: u32) -> Option<f32> {
        self.depth
            .get(x, y)
            .map(|d| self.camera.decode_depth(d, self.convention))
    }
}

/// How far behind the front-most surface a ray may pass and still hit it.
#[derive(Clone, Copy, Debug)]
pub enum Thickness<'a> {
    /// Every surface is this thick, in linear depth (world units along the
    /// view axis). `0` means an infinitely thin shell; `+inf` means
    /// everything behind a surface is solid.
    Constant(f32),
    /// A back-face depth image (same size, camera and convention as the
    /// front image): the ray hits where its depth lies between the two.
    BackFaces(ImageView<'a, f32>),
}

/// Work a kernel spent on one ray, for measuring cost in counts rather than
/// time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Work {
    /// Pixel (or cell) steps along the projected ray.
    pub steps: u32,
    /// Depth texels read, pyramids and back-face images included.
    pub fetches: u32,
    /// Loop iterations of a hierarchical traversal (0 for stepping).
    pub iterations: u32,
}

/// A ray / depth-image intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthHit {
    /// Sub-pixel position of the hit in the depth image (pixels, origin
    /// top-left; the texel hit is `pixel.floor()`).
    pub pixel: Vec2,
    /// Ray parameter of the hit (world distance from the origin).
    pub t: f32,
    /// Linear depth of the hit point on the ray.
    pub depth: f32,
    /// Linear depth stored in the image at the texel hit.
    pub surface_depth: f32,
    /// Work spent.
    pub work: Work,
}

/// Why a ray found no surface in the depth image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Miss {
    /// The projected ray left the image rectangle before hitting anything.
    LeftImage,
    /// The ray passed behind geometry (deeper than its thickness) and can no
    /// longer be resolved from this image: what it hits is not visible.
    BehindGeometry,
    /// The kernel's step or iteration cap was reached.
    OutOfSteps,
    /// The ray ended (`t_max` or the far plane) in front of every surface.
    EndOfRay,
    /// Nothing of the ray projects into the view: it lies entirely behind
    /// the near plane, or its clipped segment is empty.
    DegenerateProjection,
}

/// The result of tracing one ray against a depth image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Trace {
    /// The ray hit the depth image.
    Hit(DepthHit),
    /// The ray missed, and why.
    Miss {
        /// The reason.
        reason: Miss,
        /// Work spent before giving up.
        work: Work,
    },
}

impl Trace {
    /// The hit, if any.
    pub const fn hit(&self) -> Option<&DepthHit> {
        match self {
            Trace::Hit(h) => Some(h),
            Trace::Miss { .. } => None,
        }
    }

    /// The work spent, hit or miss.
    pub const fn work(&self) -> Work {
        match self {
            Trace::Hit(h) => h.work,
            Trace::Miss { work, .. } => *work,
        }
    }
}

/// Validates a ray and its maximum distance for a depth-image kernel.
///
/// # Errors
/// [`Error::InvalidArgument`] for a non-finite origin or direction, a
/// direction whose length differs from 1 by more than 1e-3, or a `t_max`
/// that is NaN or not positive (`+inf` is allowed).
pub fn validate_ray(ray: &Ray, t_max: f32) -> Result<(), Error> {
    if !ray.origin.is_finite()
        || !ray.dir.is_finite()
        || !((ray.dir.length_squared() - 1.0).abs() <= 2e-3)
        || !(t_max > 0.0)
    {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}
