//! The built-in stage scene, [`Scene::stage`].

use super::mesh::{cuboid, grid_for, torus, Builder};
use super::path::orbit_path;
use super::{Light, Material, Scene};
use crate::shade::SUN_DIRECTION;
use glam::{Affine3A, Quat, Vec3};
use refl_core::Plane;
use std::f32::consts::FRAC_PI_2;

impl Scene {
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
}
