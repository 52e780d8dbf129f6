//! The built-in hall of mirrors, [`Scene::hall`].

use super::mesh::{cuboid, cylinder, grid_for, sphere, Builder};
use super::{CameraPose, Light, Material, Scene};
use crate::shade::SUN_DIRECTION;
use glam::{Affine3A, Quat, Vec3};
use refl_core::Plane;

/// Half the distance between the hall's two mirror planes (`x = -HALL_HALF`
/// and `x = +HALL_HALF`).
pub const HALL_HALF: f32 = 2.0;

impl Scene {
    /// A hall of mirrors of about `tris` triangles: two parallel planar
    /// perfect mirrors facing each other (the planes `x = -2` and `x = 2`,
    /// 12 units long and 2.6 high, dark albedo 0.1, specular level 0.9),
    /// a checkered diffuse floor between them, a checkered end wall, and
    /// three diffuse objects standing on the floor (a red box, a green
    /// sphere, a blue cylinder); no ceiling, so the sky shows above the
    /// mirrors. The scene of seed 004 Sec. 4.6.4's multiple bounces (Fig.
    /// 4.24: "infinite reflections when two mirrors are parallel against
    /// each other"): every mirror pixel whose reflection meets the other
    /// mirror shows a second bounce.
    ///
    /// 12 camera poses dolly slowly down the hall, the eye half a unit
    /// from the left mirror, looking down the hall and at the right mirror
    /// at an angle (about 7 degrees off the hall's axis), so that both
    /// mirrors are on screen: a reflection pass that reads the previous
    /// frame's image finds the source of a second bounce (the other
    /// mirror, as the eye saw it) there.
    pub fn hall(tris: usize) -> Scene {
        let t = tris as f32;
        let mut b = Builder::new("hall");
        let half = HALL_HALF;
        let (z0, z1) = (3.0f32, -9.0f32);
        let (length, mirror_h) = (z0 - z1, 2.6);

        let m = b.material(Material::checkered(
            "end_wall",
            Vec3::new(0.85, 0.8, 0.7),
            Vec3::new(0.55, 0.2, 0.15),
            0.5,
        ));
        let mesh = grid_for(
            Vec3::new(-half, 0.0, z1),
            Vec3::X * 2.0 * half,
            Vec3::Y * mirror_h,
            Vec3::Z,
            t * 0.02,
        );
        b.object("end_wall", m, mesh, None);

        let m = b.material(Material::diffuse("red_box", Vec3::new(0.8, 0.2, 0.15)));
        let mesh = cuboid(Vec3::new(0.4, 0.45, 0.4), t * 0.03).transformed(
            Affine3A::from_rotation_translation(
                Quat::from_rotation_y(0.4),
                Vec3::new(0.5, 0.45, -2.5),
            ),
        );
        b.object("red_box", m, mesh, None);

        let m = b.material(Material::diffuse(
            "green_sphere",
            Vec3::new(0.25, 0.75, 0.3),
        ));
        let mesh = sphere(0.5, t * 0.06)
            .transformed(Affine3A::from_translation(Vec3::new(-0.7, 0.5, -4.5)));
        b.object("green_sphere", m, mesh, None);

        let m = b.material(Material::diffuse(
            "blue_cylinder",
            Vec3::new(0.2, 0.35, 0.85),
        ));
        let mesh = cylinder(0.35, 1.4, t * 0.05)
            .transformed(Affine3A::from_translation(Vec3::new(0.8, 0.0, -6.5)));
        b.object("blue_cylinder", m, mesh, None);

        // The two mirrors, facing each other.
        let m = b.material(Material::reflective("mirror", Vec3::splat(0.1), 0.9, 0.0));
        for (name, x, normal) in [
            ("mirror_left", -half, Vec3::X),
            ("mirror_right", half, Vec3::NEG_X),
        ] {
            let mesh = grid_for(
                Vec3::new(x, 0.0, z0),
                Vec3::NEG_Z * length,
                Vec3::Y * mirror_h,
                normal,
                t * 0.1,
            );
            let plane = Plane::try_from_point_normal(Vec3::new(x, 0.0, 0.0), normal).ok();
            b.object(name, m, mesh, plane);
        }

        // The floor takes the remaining budget.
        let m = b.material(Material::checkered(
            "floor",
            Vec3::new(0.8, 0.8, 0.75),
            Vec3::new(0.25, 0.3, 0.45),
            0.5,
        ));
        let remaining = t - b.tri_count() as f32;
        let mesh = grid_for(
            Vec3::new(-half, 0.0, z0),
            Vec3::X * 2.0 * half,
            Vec3::NEG_Z * length,
            Vec3::Y,
            remaining.max(2.0),
        );
        b.object("floor", m, mesh, None);

        // A slow dolly down the hall: equal steps of 0.1 units, the eye
        // half a unit from the left mirror, looking down the hall and at
        // the right mirror at an angle.
        let path = (0..12)
            .map(|k| {
                let s = k as f32 * 0.1;
                CameraPose {
                    eye: Vec3::new(0.5 - half, 1.5, 2.5 - s),
                    target: Vec3::new(-0.5, 1.0, -6.0 - s),
                    up: Vec3::Y,
                    fov_y: 60f32.to_radians(),
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
                    position: Vec3::new(0.0, 2.4, -2.0),
                    color: Vec3::new(0.3, 0.3, 0.35),
                    range: 5.0,
                },
            ],
            Vec3::splat(0.15),
            path,
        )
    }
}
