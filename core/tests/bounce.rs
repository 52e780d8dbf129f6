//! Multiple bounces (`refl_core::bounce`, seed 004 Sec. 4.6.4, Listing 4.9)
//! on an analytic scene ray-cast in f64 by the test: two parallel planar
//! mirrors facing each other (x = -2 and x = +2), a floor, a back wall and
//! a lit box between them. Oracles: the seed's bounce model evaluated in
//! f64 along ray-traced paths (what a mirror shows after `k` frames), the
//! previous eye's visibility of each point (f64 ray casts), the previous
//! camera's f64 projection, and the results that bands, depth conventions
//! and scales must not change.
#![cfg(any(feature = "depth-image", feature = "hiz"))]
#![allow(clippy::needless_range_loop)] // pixel indices address several images at once

use core::f32::consts::FRAC_PI_2;
use refl_core::bounce::{BounceOptions, BouncePass, BounceStats, BounceStatus, PreviousFrame};
use refl_core::glam::{DVec3, Vec3};
use refl_core::{
    Camera, DepthConvention, DepthImage, Error, GBuffer, ImageView, ImageViewMut, MirrorOptions,
    MirrorPass, MirrorStatus, MirrorTexel, NormalSpace, RowRange,
};

const W: u32 = 96;
const H: u32 = 64;
const N: usize = (W * H) as usize;

const CONVENTIONS: [DepthConvention; 3] = [
    DepthConvention::Linear,
    DepthConvention::ZeroToOne,
    DepthConvention::ReversedZ,
];

/// Object ids.
const SKY: u32 = 0;
const MIRROR_A: u32 = 1; // x = -2 s, facing +x
const MIRROR_B: u32 = 2; // x = +2 s, facing -x
const FLOOR: u32 = 3; // y = -1.5 s
const WALL: u32 = 4; // z = -12 s
const BOX: u32 = 5; // [-0.5, 0.5] x [-1.5, -0.5] x [-7, -6] (times s)

/// The specular weight of the mirrors in the host's composition
/// `final = lit + SPECULAR (reflection - lit)`.
const SPECULAR: f64 = 0.8;

fn is_mirror(id: u32) -> bool {
    id == MIRROR_A || id == MIRROR_B
}

/// The scene, scaled by `s`.
#[derive(Clone, Copy)]
struct Scene {
    s: f64,
}

impl Scene {
    fn box_hit(&self, o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
        let lo = DVec3::new(-0.5, -1.5, -7.0) * self.s;
        let hi = DVec3::new(0.5, -0.5, -6.0) * self.s;
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

    /// First hit along `o + t d` (t > 0), not on object `skip`: id, t,
    /// normal (facing the ray's origin side for the mirrors).
    fn cast(&self, o: DVec3, d: DVec3, skip: u32) -> (u32, f64, DVec3) {
        let s = self.s;
        let mut best = (SKY, f64::INFINITY, DVec3::ZERO);
        let mut take = |id: u32, t: f64, n: DVec3| {
            if id != skip && t > 0.0 && t < best.1 {
                best = (id, t, n);
            }
        };
        if let Some((t, n)) = self.box_hit(o, d) {
            take(BOX, t, n);
        }
        let inside = |p: DVec3, x: bool, y: bool, z: bool| {
            (!x || p.x.abs() <= 2.0 * s)
                && (!y || p.y.abs() <= 1.5 * s)
                && (!z || (p.z >= -12.0 * s && p.z <= 1.0 * s))
        };
        for (id, x, n) in [(MIRROR_A, -2.0, DVec3::X), (MIRROR_B, 2.0, DVec3::NEG_X)] {
            if d.x.abs() > 1e-300 {
                let t = (x * s - o.x) / d.x;
                if inside(o + d * t, false, true, true) {
                    take(id, t, n);
                }
            }
        }
        if d.y.abs() > 1e-300 {
            let t = (-1.5 * s - o.y) / d.y;
            if inside(o + d * t, true, false, true) {
                take(FLOOR, t, DVec3::Y);
            }
        }
        if d.z.abs() > 1e-300 {
            let t = (-12.0 * s - o.z) / d.z;
            if inside(o + d * t, true, true, false) {
                take(WALL, t, DVec3::Z);
            }
        }
        best
    }
}

/// The lit color (no reflections) of object `id` at point `p`: smooth,
/// gentle functions of the point (a few /255 over a pixel), so that a
/// texel's color stands for the points around it.
fn lit(id: u32, p: DVec3, s: f64) -> DVec3 {
    let p = p / s;
    match id {
        MIRROR_A | MIRROR_B => DVec3::new(0.05, 0.06, 0.08 + 0.01 * (0.2 * p.z).sin()),
        FLOOR => DVec3::new(
            0.35 + 0.1 * (0.25 * p.x + 0.15 * p.z).sin(),
            0.45,
            0.2 + 0.1 * (0.2 * p.z).cos(),
        ),
        WALL => DVec3::new(0.15, 0.3 + 0.1 * (0.3 * p.x + 0.2 * p.y).sin(), 0.65),
        BOX => DVec3::new(0.9, 0.3 + 0.08 * (0.4 * p.y + 0.2 * p.x).sin(), 0.1),
        _ => DVec3::ZERO,
    }
}

/// One frame's G-buffer: stored depth (in `conv`), world normals, ids,
/// world points, lit colors and the mirrors' mask.
struct Frame {
    scene: Scene,
    cam: Camera,
    conv: DepthConvention,
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    id: Vec<u32>,
    point: Vec<DVec3>,
    lit: Vec<[f32; 3]>,
    mask: Vec<u8>,
}

fn eye_ray(cam: &Camera, x: f64, y: f64) -> DVec3 {
    let inv = cam.inverse_view().as_dmat4();
    let (w, h) = (cam.width() as f64, cam.height() as f64);
    let ty = (cam.fov_y() as f64 / 2.0).tan();
    let tx = ty * w / h;
    let ndc = (x / w * 2.0 - 1.0, 1.0 - y / h * 2.0);
    inv.transform_vector3(DVec3::new(ndc.0 * tx, ndc.1 * ty, -1.0))
        .normalize()
}

/// The f64 projection of `p` by `cam`: pixel x, pixel y, linear depth.
fn project(cam: &Camera, p: DVec3) -> DVec3 {
    let v = cam.view().as_dmat4().transform_point3(p);
    let z = -v.z;
    let ty = (cam.fov_y() as f64 / 2.0).tan();
    let tx = ty * cam.width() as f64 / cam.height() as f64;
    DVec3::new(
        (v.x / (z * tx) + 1.0) * 0.5 * cam.width() as f64,
        (1.0 - v.y / (z * ty)) * 0.5 * cam.height() as f64,
        z,
    )
}

impl Frame {
    fn new(scene: Scene, eye: Vec3, target: Vec3, conv: DepthConvention) -> Self {
        let s = scene.s as f32;
        let cam = Camera::try_look_at(eye, target, Vec3::Y, FRAC_PI_2, 0.05 * s, 100.0 * s, W, H)
            .unwrap();
        let e = cam.eye().as_dvec3();
        let fwd = cam
            .inverse_view()
            .as_dmat4()
            .transform_vector3(DVec3::NEG_Z);
        let mut f = Frame {
            scene,
            cam,
            conv,
            depth: vec![0.0; N],
            normals: vec![[0.0; 3]; N],
            id: vec![SKY; N],
            point: vec![DVec3::ZERO; N],
            lit: vec![[0.0; 3]; N],
            mask: vec![0; N],
        };
        for y in 0..H {
            for x in 0..W {
                let d = eye_ray(&cam, x as f64 + 0.5, y as f64 + 0.5);
                let (id, t, n) = scene.cast(e, d, SKY);
                let i = (y * W + x) as usize;
                f.id[i] = id;
                if id == SKY {
                    f.depth[i] = cam.encode_depth(cam.far(), conv);
                    continue;
                }
                let p = e + d * t;
                f.depth[i] = cam.encode_depth((p - e).dot(fwd) as f32, conv);
                f.normals[i] = n.as_vec3().to_array();
                f.point[i] = p;
                f.lit[i] = lit(id, p, scene.s).as_vec3().to_array();
                f.mask[i] = u8::from(is_mirror(id));
            }
        }
        f
    }

    fn depth_image(&self) -> DepthImage<'_> {
        DepthImage::try_new(
            ImageView::try_new(&self.depth, W, H, W).unwrap(),
            self.cam,
            self.conv,
        )
        .unwrap()
    }

    /// The G-buffer with `color` as its color.
    fn gbuffer<'a>(&'a self, color: &'a [[f32; 3]]) -> GBuffer<'a> {
        GBuffer::try_new(
            self.depth_image(),
            ImageView::try_new(&self.normals, W, H, W).unwrap(),
            NormalSpace::World,
        )
        .unwrap()
        .try_with_color(ImageView::try_new(color, W, H, W).unwrap())
        .unwrap()
    }
}

/// The static view between the mirrors.
fn view(s: f64, conv: DepthConvention) -> Frame {
    let s32 = s as f32;
    Frame::new(
        Scene { s },
        Vec3::new(0.4, 0.3, 2.5) * s32,
        Vec3::new(0.0, -0.2, -6.0) * s32,
        conv,
    )
}

/// The bounce pass of `f` (lit color from `f`) reading `previous`'s final
/// image `last`: the source image, statuses and stats.
fn bounce(
    f: &Frame,
    previous: &Frame,
    last: &[[f32; 3]],
    options: BounceOptions,
) -> (Vec<[f32; 3]>, Vec<u8>, BounceStats) {
    let prev = PreviousFrame::try_new(
        previous.depth_image(),
        ImageView::try_new(last, W, H, W).unwrap(),
    )
    .unwrap();
    let pass = BouncePass::try_new(f.gbuffer(&f.lit), prev, options).unwrap();
    let mut out = vec![[-1.0f32; 3]; N];
    let mut status = vec![0xA5u8; N];
    let stats = pass
        .try_run(
            &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut status, W, H, W).unwrap()),
        )
        .unwrap();
    (out, status, stats)
}

fn mirror_options() -> MirrorOptions {
    MirrorOptions {
        border_fade: 0.0,
        ..MirrorOptions::default()
    }
}

/// `frames` frames of the static view `f` with attenuation `a`: source_k
/// from final_{k-1} (final_0 = lit), the mirror pass on a G-buffer whose
/// color is source_k, `final_k = lit + SPECULAR (reflection - lit)` at
/// hits, `lit` elsewhere. Returns every final image and the mirror texels
/// (the same every frame: static scene).
fn run_frames(f: &Frame, frames: usize, a: f32) -> (Vec<Vec<[f32; 3]>>, Vec<MirrorTexel>) {
    let options = BounceOptions {
        attenuation: a,
        ..BounceOptions::default()
    };
    let mut finals = vec![f.lit.clone()];
    let mut texels = vec![MirrorTexel::default(); N];
    for _ in 0..frames {
        let (source, _, _) = bounce(f, f, finals.last().unwrap(), options);
        let g = f
            .gbuffer(&source)
            .try_with_mask(ImageView::try_new(&f.mask, W, H, W).unwrap())
            .unwrap();
        let pass = MirrorPass::try_new(g, mirror_options(), None).unwrap();
        let mut color = vec![[0.0f32; 3]; N];
        pass.try_run(
            &mut ImageViewMut::try_new(&mut texels, W, H, W).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut color, W, H, W).unwrap()),
            &mut [],
        )
        .unwrap();
        let mut fin = f.lit.clone();
        for i in 0..N {
            if texels[i].status == MirrorStatus::Hit {
                for c in 0..3 {
                    let l = f.lit[i][c];
                    fin[i][c] = l + SPECULAR as f32 * (color[i][c] - l);
                }
            }
        }
        finals.push(fin);
    }
    (finals, texels)
}

/// The seed's bounce model in f64 after `k` frames at the visible point
/// `p` of object `id` (Sec. 4.6.4: a mirror shows what its reflection ray
/// hits, colored by the previous frame's final image there): `lit` for
/// `k = 0` and non-mirrors; otherwise `lit + SPECULAR (source - lit)`
/// with `source = lit_q + a (model(k - 1, q) - lit_q)` at the point `q`
/// the mirror ray from `p` (reflected view direction from the eye) hits.
/// Also returns the path: the objects and points met (`p` first). `None`
/// where the ray hits the sky.
fn model(
    scene: Scene,
    eye: DVec3,
    k: usize,
    id: u32,
    p: DVec3,
    a: f64,
) -> Option<(DVec3, Vec<(u32, DVec3)>)> {
    let l = lit(id, p, scene.s);
    if k == 0 || !is_mirror(id) {
        return Some((l, vec![(id, p)]));
    }
    let n = if id == MIRROR_A {
        DVec3::X
    } else {
        DVec3::NEG_X
    };
    let v = (p - eye).normalize();
    let r = v - 2.0 * v.dot(n) * n;
    let (id2, t, _) = scene.cast(p, r, id);
    if id2 == SKY {
        return None;
    }
    let q = p + r * t;
    let (fq, mut path) = model(scene, eye, k - 1, id2, q, a)?;
    let lq = lit(id2, q, scene.s);
    let source = lq + a * (fq - lq);
    path.insert(0, (id, p));
    Some((l + SPECULAR * (source - l), path))
}

/// The texels the screen reads from pixel `i` over `k` frames: `i`, then
/// the hit texel of each mirror on the way (`None` where a mirror texel on
/// the path was not a hit).
fn screen_path(f: &Frame, texels: &[MirrorTexel], i: usize, k: usize) -> Option<Vec<usize>> {
    let mut path = vec![i];
    let mut j = i;
    for _ in 0..k {
        if !is_mirror(f.id[j]) {
            break;
        }
        let t = texels[j];
        if t.status != MirrorStatus::Hit {
            return None;
        }
        j = (t.pixel.y as u32 * W + t.pixel.x as u32) as usize;
        path.push(j);
    }
    Some(path)
}

/// Whether `eye` sees the point `q` of object `id` (f64 ray cast: the
/// first hit from `eye` toward `q` is `q`, within 1e-9 relative).
fn visible(scene: Scene, eye: DVec3, id: u32, q: DVec3) -> bool {
    let d = q - eye;
    let len = d.length();
    let (hit, t, _) = scene.cast(eye, d / len, SKY);
    hit == id && (t - len).abs() <= 1e-9 * len
}

/// Whether the screen's texel path is the ray-traced one: the same
/// objects, and every point `q` the rays meet is visible from the eye
/// ([`visible`]) and lies in the texel the mirror pass read or a neighbor of it (the
/// pass's hit is refined to sub-pixel precision; a hit two texels away
/// is another point: a ray that passed behind the box and was taken on
/// the wall beyond it, `MirrorPass` step 7).
fn same_path(f: &Frame, path: &[(u32, DVec3)], screen: &[usize]) -> bool {
    if path.len() != screen.len() {
        return false;
    }
    path.iter().zip(screen).all(|(&(id, q), &j)| {
        let pq = project(&f.cam, q);
        let (qx, qy) = (pq.x.floor(), pq.y.floor());
        if !(qx >= 0.0 && qy >= 0.0 && qx < W as f64 && qy < H as f64) {
            return false;
        }
        let seen = visible(f.scene, f.cam.eye().as_dvec3(), id, q);
        let (jx, jy) = ((j as u32 % W) as f64, (j as u32 / W) as f64);
        f.id[j] == id && seen && (jx - qx).abs() <= 1.0 && (jy - qy).abs() <= 1.0
    })
}

/// The pipeline of [`run_frames`] in f64 along the screen's own texel
/// path (the same texels, the same composition; the bounce pass's source
/// is `lit + a (final - lit)` at the texel itself for a static camera):
/// the oracle of the bounce pass without the discretisation of the
/// screen-space read.
fn discrete(f: &Frame, texels: &[MirrorTexel], i: usize, k: usize, a: f64) -> DVec3 {
    let l = Vec3::from_array(f.lit[i]).as_dvec3();
    if k == 0 || !is_mirror(f.id[i]) || texels[i].status != MirrorStatus::Hit {
        return l;
    }
    let t = texels[i];
    let j = (t.pixel.y as u32 * W + t.pixel.x as u32) as usize;
    let lj = Vec3::from_array(f.lit[j]).as_dvec3();
    let source = lj + a * (discrete(f, texels, j, k - 1, a) - lj);
    l + SPECULAR * (source - l)
}

/// Largest difference (in /255) of the final image after `frames` frames
/// to the f64 model and to the f64 discrete pipeline, over the pixels
/// whose screen path is the ray-traced one ([`same_path`]), split by
/// two-bounce paths (mirror, mirror, non-mirror) and all; with the counts,
/// the pixels whose path the screen does not follow, the largest
/// discretisation spread of a path (below) and the largest excess of a
/// pixel's model error over its own spread.
#[derive(Debug)]
struct Compare {
    two_bounce: (usize, f64),
    all: (usize, f64),
    discrete: f64,
    other_path: usize,
    spread: f64,
    excess: f64,
}

fn compare(f: &Frame, fin: &[[f32; 3]], texels: &[MirrorTexel], frames: usize, a: f64) -> Compare {
    let eye = f.cam.eye().as_dvec3();
    let mut c = Compare {
        two_bounce: (0, 0.0),
        all: (0, 0.0),
        discrete: 0.0,
        other_path: 0,
        spread: 0.0,
        excess: f64::NEG_INFINITY,
    };
    for i in 0..N {
        if !is_mirror(f.id[i]) {
            continue;
        }
        let got = Vec3::from_array(fin[i]).as_dvec3();
        let d = (got - discrete(f, texels, i, frames, a))
            .abs()
            .max_element()
            * 255.0;
        c.discrete = c.discrete.max(d);
        let Some((want, path)) = model(f.scene, eye, frames, f.id[i], f.point[i], a) else {
            continue;
        };
        let Some(screen) = screen_path(f, texels, i, frames) else {
            continue;
        };
        if !same_path(f, &path, &screen) {
            c.other_path += 1;
            continue;
        }
        let d = (got - want).abs().max_element() * 255.0;
        // The model is a convex combination of the lit colors at the
        // path's points (weights 1 - SPECULAR, SPECULAR (1 - a), ...); the
        // screen evaluates the same combination at the points its texels'
        // centers see. So the two differ by at most the largest change of
        // a lit color between a path point and its texel center's point.
        let spread = path
            .iter()
            .zip(&screen)
            .map(|(&(id, q), &j)| {
                (lit(id, f.point[j], f.scene.s) - lit(id, q, f.scene.s))
                    .abs()
                    .max_element()
                    * 255.0
            })
            .fold(0.0f64, f64::max);
        c.spread = c.spread.max(spread);
        c.excess = c.excess.max(d - spread);
        c.all = (c.all.0 + 1, c.all.1.max(d));
        if path.len() == 3 && is_mirror(path[1].0) && !is_mirror(path[2].0) {
            c.two_bounce = (c.two_bounce.0 + 1, c.two_bounce.1.max(d));
        }
    }
    c
}

/// Two facing mirrors, static camera: every surface pixel re-projects;
/// after one and two frames the final image equals the f64 pipeline along
/// the screen's texels within 0.05/255 (f32 rounding of a few blends of
/// colors in [0, 1]), and every pixel whose reflection path the screen
/// follows equals the f64 bounce model within its path's discretisation
/// spread (`compare`) plus 0.05/255 (every convention);
/// with attenuation 0 the second frame equals the first (one bounce) bit
/// for bit.
#[test]
fn two_facing_mirrors_accumulate_bounces() {
    let a = 0.9;
    for conv in CONVENTIONS {
        let f = view(1.0, conv);
        let surfaces = f.id.iter().filter(|&&id| id != SKY).count() as u32;
        let (_, status, stats) = bounce(&f, &f, &f.lit, BounceOptions::default());
        assert_eq!(stats.reprojected, surfaces, "{conv:?}: {stats:?}");
        assert_eq!(stats.no_surface, N as u32 - surfaces, "{conv:?}");
        for i in 0..N {
            let want = if f.id[i] == SKY {
                BounceStatus::NoSurface
            } else {
                BounceStatus::Reprojected
            };
            assert_eq!(status[i], want as u8, "{conv:?}: pixel {i}");
        }
        let (finals, texels) = run_frames(&f, 2, a as f32);
        let c2 = compare(&f, &finals[2], &texels, 2, a);
        let c1 = compare(&f, &finals[1], &texels, 1, a);
        eprintln!("{conv:?}: frame 2: {c2:?}; frame 1: {c1:?}");
        assert!(
            c2.two_bounce.0 >= 200,
            "{conv:?}: {} two-bounce pixels",
            c2.two_bounce.0
        );
        assert!(
            c2.discrete <= 0.05 && c1.discrete <= 0.05,
            "{conv:?}: {c2:?} {c1:?}"
        );
        // Each pixel within its own path's discretisation spread plus f32
        // rounding (the spread is the scene's, not the pass's: up to
        // 3.7/255 here, where a mirror sees the floor at a grazing angle
        // through the other mirror; the model error itself stays <= 2.2).
        for c in [&c1, &c2] {
            assert!(c.excess <= 0.05, "{conv:?}: {c:?}");
            assert!(c.other_path * 10 <= c.all.0, "{conv:?}: {c:?}");
        }
        // The second bounce shows: frame 2 differs from frame 1 there.
        let eye = f.cam.eye().as_dvec3();
        let (mut changed, mut traced) = (0, 0);
        for i in 0..N {
            let d = (0..3)
                .map(|c| (finals[2][i][c] - finals[1][i][c]).abs())
                .fold(0.0f32, f32::max);
            if d > 5.0 / 255.0 {
                changed += 1;
                // Only pixels whose screen path reads a second mirror's
                // texel change (the ray-traced path may differ: a hit the
                // mirror pass took behind the box, `same_path`).
                let path = screen_path(&f, &texels, i, 2);
                assert!(
                    path.is_some_and(|p| p.len() == 3 && is_mirror(f.id[p[1]])),
                    "{conv:?}: pixel {i}"
                );
                if model(f.scene, eye, 2, f.id[i], f.point[i], a)
                    .is_some_and(|m| m.1.len() == 3 && is_mirror(m.1[1].0))
                {
                    traced += 1;
                }
            }
        }
        assert!(changed >= 200, "{conv:?}: {changed} pixels changed");
        assert!(
            traced * 10 >= changed * 9,
            "{conv:?}: {traced} of {changed}"
        );

        // Attenuation 0: the one-bounce source, every frame.
        let (finals0, _) = run_frames(&f, 2, 0.0);
        let diff = |x: &[[f32; 3]], y: &[[f32; 3]]| {
            (0..N)
                .filter(|&i| x[i] != y[i])
                .map(|i| (i, x[i], y[i], f.id[i]))
                .collect::<Vec<_>>()
        };
        let d = diff(&finals0[2], &finals0[1]);
        assert!(
            d.is_empty(),
            "{conv:?}: {} {:?}",
            d.len(),
            &d[..d.len().min(5)]
        );
        // Frame 1 reads final_0 = lit whatever the attenuation: the same up
        // to the f32 round trip of the re-projection (the pixel center
        // comes back off by ~1e-5 px, so a neighbor texel gets a bilinear
        // weight of that order).
        let (f0, f1) = (&finals0[1], &finals[1]);
        let d = (0..N)
            .flat_map(|i| (0..3).map(move |c| (f0[i][c] - f1[i][c]).abs()))
            .fold(0.0f32, f32::max);
        eprintln!(
            "{conv:?}: frame 1, attenuation 0 vs {a}: max {}/255",
            d * 255.0
        );
        assert!(d * 255.0 <= 0.01, "{conv:?}: {}/255", d * 255.0);
        let c0 = compare(&f, &finals0[2], &texels, 1, 0.0);
        assert!(c0.excess <= 0.05 && c0.discrete <= 0.05, "{conv:?}: {c0:?}");
    }
}

/// The previous and the current frame of a camera that moves sideways,
/// forward and turns (scene scaled by `s`): the box uncovers part of the
/// wall and floor, and the current view sees what the previous did not.
fn moving(s: f64, conv: DepthConvention) -> (Frame, Frame) {
    let s32 = s as f32;
    let prev = Frame::new(
        Scene { s },
        Vec3::new(-1.0, -0.5, -4.0) * s32,
        Vec3::new(0.3, -0.8, -7.0) * s32,
        conv,
    );
    let cur = Frame::new(
        Scene { s },
        Vec3::new(1.0, -0.3, -3.5) * s32,
        Vec3::new(-0.4, -0.8, -7.0) * s32,
        conv,
    );
    (prev, cur)
}

/// What the oracle expects of pixel `i` of `cur` re-projected into
/// `prev` (f64): `None` for no surface; otherwise the status and whether
/// the pixel lies in the silhouette band (its previous position within
/// 2 px of a previous texel that shows another object, or within 1e-3 px
/// of the image border), where f32 and the tolerance may decide either way.
fn expected(cur: &Frame, prev: &Frame, i: usize) -> Option<(BounceStatus, bool)> {
    if cur.id[i] == SKY {
        return None;
    }
    let p = cur.point[i];
    let q = project(&prev.cam, p);
    let (w, h) = (W as f64, H as f64);
    if !(q.z > 0.0) || q.x < 0.0 || q.y < 0.0 || q.x > w || q.y > h {
        let border = q.z > 0.0
            && (q.x.abs().min((q.x - w).abs()) < 1e-3 || q.y.abs().min((q.y - h).abs()) < 1e-3);
        return Some((BounceStatus::OffScreen, border));
    }
    let border = q.x < 1e-3 || q.y < 1e-3 || w - q.x < 1e-3 || h - q.y < 1e-3;
    let (qx, qy) = (q.x.floor() as i64, q.y.floor() as i64);
    let mut band = border;
    for y in qy - 2..=qy + 2 {
        for x in qx - 2..=qx + 2 {
            if x >= 0 && y >= 0 && x < W as i64 && y < H as i64 {
                band |= prev.id[(y as u32 * W + x as u32) as usize] != cur.id[i];
            }
        }
    }
    let seen = visible(prev.scene, prev.cam.eye().as_dvec3(), cur.id[i], p);
    let status = if seen {
        BounceStatus::Reprojected
    } else {
        BounceStatus::Rejected
    };
    Some((status, band))
}

fn status_of(b: u8) -> BounceStatus {
    match b {
        0 => BounceStatus::NoSurface,
        1 => BounceStatus::Reprojected,
        2 => BounceStatus::OffScreen,
        3 => BounceStatus::Rejected,
        _ => panic!("status byte {b}"),
    }
}

/// Counts of the statuses in a status image, as [`BounceStats`].
fn count(status: &[u8]) -> BounceStats {
    let mut s = BounceStats::default();
    for &b in status {
        match status_of(b) {
            BounceStatus::NoSurface => s.no_surface += 1,
            BounceStatus::Reprojected => s.reprojected += 1,
            BounceStatus::OffScreen => s.off_screen += 1,
            BounceStatus::Rejected => s.rejected += 1,
        }
    }
    s
}

/// A moving camera (every convention): each surface pixel is
/// `Reprojected` where the previous eye saw its point (f64 ray cast),
/// `Rejected` where it did not (disoccluded), `OffScreen` where its point
/// projects outside the previous image (f64 projection); disagreements
/// only in the silhouette band of [`expected`], at most 0.5% of the
/// surface pixels; `NoSurface` exactly on the sky; a pixel that is not
/// re-projected gets its lit color bit for bit, a re-projected one the
/// previous final image (attenuation 1) within the bilinear spread of
/// the smooth lit colors (0.5/255; measured 0.07); the stats count the
/// status image.
#[test]
fn moving_camera_rejects_disoccluded_and_off_screen_pixels() {
    for conv in CONVENTIONS {
        let (prev, cur) = moving(1.0, conv);
        let (out, status, stats) = bounce(&cur, &prev, &prev.lit, BounceOptions::default());
        assert_eq!(stats, count(&status), "{conv:?}");
        let (mut band, mut wrong, mut surfaces) = (0, 0, 0);
        let mut max_color = 0.0f64;
        for i in 0..N {
            let got = status_of(status[i]);
            let Some((want, in_band)) = expected(&cur, &prev, i) else {
                assert_eq!(got, BounceStatus::NoSurface, "{conv:?}: pixel {i}");
                assert_eq!(out[i], cur.lit[i], "{conv:?}: pixel {i}");
                continue;
            };
            surfaces += 1;
            band += usize::from(in_band);
            if got != want {
                assert!(in_band, "{conv:?}: pixel {i}: {got:?}, want {want:?}");
                wrong += 1;
            }
            if got == BounceStatus::Reprojected {
                if want == BounceStatus::Reprojected && !in_band {
                    // The previous final image is the lit color of the
                    // same point: bilinear interpolation of a smooth color
                    // over one texel, a few /255 at most.
                    let d = (Vec3::from_array(out[i]).as_dvec3()
                        - Vec3::from_array(cur.lit[i]).as_dvec3())
                    .abs()
                    .max_element();
                    max_color = max_color.max(d * 255.0);
                }
            } else {
                assert_eq!(out[i], cur.lit[i], "{conv:?}: pixel {i}");
            }
        }
        eprintln!(
            "{conv:?}: {stats:?}; {wrong} disagreements in a band of {band} of {surfaces} surface pixels; re-projected color max {max_color:.3}/255"
        );
        assert!(
            stats.rejected >= 50 && stats.off_screen >= 50,
            "{conv:?}: {stats:?}"
        );
        assert!(
            wrong * 1000 <= surfaces * 5,
            "{conv:?}: {wrong} of {surfaces}"
        );
        assert!(max_color <= 0.5, "{conv:?}: {max_color}/255");
    }
}

/// Row bands: the pass run over 1, 2, 5 and 64 bands (each into its own
/// band view of the output, and through `try_run_rows`) writes the same
/// bits as one full run, and the bands' stats sum to the full run's.
#[test]
fn row_bands_equal_one_full_run() {
    let (prev, cur) = moving(1.0, DepthConvention::ReversedZ);
    let options = BounceOptions {
        attenuation: 0.7,
        ..BounceOptions::default()
    };
    let (full, full_status, full_stats) = bounce(&cur, &prev, &prev.lit, options);
    let previous = PreviousFrame::try_new(
        prev.depth_image(),
        ImageView::try_new(&prev.lit, W, H, W).unwrap(),
    )
    .unwrap();
    let pass = BouncePass::try_new(cur.gbuffer(&cur.lit), previous, options).unwrap();
    for count in [1u32, 2, 5, 64] {
        let mut out = vec![[-1.0f32; 3]; N];
        let mut status = vec![0xA5u8; N];
        let mut sum = BounceStats::default();
        let all = RowRange::try_all(H).unwrap();
        for b in 0..count {
            let rows = all.band(b, count).unwrap();
            let (lo, hi) = ((rows.start() * W) as usize, (rows.end() * W) as usize);
            let s = pass
                .try_run(
                    &mut ImageViewMut::try_band(&mut out[lo..hi], W, H, W, rows).unwrap(),
                    Some(&mut ImageViewMut::try_band(&mut status[lo..hi], W, H, W, rows).unwrap()),
                )
                .unwrap();
            sum.reprojected += s.reprojected;
            sum.rejected += s.rejected;
            sum.off_screen += s.off_screen;
            sum.no_surface += s.no_surface;
        }
        assert_eq!(sum, full_stats, "{count} bands");
        assert_eq!(status, full_status, "{count} bands");
        let bits = |v: &[[f32; 3]]| {
            v.iter()
                .flat_map(|c| c.map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&out), bits(&full), "{count} bands");

        // The same through the sink.
        let mut out = vec![[-1.0f32; 3]; N];
        let mut status = vec![0xA5u8; N];
        let mut sum = BounceStats::default();
        for b in 0..count {
            let s = pass
                .try_run_rows(all.band(b, count).unwrap(), &mut |x, y, c, st| {
                    out[(y * W + x) as usize] = c;
                    status[(y * W + x) as usize] = st as u8;
                })
                .unwrap();
            sum.reprojected += s.reprojected;
            sum.rejected += s.rejected;
            sum.off_screen += s.off_screen;
            sum.no_surface += s.no_surface;
        }
        assert_eq!(sum, full_stats, "{count} bands, sink");
        assert_eq!(status, full_status, "{count} bands, sink");
        assert_eq!(bits(&out), bits(&full), "{count} bands, sink");
        // `pixel` is what the runs write.
        for i in (0..N).step_by(7) {
            let (c, s) = pass.pixel(i as u32 % W, i as u32 / W);
            assert_eq!(
                (c.map(f32::to_bits), s as u8),
                (full[i].map(f32::to_bits), full_status[i])
            );
        }
    }
}

/// Every depth convention and scene scales 1e-3, 1 and 1e4 give the
/// statuses of the linear, unit-scale run (up to 0.3% of the pixels, all
/// in the silhouette band of [`expected`]) and, where both re-project,
/// colors within 0.05/255 (attenuation 0.6).
#[test]
fn conventions_and_scales_agree() {
    let options = BounceOptions {
        attenuation: 0.6,
        ..BounceOptions::default()
    };
    let (p0, c0) = moving(1.0, DepthConvention::Linear);
    let last: Vec<[f32; 3]> = p0.lit.iter().map(|c| [c[2], c[0], c[1]]).collect();
    let (out0, st0, _) = bounce(&c0, &p0, &last, options);
    for s in [1e-3, 1.0, 1e4] {
        for conv in CONVENTIONS {
            let (p, c) = moving(s, conv);
            assert_eq!(c.id, c0.id, "{s} {conv:?}");
            let (out, st, stats) = bounce(&c, &p, &last, options);
            assert_eq!(stats, count(&st));
            let (mut differ, mut max) = (0, 0.0f32);
            for i in 0..N {
                if st[i] != st0[i] {
                    differ += 1;
                    assert!(
                        expected(&c0, &p0, i).is_some_and(|e| e.1),
                        "{s} {conv:?}: pixel {i}"
                    );
                } else {
                    for k in 0..3 {
                        max = max.max((out[i][k] - out0[i][k]).abs() * 255.0);
                    }
                }
            }
            eprintln!("scale {s} {conv:?}: {differ} statuses differ, colors max {max}/255");
            assert!(differ * 1000 <= N * 3, "{s} {conv:?}: {differ}");
            assert!(max <= 0.05, "{s} {conv:?}: {max}/255");
        }
    }
}

fn frame_pass<'a>(
    cur: &'a Frame,
    prev: &'a Frame,
    last: &'a [[f32; 3]],
    options: BounceOptions,
) -> BouncePass<'a> {
    let previous = PreviousFrame::try_new(
        prev.depth_image(),
        ImageView::try_new(last, W, H, W).unwrap(),
    )
    .unwrap();
    BouncePass::try_new(cur.gbuffer(&cur.lit), previous, options).unwrap()
}

/// Every refusal: a previous color not the previous depth's size, a
/// G-buffer without color, options with NaN, infinite, negative or > 1
/// attenuation or NaN, infinite or negative tolerance, an output or status
/// image not the G-buffer's size or of another band, rows beyond the
/// image: `InvalidArgument`, and the output buffers keep every byte.
#[test]
fn refusals_leave_the_output_untouched() {
    let (prev, cur) = moving(1.0, DepthConvention::ZeroToOne);
    let small = vec![[0.5f32; 3]; ((W - 1) * H) as usize];
    assert_eq!(
        PreviousFrame::try_new(
            prev.depth_image(),
            ImageView::try_new(&small, W - 1, H, W - 1).unwrap()
        )
        .err(),
        Some(Error::InvalidArgument)
    );
    let previous = PreviousFrame::try_new(
        prev.depth_image(),
        ImageView::try_new(&prev.lit, W, H, W).unwrap(),
    )
    .unwrap();
    let bare = GBuffer::try_new(
        cur.depth_image(),
        ImageView::try_new(&cur.normals, W, H, W).unwrap(),
        NormalSpace::World,
    )
    .unwrap();
    assert_eq!(
        BouncePass::try_new(bare, previous, BounceOptions::default()).err(),
        Some(Error::InvalidArgument)
    );
    let d = BounceOptions::default();
    for bad in [
        BounceOptions {
            attenuation: f32::NAN,
            ..d
        },
        BounceOptions {
            attenuation: -0.01,
            ..d
        },
        BounceOptions {
            attenuation: 1.01,
            ..d
        },
        BounceOptions {
            attenuation: f32::INFINITY,
            ..d
        },
        BounceOptions {
            depth_tolerance: f32::NAN,
            ..d
        },
        BounceOptions {
            depth_tolerance: -1e-6,
            ..d
        },
        BounceOptions {
            depth_tolerance: f32::INFINITY,
            ..d
        },
    ] {
        assert_eq!(bad.try_validate(), Err(Error::InvalidArgument), "{bad:?}");
        assert_eq!(
            BouncePass::try_new(cur.gbuffer(&cur.lit), previous, bad).err(),
            Some(Error::InvalidArgument),
            "{bad:?}"
        );
    }
    for good in [
        BounceOptions {
            attenuation: 0.0,
            depth_tolerance: 0.0,
        },
        BounceOptions {
            attenuation: 1.0,
            depth_tolerance: 1e30,
        },
    ] {
        assert_eq!(good.try_validate(), Ok(()));
    }

    let pass = frame_pass(&cur, &prev, &prev.lit, d);
    let pattern = [f32::from_bits(0x7FC0_1234), -0.0, 7.5];
    let check = |out: &[[f32; 3]], st: &[u8]| {
        assert!(out
            .iter()
            .all(|c| c.map(f32::to_bits) == pattern.map(f32::to_bits)));
        assert!(st.iter().all(|&b| b == 0x5A));
    };
    // Output of the wrong size.
    let mut out = vec![pattern; N];
    let mut st = vec![0x5Au8; N];
    let r = pass.try_run(
        &mut ImageViewMut::try_new(&mut out[..N - W as usize], W, H - 1, W).unwrap(),
        None,
    );
    assert_eq!(r, Err(Error::InvalidArgument));
    let r = pass.try_run(
        &mut ImageViewMut::try_new(&mut out, W - 1, H, W).unwrap(),
        None,
    );
    assert_eq!(r, Err(Error::InvalidArgument));
    check(&out, &st);
    // Status of the wrong size, or of another band.
    let r = pass.try_run(
        &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
        Some(&mut ImageViewMut::try_new(&mut st[..N - W as usize], W, H - 1, W).unwrap()),
    );
    assert_eq!(r, Err(Error::InvalidArgument));
    check(&out, &st);
    let rows = RowRange::try_new(0, H / 2, H).unwrap();
    let r = pass.try_run(
        &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
        Some(&mut ImageViewMut::try_band(&mut st, W, H, W, rows).unwrap()),
    );
    assert_eq!(r, Err(Error::InvalidArgument));
    check(&out, &st);
    // Rows beyond the image.
    let mut called = false;
    let r = pass.try_run_rows(
        RowRange::try_new(H - 1, H + 1, H + 1).unwrap(),
        &mut |_, _, _, _| called = true,
    );
    assert_eq!(r, Err(Error::InvalidArgument));
    assert!(!called);
    // The refusals wrote nothing; a valid run then writes every pixel.
    let stats = pass
        .try_run(
            &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut st, W, H, W).unwrap()),
        )
        .unwrap();
    assert_eq!(stats, count(&st));
    assert!(out.iter().all(|c| c.iter().all(|v| v.is_finite())));
}

/// Non-finite inputs (every convention): a previous texel with a NaN or
/// infinite color, or a NaN, infinite or negative depth, is never read
/// (a static camera, whose pixels read their own texel: `Rejected` and
/// `lit` there, finite colors everywhere else); a non-finite lit color is
/// passed through bit for bit; a blend that overflows (`lit` 3e38,
/// previous -3e38) gives `lit`.
#[test]
fn non_finite_inputs_follow_the_documented_rules() {
    for conv in CONVENTIONS {
        let f = view(1.0, conv);
        let bad: Vec<usize> = (0..N).filter(|&i| f.id[i] != SKY && i % 11 == 3).collect();
        // Previous colors.
        let mut last = f.lit.clone();
        for (k, &i) in bad.iter().enumerate() {
            last[i] = [
                [f32::NAN, 0.0, 0.0],
                [0.0, f32::INFINITY, 0.0],
                [0.0, 0.0, f32::NEG_INFINITY],
            ][k % 3];
        }
        let (out, st, _) = bounce(&f, &f, &last, BounceOptions::default());
        for i in 0..N {
            assert!(out[i].iter().all(|v| v.is_finite()), "{conv:?}: pixel {i}");
            if bad.contains(&i) {
                assert_eq!(
                    (out[i], status_of(st[i])),
                    (f.lit[i], BounceStatus::Rejected),
                    "{conv:?}: pixel {i}"
                );
            }
        }
        // Previous depths.
        let mut prev = view(1.0, conv);
        let (w, h) = (prev.cam.width(), prev.cam.height());
        assert_eq!((w, h), (W, H));
        for (k, &i) in bad.iter().enumerate() {
            prev.depth[i] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0][k % 4];
        }
        let (out, st, _) = bounce(&f, &prev, &f.lit, BounceOptions::default());
        for i in 0..N {
            assert!(out[i].iter().all(|v| v.is_finite()), "{conv:?}: pixel {i}");
            if bad.contains(&i) {
                assert_eq!(
                    (out[i], status_of(st[i])),
                    (f.lit[i], BounceStatus::Rejected),
                    "{conv:?}: pixel {i}: {}",
                    prev.depth[i]
                );
            }
        }
        // Non-finite lit colors, and an overflowing blend.
        let mut g = view(1.0, conv);
        for (k, &i) in bad.iter().enumerate() {
            g.lit[i] = [
                [f32::NAN, 0.5, 0.5],
                [f32::INFINITY, 0.0, 0.0],
                [3e38, 3e38, 3e38],
            ][k % 3];
        }
        let mut last = f.lit.clone();
        for &i in &bad {
            last[i] = [-3e38; 3];
        }
        let (out, st, _) = bounce(&g, &f, &last, BounceOptions::default());
        for &i in &bad {
            assert_eq!(
                out[i].map(f32::to_bits),
                g.lit[i].map(f32::to_bits),
                "{conv:?}: pixel {i}"
            );
            assert_eq!(
                status_of(st[i]),
                BounceStatus::Reprojected,
                "{conv:?}: pixel {i}"
            );
        }
    }
}
