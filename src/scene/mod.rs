//! Scenes: a flat triangle soup with per-vertex shading normals, objects,
//! materials, lights and a camera path, plus the built-in procedural scenes.
//!
//! Geometry is stored per triangle (`tris[i]` holds the three world-space
//! vertices of primitive `i`, `normals[i]` its three unit shading normals), so
//! a primitive id is all a tracer or rasterizer has to report. Objects own
//! contiguous primitive ranges; the object of a primitive is `tri_object[i]`.
//!
//! The built-in scenes take a target triangle count so that cost can be
//! plotted against scene size; each lands within 10% of the target for targets
//! from 10k to 1M (below ~5k the fixed minimum tessellation of the small
//! objects dominates). They are deterministic: the only "randomness" is the
//! integer hash [`refl_core::lobe::pixel_hash`].
//!
//! | scene | reflectors | reflected objects |
//! |---|---|---|
//! | [`Scene::room`] | planar mirror floor, mirror sphere, glossy torus | box and cylinder standing on the mirror, spheres, checkered walls |
//! | [`Scene::concave`] | concave hemispherical bowl, concave cylindrical mirror | cup (U profile) in the bowl, arch (U shape), spheres, checkered ground |
//! | [`Scene::walkthrough`] | mirror floors in some rooms, mirror spheres, glossy pillars | walls with doorways, pillars, crates |
//! | [`Scene::stage`] | planar mirror floor (near and grazing views) | a torus standing on the mirror, a wall, a box |
//! | [`Scene::hall`] | two facing planar mirrors (a hall of mirrors: second bounces on screen) | a box, a sphere and a cylinder on a checkered floor, a checkered end wall |
//!
//! [`Scene::load_obj`] loads a Wavefront OBJ file instead; it refuses bad
//! input with an [`ObjError`] and records what it worked around in
//! [`Scene::load_notes`].
//!
//! Source layout: this file holds the data model; `mesh.rs` the scene
//! builder and tessellation, `path.rs` the camera paths, `obj.rs` the OBJ
//! loader, and `room.rs`, `concave.rs`, `walkthrough.rs`, `stage.rs` and `hall.rs` one
//! built-in scene each.

mod concave;
mod hall;
mod mesh;
mod obj;
mod path;
mod room;
mod stage;
mod walkthrough;

pub use hall::HALL_HALF;
pub use obj::ObjError;
pub use path::load_camera_path;

use glam::Vec3;
use refl_core::{Camera, Error, Plane};
use std::ops::Range;

/// Sentinel object / primitive / material id meaning "none" (background).
pub const NONE: u32 = u32::MAX;

/// An axis-aligned bounding box. [`Aabb::EMPTY`] contains nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (`min = +inf`, `max = -inf`); growing it by a point gives
    /// that point's box.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// Extends the box to contain `p`.
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box containing both boxes.
    pub fn union(self, other: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// `true` if the box contains no point.
    pub fn is_empty(&self) -> bool {
        !self.min.cmple(self.max).all()
    }

    /// Center point (meaningless for an empty box).
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Length of the diagonal; 0 for an empty box.
    pub fn diagonal(&self) -> f32 {
        if self.is_empty() {
            0.0
        } else {
            (self.max - self.min).length()
        }
    }

    /// The eight corners.
    pub fn corners(&self) -> [Vec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            Vec3::new(a.x, a.y, a.z),
            Vec3::new(b.x, a.y, a.z),
            Vec3::new(a.x, b.y, a.z),
            Vec3::new(b.x, b.y, a.z),
            Vec3::new(a.x, a.y, b.z),
            Vec3::new(b.x, a.y, b.z),
            Vec3::new(a.x, b.y, b.z),
            Vec3::new(b.x, b.y, b.z),
        ]
    }
}

/// A procedural 3D checker: cells of edge `size` alternate between the
/// material's albedo and `color`.
///
/// Cell parity is `floor(p.x / size + 0.25) + floor(p.y / size + 0.25) +
/// floor(p.z / size + 0.25)`; the quarter-cell offset keeps axis-aligned
/// surfaces at multiples of half a cell (all walls and floors of the built-in
/// scenes) away from cell boundaries, where rounding would flip the parity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checker {
    /// Color of the odd cells.
    pub color: Vec3,
    /// Cell edge length in world units.
    pub size: f32,
}

/// A surface material: a Lambertian base plus a reflective (specular) layer.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name (from the scene or the OBJ's MTL file).
    pub name: String,
    /// Diffuse albedo (linear RGB); the even cells if `checker` is set.
    pub albedo: Vec3,
    /// Optional checker texture.
    pub checker: Option<Checker>,
    /// Specular level (reflectivity) in `0..=1`: the final color is
    /// `(1 - specular) * direct + specular * reflection`. 0 = not reflective.
    pub specular: f32,
    /// Roughness in `0..=1`; 0 is a perfect mirror. See [`phong_exponent`].
    pub roughness: f32,
}

impl Material {
    /// A non-reflective Lambertian material.
    pub fn diffuse(name: &str, albedo: Vec3) -> Self {
        Self {
            name: name.to_owned(),
            albedo,
            checker: None,
            specular: 0.0,
            roughness: 1.0,
        }
    }

    /// A non-reflective checkered material with cells `a` / `b` of edge `size`.
    pub fn checkered(name: &str, a: Vec3, b: Vec3, size: f32) -> Self {
        Self {
            checker: Some(Checker { color: b, size }),
            ..Self::diffuse(name, a)
        }
    }

    /// A reflective material.
    pub fn reflective(name: &str, albedo: Vec3, specular: f32, roughness: f32) -> Self {
        Self {
            name: name.to_owned(),
            albedo,
            checker: None,
            specular,
            roughness,
        }
    }

    /// `true` if the material reflects (specular level > 0).
    pub fn is_reflective(&self) -> bool {
        self.specular > 0.0
    }

    /// `true` for a perfect mirror: reflective with roughness 0.
    pub fn is_mirror(&self) -> bool {
        self.is_reflective() && self.roughness == 0.0
    }

    /// The Phong exponent of the reflection lobe, see [`phong_exponent`].
    pub fn phong_exponent(&self) -> f32 {
        phong_exponent(self.roughness)
    }

    /// The (possibly textured) albedo at world point `p`.
    pub fn albedo_at(&self, p: Vec3) -> Vec3 {
        match self.checker {
            Some(c) => {
                let q = (p / c.size + 0.25).floor();
                if (q.x + q.y + q.z).rem_euclid(2.0) >= 1.0 {
                    c.color
                } else {
                    self.albedo
                }
            }
            None => self.albedo,
        }
    }
}

/// The Phong exponent for a roughness: `2 / r^4 - 2`, the Blinn-Phong power
/// matching a Beckmann lobe of slope `m = r^2` (Walter et al. 2007). Roughness
/// 0 gives `+inf` (a perfect mirror), 0.25 gives 510, 0.3 gives 245, 1 gives 0.
/// This is [`refl_core::lobe::try_phong_power_from_roughness`] with the
/// roughness clamped to `0..=1` (NaN reads as 1).
pub fn phong_exponent(roughness: f32) -> f32 {
    let r = if roughness.is_nan() {
        1.0
    } else {
        roughness.clamp(0.0, 1.0)
    };
    refl_core::lobe::try_phong_power_from_roughness(r).unwrap_or(0.0)
}

/// A light source. Shading is Lambertian, see [`crate::shade::Shader::direct`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// A light at infinity.
    Directional {
        /// Unit direction from the surface **toward** the light.
        direction: Vec3,
        /// Irradiance (linear RGB) on a surface facing the light.
        color: Vec3,
    },
    /// A point light with smooth falloff `1 / (1 + (d / range)^2)`.
    Point {
        /// World position.
        position: Vec3,
        /// Irradiance (linear RGB) at distance 0 on a surface facing the light.
        color: Vec3,
        /// Distance at which the irradiance has halved.
        range: f32,
    },
}

/// A scene object: a contiguous primitive range with one material.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Name (from the built-in scene or the OBJ file).
    pub name: String,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// `Some(plane)` for a planar reflector: every triangle lies in `plane`.
    pub planar: Option<Plane>,
    /// Its primitives: `tris[range]`.
    pub tris: Range<u32>,
    /// World-space bounds of its triangles.
    pub bounds: Aabb,
}

/// One pose of a camera path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPose {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Approximate up direction.
    pub up: Vec3,
    /// Vertical field of view in radians.
    pub fov_y: f32,
}

impl CameraPose {
    /// The camera of this pose for an image size and near/far planes.
    ///
    /// # Errors
    /// As [`Camera::try_look_at`].
    pub fn camera(&self, near: f32, far: f32, width: u32, height: u32) -> Result<Camera, Error> {
        Camera::try_look_at(
            self.eye,
            self.target,
            self.up,
            self.fov_y,
            near,
            far,
            width,
            height,
        )
    }
}

/// A renderable scene. See the module docs for the layout.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Scene name (`room`, `concave`, `walkthrough`, `stage`, `hall` or the
    /// OBJ file stem).
    pub name: String,
    /// Triangle vertices, world space, one entry per primitive.
    pub tris: Vec<[Vec3; 3]>,
    /// Unit shading normals at the three vertices of each primitive.
    pub normals: Vec<[Vec3; 3]>,
    /// Object id of each primitive.
    pub tri_object: Vec<u32>,
    /// Objects; object `i` owns primitives `objects[i].tris`.
    pub objects: Vec<Object>,
    /// Materials, indexed by [`Object::material`].
    pub materials: Vec<Material>,
    /// Lights.
    pub lights: Vec<Light>,
    /// Ambient irradiance (linear RGB), added unshadowed.
    pub ambient: Vec3,
    /// A smooth camera path, 8 to 16 poses.
    pub camera_path: Vec<CameraPose>,
    /// Near plane distance for the path's cameras.
    pub near: f32,
    /// Far plane distance for the path's cameras (covers the whole scene from
    /// every pose).
    pub far: f32,
    /// Triangles [`Scene::load_obj`] dropped because they have zero area
    /// (repeated or collinear vertices); 0 for the built-in scenes.
    pub skipped_degenerate_triangles: usize,
    /// What [`Scene::load_obj`] worked around, one sentence each, for a
    /// report to print: the degenerate triangles dropped per object, an MTL
    /// file that failed to load. Empty for the built-in scenes.
    pub load_notes: Vec<String>,
}

impl Scene {
    /// Default target triangle count of the built-in scenes.
    pub const DEFAULT_TRIS: usize = 120_000;

    /// Number of triangles.
    pub fn tri_count(&self) -> usize {
        self.tris.len()
    }

    /// Bounds of the scene: the union of the objects' [`Object::bounds`].
    pub fn bounds(&self) -> Aabb {
        self.objects
            .iter()
            .fold(Aabb::EMPTY, |b, o| b.union(o.bounds))
    }

    /// Length of the bounding box diagonal.
    pub fn diameter(&self) -> f32 {
        self.bounds().diagonal()
    }

    /// Self-intersection tolerance of secondary rays, sized to the scene:
    /// `1e-5` of the diameter, at least `1e-6` (see
    /// [`crate::shade::Shader::epsilon`] for how it is applied).
    pub fn ray_epsilon(&self) -> f32 {
        (self.diameter() * 1e-5).max(1e-6)
    }

    /// The material of primitive `prim`.
    pub fn material_of(&self, prim: u32) -> &Material {
        let object = &self.objects[self.tri_object[prim as usize] as usize];
        &self.materials[object.material as usize]
    }

    /// The camera of path pose `pose` with this scene's near and far planes.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a pose index out of range; otherwise as
    /// [`Camera::try_look_at`].
    pub fn camera(&self, pose: usize, width: u32, height: u32) -> Result<Camera, Error> {
        self.camera_path
            .get(pose)
            .ok_or(Error::InvalidArgument)?
            .camera(self.near, self.far, width, height)
    }
}
