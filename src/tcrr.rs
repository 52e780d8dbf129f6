//! TCRR on the built-in camera paths (seed 000): key frames traced with the
//! obvhs tracer, other frames through `refl_core::tcrr` (search, shifting,
//! warping) with the masked pixels re-traced; and the naive baseline that
//! warps the key frame's reflection colors by depth (seed 000 Figs. 1, 6).
//!
//! Both handle the perfect-mirror pixels (specular level > 0, roughness 0;
//! seed 000 treats perfect specular reflections only); `coverage` in the
//! report says which share of the reflective pixels those are.
//!
//! Per frame of a dense sequence along the scene's camera path
//! ([`Scene::pose_at`]): the G-buffer (not timed, every method needs it);
//! the reference, which traces every handled pixel (timed: the "trace every
//! reflective pixel" frame time); then per method and setting, the frame
//! time of the method: a key frame costs the full trace (the reflection
//! buffers are its by-products) plus back-projecting them once
//! (`tcrr::prepare`); a TCRR frame costs search + shift + warp +
//! the re-trace list + tracing the listed pixels, and if the re-trace share
//! exceeds the key-frame threshold ([`KeyFramePolicy`]) the frame is
//! traced in full as the new key frame (both costs count). Every pass runs
//! on the same rayon pool (same threads) as the reference, in row bands.

use crate::gbuffer::GBuffer;
use crate::render::{compare, direct_image, save_png, timed, ImageError, ReflectionImage};
use crate::report::accum::{Accum, Extra};
use crate::report_out::Row;
use crate::scene::Scene;
use crate::shade::{env_map, reflection_dir, Shader};
use glam::Vec3;
use rayon::prelude::*;
use refl_core::tcrr::{
    self, CurrentView, KeyFramePolicy, ReflectionBuffers, TcrrOptions, INVALID_OFFSET, MASK_RETRACE,
};
use refl_core::{Camera, DepthConvention, Error, ImageView, ImageViewMut};
use std::path::Path;

/// The final image as seed 000 composes it (Alg. 1 line 7, Sec. 3.3:
/// "interpolating the diffuse component and reflection component with
/// weights defined by Fresnel terms computed from camera position, the
/// geometry normal and the pixels specular level"): refl-core's
/// [`tcrr::try_compose`] with Schlick's weight of the specular factor
/// `handled_spec` (zero where the pixel is not handled, which leaves the
/// direct term alone, as [`crate::render::composite`] does) at `n . v`
/// of the geometric normal. The reference and every reuse scheme are
/// composed alike, so their errors compare.
///
/// # Errors
/// A size mismatch (none for buffers of `g`'s size).
pub fn fresnel_composite(
    g: &GBuffer,
    direct: &[Vec3],
    reflection: &[Vec3],
    handled_spec: &[f32],
) -> Result<Vec<Vec3>, Error> {
    let (w, h) = (g.width(), g.height());
    let arr = |v: &[Vec3]| v.iter().map(|c| c.to_array()).collect::<Vec<[f32; 3]>>();
    let (d, r, nrm) = (arr(direct), arr(reflection), arr(&g.geo_normal));
    let current = current_view(g, handled_spec)?;
    let mut out = vec![[0.0f32; 3]; d.len()];
    tcrr::try_compose(
        &mut ImageViewMut::try_new(&mut out, w, h, w)?,
        &ImageView::try_new(&d, w, h, w)?,
        &ImageView::try_new(&r, w, h, w)?,
        &ImageView::try_new(&nrm, w, h, w)?,
        &current,
        tcrr::Fresnel::Schlick,
    )?;
    Ok(out.into_iter().map(Vec3::from_array).collect())
}

/// The current frame of `g` as refl-core's TCRR reads it: its camera,
/// linear depth and the specular factor `handled_spec`.
fn current_view<'a>(g: &'a GBuffer, handled_spec: &'a [f32]) -> Result<CurrentView<'a>, Error> {
    let (w, h) = (g.width(), g.height());
    CurrentView::try_new(
        g.camera,
        DepthConvention::Linear,
        ImageView::try_new(&g.depth, w, h, w)?,
        ImageView::try_new(handled_spec, w, h, w)?,
    )
}

/// Caller-buffer bytes per pixel TCRR needs: reflection buffers (depth 4,
/// normal 12, specular 4, color 12, distance 4), the prepared surfels 32
/// ([`tcrr::Surfel`]), offsets 8, intermediate image (color 12, depth 4,
/// coverage 1), warped color 12 and mask 1, and the re-trace list (4,
/// worst case). The current frame's depth and specular planes are the
/// engine's own G-buffer.
pub const BYTES_PER_PIXEL: usize = 4 + 12 + 4 + 12 + 4 + 32 + 8 + 12 + 4 + 1 + 12 + 1 + 4;

/// Which reuse scheme a run uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    /// Temporal reflection reprojection (seed 000).
    Tcrr,
    /// Depth-based warping of the key frame's reflection colors.
    NaiveWarp,
}

impl Scheme {
    /// The report's method name.
    pub fn name(self) -> &'static str {
        match self {
            Scheme::Tcrr => "tcrr",
            Scheme::NaiveWarp => "naive-warp",
        }
    }
}

/// One setting of a reuse run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setting {
    /// The scheme.
    pub scheme: Scheme,
    /// Key-frame threshold on the re-trace share.
    pub threshold: f32,
    /// Kernel parameters.
    pub params: TcrrOptions,
}

impl Setting {
    /// The setting as `key=value` pairs.
    pub fn label(&self) -> String {
        match self.scheme {
            Scheme::Tcrr => format!(
                "threshold={};max_iter={};magnification={};retrace_contrast={}",
                self.threshold,
                self.params.max_iterations,
                self.params.magnification,
                self.params.retrace_contrast
            ),
            Scheme::NaiveWarp => format!("threshold={}", self.threshold),
        }
    }
}

/// The reflection buffers of a key frame, owned.
struct Key {
    camera: Camera,
    depth: Vec<f32>,
    normal: Vec<[f32; 3]>,
    specular: Vec<f32>,
    color: Vec<[f32; 3]>,
    distance: Vec<f32>,
    /// Back-projected once per key frame ([`tcrr::prepare`]).
    surfels: Vec<tcrr::Surfel>,
}

impl Key {
    /// The buffers without the surfels attached.
    fn plain_buffers(&self) -> Result<ReflectionBuffers<'_>, Error> {
        let (w, h) = (self.camera.width(), self.camera.height());
        ReflectionBuffers::try_new(
            self.camera,
            DepthConvention::Linear,
            ImageView::try_new(&self.depth, w, h, w)?,
            ImageView::try_new(&self.normal, w, h, w)?,
            ImageView::try_new(&self.specular, w, h, w)?,
            ImageView::try_new(&self.color, w, h, w)?,
            ImageView::try_new(&self.distance, w, h, w)?,
        )
    }

    fn buffers(&self) -> Result<ReflectionBuffers<'_>, Error> {
        let (w, h) = (self.camera.width(), self.camera.height());
        self.plain_buffers()?
            .try_with_surfels(ImageView::try_new(&self.surfels, w, h, w)?)
    }

    /// Fills the surfels from the buffers, in row bands on `pool`.
    fn prepare(&mut self, pool: &rayon::ThreadPool) -> Result<(), Error> {
        let (w, h) = (self.camera.width(), self.camera.height());
        let mut surfels = std::mem::take(&mut self.surfels);
        surfels.resize(w as usize * h as usize, tcrr::Surfel::default());
        {
            let b = self.plain_buffers()?;
            let nb = bands(pool, h);
            let r: Result<Vec<_>, Error> = pool.install(|| {
                split(ImageViewMut::try_new(&mut surfels, w, h, w)?, nb)
                    .into_par_iter()
                    .map(|mut band| tcrr::try_prepare(&mut band, &b))
                    .collect()
            });
            r?;
        }
        self.surfels = surfels;
        Ok(())
    }
}

/// The pixels TCRR handles: perfect mirrors.
pub fn handled_mask(g: &GBuffer) -> Vec<bool> {
    (0..g.len())
        .map(|i| g.is_reflective(i) && g.roughness[i] <= 0.0)
        .collect()
}

/// The mirror reflection of pixel `i` (a hit pixel) and the reflected ray's
/// travel distance (`+inf` when it leaves the scene): exactly the
/// reference's one-ray mirror reflection.
pub fn trace_mirror(shader: &Shader, g: &GBuffer, i: usize) -> (Vec3, f32) {
    let Some(s) = g.surface(i) else {
        return (Vec3::ZERO, f32::INFINITY);
    };
    let view = -g.primary_ray(i).dir;
    let dir = reflection_dir(view, s.shading_normal, s.geo_normal);
    match shader
        .tracer
        .trace(s.position, dir, shader.epsilon, f32::INFINITY)
    {
        Some(hit) => (shader.shade_reflection_hit(s.position, dir, &hit), hit.t),
        None => (env_map(dir), f32::INFINITY),
    }
}

/// Traces every handled pixel: colors and distances (zero / `inf`
/// elsewhere).
pub fn trace_all(
    shader: &Shader,
    g: &GBuffer,
    handled: &[bool],
    pool: &rayon::ThreadPool,
) -> (Vec<Vec3>, Vec<f32>) {
    let w = g.width() as usize;
    let mut color = vec![Vec3::ZERO; g.len()];
    let mut dist = vec![f32::INFINITY; g.len()];
    pool.install(|| {
        color
            .par_chunks_mut(w)
            .zip(dist.par_chunks_mut(w))
            .enumerate()
            .for_each(|(y, (c, d))| {
                for x in 0..w {
                    let i = y * w + x;
                    if handled[i] {
                        (c[x], d[x]) = trace_mirror(shader, g, i);
                    }
                }
            });
    });
    (color, dist)
}

fn make_key(g: &GBuffer, handled: &[bool], color: &[Vec3], dist: &[f32]) -> Key {
    Key {
        camera: g.camera,
        depth: g.depth.clone(),
        normal: g.normal.iter().map(|n| n.to_array()).collect(),
        specular: (0..g.len())
            .map(|i| if handled[i] { g.specular[i] } else { 0.0 })
            .collect(),
        color: color.iter().map(|c| c.to_array()).collect(),
        distance: dist.to_vec(),
        surfels: Vec::new(),
    }
}

/// Row bands for the pool: a few per thread.
fn bands(pool: &rayon::ThreadPool, h: u32) -> u32 {
    (pool.current_num_threads() as u32 * 4).clamp(1, h)
}

/// Splits a mutable view into `n` row bands.
fn split<T: Copy>(view: ImageViewMut<'_, T>, n: u32) -> Vec<ImageViewMut<'_, T>> {
    let h = view.height();
    let mut out = Vec::with_capacity(n as usize);
    let mut rest = view;
    for k in 1..n {
        let (a, b) = match rest.try_split_at_row(k * h / n) {
            Ok(p) => p,
            Err((_, r)) => {
                rest = r;
                continue;
            }
        };
        out.push(a);
        rest = b;
    }
    out.push(rest);
    out
}

/// One reuse frame's outputs.
struct Reused {
    color: Vec<[f32; 3]>,
    mask: Vec<u8>,
    reflective: usize,
    retrace: usize,
}

/// Search, shift and warp (TCRR) or warp alone (naive) of frame `g` from
/// key `key`, then the re-trace list and the re-trace of the listed pixels.
#[allow(clippy::too_many_arguments)]
fn reuse_frame(
    scheme: Scheme,
    key: &Key,
    offsets: &mut [[f32; 2]],
    g: &GBuffer,
    handled_spec: &[f32],
    shader: &Shader,
    params: &TcrrOptions,
    pool: &rayon::ThreadPool,
) -> Result<Reused, Error> {
    let (w, h) = (g.width(), g.height());
    let n = g.len();
    let buffers = key.buffers()?;
    let nb = bands(pool, h);
    let eye = g.camera.eye();
    let mut inter = vec![[0.0f32; 3]; n];
    let mut idepth = vec![0.0f32; n];
    let mut coverage = vec![0u8; n];
    let naive_cov: Vec<u8>;
    let naive_path: Vec<f32>;
    let (src, src_depth, src_cov): (&[[f32; 3]], &[f32], &[u8]) = match scheme {
        Scheme::Tcrr => {
            let stats: Result<Vec<_>, Error> = pool.install(|| {
                split(ImageViewMut::try_new(offsets, w, h, w)?, nb)
                    .into_par_iter()
                    .map(|mut band| tcrr::try_search(&mut band, &buffers, eye, params))
                    .collect()
            });
            stats?;
            let ov = ImageView::try_new(offsets, w, h, w)?;
            // Shifting scatters: every band visits the whole grid, so one
            // band per thread.
            let nt = (pool.current_num_threads() as u32).clamp(1, h);
            let c = split(ImageViewMut::try_new(&mut inter, w, h, w)?, nt);
            let d = split(ImageViewMut::try_new(&mut idepth, w, h, w)?, nt);
            let v = split(ImageViewMut::try_new(&mut coverage, w, h, w)?, nt);
            let r: Result<Vec<_>, Error> = pool.install(|| {
                c.into_par_iter()
                    .zip(d)
                    .zip(v)
                    .map(|((mut c, mut d), mut v)| {
                        tcrr::try_shift(&mut c, &mut d, &mut v, &buffers, &ov, params)
                    })
                    .collect()
            });
            r?;
            (&inter, &idepth, &coverage)
        }
        Scheme::NaiveWarp => {
            naive_cov = key.specular.iter().map(|&s| u8::from(s > 0.0)).collect();
            naive_path = key
                .depth
                .iter()
                .zip(&key.distance)
                .map(|(z, r)| z + r)
                .collect();
            (&key.color, &naive_path, &naive_cov)
        }
    };
    let current = current_view(g, handled_spec)?;
    let mut color = vec![[0.0f32; 3]; n];
    let mut mask = vec![0u8; n];
    let sv = ImageView::try_new(src, w, h, w)?;
    let sd = ImageView::try_new(src_depth, w, h, w)?;
    let sc = ImageView::try_new(src_cov, w, h, w)?;
    let c = split(ImageViewMut::try_new(&mut color, w, h, w)?, nb);
    let m = split(ImageViewMut::try_new(&mut mask, w, h, w)?, nb);
    // Naive warping is the seed's baseline: no re-trace contrast test.
    let warp_params = match scheme {
        Scheme::Tcrr => *params,
        Scheme::NaiveWarp => TcrrOptions {
            retrace_contrast: f32::INFINITY,
            ..*params
        },
    };
    let stats: Result<Vec<_>, Error> = pool.install(|| {
        c.into_par_iter()
            .zip(m)
            .map(|(mut c, mut m)| {
                tcrr::try_warp(
                    &mut c,
                    &mut m,
                    &current,
                    &buffers,
                    &sv,
                    &sd,
                    &sc,
                    &warp_params,
                )
            })
            .collect()
    });
    let stats = stats?
        .into_iter()
        .fold(tcrr::WarpStats::default(), tcrr::WarpStats::merged);
    let mv = ImageView::try_new(&mask, w, h, w)?;
    let mut list = vec![0u32; tcrr::retrace_count(&mv)];
    tcrr::try_retrace_list(&mut list, &mv)?;
    let traced: Vec<Vec3> = pool.install(|| {
        list.par_iter()
            .map(|&i| trace_mirror(shader, g, i as usize).0)
            .collect()
    });
    for (&i, c) in list.iter().zip(traced) {
        color[i as usize] = c.to_array();
    }
    Ok(Reused {
        color,
        mask,
        reflective: stats.reflective as usize,
        retrace: stats.retrace as usize,
    })
}

/// Sums over the frames of one setting: the columns every method has
/// ([`Accum`]) and TCRR's own.
#[derive(Clone, Debug, Default)]
struct Totals {
    base: Accum,
    frames: usize,
    key_frames: usize,
    handled: usize,
    retraced: usize,
    /// Error sums over the reuse (non-key) frames only.
    reuse_abs: f64,
    reuse_channels: f64,
}

impl Totals {
    /// Adds one frame: its time, the reference's, the reflective pixel
    /// count and the error over the handled pixels.
    fn add(&mut self, ms: f64, reference_ms: f64, reflective: usize, err: &ImageError, key: bool) {
        self.base
            .add(ms, reference_ms, reflective, err, &Extra::None);
        self.frames += 1;
        self.handled += err.pixels;
        if !key {
            let ch = 3.0 * err.pixels as f64;
            self.reuse_abs += err.mean_abs * ch;
            self.reuse_channels += ch;
        }
    }

    fn row(&self, scene: &str, setting: &Setting, threads: usize) -> Row {
        let frames = self.frames.max(1) as f64;
        let mut row = self
            .base
            .row(scene, setting.scheme.name(), &setting.label(), threads);
        row.extra.extend([
            ("key_frames".into(), self.key_frames.to_string()),
            (
                "key_interval".into(),
                format!("{:.2}", frames / self.key_frames.max(1) as f64),
            ),
            (
                "retraced_share".into(),
                format!("{:.4}", self.retraced as f64 / self.handled.max(1) as f64),
            ),
            (
                "mean_abs_255_reuse_frames".into(),
                format!("{:.4}", self.reuse_abs / self.reuse_channels.max(1.0)),
            ),
            ("bytes_per_pixel".into(), BYTES_PER_PIXEL.to_string()),
        ]);
        row
    }
}

/// Per-setting state along the path.
struct State {
    setting: Setting,
    policy: KeyFramePolicy,
    key: Option<Key>,
    offsets: Vec<[f32; 2]>,
    totals: Totals,
    /// Per frame: (key frame?, re-traced share, mean abs 255).
    per_frame: Vec<FrameRecord>,
}

/// One frame of a setting's run: (key frame?, re-traced share of the
/// handled pixels, mean absolute difference 0..255).
pub type FrameRecord = (bool, f64, f64);

/// The output of [`run_path`].
pub struct PathOutcome {
    /// One row per setting.
    pub rows: Vec<Row>,
    /// Per setting label and scheme name: per-frame (key frame, re-traced
    /// share of handled pixels, mean absolute difference 0..255).
    pub per_frame: Vec<(String, Vec<FrameRecord>)>,
}

/// The frame cameras of a dense sequence of `frames` poses along the
/// scene's path over path parameters `span` (0 = first pose, 1 = last).
///
/// # Errors
/// As [`refl_core::Camera::try_look_at`]; [`Error::InvalidArgument`] for an
/// empty path.
pub fn path_cameras(
    scene: &Scene,
    frames: usize,
    span: (f32, f32),
    width: u32,
    height: u32,
) -> Result<Vec<Camera>, Error> {
    (0..frames)
        .map(|k| {
            let s = span.0 + (span.1 - span.0) * k as f32 / (frames.max(2) - 1) as f32;
            scene
                .pose_at(s)
                .ok_or(Error::InvalidArgument)?
                .camera(scene.near, scene.far, width, height)
        })
        .collect()
}

/// What a path study runs on: the shader (scene and tracer), the label
/// of its rows and files, the frame cameras, and the pool (and its thread
/// count) every timed pass and the reference run on.
#[derive(Clone, Copy)]
pub struct PathRun<'a> {
    /// Scene, tracer and shading.
    pub shader: &'a Shader<'a>,
    /// Scene label (rows, file names).
    pub label: &'a str,
    /// One camera per frame.
    pub cameras: &'a [Camera],
    /// Worker threads of `pool`.
    pub threads: usize,
    /// The pool.
    pub pool: &'a rayon::ThreadPool,
}

/// Runs every setting over the frame cameras; images of frame `image_frame`
/// (composites of the first setting of each scheme, the reference and the
/// re-trace marks) go to `images` with file names prefixed by `label`.
///
/// # Errors
/// A kernel's error (a bug: the inputs are built here) or an image write
/// failure, as a message.
pub fn run_path(
    run: &PathRun<'_>,
    settings: &[Setting],
    images: Option<(&Path, usize)>,
) -> Result<PathOutcome, String> {
    let PathRun {
        shader,
        label,
        cameras,
        threads,
        pool,
    } = *run;
    let scene = shader.scene;
    let mut states: Vec<State> = settings
        .iter()
        .map(|s| {
            Ok(State {
                setting: *s,
                policy: KeyFramePolicy::try_new(s.threshold)?,
                key: None,
                offsets: Vec::new(),
                totals: Totals::default(),
                per_frame: Vec::new(),
            })
        })
        .collect::<Result<_, Error>>()
        .map_err(|e| format!("setting: {e}"))?;
    let err = |e: Error| format!("{label}: tcrr: {e}");
    for (f, cam) in cameras.iter().enumerate() {
        let g = GBuffer::render(scene, shader.tracer, cam, pool);
        let handled = handled_mask(&g);
        let n_handled = handled.iter().filter(|&&h| h).count();
        let n_reflective = (0..g.len()).filter(|&i| g.is_reflective(i)).count();
        let handled_spec: Vec<f32> = (0..g.len())
            .map(|i| if handled[i] { g.specular[i] } else { 0.0 })
            .collect();
        let full = timed(|| trace_all(shader, &g, &handled, pool));
        let (truth_color, truth_dist) = full.value;
        let direct = direct_image(shader, &g, pool);
        let truth_img = ReflectionImage {
            width: g.width(),
            height: g.height(),
            rgb: truth_color.clone(),
            handled: handled.clone(),
        };
        let truth_final =
            fresnel_composite(&g, &direct, &truth_img.rgb, &handled_spec).map_err(err)?;
        let save_here = images.filter(|(_, k)| *k == f);
        if let Some((dir, _)) = save_here {
            save(
                dir,
                &format!("{label}_tcrr_reference.png"),
                &g,
                &truth_final,
            )?;
        }
        let mut saved = [false; 2];
        for st in &mut states {
            let mut time = 0.0;
            let mut out: Option<Reused> = None;
            if let Some(key) = &st.key {
                let r = timed(|| {
                    reuse_frame(
                        st.setting.scheme,
                        key,
                        &mut st.offsets,
                        &g,
                        &handled_spec,
                        shader,
                        &st.setting.params,
                        pool,
                    )
                });
                time += r.ms;
                out = Some(r.value.map_err(err)?);
            }
            let is_key = match &out {
                None => true,
                Some(o) => st
                    .policy
                    .needs_key_frame(o.retrace as u64, o.reflective as u64),
            };
            let (rgb, retrace_share) = if is_key {
                // The full trace (measured once above) is this frame's
                // reflection pass; its by-products are the new buffers.
                time += full.ms;
                let mut key = make_key(&g, &handled, &truth_color, &truth_dist);
                let prep = timed(|| key.prepare(pool));
                prep.value.map_err(err)?;
                time += prep.ms;
                st.key = Some(key);
                st.offsets = vec![INVALID_OFFSET; g.len()];
                st.totals.key_frames += 1;
                st.totals.retraced += n_handled;
                (truth_color.clone(), 1.0)
            } else {
                let o = out.expect("reuse frame");
                st.totals.retraced += o.retrace;
                let share = o.retrace as f64 / o.reflective.max(1) as f64;
                if let Some((dir, _)) = save_here {
                    let slot = usize::from(st.setting.scheme == Scheme::NaiveWarp);
                    if !saved[slot] {
                        saved[slot] = true;
                        let img = ReflectionImage {
                            width: g.width(),
                            height: g.height(),
                            rgb: o.color.iter().map(|c| Vec3::from_array(*c)).collect(),
                            handled: handled.clone(),
                        };
                        let fin =
                            fresnel_composite(&g, &direct, &img.rgb, &handled_spec).map_err(err)?;
                        let name = st.setting.scheme.name();
                        save(dir, &format!("{label}_{name}.png"), &g, &fin)?;
                        // Seed 000 Fig. 7: re-traced pixels in red.
                        let marked: Vec<Vec3> = (0..g.len())
                            .map(|i| {
                                if o.mask[i] == MASK_RETRACE {
                                    fin[i] * 0.3 + Vec3::new(0.7, 0.0, 0.0)
                                } else {
                                    fin[i]
                                }
                            })
                            .collect();
                        save(dir, &format!("{label}_{name}_retraced.png"), &g, &marked)?;
                    }
                }
                (
                    o.color.iter().map(|c| Vec3::from_array(*c)).collect(),
                    share,
                )
            };
            let img = ReflectionImage {
                width: g.width(),
                height: g.height(),
                rgb,
                handled: handled.clone(),
            };
            let fin = fresnel_composite(&g, &direct, &img.rgb, &handled_spec).map_err(err)?;
            let e = compare(&truth_final, &fin, &handled);
            st.totals.add(time, full.ms, n_reflective, &e, is_key);
            st.per_frame.push((is_key, retrace_share, e.mean_abs));
        }
    }
    Ok(PathOutcome {
        rows: states
            .iter()
            .map(|s| s.totals.row(label, &s.setting, threads))
            .collect(),
        per_frame: states
            .into_iter()
            .map(|s| {
                (
                    format!("{} {}", s.setting.scheme.name(), s.setting.label()),
                    s.per_frame,
                )
            })
            .collect(),
    })
}

fn save(dir: &Path, name: &str, g: &GBuffer, rgb: &[Vec3]) -> Result<(), String> {
    let p = dir.join(name);
    save_png(&p, g.width(), g.height(), rgb).map_err(|e| format!("{}: {e}", p.display()))
}
