//! Wavefront OBJ loading, [`Scene::load_obj`].

use super::mesh::{Builder, Mesh};
use super::path::orbit_path;
use super::{Aabb, Light, Material, Scene};
use crate::shade::SUN_DIRECTION;
use glam::Vec3;
use std::collections::HashMap;
use std::path::Path;

impl Scene {
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
