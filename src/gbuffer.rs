//! The G-buffer: what the primary ray through each pixel center sees, as
//! one plane per attribute (struct of arrays, row-major, `width * height`
//! elements, index `y * width + x`).
//!
//! Background pixels (the primary ray hits nothing) have
//! `object == prim == material ==` [`NONE`], linear depth `+inf` and zero
//! position, normals, albedo and specular level.

use crate::scene::{Scene, NONE};
use crate::shade::Surface;
use crate::tracer::Tracer;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use refl_core::{Camera, DepthConvention, Ray};

/// Per-pixel primary visibility and surface attributes of one camera.
#[derive(Clone, Debug)]
pub struct GBuffer {
    /// The camera the buffer was rendered with.
    pub camera: Camera,
    /// Linear view depth (distance along the view axis); `+inf` for
    /// background. See [`GBuffer::depth_image`] for the other conventions.
    pub depth: Vec<f32>,
    /// World-space hit point.
    pub position: Vec<Vec3>,
    /// Unit shading normal (interpolated vertex normals), on the viewer's
    /// side of the surface.
    pub normal: Vec<Vec3>,
    /// Unit geometric normal, facing the viewer.
    pub geo_normal: Vec<Vec3>,
    /// Material id.
    pub material: Vec<u32>,
    /// Textured albedo.
    pub albedo: Vec<Vec3>,
    /// Specular level (0 = not reflective).
    pub specular: Vec<f32>,
    /// Roughness (0 = mirror).
    pub roughness: Vec<f32>,
    /// Object id.
    pub object: Vec<u32>,
    /// Primitive id.
    pub prim: Vec<u32>,
}

impl GBuffer {
    /// Traces the primary ray through every pixel center of `camera`
    /// (`tmin = 0`, no far limit) in parallel over rows on `pool`.
    pub fn render(
        scene: &Scene,
        tracer: &Tracer,
        camera: &Camera,
        pool: &rayon::ThreadPool,
    ) -> GBuffer {
        let (w, h) = (camera.width(), camera.height());
        let rows: Vec<Vec<Option<Surface>>> = pool.install(|| {
            (0..h)
                .into_par_iter()
                .map(|y| {
                    (0..w)
                        .map(|x| {
                            let ray = camera.primary_ray(pixel_center(x, y));
                            tracer
                                .trace(ray.origin, ray.dir, 0.0, f32::INFINITY)
                                .map(|hit| Surface::at_hit(scene, ray.origin, ray.dir, &hit))
                        })
                        .collect()
                })
                .collect()
        });
        let n = (w as usize) * (h as usize);
        let mut g = GBuffer {
            camera: *camera,
            depth: Vec::with_capacity(n),
            position: Vec::with_capacity(n),
            normal: Vec::with_capacity(n),
            geo_normal: Vec::with_capacity(n),
            material: Vec::with_capacity(n),
            albedo: Vec::with_capacity(n),
            specular: Vec::with_capacity(n),
            roughness: Vec::with_capacity(n),
            object: Vec::with_capacity(n),
            prim: Vec::with_capacity(n),
        };
        for s in rows.into_iter().flatten() {
            match s {
                Some(s) => {
                    let m = &scene.materials[s.material as usize];
                    g.depth.push(camera.linear_depth(s.position));
                    g.position.push(s.position);
                    g.normal.push(s.shading_normal);
                    g.geo_normal.push(s.geo_normal);
                    g.material.push(s.material);
                    g.albedo.push(s.albedo);
                    g.specular.push(m.specular);
                    g.roughness.push(m.roughness);
                    g.object.push(s.object);
                    g.prim.push(s.prim);
                }
                None => {
                    g.depth.push(f32::INFINITY);
                    g.position.push(Vec3::ZERO);
                    g.normal.push(Vec3::ZERO);
                    g.geo_normal.push(Vec3::ZERO);
                    g.material.push(NONE);
                    g.albedo.push(Vec3::ZERO);
                    g.specular.push(0.0);
                    g.roughness.push(0.0);
                    g.object.push(NONE);
                    g.prim.push(NONE);
                }
            }
        }
        g
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.camera.width()
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.camera.height()
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.depth.len()
    }

    /// `true` for a zero-pixel buffer (never produced by [`GBuffer::render`],
    /// whose camera has a non-zero size).
    pub fn is_empty(&self) -> bool {
        self.depth.is_empty()
    }

    /// Pixel `(x, y)` of index `i`.
    pub fn pixel(&self, i: usize) -> (u32, u32) {
        let w = self.width() as usize;
        ((i % w) as u32, (i / w) as u32)
    }

    /// The primary ray of pixel index `i` (through its center).
    pub fn primary_ray(&self, i: usize) -> Ray {
        let (x, y) = self.pixel(i);
        self.camera.primary_ray(pixel_center(x, y))
    }

    /// `true` if pixel `i` sees a surface.
    pub fn is_hit(&self, i: usize) -> bool {
        self.object[i] != NONE
    }

    /// `true` if pixel `i` sees a reflective surface (specular level > 0).
    pub fn is_reflective(&self, i: usize) -> bool {
        self.specular[i] > 0.0
    }

    /// The mask of reflective pixels.
    pub fn reflective_mask(&self) -> Vec<bool> {
        (0..self.len()).map(|i| self.is_reflective(i)).collect()
    }

    /// The surface seen by pixel `i`, or `None` for background.
    pub fn surface(&self, i: usize) -> Option<Surface> {
        self.is_hit(i).then(|| Surface {
            position: self.position[i],
            shading_normal: self.normal[i],
            geo_normal: self.geo_normal[i],
            prim: self.prim[i],
            object: self.object[i],
            material: self.material[i],
            albedo: self.albedo[i],
        })
    }

    /// The depth plane in convention `c` for this buffer's camera with its
    /// far plane replaced by `far` (e.g. `f32::INFINITY` for infinite
    /// reversed-Z, `self.camera.far()` for the camera's own). Background
    /// pixels get the far plane's value (`far` for linear, 1 for
    /// [`DepthConvention::ZeroToOne`], 0 for [`DepthConvention::ReversedZ`]).
    ///
    /// # Errors
    /// [`refl_core::Error::InvalidArgument`] if `far` is not greater than the
    /// camera's near plane.
    pub fn depth_image(&self, c: DepthConvention, far: f32) -> Result<Vec<f32>, refl_core::Error> {
        let cam = Camera::try_new(
            self.camera.view(),
            self.camera.fov_y(),
            self.camera.near(),
            far,
            self.width(),
            self.height(),
        )?;
        Ok(self
            .depth
            .iter()
            .map(|&z| cam.encode_depth(if z.is_finite() { z } else { far }, c))
            .collect())
    }
}

/// The center of pixel `(x, y)`: `(x + 0.5, y + 0.5)`.
pub fn pixel_center(x: u32, y: u32) -> Vec2 {
    Vec2::new(x as f32 + 0.5, y as f32 + 0.5)
}
