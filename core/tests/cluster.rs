//! Seed 003 clustering, cluster cameras and finalization against f64
//! oracles: normal bins and the bin layout re-derived in f64, the counting
//! sort against a brute-force grouping, Eq. 1 recomputed in f64, frames
//! that must hold every reflected ray, planar clusters that must give the
//! mirrored eye exactly, the degenerate cases, and the finalized reflection
//! of a mirror floor compared with the f64 ray/wall intersection.
#![cfg(feature = "cluster")]
#![allow(clippy::needless_range_loop)]

use glam::{DVec3, Vec2, Vec3};
use refl_core::cluster::*;
use refl_core::{
    Camera, DepthConvention, DepthImage, Error, ImageView, ImageViewMut, RowRange, StepOptions,
    Thickness,
};

const W: u32 = 64;
const H: u32 = 48;

fn eye_camera() -> Camera {
    Camera::try_look_at(
        Vec3::new(0.3, 2.0, 5.0),
        Vec3::new(0.0, 0.0, -2.0),
        Vec3::Y,
        1.0,
        0.05,
        200.0,
        W,
        H,
    )
    .unwrap()
}

/// A G-buffer of one analytic reflector, per pixel center in f64.
struct Frame {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    objects: Vec<u32>,
}

fn arr(v: &[Vec3]) -> Vec<[f32; 3]> {
    v.iter().map(|p| p.to_array()).collect()
}

enum Reflector {
    /// y = 0 facing +Y.
    Floor,
    /// A sphere (center, radius).
    Sphere(DVec3, f64),
}

fn gbuffer(cam: &Camera, refl: &Reflector) -> Frame {
    let n = (W * H) as usize;
    let mut f = Frame {
        positions: vec![Vec3::ZERO; n],
        normals: vec![Vec3::Y; n],
        objects: vec![NO_OBJECT; n],
    };
    for y in 0..H {
        for x in 0..W {
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (o, d) = (r.origin.as_dvec3(), r.dir.as_dvec3());
            let hit = match refl {
                Reflector::Floor => {
                    let t = -o.y / d.y;
                    (t > 0.0).then(|| (o + d * t, DVec3::Y))
                }
                Reflector::Sphere(c, rad) => {
                    let oc = o - *c;
                    let b = oc.dot(d);
                    let disc = b * b - (oc.length_squared() - rad * rad);
                    (disc > 0.0).then(|| {
                        let t = -b - disc.sqrt();
                        let p = o + d * t;
                        (p, (p - *c).normalize())
                    })
                }
            };
            if let Some((p, nn)) = hit {
                let i = (y * W + x) as usize;
                f.positions[i] = p.as_vec3();
                f.normals[i] = nn.as_vec3();
                f.objects[i] = 0;
            }
        }
    }
    f
}

/// The core reads `[f32; 3]` texels; the copies live for the test run.
fn input(f: &Frame) -> ClusterInput<'static> {
    let (p, n): (&'static [[f32; 3]], &'static [[f32; 3]]) = (
        Box::leak(arr(&f.positions).into_boxed_slice()),
        Box::leak(arr(&f.normals).into_boxed_slice()),
    );
    ClusterInput {
        positions: ImageView::try_new(p, W, H, W).unwrap(),
        normals: ImageView::try_new(n, W, H, W).unwrap(),
    }
}

fn pixels_of(f: &Frame) -> Vec<u32> {
    (0..W * H).filter(|&i| f.objects[i as usize] == 0).collect()
}

// ---------------------------------------------------------------------------
// Clustering.

/// f64 oracle of `normal_bin`.
fn bin_oracle(n: DVec3, tb: u32, pb: u32) -> u32 {
    let mut theta = n.z.atan2(n.x);
    if theta < 0.0 {
        theta += std::f64::consts::TAU;
    }
    let phi = n.y.clamp(-1.0, 1.0).acos();
    let i = ((theta / std::f64::consts::TAU * tb as f64) as u32).min(tb - 1);
    let j = ((phi / std::f64::consts::PI * pb as f64) as u32).min(pb - 1);
    i * pb + j
}

#[test]
fn normal_bins_match_f64_oracle_away_from_bin_edges() {
    let mut checked = 0;
    for k in 0..20_000u32 {
        // Fibonacci sphere.
        let z = 1.0 - 2.0 * (k as f64 + 0.5) / 20_000.0;
        let r = (1.0 - z * z).sqrt();
        let a = k as f64 * 2.399_963_229_728_653;
        let n = DVec3::new(r * a.cos(), z, r * a.sin());
        for (tb, pb) in [(13, 8), (1, 1), (5, 3), (64, 32)] {
            // Skip normals within 1e-4 rad of a bin boundary (f32 rounding).
            let theta = {
                let t = n.z.atan2(n.x);
                if t < 0.0 {
                    t + std::f64::consts::TAU
                } else {
                    t
                }
            };
            let phi = n.y.acos();
            let ft = theta / std::f64::consts::TAU * tb as f64;
            let fp = phi / std::f64::consts::PI * pb as f64;
            if (ft - ft.round()).abs() < 1e-3 || (fp - fp.round()).abs() < 1e-3 {
                continue;
            }
            assert_eq!(
                normal_bin(n.as_vec3(), tb, pb),
                bin_oracle(n, tb, pb),
                "{n:?} {tb}x{pb}"
            );
            checked += 1;
        }
    }
    assert!(checked > 70_000);
}

#[test]
fn bin_layout_follows_screen_share_and_visible_count() {
    let params = ClusterOptions::default();
    // 4 objects on a 1000-pixel frame; object 2 invisible.
    let counts = [1000 - 300 - 50, 300, 0, 50];
    let mut out = [ObjectBins::default(); 4];
    let total = try_bin_layout(&mut out, &counts, 1000, &params).unwrap();
    let n_v = 3.0f64;
    let mut first = 0;
    for (k, &c) in counts.iter().enumerate() {
        if c == 0 {
            assert_eq!((out[k].theta_bins, out[k].phi_bins), (0, 0));
            continue;
        }
        let s = (c as f64 / 1000.0 / n_v).min(1.0);
        let t = ((13.0 * s).ceil() as u32).clamp(1, 13);
        let p = ((8.0 * s).ceil() as u32).clamp(1, 8);
        assert_eq!(
            out[k],
            ObjectBins {
                theta_bins: t,
                phi_bins: p,
                first
            }
        );
        first += t * p;
    }
    assert_eq!(total, first);
    // The seed's example: one object covering the frame gets 13 x 8 bins.
    let mut one = [ObjectBins::default(); 1];
    assert_eq!(try_bin_layout(&mut one, &[500], 500, &params).unwrap(), 104);
    // More gain, more bins; never more than the worst case.
    let big = ClusterOptions {
        gain: 64.0,
        ..params
    };
    let mut out2 = [ObjectBins::default(); 4];
    let total2 = try_bin_layout(&mut out2, &counts, 1000, &big).unwrap();
    assert!(total2 > total);
    assert!(total2 <= try_cluster_bins_max(4, &big).unwrap());
    // Errors leave the output alone.
    let mut keep = [ObjectBins {
        theta_bins: 9,
        phi_bins: 9,
        first: 9,
    }; 4];
    assert_eq!(
        try_bin_layout(&mut keep, &counts, 10, &params),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_bin_layout(&mut keep, &counts, 0, &params),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_bin_layout(&mut keep[..2], &counts, 1000, &params),
        Err(Error::InsufficientSize)
    );
    let bad = ClusterOptions {
        gain: f32::NAN,
        ..params
    };
    assert_eq!(
        try_bin_layout(&mut keep, &counts, 1000, &bad),
        Err(Error::InvalidArgument)
    );
    assert!(keep.iter().all(|b| b.first == 9));
    assert_eq!(
        try_cluster_bins_max(u32::MAX, &params),
        Err(Error::InvalidArgument)
    );
}

#[test]
fn assign_count_and_ranges_agree_with_brute_force() {
    let cam = eye_camera();
    let f = gbuffer(&cam, &Reflector::Sphere(DVec3::new(0.0, 0.8, -1.0), 1.2));
    let objects = ImageView::try_new(&f.objects, W, H, W).unwrap();
    let normals_flat = arr(&f.normals);
    let normals = ImageView::try_new(&normals_flat, W, H, W).unwrap();
    // Counting in two bands adds up.
    let mut c1 = [0u32; 1];
    let mut c2 = [0u32; 1];
    try_count_objects(&mut c1, &objects, RowRange::try_new(0, 20, H).unwrap()).unwrap();
    try_count_objects(&mut c2, &objects, RowRange::try_new(20, H, H).unwrap()).unwrap();
    let visible = f.objects.iter().filter(|&&o| o == 0).count() as u32;
    assert_eq!(c1[0] + c2[0], visible);
    let params = ClusterOptions {
        gain: 8.0,
        ..ClusterOptions::default()
    };
    let mut layout = [ObjectBins::default(); 1];
    let bins = try_bin_layout(&mut layout, &[visible], u64::from(W * H), &params).unwrap();
    let mut ids = vec![7u32; (W * H) as usize];
    // Two bands written separately give the same ids as one pass.
    {
        let (a, b) = ids.split_at_mut((20 * W) as usize);
        let mut va =
            ImageViewMut::try_band(a, W, H, W, RowRange::try_new(0, 20, H).unwrap()).unwrap();
        let mut vb =
            ImageViewMut::try_band(b, W, H, W, RowRange::try_new(20, H, H).unwrap()).unwrap();
        try_assign_clusters(&mut va, &normals, &objects, &layout).unwrap();
        try_assign_clusters(&mut vb, &normals, &objects, &layout).unwrap();
    }
    for i in 0..(W * H) as usize {
        if f.objects[i] == 0 {
            let b = layout[0];
            assert_eq!(
                ids[i],
                b.first + normal_bin(f.normals[i], b.theta_bins, b.phi_bins)
            );
            assert!(ids[i] < bins);
        } else {
            assert_eq!(ids[i], NO_CLUSTER);
        }
    }
    let view = ImageView::try_new(&ids, W, H, W).unwrap();
    let mut offsets = vec![0u32; bins as usize + 1];
    let mut order = vec![0u32; visible as usize];
    assert_eq!(
        try_cluster_ranges(&mut offsets, &mut order, &view, bins).unwrap(),
        visible
    );
    for c in 0..bins {
        let want: Vec<u32> = (0..W * H).filter(|&i| ids[i as usize] == c).collect();
        assert_eq!(
            &order[offsets[c as usize] as usize..offsets[c as usize + 1] as usize],
            &want[..]
        );
    }
    assert!(
        (0..bins)
            .filter(|&c| offsets[c as usize + 1] > offsets[c as usize])
            .count()
            > 3
    );
    // Hostile: a short order, an id beyond the clusters, a NaN normal.
    let mut short = vec![5u32; 3];
    assert_eq!(
        try_cluster_ranges(&mut offsets.clone(), &mut short, &view, bins),
        Err(Error::InsufficientSize)
    );
    assert!(short.iter().all(|&v| v == 5));
    assert_eq!(
        try_cluster_ranges(&mut offsets.clone(), &mut order.clone(), &view, 1),
        Err(Error::InvalidArgument)
    );
    let mut bad_normals = f.normals.clone();
    let first = pixels_of(&f)[0] as usize;
    bad_normals[first] = Vec3::NAN;
    let bad_flat = arr(&bad_normals);
    let bn = ImageView::try_new(&bad_flat, W, H, W).unwrap();
    let mut ids2 = vec![3u32; (W * H) as usize];
    let mut v2 = ImageViewMut::try_new(&mut ids2, W, H, W).unwrap();
    assert_eq!(
        try_assign_clusters(&mut v2, &bn, &objects, &layout),
        Err(Error::InvalidArgument)
    );
    assert!(ids2.iter().all(|&v| v == 3));
}

// ---------------------------------------------------------------------------
// Cluster cameras.

fn camera_of(view: ClusterView) -> ClusterCamera {
    match view {
        ClusterView::Camera(c) => c,
        ClusterView::Fallback(r) => panic!("fallback {r:?}"),
    }
}

/// Every reflected ray's near (surface) and far (far-plane) endpoint must
/// project inside the camera image (Sec. 3.3 step 4).
fn assert_frame_holds_rays(cc: &ClusterCamera, f: &Frame, pixels: &[u32], eye: Vec3) {
    let (w, h) = (cc.camera.width() as f32, cc.camera.height() as f32);
    let slack = 1e-3 * w.max(h) + 0.01;
    for &p in pixels {
        let (pos, n) = (
            f.positions[p as usize].as_dvec3(),
            f.normals[p as usize].as_dvec3(),
        );
        let v = (eye.as_dvec3() - pos).normalize();
        let r = 2.0 * v.dot(n) * n - v;
        let nc = cc.normal.as_dvec3();
        let s = (pos - cc.centroid.as_dvec3()).dot(nc);
        let rn = r.dot(nc);
        if rn <= 1e-6 {
            continue;
        }
        let q = pos + r * ((cc.far_distance as f64 - s) / rn);
        // The near endpoint: where the ray crosses the clip plane if the
        // point lies below it (the depth image holds nothing there).
        let below = (cc.clip.point.as_dvec3() - pos).dot(cc.clip.normal.as_dvec3());
        let near = if below > 0.0 {
            pos + r * (below / r.dot(cc.clip.normal.as_dvec3()))
        } else {
            pos
        };
        for x in [near, q] {
            let pr = cc.camera.project(x.as_vec3()).expect("in front of the eye");
            assert!(
                pr.x >= -slack && pr.x <= w + slack && pr.y >= -slack && pr.y <= h + slack,
                "{pr:?} outside {w}x{h}"
            );
        }
    }
}

#[test]
fn planar_cluster_is_the_mirrored_camera_exactly() {
    let cam = eye_camera();
    let f = gbuffer(&cam, &Reflector::Floor);
    let pixels = pixels_of(&f);
    let eye = cam.eye();
    let params = ClusterCameraOptions {
        far_distance: 30.0,
        ..ClusterCameraOptions::default()
    };
    let cc = camera_of(try_cluster_camera(&input(&f), &pixels, eye, &params).unwrap());
    assert!(cc.planar);
    assert_eq!(cc.f, 1.0);
    // The oracle: centroid and mean normal in f64, e0 = e - 2 h n.
    let mut c = DVec3::ZERO;
    for &p in &pixels {
        c += f.positions[p as usize].as_dvec3();
    }
    c /= pixels.len() as f64;
    let n = DVec3::Y;
    let e = eye.as_dvec3();
    let e0 = (e - 2.0 * (e - c).dot(n) * n).as_vec3();
    assert_eq!(cc.eye0, e0);
    // The mirrored eye is (x, -y, z).
    assert!((e0 - Vec3::new(eye.x, -eye.y, eye.z)).length() < 1e-5);
    assert!((cc.camera.eye() - e0).length() < 1e-5 * (1.0 + e0.length()));
    assert_frame_holds_rays(&cc, &f, &pixels, eye);
    // Every reflected ray passes through the camera eye.
    for &p in pixels.iter().step_by(37) {
        let pos = f.positions[p as usize];
        let v = (eye - pos).normalize();
        let r = 2.0 * v.dot(Vec3::Y) * Vec3::Y - v;
        let to_eye = (pos - cc.camera.eye()).normalize();
        assert!((to_eye - r).length() < 1e-4);
    }
}

/// f64 oracle of Eq. 1 with the module's plane basis.
fn eq1_oracle(f: &Frame, pixels: &[u32], eye: Vec3, d: f64) -> (f64, [f64; 3]) {
    let (mut c, mut ns) = (DVec3::ZERO, DVec3::ZERO);
    for &p in pixels {
        c += f.positions[p as usize].as_dvec3();
        ns += f.normals[p as usize].as_dvec3();
    }
    c /= pixels.len() as f64;
    let n = ns.normalize();
    let (u, v) = n.as_vec3().any_orthonormal_pair();
    let (u, v) = (u.as_dvec3(), v.as_dvec3());
    let e = eye.as_dvec3();
    let h0 = (e - c).dot(n);
    let e0 = e - 2.0 * h0 * n;
    let proj = |x: DVec3| {
        let hx = (x - c).dot(n);
        let y = e0 + (x - e0) * (h0 / (hx + h0));
        [(y - c).dot(u), (y - c).dot(v)]
    };
    let mut boxes = [[
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ]; 3];
    let mut grow = |b: usize, q: [f64; 2]| {
        boxes[b][0] = boxes[b][0].min(q[0]);
        boxes[b][1] = boxes[b][1].min(q[1]);
        boxes[b][2] = boxes[b][2].max(q[0]);
        boxes[b][3] = boxes[b][3].max(q[1]);
    };
    for &p in pixels {
        let (pos, nn) = (
            f.positions[p as usize].as_dvec3(),
            f.normals[p as usize].as_dvec3(),
        );
        let vv = (e - pos).normalize();
        let r = 2.0 * vv.dot(nn) * nn - vv;
        let s = (pos - c).dot(n);
        if r.dot(n) <= 1e-6 {
            continue;
        }
        let q = pos + r * ((d - s) / r.dot(n));
        grow(0, proj(pos));
        grow(1, proj(q));
        grow(2, [(q - c).dot(u), (q - c).dot(v)]);
    }
    let diag = |b: [f64; 4]| ((b[2] - b[0]).powi(2) + (b[3] - b[1]).powi(2)).sqrt();
    let (dn, df, dbf) = (diag(boxes[0]), diag(boxes[1]), diag(boxes[2]));
    (dn * (dbf - df) / (df * (dbf - dn)), [dn, df, dbf])
}

#[test]
fn curved_cluster_follows_eq1_and_holds_every_ray() {
    let cam = eye_camera();
    let f = gbuffer(&cam, &Reflector::Sphere(DVec3::new(0.0, 0.8, -1.0), 1.2));
    let objects = ImageView::try_new(&f.objects, W, H, W).unwrap();
    let normals_flat = arr(&f.normals);
    let normals = ImageView::try_new(&normals_flat, W, H, W).unwrap();
    let visible = f.objects.iter().filter(|&&o| o == 0).count() as u32;
    let params = ClusterOptions {
        gain: 6.0,
        ..ClusterOptions::default()
    };
    let mut layout = [ObjectBins::default(); 1];
    let bins = try_bin_layout(&mut layout, &[visible], u64::from(W * H), &params).unwrap();
    let mut ids = vec![0u32; (W * H) as usize];
    try_assign_clusters(
        &mut ImageViewMut::try_new(&mut ids, W, H, W).unwrap(),
        &normals,
        &objects,
        &layout,
    )
    .unwrap();
    let mut offsets = vec![0u32; bins as usize + 1];
    let mut order = vec![0u32; visible as usize];
    try_cluster_ranges(
        &mut offsets,
        &mut order,
        &ImageView::try_new(&ids, W, H, W).unwrap(),
        bins,
    )
    .unwrap();
    let eye = cam.eye();
    let d = 40.0;
    let mut tested = 0;
    for glossy in [0.0f32, 0.2] {
        let cp = ClusterCameraOptions {
            far_distance: d,
            cone_half_angle: glossy,
            ..ClusterCameraOptions::default()
        };
        for c in 0..bins as usize {
            let px = &order[offsets[c] as usize..offsets[c + 1] as usize];
            if px.len() < 30 {
                continue;
            }
            let cc = camera_of(try_cluster_camera(&input(&f), px, eye, &cp).unwrap());
            assert!(!cc.planar);
            let (f_oracle, diags) = eq1_oracle(&f, px, eye, f64::from(d));
            for k in 0..3 {
                assert!(
                    (f64::from(cc.diagonals[k]) - diags[k]).abs() <= 1e-3 * diags[k] + 1e-5,
                    "diag {k}: {} vs {}",
                    cc.diagonals[k],
                    diags[k]
                );
            }
            // A convex reflector: d_n < d_f < d_F, so 0 < f < 1 (Sec. 3.3).
            assert!(diags[0] < diags[1] && diags[1] < diags[2]);
            assert!(f_oracle > 0.0 && f_oracle < 1.0);
            let want = f_oracle.clamp(1.0 / f64::from(cp.max_f), f64::from(cp.max_f));
            assert!(
                (f64::from(cc.f) - want).abs() <= 2e-3 * want,
                "{} vs {want}",
                cc.f
            );
            // e_c on the segment e_0 -> P_c at fraction f of the distance.
            let ec = cc.camera.eye();
            let want = cc.centroid + (cc.eye0 - cc.centroid) * cc.f;
            assert!((ec - want).length() < 1e-4 * (1.0 + want.length()));
            assert_frame_holds_rays(&cc, &f, px, eye);
            tested += 1;
        }
    }
    assert!(tested >= 4, "{tested}");
}

#[test]
fn degenerate_clusters_have_defined_outcomes() {
    let cam = eye_camera();
    let f = gbuffer(&cam, &Reflector::Floor);
    let pixels = pixels_of(&f);
    let eye = cam.eye();
    let p = ClusterCameraOptions::default();
    // One pixel (and fewer than min_pixels).
    assert_eq!(
        try_cluster_camera(&input(&f), &pixels[..1], eye, &p).unwrap(),
        ClusterView::Fallback(ClusterFallback::TooFewPixels)
    );
    let two = ClusterCameraOptions { min_pixels: 2, ..p };
    assert_eq!(
        try_cluster_camera(&input(&f), &pixels[..1], eye, &two).unwrap(),
        ClusterView::Fallback(ClusterFallback::TooFewPixels)
    );
    // min_pixels below 2 is refused: one pixel has no spacing.
    let one = ClusterCameraOptions { min_pixels: 1, ..p };
    assert_eq!(
        try_cluster_camera(&input(&f), &pixels, eye, &one),
        Err(Error::InvalidArgument)
    );
    // Two adjacent pixels of a plane: a valid (planar) camera.
    let pair = [pixels[pixels.len() / 2], pixels[pixels.len() / 2] + 1];
    let cc = camera_of(try_cluster_camera(&input(&f), &pair, eye, &two).unwrap());
    assert!(cc.planar && cc.f == 1.0);
    assert_frame_holds_rays(&cc, &f, &pair, eye);
    // Normals facing away from the eye: the eye below the floor.
    let below = Vec3::new(0.0, -1.0, 0.0);
    assert_eq!(
        try_cluster_camera(&input(&f), &pixels, below, &p).unwrap(),
        ClusterView::Fallback(ClusterFallback::FacesAway)
    );
    // Normals that cancel out.
    let mut g2 = Frame {
        positions: f.positions.clone(),
        normals: f.normals.clone(),
        objects: f.objects.clone(),
    };
    let (a, b) = (pixels[0], pixels[1]);
    g2.normals[b as usize] = -Vec3::Y;
    assert_eq!(
        try_cluster_camera(&input(&g2), &[a, b], eye, &two).unwrap(),
        ClusterView::Fallback(ClusterFallback::FacesAway)
    );
    // d_F = d_n: an eye straight above a symmetric 3x3 patch of y = 0 whose
    // normals send every ray straight up (parallel rays along n_c): the far
    // endpoints spread exactly as the near ones, Eq. 1's denominator is 0
    // and f goes to its bound.
    {
        let e = Vec3::new(0.0, 5.0, 0.0);
        let mut pos = Vec::new();
        let mut nor = Vec::new();
        for j in -1..=1 {
            for i in -1..=1 {
                let q = Vec3::new(i as f32 * 0.5, 0.0, j as f32 * 0.5);
                pos.push(q);
                nor.push(((e - q).normalize() + Vec3::Y).normalize());
            }
        }
        let (pos_flat, nor_flat) = (arr(&pos), arr(&nor));
        let inp = ClusterInput {
            positions: ImageView::try_new(&pos_flat, 3, 3, 3).unwrap(),
            normals: ImageView::try_new(&nor_flat, 3, 3, 3).unwrap(),
        };
        let all: Vec<u32> = (0..9).collect();
        let cc = camera_of(try_cluster_camera(&inp, &all, e, &p).unwrap());
        assert!(!cc.planar);
        assert!((cc.normal - Vec3::Y).length() < 1e-6);
        let [dn, _, dbf] = cc.diagonals;
        assert!((dbf - dn).abs() <= 1e-5 * dn, "{dn} {dbf}");
        assert_eq!(cc.f, p.max_f);
        // The eye moved max_f times as far below the patch: the parallel
        // rays are nearly the camera's rays, and the frame holds them.
        assert!((cc.camera.eye() - Vec3::new(0.0, -5.0 * p.max_f, 0.0)).length() < 1e-3);
        for (q, n) in pos.iter().zip(&nor) {
            let v = (e - *q).normalize();
            let r = 2.0 * v.dot(*n) * *n - v;
            assert!((r - Vec3::Y).length() < 1e-5);
            for x in [*q, *q + r * p.far_distance] {
                let pr = cc.camera.project(x).unwrap();
                let (w, h) = (cc.camera.width() as f32, cc.camera.height() as f32);
                assert!(pr.x >= -0.01 && pr.x <= w + 0.01 && pr.y >= -0.01 && pr.y <= h + 0.01);
            }
        }
    }
    // All normals equal on two parallel planes (not planar): a valid camera
    // whose frame holds the rays.
    let mut steps = Frame {
        positions: f.positions.clone(),
        normals: f.normals.clone(),
        objects: f.objects.clone(),
    };
    for &q in pixels.iter().filter(|&&q| (q / W) % 2 == 0) {
        steps.positions[q as usize].y += 0.5;
    }
    let cc = camera_of(try_cluster_camera(&input(&steps), &pixels, eye, &p).unwrap());
    assert!(
        !cc.planar && cc.f.is_finite() && cc.f >= 1.0 / p.max_f && cc.f <= p.max_f,
        "{cc:?}"
    );
    assert_frame_holds_rays(&cc, &steps, &pixels, eye);
    // Every ray along or behind the image plane: normals tilted +-78
    // degrees about Z alternately (their mean is +Y and faces the eye right
    // above), so every reflected ray points down.
    {
        let e = Vec3::new(0.0, 5.0, 0.0);
        let pos: Vec<Vec3> = (0..4)
            .map(|i| Vec3::new(i as f32 * 0.01, 0.0, 0.0))
            .collect();
        let nor: Vec<Vec3> = (0..4)
            .map(|i| Vec3::new(if i % 2 == 0 { 1.0 } else { -1.0 }, 0.2, 0.0).normalize())
            .collect();
        let (pos_flat, nor_flat) = (arr(&pos), arr(&nor));
        let inp = ClusterInput {
            positions: ImageView::try_new(&pos_flat, 4, 1, 4).unwrap(),
            normals: ImageView::try_new(&nor_flat, 4, 1, 4).unwrap(),
        };
        assert_eq!(
            try_cluster_camera(&inp, &[0, 1, 2, 3], e, &p).unwrap(),
            ClusterView::Fallback(ClusterFallback::NoRays)
        );
    }
    // Hostile input.
    let mut nan = Frame {
        positions: f.positions.clone(),
        normals: f.normals.clone(),
        objects: f.objects.clone(),
    };
    nan.positions[pixels[3] as usize].x = f32::NAN;
    assert_eq!(
        try_cluster_camera(&input(&nan), &pixels, eye, &p),
        Err(Error::InvalidArgument)
    );
    nan.positions[pixels[3] as usize].x = f32::INFINITY;
    assert_eq!(
        try_cluster_camera(&input(&nan), &pixels, eye, &p),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_cluster_camera(&input(&f), &pixels, Vec3::NAN, &p),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_cluster_camera(&input(&f), &[W * H], eye, &two),
        Err(Error::InvalidArgument)
    );
    for bad in [
        ClusterCameraOptions {
            far_distance: f32::INFINITY,
            ..p
        },
        ClusterCameraOptions {
            far_distance: 0.0,
            ..p
        },
        ClusterCameraOptions {
            cone_half_angle: f32::NAN,
            ..p
        },
        ClusterCameraOptions {
            resolution_scale: 0.0,
            ..p
        },
        ClusterCameraOptions {
            max_resolution: 0,
            ..p
        },
        ClusterCameraOptions { max_f: 0.5, ..p },
    ] {
        assert_eq!(
            try_cluster_camera(&input(&f), &pixels, eye, &bad),
            Err(Error::InvalidArgument)
        );
    }
}

// ---------------------------------------------------------------------------
// Finalization.

/// A wall z = -6 (facing +Z) and a back wall z = 20 (facing -Z), with a
/// smooth color per world point.
fn wall_color(p: DVec3) -> Vec3 {
    Vec3::new(
        (0.5 + 0.4 * (p.x * 0.7).sin()) as f32,
        (0.5 + 0.4 * (p.y * 0.9).cos()) as f32,
        (0.5 + 0.3 * (p.z * 0.2).sin()) as f32,
    )
}

/// First hit of a ray with the two walls (f64), `t` and point.
fn walls(o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
    let mut best: Option<(f64, DVec3)> = None;
    for (z, x_max) in [(-6.0, 30.0), (20.0, 30.0)] {
        let t = (z - o.z) / d.z;
        if t > 1e-9 {
            let p = o + d * t;
            if p.x.abs() < x_max && best.is_none_or(|b| t < b.0) {
                best = Some((t, p));
            }
        }
    }
    best
}

/// The depth and color image of the walls through `cam`, per texel center
/// in f64, keeping only what lies above the clip plane (here: y > 0).
fn render_walls(cam: &Camera, conv: DepthConvention) -> (Vec<f32>, Vec<[f32; 3]>) {
    let (w, h) = (cam.width(), cam.height());
    let mut depth = vec![cam.encode_depth(f32::INFINITY, conv); (w * h) as usize];
    if conv == DepthConvention::Linear {
        depth.fill(f32::INFINITY);
    }
    let mut color = vec![[0.0f32; 3]; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (o, d) = (r.origin.as_dvec3(), r.dir.as_dvec3());
            // Start at the clip plane y = 0 (the camera is below it).
            let t0 = if d.y > 0.0 { -o.y / d.y } else { continue };
            let o2 = o + d * t0;
            if let Some((_, p)) = walls(o2, d) {
                let z = cam.linear_depth(p.as_vec3());
                depth[(y * w + x) as usize] = cam.encode_depth(z, conv);
                color[(y * w + x) as usize] = wall_color(p).to_array();
            }
        }
    }
    (depth, color)
}

#[test]
fn planar_finalization_is_one_lookup_and_matches_the_f64_reflection() {
    let cam = eye_camera();
    let f = gbuffer(&cam, &Reflector::Floor);
    let pixels = pixels_of(&f);
    let eye = cam.eye();
    let cp = ClusterCameraOptions {
        far_distance: 60.0,
        ..ClusterCameraOptions::default()
    };
    let cc = camera_of(try_cluster_camera(&input(&f), &pixels, eye, &cp).unwrap());
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let (depth, color) = render_walls(&cc.camera, conv);
        let (dw, dh) = (cc.camera.width(), cc.camera.height());
        let di = DepthImage::try_new(
            ImageView::try_new(&depth, dw, dh, dw).unwrap(),
            cc.camera,
            conv,
        )
        .unwrap();
        let cv = ImageView::try_new(&color, dw, dh, dw).unwrap();
        let params = FinalizeInput {
            thickness: Thickness::Constant(0.5),
            step: StepOptions::default(),
            refine: false,
            lobe: Lobe::MIRROR,
            fade: false,
            seed: 0,
            single_ray: false,
        };
        let mut out = vec![ClusterShade::default(); pixels.len()];
        let fell = try_finalize_cluster(&mut out, &input(&f), &pixels, eye, &cc, &di, &cv, &params)
            .unwrap();
        let mut err_sum = 0.0f64;
        let mut hits = 0;
        for (k, &p) in pixels.iter().enumerate() {
            let o = &out[k];
            assert_eq!(o.rays, 1);
            // Sec. 4.3: one lookup.
            assert_eq!((o.steps, o.fetches), (1, 1), "pixel {p}");
            let pos = f.positions[p as usize].as_dvec3();
            let v = (eye.as_dvec3() - pos).normalize();
            let r = 2.0 * v.dot(DVec3::Y) * DVec3::Y - v;
            match walls(pos, r) {
                // Where the wall meets the floor (the clip plane) a texel
                // center may see below the floor: either answer is right.
                Some((_, q)) if q.y < 0.2 => {}
                Some((t, q)) if t * r.y < 60.0 => {
                    if o.hits != 1 {
                        let pr = cc.camera.project(q.as_vec3());
                        let pp = cc.camera.project(pos.as_vec3());
                        panic!(
                            "pixel {p}: {o:?} q {q:?} proj {pr:?} pos proj {pp:?} size {dw}x{dh}"
                        );
                    }
                    assert_eq!(o.env_weight, 0.0);
                    let want = wall_color(q);
                    err_sum += f64::from((o.rgb - want).abs().max_element());
                    hits += 1;
                }
                _ => {
                    assert_eq!((o.hits, o.env_weight), (0, 1.0), "pixel {p}");
                    assert!((o.env_dir.as_dvec3() - r).length() < 1e-4);
                }
            }
        }
        assert!(hits > pixels.len() / 2);
        let hit_total = out[..pixels.len()].iter().filter(|o| o.hits == 1).count();
        assert_eq!(fell as usize, pixels.len() - hit_total);
        // Bilinear color of a texel-sized resampling of a smooth function.
        assert!(err_sum / (hits as f64) < 0.01, "{}", err_sum / hits as f64);
    }
}

#[test]
fn glossy_finalization_weights_and_hostile_input() {
    let cam = eye_camera();
    let f = gbuffer(&cam, &Reflector::Floor);
    let pixels = pixels_of(&f);
    let eye = cam.eye();
    let angle = try_lobe_angle(40.0, 0.95).unwrap();
    // Oracle: P(cos >= c) = 1 - c^(n+1) = 0.95.
    assert!(((angle as f64).cos().powf(41.0) - 0.05).abs() < 1e-4);
    let cp = ClusterCameraOptions {
        far_distance: 60.0,
        cone_half_angle: angle,
        ..ClusterCameraOptions::default()
    };
    let cc = camera_of(try_cluster_camera(&input(&f), &pixels, eye, &cp).unwrap());
    let conv = DepthConvention::ReversedZ;
    let (depth, color) = render_walls(&cc.camera, conv);
    let (dw, dh) = (cc.camera.width(), cc.camera.height());
    let di = DepthImage::try_new(
        ImageView::try_new(&depth, dw, dh, dw).unwrap(),
        cc.camera,
        conv,
    )
    .unwrap();
    let cv = ImageView::try_new(&color, dw, dh, dw).unwrap();
    for (rays, fade) in [(8u32, false), (49, false), (16, true)] {
        let params = FinalizeInput {
            thickness: Thickness::Constant(0.5),
            step: StepOptions::default(),
            refine: true,
            lobe: Lobe {
                rays,
                exponent: 40.0,
                max_angle: angle,
            },
            fade,
            seed: 1,
            single_ray: false,
        };
        let mut out = vec![ClusterShade::default(); pixels.len()];
        try_finalize_cluster(&mut out, &input(&f), &pixels, eye, &cc, &di, &cv, &params).unwrap();
        for o in &out {
            assert!(o.rays >= 1 && o.rays <= rays);
            assert!(o.hits <= o.rays);
            let miss_share = (o.rays - o.hits) as f32 / o.rays as f32;
            assert!((o.env_weight - miss_share).abs() < 1e-6);
            if fade {
                assert!(o.hit_weight <= o.hits as f32 / o.rays as f32 + 1e-6);
            } else {
                assert!((o.hit_weight + o.env_weight - 1.0).abs() < 1e-5);
            }
            // Every lobe direction lies within the truncation angle.
            assert!(o.env_dir.is_finite() && o.rgb.is_finite());
        }
        // Most glossy rays of the floor near the walls hit.
        let hit_share: f32 = out
            .iter()
            .map(|o| o.hits as f32 / o.rays as f32)
            .sum::<f32>()
            / out.len() as f32;
        assert!(hit_share > 0.5, "{hit_share}");
    }
    // Hostile input: outputs untouched.
    let sentinel = ClusterShade {
        rays: 77,
        ..ClusterShade::default()
    };
    let mut out = vec![sentinel; pixels.len()];
    let base = FinalizeInput {
        thickness: Thickness::Constant(0.5),
        step: StepOptions::default(),
        refine: false,
        lobe: Lobe::MIRROR,
        fade: false,
        seed: 0,
        single_ray: false,
    };
    let e = |out: &mut [ClusterShade], p: &FinalizeInput, eye: Vec3, inp: &ClusterInput| {
        try_finalize_cluster(out, inp, &pixels, eye, &cc, &di, &cv, p)
    };
    assert_eq!(
        e(&mut out[..3], &base, eye, &input(&f)),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        e(&mut out, &base, Vec3::NAN, &input(&f)),
        Err(Error::InvalidArgument)
    );
    for bad in [
        FinalizeInput {
            thickness: Thickness::Constant(f32::NAN),
            ..base
        },
        FinalizeInput {
            step: StepOptions {
                stride: 0,
                max_steps: 4,
            },
            ..base
        },
        FinalizeInput {
            lobe: Lobe {
                rays: 0,
                ..Lobe::MIRROR
            },
            ..base
        },
        FinalizeInput {
            lobe: Lobe {
                rays: 65,
                exponent: 1.0,
                max_angle: 0.5,
            },
            ..base
        },
        FinalizeInput {
            lobe: Lobe {
                rays: 8,
                exponent: f32::NAN,
                max_angle: 0.5,
            },
            ..base
        },
        FinalizeInput {
            lobe: Lobe {
                rays: 8,
                exponent: 10.0,
                max_angle: 2.0,
            },
            ..base
        },
    ] {
        assert_eq!(
            e(&mut out, &bad, eye, &input(&f)),
            Err(Error::InvalidArgument)
        );
    }
    let mut nan = Frame {
        positions: f.positions.clone(),
        normals: f.normals.clone(),
        objects: f.objects.clone(),
    };
    nan.normals[pixels[5] as usize] = Vec3::new(0.0, f32::NAN, 0.0);
    assert_eq!(
        e(&mut out, &base, eye, &input(&nan)),
        Err(Error::InvalidArgument)
    );
    let small = vec![[0.0f32; 3]; 4];
    let sv = ImageView::try_new(&small, 2, 2, 2).unwrap();
    assert_eq!(
        try_finalize_cluster(&mut out, &input(&f), &pixels, eye, &cc, &di, &sv, &base),
        Err(Error::InvalidArgument)
    );
    assert!(out.iter().all(|o| *o == sentinel));
    assert!(try_lobe_angle(f32::NAN, 0.5).is_err() && try_lobe_angle(1.0, 1.0).is_err());
}
