//! TCRR (seed 000) against f64 oracles: the distance function (Fig. 4) and
//! its degenerate cases, the neighborhood search (Alg. 2) against the closed
//! form of a planar mirror, shifting against an affine-map oracle, warping
//! and the whole chain against an analytic scene (a mirror floor reflecting
//! a patterned wall and the sky), and the stiff cases: stationary camera,
//! rotation only, grazing views, large steps, camera moving toward the
//! reflector.
#![cfg(feature = "tcrr")]

use refl_core::glam::{DVec3, Vec2, Vec3};
use refl_core::tcrr::{
    self, fresnel_weight, offset_is_valid, reflection_distance, retrace_count, try_compose,
    try_retrace_list, CurrentView, Fresnel, KeyFramePolicy, Reflected, ReflectionBuffers,
    TcrrOptions, INVALID_OFFSET, MASK_NONE, MASK_RETRACE, MASK_REUSED,
};
use refl_core::{Camera, DepthConvention, Error, ImageView, ImageViewMut};

// ---------------------------------------------------------------- oracles

/// f64 oracle of the distance function, written from Fig. 4 directly:
/// mirror R explicitly, then the distance from E to the ray M + s v, s >= 0.
fn distance_f64(e: DVec3, w: DVec3, n: DVec3, r: DVec3) -> Option<f64> {
    let n = n.normalize();
    if n.dot(e - w) <= 0.0 || n.dot(r - w) <= 1e-9 * (r - w).length() {
        return None;
    }
    let m = r - 2.0 * n * n.dot(r - w);
    let v = (w - m).normalize();
    let s = (e - m).dot(v);
    Some(if s < 0.0 {
        (e - m).length()
    } else {
        (e - m - v * s).length()
    })
}

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
    fn vec(&mut self, s: f64) -> DVec3 {
        DVec3::new(self.range(-s, s), self.range(-s, s), self.range(-s, s))
    }
}

#[test]
fn distance_matches_f64_oracle() {
    let mut rng = Lcg(7);
    let mut checked = 0;
    for _ in 0..20_000 {
        let w = rng.vec(5.0);
        let n = rng.vec(1.0);
        if n.length() < 0.1 {
            continue;
        }
        let e = rng.vec(8.0);
        let r = rng.vec(8.0);
        let got = reflection_distance(
            e.as_vec3(),
            w.as_vec3(),
            n.as_vec3(),
            Reflected::Point(r.as_vec3()),
        );
        let want = distance_f64(e, w, n, r);
        match (got, want) {
            (Some(g), Some(wd)) => {
                let scale = (e - w).length() + (r - w).length();
                assert!(
                    (f64::from(g) - wd).abs() <= 1e-5 * scale,
                    "e={e} w={w} n={n} r={r}: {g} vs {wd}"
                );
                checked += 1;
            }
            (None, None) => {}
            // Only the f32-vs-f64 borderline of the two guards may differ.
            (g, wd) => {
                let nn = n.normalize();
                let he = nn.dot(e - w) / (e - w).length();
                let hr = nn.dot(r - w) / (r - w).length();
                assert!(he.abs() < 1e-5 || hr.abs() < 1e-5, "{g:?} vs {wd:?}");
            }
        }
    }
    assert!(checked > 5_000, "{checked}");
}

#[test]
fn distance_degenerate_cases() {
    let w = Vec3::new(0.3, 0.0, -0.2);
    let n = Vec3::Y;
    let e = Vec3::new(1.0, 2.0, 3.0);
    // R on the tangent plane: M = R, the ray is tangent: undefined.
    assert_eq!(
        reflection_distance(e, w, n, Reflected::Point(Vec3::new(4.0, 0.0, 1.0))),
        None
    );
    // R = W_n: M = W_n, no ray at all (design.md erratum).
    assert_eq!(reflection_distance(e, w, n, Reflected::Point(w)), None);
    // R behind the tangent plane.
    assert_eq!(
        reflection_distance(e, w, n, Reflected::Point(Vec3::new(0.0, -1.0, 0.0))),
        None
    );
    let r = Reflected::Point(Vec3::new(-2.0, 1.5, -3.0));
    // The eye on, or behind, the tangent plane: the candidate faces away.
    assert_eq!(reflection_distance(Vec3::new(5.0, 0.0, 5.0), w, n, r), None);
    assert_eq!(
        reflection_distance(Vec3::new(1.0, -0.5, 1.0), w, n, r),
        None
    );
    // Eye at the surface point.
    assert_eq!(reflection_distance(w, w, n, r), None);
    // Bad input.
    assert_eq!(reflection_distance(e, w, Vec3::ZERO, r), None);
    assert_eq!(reflection_distance(Vec3::NAN, w, n, r), None);
    assert_eq!(
        reflection_distance(e, w, n, Reflected::Point(Vec3::INFINITY)),
        None
    );
    assert_eq!(
        reflection_distance(e, w, n, Reflected::Direction(Vec3::ZERO)),
        None
    );
    assert_eq!(
        reflection_distance(e, w, n, Reflected::Direction(Vec3::new(1.0, 0.0, 0.0))),
        None
    );
    // Grazing: eye and R barely above the plane; still defined and accurate.
    for h in [1e-3f32, 1e-2, 0.1] {
        let e = Vec3::new(10.0, h, 0.0);
        let rp = Vec3::new(-10.0, h * 0.9, 0.5);
        let got = reflection_distance(e, w, n, Reflected::Point(rp)).unwrap();
        let want = distance_f64(e.as_dvec3(), w.as_dvec3(), n.as_dvec3(), rp.as_dvec3()).unwrap();
        assert!(
            (f64::from(got) - want).abs() < 1e-4 * 20.0,
            "{h}: {got} {want}"
        );
    }
    // The eye "before" the ray start (s < 0): the distance is |E - M|.
    let rp = Vec3::new(0.3 + 1.0, 1.0, -0.2);
    let m = Vec3::new(1.3, -1.0, -0.2);
    let e = Vec3::new(30.0, 0.1, -0.2);
    let got = reflection_distance(e, w, n, Reflected::Point(rp)).unwrap();
    assert!((got - (e - m).length()).abs() < 1e-4, "{got}");
    let want = distance_f64(e.as_dvec3(), w.as_dvec3(), n.as_dvec3(), rp.as_dvec3()).unwrap();
    assert!((f64::from(got) - want).abs() < 1e-4);
}

#[test]
fn distance_is_zero_on_the_reflection_and_direction_is_the_far_limit() {
    let mut rng = Lcg(11);
    for _ in 0..2000 {
        let w = rng.vec(3.0);
        let mut n = rng.vec(1.0);
        if n.length() < 0.2 {
            continue;
        }
        n = n.normalize();
        let e = w + n * rng.range(0.5, 4.0) + rng.vec(2.0);
        if n.dot(e - w) <= 0.1 {
            continue;
        }
        let view = (e - w).normalize();
        let d = 2.0 * view.dot(n) * n - view;
        let r = w + d * rng.range(0.5, 10.0);
        let got = reflection_distance(
            e.as_vec3(),
            w.as_vec3(),
            n.as_vec3(),
            Reflected::Point(r.as_vec3()),
        )
        .unwrap();
        assert!(got < 1e-4 * (e - w).length() as f32 * 20.0, "{got}");
        let dir = reflection_distance(
            e.as_vec3(),
            w.as_vec3(),
            n.as_vec3(),
            Reflected::Direction(d.as_vec3()),
        )
        .unwrap();
        assert!(dir < 1e-4 * 20.0, "{dir}");
        // Direction(d) is the limit of Point(W + t d) as t grows.
        let e2 = e + rng.vec(0.5);
        if n.dot(e2 - w) <= 0.1 {
            continue;
        }
        let far = distance_f64(e2, w, n, w + d * 1e9).unwrap();
        let dir = reflection_distance(
            e2.as_vec3(),
            w.as_vec3(),
            n.as_vec3(),
            Reflected::Direction(d.as_vec3()),
        )
        .unwrap();
        assert!((f64::from(dir) - far).abs() < 1e-4 * 10.0, "{dir} {far}");
    }
}

// --------------------------------------------------------- analytic world

/// A mirror floor (y = 0, reflective over |x| <= FX, Z0 <= z <= Z1,
/// diffuse elsewhere) reflecting a patterned wall (z = -WALL, y <= WALL_H)
/// and the sky.
const FX: f64 = 3.0;
const Z0: f64 = -4.0;
const Z1: f64 = 2.0;
const WALL: f64 = 6.0;
const WALL_H: f64 = 3.0;

fn wall_color(p: DVec3) -> DVec3 {
    DVec3::new(
        0.5 + 0.4 * (1.3 * p.x).sin(),
        0.5 + 0.4 * (1.7 * p.y + 0.3).sin(),
        0.5 + 0.3 * (0.9 * p.x + 1.1 * p.y).cos(),
    )
}

fn sky_color(d: DVec3) -> DVec3 {
    DVec3::new(0.3 + 0.2 * d.x, 0.5 + 0.3 * d.y, 0.7 + 0.2 * d.z)
}

/// The reflected radiance along direction `d` from floor point `w`, and
/// the travel distance (`inf` for the sky).
fn reflected(w: DVec3, d: DVec3) -> (DVec3, f64) {
    if d.z < 0.0 {
        let t = (-WALL - w.z) / d.z;
        let p = w + d * t;
        if p.y <= WALL_H {
            return (wall_color(p), t);
        }
    }
    (sky_color(d), f64::INFINITY)
}

struct Frame {
    cam: Camera,
    conv: DepthConvention,
    depth: Vec<f32>,
    normal: Vec<[f32; 3]>,
    spec: Vec<f32>,
    color: Vec<[f32; 3]>,
    dist: Vec<f32>,
    /// f64 truth of the reflection at each reflective pixel.
    truth: Vec<DVec3>,
}

fn camera(eye: Vec3, target: Vec3, conv: DepthConvention, w: u32, h: u32) -> Camera {
    let far = match conv {
        DepthConvention::ReversedZ => f32::INFINITY,
        _ => 200.0,
    };
    Camera::try_look_at(eye, target, Vec3::Y, 55f32.to_radians(), 0.05, far, w, h).unwrap()
}

fn render(cam: Camera, conv: DepthConvention) -> Frame {
    let (w, h) = (cam.width(), cam.height());
    let n = (w * h) as usize;
    let mut f = Frame {
        cam,
        conv,
        depth: vec![cam.encode_depth(cam.far(), conv); n],
        normal: vec![[0.0; 3]; n],
        spec: vec![0.0; n],
        color: vec![[0.0; 3]; n],
        dist: vec![0.0; n],
        truth: vec![DVec3::ZERO; n],
    };
    if conv == DepthConvention::Linear {
        f.depth.fill(f32::INFINITY);
    }
    let eye = cam.eye().as_dvec3();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let ray = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let dir = ray.dir.as_dvec3();
            if dir.y >= -1e-6 {
                continue;
            }
            let t = -eye.y / dir.y;
            let p = eye + dir * t;
            if p.x.abs() > 40.0 || p.z.abs() > 40.0 {
                continue;
            }
            let z = cam.linear_depth(p.as_vec3());
            f.depth[i] = cam.encode_depth(z, conv);
            f.normal[i] = [0.0, 1.0, 0.0];
            if p.x.abs() <= FX && p.z >= Z0 && p.z <= Z1 {
                f.spec[i] = 0.9;
                let d = DVec3::new(dir.x, -dir.y, dir.z);
                let (c, r) = reflected(p, d);
                f.color[i] = c.as_vec3().to_array();
                f.dist[i] = r as f32;
                f.truth[i] = c;
            }
        }
    }
    f
}

impl Frame {
    fn size(&self) -> (u32, u32) {
        (self.cam.width(), self.cam.height())
    }
    fn buffers(&self) -> ReflectionBuffers<'_> {
        let (w, h) = self.size();
        ReflectionBuffers::try_new(
            self.cam,
            self.conv,
            ImageView::try_new(&self.depth, w, h, w).unwrap(),
            ImageView::try_new(&self.normal, w, h, w).unwrap(),
            ImageView::try_new(&self.spec, w, h, w).unwrap(),
            ImageView::try_new(&self.color, w, h, w).unwrap(),
            ImageView::try_new(&self.dist, w, h, w).unwrap(),
        )
        .unwrap()
    }
    fn current(&self) -> CurrentView<'_> {
        let (w, h) = self.size();
        CurrentView::try_new(
            self.cam,
            self.conv,
            ImageView::try_new(&self.depth, w, h, w).unwrap(),
            ImageView::try_new(&self.spec, w, h, w).unwrap(),
        )
        .unwrap()
    }
}

/// Output of one TCRR frame.
struct Out {
    offsets: Vec<[f32; 2]>,
    inter: Vec<[f32; 3]>,
    coverage: Vec<u8>,
    color: Vec<[f32; 3]>,
    mask: Vec<u8>,
    search: tcrr::SearchStats,
    shift: tcrr::ShiftStats,
    warp: tcrr::WarpStats,
}

/// Search + shift + warp of `cur` from key frame `key`, in `bands` row
/// bands (each pass split the same way).
fn run(key: &Frame, cur: &Frame, p: &TcrrOptions, prev: Option<&[[f32; 2]]>, bands: u32) -> Out {
    run_with(key, cur, p, prev, bands, false)
}

/// [`run`], optionally with [`tcrr::prepare`]d surfels (prepared in the
/// same bands) attached to the key buffers.
fn run_with(
    key: &Frame,
    cur: &Frame,
    p: &TcrrOptions,
    prev: Option<&[[f32; 2]]>,
    bands: u32,
    surfels: bool,
) -> Out {
    let (w, h) = key.size();
    let n = (w * h) as usize;
    let b = key.buffers();
    let split = |h: u32, k: u32| (k * h) / bands;
    let mut cache = vec![tcrr::Surfel::default(); n];
    let b = if surfels {
        let mut rest = ImageViewMut::try_new(&mut cache, w, h, w).unwrap();
        let mut reflective = 0;
        for k in 1..=bands {
            let (mut band, r) = rest.try_split_at_row(split(h, k)).map_err(|e| e.0).unwrap();
            reflective += tcrr::try_prepare(&mut band, &b).unwrap();
            rest = r;
        }
        let expected = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                let i = (y * w + x) as usize;
                key.spec[i] > 0.0 && key.dist[i] >= 0.0
            })
            .count();
        assert!(reflective as usize <= expected && reflective > 0);
        b.try_with_surfels(ImageView::try_new(&cache, w, h, w).unwrap())
            .unwrap()
    } else {
        b
    };
    let mut offsets = prev.map_or(vec![INVALID_OFFSET; n], <[_]>::to_vec);
    let mut search = tcrr::SearchStats::default();
    {
        let mut rest = ImageViewMut::try_new(&mut offsets, w, h, w).unwrap();
        for k in 1..=bands {
            let (mut band, r) = rest.try_split_at_row(split(h, k)).map_err(|e| e.0).unwrap();
            search = search.merged(tcrr::try_search(&mut band, &b, cur.cam.eye(), p).unwrap());
            rest = r;
        }
    }
    let mut inter = vec![[9.0; 3]; n];
    let mut depth = vec![0.0f32; n];
    let mut coverage = vec![7u8; n];
    let mut shift = tcrr::ShiftStats::default();
    {
        let ov = ImageView::try_new(&offsets, w, h, w).unwrap();
        let mut c = ImageViewMut::try_new(&mut inter, w, h, w).unwrap();
        let mut d = ImageViewMut::try_new(&mut depth, w, h, w).unwrap();
        let mut v = ImageViewMut::try_new(&mut coverage, w, h, w).unwrap();
        for k in 1..=bands {
            let at = split(h, k);
            let (mut c1, c2) = c.try_split_at_row(at).map_err(|e| e.0).unwrap();
            let (mut d1, d2) = d.try_split_at_row(at).map_err(|e| e.0).unwrap();
            let (mut v1, v2) = v.try_split_at_row(at).map_err(|e| e.0).unwrap();
            let s = tcrr::try_shift(&mut c1, &mut d1, &mut v1, &b, &ov, p).unwrap();
            shift.drawn += s.drawn;
            shift.magnified += s.magnified;
            shift.covered += s.covered;
            (c, d, v) = (c2, d2, v2);
        }
    }
    let (cw, ch) = cur.size();
    let cn = (cw * ch) as usize;
    let mut color = vec![[5.0; 3]; cn];
    let mut mask = vec![9u8; cn];
    let mut warp = tcrr::WarpStats::default();
    {
        let src = ImageView::try_new(&inter, w, h, w).unwrap();
        let sd = ImageView::try_new(&depth, w, h, w).unwrap();
        let cov = ImageView::try_new(&coverage, w, h, w).unwrap();
        let cv = cur.current();
        let mut c = ImageViewMut::try_new(&mut color, cw, ch, cw).unwrap();
        let mut m = ImageViewMut::try_new(&mut mask, cw, ch, cw).unwrap();
        for k in 1..=bands {
            let at = split(ch, k);
            let (mut c1, c2) = c.try_split_at_row(at).map_err(|e| e.0).unwrap();
            let (mut m1, m2) = m.try_split_at_row(at).map_err(|e| e.0).unwrap();
            warp =
                warp.merged(tcrr::try_warp(&mut c1, &mut m1, &cv, &b, &src, &sd, &cov, p).unwrap());
            (c, m) = (c2, m2);
        }
    }
    Out {
        offsets,
        inter,
        coverage,
        color,
        mask,
        search,
        shift,
        warp,
    }
}

/// Naive warping of the key frame's reflection colors (seed 000 Figs. 1, 6).
fn naive(key: &Frame, cur: &Frame, p: &TcrrOptions) -> (Vec<[f32; 3]>, Vec<u8>) {
    let (w, h) = key.size();
    let cov: Vec<u8> = key.spec.iter().map(|&s| u8::from(s > 0.0)).collect();
    let path: Vec<f32> = (0..key.depth.len())
        .map(|i| key.cam.decode_depth(key.depth[i], key.conv) + key.dist[i])
        .collect();
    let (cw, ch) = cur.size();
    let mut color = vec![[0.0; 3]; (cw * ch) as usize];
    let mut mask = vec![0u8; (cw * ch) as usize];
    tcrr::try_warp(
        &mut ImageViewMut::try_new(&mut color, cw, ch, cw).unwrap(),
        &mut ImageViewMut::try_new(&mut mask, cw, ch, cw).unwrap(),
        &cur.current(),
        &key.buffers(),
        &ImageView::try_new(&key.color, w, h, w).unwrap(),
        &ImageView::try_new(&path, w, h, w).unwrap(),
        &ImageView::try_new(&cov, w, h, w).unwrap(),
        p,
    )
    .unwrap();
    (color, mask)
}

/// Mean absolute error (linear units) against the truth over reused pixels.
fn mean_err(cur: &Frame, color: &[[f32; 3]], mask: &[u8]) -> (f64, usize) {
    let (mut sum, mut n) = (0.0, 0usize);
    for i in 0..mask.len() {
        if mask[i] == MASK_REUSED {
            let c = Vec3::from_array(color[i]).as_dvec3();
            sum += (c - cur.truth[i]).abs().element_sum() / 3.0;
            n += 1;
        }
    }

    (sum / n.max(1) as f64, n)
}

const W: u32 = 96;
const H: u32 = 72;

fn eye0() -> Vec3 {
    Vec3::new(0.2, 1.6, 4.5)
}

fn target0() -> Vec3 {
    Vec3::new(0.0, 0.2, -1.5)
}

// ------------------------------------------------------------ the search

/// Closed form of the planar mirror: the key-frame pixel position of the
/// floor point that reflects sample i's target into `eye` (f64).
fn planar_match(key: &Frame, i: usize, eye: DVec3) -> Option<(f64, f64)> {
    let (w, _) = key.size();
    let (x, y) = ((i as u32 % w) as f32, (i as u32 / w) as f32);
    let ray = key.cam.primary_ray(Vec2::new(x + 0.5, y + 0.5));
    let e0 = key.cam.eye().as_dvec3();
    let dir = ray.dir.as_dvec3();
    let p = e0 + dir * (-e0.y / dir.y);
    let d = DVec3::new(dir.x, -dir.y, dir.z);
    let r = f64::from(key.dist[i]);
    let x_floor = if r.is_finite() {
        let target = p + d * r;
        let mirrored = DVec3::new(eye.x, -eye.y, eye.z);
        mirrored + (target - mirrored) * (-mirrored.y / (target.y - mirrored.y))
    } else {
        let u = DVec3::new(d.x, -d.y, d.z);
        eye + u * (eye.y / d.y)
    };
    let q = key.cam.project(x_floor.as_vec3())?;
    Some((
        f64::from(q.x) - f64::from(x) - 0.5,
        f64::from(q.y) - f64::from(y) - 0.5,
    ))
}

#[test]
fn search_matches_the_planar_closed_form_in_every_convention() {
    for conv in DepthConvention::ALL {
        let key = render(camera(eye0(), target0(), conv, W, H), conv);
        let eye = eye0() + Vec3::new(0.35, -0.1, -0.2);
        let cur = render(camera(eye, target0(), conv, W, H), conv);
        for subpixel in [true, false] {
            let p = TcrrOptions {
                subpixel,
                ..TcrrOptions::default()
            };
            let out = run(&key, &cur, &p, None, 1);
            let (mut worst, mut matched) = (0.0f64, 0);
            for i in 0..out.offsets.len() {
                let o = out.offsets[i];
                if key.spec[i] == 0.0 {
                    assert!(!offset_is_valid(o));
                    continue;
                }
                let Some(want) = planar_match(&key, i, eye.as_dvec3()) else {
                    continue;
                };
                // Matches well inside the reflective patch must be found.
                let (x, y) = (i as u32 % W, i as u32 / W);
                let inside = |dx: f64, dy: f64| {
                    let (tx, ty) = (x as f64 + 0.5 + dx, y as f64 + 0.5 + dy);
                    (2.0..W as f64 - 2.0).contains(&tx) && (2.0..H as f64 - 2.0).contains(&ty) && {
                        let j = (ty as u32 * W + tx as u32) as usize;
                        let ring = [(-2i32, -2i32), (2, -2), (-2, 2), (2, 2), (0, 0)];
                        ring.iter().all(|(a, b)| {
                            let k = ((ty as i32 + b) as u32 * W + (tx as i32 + a) as u32) as usize;
                            key.spec[k] > 0.0 && key.spec[j] > 0.0
                        })
                    }
                };
                if !inside(want.0, want.1) {
                    continue;
                }
                assert!(offset_is_valid(o), "{conv:?} pixel {i} want {want:?}");
                matched += 1;
                let err = (f64::from(o[0]) - want.0).hypot(f64::from(o[1]) - want.1);
                worst = worst.max(err);
            }
            assert!(matched > 1000, "{matched}");
            let bound = if subpixel { 0.15 } else { 0.75 };
            assert!(worst < bound, "{conv:?} subpixel={subpixel}: worst {worst}");
        }
    }
}

#[test]
fn search_leaves_the_silhouette_as_invalid_and_respects_the_cap() {
    let conv = DepthConvention::Linear;
    let key = render(camera(eye0(), target0(), conv, W, H), conv);
    // A large step sideways: many matches leave the reflective patch.
    let eye = eye0() + Vec3::new(2.5, 0.0, 0.0);
    let cur = render(camera(eye, target0(), conv, W, H), conv);
    let out = run(&key, &cur, &TcrrOptions::default(), None, 1);
    let mut outside_invalid = 0;
    for i in 0..out.offsets.len() {
        if key.spec[i] == 0.0 {
            continue;
        }
        let Some(want) = planar_match(&key, i, eye.as_dvec3()) else {
            continue;
        };
        let (x, y) = ((i as u32 % W) as f64, (i as u32 / W) as f64);
        let (tx, ty) = (x + 0.5 + want.0, y + 0.5 + want.1);
        let target_reflective = tx >= 0.0
            && ty >= 0.0
            && tx < W as f64
            && ty < H as f64
            && key.spec[(ty as u32 * W + tx as u32) as usize] > 0.0;
        // A match 3 px outside the reflector cannot be found.
        let far_outside = !target_reflective
            && (tx >= 0.0 && tx < W as f64 && ty >= 0.0 && ty < H as f64)
            && [(-3.0, 0.0), (3.0, 0.0), (0.0, -3.0), (0.0, 3.0)]
                .iter()
                .all(|(a, b)| {
                    let (u, v) = (tx + a, ty + b);
                    !(u >= 0.0 && v >= 0.0 && u < W as f64 && v < H as f64)
                        || key.spec[(v as u32 * W + u as u32) as usize] == 0.0
                });
        if far_outside {
            assert!(!offset_is_valid(out.offsets[i]), "pixel {i}");
            outside_invalid += 1;
        }
    }
    assert!(outside_invalid > 20, "{outside_invalid}");
    assert!(out.search.invalid > 0 && out.search.matched > 0);
    // Cap 1: only matches within one step of the start are found.
    let capped = run(
        &key,
        &cur,
        &TcrrOptions {
            max_iterations: 1,
            ..TcrrOptions::default()
        },
        None,
        1,
    );
    assert!(capped.search.invalid > out.search.invalid + 500);
    assert!(capped.search.iterations <= u64::from(capped.search.reflective));
    // Large steps: the re-trace share tells the policy to start a key frame.
    let policy = KeyFramePolicy::try_new(0.3).unwrap();
    assert!(policy.needs_key_frame(
        u64::from(capped.warp.retrace),
        u64::from(capped.warp.reflective)
    ));
}

#[test]
fn warm_start_from_previous_offsets_saves_iterations() {
    let conv = DepthConvention::ZeroToOne;
    let key = render(camera(eye0(), target0(), conv, W, H), conv);
    let e1 = eye0() + Vec3::new(0.3, 0.0, 0.0);
    let e2 = eye0() + Vec3::new(0.33, 0.0, 0.0);
    let f1 = render(camera(e1, target0(), conv, W, H), conv);
    let f2 = render(camera(e2, target0(), conv, W, H), conv);
    let p = TcrrOptions::default();
    let first = run(&key, &f1, &p, None, 1);
    let cold = run(&key, &f2, &p, None, 1);
    let warm = run(&key, &f2, &p, Some(&first.offsets), 1);
    assert!(warm.search.iterations * 2 < cold.search.iterations);
    // Same minima (up to the sub-pixel fit) either way.
    let mut differ = 0;
    for i in 0..cold.offsets.len() {
        let (a, b) = (cold.offsets[i], warm.offsets[i]);
        if offset_is_valid(a) && offset_is_valid(b) {
            differ += usize::from((a[0] - b[0]).abs() + (a[1] - b[1]).abs() > 1e-3);
        }
    }
    assert!(differ * 100 < cold.offsets.len(), "{differ}");
}

// ------------------------------------------------------------ stiff cases

#[test]
fn stationary_camera_reproduces_the_key_frame_exactly() {
    for conv in DepthConvention::ALL {
        let key = render(camera(eye0(), target0(), conv, W, H), conv);
        let out = run(&key, &key, &TcrrOptions::default(), None, 1);
        let mut reflective = 0;
        for i in 0..out.offsets.len() {
            if key.spec[i] > 0.0 {
                reflective += 1;
                assert_eq!(out.offsets[i], [0.0, 0.0], "{conv:?} {i}");
                assert_eq!(out.mask[i], MASK_REUSED, "{conv:?} {i}");
                assert_eq!(out.color[i], key.color[i], "{conv:?} {i}");
            } else {
                assert_eq!(out.mask[i], MASK_NONE);
            }
        }
        assert_eq!(out.warp.retrace, 0);
        assert_eq!(out.warp.reused, reflective);
        assert_eq!(out.shift.magnified, 0);
    }
}

#[test]
fn rotation_only_keeps_zero_offsets_and_matches_the_truth() {
    // Reflections depend on the eye position only: turning the camera
    // leaves every match where it was; warping does the rest.
    let conv = DepthConvention::ReversedZ;
    let key = render(camera(eye0(), target0(), conv, W, H), conv);
    let cur = render(
        camera(eye0(), target0() + Vec3::new(0.6, -0.2, 0.0), conv, W, H),
        conv,
    );
    let out = run(&key, &cur, &TcrrOptions::default(), None, 1);
    for i in 0..out.offsets.len() {
        if key.spec[i] > 0.0 {
            assert_eq!(out.offsets[i], [0.0, 0.0]);
        }
    }
    let (err, n) = mean_err(&cur, &out.color, &out.mask);
    assert!(n > 1500, "{n}");
    assert!(err < 1e-3, "{err}");
}

#[test]
fn retrace_contrast_trades_re_tracing_for_error() {
    let conv = DepthConvention::Linear;
    let key = render(camera(eye0(), target0(), conv, W, H), conv);
    let cur = render(
        camera(eye0() + Vec3::new(0.4, 0.1, -0.3), target0(), conv, W, H),
        conv,
    );
    let mut last: Option<(u32, f64, Vec<u8>)> = None;
    for limit in [f32::INFINITY, 0.2, 0.1, 0.05, 0.01] {
        let p = TcrrOptions {
            retrace_contrast: limit,
            ..TcrrOptions::default()
        };
        let out = run(&key, &cur, &p, None, 1);
        let (err, _) = mean_err(&cur, &out.color, &out.mask);
        if let Some((retrace, prev_err, prev_mask)) = &last {
            // A lower limit only adds re-traced pixels (the others keep
            // their mask and color), and the reused ones get closer to
            // the truth.
            assert!(out.warp.retrace >= *retrace, "{limit}");
            for (a, b) in out.mask.iter().zip(prev_mask) {
                assert!(a == b || (*a == MASK_RETRACE && *b == MASK_REUSED));
            }
            assert!(err <= *prev_err + 1e-9, "{limit}: {err} vs {prev_err}");
        }
        last = Some((out.warp.retrace, err, out.mask));
    }
    let (retrace_inf, err_inf) = {
        let p = TcrrOptions {
            retrace_contrast: f32::INFINITY,
            ..TcrrOptions::default()
        };
        let out = run(&key, &cur, &p, None, 1);
        (out.warp.retrace, mean_err(&cur, &out.color, &out.mask).0)
    };
    let (retrace, err, _) = last.unwrap();
    assert!(retrace > retrace_inf && err < err_inf, "{err} {err_inf}");
}

#[test]
fn translation_tcrr_is_far_closer_to_the_truth_than_naive_warping() {
    for conv in DepthConvention::ALL {
        let key = render(camera(eye0(), target0(), conv, W, H), conv);
        let eye = eye0() + Vec3::new(0.4, 0.1, -0.3);
        let cur = render(camera(eye, target0(), conv, W, H), conv);
        let p = TcrrOptions::default();
        let out = run(&key, &cur, &p, None, 1);
        let (e_tcrr, n_tcrr) = mean_err(&cur, &out.color, &out.mask);
        let (nc, nm) = naive(&key, &cur, &p);
        let (e_naive, n_naive) = mean_err(&cur, &nc, &nm);
        // TCRR re-traces the reflection edges that moved; naive warping
        // reuses (wrongly) almost everything.
        assert!(n_tcrr * 2 > n_naive, "{n_tcrr} {n_naive}");
        assert!(e_tcrr * 5.0 < e_naive, "{conv:?}: {e_tcrr} vs {e_naive}");
        assert!(e_tcrr < 5e-3, "{conv:?}: {e_tcrr}");
        // Every reflective pixel is either reused or listed for re-tracing.
        let cov = ImageView::try_new(&out.mask, W, H, W).unwrap();
        let mut list = vec![0u32; retrace_count(&cov)];
        let n = try_retrace_list(&mut list, &cov).unwrap();
        assert_eq!(n as u32, out.warp.retrace);
        let brute: Vec<u32> = (0..out.mask.len() as u32)
            .filter(|&i| out.mask[i as usize] == MASK_RETRACE)
            .collect();
        assert_eq!(list, brute);
        assert_eq!(
            out.warp.reused + out.warp.retrace,
            cur.spec.iter().filter(|&&s| s > 0.0).count() as u32
        );
    }
}

#[test]
fn grazing_views_of_the_floor_converge() {
    let conv = DepthConvention::ReversedZ;
    let e0 = Vec3::new(0.0, 0.12, 3.0);
    let t = Vec3::new(0.0, 0.05, -5.0);
    let key = render(camera(e0, t, conv, W, H), conv);
    let e1 = e0 + Vec3::new(0.05, 0.01, -0.05);
    let cur = render(camera(e1, t, conv, W, H), conv);
    let out = run(&key, &cur, &TcrrOptions::default(), None, 1);
    assert!(out.search.reflective > 400);
    assert!(
        out.search.matched * 10 > out.search.reflective * 8,
        "{:?}",
        out.search
    );
    let (err, n) = mean_err(&cur, &out.color, &out.mask);
    assert!(n > 400 && err < 0.01, "{n} {err}");
}

#[test]
fn moving_toward_the_reflector_magnifies_and_the_threshold_discards() {
    let conv = DepthConvention::Linear;
    let key = render(camera(eye0(), target0(), conv, W, H), conv);
    // Toward the floor and forward: reflections spread apart on the key
    // frame's grid.
    let eye = Vec3::new(0.2, 0.5, 2.0);
    let cur = render(camera(eye, target0(), conv, W, H), conv);
    let loose = run(&key, &cur, &TcrrOptions::default(), None, 1);
    let tight = run(
        &key,
        &cur,
        &TcrrOptions {
            magnification: 1.0,
            ..TcrrOptions::default()
        },
        None,
        1,
    );
    assert!(tight.shift.magnified > 100, "{:?}", tight.shift);
    assert!(tight.shift.magnified > loose.shift.magnified);
    assert!(tight.warp.retrace > loose.warp.retrace);
    let (err, _) = mean_err(&cur, &loose.color, &loose.mask);
    assert!(err < 0.01, "{err}");
}

// --------------------------------------------------------------- shifting

#[test]
fn shifting_an_affine_offset_field_interpolates_exactly() {
    // Offsets o(s) = A s + b move the grid by an affine map; colors that
    // are affine in the source position are then exactly the affine
    // function of the preimage at every covered pixel center.
    let conv = DepthConvention::Linear;
    let mut key = render(camera(eye0(), target0(), conv, W, H), conv);
    let (w, h) = key.size();
    let a = [[0.12f64, 0.05], [-0.04, 0.08]];
    let b = [1.3f64, -0.7];
    let col = |sx: f64, sy: f64| [0.01 * sx + 0.2, 0.02 * sy - 0.1, 0.003 * (sx + sy)];
    let mut offsets = vec![INVALID_OFFSET; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (sx, sy) = (x as f64 + 0.5, y as f64 + 0.5);
            key.color[i] = col(sx, sy).map(|c| c as f32);
            key.spec[i] = 0.5;
            key.normal[i] = [0.0, 0.0, 1.0];
            key.dist[i] = 1.0;
            key.depth[i] = 5.0;
            offsets[i] = [
                (a[0][0] * sx + a[0][1] * sy + b[0]) as f32,
                (a[1][0] * sx + a[1][1] * sy + b[1]) as f32,
            ];
        }
    }
    let p = TcrrOptions::default();
    let n = (w * h) as usize;
    let (mut c, mut d, mut v) = (vec![[0.0; 3]; n], vec![0.0; n], vec![0u8; n]);
    let stats = tcrr::try_shift(
        &mut ImageViewMut::try_new(&mut c, w, h, w).unwrap(),
        &mut ImageViewMut::try_new(&mut d, w, h, w).unwrap(),
        &mut ImageViewMut::try_new(&mut v, w, h, w).unwrap(),
        &key.buffers(),
        &ImageView::try_new(&offsets, w, h, w).unwrap(),
        &p,
    )
    .unwrap();
    assert_eq!(stats.magnified, 0);
    // The map p = (I + A) s + b and its inverse.
    let m = [[1.0 + a[0][0], a[0][1]], [a[1][0], 1.0 + a[1][1]]];
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let (px, py) = (x as f64 + 0.5 - b[0], y as f64 + 0.5 - b[1]);
            let sx = (m[1][1] * px - m[0][1] * py) / det;
            let sy = (-m[1][0] * px + m[0][0] * py) / det;
            let i = (y * w + x) as usize;
            let interior = sx > 0.5 + 1e-3
                && sy > 0.5 + 1e-3
                && sx < w as f64 - 0.5 - 1e-3
                && sy < h as f64 - 0.5 - 1e-3;
            let outside = sx < 0.5 - 1e-3
                || sy < 0.5 - 1e-3
                || sx > w as f64 - 0.5 + 1e-3
                || sy > h as f64 - 0.5 + 1e-3;
            if interior {
                assert_eq!(v[i], 1, "({x},{y}) preimage ({sx},{sy})");
                let want = col(sx, sy);
                for k in 0..3 {
                    assert!((f64::from(c[i][k]) - want[k]).abs() < 1e-5, "{x},{y}");
                }
                assert!((f64::from(d[i]) - 6.0).abs() < 1e-4);
                checked += 1;
            } else if outside {
                assert_eq!(v[i], 0, "({x},{y})");
            }
        }
    }
    assert!(checked > 3000, "{checked}");
}

#[test]
fn shifting_depth_test_keeps_the_shorter_reflected_path() {
    let conv = DepthConvention::Linear;
    for near_left in [true, false] {
        let mut key = render(camera(eye0(), target0(), conv, W, H), conv);
        let (w, h) = key.size();
        let n = (w * h) as usize;
        let mut offsets = vec![[0.0f32; 2]; n];
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let left = x < w / 2;
                key.spec[i] = 1.0;
                key.normal[i] = [0.0, 0.0, 1.0];
                key.depth[i] = 5.0;
                key.color[i] = if left {
                    [1.0, 0.0, 0.0]
                } else {
                    [0.0, 0.0, 1.0]
                };
                key.dist[i] = if left == near_left { 1.0 } else { 10.0 };
                if !left {
                    offsets[i] = [-6.0, 0.0];
                }
            }
        }
        let (mut c, mut d, mut v) = (vec![[0.0; 3]; n], vec![0.0; n], vec![0u8; n]);
        tcrr::try_shift(
            &mut ImageViewMut::try_new(&mut c, w, h, w).unwrap(),
            &mut ImageViewMut::try_new(&mut d, w, h, w).unwrap(),
            &mut ImageViewMut::try_new(&mut v, w, h, w).unwrap(),
            &key.buffers(),
            &ImageView::try_new(&offsets, w, h, w).unwrap(),
            &TcrrOptions::default(),
        )
        .unwrap();
        // Columns w/2-6 .. w/2-2 are covered by both halves.
        for y in 1..h - 1 {
            for x in w / 2 - 5..w / 2 - 2 {
                let i = (y * w + x) as usize;
                let want = if near_left {
                    [1.0, 0.0, 0.0]
                } else {
                    [0.0, 0.0, 1.0]
                };
                assert_eq!(c[i], want, "({x},{y}) near_left={near_left}");
            }
        }
        // The cut between the halves (reflected discontinuity) leaves no
        // stretched triangle across it: columns w/2-2 .. w/2-1 hold only
        // the near color or nothing from a rubber sheet.
        assert!(c.iter().all(|p| p[1] == 0.0));
    }
}

// ------------------------------------------------------ banding and errors

#[test]
fn banded_passes_equal_the_whole_image() {
    let conv = DepthConvention::ZeroToOne;
    let key = render(camera(eye0(), target0(), conv, W, H), conv);
    let cur = render(
        camera(eye0() + Vec3::new(-0.3, 0.2, 0.1), target0(), conv, W, H),
        conv,
    );
    let p = TcrrOptions::default();
    let whole = run(&key, &cur, &p, None, 1);
    for bands in [2, 5] {
        let banded = run(&key, &cur, &p, None, bands);
        assert_eq!(banded.offsets, whole.offsets);
        assert_eq!(banded.inter, whole.inter);
        assert_eq!(banded.coverage, whole.coverage);
        assert_eq!(banded.color, whole.color);
        assert_eq!(banded.mask, whole.mask);
        assert_eq!(banded.search, whole.search);
        assert_eq!(banded.warp, whole.warp);
    }
}

#[test]
fn prepared_surfels_give_identical_results() {
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let key = render(camera(eye0(), target0(), conv, W, H), conv);
        let cur = render(
            camera(eye0() + Vec3::new(0.25, -0.15, -0.2), target0(), conv, W, H),
            conv,
        );
        for subpixel in [true, false] {
            let p = TcrrOptions {
                subpixel,
                ..TcrrOptions::default()
            };
            let plain = run(&key, &cur, &p, None, 1);
            let fast = run_with(&key, &cur, &p, None, 3, true);
            assert_eq!(fast.offsets, plain.offsets, "{conv:?}");
            assert_eq!(fast.inter, plain.inter, "{conv:?}");
            assert_eq!(fast.coverage, plain.coverage, "{conv:?}");
            assert_eq!(fast.color, plain.color, "{conv:?}");
            assert_eq!(fast.mask, plain.mask, "{conv:?}");
            assert_eq!(fast.search, plain.search, "{conv:?}");
            assert_eq!(fast.warp, plain.warp, "{conv:?}");
            assert!(plain.warp.reused > 0);
        }
    }
    // A surfel image of the wrong size is refused.
    let key = render(
        camera(eye0(), target0(), DepthConvention::Linear, W, H),
        DepthConvention::Linear,
    );
    let small = vec![tcrr::Surfel::default(); 4];
    let v = ImageView::try_new(&small, 2, 2, 2).unwrap();
    assert_eq!(
        key.buffers().try_with_surfels(v).err(),
        Some(Error::InvalidArgument)
    );
    let mut small = vec![tcrr::Surfel::default(); 4];
    let mut v = ImageViewMut::try_new(&mut small, 2, 2, 2).unwrap();
    assert_eq!(
        tcrr::try_prepare(&mut v, &key.buffers()),
        Err(Error::InvalidArgument)
    );
    assert_eq!(small, vec![tcrr::Surfel::default(); 4]);
}

#[test]
fn bad_input_is_refused_and_outputs_stay_untouched() {
    let conv = DepthConvention::Linear;
    let key = render(camera(eye0(), target0(), conv, W, H), conv);
    let b = key.buffers();
    let p = TcrrOptions::default();
    // Buffers of mismatched size.
    let small = vec![0.0f32; 4];
    assert_eq!(
        ReflectionBuffers::try_new(
            key.cam,
            conv,
            ImageView::try_new(&small, 2, 2, 2).unwrap(),
            ImageView::try_new(&key.normal, W, H, W).unwrap(),
            ImageView::try_new(&key.spec, W, H, W).unwrap(),
            ImageView::try_new(&key.color, W, H, W).unwrap(),
            ImageView::try_new(&key.dist, W, H, W).unwrap(),
        )
        .unwrap_err(),
        Error::InvalidArgument
    );
    let mut offsets = vec![[3.0f32, 4.0]; (W * H) as usize];
    let bad_params = [
        TcrrOptions {
            max_iterations: 0,
            ..p
        },
        TcrrOptions {
            magnification: f32::NAN,
            ..p
        },
        TcrrOptions {
            magnification: 0.5,
            ..p
        },
        TcrrOptions {
            discontinuity: -1.0,
            ..p
        },
        TcrrOptions {
            reflected_discontinuity: f32::INFINITY,
            ..p
        },
        TcrrOptions {
            retrace_contrast: f32::NAN,
            ..p
        },
        TcrrOptions {
            retrace_contrast: 0.0,
            ..p
        },
    ];
    for bp in bad_params {
        let mut o = ImageViewMut::try_new(&mut offsets, W, H, W).unwrap();
        assert_eq!(
            tcrr::try_search(&mut o, &b, Vec3::ONE, &bp),
            Err(Error::InvalidArgument)
        );
    }
    {
        let mut o = ImageViewMut::try_new(&mut offsets, W, H, W).unwrap();
        assert_eq!(
            tcrr::try_search(&mut o, &b, Vec3::new(f32::NAN, 0.0, 0.0), &p),
            Err(Error::InvalidArgument)
        );
        let mut o2 = ImageViewMut::try_new(&mut offsets, W - 1, H, W).unwrap();
        assert_eq!(
            tcrr::try_search(&mut o2, &b, Vec3::ONE, &p),
            Err(Error::InvalidArgument)
        );
    }
    assert!(offsets.iter().all(|&o| o == [3.0, 4.0]));
    // Shift with outputs owning different bands.
    let n = (W * H) as usize;
    let (mut c, mut d, mut v) = (vec![[2.0f32; 3]; n], vec![2.0f32; n], vec![2u8; n]);
    {
        let cv = ImageViewMut::try_new(&mut c, W, H, W).unwrap();
        let (mut c1, _) = cv.try_split_at_row(10).map_err(|e| e.0).unwrap();
        let r = tcrr::try_shift(
            &mut c1,
            &mut ImageViewMut::try_new(&mut d, W, H, W).unwrap(),
            &mut ImageViewMut::try_new(&mut v, W, H, W).unwrap(),
            &b,
            &ImageView::try_new(&offsets, W, H, W).unwrap(),
            &p,
        );
        assert_eq!(r, Err(Error::InvalidArgument));
    }
    assert!(c.iter().all(|&x| x == [2.0; 3]) && d.iter().all(|&x| x == 2.0));
    assert!(v.iter().all(|&x| x == 2));
    // Warp with a coverage of the wrong size.
    let cov = vec![1u8; 4];
    {
        let r = tcrr::try_warp(
            &mut ImageViewMut::try_new(&mut c, W, H, W).unwrap(),
            &mut ImageViewMut::try_new(&mut v, W, H, W).unwrap(),
            &key.current(),
            &b,
            &ImageView::try_new(&key.color, W, H, W).unwrap(),
            &ImageView::try_new(&key.dist, W, H, W).unwrap(),
            &ImageView::try_new(&cov, 2, 2, 2).unwrap(),
            &p,
        );
        assert_eq!(r, Err(Error::InvalidArgument));
    }
    assert!(c.iter().all(|&x| x == [2.0; 3]) && v.iter().all(|&x| x == 2));
    // A re-trace list that is too short.
    let mask = vec![MASK_RETRACE; 6];
    let mv = ImageView::try_new(&mask, 3, 2, 3).unwrap();
    let mut list = [77u32; 5];
    assert_eq!(
        try_retrace_list(&mut list, &mv),
        Err(Error::InsufficientSize)
    );
    assert_eq!(list, [77; 5]);
    // Key-frame policy range.
    assert!(KeyFramePolicy::try_new(f32::NAN).is_err());
    assert!(KeyFramePolicy::try_new(1.5).is_err());
    assert!(KeyFramePolicy::try_new(-0.1).is_err());
}

#[test]
fn key_frame_policy_and_fresnel_weights() {
    let p = KeyFramePolicy::try_new(0.3).unwrap();
    assert!(!p.needs_key_frame(30, 100));
    assert!(p.needs_key_frame(31, 100));
    assert!(!p.needs_key_frame(0, 0));
    assert!(KeyFramePolicy::try_new(0.0)
        .unwrap()
        .needs_key_frame(1, 100));
    assert!(!KeyFramePolicy::try_new(1.0)
        .unwrap()
        .needs_key_frame(100, 100));
    // Schlick: f at normal incidence, 1 at grazing, monotone in between.
    for f in [0.04f32, 0.5, 0.9] {
        assert_eq!(fresnel_weight(f, 1.0, Fresnel::Schlick), f);
        assert_eq!(fresnel_weight(f, 0.0, Fresnel::Schlick), 1.0);
        assert_eq!(fresnel_weight(f, 0.3, Fresnel::Off), f);
        let c = 0.4f64;
        let want = f64::from(f) + (1.0 - f64::from(f)) * (1.0 - c).powi(5);
        assert!((f64::from(fresnel_weight(f, 0.4, Fresnel::Schlick)) - want).abs() < 1e-6);
    }
    assert_eq!(fresnel_weight(f32::NAN, 0.5, Fresnel::Schlick), 0.0);
    assert_eq!(fresnel_weight(0.0, 0.5, Fresnel::Schlick), 0.0);
    // compose: diffuse off the reflectors, the weighted mix on them.
    let conv = DepthConvention::Linear;
    let key = render(camera(eye0(), target0(), conv, W, H), conv);
    let n = (W * H) as usize;
    let (diffuse, refl, out) = compose_constant(&key);
    for i in 0..n {
        if key.spec[i] > 0.0 {
            let want = Vec3::from_array(diffuse[i]) * 0.1 + Vec3::from_array(refl[i]) * 0.9;
            assert!((Vec3::from_array(out[i]) - want).abs().max_element() < 1e-6);
        } else {
            assert_eq!(out[i], diffuse[i]);
        }
    }
}

/// Composes `key` with a constant diffuse (0.2, 0.4, 0.6) and reflection
/// (1, 0, 0.5), Fresnel off: returns (diffuse, reflection, output).
type Rgb = Vec<[f32; 3]>;
fn compose_constant(key: &Frame) -> (Rgb, Rgb, Rgb) {
    let n = (W * H) as usize;
    let diffuse = vec![[0.2f32, 0.4, 0.6]; n];
    let refl = vec![[1.0f32, 0.0, 0.5]; n];
    let mut out = vec![[0.0f32; 3]; n];
    try_compose(
        &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
        &ImageView::try_new(&diffuse, W, H, W).unwrap(),
        &ImageView::try_new(&refl, W, H, W).unwrap(),
        &ImageView::try_new(&key.normal, W, H, W).unwrap(),
        &key.current(),
        Fresnel::Off,
    )
    .unwrap();
    (diffuse, refl, out)
}

/// Fuzz finding F9: a background pixel (the cleared depth, at the far
/// plane) with a positive specular factor holds no surface, so compose
/// leaves it diffuse, in every convention.
#[test]
fn compose_leaves_far_plane_pixels_diffuse() {
    for conv in DepthConvention::ALL {
        let mut key = render(camera(eye0(), target0(), conv, W, H), conv);
        // The first row shows the background: cleared to the far plane,
        // with a specular factor left over.
        let background: Vec<usize> = (0..W as usize).collect();
        for &i in &background {
            key.depth[i] = key.cam.encode_depth(key.cam.far(), conv);
            key.spec[i] = 1.0;
        }
        let (diffuse, _, out) = compose_constant(&key);
        for &i in &background {
            assert_eq!(
                out[i], diffuse[i],
                "{conv:?}: background pixel {i} composed"
            );
        }
    }
}

#[test]
fn frame_bytes_count_every_caller_buffer() {
    use core::mem::size_of;
    // Reflection buffers, surfels, offsets, shift's three images, the
    // warped color, the mask and the re-trace list, one pixel each.
    let per_pixel = 4 + 12 + 4 + 12 + 4 + size_of::<tcrr::Surfel>() + 8 + (12 + 4 + 1) + 12 + 1 + 4;
    assert_eq!(tcrr::BYTES_PER_PIXEL, per_pixel);
    assert_eq!(tcrr::BYTES_PER_PIXEL, 110);
    assert_eq!(tcrr::try_frame_bytes(640, 360), Ok(640 * 360 * 110));
    assert_eq!(tcrr::try_frame_bytes(0, 360), Err(Error::InvalidArgument));
    assert_eq!(tcrr::try_frame_bytes(640, 0), Err(Error::InvalidArgument));
    if usize::BITS == 64 {
        assert_eq!(
            tcrr::try_frame_bytes(u32::MAX, u32::MAX),
            Err(Error::InvalidArgument)
        );
    }
}
