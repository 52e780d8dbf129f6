//! Wavefront OBJ loading, [`Scene::load_obj`], and its error, [`ObjError`].
//!
//! tobj parses the file; the loader then refuses what would break a renderer
//! far downstream (a vertex with a NaN or infinite coordinate, a file without
//! a usable triangle, a scene collapsed to one point or too large for `f32`)
//! with an error naming the file, the object, the vertex or face and the
//! problem. Degenerate triangles are dropped and counted in
//! [`Scene::skipped_degenerate_triangles`] and [`Scene::load_notes`].

use super::mesh::{Builder, Mesh};
use super::path::orbit_path;
use super::{Aabb, Light, Material, Scene};
use crate::shade::SUN_DIRECTION;
use glam::Vec3;
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// Why [`Scene::load_obj`] refused a file. Every message starts with the
/// file's path; objects are named as tobj names them (from the `o` or `g`
/// line; `unnamed_object` before any such line).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ObjError {
    /// tobj could not open, read or parse the file (a face index out of
    /// range that could not be located in the file also ends here).
    Load {
        /// The OBJ file.
        path: PathBuf,
        /// tobj's error.
        error: tobj::LoadError,
    },
    /// A face refers to a vertex that is not defined (index 0, past the last
    /// vertex, or a relative index before the first).
    FaceIndexOutOfRange {
        /// The OBJ file.
        path: PathBuf,
        /// The object the face belongs to.
        object: String,
        /// The face's number, counting the file's `f` lines from 1.
        face: usize,
        /// The line of the face, from 1.
        line: usize,
        /// The vertex index as written (1-based, or negative for relative).
        index: i64,
        /// How many vertices the face could refer to.
        vertices: usize,
    },
    /// A vertex used by a face has a NaN or infinite coordinate (after the
    /// optional `w` division).
    NonFiniteVertex {
        /// The OBJ file.
        path: PathBuf,
        /// The object whose face uses the vertex.
        object: String,
        /// The vertex's number as faces refer to it (counting the file's `v`
        /// lines from 1) and its line: the first `v` line with exactly this
        /// position. `None` if the file could not be read again.
        vertex: Option<(usize, usize)>,
        /// The axis of the first non-finite coordinate: `'x'`, `'y'` or `'z'`.
        axis: char,
        /// That coordinate.
        value: f32,
    },
    /// The file has no faces (points and lines are ignored).
    NoFaces {
        /// The OBJ file.
        path: PathBuf,
    },
    /// Every vertex used by a face is the same point: the scene has no extent.
    SinglePoint {
        /// The OBJ file.
        path: PathBuf,
        /// The point.
        point: Vec3,
        /// How many face corners there are (all at `point`).
        corners: usize,
    },
    /// Every triangle has zero area (repeated or collinear vertices).
    AllTrianglesDegenerate {
        /// The OBJ file.
        path: PathBuf,
        /// How many triangles there are (after fan triangulation).
        triangles: usize,
    },
    /// The scene's bounds give no valid camera path: the extent overflows
    /// `f32`, or is too small to place an eye apart from the target.
    Extent {
        /// The OBJ file.
        path: PathBuf,
        /// The bounds of the loaded triangles.
        bounds: Aabb,
        /// Why the camera failed.
        error: refl_core::Error,
    },
}

impl fmt::Display for ObjError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ObjError::Load { path, error } => write!(f, "{}: {error}", path.display()),
            ObjError::FaceIndexOutOfRange {
                path,
                object,
                face,
                line,
                index,
                vertices,
            } => write!(
                f,
                "{}: line {line}: face {face} of object {object:?} refers to vertex \
                 index {index}, out of range ({vertices} vertices defined)",
                path.display(),
            ),
            ObjError::NonFiniteVertex {
                path,
                object,
                vertex,
                axis,
                value,
            } => {
                write!(f, "{}: ", path.display())?;
                match vertex {
                    Some((vertex, line)) => write!(f, "line {line}: vertex {vertex}")?,
                    None => f.write_str("a vertex")?,
                }
                write!(
                    f,
                    " (used by object {object:?}) has a non-finite coordinate: {axis} = {value}"
                )
            }
            ObjError::NoFaces { path } => write!(
                f,
                "{}: no triangles: the file has no faces (points and lines are ignored)",
                path.display()
            ),
            ObjError::SinglePoint {
                path,
                point,
                corners,
            } => write!(
                f,
                "{}: degenerate bounds: all {corners} face corners are the single point {}",
                path.display(),
                Coords(*point)
            ),
            ObjError::AllTrianglesDegenerate { path, triangles } => write!(
                f,
                "{}: no triangles: all {triangles} triangle(s) are degenerate (zero area: \
                 repeated or collinear vertices)",
                path.display()
            ),
            ObjError::Extent {
                path,
                bounds,
                error,
            } => {
                // The eyes lie within about 2 diagonals of the bounds, and
                // the far plane is twice the diagonal of bounds and eyes.
                let extent = if (bounds.diagonal() * 8.0).is_finite() {
                    "is too small for f32 to place an eye apart from the target"
                } else {
                    "overflows f32"
                };
                write!(
                    f,
                    "{}: bounds {} to {} give no valid camera path ({error}): the extent {extent}",
                    path.display(),
                    Coords(bounds.min),
                    Coords(bounds.max)
                )
            }
        }
    }
}

/// A point as `(x, y, z)`, each coordinate in Rust's shortest round-trip
/// notation (`3e38`, not 39 digits).
struct Coords(Vec3);

impl fmt::Display for Coords {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "({:?}, {:?}, {:?})", self.0.x, self.0.y, self.0.z)
    }
}

impl std::error::Error for ObjError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ObjError::Load { error, .. } => Some(error),
            ObjError::Extent { error, .. } => Some(error),
            _ => None,
        }
    }
}

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
    /// Triangles of zero area (repeated or collinear vertices) are dropped,
    /// counted in [`Scene::skipped_degenerate_triangles`] and described per
    /// object in [`Scene::load_notes`]; an object left without triangles is
    /// dropped. An MTL file that fails to load is a note too (the objects
    /// are gray). Vertices no face uses are not checked.
    ///
    /// # Errors
    /// An [`ObjError`] naming the file and the problem:
    /// - [`ObjError::Load`] if tobj cannot open, read or parse the file;
    /// - [`ObjError::FaceIndexOutOfRange`] for a face referring to a
    ///   vertex that is not defined;
    /// - [`ObjError::NonFiniteVertex`] for a vertex with a NaN or infinite
    ///   coordinate used by a face;
    /// - [`ObjError::NoFaces`] if the file has no faces (an empty file);
    /// - [`ObjError::SinglePoint`] if every face corner is the same point;
    /// - [`ObjError::AllTrianglesDegenerate`] if no triangle has an area;
    /// - [`ObjError::Extent`] if the bounds give no valid camera (an extent
    ///   beyond `f32`, or too small to move the eye off the target).
    pub fn load_obj(path: &Path, reflective: &[(&str, f32, f32)]) -> Result<Scene, ObjError> {
        let (models, mtl) = tobj::load_obj(path, &tobj::GPU_LOAD_OPTIONS)
            .map_err(|error| locate_load_error(path, error))?;
        let mut notes = Vec::new();
        let mtl = mtl.unwrap_or_else(|e| {
            notes.push(format!("materials: {e}; the objects are gray"));
            Vec::new()
        });

        // Every position tobj returns is a face corner (single index).
        let mut corners = 0;
        let mut bounds = Aabb::EMPTY;
        for model in &models {
            let m = &model.mesh;
            for p in m.positions.chunks_exact(3) {
                let v = Vec3::new(p[0], p[1], p[2]);
                if !v.is_finite() {
                    return Err(non_finite(path, &model.name, v));
                }
                bounds.grow(v);
            }
            // tobj checks the indices; this keeps a violation an error.
            if m.indices
                .iter()
                .any(|&i| i as usize * 3 + 2 >= m.positions.len())
            {
                return Err(locate_load_error(
                    path,
                    tobj::LoadError::FaceVertexOutOfBounds,
                ));
            }
            corners += m.indices.len();
        }
        if corners == 0 {
            return Err(ObjError::NoFaces {
                path: path.to_owned(),
            });
        }
        if bounds.min == bounds.max {
            return Err(ObjError::SinglePoint {
                path: path.to_owned(),
                point: bounds.min,
                corners,
            });
        }

        let name = path
            .file_stem()
            .map_or_else(|| "obj".to_owned(), |s| s.to_string_lossy().into_owned());
        let mut b = Builder::new(&name);
        let plane_tolerance = bounds.diagonal() * 1e-5;
        let mut skipped: Vec<(&str, usize)> = Vec::new();
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
            let mut degenerate = 0;
            for f in m.indices.chunks_exact(3) {
                let p = [pos(f[0]), pos(f[1]), pos(f[2])];
                let Some(face) = face_normal(&p) else {
                    degenerate += 1;
                    continue;
                };
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
            if degenerate > 0 {
                // tobj splits an object at each change of material.
                match skipped.iter_mut().find(|(name, _)| *name == model.name) {
                    Some((_, n)) => *n += degenerate,
                    None => skipped.push((&model.name, degenerate)),
                }
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
        let total_skipped: usize = skipped.iter().map(|&(_, n)| n).sum();
        if b.tri_count() == 0 {
            return Err(ObjError::AllTrianglesDegenerate {
                path: path.to_owned(),
                triangles: total_skipped,
            });
        }
        if total_skipped > 0 {
            let per_object: Vec<String> = skipped
                .iter()
                .map(|&(object, n)| format!("{n} in object {object:?}"))
                .collect();
            notes.insert(
                0,
                format!(
                    "skipped {total_skipped} degenerate triangle(s) (zero area: repeated or \
                     collinear vertices): {}",
                    per_object.join(", ")
                ),
            );
        }

        let bounds = b.bounds();
        let radius = bounds.diagonal() * 0.5;
        let c = bounds.center();
        let path_poses = orbit_path(
            c,
            radius * 1.4,
            // Heights above the center (orbit_path adds the center).
            (radius * 0.5, radius * 0.3),
            (-0.5, 0.5),
            12,
            c,
            55f32.to_radians(),
        );
        let mut scene = b.finish(
            vec![Light::Directional {
                direction: SUN_DIRECTION,
                color: Vec3::splat(0.8),
            }],
            Vec3::splat(0.2),
            path_poses,
        );
        scene.skipped_degenerate_triangles = total_skipped;
        scene.load_notes = notes;
        // The size does not matter here: a pose's camera fails on the
        // scene's geometry (eye on the target, non-finite eye or far plane).
        for pose in 0..scene.camera_path.len() {
            if let Err(error) = scene.camera(pose, 64, 64) {
                return Err(ObjError::Extent {
                    path: path.to_owned(),
                    bounds,
                    error,
                });
            }
        }
        Ok(scene)
    }
}

/// The unit normal of triangle `p`, `None` for zero area. Computed in `f64`
/// where the `f32` cross product overflows (coordinates beyond ~1e19).
fn face_normal(p: &[Vec3; 3]) -> Option<Vec3> {
    let face = (p[1] - p[0]).cross(p[2] - p[0]);
    let len2 = face.length_squared();
    if len2.is_finite() {
        return (len2 != 0.0).then(|| face.normalize());
    }
    let [a, b, c] = p.map(Vec3::as_dvec3);
    let wide = (b - a).cross(c - a);
    (wide.length_squared() != 0.0).then(|| wide.normalize().as_vec3())
}

/// The non-blank lines of an OBJ file as tobj splits them, each with its
/// line number (from 1) and first word, tracking the object they are in.
struct ObjLines<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    /// The current object's name, as tobj names it.
    object: String,
}

impl<'a> ObjLines<'a> {
    fn new(text: &'a str) -> Self {
        Self {
            lines: text.lines().enumerate(),
            object: "unnamed_object".to_owned(),
        }
    }
}

impl<'a> Iterator for ObjLines<'a> {
    /// `(line number, keyword, the words after it)`; the object the line
    /// is in is [`ObjLines::object`] after the call.
    type Item = (usize, &'a str, std::str::SplitWhitespace<'a>);

    fn next(&mut self) -> Option<Self::Item> {
        for (k, line) in self.lines.by_ref() {
            let mut words = line.split_whitespace();
            let Some(keyword) = words.next() else {
                continue;
            };
            if keyword == "o" || keyword == "g" {
                // tobj's rule: the line less its first character, trimmed.
                let size = line.chars().next().map_or(0, char::len_utf8);
                self.object = line[size..].trim().to_owned();
                if self.object.is_empty() {
                    "unnamed_object".clone_into(&mut self.object);
                }
            }
            return Some((k + 1, keyword, words));
        }
        None
    }
}

/// A `v` line's position as tobj computes it (three coordinates, divided by
/// an optional fourth `w`); `None` where tobj would not parse it.
fn vertex_position(mut words: std::str::SplitWhitespace<'_>) -> Option<Vec3> {
    let mut p = [0.0f32; 3];
    for c in &mut p {
        *c = words.next()?.parse().ok()?;
    }
    if let (Some(w), None) = (words.next(), words.next()) {
        let w: f32 = w.parse().ok()?;
        p.iter_mut().for_each(|c| *c /= w);
    }
    Some(Vec3::from(p))
}

/// The error for a non-finite face corner `v` of object `object`, located
/// in the file: the first `v` line with exactly `v`'s bits.
fn non_finite(path: &Path, object: &str, v: Vec3) -> ObjError {
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    let vertex = std::fs::read_to_string(path).ok().and_then(|text| {
        ObjLines::new(&text)
            .filter(|&(_, keyword, _)| keyword == "v")
            .enumerate()
            .find(|(_, (_, _, words))| {
                vertex_position(words.clone()).is_some_and(|p| bits(p) == bits(v))
            })
            .map(|(k, (line, _, _))| (k + 1, line))
    });
    let (axis, value) = ['x', 'y', 'z']
        .into_iter()
        .zip(v.to_array())
        .find(|(_, c)| !c.is_finite())
        .unwrap_or(('x', v.x));
    ObjError::NonFiniteVertex {
        path: path.to_owned(),
        object: object.to_owned(),
        vertex,
        axis,
        value,
    }
}

/// tobj's `error`, made a [`ObjError::FaceIndexOutOfRange`] where it is an
/// out-of-range face vertex and the face can be found in the file: the first
/// face with a vertex index outside the vertices defined before the next `o`
/// or `g` line (or the end of the file), which tobj refuses as well.
fn locate_load_error(path: &Path, error: tobj::LoadError) -> ObjError {
    let load = || ObjError::Load {
        path: path.to_owned(),
        error,
    };
    if error != tobj::LoadError::FaceVertexOutOfBounds {
        return load();
    }
    let Ok(text) = std::fs::read_to_string(path) else {
        return load();
    };
    // Pending faces of the current object: (line, face number, object,
    // index as written, index resolved against the vertices so far).
    let mut pending: Vec<(usize, usize, String, i64, i64)> = Vec::new();
    let (mut vertices, mut faces) = (0i64, 0);
    let mut lines = ObjLines::new(&text);
    let check = |pending: &[(usize, usize, String, i64, i64)], vertices: i64| {
        pending
            .iter()
            .find(|&&(.., resolved)| resolved < 0 || resolved >= vertices)
            .map(
                |(line, face, object, index, _)| ObjError::FaceIndexOutOfRange {
                    path: path.to_owned(),
                    object: object.clone(),
                    face: *face,
                    line: *line,
                    index: *index,
                    vertices: vertices as usize,
                },
            )
    };
    while let Some((line, keyword, words)) = lines.next() {
        match keyword {
            "v" => vertices += 1,
            "o" | "g" => {
                if let Some(e) = check(&pending, vertices) {
                    return e;
                }
                pending.clear();
            }
            "f" => {
                faces += 1;
                for word in words {
                    let Some(Ok(index)) = word.split('/').next().map(str::parse::<i64>) else {
                        continue;
                    };
                    let resolved = if index < 0 {
                        vertices + index
                    } else {
                        index - 1
                    };
                    pending.push((line, faces, lines.object.clone(), index, resolved));
                }
            }
            _ => {}
        }
    }
    check(&pending, vertices).unwrap_or_else(load)
}
