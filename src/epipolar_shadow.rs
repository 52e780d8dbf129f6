//! Shadow rays with reprojection (seed 002 Sec. 7.4, "Extension for Shadow
//! Rays": "the reprojection can be extended to handle direct illumination
//! by point-light sources similarly to method of Adelson"). The seed gives
//! the idea in one paragraph; this is our construction of it, kept exact:
//!
//! 1. Every frame, the visible point of each pixel casts one shadow ray per
//!    light (as [`Shader::direct`](crate::shade::Shader::direct) does: from
//!    the point offset by the scene's ray epsilon along the geometric
//!    normal, toward a directional light or up to a point light; a light
//!    behind the surface casts none).
//! 2. A point found in shadow is stored, per light, as a POS entry (seed 002
//!    Sec. 3.1) whose *object is its occluder*: the receiver point, the
//!    occluding object's id, the distance from the eye. Lit points store
//!    nothing.
//! 3. The next frame reprojects those entries into an AIP per light with
//!    refl-core's [`try_reproject`] (the same epipolar reprojection as
//!    primary visibility, Alg. 1 with the occlusion check and splatting), so
//!    each pixel receives the occluder of the nearest shadowed point that
//!    landed near it, the Adelson-style candidate.
//! 4. A shadow ray with a candidate is first tested against that object
//!    alone (its own BVH, [`ObjectTracers`]): a hit proves the shadow, an
//!    exact answer from one ray/object test (`c_R`). Otherwise (no
//!    candidate, or the candidate does not block this ray) the ray takes
//!    the full any-hit traversal (`c_E`), which also names the occluder for
//!    the next frame.
//!
//! Every answer is therefore the full traversal's (both find a triangle
//! between the point and the light or neither does): the visibility errors
//! counted against [`shadow_orsa`] are zero up to ties of the triangle test
//! on shared edges. What reprojection can buy is only time: a shadowed
//! pixel answered by one object's BVH instead of the scene's. A lit pixel
//! always costs the full traversal (a lit neighbor proves nothing about
//! this point), so the gain is bounded by the share of shadowed rays.

use crate::epipolar::{ray_of, ObjectTracers};
use crate::render::{median, timed};
use crate::scene::{Light, Scene};
use crate::tracer::{Hit, Tracer};
use glam::Vec3;
use rayon::prelude::*;
use refl_core::epipolar::{
    try_reproject, try_scratch_len, AipEntry, EpipolarOptions, PosEntry, BACKGROUND_OBJECT,
    INVALID_OBJECT,
};
use refl_core::Camera;

/// A shadow ray's answer and how it was reached.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowPath {
    /// No ray: no visible point, or the light is behind the surface.
    None,
    /// Shadow proved by one test against the reprojected occluder (`c_R`).
    Reprojected,
    /// Full any-hit traversal: shadow (`c_E`, with or without a candidate).
    FullShadow,
    /// Full any-hit traversal: lit.
    FullLit,
}

impl ShadowPath {
    /// Whether the ray ended in shadow.
    pub fn shadowed(self) -> bool {
        matches!(self, ShadowPath::Reprojected | ShadowPath::FullShadow)
    }
}

/// Shadow rays of one visible point toward one light: origin (offset off
/// the surface), unit direction, and the distance to the light.
fn shadow_ray(
    scene: &Scene,
    eye_ray: (Vec3, Vec3),
    hit: &Hit,
    light: &Light,
) -> Option<(Vec3, Vec3, f32)> {
    let (o, d) = eye_ray;
    let [a, b, c] = scene.tris[hit.prim as usize];
    let mut n = (b - a).cross(c - a).normalize_or_zero();
    if n.dot(d) > 0.0 {
        n = -n;
    }
    let p = o + d * hit.t;
    let (l, dist) = match *light {
        Light::Directional { direction, .. } => (direction, f32::INFINITY),
        Light::Point { position, .. } => {
            let to = position - p;
            let len = to.length();
            if !(len > 0.0) {
                return None;
            }
            (to / len, len)
        }
    };
    (n.dot(l) > 0.0).then(|| (p + n * scene.ray_epsilon(), l, dist))
}

/// The primary ray of pixel `i`, as the walkthrough casts it.
fn eye_ray(camera: &Camera, i: usize) -> (Vec3, Vec3) {
    let r = ray_of(camera, i);
    (r.origin, r.dir)
}

/// The full traversal's shadow answers for every pixel and light (any-hit,
/// [`Tracer::occluded`]): the reference, `[pixel][light]` flattened.
pub fn shadow_orsa(
    scene: &Scene,
    tracer: &Tracer,
    camera: &Camera,
    hits: &[Option<Hit>],
    pool: &rayon::ThreadPool,
) -> Vec<ShadowPath> {
    let lights = &scene.lights;
    pool.install(|| {
        hits.par_iter()
            .enumerate()
            .with_min_len(camera.width() as usize)
            .flat_map_iter(|(i, h)| {
                let ray = eye_ray(camera, i);
                lights.iter().map(move |light| {
                    let Some(h) = h else { return ShadowPath::None };
                    match shadow_ray(scene, ray, h, light) {
                        None => ShadowPath::None,
                        Some((o, l, dist)) if tracer.occluded(o, l, 0.0, dist) => {
                            ShadowPath::FullShadow
                        }
                        Some(_) => ShadowPath::FullLit,
                    }
                })
            })
            .collect()
    })
}

/// The method's state between frames: the shadow POS of the last frame
/// per light, the AIP and scratch (refl-core's caller memory).
pub struct ShadowState {
    pos: Vec<Vec<PosEntry>>,
    aip: Vec<AipEntry>,
    scratch: Vec<f32>,
    previous: Option<Camera>,
    options: EpipolarOptions,
}

impl ShadowState {
    /// Empty state for `lights` lights at `width x height`.
    ///
    /// # Errors
    /// A size refl-core's reprojection refuses.
    pub fn new(width: u32, height: u32, lights: usize) -> Result<ShadowState, String> {
        let n = width as usize * height as usize;
        Ok(ShadowState {
            pos: vec![vec![PosEntry::INVALID; n]; lights],
            aip: vec![AipEntry::UNAVAILABLE; n],
            scratch: vec![0.0; try_scratch_len(width, height).map_err(|e| e.to_string())?],
            previous: None,
            options: EpipolarOptions::default(),
        })
    }
}

/// One frame of shadow rays with reprojected occluders (module docs,
/// steps 1-4) for the visible points `hits` of `camera`; returns the
/// answers `[pixel][light]` flattened, and updates `state` for the next
/// frame.
///
/// # Errors
/// A reprojection error (cameras of different sizes).
pub fn shadow_reprojected(
    scene: &Scene,
    tracer: &Tracer,
    objects: &ObjectTracers,
    camera: &Camera,
    hits: &[Option<Hit>],
    state: &mut ShadowState,
    pool: &rayon::ThreadPool,
) -> Result<Vec<ShadowPath>, String> {
    let n = hits.len();
    let nl = scene.lights.len();
    let mut out = vec![ShadowPath::None; n * nl];
    let w = camera.width() as usize;
    for (li, light) in scene.lights.iter().enumerate() {
        match &state.previous {
            Some(prev) => try_reproject(
                &mut state.aip,
                &mut state.scratch,
                &state.pos[li],
                prev,
                camera,
                &state.options,
            )
            .map(|_| ())
            .map_err(|e| format!("shadow reproject: {e}"))?,
            None => state.aip.fill(AipEntry::UNAVAILABLE),
        }
        let aip = &state.aip;
        let answers: Vec<(ShadowPath, PosEntry)> = pool.install(|| {
            hits.par_iter()
                .enumerate()
                .with_min_len(w)
                .map(|(i, h)| {
                    let Some(h) = h else {
                        return (ShadowPath::None, PosEntry::INVALID);
                    };
                    let ray = eye_ray(camera, i);
                    let Some((o, l, dist)) = shadow_ray(scene, ray, h, light) else {
                        return (ShadowPath::None, PosEntry::INVALID);
                    };
                    let shadowed = |object: u32| PosEntry::hit(ray.0, ray.1, h.t, object);
                    let cand = aip[i].object;
                    if cand != INVALID_OBJECT
                        && cand != BACKGROUND_OBJECT
                        && objects.trace(cand, o, l, 0.0, dist).is_some()
                    {
                        return (ShadowPath::Reprojected, shadowed(cand));
                    }
                    match tracer.occluder(o, l, 0.0, dist) {
                        Some(prim) => (
                            ShadowPath::FullShadow,
                            shadowed(scene.tri_object[prim as usize]),
                        ),
                        None => (ShadowPath::FullLit, PosEntry::INVALID),
                    }
                })
                .collect()
        });
        for (i, (path, entry)) in answers.into_iter().enumerate() {
            out[i * nl + li] = path;
            state.pos[li][i] = entry;
        }
    }
    state.previous = Some(*camera);
    Ok(out)
}

/// Shadow rays over a walkthrough stretch: the reference and the method,
/// frames 1.. as the steady state.
#[derive(Clone, Debug, Default)]
pub struct ShadowMeasure {
    /// Shadow rays cast over frames 1.. (both methods cast the same rays).
    pub rays: u64,
    /// Of those, shadowed (the reference's answer).
    pub shadowed: u64,
    /// Rays answered by one test against the reprojected occluder.
    pub reprojected: u64,
    /// Rays whose answer differs from the reference's (over every frame).
    pub errors: u64,
    /// Reference time per frame, ms (median of the runs).
    pub orsa_ms: Vec<f64>,
    /// Method time per frame, ms (median of the runs; reprojection
    /// included).
    pub method_ms: Vec<f64>,
}

/// Runs both over the cameras `cams` with the visible points `hits` of
/// each frame (the ground-truth primary hits, so that only shadow work is
/// compared), `runs` times each (the method replays the whole stretch: it
/// has state).
///
/// # Errors
/// A reprojection error.
pub fn measure_shadows(
    scene: &Scene,
    tracer: &Tracer,
    objects: &ObjectTracers,
    cams: &[Camera],
    hits: &[Vec<Option<Hit>>],
    runs: usize,
    pool: &rayon::ThreadPool,
) -> Result<ShadowMeasure, String> {
    let mut m = ShadowMeasure::default();
    let mut reference = Vec::with_capacity(cams.len());
    for (cam, h) in cams.iter().zip(hits) {
        let mut times = Vec::new();
        let mut first = None;
        for _ in 0..runs.max(1) {
            let r = timed(|| shadow_orsa(scene, tracer, cam, h, pool));
            times.push(r.ms);
            first.get_or_insert(r.value);
        }
        m.orsa_ms.push(median(times));
        reference.push(first.expect("runs >= 1"));
    }
    let mut frame_times = vec![Vec::new(); cams.len()];
    for rep in 0..runs.max(1) {
        let (w, hgt) = cams.first().map_or((1, 1), |c| (c.width(), c.height()));
        let mut state = ShadowState::new(w, hgt, scene.lights.len())?;
        for (f, (cam, h)) in cams.iter().zip(hits).enumerate() {
            let r = timed(|| shadow_reprojected(scene, tracer, objects, cam, h, &mut state, pool));
            frame_times[f].push(r.ms);
            let out = r.value?;
            if rep > 0 {
                continue;
            }
            for (a, b) in out.iter().zip(&reference[f]) {
                if a.shadowed() != b.shadowed()
                    || (*a == ShadowPath::None) != (*b == ShadowPath::None)
                {
                    m.errors += 1;
                }
                if f > 0 && *b != ShadowPath::None {
                    m.rays += 1;
                    m.shadowed += u64::from(b.shadowed());
                    m.reprojected += u64::from(*a == ShadowPath::Reprojected);
                }
            }
        }
    }
    m.method_ms = frame_times.into_iter().map(median).collect();
    Ok(m)
}
