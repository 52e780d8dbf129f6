//! Reprojected ray casting of a walkthrough (seed 002) with the obvhs
//! tracer: primary visibility along a dense stretch of a scene's camera
//! path, rendered three ways in the same run with the same threads:
//!
//! * `orsa`: the ordinary ray shooting algorithm, full traversal of the
//!   scene BVH for every pixel (the ground truth of visibility);
//! * `epipolar`: refl-core's [`refl_core::epipolar`] decisions, with one
//!   ray/object test (a per-object BVH, [`ObjectTracers`]) where the
//!   reprojection predicts the object and full traversal elsewhere;
//! * `irsa`: the ideal ray shooting algorithm of Sec. 6: the object ORSA
//!   found is tested alone (the limit of any predictor).
//!
//! Every frame of the method is compared with ORSA pixel by pixel
//! (primitive id and distance): a visibility error is any difference, and
//! each one is listed.

use crate::gbuffer::pixel_center;
use crate::render::{median, timed};
use crate::report_out;
use crate::scene::Scene;
use crate::tracer::{Hit, TraceCount, Tracer};
use glam::Vec3;
use rayon::prelude::*;
use refl_core::epipolar::{
    decide, try_reproject, try_scratch_len, AipEntry, Decision, EpipolarOptions, PosEntry, Reason,
    BACKGROUND_OBJECT,
};
use refl_core::Camera;
use std::path::Path;

/// The method names this module reports (rows of `summary.csv`).
pub const METHODS: [&str; 3] = ["epipolar", "orsa", "irsa"];

/// One BVH per scene object, for "test object O only" (seed 002 Alg. 2):
/// the same obvhs CWBVH and triangle test as [`Tracer`], over the object's
/// primitives, reporting scene primitive ids.
pub struct ObjectTracers {
    tracers: Vec<(Tracer, u32)>,
}

impl ObjectTracers {
    /// Builds one tracer per object of `scene`.
    pub fn new(scene: &Scene) -> ObjectTracers {
        let tracers = scene
            .objects
            .par_iter()
            .map(|o| {
                let r = o.tris.start as usize..o.tris.end as usize;
                let sub = Scene {
                    name: o.name.clone(),
                    tris: scene.tris[r.clone()].to_vec(),
                    normals: scene.normals[r].to_vec(),
                    tri_object: Vec::new(),
                    objects: Vec::new(),
                    materials: Vec::new(),
                    lights: Vec::new(),
                    ambient: glam::Vec3::ZERO,
                    camera_path: Vec::new(),
                    near: scene.near,
                    far: scene.far,
                    skipped_degenerate_triangles: 0,
                    load_notes: Vec::new(),
                };
                (Tracer::new(&sub), o.tris.start)
            })
            .collect();
        ObjectTracers { tracers }
    }

    /// The closest hit of the ray with object `object` in `[tmin, tmax)`,
    /// with its scene primitive id; `None` for a miss or an unknown object.
    pub fn trace(
        &self,
        object: u32,
        origin: glam::Vec3,
        dir: glam::Vec3,
        tmin: f32,
        tmax: f32,
    ) -> Option<Hit> {
        self.trace_counted(object, origin, dir, tmin, tmax, &mut TraceCount::default())
    }

    /// [`Self::trace`], counting the object BVH's work into `count`
    /// ([`Tracer::trace_counted`]; an unknown object counts a ray and no
    /// work).
    pub fn trace_counted(
        &self,
        object: u32,
        origin: glam::Vec3,
        dir: glam::Vec3,
        tmin: f32,
        tmax: f32,
        count: &mut TraceCount,
    ) -> Option<Hit> {
        let Some((t, start)) = self.tracers.get(object as usize) else {
            count.rays += 1;
            return None;
        };
        t.trace_counted(origin, dir, tmin, tmax, count)
            .map(|h| Hit {
                prim: h.prim + start,
                ..h
            })
    }
}

/// Which path a pixel took in the method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelPath {
    /// One ray/object test succeeded (`c_R`).
    Resolved,
    /// Reprojection failed: too few points, or the one-object test missed
    /// (`c_E`).
    Failed,
    /// As `Failed`, near points dropped by the abrupt-motion test (`c_E`).
    Abrupt,
    /// Regular resampling (`c_O`).
    Resampled,
    /// No reprojection this frame (first frame, view-frustum check).
    Unavailable,
}

/// Per-pixel outcome of one method frame.
type PixelOut = (Option<Hit>, PixelPath);

/// A named parameter setting of the method.
#[derive(Clone, Debug)]
pub struct Variant {
    /// The `setting` column.
    pub setting: String,
    /// The parameters.
    pub params: EpipolarOptions,
}

/// The settings swept for error against run time: the default (m_cnt = 5,
/// N = 9, 3x3 splat, occlusion check, depth guard), then one change at a
/// time; with `ablations` also the three that only show a failure mode
/// (no guard margin, no guard window, the shifted origin), which the long
/// run and the tests sweep.
pub fn variants(ablations: bool) -> Vec<Variant> {
    let d = EpipolarOptions::default();
    let v = |setting: &str, params: EpipolarOptions| Variant {
        setting: setting.to_string(),
        params,
    };
    let mut all = vec![
        v("default", d),
        v("m_cnt=3", EpipolarOptions { m_cnt: 3, ..d }),
        v("m_cnt=7", EpipolarOptions { m_cnt: 7, ..d }),
        v(
            "N=4",
            EpipolarOptions {
                resample_period: 4,
                abrupt_frames: 4,
                ..d
            },
        ),
        v(
            "N=16",
            EpipolarOptions {
                resample_period: 16,
                abrupt_frames: 16,
                ..d
            },
        ),
        v(
            "resampling=off",
            EpipolarOptions {
                resample_period: 0,
                ..d
            },
        ),
        v(
            "splat=1x1;m_cnt=1",
            EpipolarOptions {
                splat_radius: 0,
                m_cnt: 1,
                ..d
            },
        ),
        v(
            "splat=5x5;m_cnt=13",
            EpipolarOptions {
                splat_radius: 2,
                m_cnt: 13,
                ..d
            },
        ),
        v(
            "occlusion_check=off",
            EpipolarOptions {
                occlusion_check: false,
                ..d
            },
        ),
        v(
            "depth_guard=off",
            EpipolarOptions {
                depth_guard: false,
                ..d
            },
        ),
    ];
    if !ablations {
        return all;
    }
    all.extend([
        v(
            "guard_margin=0",
            EpipolarOptions {
                guard_margin: 0.0,
                ..d
            },
        ),
        v(
            "guard_window=0",
            EpipolarOptions {
                guard_window: 0,
                ..d
            },
        ),
        v(
            "shift_origin=on",
            EpipolarOptions {
                shift_origin: true,
                ..d
            },
        ),
    ]);
    all
}

/// Sizes of a walkthrough run.
#[derive(Clone, Copy, Debug)]
pub struct PathSizes {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Frames rendered.
    pub frames: usize,
    /// Eye movement per frame, world units (walking speed / frame rate).
    pub step: f32,
    /// Where on the path (0..1) the stretch starts.
    pub start: f32,
    /// Where the camera looks.
    pub gaze: Gaze,
    /// Whether the ablations run too (see [`variants`]).
    pub ablations: bool,
}

/// Where the walkthrough camera looks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gaze {
    /// Along the direction of motion (the tangent of the eye path, tilted
    /// down like the stored poses): a walker looking where they go, the
    /// walkthrough of seed 002 Sec. 4.1 ("the camera is typically moving
    /// forward or rotates").
    AlongPath,
    /// The scene's stored targets (the walkthrough scene looks 3 m ahead
    /// along its route, so around corners it walks sideways, up to 54
    /// degrees off its view axis: the new eye leaves the previous view
    /// pyramid and the view-frustum check of Sec. 4.1 turns reprojection
    /// off for the frame).
    Stored,
}

impl PathSizes {
    /// `refl report --quick` and the tests: 10 frames at 256x192.
    pub const QUICK: PathSizes = PathSizes {
        width: 256,
        height: 192,
        frames: 10,
        step: 0.05,
        start: 0.3,
        gaze: Gaze::AlongPath,
        ablations: false,
    };

    /// The default report: 8 frames at 384x288.
    pub const DEFAULT: PathSizes = PathSizes {
        width: 384,
        height: 288,
        frames: 8,
        ablations: false,
        ..PathSizes::LONG
    };

    /// `refl report --long`: 48 frames at 512x384 (2.4 m of walk).
    pub const LONG: PathSizes = PathSizes {
        width: 512,
        height: 384,
        frames: 48,
        step: 0.05,
        start: 0.3,
        gaze: Gaze::AlongPath,
        ablations: true,
    };

    /// [`PathSizes::QUICK`] or [`PathSizes::LONG`].
    pub fn new(quick: bool) -> Self {
        if quick {
            PathSizes::QUICK
        } else {
            PathSizes::LONG
        }
    }
}

/// The cameras of `frames` frames along the scene's path from `start`, the
/// eye advancing about `step` per frame (arc length of the eye spline),
/// looking as `sizes.gaze` says.
pub fn path_cameras(scene: &Scene, sizes: &PathSizes) -> Result<Vec<Camera>, String> {
    // Arc length of the eye spline, sampled finely.
    let samples = 4000;
    let eye = |s: f32| scene.pose_at(s).map(|p| p.eye);
    let mut arc = vec![0.0f32; samples + 1];
    for i in 1..=samples {
        let (a, b) = (
            eye((i - 1) as f32 / samples as f32),
            eye(i as f32 / samples as f32),
        );
        let (Some(a), Some(b)) = (a, b) else {
            return Err(format!("{}: empty camera path", scene.name));
        };
        arc[i] = arc[i - 1] + (b - a).length();
    }
    let s_at = |len: f32| {
        let i = arc.partition_point(|&l| l < len).min(samples);
        i as f32 / samples as f32
    };
    let start_len = arc[(sizes.start.clamp(0.0, 1.0) * samples as f32) as usize];
    (0..sizes.frames)
        .map(|k| {
            let len = start_len + k as f32 * sizes.step;
            let s = s_at(len);
            let mut pose = scene.pose_at(s).ok_or("empty camera path".to_string())?;
            if sizes.gaze == Gaze::AlongPath {
                // Tangent of the eye path over +-10 cm of arc length,
                // horizontal, with the stored pose's downward tilt.
                let (a, b) = (eye(s_at(len - 0.1)), eye(s_at(len + 0.1)));
                let (Some(a), Some(b)) = (a, b) else {
                    return Err(format!("{}: empty camera path", scene.name));
                };
                let stored = pose.target - pose.eye;
                let flat = Vec3::new(b.x - a.x, 0.0, b.z - a.z).normalize_or_zero();
                if flat != Vec3::ZERO {
                    let horizontal = Vec3::new(stored.x, 0.0, stored.z).length();
                    pose.target = pose.eye + flat * horizontal + Vec3::Y * stored.y;
                }
            }
            pose.camera(scene.near, scene.far, sizes.width, sizes.height)
                .map_err(|e| format!("{}: camera: {e}", scene.name))
        })
        .collect()
}

pub(crate) fn ray_of(camera: &Camera, i: usize) -> refl_core::Ray {
    let w = camera.width() as usize;
    camera.primary_ray(pixel_center((i % w) as u32, (i / w) as u32))
}

/// Sums the per-pixel counts of a frame.
fn frame_count(counts: &[TraceCount]) -> TraceCount {
    counts.iter().fold(TraceCount::default(), |a, c| a + *c)
}

/// ORSA: full traversal for every pixel, with its work ([`TraceCount`]).
fn orsa(
    tracer: &Tracer,
    camera: &Camera,
    pool: &rayon::ThreadPool,
) -> (Vec<Option<Hit>>, TraceCount) {
    let n = camera.width() as usize * camera.height() as usize;
    let (hits, counts): (Vec<_>, Vec<_>) = pool.install(|| {
        (0..n)
            .into_par_iter()
            .with_min_len(camera.width() as usize)
            .map(|i| {
                let r = ray_of(camera, i);
                let mut c = TraceCount::default();
                let h = tracer.trace_counted(r.origin, r.dir, 0.0, f32::INFINITY, &mut c);
                (h, c)
            })
            .unzip()
    });
    (hits, frame_count(&counts))
}

/// IRSA: the object ORSA found, tested alone (through its own BVH, so
/// its traversal steps are not the paper's zero), with its work; a pixel
/// where ORSA saw background costs nothing.
fn irsa(
    scene: &Scene,
    objects: &ObjectTracers,
    camera: &Camera,
    truth: &[Option<Hit>],
    pool: &rayon::ThreadPool,
) -> (Vec<Option<Hit>>, TraceCount) {
    let (hits, counts): (Vec<_>, Vec<_>) = pool.install(|| {
        truth
            .par_iter()
            .enumerate()
            .with_min_len(camera.width() as usize)
            .map(|(i, h)| {
                let mut c = TraceCount::default();
                let hit = h.as_ref().and_then(|h| {
                    let r = ray_of(camera, i);
                    objects.trace_counted(
                        scene.tri_object[h.prim as usize],
                        r.origin,
                        r.dir,
                        0.0,
                        f32::INFINITY,
                        &mut c,
                    )
                });
                (hit, c)
            })
            .unzip()
    });
    (hits, frame_count(&counts))
}

/// One pixel of the method (Alg. 2 with the host's tracers).
#[inline]
fn method_pixel(
    scene_tracer: &Tracer,
    objects: &ObjectTracers,
    r: &refl_core::Ray,
    d: &Decision,
    count: &mut TraceCount,
) -> PixelOut {
    let full = |tmin: f32, count: &mut TraceCount| {
        scene_tracer.trace_counted(r.origin, r.dir, tmin, f32::INFINITY, count)
    };
    match d.reason {
        Reason::Reprojected if d.object == BACKGROUND_OBJECT => (None, PixelPath::Resolved),
        Reason::Reprojected => {
            match objects.trace_counted(d.object, r.origin, r.dir, 0.0, d.tmax, count) {
                Some(h) => (Some(h), PixelPath::Resolved),
                None => (full(d.tmin, count), PixelPath::Failed),
            }
        }
        Reason::Failed => (full(d.tmin, count), PixelPath::Failed),
        Reason::Abrupt => (full(d.tmin, count), PixelPath::Abrupt),
        Reason::Resampled => (full(d.tmin, count), PixelPath::Resampled),
        Reason::Unavailable => (full(d.tmin, count), PixelPath::Unavailable),
    }
}

/// Method state carried between frames: POS of the last frame, AIP and
/// scratch (all caller memory of refl-core).
struct State {
    pos: Vec<PosEntry>,
    aip: Vec<AipEntry>,
    scratch: Vec<f32>,
    previous: Option<Camera>,
}

/// One method frame: reprojection (serial: the epipolar order is
/// sequential), decisions and tracing (parallel), POS for the next frame.
#[allow(clippy::too_many_arguments)]
fn method_frame(
    scene: &Scene,
    tracer: &Tracer,
    objects: &ObjectTracers,
    camera: &Camera,
    frame: u32,
    params: &EpipolarOptions,
    state: &mut State,
    pool: &rayon::ThreadPool,
) -> Result<(Vec<PixelOut>, TraceCount), String> {
    let w = camera.width() as usize;
    match &state.previous {
        Some(prev) => {
            try_reproject(
                &mut state.aip,
                &mut state.scratch,
                &state.pos,
                prev,
                camera,
                params,
            )
            .map_err(|e| format!("reproject: {e}"))?;
        }
        None => state.aip.fill(AipEntry::UNAVAILABLE),
    }
    let radius = background_radius(scene);
    let aip = &state.aip;
    // Decide, trace and store the POS entry of the next frame in one pass
    // (one primary ray per pixel).
    let (out, counts): (Vec<PixelOut>, Vec<TraceCount>) = pool.install(|| {
        state
            .pos
            .par_iter_mut()
            .enumerate()
            .with_min_len(w)
            .map(|(i, p)| {
                let d = decide(&aip[i], (i % w) as u32, (i / w) as u32, frame, params);
                let r = ray_of(camera, i);
                let mut c = TraceCount::default();
                let out = method_pixel(tracer, objects, &r, &d, &mut c);
                *p = match out.0 {
                    Some(h) => {
                        PosEntry::hit(r.origin, r.dir, h.t, scene.tri_object[h.prim as usize])
                    }
                    None => PosEntry::background(r.origin, r.dir, radius),
                };
                (out, c)
            })
            .unzip()
    });
    state.previous = Some(*camera);
    Ok((out, frame_count(&counts)))
}

/// Radius of the camera-centered background sphere (seed 002 Sec. 5.2):
/// four scene diameters, beyond any hit from a camera inside the scene.
pub fn background_radius(scene: &Scene) -> f32 {
    scene.diameter().max(1.0) * 4.0
}

/// One visibility mismatch against ORSA.
#[derive(Clone, Debug, PartialEq)]
pub struct Mismatch {
    /// Frame index.
    pub frame: usize,
    /// Pixel.
    pub pixel: (u32, u32),
    /// ORSA's hit `(prim, t)`.
    pub orsa: Option<(u32, f32)>,
    /// The method's hit.
    pub method: Option<(u32, f32)>,
    /// The path the pixel took.
    pub path: PixelPath,
}

/// How a method's hit compares with ORSA's on the same ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Agreement {
    /// Both miss, or both hit the same object at the same distance (to
    /// [`SAME_T`] relative). Within one object the primitive may differ: a
    /// ray through an edge shared by two triangles of the object hits both
    /// at one distance, and which one a traversal reports depends on the
    /// order it visits them (a per-object BVH and the scene BVH differ).
    Same,
    /// Different objects at the same distance (to [`SAME_T`] relative): the
    /// ray hits the line where two objects touch (a pillar on the floor).
    /// The visible point is the same; counted and listed, not an error.
    Tie,
    /// A visibility error: one misses and the other hits, or the distances
    /// differ.
    Error,
}

/// Relative distance tolerance of [`agreement`]: far above the f32
/// rounding of one triangle test (about `1e-7` relative), far below any
/// distance between two surfaces of the scenes (millimeters at meters).
pub const SAME_T: f32 = 1e-4;

/// Compares the hits `a` (the method) and `b` (ORSA) of one ray.
pub fn agreement(scene: &Scene, a: &Option<Hit>, b: &Option<Hit>) -> Agreement {
    match (a, b) {
        (None, None) => Agreement::Same,
        (Some(a), Some(b)) => {
            if (a.t - b.t).abs() > SAME_T * a.t.abs().max(b.t.abs()).max(1e-6) {
                Agreement::Error
            } else if a.prim == b.prim
                || scene.tri_object[a.prim as usize] == scene.tri_object[b.prim as usize]
            {
                Agreement::Same
            } else {
                Agreement::Tie
            }
        }
        _ => Agreement::Error,
    }
}

/// Totals of one setting over the path.
#[derive(Clone, Debug, Default)]
pub struct Totals {
    /// Pixels over all frames.
    pub pixels: usize,
    /// Pixels resolved by one ray/object test.
    pub resolved: usize,
    /// Fallbacks from failed reprojection (including missed one-object
    /// tests and abrupt-motion drops).
    pub failed: usize,
    /// Of `failed`, pixels flagged by the abrupt-motion test.
    pub abrupt: usize,
    /// Regular resampling.
    pub resampled: usize,
    /// No reprojection (first frame, view-frustum check).
    pub unavailable: usize,
    /// Visibility errors against ORSA ([`Agreement::Error`]).
    pub mismatches: Vec<Mismatch>,
    /// Ties with ORSA ([`Agreement::Tie`]): same point, another object.
    pub ties: Vec<Mismatch>,
    /// Method time per frame, ms.
    pub times: Vec<f64>,
    /// The method's tracing work over frames 1.. (the steady state; frame
    /// 0 has no reprojection): seed 002's `Ñ_IT` and `Ñ_TS` per pixel are
    /// `count.tests_per_ray(steady_pixels)` and `count.steps_per_ray(..)`.
    pub count: TraceCount,
    /// Pixels of frames 1.. (every pixel casts one primary ray, whatever
    /// path it takes).
    pub steady_pixels: u64,
}

/// Everything a walkthrough run measured: ORSA and IRSA per frame, the
/// method's totals per setting, the view-frustum check on both gazes.
pub struct PathMeasure {
    /// Frames rendered.
    pub frames: usize,
    /// Frame pairs failing the view-frustum check (Sec. 4.1) with the
    /// run's gaze.
    pub frustum_fails: usize,
    /// The other gaze and how many frame pairs would fail with it.
    pub other_gaze: (Gaze, usize),
    /// Build time of the per-object BVHs, ms.
    pub objects_build_ms: f64,
    /// ORSA time per frame, ms (median of the runs).
    pub orsa_ms: Vec<f64>,
    /// IRSA time per frame, ms (median of the runs).
    pub irsa_ms: Vec<f64>,
    /// IRSA's visibility errors against ORSA.
    pub irsa_errors: Vec<Mismatch>,
    /// IRSA's ties with ORSA (same point, another object).
    pub irsa_ties: usize,
    /// Shadow rays toward every light from ORSA's visible points, full
    /// any-hit traversal against reprojected occluders (seed 002 Sec. 7.4,
    /// [`crate::epipolar_shadow`]).
    pub shadows: crate::epipolar_shadow::ShadowMeasure,
    /// ORSA's and IRSA's tracing work over frames 1.. (as
    /// [`Totals::count`], per pixel over [`Totals::steady_pixels`]).
    pub orsa_count: TraceCount,
    /// See `orsa_count`.
    pub irsa_count: TraceCount,
    /// The method's totals per setting (same order as [`variants`]).
    pub totals: Vec<(String, Totals)>,
}

/// ORSA's hits per frame (the ground truth of visibility) with the ORSA
/// and IRSA timings and IRSA's disagreements.
struct Truth {
    hits: Vec<Vec<Option<Hit>>>,
    orsa_count: TraceCount,
    irsa_count: TraceCount,
    orsa_ms: Vec<f64>,
    irsa_ms: Vec<f64>,
    irsa_errors: Vec<Mismatch>,
    irsa_ties: usize,
}

/// The pixel of index `i` in a `width`-wide image.
fn pixel_of(i: usize, width: u32) -> (u32, u32) {
    ((i % width as usize) as u32, (i / width as usize) as u32)
}

/// ORSA and IRSA on every camera of `cams` (median of `runs` each), IRSA
/// checked against ORSA.
fn truth_frames(
    scene: &Scene,
    tracer: &Tracer,
    objects: &ObjectTracers,
    cams: &[Camera],
    width: u32,
    runs: usize,
    pool: &rayon::ThreadPool,
) -> Truth {
    let mut t = Truth {
        hits: Vec::with_capacity(cams.len()),
        orsa_count: TraceCount::default(),
        irsa_count: TraceCount::default(),
        orsa_ms: Vec::new(),
        irsa_ms: Vec::new(),
        irsa_errors: Vec::new(),
        irsa_ties: 0,
    };
    for (f, cam) in cams.iter().enumerate() {
        let mut times = Vec::new();
        let mut hits = None;
        for _ in 0..runs.max(1) {
            let r = timed(|| orsa(tracer, cam, pool));
            times.push(r.ms);
            let (h, c) = r.value;
            if hits.is_none() && f > 0 {
                t.orsa_count = t.orsa_count + c;
            }
            hits.get_or_insert(h);
        }
        t.orsa_ms.push(median(times));
        let hits = hits.expect("runs >= 1");
        let mut times = Vec::new();
        for rep in 0..runs.max(1) {
            let r = timed(|| irsa(scene, objects, cam, &hits, pool));
            times.push(r.ms);
            if rep > 0 {
                continue;
            }
            let (found, c) = r.value;
            if f > 0 {
                t.irsa_count = t.irsa_count + c;
            }
            for (i, (a, b)) in found.iter().zip(&hits).enumerate() {
                match agreement(scene, a, b) {
                    Agreement::Same => {}
                    Agreement::Tie => t.irsa_ties += 1,
                    Agreement::Error => t.irsa_errors.push(Mismatch {
                        frame: f,
                        pixel: pixel_of(i, width),
                        orsa: b.map(|h| (h.prim, h.t)),
                        method: a.map(|h| (h.prim, h.t)),
                        path: PixelPath::Resolved,
                    }),
                }
            }
        }
        t.irsa_ms.push(median(times));
        t.hits.push(hits);
    }
    t
}

/// Adds one frame of the method (`out`) against ORSA's hits `truth` to `tot`.
fn add_frame(
    scene: &Scene,
    tot: &mut Totals,
    frame: usize,
    width: u32,
    out: &[(Option<Hit>, PixelPath)],
    truth: &[Option<Hit>],
) {
    for (i, ((hit, path), t)) in out.iter().zip(truth).enumerate() {
        tot.pixels += 1;
        match path {
            PixelPath::Resolved => tot.resolved += 1,
            PixelPath::Failed => tot.failed += 1,
            PixelPath::Abrupt => {
                tot.failed += 1;
                tot.abrupt += 1
            }
            PixelPath::Resampled => tot.resampled += 1,
            PixelPath::Unavailable => tot.unavailable += 1,
        }
        let agree = agreement(scene, hit, t);
        if agree != Agreement::Same {
            let m = Mismatch {
                frame,
                pixel: pixel_of(i, width),
                orsa: t.map(|h| (h.prim, h.t)),
                method: hit.map(|h| (h.prim, h.t)),
                path: *path,
            };
            if agree == Agreement::Tie {
                tot.ties.push(m);
            } else {
                tot.mismatches.push(m);
            }
        }
    }
}

/// Renders the walkthrough stretch with ORSA, IRSA and every setting of
/// the method, and writes the path images (which pixels took which path,
/// for the middle frame) into `images` (when given).
///
/// # Errors
/// A message for an empty camera path, a camera the path cannot make, or a
/// failed method frame.
pub fn measure(
    scene: &Scene,
    tracer: &Tracer,
    sizes: &PathSizes,
    runs: usize,
    pool: &rayon::ThreadPool,
    images: Option<&Path>,
) -> Result<PathMeasure, String> {
    let cams = path_cameras(scene, sizes)?;
    // Sec. 4.1 on the other gaze: how many frames would fail the
    // view-frustum check (and be rendered by ORSA alone).
    let other_gaze = match sizes.gaze {
        Gaze::AlongPath => Gaze::Stored,
        Gaze::Stored => Gaze::AlongPath,
    };
    let frustum_fails = |cams: &[Camera]| {
        cams.windows(2)
            .filter(|w| !refl_core::epipolar::frustum_contains(&w[0], w[1].eye()))
            .count()
    };
    let other = path_cameras(
        scene,
        &PathSizes {
            gaze: other_gaze,
            ..*sizes
        },
    )?;
    let build = timed(|| ObjectTracers::new(scene));
    let objects = build.value;
    let truth = truth_frames(scene, tracer, &objects, &cams, sizes.width, runs, pool);
    let shadows = crate::epipolar_shadow::measure_shadows(
        scene,
        tracer,
        &objects,
        &cams,
        &truth.hits,
        runs,
        pool,
    )?;
    let n = sizes.width as usize * sizes.height as usize;
    let mut totals = Vec::new();
    for v in variants(sizes.ablations) {
        // Each repetition replays the whole path (the method has state).
        let mut tot = Totals::default();
        let mut frame_times = vec![Vec::new(); cams.len()];
        for rep in 0..runs.max(1) {
            let mut state = State {
                pos: vec![PosEntry::INVALID; n],
                aip: vec![AipEntry::UNAVAILABLE; n],
                scratch: vec![
                    0.0;
                    try_scratch_len(sizes.width, sizes.height)
                        .map_err(|e| e.to_string())?
                ],
                previous: None,
            };
            for (f, cam) in cams.iter().enumerate() {
                let r = timed(|| {
                    method_frame(
                        scene, tracer, &objects, cam, f as u32, &v.params, &mut state, pool,
                    )
                });
                frame_times[f].push(r.ms);
                let (out, count) = r.value?;
                if rep > 0 {
                    continue;
                }
                if f > 0 {
                    tot.count = tot.count + count;
                    tot.steady_pixels += out.len() as u64;
                }
                add_frame(scene, &mut tot, f, sizes.width, &out, &truth.hits[f]);
                if let (true, Some(dir)) = (f == cams.len() / 2, images) {
                    let stem = v.setting.replace(['=', ';', '/', ' ', '(', ')'], "-");
                    save_path_image(
                        &dir.join(format!("{}_epipolar_{stem}_paths.png", scene.name)),
                        scene,
                        sizes,
                        &out,
                        &truth.hits[f],
                    )?;
                }
            }
        }
        tot.times = frame_times.into_iter().map(median).collect();
        totals.push((v.setting.clone(), tot));
    }
    Ok(PathMeasure {
        frames: cams.len(),
        frustum_fails: frustum_fails(&cams),
        other_gaze: (other_gaze, frustum_fails(&other)),
        objects_build_ms: build.ms,
        orsa_ms: truth.orsa_ms,
        irsa_ms: truth.irsa_ms,
        irsa_errors: truth.irsa_errors,
        irsa_ties: truth.irsa_ties,
        shadows,
        orsa_count: truth.orsa_count,
        irsa_count: truth.irsa_count,
        totals,
    })
}

/// The path image of one frame (seed 002 Fig. 6b colors): red one
/// ray/object test, green failed reprojection, white regular resampling,
/// blue abrupt motion, gray no reprojection; a visibility mismatch is
/// magenta, background pixels resolved by the background sphere dark red.
fn save_path_image(
    path: &Path,
    scene: &Scene,
    sizes: &PathSizes,
    out: &[PixelOut],
    truth: &[Option<Hit>],
) -> Result<(), String> {
    let px: Vec<[u8; 3]> = out
        .iter()
        .zip(truth)
        .map(|((hit, p), t)| {
            if agreement(scene, hit, t) == Agreement::Error {
                return [255, 0, 255];
            }
            match p {
                PixelPath::Resolved if hit.is_none() => [110, 0, 0],
                PixelPath::Resolved => [220, 30, 30],
                PixelPath::Failed => [30, 180, 30],
                PixelPath::Abrupt => [40, 60, 230],
                PixelPath::Resampled => [255, 255, 255],
                PixelPath::Unavailable => [128, 128, 128],
            }
        })
        .collect();
    report_out::save_png(path, sizes.width, sizes.height, &px)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// `true` for a method name of this module.
pub fn is_path_method(name: &str) -> bool {
    METHODS.contains(&name)
}
