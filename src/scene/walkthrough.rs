//! The built-in occluded interior, [`Scene::walkthrough`].

use super::mesh::{cuboid, cylinder, grid_for, sphere, Builder, Mesh};
use super::path::catmull_rom;
use super::{CameraPose, Light, Material, Scene};
use crate::shade::SUN_DIRECTION;
use glam::{Affine3A, Quat, Vec3};
use refl_core::lobe::pixel_hash;
use refl_core::Plane;

impl Scene {
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
                let h = pixel_hash((j * NX + i) as u32 + 17);
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
                    let hk = pixel_hash(h ^ (k + 1).wrapping_mul(0x9e37_79b9));
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
}
