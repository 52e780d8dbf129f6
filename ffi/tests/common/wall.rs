//! The depth-image test frame of the C tracers (`tests/hiz.rs`,
//! `tests/step.rs`, `tests/last_error.rs`; included with `#[path]`): a
//! camera looking down -z at a wall at depth 8 with a box at depth 3 in
//! front of it, the C descriptors of its depth images and Hi-Z pyramids, and
//! refl-core's pyramid to compare with. Each test chooses its image size and
//! where the box and the hole lie ([`Scene`]).
// Each including test uses a different subset of the frame.
#![allow(dead_code)]

use core::ops::Range;
use refl::*;
use refl_core::glam::Vec3;
use refl_core::{try_build_hiz, try_hiz_len, Camera, DepthConvention, DepthImage, ImageView};

/// A `w x h` camera at `(eye_x, 1.5, 4)` looking at `(0, 0.5, -5)`.
pub fn look(w: u32, h: u32, eye_x: f32) -> Camera {
    Camera::try_look_at(
        Vec3::new(eye_x, 1.5, 4.0),
        Vec3::new(0.0, 0.5, -5.0),
        Vec3::Y,
        1.0,
        0.1,
        100.0,
        w,
        h,
    )
    .unwrap()
}

/// A test's frame: the image size, and where the box and the hole lie in
/// it, in pixels.
pub struct Scene {
    pub width: u32,
    pub height: u32,
    /// The box's columns and rows.
    pub box_x: Range<u32>,
    pub box_y: Range<u32>,
    /// The hole's row and columns.
    pub hole_y: u32,
    pub hole_x: Range<u32>,
}

impl Scene {
    /// The frame's camera: [`look`] from `x = 0.5`.
    pub fn camera(&self) -> Camera {
        look(self.width, self.height, 0.5)
    }

    /// The front and back-face depth images seen by `cam` (of the frame's
    /// size): a wall at depth 8 (back faces at 9) with the box at depth 3
    /// (back faces at 4, so 1 thick), and the hole of NaN front texels.
    pub fn images(&self, cam: &Camera, conv: DepthConvention) -> (Vec<f32>, Vec<f32>) {
        let w = self.width;
        let n = (w * self.height) as usize;
        let mut front = vec![cam.encode_depth(8.0, conv); n];
        let mut back = vec![cam.encode_depth(9.0, conv); n];
        for y in self.box_y.clone() {
            for x in self.box_x.clone() {
                front[(y * w + x) as usize] = cam.encode_depth(3.0, conv);
                back[(y * w + x) as usize] = cam.encode_depth(4.0, conv);
            }
        }
        for x in self.hole_x.clone() {
            front[(self.hole_y * w + x) as usize] = f32::NAN;
        }
        (front, back)
    }

    /// An image of the frame's size over `data`, tightly packed.
    pub fn image_c(&self, data: &[f32]) -> refl_image_f32 {
        image_c(data, self.width, self.height)
    }
}

/// A tightly packed `w x h` image over `data`.
pub fn image_c(data: &[f32], w: u32, h: u32) -> refl_image_f32 {
    refl_image_f32 {
        data: data.as_ptr(),
        len: data.len(),
        width: w,
        height: h,
        stride: w,
    }
}

/// No image (a null `data`, every size 0).
pub fn no_image() -> refl_image_f32 {
    refl_image_f32 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

/// The depth image `data`, of the camera's size, seen by `cam`.
pub fn depth_image_c(cam: &Camera, data: &[f32], conv: DepthConvention) -> refl_depth_image {
    refl_depth_image {
        depth: image_c(data, cam.width(), cam.height()),
        camera: cam.into(),
        convention: conv as u32,
    }
}

/// refl-core's Hi-Z pyramid of the depth image `data`, of the camera's size.
pub fn core_pyramid(cam: &Camera, data: &[f32], conv: DepthConvention) -> Vec<[f32; 2]> {
    let (w, h) = (cam.width(), cam.height());
    let img = DepthImage::try_new(ImageView::try_new(data, w, h, w).unwrap(), *cam, conv).unwrap();
    let mut p = vec![[0.0f32; 2]; try_hiz_len(w, h).unwrap()];
    try_build_hiz(&mut p, &img).unwrap();
    p
}

/// A pyramid's texels as C's `refl_vec2`.
pub fn texels_c(p: &[[f32; 2]]) -> Vec<refl_vec2> {
    p.iter().map(|t| refl_vec2 { x: t[0], y: t[1] }).collect()
}

/// The pyramid `p`, built for `cam`.
pub fn hiz_c(cam: &Camera, p: &[refl_vec2], conv: DepthConvention) -> refl_hiz {
    refl_hiz {
        data: p.as_ptr(),
        len: p.len(),
        camera: cam.into(),
        convention: conv as u32,
    }
}
