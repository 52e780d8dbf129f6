//! Scene construction and tessellation: [`Builder`] appends objects to a
//! scene, [`Mesh`] collects triangles, and the shape functions (grids,
//! boxes, surfaces of revolution) tessellate to a triangle budget.

use super::{Aabb, CameraPose, Light, Material, Object, Scene};
use glam::{Affine3A, Vec2, Vec3};
use refl_core::Plane;
use std::f32::consts::{FRAC_PI_2, PI, TAU};

/// Incremental scene construction: objects are appended with contiguous
/// primitive ranges.
pub(super) struct Builder {
    scene: Scene,
}

impl Builder {
    pub(super) fn new(name: &str) -> Self {
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
                skipped_degenerate_triangles: 0,
                load_notes: Vec::new(),
            },
        }
    }

    pub(super) fn tri_count(&self) -> usize {
        self.scene.tris.len()
    }

    pub(super) fn bounds(&self) -> Aabb {
        self.scene.bounds()
    }

    pub(super) fn material(&mut self, m: Material) -> u32 {
        self.scene.materials.push(m);
        (self.scene.materials.len() - 1) as u32
    }

    pub(super) fn object(&mut self, name: &str, material: u32, mesh: Mesh, planar: Option<Plane>) {
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

    pub(super) fn finish(
        mut self,
        lights: Vec<Light>,
        ambient: Vec3,
        camera_path: Vec<CameraPose>,
    ) -> Scene {
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
pub(super) struct Mesh {
    pub(super) tris: Vec<[Vec3; 3]>,
    pub(super) normals: Vec<[Vec3; 3]>,
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
    pub(super) fn push_raw(&mut self, p: [Vec3; 3], n: [Vec3; 3]) {
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

    pub(super) fn append(&mut self, other: Mesh) {
        self.tris.extend(other.tris);
        self.normals.extend(other.normals);
    }

    /// The mesh moved by `t` (rotation, translation, uniform scale).
    pub(super) fn transformed(mut self, t: Affine3A) -> Mesh {
        let normal_matrix = t.matrix3.inverse().transpose();
        for (p, n) in self.tris.iter_mut().zip(&mut self.normals) {
            *p = p.map(|v| t.transform_point3(v));
            *n = n.map(|v| (normal_matrix * v).normalize());
        }
        self
    }

    /// The plane containing every vertex within `tol`, if there is one.
    pub(super) fn common_plane(&self, tol: f32) -> Option<Plane> {
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
pub(super) fn grid_for(corner: Vec3, u: Vec3, v: Vec3, normal: Vec3, target: f32) -> Mesh {
    let aspect = u.length() / v.length();
    let quads = (target * 0.5).max(1.0);
    let nu = (quads * aspect).sqrt().round().max(1.0);
    let nv = (quads / nu).round().max(1.0);
    grid(corner, u, v, normal, nu as u32, nv as u32)
}

/// An axis-aligned box centered at the origin with half extents `half` and
/// about `target` triangles (at least 12), cells roughly square.
pub(super) fn cuboid(half: Vec3, target: f32) -> Mesh {
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
pub(super) fn sphere(radius: f32, target: f32) -> Mesh {
    let k = ((1.0 + (1.0 + target.max(24.0)).sqrt()) * 0.5)
        .round()
        .max(3.0) as u32;
    let profile = arc(0.0, 0.0, radius, -FRAC_PI_2, FRAC_PI_2, k, false);
    lathe(&[profile], 2 * k, (0.0, TAU))
}

/// The inside of the lower hemisphere of `radius` centered at the origin,
/// normals toward the center, about `target` triangles.
pub(super) fn bowl(radius: f32, target: f32) -> Mesh {
    let k = ((1.0 + (1.0 + 4.0 * target.max(12.0)).sqrt()) * 0.25)
        .round()
        .max(2.0) as u32;
    let profile = arc(0.0, 0.0, radius, -FRAC_PI_2, 0.0, k, true);
    lathe(&[profile], 2 * k, (0.0, TAU))
}

/// A torus about the Y axis with about `target` triangles.
pub(super) fn torus(major: f32, minor: f32, target: f32) -> Mesh {
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
pub(super) fn cylinder(radius: f32, height: f32, target: f32) -> Mesh {
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
pub(super) fn cylinder_wall(radius: f32, height: f32, phi: (f32, f32), target: f32) -> Mesh {
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
pub(super) fn cup(radius: f32, height: f32, thickness: f32, target: f32) -> Mesh {
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
