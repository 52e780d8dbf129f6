//! Fewer rays (`refl_core::upsample`, seed 004 Sec. 4.7.3-4.7.4): the
//! sampling patterns, the half pass against the full mirror pass, and the
//! cross-bilateral reconstruction against an f64 re-computation of its
//! documented weights (Kopf et al. 2007 Eq. 2 with the depth-edge cut) on
//! synthetic G-buffers whose depth and normals the test knows exactly; a
//! mirror floor against the closed-form reflection; four frames of the
//! cycled pattern through the temporal filter against the full pass.
#![cfg(all(feature = "depth-image", feature = "hiz"))]
#![allow(clippy::needless_range_loop)] // pixel indices address several images at once

mod common;
#[path = "common/scene.rs"]
mod scene;

use core::f32::consts::FRAC_PI_2;
use proptest::prelude::*;
use refl_core::glam::{DMat4, DVec2, DVec3, Vec2, Vec3};
use refl_core::temporal::{History, HistoryTexel, TemporalOptions, TemporalPass};
use refl_core::upsample::{
    frame_sub_pixel, try_half_len, try_half_size, HalfPass, Pattern, SubPixel, Subsample,
    UpsampleOptions, UpsamplePass, UpsampleSink, UpsampleStats, UpsampleStatus, FRAME_CYCLE,
};
use refl_core::{
    Camera, DepthConvention, DepthImage, Error, GBuffer, HostRay, ImageView, ImageViewMut,
    MirrorMethod, MirrorOptions, MirrorPass, MirrorSink, MirrorStats, MirrorStatus, MirrorTexel,
    NormalSpace, RowRange,
};

// ------------------------------------------------------------ patterns

/// The traced pixel of block `(bx, by)` as the docs define it, derived
/// here on its own: the cycle top-left, bottom-right, top-right,
/// bottom-left; the staggered pattern mirrors the column on odd block
/// rows; clamped into the image.
fn oracle_traced(pattern: Pattern, frame: u32, bx: u32, by: u32, w: u32, h: u32) -> (u32, u32) {
    const CYCLE: [(u32, u32); 4] = [(0, 0), (1, 1), (1, 0), (0, 1)];
    let (mut sx, sy) = CYCLE[(frame % 4) as usize];
    if pattern == Pattern::Staggered && by % 2 == 1 {
        sx = 1 - sx;
    }
    ((2 * bx + sx).min(w - 1), (2 * by + sy).min(h - 1))
}

#[test]
fn four_frames_trace_every_pixel_once_and_staggering_samples_every_column() {
    assert_eq!(
        FRAME_CYCLE.map(|s| (s.x, s.y)),
        [(0, 0), (1, 1), (1, 0), (0, 1)]
    );
    assert_eq!(frame_sub_pixel(u32::MAX), SubPixel { x: 0, y: 1 });
    for pattern in [Pattern::Uniform, Pattern::Staggered] {
        for (w, h) in [(8, 8), (9, 7), (1, 5), (6, 1), (1, 1), (12, 16)] {
            let (hw, hh) = try_half_size(w, h).unwrap();
            assert_eq!((hw, hh), (w.div_ceil(2), h.div_ceil(2)));
            assert_eq!(try_half_len(w, h).unwrap(), (hw * hh) as usize);
            for start in [0u32, 1, 2, 3, 1000, u32::MAX - 1] {
                let mut count = vec![0u32; (w * h) as usize];
                for f in 0..4u32 {
                    let sub = Subsample {
                        pattern,
                        frame: start.wrapping_add(f),
                    };
                    for by in 0..hh {
                        for bx in 0..hw {
                            let (x, y) = sub.traced_pixel(bx, by, w, h).unwrap();
                            assert_eq!(
                                (x, y),
                                oracle_traced(pattern, sub.frame, bx, by, w, h),
                                "{pattern:?} frame {} block ({bx}, {by}) of {w}x{h}",
                                sub.frame
                            );
                            assert_eq!((x / 2, y / 2), (bx, by), "inside its block");
                            assert!(sub.is_traced(x, y, w, h));
                            count[(y * w + x) as usize] += 1;
                        }
                    }
                    assert_eq!(sub.traced_pixel(hw, 0, w, h), None);
                    assert_eq!(sub.traced_pixel(0, hh, w, h), None);
                    // One traced pixel per block.
                    let traced = (0..h)
                        .flat_map(|y| (0..w).map(move |x| (x, y)))
                        .filter(|&(x, y)| sub.is_traced(x, y, w, h))
                        .count();
                    assert_eq!(traced as u32, hw * hh);
                }
                // Four consecutive frames: every pixel of a full block once.
                for y in 0..h - h % 2 {
                    for x in 0..w - w % 2 {
                        assert_eq!(count[(y * w + x) as usize], 1, "({x}, {y}) {w}x{h}");
                    }
                }
            }
        }
    }
    // Staggered: the traced pixels of two consecutive block rows cover
    // every column; the uniform grid's cover every other one.
    for frame in 0..4 {
        for (pattern, columns) in [(Pattern::Staggered, 16), (Pattern::Uniform, 8)] {
            let sub = Subsample { pattern, frame };
            for by in [0u32, 2, 5] {
                let mut cols = [false; 16];
                for y in 2 * by..2 * by + 4 {
                    for x in 0..16 {
                        if sub.is_traced(x, y, 16, 16) {
                            cols[x as usize] = true;
                        }
                    }
                }
                assert_eq!(
                    cols.iter().filter(|&&c| c).count(),
                    columns,
                    "{pattern:?} {frame}"
                );
            }
        }
    }
    assert_eq!(try_half_size(0, 4), Err(Error::InvalidArgument));
    assert_eq!(try_half_len(4, 0), Err(Error::InvalidArgument));
    assert_eq!(try_half_size(u32::MAX, 1).unwrap(), (1 << 31, 1));
}

// ------------------------------------------- synthetic G-buffer: plates

/// Two planes seen from the origin looking down -Z (view space is world
/// space): plane A facing the camera at depth `za`, plane B through
/// `(0, 0, -zb)` tilted by `tilt` about the x axis (normal `(0, sin,
/// cos)`); a pixel sees A where `cos(angle) (x + 0.5 - w/2) + sin(angle)
/// (y + 0.5 - h/2) < offset`, else B. Everything in f64, stored in f32.
#[derive(Clone, Copy, Debug)]
struct PlatesSpec {
    w: u32,
    h: u32,
    scale: f64,
    za: f64,
    /// Relative step: `zb = za (1 + step)`.
    step: f64,
    tilt: f64,
    angle: f64,
    offset: f64,
}

struct Plates {
    spec: PlatesSpec,
    cam: Camera,
    conv: DepthConvention,
    /// Linear depth per pixel (f64 truth).
    z: Vec<f64>,
    /// Unit normal per pixel.
    n: Vec<DVec3>,
    /// 0 for plane A, 1 for B.
    plane: Vec<u8>,
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    /// The lit color of each pixel (for hit shading).
    lit: Vec<[f32; 3]>,
}

/// The view-space ray `(ndc_x tan_x, ndc_y tan_y, -1)` through the center
/// of pixel `(x, y)`, in f64.
fn pixel_ray(cam: &Camera, x: f64, y: f64) -> DVec3 {
    let (w, h) = (f64::from(cam.width()), f64::from(cam.height()));
    let ty = (f64::from(cam.fov_y()) * 0.5).tan();
    let tx = ty * w / h;
    DVec3::new(
        (2.0 * (x + 0.5) / w - 1.0) * tx,
        (1.0 - 2.0 * (y + 0.5) / h) * ty,
        -1.0,
    )
}

impl Plates {
    fn new(spec: PlatesSpec, conv: DepthConvention) -> Self {
        let s = spec.scale;
        let cam = Camera::try_look_at(
            Vec3::ZERO,
            Vec3::NEG_Z,
            Vec3::Y,
            FRAC_PI_2,
            (0.05 * s) as f32,
            (100.0 * s) as f32,
            spec.w,
            spec.h,
        )
        .unwrap();
        let n_px = (spec.w * spec.h) as usize;
        let mut p = Plates {
            spec,
            cam,
            conv,
            z: vec![0.0; n_px],
            n: vec![DVec3::Z; n_px],
            plane: vec![0; n_px],
            depth: vec![0.0; n_px],
            normals: vec![[0.0; 3]; n_px],
            lit: vec![[0.0; 3]; n_px],
        };
        let (za, zb) = (spec.za * s, spec.za * (1.0 + spec.step) * s);
        let nb = DVec3::new(0.0, spec.tilt.sin(), spec.tilt.cos());
        for y in 0..spec.h {
            for x in 0..spec.w {
                let i = (y * spec.w + x) as usize;
                let a = pixel_ray(&cam, f64::from(x), f64::from(y));
                let side = spec.angle.cos() * (f64::from(x) + 0.5 - f64::from(spec.w) / 2.0)
                    + spec.angle.sin() * (f64::from(y) + 0.5 - f64::from(spec.h) / 2.0);
                let (z, n, plane) = if side < spec.offset {
                    (za, DVec3::Z, 0)
                } else {
                    // n . (z a) = n . (0, 0, -zb).
                    (-zb * nb.z / nb.dot(a), nb, 1)
                };
                p.z[i] = z;
                p.n[i] = n;
                p.plane[i] = plane;
                p.depth[i] = cam.encode_depth(z as f32, conv);
                p.normals[i] = n.as_vec3().to_array();
                p.lit[i] = [x as f32, y as f32, 7.0];
            }
        }
        p
    }

    fn gbuffer(&self, lit: bool) -> GBuffer<'_> {
        let (w, h) = (self.spec.w, self.spec.h);
        let d = DepthImage::try_new(
            ImageView::try_new(&self.depth, w, h, w).unwrap(),
            self.cam,
            self.conv,
        )
        .unwrap();
        let g = GBuffer::try_new(
            d,
            ImageView::try_new(&self.normals, w, h, w).unwrap(),
            NormalSpace::World,
        )
        .unwrap();
        if lit {
            g.try_with_color(ImageView::try_new(&self.lit, w, h, w).unwrap())
                .unwrap()
        } else {
            g
        }
    }
}

/// A stepping mirror pass over `g` (the reconstruction needs one for its
/// G-buffer and for re-traces).
fn step_pass<'a>(g: GBuffer<'a>) -> MirrorPass<'a> {
    MirrorPass::try_new(
        g,
        MirrorOptions {
            method: MirrorMethod::Step,
            ..MirrorOptions::default()
        },
        None,
    )
    .unwrap()
}

/// Synthetic samples of a plates frame: per block a status from a hash
/// (mostly hits; some sky, host statuses and untraced blocks), and values
/// that say which plane they come from: plane A's colors only in the red
/// channel, B's only in the blue one, hit positions and distances in
/// disjoint ranges.
fn plates_samples(
    p: &Plates,
    sub: Subsample,
    seed: u32,
    hits_only: bool,
) -> (Vec<MirrorTexel>, Vec<[f32; 3]>) {
    let (w, h) = (p.spec.w, p.spec.h);
    let (hw, hh) = try_half_size(w, h).unwrap();
    let mut texels = vec![MirrorTexel::default(); (hw * hh) as usize];
    let mut colors = vec![[0.0f32; 3]; (hw * hh) as usize];
    for by in 0..hh {
        for bx in 0..hw {
            let (x, y) = sub.traced_pixel(bx, by, w, h).unwrap();
            let on_b = p.plane[(y * w + x) as usize] == 1;
            let k = (bx.wrapping_mul(73_856_093) ^ by.wrapping_mul(19_349_663) ^ seed) % 97;
            let status = if hits_only {
                MirrorStatus::Hit
            } else {
                match k % 16 {
                    0 => MirrorStatus::Skipped,
                    1 | 2 => MirrorStatus::Sky,
                    3 => MirrorStatus::LeftImage,
                    4 => MirrorStatus::Hidden,
                    _ => MirrorStatus::Hit,
                }
            };
            let i = (by * hw + bx) as usize;
            let off = if on_b { 100.0 } else { 0.0 };
            texels[i] = MirrorTexel {
                status,
                pixel: Vec2::new(bx as f32 * 2.0 + 0.25 + off, by as f32 * 2.0 + 0.75 + off),
                t: 1.0 + (k % 13) as f32 + off,
                confidence: (k % 10) as f32 / 9.0,
            };
            let c = 1.0 + k as f32;
            colors[i] = if on_b { [0.0, 0.0, c] } else { [c, 0.0, 0.0] };
        }
    }
    (texels, colors)
}

/// What the f64 oracle expects at one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Expect {
    /// The traced pixel: its sample, exactly.
    Copied,
    /// No sample reaches it.
    Retrace,
    /// Reconstructed: status, then color (3), hit pixel (2), t and
    /// confidence with the tolerance of each.
    Interpolated {
        status: MirrorStatus,
        values: [f64; 7],
        tolerance: [f64; 7],
        /// Contributions from the other plane's samples.
        cross: bool,
    },
    /// Too close to a threshold or tie for f32 to decide: not checked.
    Ambiguous,
}

/// The tent weight along one axis (docs: `max(0, 1 - |d| / 2)`).
fn tent64(d: f64) -> f64 {
    (1.0 - d.abs() / 2.0).max(0.0)
}

/// One contributing sample of the oracle.
struct OracleSample {
    weight: f64,
    /// Bound on the relative error of the f32 weight (module docs: depth
    /// decoding moves the Gaussian weight).
    weight_error: f64,
    values: [f64; 7],
    status: MirrorStatus,
    cross: bool,
}

/// The reconstruction of pixel `(x, y)` of a plates frame from the
/// documented weights, in f64 from the frame's exact depths and normals,
/// over all nine blocks around the pixel's.
///
/// Tolerances: f32 decodes each stored depth with a relative error `e`
/// (measured here per pixel against the exact depth), so `r` is off by up
/// to `(1 + r) (e_p + e_k)` plus rounding, and the Gaussian weight by that
/// times `r / sigma^2` relative; a reconstructed value is then off by at
/// most twice the largest relative weight error times its samples' spread
/// about the mean, plus f32 rounding (2e-4 relative).
fn oracle(
    p: &Plates,
    sub: Subsample,
    texels: &[MirrorTexel],
    colors: &[[f32; 3]],
    o: &UpsampleOptions,
    x: u32,
    y: u32,
) -> Expect {
    let (w, h) = (p.spec.w, p.spec.h);
    let (hw, hh) = try_half_size(w, h).unwrap();
    let (bx, by) = (x / 2, y / 2);
    if oracle_traced(sub.pattern, sub.frame, bx, by, w, h) == (x, y) {
        return Expect::Copied;
    }
    let decode_error = |i: usize| {
        let z = f64::from(p.cam.decode_depth(p.depth[i], p.conv));
        (z - p.z[i]).abs() / p.z[i] + 1e-7
    };
    let i = (y * w + x) as usize;
    let (zp, np, ep) = (p.z[i], p.n[i], decode_error(i));
    let ap = pixel_ray(&p.cam, f64::from(x), f64::from(y));
    let mut classes: [Vec<OracleSample>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    let mut ambiguous = false;
    for cy in by.saturating_sub(1)..(by + 2).min(hh) {
        for cx in bx.saturating_sub(1)..(bx + 2).min(hw) {
            let (sx, sy) = oracle_traced(sub.pattern, sub.frame, cx, cy, w, h);
            let s = tent64(f64::from(sx) - f64::from(x)) * tent64(f64::from(sy) - f64::from(y));
            if s <= 0.0 {
                continue;
            }
            let k = (cy * hw + cx) as usize;
            let t = texels[k];
            let class = match t.status {
                MirrorStatus::Hit => 0,
                MirrorStatus::Sky => 1,
                st if st.needs_host() => 2,
                _ => continue,
            };
            let j = (sy * w + sx) as usize;
            let compared = if o.plane_depth {
                let a = pixel_ray(&p.cam, f64::from(sx), f64::from(sy));
                zp * np.dot(ap) / np.dot(a)
            } else {
                zp
            };
            let r = (p.z[j] - compared).abs() / zp;
            let dr = (1.0 + r) * (ep + decode_error(j) + 1e-6);
            let thr = f64::from(o.depth_threshold);
            if (r - thr).abs() <= 2.0 * dr {
                ambiguous = true;
            }
            if !(r <= thr) {
                continue;
            }
            let sigma = f64::from(o.depth_sigma);
            let (d, d_error) = if sigma.is_finite() {
                let q = r / sigma;
                ((-0.5 * q * q).exp(), r * dr / (sigma * sigma))
            } else {
                (1.0, 0.0)
            };
            let pw = f64::from(o.normal_power);
            let n = if pw > 0.0 {
                np.dot(p.n[j]).clamp(0.0, 1.0).powf(pw)
            } else {
                1.0
            };
            let weight = s * d * n;
            if weight <= 1e-12 {
                // Underflow territory: f32 and f64 may disagree on zero.
                if weight > 0.0 {
                    ambiguous = true;
                }
                continue;
            }
            let c = colors[k].map(f64::from);
            let values = [
                c[0],
                c[1],
                c[2],
                f64::from(t.pixel.x),
                f64::from(t.pixel.y),
                f64::from(t.t),
                f64::from(t.confidence),
            ];
            classes[class].push(OracleSample {
                weight,
                weight_error: d_error.min(1.0) + 1e-5,
                values,
                status: t.status,
                cross: p.plane[j] != p.plane[i],
            });
        }
    }
    if ambiguous {
        return Expect::Ambiguous;
    }
    let wsum: Vec<f64> = classes
        .iter()
        .map(|c| c.iter().map(|s| s.weight).sum())
        .collect();
    let present = wsum.iter().filter(|&&v| v > 0.0).count();
    if present == 0 || (present > 1 && o.retrace_mixed) {
        return Expect::Retrace;
    }
    let mut class = 0;
    for c in [1, 2] {
        if wsum[c] > wsum[class] {
            class = c;
        }
    }
    // A near tie between classes: f32 may pick either. (An exact tie is
    // the geometry's, and f32 has it too: the order decides.)
    let top = wsum[class];
    let slack = classes
        .iter()
        .flatten()
        .map(|s| s.weight_error)
        .fold(1e-5f64, f64::max);
    if (0..3).any(|c| {
        c != class && wsum[c] > 0.0 && wsum[c] != top && (top - wsum[c]).abs() <= 2.0 * slack * top
    }) {
        return Expect::Ambiguous;
    }
    let samples = &classes[class];
    // The host class's status: its heaviest sample's (the first of equal
    // weights), unless a near tie leaves it to f32.
    let mut heaviest: Option<&OracleSample> = None;
    for s in samples {
        if let Some(h) = heaviest {
            if s.weight != h.weight
                && (s.weight - h.weight).abs() <= 2.0 * slack * s.weight
                && s.status != h.status
            {
                return Expect::Ambiguous;
            }
        }
        if heaviest.is_none_or(|h| s.weight > h.weight) {
            heaviest = Some(s);
        }
    }
    let heaviest = heaviest.expect("a class with weight has samples");
    let mut values = [0.0f64; 7];
    for s in samples {
        for (v, sv) in values.iter_mut().zip(s.values) {
            *v += sv * s.weight / top;
        }
    }
    if class != 0 {
        // Only hits carry a position, distance and confidence.
        values[3..].fill(0.0);
    }
    let weight_error = samples
        .iter()
        .map(|s| s.weight_error)
        .fold(0.0f64, f64::max);
    let mut tolerance = [0.0f64; 7];
    for (k, tol) in tolerance.iter_mut().enumerate() {
        let spread = samples
            .iter()
            .map(|s| (s.values[k] - values[k]).abs())
            .fold(0.0f64, f64::max);
        *tol = 2e-4 * (1.0 + values[k].abs()) + 2.0 * weight_error * spread;
    }
    Expect::Interpolated {
        status: match class {
            0 => MirrorStatus::Hit,
            1 => MirrorStatus::Sky,
            _ => heaviest.status,
        },
        values,
        tolerance,
        cross: samples.iter().any(|s| s.cross),
    }
}

/// Runs the reconstruction over the whole image: texels, colors, status
/// bytes, re-trace list (the first `stats.retrace_written` entries),
/// stats.
struct Upsampled {
    texels: Vec<MirrorTexel>,
    colors: Vec<[f32; 3]>,
    status: Vec<u8>,
    list: Vec<[u32; 2]>,
    stats: UpsampleStats,
}

fn upsample_all(up: &UpsamplePass<'_>, w: u32, h: u32, with_color: bool) -> Upsampled {
    let n = (w * h) as usize;
    let mut texels = vec![MirrorTexel::default(); n];
    let mut colors = vec![[9.0f32; 3]; n];
    let mut status = vec![99u8; n];
    let mut list = vec![[u32::MAX; 2]; n];
    let stats = {
        let mut o = ImageViewMut::try_new(&mut texels, w, h, w).unwrap();
        let mut c = ImageViewMut::try_new(&mut colors, w, h, w).unwrap();
        let mut s = ImageViewMut::try_new(&mut status, w, h, w).unwrap();
        up.try_run(
            &mut o,
            if with_color { Some(&mut c) } else { None },
            Some(&mut s),
            &mut list,
        )
        .unwrap()
    };
    list.truncate(stats.retrace_written as usize);
    Upsampled {
        texels,
        colors,
        status,
        list,
        stats,
    }
}

/// Checks every pixel of `out` against the oracle; returns (checked,
/// ambiguous) counts.
fn check_against_oracle(
    p: &Plates,
    sub: Subsample,
    texels: &[MirrorTexel],
    colors: &[[f32; 3]],
    o: &UpsampleOptions,
    out: &Upsampled,
    label: &str,
) -> (usize, usize) {
    let (w, h) = (p.spec.w, p.spec.h);
    let (hw, _) = try_half_size(w, h).unwrap();
    let (mut checked, mut ambiguous) = (0, 0);
    let mut listed = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (t, c, st) = (out.texels[i], out.colors[i], out.status[i]);
            let at = format!("{label}: pixel ({x}, {y})");
            match oracle(p, sub, texels, colors, o, x, y) {
                Expect::Copied => {
                    let k = ((y / 2) * hw + x / 2) as usize;
                    if matches!(texels[k].status, MirrorStatus::Skipped) {
                        assert_eq!(st, UpsampleStatus::Skipped as u8, "{at}");
                    } else {
                        assert_eq!(st, UpsampleStatus::Copied as u8, "{at}");
                        assert_eq!(c, colors[k], "{at}");
                    }
                    assert_eq!(t, texels[k], "{at}");
                }
                Expect::Retrace => {
                    assert_eq!(st, UpsampleStatus::Retrace as u8, "{at}");
                    assert_eq!(t, MirrorTexel::default(), "{at}");
                    assert_eq!(c, [0.0; 3], "{at}");
                    listed.push([x, y]);
                }
                Expect::Interpolated {
                    status,
                    values,
                    tolerance,
                    cross,
                } => {
                    assert_eq!(st, UpsampleStatus::Interpolated as u8, "{at}");
                    assert_eq!(t.status, status, "{at}");
                    let got = [c[0], c[1], c[2], t.pixel.x, t.pixel.y, t.t, t.confidence];
                    for k in 0..7 {
                        assert!(
                            (f64::from(got[k]) - values[k]).abs() <= tolerance[k],
                            "{at}: {got:?} vs {values:?} (tolerance {tolerance:?})"
                        );
                    }
                    // Never across the edge: the other plane's channel is
                    // exactly zero unless the oracle has it contribute.
                    if !cross {
                        let other = if p.plane[i] == 0 { c[2] } else { c[0] };
                        assert_eq!(other, 0.0, "{at}: blended across the edge");
                    }
                    checked += 1;
                }
                Expect::Ambiguous => {
                    ambiguous += 1;
                    if st == UpsampleStatus::Retrace as u8 {
                        listed.push([x, y]);
                    }
                }
            }
        }
    }
    assert_eq!(out.list, listed, "{label}: the re-trace list");
    (checked, ambiguous)
}

#[test]
fn a_step_larger_than_the_threshold_is_never_crossed() {
    // A vertical edge at x = 16 between A at depth 4 and B 30% deeper,
    // facing the camera; every sample a hit.
    let spec = PlatesSpec {
        w: 32,
        h: 24,
        scale: 1.0,
        za: 4.0,
        step: 0.3,
        tilt: 0.0,
        angle: 0.0,
        offset: 0.0,
    };
    for conv in DepthConvention::ALL {
        let p = Plates::new(spec, conv);
        for sub in [
            Subsample::uniform(0),
            Subsample::uniform(1),
            Subsample::staggered(2),
        ] {
            let (texels, colors) = plates_samples(&p, sub, 1, true);
            let o = UpsampleOptions {
                shade_hits: false,
                ..UpsampleOptions::default()
            };
            let pass = step_pass(p.gbuffer(false));
            let up = UpsamplePass::try_new(
                pass,
                sub,
                ImageView::try_new(&texels, 16, 12, 16).unwrap(),
                Some(ImageView::try_new(&colors, 16, 12, 16).unwrap()),
                o,
            )
            .unwrap();
            let out = upsample_all(&up, 32, 24, true);
            let (checked, ambiguous) =
                check_against_oracle(&p, sub, &texels, &colors, &o, &out, &format!("{conv:?}"));
            assert_eq!(ambiguous, 0);
            assert_eq!(checked, 32 * 24 - 16 * 12 - out.stats.retrace as usize);
            // Columns 15 and 16 straddle the edge: a pixel there whose
            // own-side samples are out of reach is listed, never blended.
            for y in 0..24 {
                for x in [15u32, 16] {
                    let i = (y * 32 + x) as usize;
                    let c = out.colors[i];
                    assert!(
                        if x == 15 { c[2] == 0.0 } else { c[0] == 0.0 },
                        "{conv:?} {sub:?} ({x}, {y}): {c:?}"
                    );
                }
            }
            // The same with the edge 5% deep is blended (threshold 10%).
            let p2 = Plates::new(PlatesSpec { step: 0.05, ..spec }, conv);
            let pass2 = step_pass(p2.gbuffer(false));
            let up2 = UpsamplePass::try_new(
                pass2,
                sub,
                ImageView::try_new(&texels, 16, 12, 16).unwrap(),
                Some(ImageView::try_new(&colors, 16, 12, 16).unwrap()),
                o,
            )
            .unwrap();
            let out2 = upsample_all(&up2, 32, 24, true);
            check_against_oracle(&p2, sub, &texels, &colors, &o, &out2, "5%");
            assert!((0..24 * 32).any(|i| out2.colors[i][0] > 0.0 && out2.colors[i][2] > 0.0));
        }
    }
}

proptest! {
    #![proptest_config(common::proptest_config(48))]
    /// Random edges (angle, offset, step, tilt), samples of every class,
    /// options, patterns, sizes, depth conventions and scales: every
    /// pixel as the f64 oracle of the documented weights says, and no
    /// pixel takes anything from across an edge the oracle cuts.
    #[test]
    fn every_pixel_is_the_documented_weighted_mean(
        w in 1u32..29, h in 1u32..23,
        conv in 0usize..3,
        scale_exp in prop::sample::select(vec![-4i32, 0, 4]),
        step in prop_oneof![0.0f64..0.08, 0.12f64..1.5],
        tilt in 0.0f64..0.6,
        angle in 0.0f64..std::f64::consts::TAU,
        offset in -8.0f64..8.0,
        staggered in any::<bool>(),
        frame in 0u32..4,
        threshold in 0.02f32..0.3,
        sigma in prop_oneof![Just(f32::INFINITY), 0.01f32..0.3],
        power in prop_oneof![Just(0.0f32), 1.0f32..16.0, Just(8.0f32)],
        plane_depth in any::<bool>(),
        retrace_mixed in any::<bool>(),
        seed in any::<u32>(),
    ) {
        let spec = PlatesSpec { w, h, scale: 10f64.powi(scale_exp), za: 4.0, step, tilt, angle, offset };
        let p = Plates::new(spec, DepthConvention::ALL[conv]);
        let sub = Subsample { pattern: if staggered { Pattern::Staggered } else { Pattern::Uniform }, frame };
        let (texels, colors) = plates_samples(&p, sub, seed, false);
        let o = UpsampleOptions {
            depth_threshold: threshold,
            depth_sigma: sigma,
            normal_power: power,
            plane_depth,
            shade_hits: false,
            retrace: false,
            retrace_mixed,
        };
        let (hw, hh) = try_half_size(w, h).unwrap();
        let pass = step_pass(p.gbuffer(false));
        let up = UpsamplePass::try_new(
            pass,
            sub,
            ImageView::try_new(&texels, hw, hh, hw).unwrap(),
            Some(ImageView::try_new(&colors, hw, hh, hw).unwrap()),
            o,
        ).unwrap();
        let out = upsample_all(&up, w, h, true);
        let (checked, ambiguous) = check_against_oracle(&p, sub, &texels, &colors, &o, &out, "prop");
        prop_assert!(ambiguous <= checked / 10 + 3, "{} ambiguous of {}", ambiguous, checked);
        // The per-pixel entry point agrees with the run.
        for (x, y) in [(0, 0), (w - 1, h - 1), (w / 2, h / 2)] {
            let i = (y * w + x) as usize;
            let (t, c, s) = up.pixel(x, y);
            prop_assert_eq!((t, c, s as u8), (out.texels[i], out.colors[i], out.status[i]));
        }
    }
}

#[test]
fn hits_shade_at_their_interpolated_position_and_re_traces_are_the_full_pass() {
    let spec = PlatesSpec {
        w: 30,
        h: 22,
        scale: 1.0,
        za: 4.0,
        step: 0.4,
        tilt: 0.3,
        angle: 0.7,
        offset: 1.5,
    };
    let p = Plates::new(spec, DepthConvention::ReversedZ);
    let sub = Subsample::staggered(3);
    let (texels, colors) = plates_samples(&p, sub, 7, false);
    let (hw, hh) = try_half_size(30, 22).unwrap();
    let pass = step_pass(p.gbuffer(true));
    let base = UpsampleOptions::default();
    let run = |o: UpsampleOptions| {
        let up = UpsamplePass::try_new(
            pass,
            sub,
            ImageView::try_new(&texels, hw, hh, hw).unwrap(),
            Some(ImageView::try_new(&colors, hw, hh, hw).unwrap()),
            o,
        )
        .unwrap();
        upsample_all(&up, 30, 22, true)
    };
    let mean = run(UpsampleOptions {
        shade_hits: false,
        ..base
    });
    let shaded = run(base);
    let mut hits = 0;
    for i in 0..30 * 22 {
        assert_eq!(mean.texels[i], shaded.texels[i]);
        assert_eq!(mean.status[i], shaded.status[i]);
        let t = shaded.texels[i];
        if shaded.status[i] == UpsampleStatus::Interpolated as u8 && t.status == MirrorStatus::Hit {
            // The lit color at the interpolated hit texel (or black off
            // the image: the synthetic positions of plane B are far out).
            let (hx, hy) = (t.pixel.x as u32, t.pixel.y as u32);
            let expect = if hx < 30 && hy < 22 {
                p.lit[(hy * 30 + hx) as usize]
            } else {
                [0.0; 3]
            };
            assert_eq!(shaded.colors[i], expect);
            hits += 1;
        } else {
            assert_eq!(mean.colors[i], shaded.colors[i]);
        }
    }
    assert!(hits > 100, "{hits}");
    // Re-tracing: the unreached pixels are what the full pass gives there;
    // everything else is unchanged.
    let retraced = run(UpsampleOptions {
        retrace: true,
        ..base
    });
    assert!(shaded.stats.retrace > 0);
    assert_eq!(retraced.stats.retraced, shaded.stats.retrace);
    assert_eq!(retraced.stats.retrace, shaded.stats.retrace);
    assert_eq!(
        (retraced.stats.retrace_written, retraced.list.len()),
        (0, 0)
    );
    for i in 0..30 * 22 {
        let (x, y) = (i as u32 % 30, i as u32 / 30);
        if shaded.status[i] == UpsampleStatus::Retrace as u8 {
            assert_eq!(retraced.status[i], UpsampleStatus::Retraced as u8);
            let (t, _) = pass.pixel(x, y);
            assert_eq!(retraced.texels[i], t);
            assert_eq!(retraced.colors[i], pass.shade(&t));
        } else {
            assert_eq!(retraced.status[i], shaded.status[i]);
            assert_eq!(retraced.texels[i], shaded.texels[i]);
            assert_eq!(retraced.colors[i], shaded.colors[i]);
        }
    }
    // Mixed answers (a hit next to the sky or a host ray) re-traced too.
    let mixed = run(UpsampleOptions {
        retrace_mixed: true,
        ..base
    });
    assert!(mixed.stats.retrace > shaded.stats.retrace);
}

// --------------------------------------------------- a mirror floor

/// A mirror floor `y = 0` in front of a wall `z = -8` (x, y unbounded),
/// seen from `(0.3, 1.1, 0)`: depth, normals, the floor as the only
/// reflective surface, the wall lit with a smooth color of its point.
struct Floor {
    cam: Camera,
    conv: DepthConvention,
    /// Linear depth per pixel (f64 truth).
    z: Vec<f64>,
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    mask: Vec<u8>,
    lit: Vec<[f32; 3]>,
}

const WALL_Z: f64 = -8.0;

fn wall_color(q: DVec3) -> [f32; 3] {
    [
        (0.5 + 0.4 * (0.9 * q.x).sin()) as f32,
        (0.5 + 0.4 * (0.7 * q.y).cos()) as f32,
        0.3,
    ]
}

impl Floor {
    fn new(w: u32, h: u32, conv: DepthConvention) -> Self {
        let cam = Camera::try_look_at(
            Vec3::new(0.3, 1.1, 0.0),
            Vec3::new(0.0, 0.6, -4.0),
            Vec3::Y,
            1.0,
            0.05,
            100.0,
            w,
            h,
        )
        .unwrap();
        let n = (w * h) as usize;
        let mut f = Floor {
            cam,
            conv,
            z: vec![0.0; n],
            depth: vec![0.0; n],
            normals: vec![[0.0; 3]; n],
            mask: vec![0; n],
            lit: vec![[0.0; 3]; n],
        };
        let inv = cam.inverse_view().as_dmat4();
        let e = cam.eye().as_dvec3();
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let a = pixel_ray(&cam, f64::from(x), f64::from(y));
                let d = inv.transform_vector3(a);
                // Linear depth along `a` is the ray parameter (a.z = -1).
                let t_floor = if d.y < 0.0 { -e.y / d.y } else { f64::INFINITY };
                let t_wall = (WALL_Z - e.z) / d.z;
                let (t, n, floor) = if t_floor < t_wall {
                    (t_floor, DVec3::Y, true)
                } else {
                    (t_wall, DVec3::Z, false)
                };
                f.z[i] = t;
                f.depth[i] = cam.encode_depth(t as f32, conv);
                f.normals[i] = n.as_vec3().to_array();
                f.mask[i] = u8::from(floor);
                f.lit[i] = if floor {
                    [0.1, 0.1, 0.1]
                } else {
                    wall_color(e + d * t)
                };
            }
        }
        f
    }

    fn gbuffer(&self) -> GBuffer<'_> {
        let (w, h) = (self.cam.width(), self.cam.height());
        let d = DepthImage::try_new(
            ImageView::try_new(&self.depth, w, h, w).unwrap(),
            self.cam,
            self.conv,
        )
        .unwrap();
        GBuffer::try_new(
            d,
            ImageView::try_new(&self.normals, w, h, w).unwrap(),
            NormalSpace::World,
        )
        .unwrap()
        .try_with_mask(ImageView::try_new(&self.mask, w, h, w).unwrap())
        .unwrap()
        .try_with_color(ImageView::try_new(&self.lit, w, h, w).unwrap())
        .unwrap()
    }

    /// The exact reflection of floor pixel `(x, y)`: the hit's pixel
    /// position and distance (f64, closed form: the ray from the mirrored
    /// eye through the floor point meets the wall).
    fn exact(&self, x: u32, y: u32) -> (DVec2, f64) {
        let inv = self.cam.inverse_view().as_dmat4();
        let view: DMat4 = self.cam.view().as_dmat4();
        let e = self.cam.eye().as_dvec3();
        let d = inv.transform_vector3(pixel_ray(&self.cam, f64::from(x), f64::from(y)));
        let p = e + d * (-e.y / d.y);
        let m = DVec3::new(e.x, -e.y, e.z);
        let r = (p - m).normalize();
        let q = p + r * ((WALL_Z - p.z) / r.z);
        let v = view.transform_point3(q);
        let (w, h) = (f64::from(self.cam.width()), f64::from(self.cam.height()));
        let ty = (f64::from(self.cam.fov_y()) * 0.5).tan();
        let tx = ty * w / h;
        let px = (v.x / -v.z / tx + 1.0) * 0.5 * w;
        let py = (1.0 - v.y / -v.z / ty) * 0.5 * h;
        (DVec2::new(px, py), (q - p).length())
    }
}

/// The full mirror pass over `pass`'s G-buffer: texels and colors.
fn full_run(pass: &MirrorPass<'_>) -> (Vec<MirrorTexel>, Vec<[f32; 3]>) {
    let (w, h) = (pass.gbuffer().width(), pass.gbuffer().height());
    let n = (w * h) as usize;
    let mut out = vec![MirrorTexel::default(); n];
    let mut color = vec![[0.0f32; 3]; n];
    pass.try_run(
        &mut ImageViewMut::try_new(&mut out, w, h, w).unwrap(),
        Some(&mut ImageViewMut::try_new(&mut color, w, h, w).unwrap()),
        &mut [],
    )
    .unwrap();
    (out, color)
}

/// The half pass over `pass`'s G-buffer: texels, colors and stats.
fn half_run(
    pass: &MirrorPass<'_>,
    sub: Subsample,
) -> (Vec<MirrorTexel>, Vec<[f32; 3]>, MirrorStats) {
    let (w, h) = (pass.gbuffer().width(), pass.gbuffer().height());
    let (hw, hh) = try_half_size(w, h).unwrap();
    let n = (hw * hh) as usize;
    let mut out = vec![MirrorTexel::default(); n];
    let mut color = vec![[0.0f32; 3]; n];
    let stats = HalfPass::new(*pass, sub)
        .try_run(
            &mut ImageViewMut::try_new(&mut out, hw, hh, hw).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut color, hw, hh, hw).unwrap()),
            &mut [],
        )
        .unwrap();
    (out, color, stats)
}

#[test]
fn on_a_mirror_floor_the_upsampled_hits_match_the_full_pass_within_the_interpolation_error() {
    let (w, h) = (96u32, 72u32);
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    // Interpolation errors: uniform, uniform along the plane, staggered,
    // staggered along the plane.
    let mut errors: [Vec<f64>; 4] = Default::default();
    for conv in DepthConvention::ALL {
        let f = Floor::new(w, h, conv);
        let pass = step_pass(f.gbuffer());
        let (full, full_color) = full_run(&pass);
        for (sub, plane) in [
            (Subsample::uniform(0), false),
            (Subsample::staggered(1), false),
            (Subsample::uniform(0), true),
            (Subsample::staggered(1), true),
        ] {
            let o = UpsampleOptions {
                plane_depth: plane,
                ..UpsampleOptions::default()
            };
            let (half, half_color, stats) = half_run(&pass, sub);
            let (hw, hh) = try_half_size(w, h).unwrap();
            // The half pass is the full pass on the traced pixels.
            for by in 0..hh {
                for bx in 0..hw {
                    let (x, y) = sub.traced_pixel(bx, by, w, h).unwrap();
                    let (k, i) = ((by * hw + bx) as usize, (y * w + x) as usize);
                    assert_eq!(half[k], full[i]);
                    assert_eq!(half_color[k], full_color[i]);
                }
            }
            assert_eq!(
                stats.traced as usize,
                (0..hw * hh)
                    .filter(|&k| !matches!(
                        half[k as usize].status,
                        MirrorStatus::Skipped | MirrorStatus::NoSurface
                    ))
                    .count()
            );
            let up = UpsamplePass::try_new(
                pass,
                sub,
                ImageView::try_new(&half, hw, hh, hw).unwrap(),
                Some(ImageView::try_new(&half_color, hw, hh, hw).unwrap()),
                o,
            )
            .unwrap();
            let out = upsample_all(&up, w, h, true);
            let (mut checked, mut within_tenth, mut cut) = (0, 0, 0);
            for y in 1..h - 1 {
                for x in 1..w - 1 {
                    let i = (y * w + x) as usize;
                    // Inside the floor's reflection of the wall: the pixel
                    // and its eight neighbors are hits of the full pass.
                    let interior = (y - 1..=y + 1).all(|yy| {
                        (x - 1..=x + 1)
                            .all(|xx| full[(yy * w + xx) as usize].status == MirrorStatus::Hit)
                    });
                    if !interior || sub.is_traced(x, y, w, h) {
                        continue;
                    }
                    let t = out.texels[i];
                    // The samples in reach with their documented weights:
                    // the normals are equal, and along the tangent plane
                    // (the floor) the depth weight is 1 (up to f32); by
                    // the pixel's own depth, the Gaussian of the floor's
                    // depth change, cut at the threshold.
                    let mut samples = Vec::new();
                    for cy in (y / 2).saturating_sub(1)..(y / 2 + 2).min(hh) {
                        for cx in (x / 2).saturating_sub(1)..(x / 2 + 2).min(hw) {
                            let (sx, sy) = sub.traced_pixel(cx, cy, w, h).unwrap();
                            let mut s = tent64(f64::from(sx) - f64::from(x))
                                * tent64(f64::from(sy) - f64::from(y));
                            if !plane {
                                let (zp, zk) = (f.z[i], f.z[(sy * w + sx) as usize]);
                                let r = (zk - zp).abs() / zp;
                                let sigma = f64::from(o.depth_sigma);
                                s *= if r <= f64::from(o.depth_threshold) {
                                    (-0.5 * (r / sigma).powi(2)).exp()
                                } else {
                                    0.0
                                };
                            }
                            if s > 0.0 {
                                samples.push((s, sx, sy));
                            }
                        }
                    }
                    if samples.is_empty() {
                        // Every sample beyond the depth edge (the floor's
                        // far rows, by the pixel's own depth).
                        assert_eq!(out.status[i], UpsampleStatus::Retrace as u8, "({x}, {y})");
                        cut += 1;
                        continue;
                    }
                    assert_eq!(out.status[i], UpsampleStatus::Interpolated as u8);
                    assert_eq!(t.status, MirrorStatus::Hit, "({x}, {y})");
                    let samples: Vec<(f64, u32, u32)> = samples;
                    let ws: f64 = samples.iter().map(|s| s.0).sum();
                    let (mut interp, mut interp_t) = (DVec2::ZERO, 0.0);
                    let (mut sample_err, mut sample_err_t) = (0.0f64, 0.0f64);
                    for &(s, sx, sy) in &samples {
                        let (hp, ht) = f.exact(sx, sy);
                        interp += hp * (s / ws);
                        interp_t += ht * (s / ws);
                        let ft = full[(sy * w + sx) as usize];
                        sample_err = sample_err.max((ft.pixel.as_dvec2() - hp).length());
                        sample_err_t = sample_err_t.max((f64::from(ft.t) - ht).abs());
                    }
                    let (hp, ht) = f.exact(x, y);
                    // |up - exact| <= |interpolated exact - exact| + the
                    // samples' own error (+ f32 rounding).
                    let e_interp = (interp - hp).length();
                    let e_up = (t.pixel.as_dvec2() - hp).length();
                    assert!(
                        e_up <= e_interp + sample_err + 1e-3,
                        "({x}, {y}): {e_up} > {e_interp} + {sample_err}"
                    );
                    let e_full = (full[i].pixel.as_dvec2() - hp).length();
                    // The distance alike (the reflection runs toward its
                    // vanishing point, where a small pixel error is a
                    // large error in t: the samples' own t errors).
                    let e_t = (f64::from(t.t) - ht).abs();
                    assert!(
                        e_t <= (interp_t - ht).abs() + sample_err_t + 1e-4 * ht,
                        "t {} vs {ht}: {} + {sample_err_t}",
                        t.t,
                        (interp_t - ht).abs()
                    );
                    // Against the full pass: what the reconstruction adds
                    // (the interpolation error of the exact map, a
                    // hundredth of a pixel here: stated below) besides
                    // the full pass's own errors at the samples and the
                    // pixel.
                    let vs_full = f64::from((t.pixel - full[i].pixel).length());
                    assert!(
                        vs_full <= e_interp + sample_err + e_full + 1e-3,
                        "({x}, {y}): {vs_full} px from the full pass; interp {e_interp} samples {sample_err} full {e_full}"
                    );
                    errors[2 * usize::from(sub.pattern == Pattern::Staggered) + usize::from(plane)]
                        .push(e_interp);
                    worst.0 = worst.0.max(e_interp);
                    worst.1 = worst.1.max(e_full.max(sample_err));
                    worst.2 = worst.2.max(vs_full);
                    within_tenth += usize::from(vs_full <= 0.1);

                    checked += 1;
                }
            }
            assert!(checked > 500, "{checked}");
            eprintln!("{conv:?} {:?} plane {plane}: {checked} checked, {cut} cut, {within_tenth} within 0.1 px", sub.pattern);
            // Along the plane the tent weights reproduce linear maps on
            // both lattices: the upsampled hit is within a tenth of a
            // pixel of the full pass's nearly everywhere (not on the few
            // rows next to the floor's far edge, where the map bends and
            // the full pass errs itself). By the pixel's own depth the
            // floor's depth gradient tilts the weights (below).
            if plane {
                assert!(
                    within_tenth * 100 >= checked * 97,
                    "{within_tenth} of {checked}"
                );
            } else {
                assert!(
                    within_tenth * 100 >= checked * 80,
                    "{within_tenth} of {checked}"
                );
            }
        }
    }
    // The interpolation error of the exact map: along the plane the tent
    // weights reproduce linear maps on both lattices, so what is left is
    // the map's curvature; by the pixel's own depth the Gaussian weighs
    // the nearer and the farther sample differently where the floor's
    // depth changes fast, which moves the mean toward one of them.
    let q = errors.each_mut().map(|v| {
        v.sort_by(f64::total_cmp);
        [0.5, 0.9, 0.99, 1.0].map(|p| v[((v.len() - 1) as f64 * p) as usize])
    });
    eprintln!(
        "interpolation error quantiles 50/90/99/100%: uniform {:.4?}, along the plane {:.4?}; staggered {:.4?}, along the plane {:.4?}",
        q[0], q[1], q[2], q[3]
    );
    for k in [1, 3] {
        assert!(q[k][1] <= 0.01 && q[k][2] <= 0.05, "{:?}", q[k]);
    }
    // What the bound is made of (printed for the record).
    eprintln!(
        "mirror floor: interpolation error <= {:.4} px, full pass vs exact <= {:.4} px, upsampled vs full <= {:.4} px",
        worst.0, worst.1, worst.2
    );
}

// ------------------------------------------- temporal super-sampling

#[test]
fn four_cycled_frames_through_the_temporal_filter_reach_the_full_pass() {
    let cam = scene::default_camera();
    let (w, h) = (cam.width(), cam.height());
    let n = (w * h) as usize;
    for conv in [DepthConvention::ReversedZ, DepthConvention::Linear] {
        let frame = scene::render(cam, conv);
        let g = frame.gbuffer(false);
        let pass = step_pass(g);
        let (full, full_color) = full_run(&pass);
        // How far the filter's f32 re-projection of a pixel's own surface
        // point (unproject, then project with the same camera) lands from
        // the texel center: the bilinear share of the neighbors it reads.
        let mut eps = 0.0f32;
        for y in 0..h {
            for x in 0..w {
                if let Some(q) = g.surface(x, y).and_then(|s| cam.project(s.position)) {
                    let d = (q.x - (x as f32 + 0.5)).abs() + (q.y - (y as f32 + 0.5)).abs();
                    eps = eps.max(d);
                }
            }
        }
        let cmax = full_color
            .iter()
            .flatten()
            .fold(0.0f32, |a, &b| a.max(b.abs()));
        eprintln!("{conv:?}: re-projection offset <= {eps:e} px, colors <= {cmax}");
        assert!(eps < 1e-3, "{eps}");
        for pattern in [Pattern::Uniform, Pattern::Staggered] {
            for max_frames in [1.0, 8.0] {
                let mut history: Option<Vec<HistoryTexel>> = None;
                for f in 0..8u32 {
                    let sub = Subsample { pattern, frame: f };
                    let (half, half_color, _) = half_run(&pass, sub);
                    let (hw, hh) = try_half_size(w, h).unwrap();
                    let up = UpsamplePass::try_new(
                        pass,
                        sub,
                        ImageView::try_new(&half, hw, hh, hw).unwrap(),
                        Some(ImageView::try_new(&half_color, hw, hh, hw).unwrap()),
                        UpsampleOptions::default(),
                    )
                    .unwrap();
                    let out = upsample_all(&up, w, h, true);
                    let answered: Vec<u8> = (0..n)
                        .map(|i| {
                            let s = match out.status[i] {
                                1 => UpsampleStatus::Copied,
                                4 => UpsampleStatus::Retraced,
                                _ => UpsampleStatus::Interpolated,
                            };
                            u8::from(s.answers(out.texels[i].status))
                        })
                        .collect();
                    let hist = history.as_ref().map(|t| {
                        History::try_new(cam, ImageView::try_new(t, w, h, w).unwrap()).unwrap()
                    });
                    let tp = TemporalPass::try_new(
                        g,
                        ImageView::try_new(&out.colors, w, h, w).unwrap(),
                        ImageView::try_new(&answered, w, h, w).unwrap(),
                        hist,
                        TemporalOptions {
                            max_frames,
                            ..TemporalOptions::default()
                        },
                    )
                    .unwrap();
                    let mut next = vec![HistoryTexel::default(); n];
                    tp.try_run(
                        &mut ImageViewMut::try_new(&mut next, w, h, w).unwrap(),
                        None,
                    )
                    .unwrap();
                    if f >= 3 {
                        // Every pixel the full pass answers holds its
                        // answer; no other pixel holds history.
                        // Each frame's recovery may take up to `eps` of a
                        // neighbor of another color.
                        let bound = (f as f32 + 1.0) * eps * cmax + 1e-5 * cmax;
                        let mut worst = 0.0f32;
                        for i in 0..n {
                            let answered_full =
                                matches!(full[i].status, MirrorStatus::Hit | MirrorStatus::Sky);
                            assert_eq!(
                                next[i].frames > 0.0,
                                answered_full,
                                "{conv:?} {pattern:?} frame {f} pixel {i}: {:?} {:?}",
                                full[i],
                                next[i]
                            );
                            if answered_full {
                                for k in 0..3 {
                                    worst = worst.max((next[i].color[k] - full_color[i][k]).abs());
                                }
                            }
                        }
                        assert!(
                            worst <= bound,
                            "{conv:?} {pattern:?} frame {f}: {worst} > {bound}"
                        );
                    }
                    history = Some(next);
                }
            }
        }
    }
}

// ------------------------------------- conventions, scales, bad input

#[test]
fn every_depth_convention_and_scale_gives_the_same_result() {
    let base = PlatesSpec {
        w: 27,
        h: 19,
        scale: 1.0,
        za: 4.0,
        step: 0.5,
        tilt: 0.35,
        angle: 1.1,
        offset: -2.0,
    };
    for plane_depth in [true, false] {
        let o = UpsampleOptions {
            plane_depth,
            shade_hits: false,
            ..UpsampleOptions::default()
        };
        let mut reference: Option<Upsampled> = None;
        for scale in [1.0, 1e-4, 1e4] {
            for conv in DepthConvention::ALL {
                let p = Plates::new(PlatesSpec { scale, ..base }, conv);
                let sub = Subsample::uniform(2);
                let (texels, colors) = plates_samples(&p, sub, 3, true);
                let (hw, hh) = try_half_size(27, 19).unwrap();
                let pass = step_pass(p.gbuffer(false));
                let up = UpsamplePass::try_new(
                    pass,
                    sub,
                    ImageView::try_new(&texels, hw, hh, hw).unwrap(),
                    Some(ImageView::try_new(&colors, hw, hh, hw).unwrap()),
                    o,
                )
                .unwrap();
                let out = upsample_all(&up, 27, 19, true);
                check_against_oracle(&p, sub, &texels, &colors, &o, &out, "conv");
                match &reference {
                    None => reference = Some(out),
                    Some(r) => {
                        assert_eq!(out.status, r.status, "{scale} {conv:?}");
                        assert_eq!(out.list, r.list);
                        for i in 0..27 * 19 {
                            assert_eq!(out.texels[i].status, r.texels[i].status);
                            // Each within the oracle's 2e-4 of the same
                            // f64 value: within twice that of each other
                            // (depth decoding rounds differently per
                            // convention, which moves the Gaussian weights).
                            for k in 0..3 {
                                let (a, b) = (out.colors[i][k], r.colors[i][k]);
                                assert!(
                                    (a - b).abs() <= 4e-4 * (1.0 + b.abs()),
                                    "{scale} {conv:?}: {a} vs {b}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn bad_depths_normals_and_samples_are_not_used() {
    let spec = PlatesSpec {
        w: 20,
        h: 14,
        scale: 1.0,
        za: 4.0,
        step: 0.0,
        tilt: 0.0,
        angle: 0.0,
        offset: 100.0,
    };
    let sub = Subsample::uniform(0);
    for conv in DepthConvention::ALL {
        let mut p = Plates::new(spec, conv);
        let (mut texels, mut colors) = plates_samples(&p, sub, 5, true);
        let (hw, hh) = try_half_size(20, 14).unwrap();
        // Bad G-buffer texels at traced and at reconstructed pixels.
        let bad_depth = [(2u32, 2u32), (5, 3), (8, 8)];
        let bad_normal = [(4u32, 6u32), (7, 7), (12, 4)];
        let (nan, inf) = (f32::NAN, f32::INFINITY);
        for (k, &(x, y)) in bad_depth.iter().enumerate() {
            p.depth[(y * 20 + x) as usize] = [nan, inf, -1.0][k];
        }
        for (k, &(x, y)) in bad_normal.iter().enumerate() {
            p.normals[(y * 20 + x) as usize] = [[nan, 0.0, 1.0], [inf, 0.0, 0.0], [0.0; 3]][k];
        }
        // Bad samples: a NaN color, a NaN distance, an infinite position.
        colors[(3 * hw + 3) as usize] = [nan, 0.0, 0.0];
        texels[(4 * hw + 6) as usize].t = nan;
        texels[(hw + 7) as usize].pixel = Vec2::new(inf, 0.0);
        let pass = step_pass(p.gbuffer(false));
        let o = UpsampleOptions {
            shade_hits: false,
            ..UpsampleOptions::default()
        };
        let run = |texels: &[MirrorTexel], colors: &[[f32; 3]]| {
            let up = UpsamplePass::try_new(
                pass,
                sub,
                ImageView::try_new(texels, hw, hh, hw).unwrap(),
                Some(ImageView::try_new(colors, hw, hh, hw).unwrap()),
                o,
            )
            .unwrap();
            upsample_all(&up, 20, 14, true)
        };
        let out = run(&texels, &colors);
        // The same frame with those samples marked untraced: identical
        // wherever the pixel is not itself a bad traced one.
        let mut cleaned = texels.clone();
        let mut bad_blocks = vec![(3u32, 3u32), (6, 4), (7, 1)];
        for &(x, y) in bad_depth.iter().chain(&bad_normal) {
            if sub.is_traced(x, y, 20, 14) {
                bad_blocks.push((x / 2, y / 2));
            }
        }
        for &(bx, by) in &bad_blocks {
            cleaned[(by * hw + bx) as usize].status = MirrorStatus::Skipped;
        }
        let clean = run(&cleaned, &colors);
        for y in 0..14u32 {
            for x in 0..20u32 {
                let i = (y * 20 + x) as usize;
                if bad_blocks.contains(&(x / 2, y / 2)) && sub.is_traced(x, y, 20, 14) {
                    // A traced pixel is its sample, whatever it holds.
                    let k = ((y / 2) * hw + x / 2) as usize;
                    assert_eq!(bits(&out.texels[i]), bits(&texels[k]));
                    continue;
                }
                assert_eq!(out.status[i], clean.status[i], "{conv:?} ({x}, {y})");
                assert_eq!(out.texels[i], clean.texels[i], "{conv:?} ({x}, {y})");
                assert_eq!(out.colors[i], clean.colors[i], "{conv:?} ({x}, {y})");
                assert!(out.colors[i].iter().all(|c| c.is_finite()));
            }
        }
        // Reconstructed pixels without a surface are skipped as the full
        // pass skips them.
        for &(x, y) in bad_depth.iter().chain(&bad_normal) {
            if !sub.is_traced(x, y, 20, 14) {
                let i = (y * 20 + x) as usize;
                assert_eq!(out.status[i], UpsampleStatus::Skipped as u8);
                assert_eq!(out.texels[i].status, pass.pixel(x, y).0.status);
                assert_eq!(out.texels[i].status, MirrorStatus::NoSurface);
            }
        }
    }
}

#[test]
fn odd_and_one_pixel_sizes_work_as_documented() {
    for (w, h) in [
        (1u32, 1u32),
        (1, 9),
        (9, 1),
        (2, 3),
        (3, 2),
        (5, 5),
        (9, 4),
        (4, 9),
    ] {
        for pattern in [Pattern::Uniform, Pattern::Staggered] {
            for frame in 0..4 {
                let sub = Subsample { pattern, frame };
                // The half pass on a floor of that size is the full pass
                // on the traced pixels.
                let f = Floor::new(w, h, DepthConvention::ZeroToOne);
                let pass = step_pass(f.gbuffer());
                let (full, _) = full_run(&pass);
                let (half, _, _) = half_run(&pass, sub);
                let (hw, hh) = try_half_size(w, h).unwrap();
                assert_eq!(half.len(), (hw * hh) as usize);
                for by in 0..hh {
                    for bx in 0..hw {
                        let (x, y) = sub.traced_pixel(bx, by, w, h).unwrap();
                        assert_eq!(half[(by * hw + bx) as usize], full[(y * w + x) as usize]);
                    }
                }
                // The reconstruction of plates of that size: as the oracle.
                let p = Plates::new(
                    PlatesSpec {
                        w,
                        h,
                        scale: 1.0,
                        za: 4.0,
                        step: 0.3,
                        tilt: 0.2,
                        angle: 0.4,
                        offset: 0.0,
                    },
                    DepthConvention::ReversedZ,
                );
                let (texels, colors) = plates_samples(&p, sub, frame, false);
                let o = UpsampleOptions {
                    shade_hits: false,
                    ..UpsampleOptions::default()
                };
                let up = UpsamplePass::try_new(
                    step_pass(p.gbuffer(false)),
                    sub,
                    ImageView::try_new(&texels, hw, hh, hw).unwrap(),
                    Some(ImageView::try_new(&colors, hw, hh, hw).unwrap()),
                    o,
                )
                .unwrap();
                let out = upsample_all(&up, w, h, true);
                check_against_oracle(&p, sub, &texels, &colors, &o, &out, &format!("{w}x{h}"));
                let skipped = texels
                    .iter()
                    .filter(|t| t.status == MirrorStatus::Skipped)
                    .count() as u32;
                assert_eq!(out.stats.copied, hw * hh - skipped);
                assert_eq!(
                    out.stats.copied + out.stats.interpolated + out.stats.retrace + skipped,
                    w * h
                );
            }
        }
    }
}

/// A texel's fields as bits (NaN equals NaN).
fn bits(t: &MirrorTexel) -> (MirrorStatus, [u32; 4]) {
    (
        t.status,
        [
            t.pixel.x.to_bits(),
            t.pixel.y.to_bits(),
            t.t.to_bits(),
            t.confidence.to_bits(),
        ],
    )
}

// ---------------------------------------------- bands and refusals

/// `v` split at row `y` into two bands.
fn split_view<T: Copy>(
    v: ImageViewMut<'_, T>,
    y: u32,
) -> (ImageViewMut<'_, T>, ImageViewMut<'_, T>) {
    v.try_split_at_row(y).map_err(|(e, _)| e).unwrap()
}

struct Collect {
    texels: Vec<(u32, u32, MirrorTexel, [f32; 3], UpsampleStatus)>,
    list: Vec<[u32; 2]>,
}

impl UpsampleSink for Collect {
    fn texel(&mut self, x: u32, y: u32, t: &MirrorTexel, c: [f32; 3], s: UpsampleStatus) {
        self.texels.push((x, y, *t, c, s));
    }
    fn retrace(&mut self, index: u32, x: u32, y: u32) -> bool {
        assert_eq!(index as usize, self.list.len());
        self.list.push([x, y]);
        true
    }
}

struct CollectHalf(Vec<(u32, u32, MirrorTexel)>, Vec<HostRay>);

impl MirrorSink for CollectHalf {
    fn texel(&mut self, x: u32, y: u32, t: &MirrorTexel, _: [f32; 3]) {
        self.0.push((x, y, *t));
    }
    fn host(&mut self, _: u32, ray: &HostRay) -> bool {
        self.1.push(*ray);
        true
    }
}

#[test]
fn bands_equal_one_call_and_refusals_leave_outputs_untouched() {
    let (w, h) = (33u32, 25u32);
    let f = Floor::new(w, h, DepthConvention::ReversedZ);
    let pass = step_pass(f.gbuffer());
    let sub = Subsample::staggered(1);
    let (hw, hh) = try_half_size(w, h).unwrap();
    let (half, half_color, stats) = half_run(&pass, sub);
    // Half pass: two bands of half rows, host lists restarting.
    for split in [1, hh / 2, hh - 1] {
        let mut t = vec![MirrorTexel::default(); (hw * hh) as usize];
        let mut c = vec![[0.0f32; 3]; (hw * hh) as usize];
        let mut host = vec![HostRay::default(); (hw * hh) as usize];
        let (a, b) = ImageViewMut::try_new(&mut t, hw, hh, hw)
            .unwrap()
            .try_split_at_row(split)
            .map_err(|(e, _)| e)
            .unwrap();
        let (ca, cb) = ImageViewMut::try_new(&mut c, hw, hh, hw)
            .unwrap()
            .try_split_at_row(split)
            .map_err(|(e, _)| e)
            .unwrap();
        let hp = HalfPass::new(pass, sub);
        let (mut a, mut b, mut ca, mut cb) = (a, b, ca, cb);
        let (h1, h2) = host.split_at_mut((hw * hh) as usize / 2);
        let s1 = hp.try_run(&mut a, Some(&mut ca), h1).unwrap();
        let s2 = hp.try_run(&mut b, Some(&mut cb), h2).unwrap();
        assert_eq!(s1.traced + s2.traced, stats.traced);
        assert_eq!(s1.hits + s2.hits, stats.hits);
        assert_eq!(s1.host_rays + s2.host_rays, stats.host_rays);
        assert_eq!(t, half);
        assert_eq!(c, half_color);
        // The sink form: the same texels at block coordinates, host rays
        // at full-resolution pixels.
        let mut sink = CollectHalf(Vec::new(), Vec::new());
        hp.try_run_rows(RowRange::try_all(hh).unwrap(), &mut sink)
            .unwrap();
        assert_eq!(sink.0.len(), (hw * hh) as usize);
        for (bx, by, t) in &sink.0 {
            assert_eq!(*t, half[(by * hw + bx) as usize]);
        }
        for r in &sink.1 {
            assert!(sub.is_traced(r.x, r.y, w, h));
            assert_eq!(Some(*r), pass.host_ray(r.x, r.y, r.status));
        }
        assert_eq!(
            hp.try_run_rows(RowRange::try_new(0, hh + 1, hh + 1).unwrap(), &mut sink),
            Err(Error::InvalidArgument)
        );
    }
    // Reconstruction: bands at odd and even rows, lists restarting.
    let o = UpsampleOptions {
        // The pixel's own depth and a tight edge: the floor's slope cuts
        // some pixels off their samples (re-trace entries).
        depth_threshold: 0.01,
        plane_depth: false,
        ..UpsampleOptions::default()
    };
    let up = UpsamplePass::try_new(
        pass,
        sub,
        ImageView::try_new(&half, hw, hh, hw).unwrap(),
        Some(ImageView::try_new(&half_color, hw, hh, hw).unwrap()),
        o,
    )
    .unwrap();
    let whole = upsample_all(&up, w, h, true);
    assert!(whole.stats.retrace > 0 && whole.stats.interpolated > 0);
    for split in [1, 12, 13, h - 1] {
        let n = (w * h) as usize;
        let (mut t, mut c, mut s) = (
            vec![MirrorTexel::default(); n],
            vec![[0.0f32; 3]; n],
            vec![0u8; n],
        );
        let mut list = vec![[0u32; 2]; n];
        let (mut ta, mut tb) = split_view(ImageViewMut::try_new(&mut t, w, h, w).unwrap(), split);
        let (mut ca, mut cb) = split_view(ImageViewMut::try_new(&mut c, w, h, w).unwrap(), split);
        let (mut sa, mut sb) = split_view(ImageViewMut::try_new(&mut s, w, h, w).unwrap(), split);
        let (la, lb) = list.split_at_mut(n / 2);
        let s1 = up
            .try_run(&mut ta, Some(&mut ca), Some(&mut sa), la)
            .unwrap();
        let s2 = up
            .try_run(&mut tb, Some(&mut cb), Some(&mut sb), lb)
            .unwrap();
        assert_eq!(t, whole.texels);
        assert_eq!(c, whole.colors);
        assert_eq!(s, whole.status);
        assert_eq!(s1.copied + s2.copied, whole.stats.copied);
        assert_eq!(s1.interpolated + s2.interpolated, whole.stats.interpolated);
        assert_eq!(s1.hits + s2.hits, whole.stats.hits);
        let mut joined = list[..s1.retrace_written as usize].to_vec();
        joined.extend_from_slice(&list[n / 2..n / 2 + s2.retrace_written as usize]);
        assert_eq!(joined, whole.list);
    }
    // A list too short keeps what fits and counts the rest.
    let mut short = [[0u32; 2]; 3];
    let mut t = vec![MirrorTexel::default(); (w * h) as usize];
    let st = up
        .try_run(
            &mut ImageViewMut::try_new(&mut t, w, h, w).unwrap(),
            None,
            None,
            &mut short,
        )
        .unwrap();
    assert_eq!((st.retrace_written, st.retrace), (3, whole.stats.retrace));
    assert_eq!(short.to_vec(), whole.list[..3].to_vec());
    // The sink form equals the images.
    let mut sink = Collect {
        texels: Vec::new(),
        list: Vec::new(),
    };
    let ss = up
        .try_run_rows(RowRange::try_all(h).unwrap(), &mut sink)
        .unwrap();
    assert_eq!(ss, whole.stats);
    assert_eq!(sink.list, whole.list);
    for (x, y, t, c, s) in sink.texels {
        let i = (y * w + x) as usize;
        assert_eq!(
            (t, c, s as u8),
            (whole.texels[i], whole.colors[i], whole.status[i])
        );
    }
    assert_eq!(
        up.try_run_rows(
            RowRange::try_new(0, h + 1, h + 1).unwrap(),
            &mut Collect {
                texels: Vec::new(),
                list: Vec::new()
            }
        ),
        Err(Error::InvalidArgument)
    );

    // Refusals: options, sizes, color without an input; nothing written.
    let bad_options = [
        UpsampleOptions {
            depth_threshold: f32::NAN,
            ..o
        },
        UpsampleOptions {
            depth_threshold: 0.0,
            ..o
        },
        UpsampleOptions {
            depth_threshold: -0.1,
            ..o
        },
        UpsampleOptions {
            depth_sigma: f32::NAN,
            ..o
        },
        UpsampleOptions {
            depth_sigma: 0.0,
            ..o
        },
        UpsampleOptions {
            normal_power: f32::NAN,
            ..o
        },
        UpsampleOptions {
            normal_power: f32::INFINITY,
            ..o
        },
        UpsampleOptions {
            normal_power: -1.0,
            ..o
        },
    ];
    let tv = ImageView::try_new(&half, hw, hh, hw).unwrap();
    let cv = ImageView::try_new(&half_color, hw, hh, hw).unwrap();
    for b in bad_options {
        assert_eq!(b.try_validate(), Err(Error::InvalidArgument), "{b:?}");
        assert_eq!(
            UpsamplePass::try_new(pass, sub, tv, Some(cv), b).err(),
            Some(Error::InvalidArgument)
        );
    }
    // +inf threshold and sigma are "off", not refused.
    UpsampleOptions {
        depth_threshold: f32::INFINITY,
        depth_sigma: f32::INFINITY,
        ..o
    }
    .try_validate()
    .unwrap();
    // Half images of another G-buffer's size.
    let wrong = ImageView::try_new(&half, hw - 1, hh, hw).unwrap();
    assert_eq!(
        UpsamplePass::try_new(pass, sub, wrong, Some(cv), o).err(),
        Some(Error::InvalidArgument)
    );
    let wrong_c = ImageView::try_new(&half_color, hw, hh - 1, hw).unwrap();
    assert_eq!(
        UpsamplePass::try_new(pass, sub, tv, Some(wrong_c), o).err(),
        Some(Error::InvalidArgument)
    );
    let small = Floor::new(w - 2, h, DepthConvention::ReversedZ);
    let other = step_pass(small.gbuffer());
    assert_eq!(
        UpsamplePass::try_new(other, sub, tv, Some(cv), o).err(),
        Some(Error::InvalidArgument)
    );
    let n = (w * h) as usize;
    let sentinel = MirrorTexel {
        status: MirrorStatus::Hidden,
        t: 42.0,
        ..MirrorTexel::default()
    };
    let untouched = |t: &[MirrorTexel], c: &[[f32; 3]], s: &[u8], l: &[[u32; 2]]| {
        t.iter().all(|x| *x == sentinel)
            && c.iter().all(|x| *x == [5.0; 3])
            && s.iter().all(|x| *x == 77)
            && l.iter().all(|x| *x == [9, 9])
    };
    let (mut t, mut c, mut s, mut l) = (
        vec![sentinel; n],
        vec![[5.0f32; 3]; n],
        vec![77u8; n],
        vec![[9u32, 9]; 8],
    );
    {
        // Output of the wrong size.
        let mut o1 = ImageViewMut::try_new(&mut t, w - 1, h, w).unwrap();
        assert_eq!(
            up.try_run(&mut o1, None, None, &mut l).err(),
            Some(Error::InvalidArgument)
        );
        // Color or status of the wrong size, or of another band.
        let mut o2 = ImageViewMut::try_new(&mut t, w, h, w).unwrap();
        let mut c2 = ImageViewMut::try_new(&mut c, w, h - 1, w).unwrap();
        assert_eq!(
            up.try_run(&mut o2, Some(&mut c2), None, &mut l).err(),
            Some(Error::InvalidArgument)
        );
        let mut s2 = ImageViewMut::try_new(&mut s, w, h, w)
            .unwrap()
            .try_split_at_row(3)
            .map_err(|(e, _)| e)
            .unwrap()
            .1;
        assert_eq!(
            up.try_run(&mut o2, None, Some(&mut s2), &mut l).err(),
            Some(Error::InvalidArgument)
        );
    }
    assert!(untouched(&t, &c, &s, &l));
    {
        // A color output without a color input.
        let no_color = UpsamplePass::try_new(pass, sub, tv, None, o).unwrap();
        let mut o3 = ImageViewMut::try_new(&mut t, w, h, w).unwrap();
        let mut c3 = ImageViewMut::try_new(&mut c, w, h, w).unwrap();
        assert_eq!(
            no_color.try_run(&mut o3, Some(&mut c3), None, &mut l).err(),
            Some(Error::InvalidArgument)
        );
    }
    assert!(untouched(&t, &c, &s, &l));
    // The half pass: outputs of the full size, a color output without a
    // G-buffer color.
    let hp = HalfPass::new(pass, sub);
    {
        let mut o4 = ImageViewMut::try_new(&mut t, w, h, w).unwrap();
        assert_eq!(
            hp.try_run(&mut o4, None, &mut []).err(),
            Some(Error::InvalidArgument)
        );
        let mut o5 = ImageViewMut::try_new(&mut t, hw, hh, hw).unwrap();
        let mut c5 = ImageViewMut::try_new(&mut c, hw + 1, hh, hw + 1).unwrap();
        assert_eq!(
            hp.try_run(&mut o5, Some(&mut c5), &mut []).err(),
            Some(Error::InvalidArgument)
        );
        let p = Plates::new(
            PlatesSpec {
                w,
                h,
                scale: 1.0,
                za: 4.0,
                step: 0.0,
                tilt: 0.0,
                angle: 0.0,
                offset: 0.0,
            },
            DepthConvention::ReversedZ,
        );
        let unlit = HalfPass::new(step_pass(p.gbuffer(false)), sub);
        let mut c6 = ImageViewMut::try_new(&mut c, hw, hh, hw).unwrap();
        assert_eq!(
            unlit.try_run(&mut o5, Some(&mut c6), &mut []).err(),
            Some(Error::InvalidArgument)
        );
    }
    assert!(untouched(&t, &c, &s, &l));
}
