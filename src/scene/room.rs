//! The built-in room scene, [`Scene::room`].

use super::mesh::{cuboid, cylinder, grid_for, sphere, torus, Builder};
use super::path::orbit_path;
use super::{Light, Material, Scene};
use crate::shade::SUN_DIRECTION;
use glam::{Affine3A, Quat, Vec3};
use refl_core::Plane;
use std::f32::consts::FRAC_PI_2;

impl Scene {
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
}
