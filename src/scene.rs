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
//! integer hash [`crate::shade::hash32`].
//!
//! | scene | reflectors | reflected objects |
//! |---|---|---|
//! | [`Scene::room`] | planar mirror floor, mirror sphere, glossy torus | box and cylinder standing on the mirror, spheres, checkered walls |
//! | [`Scene::concave`] | concave hemispherical bowl, concave cylindrical mirror | cup (U profile) in the bowl, arch (U shape), spheres, checkered ground |
//! | [`Scene::walkthrough`] | mirror floors in some rooms, mirror spheres, glossy pillars | walls with doorways, pillars, crates |
//! | [`Scene::stage`] | planar mirror floor (near and grazing views) | a torus standing on the mirror, a wall, a box |

use crate::shade::{hash32, SUN_DIRECTION};
use glam::{Affine3A, Quat, Vec2, Vec3};
use refl_core::{Camera, Error, Plane};
use std::collections::HashMap;
use std::f32::consts::{FRAC_PI_2, PI, TAU};
use std::ops::Range;
use std::path::Path;

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
pub fn phong_exponent(roughness: f32) -> f32 {
    if roughness <= 0.0 {
        f32::INFINITY
    } else {
        (2.0 / roughness.powi(4) - 2.0).max(0.0)
    }
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
    /// Scene name (`room`, `concave`, `walkthrough` or the OBJ file stem).
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

    /// A pose between the path's poses, for frame sequences denser than the
    /// stored path: `s` runs from 0 (first pose) to 1 (last pose, clamped);
    /// eye and target follow uniform Catmull-Rom splines through the stored
    /// poses (so `s = k / (n - 1)` gives pose `k`), up and field of view are
    /// those of the nearest stored pose. `None` for an empty path.
    pub fn pose_at(&self, s: f32) -> Option<CameraPose> {
        let n = self.camera_path.len();
        let nearest = self
            .camera_path
            .get((s.clamp(0.0, 1.0) * (n.max(1) - 1) as f32).round() as usize)?;
        if n == 1 {
            return Some(*nearest);
        }
        let eyes: Vec<Vec3> = self.camera_path.iter().map(|p| p.eye).collect();
        let targets: Vec<Vec3> = self.camera_path.iter().map(|p| p.target).collect();
        Some(CameraPose {
            eye: catmull_rom(&eyes, s),
            target: catmull_rom(&targets, s),
            ..*nearest
        })
    }

    /// A room of about `tris` triangles: a planar perfect-mirror floor, a
    /// mirror sphere and a glossy torus (roughness 0.25) standing on it, a box
    /// and a cylinder standing on the mirror, a diffuse sphere, a checkered
    /// pedestal and four checkered walls (no ceiling, so the sky shows in
    /// upward reflections). 12 camera poses on an arc inside the room.
    pub fn room(tris: usize) -> Scene {
        let t = tris as f32;
        let mut b = Builder::new("room");
        let half = 6.0;
        let wall_h = 3.5;

        let walls = [
            (
                "wall_back",
                Vec3::new(-half, 0.0, -half),
                Vec3::X * 2.0 * half,
                Vec3::Z,
                Vec3::new(0.85, 0.85, 0.8),
                Vec3::new(0.2, 0.25, 0.5),
            ),
            (
                "wall_front",
                Vec3::new(half, 0.0, half),
                Vec3::NEG_X * 2.0 * half,
                Vec3::NEG_Z,
                Vec3::new(0.8, 0.8, 0.9),
                Vec3::new(0.3, 0.3, 0.3),
            ),
            (
                "wall_left",
                Vec3::new(-half, 0.0, half),
                Vec3::NEG_Z * 2.0 * half,
                Vec3::X,
                Vec3::new(0.9, 0.8, 0.6),
                Vec3::new(0.5, 0.2, 0.15),
            ),
            (
                "wall_right",
                Vec3::new(half, 0.0, -half),
                Vec3::Z * 2.0 * half,
                Vec3::NEG_X,
                Vec3::new(0.8, 0.9, 0.8),
                Vec3::new(0.15, 0.4, 0.2),
            ),
        ];
        for (name, corner, u, normal, a, c) in walls {
            let m = b.material(Material::checkered(name, a, c, 0.5));
            let mesh = grid_for(corner, u, Vec3::Y * wall_h, normal, t * 0.03);
            b.object(name, m, mesh, None);
        }

        let m = b.material(Material::reflective(
            "mirror_sphere",
            Vec3::splat(0.75),
            0.95,
            0.0,
        ));
        let r = 1.1;
        let mesh =
            sphere(r, t * 0.25).transformed(Affine3A::from_translation(Vec3::new(-1.6, r, -1.2)));
        b.object("mirror_sphere", m, mesh, None);

        let m = b.material(Material::reflective(
            "glossy_torus",
            Vec3::new(0.9, 0.7, 0.3),
            0.7,
            0.25,
        ));
        let (major, minor) = (0.75, 0.25);
        // Stood up (axis horizontal), then turned about the vertical: the
        // lowest point touches the floor.
        let mesh = torus(major, minor, t * 0.2).transformed(Affine3A::from_rotation_translation(
            Quat::from_rotation_y(0.5) * Quat::from_rotation_x(FRAC_PI_2),
            Vec3::new(2.0, major + minor, -1.8),
        ));
        b.object("glossy_torus", m, mesh, None);

        let m = b.material(Material::diffuse("red_box", Vec3::new(0.8, 0.2, 0.15)));
        let mesh = cuboid(Vec3::new(0.45, 0.6, 0.45), t * 0.03).transformed(
            Affine3A::from_rotation_translation(
                Quat::from_rotation_y(0.52),
                Vec3::new(0.6, 0.6, 0.4),
            ),
        );
        b.object("red_box", m, mesh, None);

        let m = b.material(Material::diffuse(
            "blue_cylinder",
            Vec3::new(0.2, 0.35, 0.85),
        ));
        let mesh = cylinder(0.45, 1.6, t * 0.06)
            .transformed(Affine3A::from_translation(Vec3::new(-2.8, 0.0, 1.2)));
        b.object("blue_cylinder", m, mesh, None);

        let m = b.material(Material::diffuse(
            "green_sphere",
            Vec3::new(0.25, 0.75, 0.3),
        ));
        let mesh = sphere(0.55, t * 0.08)
            .transformed(Affine3A::from_translation(Vec3::new(2.6, 0.55, 1.4)));
        b.object("green_sphere", m, mesh, None);

        let m = b.material(Material::checkered(
            "pedestal",
            Vec3::splat(0.9),
            Vec3::splat(0.08),
            0.2,
        ));
        let mesh = cuboid(Vec3::new(1.0, 0.4, 0.5), t * 0.02)
            .transformed(Affine3A::from_translation(Vec3::new(0.0, 0.4, -4.0)));
        b.object("pedestal", m, mesh, None);

        // The floor takes the remaining budget.
        let m = b.material(Material::reflective(
            "mirror_floor",
            Vec3::splat(0.15),
            0.9,
            0.0,
        ));
        let remaining = t - b.tri_count() as f32;
        let mesh = grid_for(
            Vec3::new(-half, 0.0, half),
            Vec3::X * 2.0 * half,
            Vec3::NEG_Z * 2.0 * half,
            Vec3::Y,
            remaining.max(2.0),
        );
        let floor_plane = Plane::try_from_point_normal(Vec3::ZERO, Vec3::Y).ok();
        b.object("mirror_floor", m, mesh, floor_plane);

        let path = orbit_path(
            Vec3::new(0.0, 0.0, 0.0),
            5.2,
            (2.4, 1.9),
            (-0.6, 0.6),
            12,
            Vec3::new(0.0, 0.7, -0.8),
            60f32.to_radians(),
        );
        b.finish(
            vec![
                Light::Directional {
                    direction: SUN_DIRECTION,
                    color: Vec3::new(0.75, 0.72, 0.65),
                },
                Light::Point {
                    position: Vec3::new(0.0, 3.2, 2.0),
                    color: Vec3::new(0.3, 0.3, 0.35),
                    range: 6.0,
                },
            ],
            Vec3::splat(0.15),
            path,
        )
    }

    /// Concave reflectors of about `tris` triangles: the inside of a
    /// hemispherical mirror bowl with a cup (U-shaped profile) standing in
    /// it, a concave cylindrical mirror wall behind, an arch (U shape) and
    /// two spheres on a checkered ground. 12 camera poses on an arc.
    pub fn concave(tris: usize) -> Scene {
        let t = tris as f32;
        let mut b = Builder::new("concave");

        let bowl_r = 1.6;
        let m = b.material(Material::reflective(
            "mirror_bowl",
            Vec3::splat(0.7),
            0.9,
            0.0,
        ));
        let mesh = bowl(bowl_r, t * 0.3)
            .transformed(Affine3A::from_translation(Vec3::new(0.0, bowl_r, 0.0)));
        b.object("mirror_bowl", m, mesh, None);

        // The cup's base rim touches the bowl.
        let cup_r = 0.35;
        let base_y = bowl_r - (bowl_r * bowl_r - cup_r * cup_r).sqrt();
        let m = b.material(Material::diffuse("cup", Vec3::new(0.9, 0.5, 0.15)));
        let mesh = cup(cup_r, 0.9, 0.05, t * 0.15)
            .transformed(Affine3A::from_translation(Vec3::new(0.0, base_y, 0.0)));
        b.object("cup", m, mesh, None);

        let m = b.material(Material::reflective(
            "concave_cylinder_mirror",
            Vec3::splat(0.6),
            0.85,
            0.0,
        ));
        let mesh = cylinder_wall(
            4.5,
            2.8,
            (195f32.to_radians(), 345f32.to_radians()),
            t * 0.2,
        );
        b.object("concave_cylinder_mirror", m, mesh, None);

        let m = b.material(Material::checkered(
            "arch",
            Vec3::new(0.55, 0.3, 0.75),
            Vec3::new(0.95, 0.9, 0.4),
            0.25,
        ));
        let arch_t = t * 0.05 / 3.0;
        let mut arch = cuboid(Vec3::new(0.15, 0.6, 0.2), arch_t)
            .transformed(Affine3A::from_translation(Vec3::new(-0.5, 0.6, 0.0)));
        arch.append(
            cuboid(Vec3::new(0.15, 0.6, 0.2), arch_t)
                .transformed(Affine3A::from_translation(Vec3::new(0.5, 0.6, 0.0))),
        );
        arch.append(
            cuboid(Vec3::new(0.65, 0.15, 0.2), arch_t)
                .transformed(Affine3A::from_translation(Vec3::new(0.0, 1.35, 0.0))),
        );
        let arch = arch.transformed(Affine3A::from_rotation_translation(
            Quat::from_rotation_y(-0.5),
            Vec3::new(2.4, 0.0, 1.0),
        ));
        b.object("arch", m, arch, None);

        let m = b.material(Material::diffuse("red_sphere", Vec3::new(0.85, 0.2, 0.2)));
        let mesh = sphere(0.5, t * 0.06)
            .transformed(Affine3A::from_translation(Vec3::new(-2.3, 0.5, 0.9)));
        b.object("red_sphere", m, mesh, None);

        let m = b.material(Material::checkered(
            "checker_sphere",
            Vec3::splat(0.9),
            Vec3::new(0.1, 0.3, 0.6),
            0.15,
        ));
        let mesh = sphere(0.35, t * 0.04)
            .transformed(Affine3A::from_translation(Vec3::new(0.9, 0.35, 2.3)));
        b.object("checker_sphere", m, mesh, None);

        let m = b.material(Material::checkered(
            "ground",
            Vec3::splat(0.7),
            Vec3::new(0.35, 0.35, 0.4),
            0.5,
        ));
        let remaining = t - b.tri_count() as f32;
        let mesh = grid_for(
            Vec3::new(-8.0, 0.0, 8.0),
            Vec3::X * 16.0,
            Vec3::NEG_Z * 16.0,
            Vec3::Y,
            remaining.max(2.0),
        );
        b.object("ground", m, mesh, None);

        // High enough to see the cup over the bowl's rim.
        let path = orbit_path(
            Vec3::ZERO,
            5.8,
            (5.0, 4.2),
            (-0.7, 0.7),
            12,
            Vec3::new(0.0, 0.6, -0.4),
            55f32.to_radians(),
        );
        b.finish(
            vec![
                Light::Directional {
                    direction: SUN_DIRECTION,
                    color: Vec3::new(0.75, 0.72, 0.65),
                },
                Light::Point {
                    position: Vec3::new(0.0, 4.0, 3.0),
                    color: Vec3::new(0.3, 0.3, 0.35),
                    range: 6.0,
                },
            ],
            Vec3::splat(0.15),
            path,
        )
    }

    /// A densely occluded interior of about `tris` triangles: a 4 x 3 block
    /// of 6 m rooms with 3 m walls (doorways in every interior wall, no
    /// ceiling), four pillars and two crates per room. Room `(i, j)` has a
    /// planar mirror floor if `i + j` is even, glossy pillars if
    /// `(i + 2j) mod 3 = 0` and a mirror sphere on a pedestal unless
    /// `(2i + j) mod 3 = 1`. 16 camera poses walk a smooth path through seven
    /// rooms at eye height, alternating mirror and stone floors.
    pub fn walkthrough(tris: usize) -> Scene {
        const NX: i32 = 4;
        const NZ: i32 = 3;
        const ROOM: f32 = 6.0;
        const WALL_H: f32 = 3.0;
        const WALL_T: f32 = 0.1; // half thickness
        const DOOR_W: f32 = 1.2;
        const DOOR_H: f32 = 2.2;
        let t = tris as f32;
        let rooms = (NX * NZ) as f32;
        let x0 = -(NX as f32) * ROOM * 0.5;
        let z0 = -(NZ as f32) * ROOM * 0.5;
        let center = |i: i32, j: i32| {
            Vec3::new(
                x0 + (i as f32 + 0.5) * ROOM,
                0.0,
                z0 + (j as f32 + 0.5) * ROOM,
            )
        };
        let mut b = Builder::new("walkthrough");

        // Walls: one object per room side on each grid line; interior
        // segments have a centered doorway (two side pieces and a lintel).
        // Walls along x stop short of the walls along z by the thickness, so
        // that no two faces overlap in a plane.
        let wall_m = b.material(Material::checkered(
            "walls",
            Vec3::new(0.85, 0.82, 0.75),
            Vec3::new(0.55, 0.5, 0.45),
            0.5,
        ));
        // Total wall length (ignoring doors) to spread the wall budget.
        let segments = (NX * (NZ + 1) + NZ * (NX + 1)) as f32;
        let seg_t = t * 0.35 / segments;
        // `a` is the segment's start on the grid line; the segment runs ROOM
        // along +x or +z.
        let wall_segment = |a: Vec3, along_x: bool, door: bool| {
            let mut mesh = Mesh::default();
            let dir = if along_x { Vec3::X } else { Vec3::Z };
            let side = if along_x { Vec3::Z } else { Vec3::X };
            let mut piece = |from: f32, to: f32, y0: f32, y1: f32, share_of: f32| {
                let mid = a + dir * (from + to) * 0.5 + Vec3::Y * (y0 + y1) * 0.5;
                let half = dir * (to - from) * 0.5 + Vec3::Y * (y1 - y0) * 0.5 + side * WALL_T;
                mesh.append(
                    cuboid(half.abs(), seg_t * share_of)
                        .transformed(Affine3A::from_translation(mid)),
                );
            };
            let (start, end) = if along_x {
                (WALL_T, ROOM - WALL_T)
            } else {
                (0.0, ROOM)
            };
            if door {
                let d0 = (ROOM - DOOR_W) * 0.5;
                let d1 = (ROOM + DOOR_W) * 0.5;
                piece(start, d0, 0.0, WALL_H, 0.42);
                piece(d1, end, 0.0, WALL_H, 0.42);
                piece(d0, d1, DOOR_H, WALL_H, 0.16);
            } else {
                piece(start, end, 0.0, WALL_H, 1.0);
            }
            mesh
        };
        for j in 0..=NZ {
            for i in 0..NX {
                let a = Vec3::new(x0 + i as f32 * ROOM, 0.0, z0 + j as f32 * ROOM);
                let mesh = wall_segment(a, true, j > 0 && j < NZ);
                b.object(&format!("wall_x_{i}_{j}"), wall_m, mesh, None);
            }
        }
        for i in 0..=NX {
            for j in 0..NZ {
                let a = Vec3::new(x0 + i as f32 * ROOM, 0.0, z0 + j as f32 * ROOM);
                let mesh = wall_segment(a, false, i > 0 && i < NX);
                b.object(&format!("wall_z_{i}_{j}"), wall_m, mesh, None);
            }
        }

        let stone = b.material(Material::diffuse("pillar", Vec3::new(0.7, 0.68, 0.62)));
        let polished = b.material(Material::reflective(
            "glossy_pillar",
            Vec3::new(0.3, 0.3, 0.35),
            0.6,
            0.2,
        ));
        let crate_m = b.material(Material::checkered(
            "crate",
            Vec3::new(0.65, 0.45, 0.25),
            Vec3::new(0.45, 0.3, 0.15),
            0.25,
        ));
        let mirror_m = b.material(Material::reflective(
            "mirror_sphere",
            Vec3::splat(0.75),
            0.95,
            0.0,
        ));
        let pedestal_m = b.material(Material::diffuse("pedestal", Vec3::splat(0.35)));
        let pillar_t = t * 0.25 / (rooms * 4.0);
        let crate_t = t * 0.1 / (rooms * 2.0);
        let sphere_t = t * 0.1 / rooms;
        for j in 0..NZ {
            for i in 0..NX {
                let c = center(i, j);
                let h = hash32((j * NX + i) as u32 + 17);
                let glossy = (i + 2 * j) % 3 == 0;
                for (k, (sx, sz)) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
                    .into_iter()
                    .enumerate()
                {
                    let mesh = cylinder(0.25, WALL_H, pillar_t).transformed(
                        Affine3A::from_translation(c + Vec3::new(sx * 1.8, 0.0, sz * 1.8)),
                    );
                    let m = if glossy { polished } else { stone };
                    b.object(&format!("pillar_{i}_{j}_{k}"), m, mesh, None);
                }
                for k in 0..2u32 {
                    let hk = hash32(h ^ (k + 1).wrapping_mul(0x9e37_79b9));
                    let unit = |shift: u32| ((hk >> shift) & 0xff) as f32 / 255.0;
                    let sx = if k == 0 { -1.0 } else { 1.0 };
                    let sz = if hk & 1 == 0 { -1.0 } else { 1.0 };
                    let half = Vec3::new(
                        0.25 + 0.15 * unit(8),
                        0.25 + 0.25 * unit(16),
                        0.25 + 0.15 * unit(24),
                    );
                    let pos = c + Vec3::new(sx * 1.0, half.y, sz * 2.3);
                    let mesh =
                        cuboid(half, crate_t).transformed(Affine3A::from_rotation_translation(
                            Quat::from_rotation_y(unit(4) * 0.8 - 0.4),
                            pos,
                        ));
                    b.object(&format!("crate_{i}_{j}_{k}"), crate_m, mesh, None);
                }
                if (2 * i + j) % 3 != 1 {
                    let sx = if h & 4 == 0 { -1.0 } else { 1.0 };
                    let base = c + Vec3::new(sx * 1.0, 0.0, -1.0);
                    let mesh = cuboid(Vec3::new(0.3, 0.35, 0.3), 12.0)
                        .transformed(Affine3A::from_translation(base + Vec3::Y * 0.35));
                    b.object(&format!("pedestal_{i}_{j}"), pedestal_m, mesh, None);
                    let mesh = sphere(0.45, sphere_t)
                        .transformed(Affine3A::from_translation(base + Vec3::Y * 1.15));
                    b.object(&format!("mirror_sphere_{i}_{j}"), mirror_m, mesh, None);
                }
            }
        }

        // Floors take the remaining budget, one planar object per room.
        let floor_t = (t - b.tri_count() as f32 - 2.0 * rooms).max(2.0 * rooms) / rooms;
        let floor_mirror = b.material(Material::reflective(
            "mirror_floor",
            Vec3::splat(0.12),
            0.85,
            0.0,
        ));
        let floor_stone = b.material(Material::checkered(
            "floor",
            Vec3::new(0.6, 0.6, 0.62),
            Vec3::new(0.3, 0.32, 0.35),
            1.0,
        ));
        let plane = Plane::try_from_point_normal(Vec3::ZERO, Vec3::Y).ok();
        for j in 0..NZ {
            for i in 0..NX {
                let c = center(i, j);
                let mirror = (i + j) % 2 == 0;
                let mesh = grid_for(
                    c + Vec3::new(-ROOM * 0.5, 0.0, ROOM * 0.5),
                    Vec3::X * ROOM,
                    Vec3::NEG_Z * ROOM,
                    Vec3::Y,
                    floor_t,
                );
                let (m, p) = if mirror {
                    (floor_mirror, plane)
                } else {
                    (floor_stone, None)
                };
                b.object(&format!("floor_{i}_{j}"), m, mesh, p);
            }
        }

        // Walk through doors: room centers joined through door midpoints.
        // The eye looks one waypoint (3 m) ahead and stops at the last door,
        // looking at the last room's center.
        let route = [(0, 0), (1, 0), (1, 1), (2, 1), (2, 2), (3, 2), (3, 1)];
        let mut points = Vec::new();
        for w in route.windows(2) {
            let (a, c) = (center(w[0].0, w[0].1), center(w[1].0, w[1].1));
            points.push(a);
            points.push((a + c) * 0.5);
        }
        points.push(center(3, 1));
        let ahead = 1.0 / (points.len() - 1) as f32;
        let path = (0..16)
            .map(|k| {
                let s = k as f32 / 15.0 * (1.0 - ahead);
                CameraPose {
                    eye: catmull_rom(&points, s) + Vec3::Y * 1.6,
                    target: catmull_rom(&points, s + ahead) + Vec3::Y * 1.3,
                    up: Vec3::Y,
                    fov_y: 65f32.to_radians(),
                }
            })
            .collect();
        b.finish(
            vec![
                Light::Directional {
                    direction: SUN_DIRECTION,
                    color: Vec3::new(0.75, 0.72, 0.65),
                },
                Light::Point {
                    position: center(1, 1) + Vec3::Y * 2.8,
                    color: Vec3::new(0.35, 0.33, 0.3),
                    range: 5.0,
                },
            ],
            Vec3::splat(0.2),
            path,
        )
    }

    /// A mesh standing on a mirror floor, a wall and a box, seen from near
    /// and grazing poses, of about `tris` triangles: a diffuse torus stood
    /// up on a wide planar perfect-mirror floor (50 x 50 units; the ring
    /// touches the floor), a checkered wall behind the torus and a box
    /// beside it; no ceiling and no other walls, so much of the floor
    /// reflects the sky. 12 camera poses on an arc near the torus (3.3
    /// units from its center at the first pose, 2.4 at the last), the eye
    /// rising from 0.25 (grazing the floor) to 2.0 units (looking down). The
    /// scene of issue 13, where stride-1 stepping and Hi-Z with the root
    /// package's old start rule and a constant thickness of 0.005 scene
    /// diameters reported hits for up to 13% of the rays whose reflection
    /// is not visible.
    pub fn stage(tris: usize) -> Scene {
        let t = tris as f32;
        let mut b = Builder::new("stage");

        let m = b.material(Material::diffuse("torus", Vec3::new(0.85, 0.55, 0.2)));
        let (major, minor) = (0.7, 0.28);
        let mesh = torus(major, minor, t * 0.3).transformed(Affine3A::from_rotation_translation(
            Quat::from_rotation_y(-0.35) * Quat::from_rotation_x(FRAC_PI_2),
            Vec3::new(0.0, major + minor, -1.2),
        ));
        b.object("torus", m, mesh, None);

        let m = b.material(Material::checkered(
            "wall",
            Vec3::new(0.85, 0.85, 0.8),
            Vec3::new(0.2, 0.3, 0.55),
            0.4,
        ));
        let mesh = grid_for(
            Vec3::new(-4.5, 0.0, -3.8),
            Vec3::X * 9.0,
            Vec3::Y * 2.4,
            Vec3::Z,
            t * 0.05,
        );
        b.object("wall", m, mesh, None);

        let m = b.material(Material::diffuse("box", Vec3::new(0.2, 0.45, 0.8)));
        let mesh = cuboid(Vec3::new(0.45, 0.5, 0.45), t * 0.03).transformed(
            Affine3A::from_rotation_translation(
                Quat::from_rotation_y(0.6),
                Vec3::new(1.7, 0.5, -2.3),
            ),
        );
        b.object("box", m, mesh, None);

        // The floor takes the remaining budget.
        let m = b.material(Material::reflective(
            "mirror_floor",
            Vec3::splat(0.12),
            0.9,
            0.0,
        ));
        let remaining = t - b.tri_count() as f32;
        let half = 25.0;
        let mesh = grid_for(
            Vec3::new(-half, 0.0, half),
            Vec3::X * 2.0 * half,
            Vec3::NEG_Z * 2.0 * half,
            Vec3::Y,
            remaining.max(2.0),
        );
        let floor_plane = Plane::try_from_point_normal(Vec3::ZERO, Vec3::Y).ok();
        b.object("mirror_floor", m, mesh, floor_plane);

        // Near the torus, from grazing (0.25) to 1.1 units high; the radius
        // shrinks as the eye rises.
        let mut path = orbit_path(
            Vec3::new(0.0, 0.0, -1.2),
            3.3,
            (0.25, 2.0),
            (-0.75, 0.75),
            12,
            Vec3::new(0.2, 0.35, -1.5),
            60f32.to_radians(),
        );
        let n = path.len();
        for (k, p) in path.iter_mut().enumerate() {
            let s = k as f32 / (n - 1) as f32;
            let c = Vec3::new(0.0, p.eye.y, -1.2);
            p.eye = c + (p.eye - c) * (1.0 - 0.27 * s);
        }
        b.finish(
            vec![
                Light::Directional {
                    direction: SUN_DIRECTION,
                    color: Vec3::new(0.75, 0.72, 0.65),
                },
                Light::Point {
                    position: Vec3::new(-1.0, 2.5, 1.0),
                    color: Vec3::new(0.3, 0.3, 0.35),
                    range: 5.0,
                },
            ],
            Vec3::splat(0.15),
            path,
        )
    }

    /// Loads a Wavefront OBJ (faces triangulated as fans; one object per OBJ
    /// object/group). Materials take the MTL diffuse color when available
    /// (gray otherwise). An object whose name contains one of the substrings
    /// in `reflective` gets that entry's `(specular, roughness)`; a reflective
    /// object whose triangles all lie in one plane (within `1e-5` of the
    /// scene diameter) is flagged as a planar reflector. Shading normals come
    /// from the file or, if absent, from area-weighted face normals averaged
    /// over vertices at identical positions. The camera path orbits the
    /// scene bounds.
    ///
    /// # Errors
    /// The loader's error if the file cannot be read or parsed.
    pub fn load_obj(
        path: &Path,
        reflective: &[(&str, f32, f32)],
    ) -> Result<Scene, tobj::LoadError> {
        let (models, mtl) = tobj::load_obj(path, &tobj::GPU_LOAD_OPTIONS)?;
        let mtl = mtl.unwrap_or_default();
        let name = path
            .file_stem()
            .map_or_else(|| "obj".to_owned(), |s| s.to_string_lossy().into_owned());
        let mut b = Builder::new(&name);
        let mut bounds = Aabb::EMPTY;
        for model in &models {
            for p in model.mesh.positions.chunks_exact(3) {
                bounds.grow(Vec3::new(p[0], p[1], p[2]));
            }
        }
        let plane_tolerance = bounds.diagonal() * 1e-5;
        for model in &models {
            let m = &model.mesh;
            let pos = |i: u32| {
                let i = i as usize * 3;
                Vec3::new(m.positions[i], m.positions[i + 1], m.positions[i + 2])
            };
            let has_normals = m.normals.len() == m.positions.len();
            let file_normal = |i: u32| {
                let i = i as usize * 3;
                Vec3::new(m.normals[i], m.normals[i + 1], m.normals[i + 2]).normalize_or_zero()
            };
            // Area-weighted face normals accumulated per position.
            let mut accumulated: HashMap<[u32; 3], Vec3> = HashMap::new();
            let key = |p: Vec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            if !has_normals {
                for f in m.indices.chunks_exact(3) {
                    let (a, b, c) = (pos(f[0]), pos(f[1]), pos(f[2]));
                    let n = (b - a).cross(c - a);
                    for p in [a, b, c] {
                        *accumulated.entry(key(p)).or_insert(Vec3::ZERO) += n;
                    }
                }
            }
            let mut mesh = Mesh::default();
            for f in m.indices.chunks_exact(3) {
                let p = [pos(f[0]), pos(f[1]), pos(f[2])];
                let face = (p[1] - p[0]).cross(p[2] - p[0]);
                if face.length_squared() == 0.0 || !face.is_finite() {
                    continue;
                }
                let face = face.normalize();
                let n = [0, 1, 2].map(|k| {
                    let n = if has_normals {
                        file_normal(f[k])
                    } else {
                        accumulated[&key(p[k])].normalize_or_zero()
                    };
                    if n == Vec3::ZERO {
                        face
                    } else {
                        n
                    }
                });
                mesh.push_raw(p, n);
            }
            if mesh.tris.is_empty() {
                continue;
            }
            let (albedo, material_name) = match m.material_id.and_then(|i| mtl.get(i)) {
                Some(mat) => (
                    mat.diffuse.map_or(Vec3::splat(0.7), Vec3::from),
                    mat.name.as_str(),
                ),
                None => (Vec3::splat(0.7), model.name.as_str()),
            };
            let (specular, roughness) = reflective
                .iter()
                .find(|(s, _, _)| model.name.contains(s))
                .map_or((0.0, 1.0), |&(_, s, r)| (s, r));
            let material = b.material(Material::reflective(
                material_name,
                albedo,
                specular,
                roughness,
            ));
            let planar = if specular > 0.0 {
                mesh.common_plane(plane_tolerance)
            } else {
                None
            };
            b.object(&model.name, material, mesh, planar);
        }
        let bounds = b.bounds();
        let radius = bounds.diagonal() * 0.5;
        let c = bounds.center();
        let path = orbit_path(
            c,
            radius * 1.4,
            (c.y + radius * 0.5, c.y + radius * 0.3),
            (-0.5, 0.5),
            12,
            c,
            55f32.to_radians(),
        );
        Ok(b.finish(
            vec![Light::Directional {
                direction: SUN_DIRECTION,
                color: Vec3::splat(0.8),
            }],
            Vec3::splat(0.2),
            path,
        ))
    }
}

/// Incremental scene construction: objects are appended with contiguous
/// primitive ranges.
struct Builder {
    scene: Scene,
}

impl Builder {
    fn new(name: &str) -> Self {
        Self {
            scene: Scene {
                name: name.to_owned(),
                tris: Vec::new(),
                normals: Vec::new(),
                tri_object: Vec::new(),
                objects: Vec::new(),
                materials: Vec::new(),
                lights: Vec::new(),
                ambient: Vec3::ZERO,
                camera_path: Vec::new(),
                near: 0.05,
                far: 1.0,
            },
        }
    }

    fn tri_count(&self) -> usize {
        self.scene.tris.len()
    }

    fn bounds(&self) -> Aabb {
        self.scene.bounds()
    }

    fn material(&mut self, m: Material) -> u32 {
        self.scene.materials.push(m);
        (self.scene.materials.len() - 1) as u32
    }

    fn object(&mut self, name: &str, material: u32, mesh: Mesh, planar: Option<Plane>) {
        let id = self.scene.objects.len() as u32;
        let start = self.scene.tris.len() as u32;
        let mut bounds = Aabb::EMPTY;
        mesh.tris.iter().flatten().for_each(|&p| bounds.grow(p));
        self.scene
            .tri_object
            .extend(std::iter::repeat_n(id, mesh.tris.len()));
        self.scene.tris.extend(mesh.tris);
        self.scene.normals.extend(mesh.normals);
        self.scene.objects.push(Object {
            name: name.to_owned(),
            material,
            planar,
            tris: start..self.scene.tris.len() as u32,
            bounds,
        });
    }

    fn finish(mut self, lights: Vec<Light>, ambient: Vec3, camera_path: Vec<CameraPose>) -> Scene {
        let s = &mut self.scene;
        s.lights = lights;
        s.ambient = ambient;
        s.camera_path = camera_path;
        let mut reach = s.bounds();
        s.camera_path.iter().for_each(|p| reach.grow(p.eye));
        s.far = (reach.diagonal() * 2.0).max(s.near * 2.0);
        self.scene
    }
}

/// Triangles with per-vertex shading normals, before they become an object.
#[derive(Default)]
struct Mesh {
    tris: Vec<[Vec3; 3]>,
    normals: Vec<[Vec3; 3]>,
}

impl Mesh {
    /// Adds a triangle, ordering its vertices so that the geometric normal
    /// `(b - a) x (c - a)` points to the side of the shading normals.
    fn push(&mut self, mut p: [Vec3; 3], mut n: [Vec3; 3]) {
        let geometric = (p[1] - p[0]).cross(p[2] - p[0]);
        if geometric.dot(n[0] + n[1] + n[2]) < 0.0 {
            p.swap(1, 2);
            n.swap(1, 2);
        }
        self.push_raw(p, n);
    }

    /// Adds a triangle as given.
    fn push_raw(&mut self, p: [Vec3; 3], n: [Vec3; 3]) {
        self.tris.push(p);
        self.normals.push(n);
    }

    /// Adds the quad `p` (corners in order around its boundary) as two
    /// triangles, skipping a triangle with coincident corners (a quad
    /// touching a pole of a surface of revolution).
    fn quad(&mut self, p: [Vec3; 4], n: [Vec3; 4]) {
        if p[0] != p[1] && p[1] != p[2] && p[0] != p[2] {
            self.push([p[0], p[1], p[2]], [n[0], n[1], n[2]]);
        }
        if p[0] != p[2] && p[2] != p[3] && p[0] != p[3] {
            self.push([p[0], p[2], p[3]], [n[0], n[2], n[3]]);
        }
    }

    fn append(&mut self, other: Mesh) {
        self.tris.extend(other.tris);
        self.normals.extend(other.normals);
    }

    /// The mesh moved by `t` (rotation, translation, uniform scale).
    fn transformed(mut self, t: Affine3A) -> Mesh {
        let normal_matrix = t.matrix3.inverse().transpose();
        for (p, n) in self.tris.iter_mut().zip(&mut self.normals) {
            *p = p.map(|v| t.transform_point3(v));
            *n = n.map(|v| (normal_matrix * v).normalize());
        }
        self
    }

    /// The plane containing every vertex within `tol`, if there is one.
    fn common_plane(&self, tol: f32) -> Option<Plane> {
        let [a, b, c] = *self
            .tris
            .iter()
            .max_by(|x, y| area2(x).total_cmp(&area2(y)))?;
        let plane = Plane::try_from_triangle(a, b, c).ok()?;
        self.tris
            .iter()
            .flatten()
            .all(|&p| plane.signed_distance(p).abs() <= tol)
            .then_some(plane)
    }
}

fn area2(t: &[Vec3; 3]) -> f32 {
    (t[1] - t[0]).cross(t[2] - t[0]).length_squared()
}

/// A planar grid of `nu x nv` quads spanning `corner + s u + t v`,
/// `s, t in [0, 1]`, with constant shading normal `normal`. Vertex positions
/// come from one formula per grid index, so shared vertices are bit-identical
/// and a grid in an axis plane stays exactly in it.
fn grid(corner: Vec3, u: Vec3, v: Vec3, normal: Vec3, nu: u32, nv: u32) -> Mesh {
    let at = |i: u32, j: u32| corner + u * (i as f32 / nu as f32) + v * (j as f32 / nv as f32);
    let mut m = Mesh::default();
    for j in 0..nv {
        for i in 0..nu {
            m.quad(
                [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)],
                [normal; 4],
            );
        }
    }
    m
}

/// A grid of about `target` triangles with roughly square cells.
fn grid_for(corner: Vec3, u: Vec3, v: Vec3, normal: Vec3, target: f32) -> Mesh {
    let aspect = u.length() / v.length();
    let quads = (target * 0.5).max(1.0);
    let nu = (quads * aspect).sqrt().round().max(1.0);
    let nv = (quads / nu).round().max(1.0);
    grid(corner, u, v, normal, nu as u32, nv as u32)
}

/// An axis-aligned box centered at the origin with half extents `half` and
/// about `target` triangles (at least 12), cells roughly square.
fn cuboid(half: Vec3, target: f32) -> Mesh {
    let size = half * 2.0;
    let area = 2.0 * (size.x * size.y + size.y * size.z + size.z * size.x);
    let cell = (2.0 * area / target.max(12.0)).sqrt();
    let n = |len: f32| (len / cell).round().max(1.0) as u32;
    let mut m = Mesh::default();
    // (normal axis, u axis, v axis) with u x v = normal.
    for (axis, ua, va) in [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::Z, Vec3::X, Vec3::Y),
    ] {
        for sign in [1.0f32, -1.0] {
            let normal = axis * sign;
            let (u, v) = (ua * size, va * size);
            let (u, v) = if sign > 0.0 { (u, v) } else { (v, u) };
            let corner = normal * half - (u + v) * 0.5;
            m.append(grid(corner, u, v, normal, n(u.length()), n(v.length())));
        }
    }
    m
}

/// A point of a surface-of-revolution profile: radius `r` from the Y axis,
/// height `y` and the shading normal's `(radial, y)` components.
#[derive(Clone, Copy)]
struct ProfilePoint {
    r: f32,
    y: f32,
    n: Vec2,
}

/// A surface of revolution about the Y axis: each strip (a polyline of
/// profile points with its own normals, so strips meet at creases) is swept
/// over angles `phi.0..phi.1` in `segments` steps (`x = r cos phi`,
/// `z = r sin phi`). A full turn reuses the first column of vertices, so the
/// seam is watertight. Profile points on the axis produce triangles.
fn lathe(strips: &[Vec<ProfilePoint>], segments: u32, phi: (f32, f32)) -> Mesh {
    let closed = (phi.1 - phi.0 - TAU).abs() < 1e-6;
    let angle = |j: u32| {
        let j = if closed { j % segments } else { j };
        phi.0 + (phi.1 - phi.0) * j as f32 / segments as f32
    };
    let mut m = Mesh::default();
    for strip in strips {
        for pair in strip.windows(2) {
            for j in 0..segments {
                let (a0, a1) = (angle(j), angle(j + 1));
                let vert = |q: ProfilePoint, a: f32| {
                    let (s, c) = a.sin_cos();
                    let p = Vec3::new(q.r * c, q.y, q.r * s);
                    let n = Vec3::new(q.n.x * c, q.n.y, q.n.x * s).normalize();
                    (p, n)
                };
                let (p0, n0) = vert(pair[0], a0);
                let (p1, n1) = vert(pair[0], a1);
                let (p2, n2) = vert(pair[1], a1);
                let (p3, n3) = vert(pair[1], a0);
                m.quad([p0, p1, p2, p3], [n0, n1, n2, n3]);
            }
        }
    }
    m
}

/// Points on a circular arc of the profile plane: center `(cr, cy)`, radius
/// `r`, angles `t0..t1` (0 = +radial, pi/2 = +y) in `steps` steps, normals
/// pointing outward (`inward = false`) or toward the center.
fn arc(cr: f32, cy: f32, r: f32, t0: f32, t1: f32, steps: u32, inward: bool) -> Vec<ProfilePoint> {
    (0..=steps)
        .map(|k| {
            let a = t0 + (t1 - t0) * k as f32 / steps as f32;
            let (s, c) = a.sin_cos();
            let n = if inward {
                -Vec2::new(c, s)
            } else {
                Vec2::new(c, s)
            };
            // Snap to the axis so that poles produce triangles.
            let radial = cr + r * c;
            let radial = if radial.abs() < r * 1e-6 { 0.0 } else { radial };
            ProfilePoint {
                r: radial,
                y: cy + r * s,
                n,
            }
        })
        .collect()
}

/// A straight profile segment from `(r0, y0)` to `(r1, y1)` in `steps` steps
/// with constant normal `n`.
fn segment(r0: f32, y0: f32, r1: f32, y1: f32, steps: u32, n: Vec2) -> Vec<ProfilePoint> {
    (0..=steps)
        .map(|k| {
            let s = k as f32 / steps as f32;
            ProfilePoint {
                r: r0 + (r1 - r0) * s,
                y: y0 + (y1 - y0) * s,
                n,
            }
        })
        .collect()
}

/// A UV sphere of `radius` at the origin with about `target` triangles
/// (`4 k (k - 1)` for `k` rings and `2 k` segments, `k >= 3`).
fn sphere(radius: f32, target: f32) -> Mesh {
    let k = ((1.0 + (1.0 + target.max(24.0)).sqrt()) * 0.5)
        .round()
        .max(3.0) as u32;
    let profile = arc(0.0, 0.0, radius, -FRAC_PI_2, FRAC_PI_2, k, false);
    lathe(&[profile], 2 * k, (0.0, TAU))
}

/// The inside of the lower hemisphere of `radius` centered at the origin,
/// normals toward the center, about `target` triangles.
fn bowl(radius: f32, target: f32) -> Mesh {
    let k = ((1.0 + (1.0 + 4.0 * target.max(12.0)).sqrt()) * 0.25)
        .round()
        .max(2.0) as u32;
    let profile = arc(0.0, 0.0, radius, -FRAC_PI_2, 0.0, k, true);
    lathe(&[profile], 2 * k, (0.0, TAU))
}

/// A torus about the Y axis with about `target` triangles.
fn torus(major: f32, minor: f32, target: f32) -> Mesh {
    let target = target.max(18.0);
    let segments = (target * 0.5 * major / minor).sqrt().round().max(3.0);
    let rings = (target * 0.5 / segments).round().max(3.0) as u32;
    // Close the profile circle with bit-identical end points.
    let mut profile = arc(major, 0.0, minor, 0.0, TAU, rings, false);
    profile[rings as usize] = profile[0];
    lathe(&[profile], segments as u32, (0.0, TAU))
}

/// A capped cylinder about the Y axis from `y = 0` to `height` with about
/// `target` triangles (`2 s (k + 1)` for `s` segments and `k` rings).
fn cylinder(radius: f32, height: f32, target: f32) -> Mesh {
    let target = target.max(24.0);
    // Square side cells: k ~ s h / (2 pi r), so T ~ s^2 h / (pi r) + 2 s.
    let a = height / (PI * radius);
    let s = ((-2.0 + (4.0 + 4.0 * a * target).sqrt()) / (2.0 * a))
        .round()
        .max(3.0);
    let k = (target / (2.0 * s) - 1.0).round().max(1.0) as u32;
    let strips = [
        segment(radius, 0.0, radius, height, k, Vec2::X),
        segment(radius, height, 0.0, height, 1, Vec2::Y),
        segment(radius, 0.0, 0.0, 0.0, 1, Vec2::NEG_Y),
    ];
    lathe(&strips, s as u32, (0.0, TAU))
}

/// An open concave cylindrical wall of `radius` about the Y axis, from
/// `y = 0` to `height`, over angles `phi`, normals toward the axis, about
/// `target` triangles.
fn cylinder_wall(radius: f32, height: f32, phi: (f32, f32), target: f32) -> Mesh {
    let quads = (target * 0.5).max(1.0);
    let aspect = radius * (phi.1 - phi.0) / height;
    let s = (quads * aspect).sqrt().round().max(1.0);
    let k = (quads / s).round().max(1.0) as u32;
    let strip = segment(radius, 0.0, radius, height, k, Vec2::NEG_X);
    lathe(&[strip], s as u32, phi)
}

/// A cup standing at the origin: outer wall of `radius` and `height`, wall
/// and bottom `thickness`, inner wall, rim and both bottoms, about `target`
/// triangles (`s (4 k + 4)` for `s` segments and `k` rings per wall).
fn cup(radius: f32, height: f32, thickness: f32, target: f32) -> Mesh {
    let target = target.max(40.0);
    let s = (target * PI * radius / (2.0 * height))
        .sqrt()
        .round()
        .max(3.0);
    let k = ((target / s - 4.0) / 4.0).round().max(1.0) as u32;
    let inner = radius - thickness;
    let strips = [
        segment(radius, 0.0, radius, height, k, Vec2::X),
        segment(radius, height, inner, height, 1, Vec2::Y),
        segment(inner, height, inner, thickness, k, Vec2::NEG_X),
        segment(inner, thickness, 0.0, thickness, 1, Vec2::Y),
        segment(radius, 0.0, 0.0, 0.0, 1, Vec2::NEG_Y),
    ];
    lathe(&strips, s as u32, (0.0, TAU))
}

/// `n` poses on a horizontal arc around `center` (angle 0 on +Z), the eye
/// height moving from `height.0` to `height.1`, all looking at `target`.
fn orbit_path(
    center: Vec3,
    radius: f32,
    height: (f32, f32),
    angles: (f32, f32),
    n: usize,
    target: Vec3,
    fov_y: f32,
) -> Vec<CameraPose> {
    (0..n)
        .map(|k| {
            let s = k as f32 / (n - 1) as f32;
            let a = angles.0 + (angles.1 - angles.0) * s;
            let eye = center
                + Vec3::new(
                    radius * a.sin(),
                    height.0 + (height.1 - height.0) * s,
                    radius * a.cos(),
                );
            CameraPose {
                eye,
                target,
                up: Vec3::Y,
                fov_y,
            }
        })
        .collect()
}

/// Uniform Catmull-Rom spline through `points` at parameter `s in [0, 1]`
/// (clamped), end points duplicated.
fn catmull_rom(points: &[Vec3], s: f32) -> Vec3 {
    let n = points.len();
    let x = s.clamp(0.0, 1.0) * (n - 1) as f32;
    let i = (x.floor() as usize).min(n - 2);
    let t = x - i as f32;
    let p = |k: isize| points[(i as isize + k).clamp(0, n as isize - 1) as usize];
    let (p0, p1, p2, p3) = (p(-1), p(0), p(1), p(2));
    let t2 = t * t;
    let t3 = t2 * t;
    0.5 * ((2.0 * p1)
        + (p2 - p0) * t
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t3)
}
