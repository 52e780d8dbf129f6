//! The temporal filter (`refl_core::temporal`, seed 004 Sec. 4.6.4-4.6.5)
//! on an analytic scene ray-cast in f64 by the test: a wall with a box in
//! front of it, and a floor. Oracles: which wall points the previous eye
//! saw (an f64 segment-box test), the running mean and the exponential
//! average of the frames (f64), the colors a surface point should carry (a
//! smooth function of the point), and the statuses that bands, depth
//! conventions and scales must not change.
#![cfg(any(feature = "depth-image", feature = "hiz"))]
#![allow(clippy::needless_range_loop)] // pixel indices address several images at once

use core::f32::consts::FRAC_PI_2;
use refl_core::glam::{DVec3, Vec3};
use refl_core::temporal::{
    History, HistoryTexel, TemporalOptions, TemporalPass, TemporalStats, TemporalStatus,
};
use refl_core::{
    Camera, DepthConvention, DepthImage, Error, GBuffer, ImageView, ImageViewMut, NormalSpace,
    RowRange,
};

const W: u32 = 64;
const H: u32 = 48;
const N: usize = (W * H) as usize;

/// What a pixel sees.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Sky,
    Wall,
    Floor,
    Box,
}

/// The scene, scaled by `s`: a wall z = -6 s (x, y in [-6 s, 6 s]), a
/// floor y = -1.5 s in front of it, a box [-0.6, 0.6] x [-0.6, 0.6] x [-3.5,
/// -2.5] (times s); the floor ends at z = 30 s, within the far plane.
#[derive(Clone, Copy)]
struct Scene {
    s: f64,
}

impl Scene {
    fn box_hit(&self, o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
        let lo = DVec3::new(-0.6, -0.6, -3.5) * self.s;
        let hi = DVec3::new(0.6, 0.6, -2.5) * self.s;
        let (mut t0, mut t1, mut n) = (0.0f64, f64::INFINITY, DVec3::ZERO);
        for a in 0..3 {
            let (o_a, d_a) = (o[a], d[a]);
            if d_a.abs() < 1e-300 {
                if o_a < lo[a] || o_a > hi[a] {
                    return None;
                }
                continue;
            }
            let (mut ta, mut tb) = ((lo[a] - o_a) / d_a, (hi[a] - o_a) / d_a);
            let mut na = DVec3::ZERO;
            na[a] = -d_a.signum();
            if ta > tb {
                core::mem::swap(&mut ta, &mut tb);
            }
            if ta > t0 {
                t0 = ta;
                n = na;
            }
            t1 = t1.min(tb);
        }
        (t0 <= t1 && t0 > 0.0).then_some((t0, n))
    }

    /// First hit along `o + t d`: kind, t, normal.
    fn cast(&self, o: DVec3, d: DVec3) -> (Kind, f64, DVec3) {
        let mut best = (Kind::Sky, f64::INFINITY, DVec3::ZERO);
        if let Some((t, n)) = self.box_hit(o, d) {
            best = (Kind::Box, t, n);
        }
        if d.z < 0.0 {
            let t = (-6.0 * self.s - o.z) / d.z;
            let p = o + d * t;
            if t < best.1 && p.x.abs() <= 6.0 * self.s && p.y.abs() <= 6.0 * self.s {
                best = (Kind::Wall, t, DVec3::Z);
            }
        }
        if d.y < 0.0 {
            let t = (-1.5 * self.s - o.y) / d.y;
            let p = o + d * t;
            if t < best.1
                && p.x.abs() <= 6.0 * self.s
                && p.z >= -6.0 * self.s
                && p.z <= 30.0 * self.s
            {
                best = (Kind::Floor, t, DVec3::Y);
            }
        }
        best
    }
}

/// The smooth color a surface point carries (what a reflection pass would
/// return there, as a function of the point only).
fn shade(p: DVec3, s: f64) -> [f32; 3] {
    let p = p / s;
    [
        (0.5 + 0.4 * (1.3 * p.x).sin()) as f32,
        (0.5 + 0.4 * (0.9 * p.y + 0.3 * p.z).cos()) as f32,
        (0.5 + 0.03 * p.z) as f32,
    ]
}

/// One frame of G-buffer: stored depth (in `conv`), world normals, kinds,
/// world points and the colors the points carry.
struct Frame {
    cam: Camera,
    conv: DepthConvention,
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    kind: Vec<Kind>,
    point: Vec<DVec3>,
    color: Vec<[f32; 3]>,
}

impl Frame {
    fn new(scene: Scene, eye: Vec3, target: Vec3, conv: DepthConvention) -> Self {
        let s = scene.s as f32;
        let cam = Camera::try_look_at(eye, target, Vec3::Y, FRAC_PI_2, 0.05 * s, 100.0 * s, W, H)
            .unwrap();
        let inv = cam.inverse_view().as_dmat4();
        let e = cam.eye().as_dvec3();
        let (tx, ty) = ((FRAC_PI_2 as f64 / 2.0).tan() * W as f64 / H as f64, 1.0f64);
        let mut f = Frame {
            cam,
            conv,
            depth: vec![0.0; N],
            normals: vec![[0.0; 3]; N],
            kind: vec![Kind::Sky; N],
            point: vec![DVec3::ZERO; N],
            color: vec![[0.0; 3]; N],
        };
        let fwd = inv.transform_vector3(DVec3::NEG_Z);
        for y in 0..H {
            for x in 0..W {
                let ndc = (
                    (x as f64 + 0.5) / W as f64 * 2.0 - 1.0,
                    1.0 - (y as f64 + 0.5) / H as f64 * 2.0,
                );
                let dv = DVec3::new(ndc.0 * tx, ndc.1 * ty, -1.0);
                let d = inv.transform_vector3(dv).normalize();
                let (k, t, n) = scene.cast(e, d);
                let i = (y * W + x) as usize;
                f.kind[i] = k;
                if k == Kind::Sky {
                    f.depth[i] = match conv {
                        DepthConvention::Linear => f32::INFINITY,
                        DepthConvention::ZeroToOne => 1.0,
                        DepthConvention::ReversedZ => 0.0,
                    };
                    continue;
                }
                let p = e + d * t;
                let z = (p - e).dot(fwd);
                f.depth[i] = cam.encode_depth(z as f32, conv);
                f.normals[i] = n.as_vec3().to_array();
                f.point[i] = p;
                f.color[i] = shade(p, scene.s);
            }
        }
        f
    }

    fn gbuffer(&self) -> GBuffer<'_> {
        let depth = DepthImage::try_new(
            ImageView::try_new(&self.depth, W, H, W).unwrap(),
            self.cam,
            self.conv,
        )
        .unwrap();
        GBuffer::try_new(
            depth,
            ImageView::try_new(&self.normals, W, H, W).unwrap(),
            NormalSpace::World,
        )
        .unwrap()
    }
}

/// The frame from the origin looking at the wall, in convention `conv`.
fn front(conv: DepthConvention) -> Frame {
    Frame::new(
        Scene { s: 1.0 },
        Vec3::ZERO,
        Vec3::new(0.0, 0.0, -6.0),
        conv,
    )
}

/// Runs one frame of the filter: the next history, statuses and stats.
fn run(
    f: &Frame,
    color: &[[f32; 3]],
    answered: &[u8],
    history: Option<(&Camera, &[HistoryTexel])>,
    options: TemporalOptions,
) -> (Vec<HistoryTexel>, Vec<u8>, TemporalStats) {
    run_with(f, color, answered, None, history, options)
}

/// [`run`] with the reflection distances `distance`, if given.
fn run_with(
    f: &Frame,
    color: &[[f32; 3]],
    answered: &[u8],
    distance: Option<&[f32]>,
    history: Option<(&Camera, &[HistoryTexel])>,
    options: TemporalOptions,
) -> (Vec<HistoryTexel>, Vec<u8>, TemporalStats) {
    let hist = history
        .map(|(c, t)| History::try_new(*c, ImageView::try_new(t, W, H, W).unwrap()).unwrap());
    let mut pass = TemporalPass::try_new(
        f.gbuffer(),
        ImageView::try_new(color, W, H, W).unwrap(),
        ImageView::try_new(answered, W, H, W).unwrap(),
        hist,
        options,
    )
    .unwrap();
    if let Some(d) = distance {
        pass = pass
            .try_with_distance(ImageView::try_new(d, W, H, W).unwrap())
            .unwrap();
    }
    let mut next = vec![HistoryTexel::default(); N];
    let mut status = vec![0xA5u8; N];
    let stats = pass
        .try_run(
            &mut ImageViewMut::try_new(&mut next, W, H, W).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut status, W, H, W).unwrap()),
        )
        .unwrap();
    (next, status, stats)
}

const BLENDED: u8 = TemporalStatus::Blended as u8;
const RESET: u8 = TemporalStatus::Reset as u8;
const SKIPPED: u8 = TemporalStatus::Skipped as u8;
const RECOVERED: u8 = TemporalStatus::Recovered as u8;
const UNANSWERED: u8 = TemporalStatus::Unanswered as u8;

/// The kinds frame `f0` shows in the 3x3 texels around `q` (None where
/// any lies outside the image).
fn kinds_around(f0: &Frame, q: Vec3) -> Option<Vec<Kind>> {
    let (cx, cy) = ((q.x - 0.5).floor() as i64, (q.y - 0.5).floor() as i64);
    let mut out = Vec::new();
    for dy in -1..=2 {
        for dx in -1..=2 {
            let (x, y) = (cx + dx, cy + dy);
            if x < 0 || y < 0 || x >= W as i64 || y >= H as i64 {
                return None;
            }
            out.push(f0.kind[(y * W as i64 + x) as usize]);
        }
    }
    Some(out)
}

/// Whether the segment from `eye` to `p` passes through the box (f64).
fn hidden_by_box(scene: Scene, eye: DVec3, p: DVec3) -> bool {
    let d = p - eye;
    let len = d.length();
    scene
        .box_hit(eye, d / len)
        .is_some_and(|(t, _)| t < len * (1.0 - 1e-9))
}

/// Frame 0 from the origin, frame 1 from `1.2 s` to the right: checks the
/// disocclusion of the wall behind the box and the colors of the rest;
/// returns frame 1's statuses.
fn moving_camera_case(scene: Scene, conv: DepthConvention) -> Vec<u8> {
    let s = scene.s as f32;
    let f0 = Frame::new(scene, Vec3::ZERO, Vec3::new(0.0, 0.0, -6.0 * s), conv);
    let eye1 = Vec3::new(1.2 * s, 0.0, 0.0);
    let f1 = Frame::new(scene, eye1, eye1 + Vec3::new(0.0, 0.0, -6.0 * s), conv);
    let all = vec![1u8; N];
    let opts = TemporalOptions::default();
    let (h0, st0, stats0) = run(&f0, &f0.color, &all, None, opts);
    // The first frame: no history anywhere.
    let surfaces = f0.kind.iter().filter(|k| **k != Kind::Sky).count() as u32;
    assert_eq!(stats0.reset, surfaces);
    assert_eq!(
        st0.iter().filter(|s| **s == SKIPPED).count() as u32,
        N as u32 - surfaces
    );
    for (t, k) in h0.iter().zip(&f0.kind) {
        assert_eq!(t.frames > 0.0, *k != Kind::Sky);
    }

    let (h1, st1, stats1) = run(&f1, &f1.color, &all, Some((&f0.cam, &h0)), opts);
    let (mut disoccluded, mut kept) = (0, 0);
    for i in 0..N {
        if f1.kind[i] != Kind::Wall {
            continue;
        }
        let p = f1.point[i];
        let Some(q) = f0.cam.project(p.as_vec3()) else {
            continue;
        };
        let Some(around) = kinds_around(&f0, q) else {
            continue;
        };
        if around.iter().all(|k| *k == Kind::Box) {
            // Behind the box from the first eye: the f64 segment test
            // agrees, and the filter must not blend the box's history.
            assert!(hidden_by_box(scene, DVec3::ZERO, p), "pixel {i}");
            assert_eq!(st1[i], RESET, "pixel {i}: disoccluded wall took history");
            assert_eq!(h1[i].frames, 1.0);
            assert_eq!(h1[i].color, f1.color[i]);
            disoccluded += 1;
        } else if around.iter().all(|k| *k == Kind::Wall) {
            assert!(!hidden_by_box(scene, DVec3::ZERO, p), "pixel {i}");
            assert_eq!(st1[i], BLENDED, "pixel {i}: visible wall lost its history");
            assert_eq!(h1[i].frames, 2.0);
            // History (bilinear of the same smooth colors) and current agree
            // to the interpolation error.
            let want = shade(p, scene.s);
            for c in 0..3 {
                assert!(
                    (h1[i].color[c] - want[c]).abs() < 0.01,
                    "pixel {i}: {:?} vs {want:?}",
                    h1[i].color
                );
            }
            kept += 1;
        }
    }
    assert!(
        disoccluded >= 20,
        "only {disoccluded} disoccluded pixels checked"
    );
    assert!(kept >= 800, "only {kept} kept pixels checked");
    assert_eq!(
        stats1.blended + stats1.reset,
        f1.kind.iter().filter(|k| **k != Kind::Sky).count() as u32
    );
    assert!(stats1.rejected >= disoccluded as u32);
    st1
}

#[test]
fn a_moving_camera_rejects_the_disoccluded_wall_and_keeps_the_rest() {
    moving_camera_case(Scene { s: 1.0 }, DepthConvention::Linear);
}

#[test]
fn every_depth_convention_and_scale_gives_the_same_statuses() {
    let base = moving_camera_case(Scene { s: 1.0 }, DepthConvention::Linear);
    for conv in [DepthConvention::ZeroToOne, DepthConvention::ReversedZ] {
        let st = moving_camera_case(Scene { s: 1.0 }, conv);
        let diff = st.iter().zip(&base).filter(|(a, b)| a != b).count();
        assert!(diff <= 4, "{conv:?}: {diff} statuses differ");
    }
    for s in [1e-4, 1e4] {
        let st = moving_camera_case(Scene { s }, DepthConvention::Linear);
        let diff = st.iter().zip(&base).filter(|(a, b)| a != b).count();
        assert!(diff <= 4, "scale {s}: {diff} statuses differ");
    }
}

/// A deterministic "noisy" frame: colors in [0, 1).
fn noisy(frame: u32, i: usize) -> [f32; 3] {
    let h = refl_core::lobe::pixel_hash(frame.wrapping_mul(0x9e37_79b9) ^ i as u32);
    let r = refl_core::lobe::hash_rotation(h);
    [r.x, r.y, (r.x + r.y) * 0.5]
}

/// Runs `frames` frames of [`noisy`] colors, every pixel answered, on the
/// static frame `f` with `opts`; `check` sees each frame's number, colors,
/// next history and statuses. Returns the last history.
fn run_noisy_frames(
    f: &Frame,
    opts: TemporalOptions,
    frames: u32,
    mut check: impl FnMut(u32, &[[f32; 3]], &[HistoryTexel], &[u8]),
) -> Vec<HistoryTexel> {
    let all = vec![1u8; N];
    let mut hist: Option<Vec<HistoryTexel>> = None;
    for k in 0..frames {
        let color: Vec<[f32; 3]> = (0..N).map(|i| noisy(k, i)).collect();
        let (next, st, _) = run(
            f,
            &color,
            &all,
            hist.as_ref().map(|h| (&f.cam, h.as_slice())),
            opts,
        );
        check(k, &color, &next, &st);
        hist = Some(next);
    }
    hist.unwrap_or_default()
}

#[test]
fn a_static_camera_converges_to_the_mean_of_its_frames() {
    let f = front(DepthConvention::ReversedZ);
    for max_frames in [f32::INFINITY, 4.0] {
        // The oracle is the plain running mean: no clamping (the clamped
        // blend has its own test below).
        let opts = TemporalOptions {
            max_frames,
            clamp_history: false,
            ..TemporalOptions::default()
        };
        let mut oracle = vec![[0.0f64; 3]; N];
        let hist = run_noisy_frames(&f, opts, 12, |k, color, next, st| {
            for i in 0..N {
                if f.kind[i] == Kind::Sky {
                    assert_eq!(st[i], SKIPPED);
                    continue;
                }
                let n = (f64::from(k) + 1.0).min(f64::from(max_frames));
                for c in 0..3 {
                    oracle[i][c] += (f64::from(color[i][c]) - oracle[i][c]) / n;
                    assert!(
                        (f64::from(next[i].color[c]) - oracle[i][c]).abs() < 1e-4,
                        "max {max_frames} frame {k} pixel {i}"
                    );
                }
                assert_eq!(f64::from(next[i].frames), n);
                assert_eq!(st[i], if k == 0 { RESET } else { BLENDED });
            }
        });
        // With no cap the result is the plain mean of the 12 frames.
        if max_frames == f32::INFINITY {
            let i = (20 * W + 30) as usize;
            let mean: f64 = (0..12).map(|k| f64::from(noisy(k, i)[0])).sum::<f64>() / 12.0;
            assert!((f64::from(hist[i].color[0]) - mean).abs() < 1e-4);
        }
    }
}

/// The f64 oracle of one clamped blend at pixel `i` (module docs, step 4
/// and "History clamping"): the history clamped per channel to the range
/// of the answered, finite current colors in the 3x3 pixels around `i`
/// (the pixel's own included), then `c + (current - c) / n`.
fn clamped_blend(
    color: &[[f32; 3]],
    answered: &[u8],
    hist: [f64; 3],
    i: usize,
    n: f64,
) -> [f64; 3] {
    let (x, y) = ((i as u32 % W) as i64, (i as u32 / W) as i64);
    let mut out = [0.0f64; 3];
    for c in 0..3 {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for ny in y - 1..=y + 1 {
            for nx in x - 1..=x + 1 {
                if nx < 0 || ny < 0 || nx >= i64::from(W) || ny >= i64::from(H) {
                    continue;
                }
                let j = (ny * i64::from(W) + nx) as usize;
                if answered[j] != 0 && color[j].iter().all(|v| v.is_finite()) {
                    lo = lo.min(f64::from(color[j][c]));
                    hi = hi.max(f64::from(color[j][c]));
                }
            }
        }
        let h = hist[c].clamp(lo, hi);
        out[c] = h + (f64::from(color[i][c]) - h) / n;
    }
    out
}

#[test]
fn the_clamped_blend_matches_its_f64_oracle_and_removes_a_ghost() {
    let f = front(DepthConvention::ReversedZ);
    let all = vec![1u8; N];
    let opts = TemporalOptions::default();
    assert!(opts.clamp_history, "clamping is the default");
    let mut oracle = vec![[0.0f64; 3]; N];
    let mut clamped = 0usize;
    run_noisy_frames(&f, opts, 8, |k, color, next, st| {
        for i in (0..N).filter(|&i| f.kind[i] != Kind::Sky) {
            let n = (f64::from(k) + 1.0).min(f64::from(opts.max_frames));
            let want = if k == 0 {
                color[i].map(f64::from)
            } else {
                let unclamped: Vec<f64> = (0..3)
                    .map(|c| oracle[i][c] + (f64::from(color[i][c]) - oracle[i][c]) / n)
                    .collect();
                let w = clamped_blend(color, &all, oracle[i], i, n);
                clamped += usize::from((0..3).any(|c| (w[c] - unclamped[c]).abs() > 1e-3));
                w
            };
            for c in 0..3 {
                assert!(
                    (f64::from(next[i].color[c]) - want[c]).abs() < 1e-5,
                    "frame {k} pixel {i} channel {c}: {} against {}",
                    next[i].color[c],
                    want[c]
                );
            }
            assert_eq!(st[i], if k == 0 { RESET } else { BLENDED });
            oracle[i] = want;
        }
    });
    // The noise varies per pixel, so the clamp acts on many blends; a test
    // where it never acted would not test it.
    // (2,519 of the 7 x 2,940 blends here.)
    assert!(clamped > N / 2, "the clamp changed only {clamped} blends");

    // A ghost: eight frames of red history where this frame is green on a
    // whole region. Clamped, the green region is green at once; without
    // the clamp it keeps 7/8 of the red.
    let red = [1.0f32, 0.0, 0.0];
    let green = [0.0f32, 1.0, 0.0];
    let (h0, _, _) = run(
        &f,
        &vec![red; N],
        &all,
        None,
        TemporalOptions {
            max_frames: 1.0,
            ..opts
        },
    );
    let ghost: Vec<HistoryTexel> = h0
        .iter()
        .map(|t| HistoryTexel {
            frames: if t.frames > 0.0 { 8.0 } else { 0.0 },
            ..*t
        })
        .collect();
    let i = (24 * W + 32) as usize;
    assert_eq!(f.kind[i], Kind::Box);
    for (clamp, want) in [(true, green), (false, [1.0 - 1.0 / 8.0, 1.0 / 8.0, 0.0])] {
        let o = TemporalOptions {
            clamp_history: clamp,
            ..opts
        };
        let (next, st, _) = run(&f, &vec![green; N], &all, Some((&f.cam, &ghost)), o);
        assert_eq!(st[i], BLENDED);
        for c in 0..3 {
            assert!(
                (next[i].color[c] - want[c]).abs() < 1e-6,
                "clamp {clamp}: {:?}",
                next[i].color
            );
        }
    }
}

#[test]
fn failed_pixels_take_the_history_and_unanswered_ones_are_not_history() {
    let f = front(DepthConvention::ZeroToOne);
    let all = vec![1u8; N];
    let opts = TemporalOptions::default();
    let (h0, _, _) = run(&f, &f.color, &all, None, opts);
    // Frame 1: rows 10..20 failed; their "current" color is the host's
    // fallback (magenta).
    let mut answered = all.clone();
    let mut color = f.color.clone();
    for i in (10 * W as usize)..(20 * W as usize) {
        answered[i] = 0;
        color[i] = [1.0, 0.0, 1.0];
    }
    let (h1, st1, stats1) = run(&f, &color, &answered, Some((&f.cam, &h0)), opts);
    let (mut h1_off, st1_off, _) = run(
        &f,
        &color,
        &answered,
        Some((&f.cam, &h0)),
        TemporalOptions {
            recover: false,
            ..opts
        },
    );
    let mut failed = 0;
    for i in (10 * W as usize)..(20 * W as usize) {
        if f.kind[i] == Kind::Sky {
            continue;
        }
        failed += 1;
        assert_eq!(st1[i], RECOVERED);
        // A static camera re-projects to the texel center up to f32
        // rounding (bilinear weights of ~1e-5 on the neighbours).
        for c in 0..3 {
            assert!((h1[i].color[c] - f.color[i][c]).abs() < 1e-4, "pixel {i}");
        }
        assert_eq!(h1[i].frames, 1.0);
        assert_eq!(st1_off[i], UNANSWERED);
        assert_eq!(h1_off[i].color, [1.0, 0.0, 1.0]);
        assert_eq!(h1_off[i].frames, 0.0);
    }
    assert_eq!(stats1.recovered, failed);
    // Frame 2 after the unrecovered frame: those pixels have no history
    // (their own texel is empty, and a static camera reads no neighbour).
    let (_, st2, _) = run(&f, &f.color, &all, Some((&f.cam, &h1_off)), opts);
    for i in (10 * W as usize)..(20 * W as usize) {
        if f.kind[i] != Kind::Sky {
            assert_eq!(st2[i], RESET, "pixel {i}");
        }
    }
    // A non-finite current color counts as not answered.
    color[(30 * W + 30) as usize] = [f32::NAN, 0.0, 0.0];
    let (h3, st3, _) = run(&f, &color, &all, Some((&f.cam, &h0)), opts);
    assert_eq!(st3[(30 * W + 30) as usize], RECOVERED);
    assert!(Vec3::from_array(h3[(30 * W + 30) as usize].color).is_finite());
    // History texels that are not finite are no history.
    h1_off[(30 * W + 31) as usize].color = [f32::INFINITY, 0.0, 0.0];
    h1_off[(30 * W + 32) as usize].frames = f32::NAN;
    let (_, st4, _) = run(&f, &f.color, &all, Some((&f.cam, &h1_off)), opts);
    assert_eq!(st4[(30 * W + 31) as usize], RESET);
    assert_eq!(st4[(30 * W + 32) as usize], RESET);
}

/// A failed pixel recovered from history written with a larger
/// `max_frames` (the host lowered it, or wrote the history itself) keeps
/// the history's color but caps its frame count at this frame's
/// `max_frames`, the range `HistoryTexel::frames` documents. Fuzz finding
/// F30 (`fuzz/README.md`): the recovered texel took the history's count, 8
/// frames under `max_frames = 2`.
#[test]
fn recovered_frame_counts_are_capped_at_max_frames() {
    let f = front(DepthConvention::Linear);
    let all = vec![1u8; N];
    let (mut h0, _, _) = run(&f, &f.color, &all, None, TemporalOptions::default());
    for t in h0.iter_mut().filter(|t| t.frames > 0.0) {
        t.frames = 8.0;
    }
    let mut answered = all.clone();
    let failed: Vec<usize> = (0..N)
        .filter(|&i| f.kind[i] != Kind::Sky && i % 5 == 0)
        .collect();
    for &i in &failed {
        answered[i] = 0;
    }
    for (max_frames, want) in [(2.0, 2.0), (8.0, 8.0), (f32::INFINITY, 8.0), (1.0, 1.0)] {
        let opts = TemporalOptions {
            max_frames,
            ..TemporalOptions::default()
        };
        let (h1, st1, stats) = run(&f, &f.color, &answered, Some((&f.cam, &h0)), opts);
        assert_eq!(
            stats.recovered as usize,
            failed.len(),
            "max_frames {max_frames}"
        );
        for &i in &failed {
            assert_eq!(st1[i], RECOVERED, "pixel {i}");
            assert_eq!(h1[i].frames, want, "pixel {i}, max_frames {max_frames}");
            // The color is the history's (a static camera reads the texel
            // itself, up to bilinear weights of f32 rounding).
            for c in 0..3 {
                assert!((h1[i].color[c] - h0[i].color[c]).abs() < 1e-4, "pixel {i}");
            }
        }
        assert!(
            h1.iter().all(|t| t.frames <= max_frames),
            "max_frames {max_frames}"
        );
    }
}

#[test]
fn the_normal_test_rejects_a_turned_surface_that_depth_alone_keeps() {
    let f0 = front(DepthConvention::Linear);
    let mut f1 = front(DepthConvention::Linear);
    // Same depths; the left half's normals turned by 60 degrees.
    let turned = Vec3::new((60f32).to_radians().sin(), 0.0, (60f32).to_radians().cos());
    for y in 0..H {
        for x in 0..W / 2 {
            let i = (y * W + x) as usize;
            if f1.kind[i] == Kind::Wall {
                f1.normals[i] = turned.to_array();
            }
        }
    }
    let all = vec![1u8; N];
    let (h0, _, _) = run(&f0, &f0.color, &all, None, TemporalOptions::default());
    let (_, st, _) = run(
        &f1,
        &f1.color,
        &all,
        Some((&f0.cam, &h0)),
        TemporalOptions::default(),
    );
    let depth_only = TemporalOptions {
        normal_cos: -1.0,
        ..TemporalOptions::default()
    };
    let (_, st_d, _) = run(&f1, &f1.color, &all, Some((&f0.cam, &h0)), depth_only);
    let mut n = 0;
    for y in 0..H {
        for x in 0..W / 2 {
            let i = (y * W + x) as usize;
            if f1.kind[i] == Kind::Wall {
                // The turned plane through the point: the texel's own point
                // lies on the old plane, at the same spot (static camera).
                assert_eq!(st[i], RESET, "pixel {x} {y}");
                assert_eq!(st_d[i], BLENDED, "pixel {x} {y}");
                n += 1;
            }
        }
    }
    assert!(n > 500);
}

#[test]
fn a_grazing_floor_keeps_its_history_under_motion() {
    // The floor seen at a few degrees: its depth changes by far more than
    // the 2% tolerance from one texel to the next, yet every texel lies on
    // the same plane.
    let scene = Scene { s: 1.0 };
    let eye0 = Vec3::new(0.0, -1.3, 0.0);
    let eye1 = Vec3::new(0.05, -1.3, -0.1);
    let f0 = Frame::new(
        scene,
        eye0,
        eye0 + Vec3::new(0.0, -0.05, -1.0),
        DepthConvention::ReversedZ,
    );
    let f1 = Frame::new(
        scene,
        eye1,
        eye1 + Vec3::new(0.0, -0.05, -1.0),
        DepthConvention::ReversedZ,
    );
    let all = vec![1u8; N];
    let (h0, _, _) = run(&f0, &f0.color, &all, None, TemporalOptions::default());
    let (h1, st, _) = run(
        &f1,
        &f1.color,
        &all,
        Some((&f0.cam, &h0)),
        TemporalOptions::default(),
    );
    let (mut floor, mut steep) = (0, 0);
    for i in 0..N {
        if f1.kind[i] != Kind::Floor {
            continue;
        }
        let Some(q) = f0.cam.project(f1.point[i].as_vec3()) else {
            continue;
        };
        let Some(around) = kinds_around(&f0, q) else {
            continue;
        };
        if !around.iter().all(|k| *k == Kind::Floor) {
            continue;
        }
        assert_eq!(st[i], BLENDED, "floor pixel {i}");
        let want = shade(f1.point[i], 1.0);
        assert!((h1[i].color[0] - want[0]).abs() < 0.05, "pixel {i}");
        floor += 1;
        // The depth step to the next row, relative.
        let below = i + W as usize;
        if below < N && f0.kind[below] == Kind::Floor {
            let z = |f: &Frame, j: usize| f.cam.decode_depth(f.depth[j], f.conv);
            if (z(&f1, i) - z(&f1, below)).abs() > 0.02 * z(&f1, i) {
                steep += 1;
            }
        }
    }
    assert!(floor > 100, "{floor}");
    assert!(steep > 50, "the case is not grazing: {steep}");
}

#[test]
fn a_point_behind_or_outside_the_last_view_has_no_history() {
    let scene = Scene { s: 1.0 };
    let f0 = front(DepthConvention::Linear);
    // Behind the first eye, looking the other way: the floor it sees lies
    // behind the first camera.
    let f1 = Frame::new(
        scene,
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.0, -0.3, 5.0),
        DepthConvention::Linear,
    );
    let all = vec![1u8; N];
    let (h0, _, _) = run(&f0, &f0.color, &all, None, TemporalOptions::default());
    let (_, st, stats) = run(
        &f1,
        &f1.color,
        &all,
        Some((&f0.cam, &h0)),
        TemporalOptions::default(),
    );
    let surfaces = f1.kind.iter().filter(|k| **k != Kind::Sky).count() as u32;
    assert_eq!(stats.blended, 0);
    assert_eq!(stats.reset, surfaces);
    assert!(st.iter().all(|s| *s == RESET || *s == SKIPPED));
    assert!(surfaces > 100);
    assert_eq!(stats.off_screen, surfaces);
}

#[test]
fn bands_equal_one_call_and_errors_leave_outputs_untouched() {
    let scene = Scene { s: 1.0 };
    let f0 = front(DepthConvention::Linear);
    let eye1 = Vec3::new(0.2, 0.1, 0.0);
    let f1 = Frame::new(
        scene,
        eye1,
        eye1 + Vec3::new(0.0, 0.0, -6.0),
        DepthConvention::Linear,
    );
    let all = vec![1u8; N];
    let (h0, _, _) = run(&f0, &f0.color, &all, None, TemporalOptions::default());
    let (whole, whole_st, whole_stats) = run(
        &f1,
        &f1.color,
        &all,
        Some((&f0.cam, &h0)),
        TemporalOptions::default(),
    );

    let hist = History::try_new(f0.cam, ImageView::try_new(&h0, W, H, W).unwrap()).unwrap();
    let pass = TemporalPass::try_new(
        f1.gbuffer(),
        ImageView::try_new(&f1.color, W, H, W).unwrap(),
        ImageView::try_new(&all, W, H, W).unwrap(),
        Some(hist),
        TemporalOptions::default(),
    )
    .unwrap();
    let mut next = vec![HistoryTexel::default(); N];
    let mut stats = TemporalStats::default();
    let (a, b) = next.split_at_mut((17 * W) as usize);
    for (data, rows) in [(a, (0, 17)), (b, (17, H))] {
        let rows = RowRange::try_new(rows.0, rows.1, H).unwrap();
        let mut band = ImageViewMut::try_band(data, W, H, W, rows).unwrap();
        let s = pass.try_run(&mut band, None).unwrap();
        stats.blended += s.blended;
        stats.reset += s.reset;
        stats.rejected += s.rejected;
        stats.off_screen += s.off_screen;
    }
    assert_eq!(next, whole);
    assert_eq!(
        (stats.blended, stats.reset),
        (whole_stats.blended, whole_stats.reset)
    );
    assert_eq!(
        (stats.rejected, stats.off_screen),
        (whole_stats.rejected, whole_stats.off_screen)
    );
    for y in 0..H {
        for x in 0..W {
            let (t, s) = pass.pixel(x, y);
            let i = (y * W + x) as usize;
            assert_eq!((t, s as u8), (whole[i], whole_st[i]));
        }
    }
    let mut rows_seen = 0;
    pass.try_run_rows(RowRange::try_new(5, 9, H).unwrap(), &mut |x, y, t, _| {
        assert_eq!(*t, whole[(y * W + x) as usize]);
        rows_seen += 1;
    })
    .unwrap();
    assert_eq!(rows_seen, 4 * W);
    assert_eq!(
        pass.try_run_rows(
            RowRange::try_new(0, H + 1, H + 1).unwrap(),
            &mut |_, _, _, _| {}
        ),
        Err(Error::InvalidArgument)
    );

    // Refusals: wrong sizes and options, outputs untouched.
    let small = vec![[0.0f32; 3]; N / 2];
    let small_u8 = vec![1u8; N / 2];
    let small_hist = vec![HistoryTexel::default(); N / 2];
    let g = f1.gbuffer();
    let color = ImageView::try_new(&f1.color, W, H, W).unwrap();
    let ans = ImageView::try_new(&all, W, H, W).unwrap();
    let bad_color = ImageView::try_new(&small, W, H / 2, W).unwrap();
    let bad_ans = ImageView::try_new(&small_u8, W, H / 2, W).unwrap();
    let half_cam =
        Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 0.1, 10.0, W, H / 2).unwrap();
    let bad_hist = History::try_new(
        half_cam,
        ImageView::try_new(&small_hist, W, H / 2, W).unwrap(),
    )
    .unwrap();
    let opts = TemporalOptions::default();
    assert_eq!(
        TemporalPass::try_new(g, bad_color, ans, None, opts).err(),
        Some(Error::InvalidArgument)
    );
    assert_eq!(
        TemporalPass::try_new(g, color, bad_ans, None, opts).err(),
        Some(Error::InvalidArgument)
    );
    assert_eq!(
        TemporalPass::try_new(g, color, ans, Some(bad_hist), opts).err(),
        Some(Error::InvalidArgument)
    );
    assert_eq!(
        History::try_new(
            f0.cam,
            ImageView::try_new(&small_hist, W, H / 2, W).unwrap()
        )
        .err(),
        Some(Error::InvalidArgument)
    );
    for bad in [
        TemporalOptions {
            max_frames: 0.5,
            ..opts
        },
        TemporalOptions {
            max_frames: f32::NAN,
            ..opts
        },
        TemporalOptions {
            depth_tolerance: -0.1,
            ..opts
        },
        TemporalOptions {
            depth_tolerance: f32::INFINITY,
            ..opts
        },
        TemporalOptions {
            normal_cos: 1.5,
            ..opts
        },
        TemporalOptions {
            normal_cos: f32::NAN,
            ..opts
        },
    ] {
        assert_eq!(bad.try_validate(), Err(Error::InvalidArgument), "{bad:?}");
        assert_eq!(
            TemporalPass::try_new(g, color, ans, None, bad).err(),
            Some(Error::InvalidArgument)
        );
    }
    let sentinel = HistoryTexel {
        color: [7.0; 3],
        frames: 7.0,
        normal: [7.0; 3],
        depth: 7.0,
        distance: 7.0,
    };
    let mut out = vec![sentinel; N];
    let mut wrong = vec![sentinel; N / 2];
    assert_eq!(
        pass.try_run(
            &mut ImageViewMut::try_new(&mut wrong, W, H / 2, W).unwrap(),
            None
        ),
        Err(Error::InvalidArgument)
    );
    assert!(wrong.iter().all(|t| *t == sentinel));
    let mut st_small = vec![9u8; N / 2];
    assert_eq!(
        pass.try_run(
            &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut st_small, W, H / 2, W).unwrap())
        ),
        Err(Error::InvalidArgument)
    );
    assert!(out.iter().all(|t| *t == sentinel));
    assert!(st_small.iter().all(|s| *s == 9));
    assert_eq!(
        pass.pixel(W, 0),
        (HistoryTexel::default(), TemporalStatus::Skipped)
    );
}

#[test]
fn masked_pixels_and_pixels_without_a_surface_empty_the_history() {
    let f = front(DepthConvention::Linear);
    let all = vec![1u8; N];
    let (h0, _, _) = run(&f, &f.color, &all, None, TemporalOptions::default());
    let mut mask = vec![1u8; N];
    mask[..W as usize].fill(0);
    let g = f
        .gbuffer()
        .try_with_mask(ImageView::try_new(&mask, W, H, W).unwrap())
        .unwrap();
    let hist = History::try_new(f.cam, ImageView::try_new(&h0, W, H, W).unwrap()).unwrap();
    let pass = TemporalPass::try_new(
        g,
        ImageView::try_new(&f.color, W, H, W).unwrap(),
        ImageView::try_new(&all, W, H, W).unwrap(),
        Some(hist),
        TemporalOptions::default(),
    )
    .unwrap();
    for x in 0..W {
        let (t, s) = pass.pixel(x, 0);
        assert_eq!(s, TemporalStatus::Skipped);
        assert_eq!(t.frames, 0.0);
        assert_eq!(
            t.color, f.color[x as usize],
            "the current color passes through"
        );
    }
    for i in 0..N {
        if f.kind[i] == Kind::Sky {
            let (x, y) = (i as u32 % W, i as u32 / W);
            assert_eq!(pass.pixel(x, y).1, TemporalStatus::Skipped);
        }
    }
}

/// The floor as a mirror: per pixel of `f`, the reflected ray's hit kind,
/// its color (the smooth color of the hit point) and its distance `t`.
fn floor_reflections(scene: Scene, f: &Frame) -> (Vec<Kind>, Vec<[f32; 3]>, Vec<f32>) {
    let e = f.cam.eye().as_dvec3();
    let (mut kind, mut color, mut dist) = (vec![Kind::Sky; N], vec![[0.0; 3]; N], vec![0.0; N]);
    for i in 0..N {
        if f.kind[i] != Kind::Floor {
            continue;
        }
        let p = f.point[i];
        let d = (p - e).normalize();
        let r = d - 2.0 * d.dot(DVec3::Y) * DVec3::Y;
        let (k, t, _) = scene.cast(p + r * 1e-9, r);
        kind[i] = k;
        if k == Kind::Sky {
            color[i] = [0.2, 0.3, 0.9];
            dist[i] = f32::INFINITY;
        } else {
            color[i] = shade(p + r * t, scene.s);
            dist[i] = t as f32;
        }
    }
    (kind, color, dist)
}

#[test]
fn reflection_distances_re_project_a_mirrors_reflection_without_lag() {
    // The floor is a mirror reflecting the wall; the camera moves up and
    // sideways. The reflection moves against the floor (parallax): the
    // floor point's history holds another part of the wall, the virtual
    // point's holds the same one.
    let scene = Scene { s: 1.0 };
    let eye0 = Vec3::new(0.0, -0.4, 0.0);
    let eye1 = Vec3::new(0.15, -0.25, -0.05);
    let dir = Vec3::new(0.0, -0.35, -1.0);
    let f0 = Frame::new(scene, eye0, eye0 + dir, DepthConvention::ReversedZ);
    let f1 = Frame::new(scene, eye1, eye1 + dir, DepthConvention::ReversedZ);
    let (k0, c0, t0) = floor_reflections(scene, &f0);
    let (k1, c1, t1) = floor_reflections(scene, &f1);
    let answered: Vec<u8> = f0
        .kind
        .iter()
        .map(|k| u8::from(*k == Kind::Floor))
        .collect();
    let answered1: Vec<u8> = f1
        .kind
        .iter()
        .map(|k| u8::from(*k == Kind::Floor))
        .collect();
    let opts = TemporalOptions::default();
    let run_d = |f: &Frame,
                 c: &[[f32; 3]],
                 a: &[u8],
                 t: &[f32],
                 hist: Option<(&Camera, &[HistoryTexel])>,
                 with_distance: bool| {
        let (next, st, _) = run_with(f, c, a, with_distance.then_some(t), hist, opts);
        (next, st)
    };
    let (h0d, _) = run_d(&f0, &c0, &answered, &t0, None, true);
    let (h0s, _) = run_d(&f0, &c0, &answered, &t0, None, false);
    for i in 0..N {
        if f0.kind[i] == Kind::Floor {
            assert_eq!(h0d[i].distance, t0[i]);
            assert_eq!(h0s[i].distance, 0.0, "no distance image: unknown");
        }
    }
    let (h1d, s1d) = run_d(&f1, &c1, &answered1, &t1, Some((&f0.cam, &h0d)), true);
    let (h1s, s1s) = run_d(&f1, &c1, &answered1, &t1, Some((&f0.cam, &h0s)), false);
    let (mut n, mut err_d, mut err_s) = (0, 0.0f64, 0.0f64);
    for i in 0..N {
        if f1.kind[i] != Kind::Floor || k1[i] != Kind::Wall {
            continue;
        }
        // The virtual point's pixel in frame 0, and a clean neighbourhood
        // there: floor reflecting the wall.
        let e1 = f1.cam.eye().as_dvec3();
        let p = f1.point[i];
        let v = p - e1;
        let virt = e1 + v * ((v.length() + f64::from(t1[i])) / v.length());
        let Some(q) = f0.cam.project(virt.as_vec3()) else {
            continue;
        };
        let Some(around) = kinds_around(&f0, q) else {
            continue;
        };
        let (cx, cy) = ((q.x - 0.5).floor() as i64, (q.y - 0.5).floor() as i64);
        let clean = around.iter().all(|k| *k == Kind::Floor)
            && (-1..=2).all(|dy| {
                (-1..=2).all(|dx| k0[((cy + dy) * W as i64 + cx + dx) as usize] == Kind::Wall)
            });
        if !clean {
            continue;
        }
        assert_eq!(s1d[i], BLENDED, "pixel {i}");
        n += 1;
        for c in 0..3 {
            err_d += f64::from((h1d[i].color[c] - c1[i][c]).abs());
            err_s += f64::from((h1s[i].color[c] - c1[i][c]).abs());
        }
        assert!(
            (0..3).all(|c| (h1d[i].color[c] - c1[i][c]).abs() < 0.02),
            "pixel {i}: {:?} vs {:?}",
            h1d[i].color,
            c1[i]
        );
        let _ = s1s[i];
    }
    assert!(n >= 200, "only {n} clean pixels");
    let (err_d, err_s) = (err_d / (3.0 * n as f64), err_s / (3.0 * n as f64));
    assert!(
        err_s > 4.0 * err_d,
        "surface re-projection {err_s:.4} vs virtual {err_d:.4}"
    );

    // Failed pixels (every other clean floor pixel) have no distance this
    // frame: they take the one the history holds where their surface was,
    // and recover the same wall point's color.
    let mut failed = answered1.clone();
    let mut fallback = c1.clone();
    let mut targets = Vec::new();
    for i in (0..N).step_by(2) {
        if s1d[i] == BLENDED && k1[i] == Kind::Wall {
            failed[i] = 0;
            fallback[i] = [1.0, 0.0, 1.0];
            targets.push(i);
        }
    }
    let (h1f, s1f) = run_d(&f1, &fallback, &failed, &t1, Some((&f0.cam, &h0d)), true);
    let (mut recovered, mut close) = (0, 0);
    for &i in &targets {
        if s1f[i] != RECOVERED {
            continue;
        }
        recovered += 1;
        assert!(h1f[i].distance > 0.0, "pixel {i}: {:?}", h1f[i]);
        if (0..3).all(|c| (h1f[i].color[c] - c1[i][c]).abs() < 0.03) {
            close += 1;
        }
    }
    let m = targets.len();
    assert!(m >= 100, "{m} targets");
    // Some lose their history at the failed pixels' own silhouettes
    // (MIN_RECOVERY_WEIGHT); those recovered carry the true reflection.
    assert!(recovered * 4 >= m * 3, "{recovered} of {m} recovered");
    assert!(
        close * 10 >= recovered * 9,
        "{close} of {recovered} close to the true reflection"
    );

    // The sky: a reflection of the sky is re-projected at infinity and kept
    // only by history of the sky.
    let sky = vec![f32::INFINITY; N];
    let sky_color = vec![[0.2f32, 0.3, 0.9]; N];
    let (hs0, _) = run_d(&f0, &sky_color, &answered, &sky, None, true);
    let (hs1, ss1) = run_d(
        &f1,
        &sky_color,
        &answered1,
        &sky,
        Some((&f0.cam, &hs0)),
        true,
    );
    let (_, sx1) = run_d(
        &f1,
        &sky_color,
        &answered1,
        &t1,
        Some((&f0.cam, &hs0)),
        true,
    );
    let floor1: Vec<usize> = (0..N).filter(|&i| f1.kind[i] == Kind::Floor).collect();
    let blended = floor1.iter().filter(|&&i| ss1[i] == BLENDED).count();
    assert!(
        blended * 10 >= floor1.len() * 8,
        "{blended} of {}",
        floor1.len()
    );
    assert!(floor1.iter().all(|&i| hs1[i].distance == f32::INFINITY));
    // Finite distances against a history of the sky: rejected.
    assert!(
        floor1
            .iter()
            .all(|&i| !t1[i].is_finite() || sx1[i] != BLENDED),
        "sky history blended into a wall reflection"
    );
    // A distance image of another size is refused.
    let short = vec![0.0f32; N / 2];
    let pass = TemporalPass::try_new(
        f1.gbuffer(),
        ImageView::try_new(&c1, W, H, W).unwrap(),
        ImageView::try_new(&answered1, W, H, W).unwrap(),
        None,
        opts,
    )
    .unwrap();
    assert_eq!(
        pass.try_with_distance(ImageView::try_new(&short, W, H / 2, W).unwrap())
            .err(),
        Some(Error::InvalidArgument)
    );
}
