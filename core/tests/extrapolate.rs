//! The bilateral dilation of seed 004 Sec. 4.6.2 (`refl_core::extrapolate`).
//! Oracles: the weighted mean of the module docs recomputed in f64 from
//! the same inputs (linear depths decoded in f64, weights in closed form),
//! sources of one color across a depth edge (no other color may leak in),
//! and the results that bands, depth conventions and scales must not
//! change.
#![cfg(any(feature = "depth-image", feature = "hiz"))]
#![allow(clippy::needless_range_loop)] // pixel indices address several images at once

use core::f32::consts::FRAC_PI_2;
use refl_core::extrapolate::{
    ExtrapolateOptions, ExtrapolatePass, ExtrapolateStats, ExtrapolateStatus,
    MAX_EXTRAPOLATE_RADIUS,
};
use refl_core::glam::{Vec2, Vec3};
use refl_core::{
    Camera, DepthConvention, DepthImage, Error, GBuffer, ImageView, ImageViewMut, MirrorStatus,
    MirrorTexel, NormalSpace, RowRange,
};

const W: u32 = 24;
const H: u32 = 18;
const N: usize = (W * H) as usize;
const CONVENTIONS: [DepthConvention; 3] = [
    DepthConvention::Linear,
    DepthConvention::ZeroToOne,
    DepthConvention::ReversedZ,
];

/// A deterministic hash in `[0, 1)`.
fn hash(i: u32, salt: u32) -> f32 {
    let mut h = i.wrapping_mul(0x9E37_79B9) ^ salt.wrapping_mul(0x85EB_CA6B);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// One frame's inputs: linear depths, unit normals, texels, colors and
/// roughness, with the camera at `scale`.
struct Frame {
    cam: Camera,
    conv: DepthConvention,
    stored: Vec<f32>,
    normals: Vec<[f32; 3]>,
    texels: Vec<MirrorTexel>,
    color: Vec<[f32; 3]>,
    roughness: Vec<f32>,
}

fn texel(status: MirrorStatus) -> MirrorTexel {
    match status {
        MirrorStatus::Hit => MirrorTexel {
            status,
            pixel: Vec2::new(3.5, 2.5),
            t: 1.0,
            confidence: 1.0,
        },
        _ => MirrorTexel {
            status,
            ..MirrorTexel::default()
        },
    }
}

/// A wall tilted in depth (linear depth `4 + 0.05 x`, at `scale`), a box
/// face at depth 2 over the left third, sky in the top-right corner,
/// normals tilted by a few degrees from pixel to pixel; a mix of hits,
/// sky answers, holes (rays that left the image) and other host rays.
fn frame(scale: f32, conv: DepthConvention) -> Frame {
    let cam = Camera::try_look_at(
        Vec3::ZERO,
        Vec3::NEG_Z,
        Vec3::Y,
        FRAC_PI_2,
        0.1 * scale,
        100.0 * scale,
        W,
        H,
    )
    .unwrap();
    let mut f = Frame {
        cam,
        conv,
        stored: vec![0.0; N],
        normals: vec![[0.0; 3]; N],
        texels: vec![MirrorTexel::default(); N],
        color: vec![[0.0; 3]; N],
        roughness: vec![0.0; N],
    };
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let sky = x >= W - 3 && y < 3;
            let z = if sky {
                f32::INFINITY
            } else if x < W / 3 {
                2.0 * scale
            } else {
                (4.0 + 0.05 * x as f32) * scale
            };
            // A cleared depth buffer's far plane, exactly.
            f.stored[i] = if sky {
                match conv {
                    DepthConvention::Linear => 100.0 * scale,
                    DepthConvention::ZeroToOne => 1.0,
                    DepthConvention::ReversedZ => 0.0,
                }
            } else {
                cam.encode_depth(z, conv)
            };
            let n = Vec3::new(
                0.3 * (hash(i as u32, 1) - 0.5),
                0.3 * (hash(i as u32, 2) - 0.5),
                1.0,
            )
            .normalize();
            f.normals[i] = n.to_array();
            let r = hash(i as u32, 3);
            let status = if r < 0.55 {
                MirrorStatus::Hit
            } else if r < 0.65 {
                MirrorStatus::Sky
            } else if r < 0.85 {
                MirrorStatus::LeftImage
            } else if r < 0.95 {
                MirrorStatus::BehindGeometry
            } else {
                MirrorStatus::Skipped
            };
            f.texels[i] = texel(status);
            f.color[i] = [hash(i as u32, 4), hash(i as u32, 5), hash(i as u32, 6)];
            f.roughness[i] = hash(i as u32, 7);
        }
    }
    // A 9 x 3 patch of holes low on the wall: a radius of 1 leaves the
    // middle ones unfilled.
    for y in H - 5..H - 2 {
        for x in W - 12..W - 3 {
            f.texels[(y * W + x) as usize] = texel(MirrorStatus::LeftImage);
        }
    }
    // A NaN color on one answered pixel: never a source.
    f.texels[5 * W as usize + 12] = texel(MirrorStatus::Hit);
    f.color[5 * W as usize + 12] = [f32::NAN, 0.0, 0.0];
    f
}

impl Frame {
    fn gbuffer(&self, roughness: bool) -> GBuffer<'_> {
        let d = DepthImage::try_new(
            ImageView::try_new(&self.stored, W, H, W).unwrap(),
            self.cam,
            self.conv,
        )
        .unwrap();
        let g = GBuffer::try_new(
            d,
            ImageView::try_new(&self.normals, W, H, W).unwrap(),
            NormalSpace::World,
        )
        .unwrap();
        if roughness {
            g.try_with_roughness(ImageView::try_new(&self.roughness, W, H, W).unwrap())
                .unwrap()
        } else {
            g
        }
    }

    fn pass(&self, roughness: bool, o: ExtrapolateOptions) -> Result<ExtrapolatePass<'_>, Error> {
        ExtrapolatePass::try_new(
            self.gbuffer(roughness),
            ImageView::try_new(&self.texels, W, H, W).unwrap(),
            ImageView::try_new(&self.color, W, H, W).unwrap(),
            o,
        )
    }

    /// The f64 linear depth of pixel `i`, `None` for sky.
    fn depth64(&self, i: usize) -> Option<f64> {
        let (n, f) = (self.cam.near() as f64, self.cam.far() as f64);
        let d = self.stored[i] as f64;
        let z = match self.conv {
            DepthConvention::Linear => d,
            // d = f (z - n) / (z (f - n))  =>  z = f n / (f - d (f - n))
            DepthConvention::ZeroToOne => f * n / (f - d * (f - n)),
            // d = n (f - z) / (z (f - n))  =>  z = f n / (n + d (f - n))
            DepthConvention::ReversedZ => f * n / (n + d * (f - n)),
        };
        (z >= n && z < f).then_some(z)
    }
}

/// The module docs' dilation of hole `i` in f64.
fn oracle(f: &Frame, i: usize, o: &ExtrapolateOptions) -> Option<[f64; 3]> {
    let (x, y) = ((i as u32 % W) as i64, (i as u32 / W) as i64);
    let z = f.depth64(i)?;
    let n = Vec3::from_array(f.normals[i]).as_dvec3();
    let r = o.radius as i64;
    let (mut sum, mut wsum) = ([0.0f64; 3], 0.0f64);
    for qy in (y - r).max(0)..=(y + r).min(H as i64 - 1) {
        for qx in (x - r).max(0)..=(x + r).min(W as i64 - 1) {
            let q = (qy * W as i64 + qx) as usize;
            if !matches!(f.texels[q].status, MirrorStatus::Hit | MirrorStatus::Sky) {
                continue;
            }
            let c = f.color[q];
            if !c.iter().all(|v| v.is_finite()) {
                continue;
            }
            let Some(zq) = f.depth64(q) else { continue };
            let rel = (zq - z).abs() / z;
            if rel > o.depth_threshold as f64 {
                continue;
            }
            let s = o.spatial_sigma as f64;
            let d2 = ((qx - x).pow(2) + (qy - y).pow(2)) as f64;
            let ds = o.depth_sigma as f64;
            let cos = Vec3::from_array(f.normals[q]).as_dvec3().dot(n);
            let nw = if o.normal_power > 0.0 {
                cos.clamp(0.0, 1.0).powf(o.normal_power as f64)
            } else {
                1.0
            };
            let w = (-d2 / (2.0 * s * s)).exp() * (-(rel * rel) / (2.0 * ds * ds)).exp() * nw;
            if w > 0.0 {
                for k in 0..3 {
                    sum[k] += w * c[k] as f64;
                }
                wsum += w;
            }
        }
    }
    (wsum > 0.0).then(|| sum.map(|s| s / wsum))
}

/// A run's colors, statuses, host list and stats.
type Run = (Vec<[f32; 3]>, Vec<u8>, Vec<[u32; 2]>, ExtrapolateStats);

fn run(pass: &ExtrapolatePass<'_>) -> Run {
    let mut out = vec![[-1.0f32; 3]; N];
    let mut status = vec![255u8; N];
    let mut host = vec![[u32::MAX; 2]; N];
    let stats = pass
        .try_run(
            &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut status, W, H, W).unwrap()),
            &mut host,
        )
        .unwrap();
    host.truncate(stats.host_written as usize);
    (out, status, host, stats)
}

fn is_hole(t: &MirrorTexel, o: &ExtrapolateOptions) -> bool {
    if o.all_host_rays {
        t.status.needs_host()
    } else {
        t.status == MirrorStatus::LeftImage
    }
}

/// Every filled hole equals the f64 weighted mean; every kept pixel its
/// input color bit for bit; the statuses, the host list and the stats
/// agree with each other and with which pixels are holes.
#[test]
fn fills_equal_the_f64_weighted_mean() {
    let settings = [
        ExtrapolateOptions::default(),
        ExtrapolateOptions {
            radius: 1,
            spatial_sigma: 0.7,
            ..ExtrapolateOptions::default()
        },
        ExtrapolateOptions {
            radius: 6,
            spatial_sigma: f32::INFINITY,
            normal_power: 3.5,
            all_host_rays: true,
            ..ExtrapolateOptions::default()
        },
        ExtrapolateOptions {
            normal_power: 0.0,
            depth_threshold: f32::INFINITY,
            depth_sigma: f32::INFINITY,
            ..ExtrapolateOptions::default()
        },
        ExtrapolateOptions {
            radius: MAX_EXTRAPOLATE_RADIUS,
            depth_threshold: 0.02,
            depth_sigma: 0.01,
            normal_power: 64.0,
            ..ExtrapolateOptions::default()
        },
    ];
    for conv in CONVENTIONS {
        let f = frame(1.0, conv);
        for o in settings {
            let pass = f.pass(false, o).unwrap();
            let (out, status, host, stats) = run(&pass);
            // f32 arithmetic on linear depths; a post-projection depth near
            // the far plane decodes in f32 with a relative error of about
            // 1e-6, which the narrowest depth Gaussian (sigma 0.01) turns
            // into weights off by up to 1e-4 relative.
            let bound = if conv == DepthConvention::Linear {
                2e-6
            } else {
                1e-4
            };
            let mut counted = ExtrapolateStats::default();
            let mut listed = Vec::new();
            let mut worst = 0.0f64;
            for i in 0..N {
                let s = status[i];
                let hole = is_hole(&f.texels[i], &o) && f.depth64(i).is_some();
                if !hole {
                    assert_eq!(s, ExtrapolateStatus::Kept as u8, "{conv:?} {o:?} {i}");
                    assert_eq!(out[i].map(f32::to_bits), f.color[i].map(f32::to_bits));
                    continue;
                }
                counted.holes += 1;
                match oracle(&f, i, &o) {
                    Some(want) => {
                        assert_eq!(s, ExtrapolateStatus::Filled as u8, "{conv:?} {o:?} {i}");
                        counted.filled += 1;
                        for k in 0..3 {
                            let e = (out[i][k] as f64 - want[k]).abs();
                            worst = worst.max(e);
                            assert!(
                                e <= bound,
                                "{conv:?} {o:?} pixel {i}: {:?} vs {want:?}",
                                out[i]
                            );
                        }
                    }
                    None => {
                        assert_eq!(s, ExtrapolateStatus::Unfilled as u8, "{conv:?} {o:?} {i}");
                        assert_eq!(out[i].map(f32::to_bits), f.color[i].map(f32::to_bits));
                        counted.unfilled += 1;
                        listed.push([i as u32 % W, i as u32 / W]);
                    }
                }
                assert_eq!(pass.pixel(i as u32 % W, i as u32 / W).0, out[i]);
            }
            counted.host_written = listed.len() as u32;
            assert_eq!(stats, counted, "{conv:?} {o:?}");
            assert_eq!(host, listed);
            assert!(stats.filled > 20, "{conv:?} {o:?}: {stats:?}");
            if o.radius == 1 {
                assert!(stats.unfilled >= 7, "{conv:?} {o:?}: {stats:?}");
            }
            eprintln!("{conv:?} radius {}: {stats:?}, worst {worst:.2e}", o.radius);
        }
    }
}

/// Sources all red on a near box and all blue on the far wall behind it:
/// a hole on the wall next to the box's edge takes blue only (the depth
/// edge of 0.1 cuts every red pixel), and does take red when the edge is
/// turned off (so the first check can fail).
#[test]
fn never_blends_across_a_depth_edge() {
    let mut f = frame(1.0, DepthConvention::ReversedZ);
    for i in 0..N {
        let near = (i as u32 % W) < W / 3;
        f.color[i] = if near {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 0.0, 1.0]
        };
        f.normals[i] = [0.0, 0.0, 1.0];
        if f.texels[i].status != MirrorStatus::Skipped {
            f.texels[i] = texel(MirrorStatus::Hit);
        }
    }
    let edge: Vec<usize> = (0..H).map(|y| (y * W + W / 3) as usize).collect();
    for &i in &edge {
        f.texels[i] = texel(MirrorStatus::LeftImage);
    }
    let o = ExtrapolateOptions::default();
    let (out, status, _, _) = run(&f.pass(false, o).unwrap());
    for &i in &edge {
        assert_eq!(status[i], ExtrapolateStatus::Filled as u8);
        assert_eq!(out[i][0], 0.0, "pixel {i}: {:?}", out[i]);
        assert!((out[i][2] - 1.0).abs() < 1e-6);
    }
    let open = ExtrapolateOptions {
        depth_threshold: f32::INFINITY,
        depth_sigma: f32::INFINITY,
        ..o
    };
    let (out, _, _, _) = run(&f.pass(false, open).unwrap());
    assert!(
        edge.iter().all(|&i| out[i][0] > 0.1),
        "the open edge lets red in"
    );
}

/// Roughness: holes smoother than `min_roughness` (or NaN, or without a
/// roughness image) go to the host as `TooSmooth`, listed in row-major
/// order; rougher ones are filled as before.
#[test]
fn smooth_holes_go_to_the_host() {
    let mut f = frame(1.0, DepthConvention::Linear);
    let nan_at = (0..N)
        .find(|&i| f.texels[i].status == MirrorStatus::LeftImage && f.depth64(i).is_some())
        .unwrap();
    f.roughness[nan_at] = f32::NAN;
    let o = ExtrapolateOptions {
        min_roughness: 0.5,
        ..ExtrapolateOptions::default()
    };
    let all = ExtrapolateOptions::default();
    let (out_all, status_all, _, _) = run(&f.pass(true, all).unwrap());
    let (out, status, host, stats) = run(&f.pass(true, o).unwrap());
    let mut smooth = 0;
    for i in 0..N {
        let hole = is_hole(&f.texels[i], &o) && f.depth64(i).is_some();
        if hole && !(f.roughness[i] >= 0.5) {
            smooth += 1;
            assert_eq!(status[i], ExtrapolateStatus::TooSmooth as u8, "{i}");
            assert_eq!(out[i].map(f32::to_bits), f.color[i].map(f32::to_bits));
            assert!(host.contains(&[i as u32 % W, i as u32 / W]));
        } else {
            assert_eq!(status[i], status_all[i], "{i}");
            assert_eq!(out[i].map(f32::to_bits), out_all[i].map(f32::to_bits));
        }
    }
    assert_eq!(stats.too_smooth, smooth);
    assert!(smooth > 10 && status[nan_at] == ExtrapolateStatus::TooSmooth as u8);
    assert!(host
        .windows(2)
        .all(|p| (p[0][1], p[0][0]) < (p[1][1], p[1][0])));
    // Without a roughness image every surface is a mirror (roughness 0).
    let (_, _, _, s) = run(&f.pass(false, o).unwrap());
    assert_eq!((s.filled, s.too_smooth), (0, s.holes));
}

/// Every refusal returns `InvalidArgument` and leaves the caller's
/// buffers as they were, bit for bit.
#[test]
fn refusals_leave_the_outputs_untouched() {
    let f = frame(1.0, DepthConvention::ReversedZ);
    let d = ExtrapolateOptions::default();
    let bad = [
        ExtrapolateOptions { radius: 0, ..d },
        ExtrapolateOptions {
            radius: MAX_EXTRAPOLATE_RADIUS + 1,
            ..d
        },
        ExtrapolateOptions {
            spatial_sigma: f32::NAN,
            ..d
        },
        ExtrapolateOptions {
            spatial_sigma: 0.0,
            ..d
        },
        ExtrapolateOptions {
            depth_threshold: -1.0,
            ..d
        },
        ExtrapolateOptions {
            depth_sigma: f32::NAN,
            ..d
        },
        ExtrapolateOptions {
            normal_power: f32::INFINITY,
            ..d
        },
        ExtrapolateOptions {
            normal_power: -0.5,
            ..d
        },
        ExtrapolateOptions {
            min_roughness: f32::NAN,
            ..d
        },
        ExtrapolateOptions {
            min_roughness: f32::INFINITY,
            ..d
        },
    ];
    for o in bad {
        assert_eq!(o.try_validate(), Err(Error::InvalidArgument), "{o:?}");
        assert!(matches!(f.pass(false, o), Err(Error::InvalidArgument)));
    }
    // Inputs of another size.
    let small = vec![MirrorTexel::default(); N - W as usize];
    let small_color = vec![[0.0f32; 3]; N - W as usize];
    assert!(matches!(
        ExtrapolatePass::try_new(
            f.gbuffer(false),
            ImageView::try_new(&small, W, H - 1, W).unwrap(),
            ImageView::try_new(&f.color, W, H, W).unwrap(),
            d,
        ),
        Err(Error::InvalidArgument)
    ));
    assert!(matches!(
        ExtrapolatePass::try_new(
            f.gbuffer(false),
            ImageView::try_new(&f.texels, W, H, W).unwrap(),
            ImageView::try_new(&small_color, W, H - 1, W).unwrap(),
            d,
        ),
        Err(Error::InvalidArgument)
    ));
    // Outputs of another size, or whose bands differ.
    let pass = f.pass(false, d).unwrap();
    let pattern = f32::from_bits(0x7FC0_1234);
    let mut out = vec![[pattern; 3]; N];
    let mut status = vec![0xA5u8; N];
    let mut host = vec![[7u32; 2]; 8];
    let check = |out: &[[f32; 3]], status: &[u8], host: &[[u32; 2]]| {
        assert!(out.iter().flatten().all(|v| v.to_bits() == 0x7FC0_1234));
        assert!(status.iter().all(|&s| s == 0xA5));
        assert!(host.iter().all(|&h| h == [7, 7]));
    };
    let r = pass.try_run(
        &mut ImageViewMut::try_new(&mut out[..N - W as usize], W, H - 1, W).unwrap(),
        None,
        &mut host,
    );
    assert_eq!(r, Err(Error::InvalidArgument));
    check(&out, &status, &host);
    let (top, _) = out.split_at_mut(W as usize * 4);
    let r = pass.try_run(
        &mut ImageViewMut::try_band(top, W, H, W, RowRange::try_new(0, 4, H).unwrap()).unwrap(),
        Some(
            &mut ImageViewMut::try_band(
                &mut status[..W as usize * 5],
                W,
                H,
                W,
                RowRange::try_new(0, 5, H).unwrap(),
            )
            .unwrap(),
        ),
        &mut host,
    );
    assert_eq!(r, Err(Error::InvalidArgument));
    let r = pass.try_run(
        &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
        Some(&mut ImageViewMut::try_new(&mut status[..N - W as usize], W, H - 1, W).unwrap()),
        &mut host,
    );
    assert_eq!(r, Err(Error::InvalidArgument));
    check(&out, &status, &host);
}

/// Bands of any height give the full run's colors and statuses bit for
/// bit, their host lists concatenate to the full list, and their stats
/// sum to the full run's.
#[test]
fn row_bands_equal_one_full_run() {
    let f = frame(1.0, DepthConvention::ZeroToOne);
    let o = ExtrapolateOptions {
        radius: 1,
        min_roughness: 0.3,
        all_host_rays: true,
        ..ExtrapolateOptions::default()
    };
    let pass = f.pass(true, o).unwrap();
    let (out, status, host, stats) = run(&pass);
    assert!(stats.unfilled > 3 && stats.too_smooth > 3, "{stats:?}");
    for band in [1u32, 4, 7, H] {
        let mut bout = vec![[0.0f32; 3]; N];
        let mut bstatus = vec![0u8; N];
        let mut bhost = Vec::new();
        let mut sum = ExtrapolateStats::default();
        let mut y0 = 0;
        while y0 < H {
            let y1 = (y0 + band).min(H);
            let rows = RowRange::try_new(y0, y1, H).unwrap();
            let span = (y0 * W) as usize..(y1 * W) as usize;
            let mut list = vec![[0u32; 2]; N];
            let s = pass
                .try_run(
                    &mut ImageViewMut::try_band(&mut bout[span.clone()], W, H, W, rows).unwrap(),
                    Some(&mut ImageViewMut::try_band(&mut bstatus[span], W, H, W, rows).unwrap()),
                    &mut list,
                )
                .unwrap();
            bhost.extend_from_slice(&list[..s.host_written as usize]);
            sum.holes += s.holes;
            sum.filled += s.filled;
            sum.unfilled += s.unfilled;
            sum.too_smooth += s.too_smooth;
            sum.host_written += s.host_written;
            y0 = y1;
        }
        assert_eq!(
            bout.iter()
                .flatten()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>(),
            out.iter()
                .flatten()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>(),
            "band {band}"
        );
        assert_eq!(bstatus, status, "band {band}");
        assert_eq!(bhost, host, "band {band}");
        assert_eq!(sum, stats, "band {band}");
    }
    // A short host list keeps the first entries and counts only those.
    let mut short = [[0u32; 2]; 3];
    let mut o2 = vec![[0.0f32; 3]; N];
    let s = pass
        .try_run(
            &mut ImageViewMut::try_new(&mut o2, W, H, W).unwrap(),
            None,
            &mut short,
        )
        .unwrap();
    assert_eq!(s.host_written, 3);
    assert_eq!(s.unfilled + s.too_smooth, stats.unfilled + stats.too_smooth);
    assert_eq!(&short[..], &host[..3]);
}

/// Depth conventions and scene scales from 1e-3 to 1e4 (camera planes
/// scaled with the scene) give the same statuses and the same colors
/// within 1e-5 (the weights read only relative depths and normals).
#[test]
fn conventions_and_scales_agree() {
    let o = ExtrapolateOptions::default();
    let base = frame(1.0, DepthConvention::Linear);
    let (want, want_status, _, _) = run(&base.pass(false, o).unwrap());
    for conv in CONVENTIONS {
        for scale in [1e-3f32, 1.0, 1e4] {
            let f = frame(scale, conv);
            let (out, status, _, _) = run(&f.pass(false, o).unwrap());
            let differ = (0..N).filter(|&i| status[i] != want_status[i]).count();
            assert_eq!(differ, 0, "{conv:?} scale {scale}");
            let worst = (0..N)
                .flat_map(|i| (0..3).map(move |k| (i, k)))
                .map(|(i, k)| (out[i][k] - want[i][k]).abs())
                .fold(0.0f32, f32::max);
            assert!(worst <= 1e-5, "{conv:?} scale {scale}: {worst}");
        }
    }
}
