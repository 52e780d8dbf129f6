//! What a scene holds, measured from its frames and geometry: the report
//! decides from this, not from a scene's name, which methods and studies
//! run on it (issue 17; design: "a pipeline that skips passes a scene
//! cannot use").

use crate::gbuffer::GBuffer;
use crate::scene::Scene;
use crate::tracer::Tracer;
use glam::Vec3;

/// Azimuths probed per eye and elevation by [`Content::interior`]'s test.
pub const PROBE_AZIMUTHS: u32 = 32;
/// Elevations (degrees) probed by the interior test: around the horizon,
/// where walls are (a walled interior may be open to the sky).
pub const PROBE_ELEVATIONS: [f32; 3] = [-5.0, 0.0, 5.0];
/// Eyes along the camera path probed by the interior test.
pub const PROBE_EYES: u32 = 8;
/// Share of probe rays that must hit geometry for an enclosed path.
pub const ENCLOSED_SHARE: f64 = 0.95;

/// The content of one scene over the frames the report renders.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Content {
    /// Reflective pixels with roughness > 0, summed over the frames.
    pub glossy_pixels: usize,
    /// Pixels of planar perfect mirrors, summed over the frames.
    pub planar_mirror_pixels: usize,
    /// Reflective pixels, summed over the frames.
    pub reflective_pixels: usize,
    /// Objects the layered method maps (compact, non-reflective; scene-wide).
    pub reflected_objects: usize,
    /// Poses of the scene's camera path.
    pub path_poses: usize,
    /// The camera path runs inside walls (see [`Content::interior`]).
    pub interior: bool,
}

impl Content {
    /// The content `g` shows (per-frame counts; `path_poses` and `interior`
    /// are left for [`Content::of_scene`]).
    pub fn of_frame(scene: &Scene, g: &GBuffer) -> Self {
        let planar_mirror: Vec<bool> = scene
            .objects
            .iter()
            .map(|o| o.planar.is_some() && scene.materials[o.material as usize].is_mirror())
            .collect();
        let mut c = Content::default();
        for i in 0..g.len() {
            if !g.is_reflective(i) {
                continue;
            }
            c.reflective_pixels += 1;
            c.glossy_pixels += usize::from(g.roughness[i] > 0.0);
            c.planar_mirror_pixels += usize::from(
                planar_mirror
                    .get(g.object[i] as usize)
                    .copied()
                    .unwrap_or(false),
            );
        }
        c
    }

    /// The content of `scene` over the G-buffers `frames`: pixel counts
    /// summed, the mapped objects, the camera path and whether it is an
    /// interior.
    pub fn of_scene<'a>(
        scene: &Scene,
        tracer: &Tracer,
        frames: impl IntoIterator<Item = &'a GBuffer>,
    ) -> Self {
        let mut c = frames
            .into_iter()
            .map(|g| Content::of_frame(scene, g))
            .fold(Content::default(), |a, n| Content {
                glossy_pixels: a.glossy_pixels + n.glossy_pixels,
                planar_mirror_pixels: a.planar_mirror_pixels + n.planar_mirror_pixels,
                reflective_pixels: a.reflective_pixels + n.reflective_pixels,
                ..a
            });
        c.reflected_objects = crate::layered_render::reflected_objects(scene).len();
        c.path_poses = scene.camera_path.len();
        c.interior = Content::interior(scene, tracer);
        c
    }

    /// Whether the camera path runs inside walls: from each of
    /// [`PROBE_EYES`] eyes spread over the path, rays at
    /// [`PROBE_AZIMUTHS`] azimuths and the [`PROBE_ELEVATIONS`] around the
    /// horizon, and at least [`ENCLOSED_SHARE`] of them hit the scene. A
    /// walk through walled, densely occluded space is what seed 002's
    /// reprojection of primary visibility is for (a walkthrough: the
    /// walkthrough scene has no ceiling, so the sky does not count); an
    /// open scene seen from outside is not.
    pub fn interior(scene: &Scene, tracer: &Tracer) -> bool {
        if scene.camera_path.len() < 2 {
            return false;
        }
        let (mut hits, mut rays) = (0u32, 0u32);
        for e in 0..PROBE_EYES {
            let Some(pose) = scene.pose_at(e as f32 / (PROBE_EYES - 1) as f32) else {
                return false;
            };
            for elevation in PROBE_ELEVATIONS {
                let (sin_e, cos_e) = elevation.to_radians().sin_cos();
                for k in 0..PROBE_AZIMUTHS {
                    let phi = std::f32::consts::TAU * k as f32 / PROBE_AZIMUTHS as f32;
                    let dir = Vec3::new(cos_e * phi.cos(), sin_e, cos_e * phi.sin());
                    rays += 1;
                    hits += u32::from(
                        tracer
                            .trace(pose.eye, dir, scene.ray_epsilon(), f32::INFINITY)
                            .is_some(),
                    );
                }
            }
        }
        f64::from(hits) >= ENCLOSED_SHARE * f64::from(rays)
    }
}
