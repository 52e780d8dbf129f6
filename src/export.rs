//! Export of a scene, a ray set and the reference tracer's hits, so that a
//! C++ test can trace the same rays with Embree and compare.
//!
//! [`export_crosscheck`] writes four files into a directory:
//!
//! * `scene.obj`: the room scene as `v x y z` lines (three per triangle, no
//!   sharing, each f32 printed with the shortest decimal that parses back to
//!   the same f32) and `f a b c` lines, face `k` being primitive `k` with its
//!   vertices in scene order (1-based indices `3k+1 3k+2 3k+3`).
//! * `rays.bin`: little-endian binary. Header: the 8 bytes `REFLRAY1`, then
//!   `u32 count`, `u32 reflection_count`. Then `count` records of eight f32:
//!   `origin.xyz, dir.xyz, tmin, tmax` (`tmax` may be `+inf`). The first
//!   `reflection_count` rays are reflection rays, the rest primary rays.
//! * `hits.bin`: little-endian binary. Header: the 8 bytes `REFLHIT1`, then
//!   `u32 count`. Then `count` records: `u32 prim` (`0xFFFFFFFF` = miss),
//!   `f32 t` (`+inf` for a miss), `f32 u`, `f32 v`, the closest hit of the
//!   same-index ray found by [`Tracer::trace`]; `(u, v)` weight the second
//!   and third vertex, Embree's convention.
//! * `meta.txt`: `key = value` lines (scene, triangle count, image size, ray
//!   counts, epsilon, and the camera: `view` as 16 f32 column-major,
//!   `fov_y` in radians, `near`, `far`), so that a C++ test can rebuild the
//!   primary view's depth buffer.
//!
//! The rays belong to the room scene's first camera at
//! [`CROSSCHECK_WIDTH`] x [`CROSSCHECK_HEIGHT`]: one reflection ray per
//! reflective pixel (the mirror reflection of the primary ray about the
//! interpolated shading normal, as [`crate::shade::reflection_dir`], starting
//! at the primary hit with `tmin =` [`Scene::ray_epsilon`], as the reference
//! renderer traces it), then the primary rays (`tmin = 0`) of every 4th
//! pixel in x and y. Every ray is
//! computed in f64 (camera, primary hit re-intersected in f64 with the
//! primitive the tracer found, normals, reflection) and cast to f32 once, so
//! the file, not a re-derivation, defines the rays.

use crate::scene::Scene;
use crate::tracer::Tracer;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use refl_core::Camera;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// Width of the image whose rays are exported.
pub const CROSSCHECK_WIDTH: u32 = 512;
/// Height of the image whose rays are exported.
pub const CROSSCHECK_HEIGHT: u32 = 384;
/// Primary rays are exported for every `PRIMARY_STRIDE`-th pixel in x and y.
pub const PRIMARY_STRIDE: u32 = 4;

/// An exported ray (f32, as written).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExportRay {
    /// Origin.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// Minimum `t`.
    pub tmin: f32,
    /// Maximum `t`.
    pub tmax: f32,
}

/// Writes `scene.obj`, `rays.bin`, `hits.bin` and `meta.txt` for
/// `Scene::room(scene_tris)` into `dir` (created if missing). See the module
/// docs for the formats.
///
/// # Errors
/// File system errors; [`io::ErrorKind::InvalidInput`] if the scene's first
/// camera cannot be built.
pub fn export_crosscheck(dir: &Path, scene_tris: usize) -> io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let scene = Scene::room(scene_tris);
    let tracer = Tracer::new(&scene);
    let camera = scene
        .camera(0, CROSSCHECK_WIDTH, CROSSCHECK_HEIGHT)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
    let (reflection, primary) = crosscheck_rays(&scene, &tracer, &camera);
    let rays: Vec<ExportRay> = reflection.iter().chain(&primary).copied().collect();
    let hits: Vec<_> = rays
        .par_iter()
        .map(|r| tracer.trace(r.origin, r.dir, r.tmin, r.tmax))
        .collect();

    write_obj(&dir.join("scene.obj"), &scene)?;

    let mut f = BufWriter::new(File::create(dir.join("rays.bin"))?);
    f.write_all(b"REFLRAY1")?;
    f.write_all(&(rays.len() as u32).to_le_bytes())?;
    f.write_all(&(reflection.len() as u32).to_le_bytes())?;
    for r in &rays {
        for x in r.origin.to_array().into_iter().chain(r.dir.to_array()) {
            f.write_all(&x.to_le_bytes())?;
        }
        f.write_all(&r.tmin.to_le_bytes())?;
        f.write_all(&r.tmax.to_le_bytes())?;
    }
    f.flush()?;

    let mut f = BufWriter::new(File::create(dir.join("hits.bin"))?);
    f.write_all(b"REFLHIT1")?;
    f.write_all(&(hits.len() as u32).to_le_bytes())?;
    for h in &hits {
        let (prim, t, u, v) = h.map_or((u32::MAX, f32::INFINITY, 0.0, 0.0), |h| {
            (h.prim, h.t, h.u, h.v)
        });
        f.write_all(&prim.to_le_bytes())?;
        for x in [t, u, v] {
            f.write_all(&x.to_le_bytes())?;
        }
    }
    f.flush()?;

    let mut f = BufWriter::new(File::create(dir.join("meta.txt"))?);
    writeln!(f, "scene = {}", scene.name)?;
    writeln!(f, "triangles = {}", scene.tri_count())?;
    writeln!(f, "width = {CROSSCHECK_WIDTH}")?;
    writeln!(f, "height = {CROSSCHECK_HEIGHT}")?;
    writeln!(f, "rays = {}", rays.len())?;
    writeln!(f, "reflection_rays = {}", reflection.len())?;
    writeln!(f, "primary_rays = {}", primary.len())?;
    writeln!(f, "primary_stride = {PRIMARY_STRIDE}")?;
    writeln!(f, "epsilon = {}", scene.ray_epsilon())?;
    let view: Vec<String> = camera
        .view()
        .to_cols_array()
        .iter()
        .map(|x| x.to_string())
        .collect();
    writeln!(f, "view = {}", view.join(" "))?;
    writeln!(f, "fov_y = {}", camera.fov_y())?;
    writeln!(f, "near = {}", camera.near())?;
    writeln!(f, "far = {}", camera.far())?;
    f.flush()
}

/// Writes the scene's triangles as an OBJ, one face per primitive.
fn write_obj(path: &Path, scene: &Scene) -> io::Result<()> {
    let mut f = BufWriter::new(File::create(path)?);
    writeln!(
        f,
        "# refl crosscheck: scene {}, {} triangles, face k = primitive k",
        scene.name,
        scene.tri_count()
    )?;
    for t in &scene.tris {
        for v in t {
            writeln!(f, "v {} {} {}", v.x, v.y, v.z)?;
        }
    }
    for k in 0..scene.tri_count() {
        let b = 3 * k + 1;
        writeln!(f, "f {} {} {}", b, b + 1, b + 2)?;
    }
    f.flush()
}

/// The crosscheck ray set of `camera`: (reflection rays, primary rays), see
/// the module docs.
pub fn crosscheck_rays(
    scene: &Scene,
    tracer: &Tracer,
    camera: &Camera,
) -> (Vec<ExportRay>, Vec<ExportRay>) {
    let (w, h) = (camera.width(), camera.height());
    let inv_view = camera.inverse_view().as_dmat4();
    let tan_y = (f64::from(camera.fov_y()) * 0.5).tan();
    let tan_x = tan_y * f64::from(w) / f64::from(h);
    let primary = |x: u32, y: u32| -> (DVec3, DVec3) {
        let ndc_x = 2.0 * (f64::from(x) + 0.5) / f64::from(w) - 1.0;
        let ndc_y = 1.0 - 2.0 * (f64::from(y) + 0.5) / f64::from(h);
        let d = DVec3::new(ndc_x * tan_x, ndc_y * tan_y, -1.0);
        (
            inv_view.w_axis.truncate(),
            inv_view.transform_vector3(d).normalize(),
        )
    };
    let epsilon = scene.ray_epsilon();
    let reflection: Vec<ExportRay> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            (0..w).filter_map(move |x| {
                let (o, d) = primary(x, y);
                let hit = tracer.trace(o.as_vec3(), d.as_vec3(), 0.0, f32::INFINITY)?;
                if !scene.material_of(hit.prim).is_reflective() {
                    return None;
                }
                let (origin, dir) = reflection_ray_f64(scene, hit.prim, o, d)?;
                Some(ExportRay {
                    origin: origin.as_vec3(),
                    dir: dir.as_vec3(),
                    tmin: epsilon,
                    tmax: f32::INFINITY,
                })
            })
        })
        .collect();
    let primary: Vec<ExportRay> = (0..h)
        .step_by(PRIMARY_STRIDE as usize)
        .flat_map(|y| (0..w).step_by(PRIMARY_STRIDE as usize).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (o, d) = primary(x, y);
            ExportRay {
                origin: o.as_vec3(),
                dir: d.as_vec3(),
                tmin: 0.0,
                tmax: f32::INFINITY,
            }
        })
        .collect();
    (reflection, primary)
}

/// The reflection ray (origin, unit direction) at the hit of the f64 ray
/// `o + t d` with primitive `prim`, all in f64; `None` if the ray is
/// parallel to the primitive's plane.
fn reflection_ray_f64(scene: &Scene, prim: u32, o: DVec3, d: DVec3) -> Option<(DVec3, DVec3)> {
    let [a, b, c] = scene.tris[prim as usize].map(|p| p.as_dvec3());
    let [na, nb, nc] = scene.normals[prim as usize].map(|n| n.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let s = o - a;
    let q = s.cross(e1);
    let (u, v, t) = (s.dot(p) / det, d.dot(q) / det, e2.dot(q) / det);
    let mut ng = e1.cross(e2).normalize();
    let mut ns = (na * (1.0 - u - v) + nb * u + nc * v).normalize();
    if ng.dot(d) > 0.0 {
        ng = -ng;
        ns = -ns;
    }
    let view = -d;
    let mut r = 2.0 * view.dot(ns) * ns - view;
    let below = r.dot(ng);
    if below < 0.0 {
        r = (r - 2.0 * below * ng).normalize();
    }
    Some((o + d * t, r.normalize()))
}
