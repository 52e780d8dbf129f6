//! The built-in scene of concave reflectors, [`Scene::concave`].

use super::mesh::{bowl, cuboid, cup, cylinder_wall, grid_for, sphere, Builder};
use super::path::orbit_path;
use super::{Light, Material, Scene};
use crate::shade::SUN_DIRECTION;
use glam::{Affine3A, Quat, Vec3};

impl Scene {
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
}
