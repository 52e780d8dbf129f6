//! The G-buffer a deferred renderer already has, as one validated view: what
//! the reflection passes read (design.md, "Passes").
//!
//! * depth, with its camera and [`DepthConvention`] (a [`DepthImage`]);
//! * normals, in world or view space ([`NormalSpace`]), not necessarily
//!   unit length (a pass normalizes them; a zero or non-finite normal marks
//!   a pixel without a usable surface);
//! * optionally a reflective mask (`0` = not reflective) and/or a
//!   per-pixel roughness (`[0, 1]`, perceptual, as in the cone pass);
//! * optionally the lit color of the frame (linear RGB), which passes that
//!   shade read at their hits;
//! * optionally a back-face depth image (same camera and convention): the
//!   depth of the farthest surface behind each pixel, which gives a hit
//!   test far better than a constant thickness where the host can render
//!   it (issue 13: 99.3% of the visible hits found against 95.6-97.1% for
//!   constants).
//!
//! Every image must have the camera's size; this is checked once, when the
//! view is built, and never again per ray.
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::glam::Vec3;
//! use refl_core::{Camera, DepthConvention, DepthImage, Error, GBuffer, ImageView, NormalSpace};
//!
//! // 4 x 4 pixels of [0, 1] depth: a wall at linear depth 5, pixel (3, 0) cleared (sky).
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 1.0, 101.0, 4, 4)?;
//! let mut depth = [cam.encode_depth(5.0, DepthConvention::ZeroToOne); 16];
//! depth[3] = 1.0;
//! let normals = [[0.0, 0.0, 2.0f32]; 16]; // view space, toward the eye, not unit
//! let depth = DepthImage::try_new(ImageView::try_new(&depth, 4, 4, 4)?, cam, DepthConvention::ZeroToOne)?;
//! let g = GBuffer::try_new(depth, ImageView::try_new(&normals, 4, 4, 4)?, NormalSpace::View)?;
//!
//! // Pixel (1, 2) has its center at NDC (-1/4, -1/4): the point 5 (-1/4, -1/4, -1).
//! let s = g.surface(1, 2).unwrap();
//! assert!((s.position - Vec3::new(-1.25, -1.25, -5.0)).length() < 1e-4);
//! assert!((s.depth - 5.0).abs() < 1e-4 && (s.normal - Vec3::Z).length() < 1e-6);
//! assert_eq!(g.surface(3, 0), None);
//! // Every image must have the camera's size.
//! let mask = [1u8; 8];
//! assert_eq!(g.try_with_mask(ImageView::try_new(&mask, 4, 2, 4)?).unwrap_err(), Error::InvalidArgument);
//! # Ok::<(), Error>(())
//! ```

use crate::{Camera, DepthConvention, DepthImage, Error, ImageView};
use glam::{Vec2, Vec3};

/// The space a G-buffer's normals are stored in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NormalSpace {
    /// World space (the camera's world).
    World,
    /// View space of the G-buffer's camera (right-handed, looking down
    /// `-z`, as [`Camera::view`] maps world to view).
    View,
}

/// A deferred renderer's G-buffer over caller memory (module docs).
#[derive(Clone, Copy, Debug)]
pub struct GBuffer<'a> {
    depth: DepthImage<'a>,
    normals: ImageView<'a, [f32; 3]>,
    normal_space: NormalSpace,
    mask: Option<ImageView<'a, u8>>,
    roughness: Option<ImageView<'a, f32>>,
    color: Option<ImageView<'a, [f32; 3]>>,
    back_depth: Option<ImageView<'a, f32>>,
}

/// What a G-buffer says about one pixel's surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// World point seen through the pixel center at the stored depth
    /// ([`Camera::unproject`]).
    pub position: Vec3,
    /// Unit world-space normal, as stored (not flipped toward the eye).
    pub normal: Vec3,
    /// Linear depth of the pixel.
    pub depth: f32,
}

fn same_size<T: Copy>(v: &ImageView<'_, T>, camera: &Camera) -> Result<(), Error> {
    if v.width() != camera.width() || v.height() != camera.height() {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

impl<'a> GBuffer<'a> {
    /// Binds a depth image (with its camera and convention) and the
    /// normals of the same pixels.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `normals` is not the camera's size.
    pub fn try_new(
        depth: DepthImage<'a>,
        normals: ImageView<'a, [f32; 3]>,
        normal_space: NormalSpace,
    ) -> Result<Self, Error> {
        same_size(&normals, depth.camera())?;
        Ok(Self {
            depth,
            normals,
            normal_space,
            mask: None,
            roughness: None,
            color: None,
            back_depth: None,
        })
    }

    /// Adds a reflective mask: pixels whose mask is `0` are not reflective.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `mask` is not the camera's size.
    pub fn try_with_mask(mut self, mask: ImageView<'a, u8>) -> Result<Self, Error> {
        same_size(&mask, self.depth.camera())?;
        self.mask = Some(mask);
        Ok(self)
    }

    /// Adds per-pixel roughness (`[0, 1]`; NaN marks a pixel not
    /// reflective).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `roughness` is not the camera's size.
    pub fn try_with_roughness(mut self, roughness: ImageView<'a, f32>) -> Result<Self, Error> {
        same_size(&roughness, self.depth.camera())?;
        self.roughness = Some(roughness);
        Ok(self)
    }

    /// Adds the lit color of the frame (linear RGB), read by passes that
    /// shade.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `color` is not the camera's size.
    pub fn try_with_color(mut self, color: ImageView<'a, [f32; 3]>) -> Result<Self, Error> {
        same_size(&color, self.depth.camera())?;
        self.color = Some(color);
        Ok(self)
    }

    /// Adds a back-face depth image (same camera and convention as the
    /// depth): a hit then needs the ray's depth between the two.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `back_depth` is not the camera's size.
    pub fn try_with_back_depth(mut self, back_depth: ImageView<'a, f32>) -> Result<Self, Error> {
        same_size(&back_depth, self.depth.camera())?;
        self.back_depth = Some(back_depth);
        Ok(self)
    }

    /// The depth image.
    pub const fn depth(&self) -> &DepthImage<'a> {
        &self.depth
    }

    /// The camera.
    pub const fn camera(&self) -> &Camera {
        self.depth.camera()
    }

    /// The normals.
    pub const fn normals(&self) -> &ImageView<'a, [f32; 3]> {
        &self.normals
    }

    /// The space of the normals.
    pub const fn normal_space(&self) -> NormalSpace {
        self.normal_space
    }

    /// The reflective mask, if any.
    pub const fn mask(&self) -> Option<&ImageView<'a, u8>> {
        self.mask.as_ref()
    }

    /// The roughness, if any.
    pub const fn roughness(&self) -> Option<&ImageView<'a, f32>> {
        self.roughness.as_ref()
    }

    /// The lit color, if any.
    pub const fn color(&self) -> Option<&ImageView<'a, [f32; 3]>> {
        self.color.as_ref()
    }

    /// The back-face depth image, if any.
    pub const fn back_depth(&self) -> Option<&ImageView<'a, f32>> {
        self.back_depth.as_ref()
    }

    /// Width in pixels.
    pub const fn width(&self) -> u32 {
        self.depth.width()
    }

    /// Height in pixels.
    pub const fn height(&self) -> u32 {
        self.depth.height()
    }

    /// Unit world-space normal of pixel `(x, y)`, or `None` outside the
    /// image or for a zero or non-finite stored normal (any other length is
    /// used, however huge or tiny).
    #[inline]
    pub fn world_normal(&self, x: u32, y: u32) -> Option<Vec3> {
        let n = Vec3::from_array(self.normals.get(x, y)?);
        // Any finite, non-zero length is usable: a normal whose square
        // would overflow or underflow f32 (components beyond about 1e18 or
        // all below about 1e-18; finding F24b) is scaled by its largest
        // component first. Other normals keep their bits.
        let m = n.abs().max_element();
        if !(m > 0.0 && m.is_finite()) {
            return None;
        }
        let n = if (1e-18..=1e18).contains(&m) {
            n
        } else {
            n / m
        };
        let n = match self.normal_space {
            NormalSpace::World => n,
            NormalSpace::View => self.camera().inverse_view().transform_vector3(n),
        };
        let len2 = n.length_squared();
        // Not NaN, not zero, and the square did not overflow.
        if !(len2 > 0.0 && len2.is_finite()) {
            return None;
        }
        Some(n * (1.0 / libm::sqrtf(len2)))
    }

    /// The surface of pixel `(x, y)`: `None` outside the image, for a
    /// stored depth that is NaN, not in front of the near plane or at or
    /// beyond the far plane (sky), or an unusable normal.
    #[inline]
    pub fn surface(&self, x: u32, y: u32) -> Option<Surface> {
        let cam = self.camera();
        let z = self.depth.linear_at(x, y)?;
        if !(z >= cam.near() && z < cam.far()) {
            return None;
        }
        let normal = self.world_normal(x, y)?;
        let stored = self.depth.depth().get(x, y)?;
        let position = cam.unproject(
            Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
            stored,
            self.depth.convention(),
        );
        if !position.is_finite() {
            return None;
        }
        Some(Surface {
            position,
            normal,
            depth: z,
        })
    }

    /// The convention of the depth (and back-face) images.
    pub const fn convention(&self) -> DepthConvention {
        self.depth.convention()
    }
}
