//! Back-face depth images (`refl_core::backface`): the second-pass rule
//! against its statement (every convention, the cleared value, texels in
//! front and NaN), and the layered rule against the analytic exit of
//! spheres (closed form), including a sphere behind another in the same
//! two-layer map.
#![cfg(any(feature = "depth-image", feature = "hiz"))]

use refl_core::glam::{DVec3, Vec2, Vec3};
use refl_core::{
    try_back_depth, BackDepthStats, Camera, DepthConvention, DepthImage, Error, ImageView,
    ImageViewMut, RowRange,
};

const W: u32 = 96;
const H: u32 = 72;

/// Conventions with an infinite far plane or not.
const CASES: [(DepthConvention, bool); 4] = [
    (DepthConvention::Linear, false),
    (DepthConvention::ZeroToOne, false),
    (DepthConvention::ReversedZ, false),
    (DepthConvention::ReversedZ, true),
];

/// Spheres `(center, radius)`: A at the front, B behind it along the view.
const SPHERES: [(DVec3, f64); 2] = [
    (DVec3::new(0.0, 1.0, 0.0), 1.0),
    (DVec3::new(0.3, 1.1, -3.0), 0.8),
];

fn camera(far: f32) -> Camera {
    Camera::try_look_at(
        Vec3::new(0.4, 1.6, 6.0),
        Vec3::new(0.0, 0.9, 0.0),
        Vec3::Y,
        0.8,
        0.1,
        far,
        W,
        H,
    )
    .unwrap()
}

/// Entry and exit of a ray with sphere `k` (f64), if it crosses it.
fn sphere_span(o: DVec3, d: DVec3, k: usize) -> Option<(f64, f64)> {
    let (c, r) = SPHERES[k];
    let oc = o - c;
    let b = oc.dot(d);
    let disc = b * b - (oc.dot(oc) - r * r);
    (disc > 0.0).then(|| (-b - disc.sqrt(), -b + disc.sqrt()))
}

/// Per pixel: the front linear depth, the exit linear depth of the
/// object seen and which sphere (`None`: the floor `y = 0` or nothing).
struct Truth {
    front: Vec<Option<f64>>,
    exit: Vec<Option<f64>>,
    sphere: Vec<Option<usize>>,
}

fn truth(cam: &Camera) -> Truth {
    let n = (W * H) as usize;
    let mut t = Truth {
        front: vec![None; n],
        exit: vec![None; n],
        sphere: vec![None; n],
    };
    let fwd = -cam.inverse_view().z_axis.truncate().as_dvec3();
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (o, d) = (r.origin.as_dvec3(), r.dir.as_dvec3().normalize());
            let mut best: Option<(f64, Option<f64>, Option<usize>)> = None;
            for k in 0..2 {
                if let Some((t0, t1)) = sphere_span(o, d, k) {
                    if t0 > 0.0 && best.is_none_or(|b| t0 < b.0) {
                        best = Some((t0, Some(t1), Some(k)));
                    }
                }
            }
            if d.y < 0.0 {
                let tf = -o.y / d.y;
                if best.is_none_or(|b| tf < b.0) {
                    best = Some((tf, None, None));
                }
            }
            if let Some((t0, t1, k)) = best {
                let c = d.dot(fwd);
                if t0 * c < f64::from(cam.far()) {
                    t.front[i] = Some(t0 * c);
                    t.exit[i] = t1.map(|t1| t1 * c);
                    t.sphere[i] = k;
                }
            }
        }
    }
    t
}

fn cleared(cam: &Camera, c: DepthConvention) -> f32 {
    cam.encode_depth(cam.far(), c)
}

fn encode(cam: &Camera, c: DepthConvention, z: Option<f64>) -> f32 {
    match z {
        Some(z) => cam.encode_depth(z as f32, c),
        None => cleared(cam, c),
    }
}

fn run(
    cam: &Camera,
    c: DepthConvention,
    front: &[f32],
    back: &[f32],
    rows: Option<RowRange>,
    dst: &mut [f32],
) -> Result<BackDepthStats, Error> {
    let f = DepthImage::try_new(ImageView::try_new(front, W, H, W).unwrap(), *cam, c).unwrap();
    let b = ImageView::try_new(back, W, H, W).unwrap();
    match rows {
        None => try_back_depth(&mut ImageViewMut::try_new(dst, W, H, W).unwrap(), &f, &b),
        Some(r) => {
            let start = (r.start() * W) as usize;
            let end = (r.end() * W) as usize;
            let mut band = ImageViewMut::try_band(&mut dst[start..end], W, H, W, r).unwrap();
            try_back_depth(&mut band, &f, &b)
        }
    }
}

#[test]
fn a_second_pass_is_kept_behind_the_front_and_clamped_in_front() {
    for (c, inf) in CASES {
        let cam = camera(if inf { f32::INFINITY } else { 40.0 });
        let t = truth(&cam);
        let n = (W * H) as usize;
        let front: Vec<f32> = t.front.iter().map(|z| encode(&cam, c, *z)).collect();
        // The back pass: the sphere's exit, the cleared value behind the
        // one-sided floor; then damaged texels: a back face in front of the
        // front, NaN, and exactly the front.
        let mut back: Vec<f32> = t.exit.iter().map(|z| encode(&cam, c, *z)).collect();
        let mut kinds = vec![0u8; n];
        for i in (0..n).step_by(7) {
            if let Some(z) = t.front[i] {
                match i % 3 {
                    0 => {
                        back[i] = cam.encode_depth((0.5 * z) as f32, c);
                        kinds[i] = 1;
                    }
                    1 => {
                        back[i] = f32::NAN;
                        kinds[i] = 1;
                    }
                    _ => {
                        back[i] = front[i];
                        kinds[i] = 2;
                    }
                }
            }
        }
        let mut dst = vec![-5.0f32; n];
        let st = run(&cam, c, &front, &back, None, &mut dst).unwrap();
        let (mut surfaces, mut clamped, mut solid) = (0, 0, 0);
        for i in 0..n {
            let want = match t.front[i] {
                None => back[i],
                Some(_) => {
                    surfaces += 1;
                    if kinds[i] == 1 {
                        clamped += 1;
                        front[i]
                    } else {
                        if kinds[i] == 0 && t.exit[i].is_none() {
                            solid += 1;
                        }
                        back[i]
                    }
                }
            };
            assert_eq!(dst[i].to_bits(), want.to_bits(), "{c:?} pixel {i}");
        }
        assert_eq!(
            (st.surfaces, st.clamped, st.cleared, st.exits),
            (surfaces, clamped, solid, 0),
            "{c:?}"
        );
        assert!(surfaces > 3000 && clamped > 200 && solid > 1000, "{st:?}");
        // Never in front of the front, wherever there is a surface.
        for i in 0..n {
            if t.front[i].is_some() {
                let (f, b) = (front[i], dst[i]);
                let behind = if c.closer_is_greater() {
                    b <= f
                } else {
                    b >= f
                };
                assert!(behind, "{c:?} {i}");
            }
        }
        // Bands give the whole image.
        let mut banded = vec![-5.0f32; n];
        let mut sum = BackDepthStats::default();
        for k in 0..4 {
            let r = RowRange::try_all(H).unwrap().band(k, 4).unwrap();
            let s = run(&cam, c, &front, &back, Some(r), &mut banded).unwrap();
            sum.surfaces += s.surfaces;
            sum.clamped += s.clamped;
            sum.cleared += s.cleared;
        }
        assert_eq!(sum, st);
        assert!(banded
            .iter()
            .zip(&dst)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}

#[test]
fn images_of_another_size_are_refused_and_nothing_is_written() {
    let cam = camera(40.0);
    let c = DepthConvention::ZeroToOne;
    let n = (W * H) as usize;
    let front = vec![0.5f32; n];
    let f = DepthImage::try_new(ImageView::try_new(&front, W, H, W).unwrap(), cam, c).unwrap();
    let back = vec![0.7f32; n];
    let mut dst = vec![-5.0f32; n];
    let b_small = ImageView::try_new(&back, W - 1, H, W).unwrap();
    let b = ImageView::try_new(&back, W, H, W).unwrap();
    assert_eq!(
        try_back_depth(
            &mut ImageViewMut::try_new(&mut dst, W, H, W).unwrap(),
            &f,
            &b_small
        ),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_back_depth(
            &mut ImageViewMut::try_new(&mut dst, W, H - 1, W).unwrap(),
            &f,
            &b
        ),
        Err(Error::InvalidArgument)
    );
    assert!(dst.iter().all(|v| *v == -5.0));
}

#[cfg(feature = "layered")]
mod layered {
    use super::*;
    use refl_core::{
        try_back_depth_layered, try_layered_len, Face, LayerHit, LayeredGrid, LayeredMap,
        LayeredMapMut, Ray,
    };

    struct Owned {
        grid: LayeredGrid,
        depth: Vec<f32>,
        payload: Vec<u32>,
        counts: Vec<u32>,
        bounds: Vec<f32>,
    }

    impl Owned {
        fn map(&self) -> LayeredMap<'_> {
            LayeredMap::try_new(
                self.grid,
                &self.depth,
                &self.payload,
                &self.counts,
                &self.bounds,
            )
            .unwrap()
        }
    }

    /// A map of `spheres` (indices into SPHERES) over their box enlarged by
    /// 5%, every column cast through the analytic crossings.
    fn build(spheres: &[usize], res: u32, layers: u32) -> Owned {
        let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
        for &k in spheres {
            let (c, r) = SPHERES[k];
            lo = lo.min(c - r);
            hi = hi.max(c + r);
        }
        let m = (hi - lo) * 0.05;
        let grid =
            LayeredGrid::try_new((lo - m).as_vec3(), (hi + m).as_vec3(), res, layers).unwrap();
        let len = try_layered_len(res, layers).unwrap();
        let mut o = Owned {
            grid,
            depth: vec![0.0; len.depth],
            payload: vec![0; len.payload],
            counts: vec![0; len.counts],
            bounds: vec![0.0; len.bounds],
        };
        let mut map = LayeredMapMut::try_new(
            grid,
            &mut o.depth,
            &mut o.payload,
            &mut o.counts,
            &mut o.bounds,
        )
        .unwrap();
        map.clear();
        for face in [Face::NegX, Face::NegY, Face::NegZ] {
            for j in 0..res {
                for i in 0..res {
                    let ray = grid.try_face_ray(face, i, j).unwrap();
                    let (org, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
                    let mut hits = Vec::new();
                    for &k in spheres {
                        if let Some((t0, t1)) = sphere_span(org, d, k) {
                            for (t, front) in [(t0, true), (t1, false)] {
                                if t >= 0.0 && t <= f64::from(ray.t_max) {
                                    hits.push(LayerHit {
                                        t: t as f32,
                                        id: k as u32,
                                        front,
                                    });
                                }
                            }
                        }
                    }
                    map.try_fill_column(face, i, j, &mut hits).unwrap();
                }
            }
        }
        map.build_bounds();
        o
    }

    fn texel(o: &Owned) -> f64 {
        let e = (o.grid.max() - o.grid.min()).as_dvec3();
        e.max_element() / f64::from(o.grid.face_res())
    }

    #[test]
    fn exit_of_rays_from_the_sphere_surface_is_the_chord() {
        let o = build(&[0], 64, 1);
        let map = o.map();
        let (c, r) = SPHERES[0];
        let mut errs = Vec::new();
        let mut s = 1u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            // A point on the sphere and a direction into it.
            let u = DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize();
            let p = c + u * r;
            let mut d = DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize();
            if d.dot(u) > -0.1 {
                d = (d - u * (d.dot(u) + 0.5)).normalize();
            }
            let chord = -2.0 * (p - c).dot(d);
            let Some(t) = map.exit(&Ray {
                origin: p.as_vec3(),
                dir: d.as_vec3(),
            }) else {
                panic!("no exit: p {p} d {d}");
            };
            errs.push((f64::from(t) - chord).abs() / texel(&o));
        }
        // In texels of the map: within one mostly, a few where the ray
        // leaves at a grazing angle (the chords' exit angles are those of
        // their entries, down to acos(0.1)).
        errs.sort_by(f64::total_cmp);
        let (p99, max) = (errs[errs.len() * 99 / 100], errs[errs.len() - 1]);
        eprintln!("sphere chords: p99 {p99:.3} texels, max {max:.3}");
        assert!(p99 < 1.5 && max < 3.0, "p99 {p99} max {max}");
        // A ray from outside the object (beyond the window) has no exit.
        let away = Ray {
            origin: Vec3::new(0.0, 1.0, 1.5),
            dir: Vec3::Z,
        };
        assert_eq!(map.exit(&away), None);
        let nan = Ray {
            origin: Vec3::new(f32::NAN, 1.0, 1.0),
            dir: Vec3::Z,
        };
        assert_eq!(map.exit(&nan), None);
    }

    #[test]
    fn layered_back_depth_is_the_exit_of_the_sphere_seen() {
        let (mut p99_worst, mut max_worst) = (0.0f64, 0.0f64);
        for (c, inf) in CASES {
            let cam = camera(if inf { f32::INFINITY } else { 40.0 });
            let t = truth(&cam);
            let n = (W * H) as usize;
            let front: Vec<f32> = t.front.iter().map(|z| encode(&cam, c, *z)).collect();
            let f =
                DepthImage::try_new(ImageView::try_new(&front, W, H, W).unwrap(), cam, c).unwrap();
            // Both spheres in one map with two layers, and each alone.
            let both = build(&[0, 1], 96, 2);
            let tx = texel(&both);
            let mut dst = vec![cleared(&cam, c); n];
            let st = try_back_depth_layered(
                &mut ImageViewMut::try_new(&mut dst, W, H, W).unwrap(),
                &f,
                &both.map(),
            )
            .unwrap();
            let mut errs = Vec::new();
            for (i, v) in dst.iter().enumerate() {
                match (t.sphere[i], t.exit[i]) {
                    (Some(_), Some(ze)) => {
                        let z = f64::from(cam.decode_depth(*v, c));
                        errs.push((z - ze).abs() / tx);
                    }
                    // The floor and the background keep the cleared value.
                    _ => assert_eq!(v.to_bits(), cleared(&cam, c).to_bits(), "{c:?} {i}"),
                }
            }
            errs.sort_by(f64::total_cmp);
            let p99 = errs[errs.len() * 99 / 100];
            let max = *errs.last().unwrap();
            p99_worst = p99_worst.max(p99);
            max_worst = max_worst.max(max);
            assert!(errs.len() > 500, "{}", errs.len());
            assert!(st.exits as usize >= errs.len() * 99 / 100, "{st:?}");
            // Error in texels of the map along the view axis: the exit is
            // found within a texel, silhouettes within a few.
            assert!(p99 < 1.0 && max < 6.0, "{c:?}: p99 {p99} max {max} texels");
            // Sphere A's pixels whose ray goes on into B get A's exit, not
            // B's: the exit of the object seen.
            let mut through = 0;
            for y in 0..H {
                for x in 0..W {
                    let i = (y * W + x) as usize;
                    if t.sphere[i] != Some(0) {
                        continue;
                    }
                    let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                    if sphere_span(r.origin.as_dvec3(), r.dir.as_dvec3().normalize(), 1).is_some() {
                        through += 1;
                        let z = f64::from(cam.decode_depth(dst[i], c));
                        assert!((z - t.exit[i].unwrap()).abs() < 6.0 * tx);
                    }
                }
            }
            assert!(through > 100, "{through}");
            // The nearest exit wins: a valid, nearer value already there is
            // kept; one in front of the front is replaced.
            let mut pre = vec![cleared(&cam, c); n];
            let i = t.sphere.iter().position(|s| *s == Some(0)).unwrap();
            let zf = t.front[i].unwrap();
            let near_back = cam.encode_depth((zf + 0.01) as f32, c);
            pre[i] = near_back;
            pre[i + 1] = cam.encode_depth((0.5 * t.front[i + 1].unwrap()) as f32, c);
            try_back_depth_layered(
                &mut ImageViewMut::try_new(&mut pre, W, H, W).unwrap(),
                &f,
                &both.map(),
            )
            .unwrap();
            assert_eq!(pre[i].to_bits(), near_back.to_bits());
            assert_eq!(pre[i + 1].to_bits(), dst[i + 1].to_bits());
            // Size mismatch: refused, nothing written.
            let mut small = vec![-5.0f32; n];
            assert_eq!(
                try_back_depth_layered(
                    &mut ImageViewMut::try_new(&mut small, W - 1, H, W).unwrap(),
                    &f,
                    &both.map()
                ),
                Err(Error::InvalidArgument)
            );
            assert!(small.iter().all(|v| *v == -5.0));
        }
        eprintln!("layered back depth: p99 {p99_worst:.3} texels, max {max_worst:.3}");
    }
}
