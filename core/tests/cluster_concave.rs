//! Seed 003 Sec. 4.4 (concave clusters) and Sec. 4.2.2 (the single-ray
//! glossy reflection) against f64 oracles: the concavity test against the
//! closed-form center of paraboloids and sphere patches, the second
//! intersection of a mirror bowl's rays with the bowl against the exact
//! second root of the sphere, and the single-ray glossy neighborhood
//! against constant and linear colors and the lobe of many rays.
#![cfg(feature = "cluster")]

use refl_core::cluster::*;
use refl_core::glam::{DVec3, Vec2, Vec3};
use refl_core::{
    Camera, DepthConvention, DepthImage, Error, GBuffer, ImageView, ImageViewMut, NormalSpace,
    StepOptions, Thickness,
};

// ---------------------------------------------------------------- detection

#[test]
fn center_height_is_the_paraboloid_center() {
    let (c, n) = (Vec3::new(0.5, -1.0, 2.0), Vec3::new(0.0, 0.6, 0.8));
    let (u, v) = n.any_orthonormal_pair();
    for (a, k) in [(-0.03f64, 0.4f64), (0.02, -0.7), (0.0, 0.0), (-1e-3, 2.0)] {
        // Points s = a + k rho^2 on a grid; the centroid is not on the axis
        // in general, so the fit's frame is the one given.
        let pts: Vec<Vec3> = (0..121)
            .map(|i| {
                let (x, y) = ((i % 11) as f64 * 0.1 - 0.5, (i / 11) as f64 * 0.1 - 0.5);
                let s = a + k * (x * x + y * y);
                (c.as_dvec3() + u.as_dvec3() * x + v.as_dvec3() * y + n.as_dvec3() * s).as_vec3()
            })
            .collect();
        let got = center_height(pts.iter().copied(), c, n).unwrap();
        assert!((got - a).abs() < 1e-6, "a {a} k {k}: {got}");
    }
    // A ring: every point at one distance from the axis, no slope.
    let ring: Vec<Vec3> = (0..16)
        .map(|i| {
            let t = i as f32 * 0.4;
            c + u * t.cos() + v * t.sin()
        })
        .collect();
    assert_eq!(center_height(ring.iter().copied(), c, n), None);
    assert_eq!(center_height([c].into_iter(), c, n), None);
}

/// A sphere of radius `r` around `center`: `pixels x pixels` points of the
/// cap within `angle` of the direction `toward`, with normals pointing
/// out (a dome seen from `toward`) or in (the inside of a bowl).
fn cap(
    center: Vec3,
    r: f32,
    toward: Vec3,
    angle: f32,
    inward: bool,
) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let (u, v) = toward.any_orthonormal_pair();
    let (mut pos, mut nor) = (Vec::new(), Vec::new());
    for j in 0..8 {
        for i in 0..8 {
            let (a, b) = (
                (i as f32 / 7.0 - 0.5) * angle,
                (j as f32 / 7.0 - 0.5) * angle,
            );
            let d = (toward + u * a.tan() + v * b.tan()).normalize();
            pos.push((center + d * r).to_array());
            nor.push(if inward {
                (-d).to_array()
            } else {
                d.to_array()
            });
        }
    }
    (pos, nor)
}

#[test]
fn bowls_are_concave_domes_and_planes_are_not() {
    let eye = Vec3::new(0.2, 6.0, 0.5);
    let camera_options = ClusterCameraOptions {
        far_distance: 30.0,
        ..ClusterCameraOptions::default()
    };
    let pixels: Vec<u32> = (0..64).collect();
    let view_of = |pos: &[[f32; 3]], nor: &[[f32; 3]], eye: Vec3| {
        let input = ClusterInput {
            positions: ImageView::try_new(pos, 8, 8, 8).unwrap(),
            normals: ImageView::try_new(nor, 8, 8, 8).unwrap(),
        };
        let options = ClusterCameraOptions {
            far_distance: camera_options.far_distance * eye.length() / 6.0,
            ..camera_options
        };
        match try_cluster_camera(&input, &pixels, eye, &options).unwrap() {
            ClusterView::Camera(c) => c,
            ClusterView::Fallback(f) => panic!("no camera: {f:?}"),
        }
    };
    for scale in [1e-3f32, 1.0, 1e3] {
        let (e, r) = (eye * scale, 2.0 * scale);
        // The inside of a bowl below the eye: concave.
        let (p, n) = cap(Vec3::ZERO, r, -Vec3::Y, 0.8, true);
        let c = view_of(&p, &n, e);
        assert!(c.concave && !c.planar, "scale {scale}");
        // A dome: convex.
        let (p, n) = cap(Vec3::ZERO, r, Vec3::Y, 0.8, false);
        let c = view_of(&p, &n, e);
        assert!(!c.concave && !c.planar, "scale {scale}");
    }
    // A plane: planar, never concave.
    let p: Vec<[f32; 3]> = (0..64)
        .map(|i| [(i % 8) as f32 * 0.1, 0.0, (i / 8) as f32 * 0.1])
        .collect();
    let n = vec![[0.0, 1.0, 0.0]; 64];
    let c = view_of(&p, &n, eye);
    assert!(c.planar && !c.concave);
}

// --------------------------------------------------- second intersection

const W: u32 = 128;
const H: u32 = 96;
const N: usize = (W * H) as usize;
const BOWL_C: DVec3 = DVec3::new(0.0, 1.0, 0.0);

fn camera() -> Camera {
    Camera::try_look_at(
        Vec3::new(0.4, 3.4, 1.6),
        Vec3::new(0.0, 0.4, 0.0),
        Vec3::Y,
        0.9,
        0.05,
        40.0,
        W,
        H,
    )
    .unwrap()
}

/// The bowl: the lower half (`y < 1`) of the unit sphere at `BOWL_C`,
/// two-sided. The first hit of `o + t d` after `t_min`: `(t, point,
/// normal toward the ray's origin side)`.
fn bowl(o: DVec3, d: DVec3, t_min: f64) -> Option<(f64, DVec3, DVec3)> {
    let oc = o - BOWL_C;
    let b = oc.dot(d);
    let disc = b * b - (oc.dot(oc) - 1.0);
    if !(disc > 0.0) {
        return None;
    }
    for t in [-b - disc.sqrt(), -b + disc.sqrt()] {
        let p = o + d * t;
        if t > t_min && p.y < BOWL_C.y {
            let n = (p - BOWL_C).normalize();
            return Some((t, p, if n.dot(d) > 0.0 { -n } else { n }));
        }
    }
    None
}

struct Frame {
    cam: Camera,
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    ids: Vec<u32>,
    /// Pixel `(x, y)`'s diffuse color encodes it: `(x, y, 1)`.
    diffuse: Vec<[f32; 3]>,
    /// The f64 surface point of each pixel.
    points: Vec<Option<DVec3>>,
}

fn frame(conv: DepthConvention) -> Frame {
    let cam = camera();
    let far = cam.encode_depth(cam.far(), conv);
    let mut f = Frame {
        cam,
        depth: vec![far; N],
        normals: vec![[0.0; 3]; N],
        ids: vec![u32::MAX; N],
        diffuse: vec![[0.0; 3]; N],
        points: vec![None; N],
    };
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            f.diffuse[i] = [x as f32, y as f32, 1.0];
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let Some((_, p, n)) = bowl(r.origin.as_dvec3(), r.dir.as_dvec3(), 0.0) else {
                continue;
            };
            f.depth[i] = cam.encode_depth(cam.linear_depth(p.as_vec3()), conv);
            f.normals[i] = n.as_vec3().to_array();
            f.ids[i] = 0;
            f.points[i] = Some(p);
        }
    }
    f
}

impl Frame {
    fn gbuffer(&self, conv: DepthConvention) -> GBuffer<'_> {
        GBuffer::try_new(
            DepthImage::try_new(
                ImageView::try_new(&self.depth, W, H, W).unwrap(),
                self.cam,
                conv,
            )
            .unwrap(),
            ImageView::try_new(&self.normals, W, H, W).unwrap(),
            NormalSpace::World,
        )
        .unwrap()
    }
}

/// What the pass gives for every pixel of `f` with `options`: a plan and
/// each camera cluster finalized over an empty render (nothing in the
/// depth images), with the reflector's diffuse image unless `no_diffuse`.
struct Run {
    texels: Vec<ClusterTexel>,
    stats: ClusterPlanStats,
    concave_pixels: Vec<bool>,
    self_hits: u64,
}

fn run(f: &Frame, conv: DepthConvention, options: ClusterPassOptions) -> Result<Run, Error> {
    let lobes = [Lobe::MIRROR];
    let objects = ClusterObjects {
        ids: ImageView::try_new(&f.ids, W, H, W).unwrap(),
        lobes: &lobes,
    };
    let pass = ClusterPass::try_new(f.gbuffer(conv), options).unwrap();
    let len = try_cluster_plan_len(W, H, 1, &options).unwrap();
    let (mut ids, mut order) = (vec![0u32; len.ids], vec![0u32; len.order]);
    let (mut offsets, mut counts) = (vec![0u32; len.offsets], vec![0u32; len.counts]);
    let mut layout = vec![ObjectBins::default(); len.layout];
    let mut plan: Vec<Option<ClusterPlanEntry>> = vec![None; len.clusters];
    let stats = pass
        .try_plan(
            &mut plan,
            ClusterScratchMut {
                ids: &mut ids,
                order: &mut order,
                offsets: &mut offsets,
                counts: &mut counts,
                layout: &mut layout,
            },
            &objects,
        )
        .unwrap();
    let mut texels = vec![ClusterTexel::default(); N];
    let mut concave_pixels = vec![false; N];
    let mut self_hits = 0;
    for e in plan.iter().flatten() {
        let Some(cc) = e.camera() else { continue };
        let cam = cc.camera;
        let (dw, dh) = (cam.width(), cam.height());
        let empty = vec![cam.encode_depth(cam.far(), DepthConvention::Linear); (dw * dh) as usize];
        let color = vec![[0.0f32; 3]; (dw * dh) as usize];
        let mut render = ClusterRender::try_new(
            DepthImage::try_new(
                ImageView::try_new(&empty, dw, dh, dw).unwrap(),
                cam,
                DepthConvention::Linear,
            )
            .unwrap(),
            ImageView::try_new(&color, dw, dh, dw).unwrap(),
        )
        .unwrap();
        if !options.glossy_single_ray {
            render = render.with_reflector(
                ImageView::try_new(&f.diffuse, W, H, W).unwrap(),
                ImageView::try_new(&f.ids, W, H, W).unwrap(),
            );
        }
        let mut view = ImageViewMut::try_new(&mut texels, W, H, W).unwrap();
        let st = pass.try_finalize(&mut view, &mut [], e, &order, Some(&render))?;
        self_hits += st.self_hits;
        for &p in &order[e.first as usize..(e.first + e.len) as usize] {
            concave_pixels[p as usize] = cc.concave;
        }
    }
    Ok(Run {
        texels,
        stats,
        concave_pixels,
        self_hits,
    })
}

/// The exact second intersection of pixel `i`'s mirror ray with the bowl's
/// sphere (within `rim` above the bowl's rim `y = 1`): the point and the
/// pixel it projects to.
fn oracle(f: &Frame, i: usize, rim: f64) -> Option<(DVec3, Vec2)> {
    let p = f.points[i]?;
    let eye = f.cam.eye().as_dvec3();
    let v = (p - eye).normalize();
    let n = (p - BOWL_C).normalize();
    let n = if n.dot(v) > 0.0 { -n } else { n };
    let r = v - 2.0 * v.dot(n) * n;
    // The other root of |p + t r - c| = 1 (the ray leaves its own point).
    let t = -2.0 * (p - BOWL_C).dot(r);
    let q = p + r * t;
    if !(t > 1e-3 && q.y < BOWL_C.y + rim) {
        return None;
    }
    let s = f.cam.project(q.as_vec3())?;
    Some((q, Vec2::new(s.x, s.y)))
}

#[test]
fn concave_clusters_meet_themselves_where_the_sphere_says() {
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ReversedZ,
        DepthConvention::ZeroToOne,
    ] {
        let f = frame(conv);
        let mut o = ClusterPassOptions::default();
        o.camera.far_distance = 20.0;
        o.cluster.gain = 16.0;
        let off = run(&f, conv, o).unwrap();
        // The seed's first way: no ray answers itself, every ray falls back
        // (the render holds nothing).
        assert_eq!(off.self_hits, 0);
        assert!(off
            .texels
            .iter()
            .all(|t| t.shade.self_hits == 0 && t.shade.hits == 0));
        assert!(off.stats.concave > 0, "{:?}", off.stats);
        // The bowl's outside (seen below its rim) is convex.
        assert!(off.stats.concave < off.stats.cameras, "{:?}", off.stats);

        let on = run(
            &f,
            conv,
            ClusterPassOptions {
                second_intersection: true,
                ..o
            },
        )
        .unwrap();
        assert_eq!(on.stats, off.stats);
        let (mut expected, mut found, mut checked) = (0u32, 0u32, 0u32);
        for i in 0..N {
            let t = &on.texels[i];
            if !on.concave_pixels[i] {
                // Convex clusters: as without the option.
                assert_eq!(*t, off.texels[i]);
                continue;
            }
            let want = oracle(&f, i, 0.0).filter(|(q, s)| {
                // Visible: the pixel it projects to shows that point, and
                // belongs to the same cluster.
                let (x, y) = (s.x as u32, s.y as u32);
                if x >= W || y >= H {
                    return false;
                }
                let j = (y * W + x) as usize;
                f.ids[j] == 0 && f.points[j].is_some_and(|pj| (pj - *q).length() < 0.02)
            });
            if t.shade.self_hits == 1 {
                // The diffuse color says which pixel the ray met: the
                // oracle's, within the stepping's reach.
                let got = Vec2::new(t.shade.rgb.x + 0.5, t.shade.rgb.y + 0.5);
                // A ray that leaves over the rim by less than a pixel's
                // footprint there may meet the rim's pixels.
                let (_, s) = oracle(&f, i, 0.01).expect("a self hit where the sphere has none");
                assert!(
                    (got - s).abs().max_element() <= 2.0,
                    "pixel {i}: {got} vs {s}"
                );
                assert_eq!(t.shade.hits, 1);
                assert_eq!(t.status, refl_core::MirrorStatus::Hit);
                checked += 1;
            }
            if want.is_some() {
                expected += 1;
                found += u32::from(t.shade.self_hits == 1);
            }
        }
        assert_eq!(u64::from(checked), on.self_hits);
        eprintln!("{conv:?}: {found} of {expected} expected self hits found, {checked} in all");
        assert!(expected > 200, "{expected}");
        assert!(
            found as f64 >= 0.9 * expected as f64,
            "{found} of {expected}"
        );
    }
}

#[test]
fn second_intersection_needs_the_reflector_diffuse() {
    let conv = DepthConvention::Linear;
    let f = frame(conv);
    let mut o = ClusterPassOptions::default();
    o.camera.far_distance = 20.0;
    o.cluster.gain = 16.0;
    // `glossy_single_ray` here only makes `run` leave the diffuse out.
    let no_diffuse = ClusterPassOptions {
        second_intersection: true,
        glossy_single_ray: true,
        ..o
    };
    assert_eq!(
        run(&f, conv, no_diffuse).err(),
        Some(Error::InvalidArgument)
    );
    // Without the option the diffuse is not needed.
    let fine = ClusterPassOptions {
        glossy_single_ray: true,
        ..o
    };
    assert!(run(&f, conv, fine).is_ok());
}

// ------------------------------------------------------ single-ray glossy

/// A wall across the mirror direction `(0, -1, 1) / sqrt 2` at distance 3
/// from a mirror pixel at the origin (normal +Z, eye at `(0, 2, 2)`): the
/// mirror ray meets it head on. Returns the shade of the one pixel for `color(x, y)` and
/// `lobe`, single ray or not.
fn wall_shade(color: &dyn Fn(u32, u32) -> [f32; 3], lobe: Lobe, single_ray: bool) -> ClusterShade {
    // Four pixels of a tiny flat cluster around the origin, normal +Z.
    let pos = [
        [-0.01f32, -0.01, 0.0],
        [0.01, -0.01, 0.0],
        [-0.01, 0.01, 0.0],
        [0.01, 0.01, 0.0],
    ];
    let nor = [[0.0f32, 0.0, 1.0]; 4];
    let input = ClusterInput {
        positions: ImageView::try_new(&pos, 2, 2, 2).unwrap(),
        normals: ImageView::try_new(&nor, 2, 2, 2).unwrap(),
    };
    let eye = Vec3::new(0.0, 2.0, 2.0);
    let axis = Vec3::new(0.0, -1.0, 1.0).normalize();
    let pixels = [0u32, 1, 2, 3];
    let cc = match try_cluster_camera(
        &input,
        &pixels,
        eye,
        &ClusterCameraOptions {
            far_distance: 10.0,
            // One frame for every lobe: the glossy one's.
            cone_half_angle: 0.5,
            ..ClusterCameraOptions::default()
        },
    )
    .unwrap()
    {
        ClusterView::Camera(c) => c,
        ClusterView::Fallback(f) => panic!("{f:?}"),
    };
    let cam = cc.camera;
    let (dw, dh) = (cam.width(), cam.height());
    let mut depth = vec![0.0f32; (dw * dh) as usize];
    let mut col = vec![[0.0f32; 3]; (dw * dh) as usize];
    for y in 0..dh {
        for x in 0..dw {
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let t = (3.0 - r.origin.dot(axis)) / r.dir.dot(axis);
            let i = (y * dw + x) as usize;
            depth[i] = cam.linear_depth(r.at(t));
            col[i] = color(x, y);
        }
    }
    let di = DepthImage::try_new(
        ImageView::try_new(&depth, dw, dh, dw).unwrap(),
        cam,
        DepthConvention::Linear,
    )
    .unwrap();
    let cv = ImageView::try_new(&col, dw, dh, dw).unwrap();
    let fin = FinalizeInput {
        thickness: Thickness::Constant(0.5),
        step: StepOptions::default(),
        refine: true,
        lobe,
        fade: false,
        seed: 5,
        single_ray,
    };
    let mut out = [ClusterShade::default(); 4];
    try_finalize_cluster(&mut out, &input, &pixels, eye, &cc, &di, &cv, &fin).unwrap();
    out[0]
}

#[test]
fn single_ray_glossy_averages_the_lobe_around_the_hit() {
    let lobe = Lobe {
        rays: 64,
        exponent: 30.0,
        max_angle: try_lobe_angle(30.0, 0.95).unwrap(),
    };
    // A constant color: exactly that color, from one ray.
    let c = [0.3f32, 0.6, 0.9];
    let s = wall_shade(&|_, _| c, lobe, true);
    assert_eq!((s.rays, s.hits, s.hit_weight), (1, 1, 1.0));
    assert!(
        (s.rgb - Vec3::from_array(c)).abs().max_element() < 1e-6,
        "{}",
        s.rgb
    );
    // A mirror lobe ignores the setting.
    let m = wall_shade(&|x, _| [x as f32, 0.0, 0.0], Lobe::MIRROR, true);
    let m0 = wall_shade(&|x, _| [x as f32, 0.0, 0.0], Lobe::MIRROR, false);
    assert_eq!(m, m0);
    // A linear ramp: the lobe's mean over a symmetric footprint is the
    // ramp at the hit (within the half texel of nearest-texel sampling),
    // and the 64-ray lobe agrees.
    let ramp = |x: u32, y: u32| [x as f32 + 0.5, y as f32 + 0.5, 0.0];
    let single = wall_shade(&ramp, lobe, true);
    let full = wall_shade(&ramp, lobe, false);
    let at_hit = wall_shade(&ramp, Lobe::MIRROR, false).rgb;
    assert!(
        (single.rgb - at_hit).abs().max_element() <= 0.75,
        "{} vs {}",
        single.rgb,
        at_hit
    );
    assert!(
        (full.rgb - at_hit).abs().max_element() <= 2.0,
        "{} vs {}",
        full.rgb,
        at_hit
    );
    // A checkerboard of period 2 texels: the neighborhood mean is near
    // its mean 0.5 (the mirror ray alone sees 0 or 1), as the full lobe's.
    let checker = |x: u32, y: u32| {
        let v = ((x / 2 + y / 2) % 2) as f32;
        [v, v, v]
    };
    let single = wall_shade(&checker, lobe, true);
    let full = wall_shade(&checker, lobe, false);
    assert!((single.rgb.x - 0.5).abs() < 0.15, "{}", single.rgb);
    assert!(
        (single.rgb.x - full.rgb.x).abs() < 0.25,
        "{} vs {}",
        single.rgb,
        full.rgb
    );
    assert_eq!(single.rays, 1);
    assert_eq!(full.rays, 64);
}
