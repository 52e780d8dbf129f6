//! Per-pixel stepping (seed 003 Sec. 3.4) against analytic f64 oracles:
//! depth images of planes, spheres and boxes rendered per pixel center in
//! f64, random rays whose true first intersection is computed in f64, and
//! the stiff cases (planar rays, grazing rays, extreme scales and sizes,
//! hostile input, every miss reason).
#![cfg(feature = "depth-image")]

use glam::{DMat4, DVec3, Vec2, Vec3};
use proptest::prelude::*;

mod common;
use refl_core::{
    try_step, try_step_rays, Camera, DepthConvention, DepthImage, Error, ImageView, Miss, Ray,
    StepOptions, Thickness, Trace,
};

// ---------------------------------------------------------------------------
// Analytic scenes in f64.

/// A solid: the ray is inside it on `[t_in, t_out]`.
#[derive(Clone, Copy, Debug)]
enum Shape {
    /// The half-space `n . p + d < 0`.
    HalfSpace {
        n: DVec3,
        d: f64,
    },
    Sphere {
        c: DVec3,
        r: f64,
    },
    Cuboid {
        lo: DVec3,
        hi: DVec3,
    },
}

impl Shape {
    fn scaled(self, k: f64) -> Self {
        match self {
            Shape::HalfSpace { n, d } => Shape::HalfSpace { n, d: d * k },
            Shape::Sphere { c, r } => Shape::Sphere { c: c * k, r: r * k },
            Shape::Cuboid { lo, hi } => Shape::Cuboid {
                lo: lo * k,
                hi: hi * k,
            },
        }
    }

    /// The parameter interval of the line `o + t d` inside the solid.
    fn interval(&self, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        match *self {
            Shape::HalfSpace { n, d: off } => {
                let s0 = n.dot(o) + off;
                let sd = n.dot(d);
                if sd == 0.0 {
                    return (s0 < 0.0).then_some((f64::NEG_INFINITY, f64::INFINITY));
                }
                let t = -s0 / sd;
                if sd < 0.0 {
                    Some((t, f64::INFINITY))
                } else {
                    Some((f64::NEG_INFINITY, t))
                }
            }
            Shape::Sphere { c, r } => {
                let oc = o - c;
                let a = d.dot(d);
                let b = oc.dot(d);
                let cc = oc.dot(oc) - r * r;
                let disc = b * b - a * cc;
                if disc < 0.0 {
                    return None;
                }
                let q = disc.sqrt();
                Some(((-b - q) / a, (-b + q) / a))
            }
            Shape::Cuboid { lo, hi } => {
                let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
                for i in 0..3 {
                    if d[i] == 0.0 {
                        if o[i] < lo[i] || o[i] > hi[i] {
                            return None;
                        }
                        continue;
                    }
                    let (a, b) = ((lo[i] - o[i]) / d[i], (hi[i] - o[i]) / d[i]);
                    t0 = t0.max(a.min(b));
                    t1 = t1.min(a.max(b));
                }
                (t0 <= t1).then_some((t0, t1))
            }
        }
    }
}

/// First entry into a solid at `t > 0` along `o + t d` (the origin lies
/// outside every solid): `(t_in, t_out, shape index)`.
fn first_hit(scene: &[Shape], o: DVec3, d: DVec3) -> Option<(f64, f64, usize)> {
    let mut best: Option<(f64, f64, usize)> = None;
    for (i, s) in scene.iter().enumerate() {
        if let Some((t0, t1)) = s.interval(o, d) {
            if t0 > 0.0 && t0 <= t1 && best.is_none_or(|b| t0 < b.0) {
                best = Some((t0, t1, i));
            }
        }
    }
    best
}

/// A box room seen from inside: five half-spaces (convex, so every point
/// outside it is hidden from an eye inside it).
fn room() -> Vec<Shape> {
    vec![
        Shape::HalfSpace {
            n: DVec3::Y,
            d: 0.0,
        },
        Shape::HalfSpace {
            n: DVec3::Z,
            d: 12.0,
        },
        Shape::HalfSpace {
            n: DVec3::X,
            d: 7.0,
        },
        Shape::HalfSpace {
            n: -DVec3::X,
            d: 6.0,
        },
        Shape::HalfSpace {
            n: -DVec3::Y,
            d: 6.0,
        },
        Shape::HalfSpace {
            n: DVec3::new(0.3, 0.2, 1.0).normalize(),
            d: 15.0,
        },
    ]
}

/// Closed solids over an empty background: a floor slab, a sphere, boxes.
fn objects() -> Vec<Shape> {
    vec![
        Shape::Cuboid {
            lo: DVec3::new(-12.0, -1.0, -25.0),
            hi: DVec3::new(12.0, 0.0, 2.0),
        },
        Shape::Sphere {
            c: DVec3::new(1.2, 1.0, -3.0),
            r: 1.0,
        },
        Shape::Cuboid {
            lo: DVec3::new(-3.0, 0.0, -7.0),
            hi: DVec3::new(-1.0, 2.5, -5.0),
        },
        Shape::Cuboid {
            lo: DVec3::new(2.0, 0.0, -12.0),
            hi: DVec3::new(5.0, 4.0, -10.0),
        },
        Shape::Sphere {
            c: DVec3::new(-4.0, 3.0, -14.0),
            r: 2.0,
        },
    ]
}

// ---------------------------------------------------------------------------
// Cameras, depth images and projection in f64.

const NEAR: f32 = 0.1;

fn camera(scale: f32, far: f32, w: u32, h: u32) -> Camera {
    Camera::try_look_at(
        Vec3::new(0.3, 2.2, 5.0) * scale,
        Vec3::new(-0.5, 0.8, -6.0) * scale,
        Vec3::Y,
        55f32.to_radians(),
        NEAR * scale,
        far * scale,
        w,
        h,
    )
    .unwrap()
}

/// f64 mirror of the camera's projection.
struct Cam64 {
    view: DMat4,
    inv: DMat4,
    tx: f64,
    ty: f64,
    w: f64,
    h: f64,
    near: f64,
    far: f64,
}

impl Cam64 {
    fn new(c: &Camera) -> Self {
        let ty = (f64::from(c.fov_y()) * 0.5).tan();
        Self {
            view: c.view().as_dmat4(),
            inv: c.inverse_view().as_dmat4(),
            tx: ty * f64::from(c.width()) / f64::from(c.height()),
            ty,
            w: f64::from(c.width()),
            h: f64::from(c.height()),
            near: f64::from(c.near()),
            far: f64::from(c.far()),
        }
    }

    fn eye(&self) -> DVec3 {
        self.inv.w_axis.truncate()
    }

    /// World direction through pixel position `(px, py)` whose parameter is
    /// linear depth (view z = -1).
    fn dir(&self, px: f64, py: f64) -> DVec3 {
        let v = DVec3::new(
            (2.0 * px / self.w - 1.0) * self.tx,
            (1.0 - 2.0 * py / self.h) * self.ty,
            -1.0,
        );
        self.inv.transform_vector3(v)
    }

    /// `(px, py, linear z)` of a world point (z may be <= 0).
    fn project(&self, p: DVec3) -> (f64, f64, f64) {
        let v = self.view.transform_point3(p);
        let z = -v.z;
        (
            (v.x / (z * self.tx) + 1.0) * 0.5 * self.w,
            (1.0 - v.y / (z * self.ty)) * 0.5 * self.h,
            z,
        )
    }

    /// Front surface seen through `(px, py)`: linear depth, back depth and
    /// shape, if any (not clipped by the far plane).
    fn surface(&self, scene: &[Shape], px: f64, py: f64) -> Option<(f64, f64, usize)> {
        first_hit(scene, self.eye(), self.dir(px, py))
    }
}

fn encode64(z: f64, n: f64, f: f64, c: DepthConvention) -> f64 {
    match c {
        DepthConvention::Linear => z,
        DepthConvention::ZeroToOne if f.is_infinite() => 1.0 - n / z,
        DepthConvention::ZeroToOne => f * (z - n) / (z * (f - n)),
        DepthConvention::ReversedZ if f.is_infinite() => n / z,
        DepthConvention::ReversedZ => n * (f - z) / (z * (f - n)),
    }
}

/// The convention's "nothing rendered" value.
fn clear(c: DepthConvention) -> f32 {
    match c {
        DepthConvention::Linear => f32::NAN,
        DepthConvention::ZeroToOne => 1.0,
        DepthConvention::ReversedZ => 0.0,
    }
}

/// Front and back depth images and the shape id per texel, rendered per
/// pixel center in f64.
struct Rendered {
    front: Vec<f32>,
    back: Vec<f32>,
    id: Vec<i32>,
}

fn render(cam: &Camera, scene: &[Shape], conv: DepthConvention) -> Rendered {
    let c = Cam64::new(cam);
    let (w, h) = (cam.width() as usize, cam.height() as usize);
    let mut r = Rendered {
        front: vec![clear(conv); w * h],
        back: vec![clear(conv); w * h],
        id: vec![-1; w * h],
    };
    for y in 0..h {
        for x in 0..w {
            if let Some((z, zb, i)) = c.surface(scene, x as f64 + 0.5, y as f64 + 0.5) {
                if z < c.far {
                    r.front[y * w + x] = encode64(z, c.near, c.far, conv) as f32;
                    if zb < c.far {
                        r.back[y * w + x] = encode64(zb, c.near, c.far, conv) as f32;
                    }
                    r.id[y * w + x] = i as i32;
                }
            }
        }
    }
    r
}

// ---------------------------------------------------------------------------
// The f64 oracle of a ray.

/// What the f64 oracle says about a ray.
#[derive(Clone, Copy, Debug)]
enum Truth {
    /// The true first hit lies in the image and every point of the ray
    /// before it is visible from the camera: the kernel must find it.
    /// `interior`: the 3x3 texels around the hit all see the hit's shape.
    Visible {
        t: f64,
        px: f64,
        py: f64,
        interior: bool,
    },
    /// No hit on the clipped segment, which is visible all the way: the
    /// kernel must miss.
    ClearMiss,
    /// Anything else (passes behind geometry, hit outside the image ...).
    Other,
}

/// The clipped parameter interval of the ray in f64 (Liang-Barsky against
/// the frustum).
fn clip64(c: &Cam64, o: DVec3, d: DVec3, t_max: f64) -> Option<(f64, f64)> {
    let vo = c.view.transform_point3(o);
    let vd = c.view.transform_vector3(d);
    let (z0, dz) = (-vo.z, -vd.z);
    let mut lo = 0.0f64;
    let mut hi = t_max;
    let mut cut = |a: f64, b: f64| {
        if b > 0.0 {
            lo = lo.max(-a / b);
        } else if b < 0.0 {
            hi = hi.min(a / -b);
        } else if a < 0.0 {
            hi = f64::NEG_INFINITY;
        }
    };
    cut(z0 - c.near, dz);
    if c.far.is_finite() {
        cut(c.far - z0, -dz);
    }
    // |x| <= z tx, |y| <= z ty.
    cut(z0 * c.tx - vo.x, dz * c.tx - vd.x);
    cut(z0 * c.tx + vo.x, dz * c.tx + vd.x);
    cut(z0 * c.ty - vo.y, dz * c.ty - vd.y);
    cut(z0 * c.ty + vo.y, dz * c.ty + vd.y);
    (lo <= hi).then_some((lo, hi))
}

/// `true` if world point `p` is not behind the front surface seen through
/// its own pixel position.
fn visible(c: &Cam64, scene: &[Shape], p: DVec3) -> bool {
    let (px, py, z) = c.project(p);
    match c.surface(scene, px, py) {
        Some((zs, _, _)) => z <= zs * (1.0 + 1e-9),
        None => true,
    }
}

fn truth(c: &Cam64, scene: &[Shape], ray: &Ray, t_max: f32) -> Truth {
    let o = ray.origin.as_dvec3();
    let d = ray.dir.as_dvec3();
    let Some((ta, tb)) = clip64(c, o, d, f64::from(t_max)) else {
        return Truth::Other;
    };
    let tb_fin = if tb.is_finite() { tb } else { 1e6 };
    let hit = first_hit(scene, o, d).filter(|h| h.0 <= f64::from(t_max));
    let t_end = match hit {
        Some((t, _, _)) if t >= ta && t <= tb_fin => t,
        Some((t, _, _)) if t < ta => return Truth::Other,
        _ => tb_fin,
    };
    // Sample the path [ta, t_end] about every quarter pixel (and densely
    // near both ends in t).
    let pa = c.project(o + d * ta);
    let pb = c.project(o + d * t_end);
    let len = ((pb.0 - pa.0).powi(2) + (pb.1 - pa.1).powi(2)).sqrt();
    let n = ((len * 4.0) as usize).clamp(16, 20_000);
    for i in 0..n {
        // Uniform in screen space: t from the projective map.
        let s = i as f64 / n as f64;
        let u = s * pa.2 / ((1.0 - s) * pb.2 + s * pa.2);
        let t = ta + (t_end - ta) * u;
        if !visible(c, scene, o + d * t) {
            return Truth::Other;
        }
    }
    match hit {
        Some((t, _, id)) if t <= tb_fin => {
            let (px, py, _) = c.project(o + d * t);
            if px < 1.0 || py < 1.0 || px > c.w - 1.0 || py > c.h - 1.0 {
                return Truth::Other;
            }
            let interior = (-1..=1).all(|dy: i32| {
                (-1..=1).all(|dx: i32| {
                    let x = px.floor() + 0.5 + f64::from(dx);
                    let y = py.floor() + 0.5 + f64::from(dy);
                    c.surface(scene, x, y)
                        .is_some_and(|s| s.2 == id && s.0 < c.far)
                })
            });
            Truth::Visible {
                t,
                px,
                py,
                interior,
            }
        }
        _ => {
            if tb.is_finite() || c.far.is_infinite() {
                Truth::ClearMiss
            } else {
                Truth::Other
            }
        }
    }
}

/// A small deterministic PRNG (splitmix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn dir(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                2.0 * self.unit() - 1.0,
                2.0 * self.unit() - 1.0,
                2.0 * self.unit() - 1.0,
            );
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

/// A random ray starting at a visible point in front of the surface seen
/// through a random pixel position, in a random direction.
fn random_ray(rng: &mut Rng, c: &Cam64, scene: &[Shape], scale: f64) -> (Ray, f32) {
    let px = rng.unit() * c.w;
    let py = rng.unit() * c.h;
    let zs = c
        .surface(scene, px, py)
        .map_or(30.0 * scale, |s| s.0)
        .min(c.far);
    let z = c.near + (0.02 + 0.96 * rng.unit()) * (zs - c.near);
    let o = c.eye() + c.dir(px, py) * z;
    let d = rng.dir();
    let t_max = if rng.unit() < 0.5 {
        f32::INFINITY
    } else {
        ((0.5 + 20.0 * rng.unit()) * scale) as f32
    };
    (
        Ray {
            origin: o.as_vec3(),
            dir: d.as_vec3().normalize(),
        },
        t_max,
    )
}

// ---------------------------------------------------------------------------
// Statistics against the geometric oracle.

#[derive(Default, Debug)]
struct Stats {
    /// Visible true hits, and those the kernel found within one texel.
    visible: u32,
    near: u32,
    /// Found farther than a texel away but within one pixel of the surface
    /// (grazing rays, where the position along the ray is ill-conditioned).
    on_surface: u32,
    /// The same for hits whose 3x3 texel neighborhood sees one shape.
    interior: u32,
    interior_ok: u32,
    /// Rays that miss on a visible path, and kernel hits on them (false),
    /// of which within one pixel of a surface (grazing near-misses).
    clear_miss: u32,
    false_hits: u32,
    false_on_surface: u32,
    /// Results identical to stride 1's (same variant, texel and t).
    same_as_unit: u32,
    total: u32,
    /// Sum of |t - t_true| / t_true over the hits within one texel.
    sum_t_err: f64,
}

impl Stats {
    fn ok(&self) -> u32 {
        self.near + self.on_surface
    }
}

/// Chebyshev distance in texels between the hit and the oracle's pixel.
fn texel_dist(pixel: Vec2, px: f64, py: f64) -> i64 {
    let dx = (pixel.x.floor() as i64 - px.floor() as i64).abs();
    let dy = (pixel.y.floor() as i64 - py.floor() as i64).abs();
    dx.max(dy)
}

/// `true` if world point `p` lies within one pixel of the (thick) surface:
/// its depth is between the smallest front depth and the largest back
/// depth seen through the 3x3 pixel positions around its projection (back =
/// front + `th`, or the solid's exit when `th` is NaN).
fn on_surface(c: &Cam64, scene: &[Shape], p: DVec3, th: f64) -> bool {
    let (px, py, z) = c.project(p);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for dy in [-1.0, 0.0, 1.0] {
        for dx in [-1.0, 0.0, 1.0] {
            if let Some((zs, zb, _)) = c.surface(scene, px + dx, py + dy) {
                lo = lo.min(zs);
                hi = hi.max(zs).max(if th.is_nan() { zb } else { zs + th });
            }
        }
    }
    z >= lo * (1.0 - 1e-4) && z <= hi * (1.0 + 1e-4)
}

/// `true` if some point of the ray (within `t_max` and the frustum) that
/// projects within one texel of the oracle's hit pixel `(hx, hy)` lies in the
/// shell `[front, front + th]` of the texel it projects into, with `front`
/// the depth *stored* in `image` (ReversedZ). The f64 oracle's visible hit
/// is the analytic surface's; the image holds only its samples at texel
/// centers, so where the ray ends inside one texel's depth variation the
/// image has nothing to hit and the oracle's hit cannot be asked for.
#[allow(clippy::too_many_arguments)]
fn image_shell_near_hit(
    cam: &Camera,
    c: &Cam64,
    image: &[f32],
    ray: &Ray,
    t_max: f32,
    hx: f64,
    hy: f64,
    th: f64,
) -> bool {
    let o = ray.origin.as_dvec3();
    let d = ray.dir.as_dvec3();
    let Some((ta, tb)) = clip64(c, o, d, f64::from(t_max)) else {
        return false;
    };
    let tb = if tb.is_finite() { tb } else { 1e6 };
    let (w, h) = (cam.width() as i64, cam.height() as i64);
    let (hx, hy) = (hx.floor() as i64, hy.floor() as i64);
    let pa = c.project(o + d * ta);
    let pb = c.project(o + d * tb);
    let len = ((pb.0 - pa.0).powi(2) + (pb.1 - pa.1).powi(2)).sqrt();
    let n = ((len * 64.0) as usize).clamp(256, 200_000);
    (0..=n).any(|i| {
        let s = i as f64 / n as f64;
        let u = s * pa.2 / ((1.0 - s) * pb.2 + s * pa.2);
        let (px, py, z) = c.project(o + d * (ta + (tb - ta) * u));
        let (x, y) = (px.floor() as i64, py.floor() as i64);
        if (x - hx).abs().max((y - hy).abs()) > 1 || x < 0 || y < 0 || x >= w || y >= h {
            return false;
        }
        let zf =
            f64::from(cam.decode_depth(image[(y * w + x) as usize], DepthConvention::ReversedZ));
        zf > 0.0 && z >= zf * (1.0 - 1e-6) && z <= (zf + th) * (1.0 + 1e-6)
    })
}

/// `ray.at(t)` projects into the reported texel (to rounding) and the hit
/// lies in the image.
fn assert_consistent(cam: &Camera, ray: &Ray, tr: &Trace) {
    if let Some(h) = tr.hit() {
        let q = cam
            .project(ray.at(h.t))
            .expect("hit point in front of the eye");
        let d = (q.truncate() - h.pixel).abs().max_element();
        let tol = 2e-2 + 1e-5 * h.pixel.abs().max_element();
        assert!(
            d <= tol,
            "ray.at(t) projects {d} px from the hit pixel: {tr:?}"
        );
        assert!(
            (q.z - h.depth).abs() <= 1e-3 * h.depth,
            "depth {} vs projected {}",
            h.depth,
            q.z
        );
        assert!(h.pixel.x >= 0.0 && h.pixel.y >= 0.0);
        assert!(h.pixel.x < cam.width() as f32 && h.pixel.y < cam.height() as f32);
    }
}

fn same_result(a: &Trace, b: &Trace) -> bool {
    match (a, b) {
        (Trace::Hit(x), Trace::Hit(y)) => x.pixel.floor() == y.pixel.floor() && x.t == y.t,
        (Trace::Miss { reason: r, .. }, Trace::Miss { reason: q, .. }) => r == q,
        _ => false,
    }
}

struct Config {
    scene: Vec<Shape>,
    far: f32,
    back_faces: bool,
    thickness: f32,
    rays: usize,
    seed: u64,
}

const STRIDES: [u32; 3] = [1, 4, 8];

/// Runs `cfg.rays` random rays through every convention and strides 1, 4
/// and 8, returning the statistics per stride (summed over conventions).
fn run(cfg: &Config) -> [Stats; 3] {
    let (w, h) = (160, 120);
    let cam = camera(1.0, cfg.far, w, h);
    let c = Cam64::new(&cam);
    let mut rng = Rng(cfg.seed);
    let rays: Vec<(Ray, f32, Truth)> = (0..cfg.rays)
        .map(|_| {
            let (r, tm) = random_ray(&mut rng, &c, &cfg.scene, 1.0);
            (r, tm, truth(&c, &cfg.scene, &r, tm))
        })
        .collect();
    let mut stats: [Stats; 3] = Default::default();
    for conv in DepthConvention::ALL {
        let img = render(&cam, &cfg.scene, conv);
        let view = ImageView::try_new(&img.front, w, h, w).unwrap();
        let back = ImageView::try_new(&img.back, w, h, w).unwrap();
        let di = DepthImage::try_new(view, cam, conv).unwrap();
        let th = if cfg.back_faces {
            Thickness::BackFaces(back)
        } else {
            Thickness::Constant(cfg.thickness)
        };
        let th64 = if cfg.back_faces {
            f64::NAN
        } else {
            f64::from(cfg.thickness)
        };
        let unit: Vec<Trace> = rays
            .iter()
            .map(|(r, tm, _)| try_step(&di, th, *r, *tm, StepOptions::default()).unwrap())
            .collect();
        for (k, stride) in STRIDES.into_iter().enumerate() {
            let opts = StepOptions {
                stride,
                ..StepOptions::default()
            };
            let st = &mut stats[k];
            for ((ray, tm, t), u) in rays.iter().zip(&unit) {
                let tr = try_step(&di, th, *ray, *tm, opts).unwrap();
                assert_consistent(&cam, ray, &tr);
                st.total += 1;
                st.same_as_unit += u32::from(same_result(&tr, u));
                let hit_on_surface = |tr: &Trace| {
                    tr.hit().is_some_and(|h| {
                        let p = ray.origin.as_dvec3() + ray.dir.as_dvec3() * f64::from(h.t);
                        on_surface(&c, &cfg.scene, p, th64)
                    })
                };
                match *t {
                    Truth::Visible {
                        t: t_true,
                        px,
                        py,
                        interior,
                    } => {
                        st.visible += 1;
                        st.interior += u32::from(interior);
                        let near = tr.hit().is_some_and(|h| texel_dist(h.pixel, px, py) <= 1);
                        if let (true, Some(h)) = (near, tr.hit()) {
                            let dt = (f64::from(h.t) - t_true).abs() / t_true.max(1e-3);
                            st.sum_t_err += dt;
                        }
                        let ok = near || hit_on_surface(&tr);
                        st.near += u32::from(near);
                        st.on_surface += u32::from(ok && !near);
                        st.interior_ok += u32::from(interior && ok);
                    }
                    Truth::ClearMiss => {
                        st.clear_miss += 1;
                        if tr.hit().is_some() {
                            st.false_hits += 1;
                            st.false_on_surface += u32::from(hit_on_surface(&tr));
                        }
                    }
                    Truth::Other => {}
                }
            }
        }
    }
    stats
}

fn pct(a: u32, b: u32) -> f64 {
    100.0 * f64::from(a) / f64::from(b.max(1))
}

fn report(name: &str, stats: &[Stats; 3]) {
    for (s, stride) in stats.iter().zip(STRIDES) {
        eprintln!(
            "{name} stride {stride}: visible hits found {:.2}% ({} within 1 texel + {} within 1 px \
             of the surface, of {}), interior {:.2}% of {}; false hits {}/{} ({} within 1 px of \
             a surface); same as stride 1: {:.2}%; mean |dt|/t {:.2e}",
            pct(s.ok(), s.visible),
            s.near,
            s.on_surface,
            s.visible,
            pct(s.interior_ok, s.interior),
            s.interior,
            s.false_hits,
            s.clear_miss,
            s.false_on_surface,
            pct(s.same_as_unit, s.total),
            s.sum_t_err / f64::from(s.near.max(1)),
        );
    }
}

/// Asserts the measured rates (per stride 1, 4, 8: the share of visible
/// true hits found within one texel or one pixel of the surface), that
/// every false hit is within one pixel of a surface, and that strides 4
/// and 8 give stride 1's result on at least 99% of the rays.
fn check(name: &str, stats: &[Stats; 3], min_found: [f64; 3]) {
    report(name, stats);
    for ((s, min), stride) in stats.iter().zip(min_found).zip(STRIDES) {
        assert!(
            s.visible >= 300,
            "{name}: too few visible hits ({})",
            s.visible
        );
        let found = pct(s.ok(), s.visible);
        assert!(
            found >= min,
            "{name} stride {stride}: found {found:.2}% < {min}%"
        );
        assert_eq!(
            s.false_hits, s.false_on_surface,
            "{name} stride {stride}: a false hit away from every surface"
        );
        assert!(
            pct(s.same_as_unit, s.total) >= 99.0,
            "{name} stride {stride}"
        );
    }
}

#[test]
fn oracle_room_planes_constant_thickness() {
    for (far, th) in [
        (60.0, 0.5),
        (f32::INFINITY, 0.5),
        (60.0, 2.0),
        (f32::INFINITY, f32::INFINITY),
    ] {
        let stats = run(&Config {
            scene: room(),
            far,
            back_faces: false,
            thickness: th,
            rays: 1500,
            seed: 1,
        });
        // A 0.5 shell is thinner than the depth step between texels of the
        // grazing floor near the horizon: rays meeting it against the slope
        // pass behind it (the thickness contract); 2.0 and inf resolve all.
        let min = if th < 1.0 { 96.5 } else { 99.5 };
        check(&format!("room far={far} th={th}"), &stats, [min; 3]);
    }
}

#[test]
fn oracle_objects_back_faces() {
    for far in [60.0, f32::INFINITY] {
        let stats = run(&Config {
            scene: objects(),
            far,
            back_faces: true,
            thickness: 0.0,
            rays: 1500,
            seed: 2,
        });
        check(
            &format!("objects back-faces far={far}"),
            &stats,
            [99.5, 99.0, 99.0],
        );
    }
}

#[test]
fn oracle_objects_constant_thickness() {
    for (far, th) in [(60.0, 0.3), (f32::INFINITY, 1.0)] {
        let stats = run(&Config {
            scene: objects(),
            far,
            back_faces: false,
            thickness: th,
            rays: 1500,
            seed: 3,
        });
        let min = if th < 0.5 { 89.0 } else { 96.0 };
        check(&format!("objects far={far} th={th}"), &stats, [min; 3]);
    }
}

// ---------------------------------------------------------------------------
// The hit contract of refl_core::trace, by brute force in f64.

fn decode64(d: f64, n: f64, f: f64, c: DepthConvention) -> f64 {
    match c {
        DepthConvention::Linear => d,
        DepthConvention::ZeroToOne if f.is_infinite() => n / (1.0 - d),
        DepthConvention::ZeroToOne => n * f / (f - d * (f - n)),
        DepthConvention::ReversedZ if f.is_infinite() => n / d,
        DepthConvention::ReversedZ => n * f / (n + d * (f - n)),
    }
}

/// The first `t` at which the ray's depth lies in `[front, back]` of the
/// texel whose column it is in, over every texel of the image (no walk):
/// `(t, x, y)`. Texel columns, the frustum and the depth interval are all
/// half-spaces `alpha + beta t >= 0` in f64.
fn contract_oracle(
    c: &Cam64,
    front: &[f32],
    back: Option<&[f32]>,
    th: f64,
    conv: DepthConvention,
    ray: &Ray,
    t_max: f32,
) -> Option<(f64, u32, u32)> {
    let (w, h) = (c.w as u32, c.h as u32);
    let o = ray.origin.as_dvec3();
    let d = ray.dir.as_dvec3();
    let (ta, tb) = clip64(c, o, d, f64::from(t_max))?;
    let tb = tb.min(1e7);
    let vo = c.view.transform_point3(o);
    let vd = c.view.transform_vector3(d);
    let (z0, dz) = (-vo.z, -vd.z);
    let surface = |z: f64| z > 0.0 && z < c.far;
    let mut best: Option<(f64, u32, u32)> = None;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let zf = decode64(f64::from(front[i]), c.near, c.far, conv);
            if !surface(zf) {
                continue;
            }
            let zb = match back {
                Some(b) => {
                    let z = decode64(f64::from(b[i]), c.near, c.far, conv);
                    if surface(z) && z > zf {
                        z
                    } else {
                        zf
                    }
                }
                None => zf + th,
            };
            let (mut lo, mut hi) = (ta, tb);
            let mut cut = |a: f64, b: f64| {
                if b > 0.0 {
                    lo = lo.max(-a / b);
                } else if b < 0.0 {
                    hi = hi.min(a / -b);
                } else if a < 0.0 {
                    hi = f64::NEG_INFINITY;
                }
            };
            let ax0 = (2.0 * f64::from(x) / c.w - 1.0) * c.tx;
            let ax1 = (2.0 * f64::from(x + 1) / c.w - 1.0) * c.tx;
            let by0 = (1.0 - 2.0 * f64::from(y) / c.h) * c.ty;
            let by1 = (1.0 - 2.0 * f64::from(y + 1) / c.h) * c.ty;
            cut(vo.x - z0 * ax0, vd.x - dz * ax0);
            cut(z0 * ax1 - vo.x, dz * ax1 - vd.x);
            cut(z0 * by0 - vo.y, dz * by0 - vd.y);
            cut(vo.y - z0 * by1, vd.y - dz * by1);
            cut(z0 - zf, dz);
            if zb.is_finite() {
                cut(zb - z0, -dz);
            }
            if lo <= hi && best.is_none_or(|b: (f64, u32, u32)| lo < b.0) {
                best = Some((lo, x, y));
            }
        }
    }
    best
}

/// The f32 kernel against the brute-force f64 evaluation of the same hit
/// contract: every hit and miss agrees, up to ties within rounding.
#[test]
fn kernel_matches_brute_force_contract_oracle() {
    let (w, h) = (64u32, 48u32);
    for (scene, back_faces, th, seed) in [
        (room(), false, 0.5f32, 11u64),
        (objects(), true, 0.0, 12),
        (objects(), false, 0.3, 13),
    ] {
        for far in [60.0, f32::INFINITY] {
            let cam = camera(1.0, far, w, h);
            let c = Cam64::new(&cam);
            let mut rng = Rng(seed);
            let rays: Vec<(Ray, f32)> = (0..400)
                .map(|_| random_ray(&mut rng, &c, &scene, 1.0))
                .collect();
            for conv in DepthConvention::ALL {
                let img = render(&cam, &scene, conv);
                let view = ImageView::try_new(&img.front, w, h, w).unwrap();
                let bview = ImageView::try_new(&img.back, w, h, w).unwrap();
                let di = DepthImage::try_new(view, cam, conv).unwrap();
                let thick = if back_faces {
                    Thickness::BackFaces(bview)
                } else {
                    Thickness::Constant(th)
                };
                let (mut agree, mut ties, mut hits) = (0, 0, 0);
                for (ray, tm) in &rays {
                    let tr = try_step(&di, thick, *ray, *tm, StepOptions::default()).unwrap();
                    let want = contract_oracle(
                        &c,
                        &img.front,
                        back_faces.then_some(&img.back[..]),
                        f64::from(th),
                        conv,
                        ray,
                        *tm,
                    );
                    let ok = match (tr.hit(), want) {
                        (None, None) => true,
                        (Some(hk), Some((t, x, y))) => {
                            let same = hk.pixel.floor() == Vec2::new(x as f32, y as f32);
                            let dt = (f64::from(hk.t) - t).abs();
                            let close = dt <= 1e-3 * (1.0 + t);
                            let adjacent = texel_dist(hk.pixel, f64::from(x), f64::from(y)) <= 1;
                            ties += u32::from(!same && close && adjacent);
                            close && adjacent
                        }
                        _ => false,
                    };
                    if !ok {
                        eprintln!("{conv:?} far={far}: {ray:?} t_max={tm}\n  kernel {tr:?}\n  oracle {want:?}");
                    }
                    agree += u32::from(ok);
                    hits += u32::from(want.is_some());
                }
                eprintln!(
                    "contract oracle {conv:?} far={far} back={back_faces}: {agree}/{} agree ({hits} \
                     oracle hits, {ties} ties on a texel boundary)",
                    rays.len()
                );
                assert!(agree as usize >= rays.len() - 2, "{agree}/{}", rays.len());
            }
        }
    }
}

// ---------------------------------------------------------------------------
// Stiff cases.

/// A depth image holding stored value `v` in every texel.
fn filled(w: u32, h: u32, v: f32) -> Vec<f32> {
    vec![v; (w * h) as usize]
}

/// A wall at constant linear depth `z` (a plane parallel to the image).
fn wall(cam: &Camera, conv: DepthConvention, z: f32) -> Vec<f32> {
    filled(cam.width(), cam.height(), cam.encode_depth(z, conv))
}

fn di<'a>(cam: &Camera, data: &'a [f32], conv: DepthConvention) -> DepthImage<'a> {
    let v = ImageView::try_new(data, cam.width(), cam.height(), cam.width()).unwrap();
    DepthImage::try_new(v, *cam, conv).unwrap()
}

fn step(img: &DepthImage<'_>, th: f32, ray: Ray, t_max: f32) -> Trace {
    try_step(
        img,
        Thickness::Constant(th),
        ray,
        t_max,
        StepOptions::default(),
    )
    .unwrap()
}

fn miss_reason(t: &Trace) -> Option<Miss> {
    match t {
        Trace::Miss { reason, .. } => Some(*reason),
        Trace::Hit(_) => None,
    }
}

/// The world point at pixel position `p` and linear depth `z`.
fn at_depth(cam: &Camera, p: Vec2, z: f32) -> Vec3 {
    cam.unproject(p, z, DepthConvention::Linear)
}

fn ray_between(a: Vec3, b: Vec3) -> Ray {
    let d = (b.as_dvec3() - a.as_dvec3()).normalize();
    Ray {
        origin: a,
        dir: d.as_vec3(),
    }
}

#[test]
fn planar_rays_through_the_eye_resolve_with_one_lookup() {
    let scene = room();
    for far in [60.0, f32::INFINITY] {
        let cam = camera(1.0, far, 64, 48);
        let c = Cam64::new(&cam);
        for conv in DepthConvention::ALL {
            let img = render(&cam, &scene, conv);
            let d = di(&cam, &img.front, conv);
            for (x, y) in [(0u32, 0u32), (31, 23), (63, 47), (10, 40), (50, 5)] {
                let center = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let primary = cam.primary_ray(center);
                let (t_true, _, _) =
                    first_hit(&scene, primary.origin.as_dvec3(), primary.dir.as_dvec3()).unwrap();
                // From the eye, from between eye and near plane, from midway.
                for start in [0.0, 0.5 * NEAR, 0.4 * t_true as f32] {
                    let ray = Ray {
                        origin: primary.at(start),
                        dir: primary.dir,
                    };
                    let tr = step(&d, 0.5, ray, f32::INFINITY);
                    let h = tr
                        .hit()
                        .unwrap_or_else(|| panic!("{conv:?} ({x},{y}): {tr:?}"));
                    assert_eq!(h.work.steps, 1, "{tr:?}");
                    assert_eq!(h.work.fetches, 1, "{tr:?}");
                    assert_eq!(h.pixel.floor(), Vec2::new(x as f32, y as f32));
                    let want = t_true - f64::from(start);
                    assert!(
                        (f64::from(h.t) - want).abs() <= 2e-4 * t_true,
                        "{conv:?} ({x},{y}) start {start}: t {} vs {want}",
                        h.t
                    );
                }
                // Along the view line toward the eye, from behind the
                // surface: within the shell (hit at once) and beyond it
                // (enters through the back face, z_front + thickness).
                let zf = c.project(primary.at(t_true as f32).as_dvec3()).2 as f32;
                let back_dir = -primary.dir;
                let inside = Ray {
                    origin: at_depth(&cam, center, zf + 0.25),
                    dir: back_dir,
                };
                let tr = step(&d, 0.5, inside, f32::INFINITY);
                assert_eq!(
                    tr.hit().map(|h| (h.t, h.work.steps)),
                    Some((0.0, 1)),
                    "{tr:?}"
                );
                let behind = Ray {
                    origin: at_depth(&cam, center, zf + 3.0),
                    dir: back_dir,
                };
                let tr = step(&d, 0.5, behind, f32::INFINITY);
                let h = tr.hit().expect("enters through the back face");
                assert!((h.depth - (zf + 0.5)).abs() <= 1e-3 * zf, "{tr:?}");
                assert_eq!(h.work.steps, 1);
                // Moving away from behind the shell: passes behind, one step.
                let away = Ray {
                    origin: behind.origin,
                    dir: primary.dir,
                };
                let tr = step(&d, 0.5, away, f32::INFINITY);
                assert_eq!(miss_reason(&tr), Some(Miss::BehindGeometry), "{tr:?}");
                assert_eq!(tr.work().steps, 1);
            }
        }
    }
}

#[test]
fn planar_ray_into_an_empty_texel_misses_in_one_step() {
    let cam = camera(1.0, f32::INFINITY, 32, 24);
    for conv in DepthConvention::ALL {
        let data = filled(32, 24, clear(conv));
        let d = di(&cam, &data, conv);
        let ray = cam.primary_ray(Vec2::new(7.5, 9.5));
        let tr = step(&d, 1.0, ray, f32::INFINITY);
        assert_eq!(miss_reason(&tr), Some(Miss::EndOfRay), "{conv:?} {tr:?}");
        assert_eq!((tr.work().steps, tr.work().fetches), (1, 1));
        // NaN is "no surface" in every convention.
        let nan = filled(32, 24, f32::NAN);
        let tr = step(&di(&cam, &nan, conv), f32::INFINITY, ray, f32::INFINITY);
        assert_eq!(miss_reason(&tr), Some(Miss::EndOfRay));
    }
}

#[test]
fn sub_pixel_projections_touch_at_most_a_few_texels() {
    let cam = camera(1.0, 100.0, 64, 48);
    for conv in DepthConvention::ALL {
        let data = wall(&cam, conv, 10.0);
        let d = di(&cam, &data, conv);
        // Nearly through the eye: from depth 2 at one pixel position to
        // depth 12 a fraction of a pixel away.
        for (dx, dy) in [(0.3f32, 0.0f32), (0.0, -0.4), (0.2, 0.2), (1e-4, 1e-4)] {
            let a = at_depth(&cam, Vec2::new(20.4, 30.6), 2.0);
            let b = at_depth(&cam, Vec2::new(20.4 + dx, 30.6 + dy), 12.0);
            let ray = ray_between(a, b);
            let tr = step(&d, 0.5, ray, f32::INFINITY);
            let h = tr.hit().unwrap_or_else(|| panic!("{tr:?}"));
            assert!(h.work.steps <= 2, "{tr:?}");
            assert!((h.depth - 10.0).abs() <= 1e-3, "{tr:?}");
            let want = cam.project(ray.at(h.t)).unwrap();
            assert!((want.truncate() - h.pixel).length() < 1e-3);
        }
    }
}

#[test]
fn rays_parallel_to_the_image_plane() {
    let cam = camera(1.0, 100.0, 64, 48);
    let right = cam.inverse_view().x_axis.truncate().normalize();
    let forward = -cam.inverse_view().z_axis.truncate().normalize();
    for conv in DepthConvention::ALL {
        let data = wall(&cam, conv, 10.0);
        let d = di(&cam, &data, conv);
        // In front of the wall by 0.1: never within the shell, leaves the
        // image after crossing it.
        let o = at_depth(&cam, Vec2::new(3.5, 20.5), 9.9);
        let tr = step(
            &d,
            0.5,
            Ray {
                origin: o,
                dir: right,
            },
            f32::INFINITY,
        );
        assert_eq!(miss_reason(&tr), Some(Miss::LeftImage), "{tr:?}");
        assert!(tr.work().steps >= 60, "{tr:?}");
        // Inside the shell: hit at t = 0.
        let o = at_depth(&cam, Vec2::new(3.5, 20.5), 10.2);
        let tr = step(
            &d,
            0.5,
            Ray {
                origin: o,
                dir: right,
            },
            f32::INFINITY,
        );
        assert_eq!(tr.hit().map(|h| h.t), Some(0.0));
        // Nearly parallel: depth grows by 1e-3 per unit; hits at t = 100
        // (f64 oracle: (10 - 9.9) / 1e-3), if still in the image.
        let o = at_depth(&cam, Vec2::new(0.5, 20.5), 9.99);
        let dir = (right.as_dvec3() + forward.as_dvec3() * 1e-3).normalize();
        let ray = Ray {
            origin: o,
            dir: dir.as_vec3(),
        };
        let t_true = 0.01 / (forward.as_dvec3().dot(dir));
        let tr = step(&d, 0.5, ray, f32::INFINITY);
        let h = tr.hit().unwrap_or_else(|| panic!("{tr:?}"));
        assert!(
            (f64::from(h.t) - t_true).abs() <= 1e-2 * t_true,
            "t {} vs {t_true}",
            h.t
        );
        assert_consistent(&cam, &ray, &tr);
    }
}

/// Rays skimming the floor (1e-3 above it, heading down at a small angle)
/// while the camera also sees the floor at a grazing angle. Every hit lies
/// within a texel of the true hit or a pixel of the surface; what is found
/// depends on how far below the floor the ray gets before leaving the
/// image, relative to the floor's depth step between texel centers.
#[test]
fn grazing_rays_along_the_floor() {
    let scene = room();
    let cam = camera(1.0, f32::INFINITY, 160, 120);
    let c = Cam64::new(&cam);
    for (lo, hi, min_found) in [(0.01f64, 1.0f64, 99.0f64), (1.0, 10.0, 100.0)] {
        let mut rng = Rng(7);
        for conv in DepthConvention::ALL {
            let img = render(&cam, &scene, conv);
            let d = di(&cam, &img.front, conv);
            let (mut visible, mut found) = (0, 0);
            for _ in 0..300 {
                let o = DVec3::new(-4.0 + 8.0 * rng.unit(), 1e-3, -1.0 - 8.0 * rng.unit());
                let angle = (lo + (hi - lo) * rng.unit()).to_radians();
                let az = std::f64::consts::TAU * rng.unit();
                let dir = DVec3::new(az.cos() * angle.cos(), -angle.sin(), az.sin() * angle.cos());
                let ray = Ray {
                    origin: o.as_vec3(),
                    dir: dir.as_vec3(),
                };
                let tr = step(&d, 2.0, ray, f32::INFINITY);
                assert_consistent(&cam, &ray, &tr);
                let truth = truth(&c, &scene, &ray, f32::INFINITY);
                if let Some(h) = tr.hit() {
                    let p = o + dir * f64::from(h.t);
                    let near = match truth {
                        Truth::Visible { px, py, .. } => texel_dist(h.pixel, px, py) <= 1,
                        _ => false,
                    };
                    assert!(
                        near || on_surface(&c, &scene, p, 2.0),
                        "{ray:?}: {tr:?} {truth:?}"
                    );
                }
                if let Truth::Visible { .. } = truth {
                    visible += 1;
                    found += u32::from(tr.hit().is_some());
                }
            }
            eprintln!("grazing {lo}..{hi} deg {conv:?}: {found}/{visible} visible hits found");
            assert!(pct(found, visible) >= min_found);
        }
    }
}

#[test]
fn rays_toward_the_camera() {
    let cam = camera(1.0, 100.0, 64, 48);
    let eye = cam.eye();
    for conv in DepthConvention::ALL {
        // A near wall at depth 4 in the left half, far wall at 20 elsewhere.
        let mut data = wall(&cam, conv, 20.0);
        for y in 0..48 {
            for x in 0..32 {
                data[y * 64 + x] = cam.encode_depth(4.0, conv);
            }
        }
        let d = di(&cam, &data, conv);
        // From in front of the far wall (right half) toward the eye region
        // of the left half: enters the near wall's shell from behind.
        let o = at_depth(&cam, Vec2::new(50.5, 20.5), 19.0);
        let target = at_depth(&cam, Vec2::new(10.5, 24.5), 3.0);
        let ray = ray_between(o, target);
        let tr = step(&d, 1.0, ray, f32::INFINITY);
        let h = tr.hit().unwrap_or_else(|| panic!("{tr:?}"));
        assert!(
            (h.depth - 5.0).abs() < 1e-3,
            "enters through the back at 5: {tr:?}"
        );
        assert!(h.pixel.x < 32.0);
        assert_consistent(&cam, &ray, &tr);
        // In front of everything, toward the eye: leaves through the near
        // plane.
        let o = at_depth(&cam, Vec2::new(40.5, 20.5), 15.0);
        let ray = ray_between(o, eye);
        let tr = step(&d, 1.0, ray, f32::INFINITY);
        assert_eq!(miss_reason(&tr), Some(Miss::LeftImage), "{tr:?}");
    }
}

#[test]
fn origins_on_in_front_of_and_behind_the_near_plane() {
    let cam = camera(1.0, 100.0, 64, 48);
    let fwd = -cam.inverse_view().z_axis.truncate().normalize();
    for conv in DepthConvention::ALL {
        let data = wall(&cam, conv, 10.0);
        let d = di(&cam, &data, conv);
        let target = at_depth(&cam, Vec2::new(40.5, 12.5), 10.0);
        let on_near = at_depth(&cam, Vec2::new(20.25, 30.75), NEAR);
        let ray = ray_between(on_near, target);
        let reference = step(&d, 0.5, ray, f32::INFINITY);
        let h0 = *reference.hit().unwrap();
        assert_eq!(h0.pixel.floor(), Vec2::new(40.0, 12.0), "{reference:?}");
        // The same line started before the near plane and behind the eye
        // plane: clipped to the near plane, the same texel, t offset.
        for back in [0.05f32, 1.0, 30.0] {
            let o = ray.origin - ray.dir * back;
            let tr = step(&d, 0.5, Ray { origin: o, ..ray }, f32::INFINITY);
            let h = tr.hit().unwrap_or_else(|| panic!("{tr:?}"));
            assert_eq!(h.pixel.floor(), h0.pixel.floor());
            assert!(
                (h.t - back - h0.t).abs() <= 1e-4 * (h.t + 1.0),
                "{} vs {}",
                h.t,
                h0.t
            );
        }
        // Behind the eye, looking away from the scene: nothing to see.
        let o = cam.eye() - fwd * 2.0;
        let tr = step(
            &d,
            0.5,
            Ray {
                origin: o,
                dir: -fwd,
            },
            f32::INFINITY,
        );
        assert_eq!(miss_reason(&tr), Some(Miss::DegenerateProjection));
        assert_eq!(tr.work(), Default::default());
    }
}

#[test]
fn stored_depth_exactly_zero_and_one() {
    for far in [100.0f32, f32::INFINITY] {
        let cam = camera(1.0, far, 16, 12);
        let fwd = -cam.inverse_view().z_axis.truncate().normalize();
        for conv in DepthConvention::ALL {
            for v in [0.0f32, 1.0] {
                let data = filled(16, 12, v);
                let d = di(&cam, &data, conv);
                let z = cam.decode_depth(v, conv);
                // From the near plane (off the eye line) straight ahead.
                let o = at_depth(&cam, Vec2::new(5.3, 6.7), NEAR);
                let tr = step(
                    &d,
                    0.5,
                    Ray {
                        origin: o,
                        dir: fwd,
                    },
                    f32::INFINITY,
                );
                let surface = z > 0.0 && z < far;
                match tr.hit() {
                    Some(h) => {
                        assert!(surface, "{conv:?} v={v}: {tr:?}");
                        // Surfaces at the near plane are hit at once.
                        let want = (z - NEAR).max(0.0);
                        assert!(
                            (h.t - want).abs() <= 1e-4 * (1.0 + z),
                            "{conv:?} {v}: {tr:?}"
                        );
                    }
                    None => assert!(!surface, "{conv:?} v={v} z={z}: {tr:?}"),
                }
            }
            // The near-plane values are surfaces; the far-plane values not.
            let near_v = cam.encode_depth(NEAR, conv);
            let far_v = if far.is_finite() {
                cam.encode_depth(far, conv)
            } else {
                clear(conv)
            };
            assert!(step(
                &di(&cam, &filled(16, 12, near_v), conv),
                0.5,
                cam.primary_ray(Vec2::splat(3.5)),
                f32::INFINITY
            )
            .hit()
            .is_some());
            assert!(step(
                &di(&cam, &filled(16, 12, far_v), conv),
                f32::INFINITY,
                cam.primary_ray(Vec2::splat(3.5)),
                f32::INFINITY
            )
            .hit()
            .is_none());
        }
    }
}

#[test]
fn one_by_one_image() {
    let cam = Camera::try_look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 1.0, 0.1, 50.0, 1, 1).unwrap();
    for conv in DepthConvention::ALL {
        let data = wall(&cam, conv, 5.0);
        let d = di(&cam, &data, conv);
        let ray = ray_between(Vec3::new(0.01, 0.02, -1.0), Vec3::new(-0.2, 0.1, -7.0));
        let tr = step(&d, 0.5, ray, f32::INFINITY);
        let h = tr.hit().unwrap_or_else(|| panic!("{tr:?}"));
        assert_eq!(h.pixel.floor(), Vec2::ZERO);
        assert!((h.depth - 5.0).abs() < 1e-4);
        assert_consistent(&cam, &ray, &tr);
        // Sideways out of the single pixel.
        let ray = ray_between(Vec3::new(0.0, 0.0, -1.0), Vec3::new(3.0, 0.0, -1.5));
        assert_eq!(
            miss_reason(&step(&d, 0.5, ray, f32::INFINITY)),
            Some(Miss::LeftImage)
        );
    }
}

/// 16384 texels along one axis (a 16384 x 16384 image would need 1 GiB;
/// the coordinate range, the walk length and the f32 pixel positions are
/// the same, and `ImageView` indexes in `usize`, tested in image.rs).
#[test]
fn sixteen_thousand_pixels_along_either_axis() {
    for (w, h) in [(16384u32, 4u32), (4, 16384)] {
        // About 90 degrees along the long axis.
        let fov = 2.0 * (h as f32 / w as f32).min(1.0).atan();
        let cam = Camera::try_look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, fov, 0.1, f32::INFINITY, w, h)
            .unwrap();
        let c = Cam64::new(&cam);
        // A tilted plane: depth grows along the long axis.
        let scene = [Shape::HalfSpace {
            n: DVec3::new(0.3, 0.3, 1.0).normalize(),
            d: 6.0,
        }];
        for conv in DepthConvention::ALL {
            let img = render(&cam, &scene, conv);
            let d = di(&cam, &img.front, conv);
            assert!(d.linear_at(w - 1, h - 1).is_some(), "last texel readable");
            assert!(d.linear_at(w, h - 1).is_none() && d.linear_at(w - 1, h).is_none());
            let long = |a: f32| {
                if w > h {
                    Vec2::new(a, 1.5)
                } else {
                    Vec2::new(1.5, a)
                }
            };
            // From pixel 100 (in front of the plane) to the plane point seen
            // through pixel 16000.5.
            let target_px = long(16000.5);
            let dt = c.dir(f64::from(target_px.x), f64::from(target_px.y));
            let (t_hit, _, _) = first_hit(&scene, c.eye(), dt).unwrap();
            let target = (c.eye() + dt * t_hit).as_vec3();
            let zs = c.surface(&scene, 100.5, 1.5).map(|s| s.0).unwrap_or(1.0);
            let start_px = long(100.5);
            let o = at_depth(&cam, start_px, (0.5 * zs).max(0.2) as f32);
            let ray = ray_between(o, target);
            if let Truth::Visible { px, py, .. } = truth(&c, &scene, &ray, f32::INFINITY) {
                let tr = step(&d, 1.0, ray, f32::INFINITY);
                let hit = tr
                    .hit()
                    .unwrap_or_else(|| panic!("{w}x{h} {conv:?}: {tr:?}"));
                assert!(texel_dist(hit.pixel, px, py) <= 1, "{tr:?} vs ({px}, {py})");
                assert!(hit.work.steps >= 15_000, "{tr:?}");
                assert_consistent(&cam, &ray, &tr);
            } else {
                panic!("{w}x{h}: the test ray should see the plane");
            }
        }
    }
}

#[test]
fn hostile_input_is_rejected() {
    let cam = camera(1.0, 100.0, 16, 12);
    let data = wall(&cam, DepthConvention::Linear, 5.0);
    let d = di(&cam, &data, DepthConvention::Linear);
    let good = cam.primary_ray(Vec2::splat(4.5));
    let o = StepOptions::default();
    let th = Thickness::Constant(1.0);
    let bad_rays = [
        Ray {
            origin: Vec3::NAN,
            ..good
        },
        Ray {
            origin: Vec3::new(f32::INFINITY, 0.0, 0.0),
            ..good
        },
        Ray {
            dir: Vec3::NAN,
            ..good
        },
        Ray {
            dir: Vec3::new(f32::NEG_INFINITY, 0.0, 0.0),
            ..good
        },
        Ray {
            dir: Vec3::ZERO,
            ..good
        },
        Ray {
            dir: good.dir * 2.0,
            ..good
        },
    ];
    for r in bad_rays {
        assert_eq!(
            try_step(&d, th, r, 1.0, o),
            Err(Error::InvalidArgument),
            "{r:?}"
        );
    }
    for t_max in [f32::NAN, 0.0, -1.0, f32::NEG_INFINITY] {
        assert_eq!(
            try_step(&d, th, good, t_max, o),
            Err(Error::InvalidArgument)
        );
    }
    let no_stride = StepOptions { stride: 0, ..o };
    assert_eq!(
        try_step(&d, th, good, 1.0, no_stride),
        Err(Error::InvalidArgument)
    );
    for c in [f32::NAN, -1e-3, f32::NEG_INFINITY] {
        assert_eq!(
            try_step(&d, Thickness::Constant(c), good, 1.0, o),
            Err(Error::InvalidArgument)
        );
    }
    let small = [0f32; 4];
    let wrong = ImageView::try_new(&small, 2, 2, 2).unwrap();
    assert_eq!(
        try_step(&d, Thickness::BackFaces(wrong), good, 1.0, o),
        Err(Error::InvalidArgument)
    );
    // Huge but finite coordinates terminate with a result.
    let far_away = Ray {
        origin: Vec3::splat(3e38),
        dir: good.dir,
    };
    assert!(try_step(&d, th, far_away, f32::INFINITY, o).is_ok());
    let huge_t = try_step(&d, th, good, f32::MAX, o).unwrap();
    assert!(huge_t.hit().is_some());
}

#[test]
fn scaled_scenes_hit_the_same_texels() {
    let base = objects();
    let (w, h) = (96, 72);
    let mut rng = Rng(5);
    let cam1 = camera(1.0, f32::INFINITY, w, h);
    let c1 = Cam64::new(&cam1);
    let rays: Vec<(Ray, f32)> = (0..400)
        .map(|_| random_ray(&mut rng, &c1, &base, 1.0))
        .collect();
    for conv in DepthConvention::ALL {
        let img1 = render(&cam1, &base, conv);
        let bv1 = ImageView::try_new(&img1.back, w, h, w).unwrap();
        let d1 = di(&cam1, &img1.front, conv);
        for k in [1e-3f32, 1e4] {
            let scene: Vec<Shape> = base.iter().map(|s| s.scaled(f64::from(k))).collect();
            let cam = camera(k, f32::INFINITY, w, h);
            let img = render(&cam, &scene, conv);
            let bv = ImageView::try_new(&img.back, w, h, w).unwrap();
            let d = di(&cam, &img.front, conv);
            let (mut same, mut total) = (0, 0);
            for (r, tm) in &rays {
                let a = try_step(
                    &d1,
                    Thickness::BackFaces(bv1),
                    *r,
                    *tm,
                    StepOptions::default(),
                )
                .unwrap();
                let rs = Ray {
                    origin: r.origin * k,
                    dir: r.dir,
                };
                let b = try_step(
                    &d,
                    Thickness::BackFaces(bv),
                    rs,
                    *tm * k,
                    StepOptions::default(),
                )
                .unwrap();
                assert_consistent(&cam, &rs, &b);
                total += 1;
                match (a.hit(), b.hit()) {
                    (Some(x), Some(y)) => {
                        assert!(
                            texel_dist(y.pixel, f64::from(x.pixel.x), f64::from(x.pixel.y)) <= 1,
                            "{a:?} vs {b:?}"
                        );
                        same += u32::from(x.pixel.floor() == y.pixel.floor());
                    }
                    (None, None) => same += 1,
                    _ => eprintln!("scale {k} {conv:?}: {a:?} vs {b:?}"),
                }
            }
            eprintln!("scale {k} {conv:?}: {same}/{total} same texel or both miss");
            assert!(same * 100 >= total * 99, "{same}/{total}");
        }
    }
}

#[test]
fn max_steps_zero_and_one() {
    let cam = camera(1.0, 100.0, 64, 48);
    let data = wall(&cam, DepthConvention::ReversedZ, 10.0);
    let d = di(&cam, &data, DepthConvention::ReversedZ);
    let long = ray_between(
        at_depth(&cam, Vec2::new(2.5, 2.5), 1.0),
        at_depth(&cam, Vec2::new(60.5, 40.5), 10.0),
    );
    let planar = cam.primary_ray(Vec2::new(9.5, 9.5));
    for stride in [1, 4] {
        let opts = |max_steps| StepOptions { stride, max_steps };
        let tr = try_step(&d, Thickness::Constant(1.0), long, f32::INFINITY, opts(0)).unwrap();
        assert_eq!(miss_reason(&tr), Some(Miss::OutOfSteps));
        assert_eq!(tr.work(), Default::default());
        let tr = try_step(&d, Thickness::Constant(1.0), long, f32::INFINITY, opts(1)).unwrap();
        assert_eq!(miss_reason(&tr), Some(Miss::OutOfSteps));
        assert_eq!(tr.work().steps, 1);
        let tr = try_step(&d, Thickness::Constant(1.0), planar, f32::INFINITY, opts(1)).unwrap();
        assert!(tr.hit().is_some(), "{tr:?}");
        let tr = try_step(&d, Thickness::Constant(1.0), planar, f32::INFINITY, opts(0)).unwrap();
        assert_eq!(miss_reason(&tr), Some(Miss::OutOfSteps));
        // Enough steps: found.
        let tr = try_step(&d, Thickness::Constant(1.0), long, f32::INFINITY, opts(200)).unwrap();
        assert!(tr.hit().is_some(), "{tr:?}");
    }
}

#[test]
fn tiny_t_max() {
    let cam = camera(1.0, 100.0, 64, 48);
    for conv in DepthConvention::ALL {
        let data = wall(&cam, conv, 10.0);
        let d = di(&cam, &data, conv);
        let dir = cam.primary_ray(Vec2::new(30.5, 20.5)).dir;
        let o = at_depth(&cam, Vec2::new(11.5, 13.5), 9.0);
        let tr = step(&d, 0.5, Ray { origin: o, dir }, 1e-6);
        assert_eq!(miss_reason(&tr), Some(Miss::EndOfRay), "{tr:?}");
        assert_eq!(tr.work().steps, 1);
        let o = at_depth(&cam, Vec2::new(11.5, 13.5), 10.1);
        let tr = step(&d, 0.5, Ray { origin: o, dir }, f32::MIN_POSITIVE);
        assert_eq!(tr.hit().map(|h| h.t), Some(0.0), "{tr:?}");
    }
}

#[test]
fn miss_reasons() {
    let cam = camera(1.0, 100.0, 64, 48);
    let fwd = -cam.inverse_view().z_axis.truncate().normalize();
    let right = cam.inverse_view().x_axis.truncate().normalize();
    for conv in DepthConvention::ALL {
        // Far wall at 30, a thin occluder (depth 5) in texels x in [20, 28).
        let mut data = wall(&cam, conv, 30.0);
        for y in 0..48 {
            for x in 20..28 {
                data[y * 64 + x] = cam.encode_depth(5.0, conv);
            }
        }
        let d = di(&cam, &data, conv);
        let empty_data = filled(64, 48, clear(conv));
        let empty = di(&cam, &empty_data, conv);
        let o = at_depth(&cam, Vec2::new(10.5, 24.5), 8.0);

        // Sideways in front of the wall and behind the occluder's shell?
        // No: at depth 8 the ray is behind the occluder (5 + 0.5) while
        // crossing it, keeps marching, and leaves the image in front of
        // the wall.
        let tr = step(
            &d,
            0.5,
            Ray {
                origin: o,
                dir: right,
            },
            f32::INFINITY,
        );
        assert_eq!(miss_reason(&tr), Some(Miss::LeftImage), "{tr:?}");
        // Ends (t_max) while behind the occluder.
        let t_end = {
            let p = at_depth(&cam, Vec2::new(24.5, 24.5), 8.0);
            (p - o).length()
        };
        let tr = step(
            &d,
            0.5,
            Ray {
                origin: o,
                dir: right,
            },
            t_end,
        );
        assert_eq!(miss_reason(&tr), Some(Miss::BehindGeometry), "{tr:?}");
        // Passes behind the occluder, then hits the far wall.
        let target = at_depth(&cam, Vec2::new(40.5, 24.5), 31.0);
        let tr = step(&d, 0.5, ray_between(o, target), f32::INFINITY);
        let h = tr.hit().unwrap_or_else(|| panic!("{tr:?}"));
        assert!(
            (h.surface_depth - 30.0).abs() < 1e-3 && h.pixel.x >= 28.0,
            "{tr:?}"
        );
        // With a solid occluder (infinite thickness) the same ray stops there.
        let tr = step(&d, f32::INFINITY, ray_between(o, target), f32::INFINITY);
        assert!(
            (tr.hit().unwrap().surface_depth - 5.0).abs() < 1e-4,
            "{tr:?}"
        );
        // t_max in front of everything.
        let tr = step(
            &d,
            0.5,
            Ray {
                origin: o,
                dir: fwd,
            },
            2.0,
        );
        assert_eq!(miss_reason(&tr), Some(Miss::EndOfRay), "{tr:?}");
        // The far plane of an empty image.
        let tr = step(
            &empty,
            0.5,
            Ray {
                origin: o,
                dir: fwd,
            },
            f32::INFINITY,
        );
        assert_eq!(miss_reason(&tr), Some(Miss::EndOfRay), "{tr:?}");
        // Entirely beyond the far plane, and entirely behind the eye.
        let beyond = at_depth(&cam, Vec2::new(10.5, 24.5), 150.0);
        let tr = step(
            &d,
            0.5,
            Ray {
                origin: beyond,
                dir: fwd,
            },
            f32::INFINITY,
        );
        assert_eq!(miss_reason(&tr), Some(Miss::DegenerateProjection));
        // Outside the image rectangle all the way.
        let tr = step(
            &d,
            0.5,
            Ray {
                origin: o + right * 100.0,
                dir: right,
            },
            f32::INFINITY,
        );
        assert_eq!(miss_reason(&tr), Some(Miss::DegenerateProjection));
        // Step cap.
        let opts = StepOptions {
            stride: 1,
            max_steps: 3,
        };
        let tr = try_step(
            &d,
            Thickness::Constant(0.5),
            Ray {
                origin: o,
                dir: right,
            },
            f32::INFINITY,
            opts,
        )
        .unwrap();
        assert_eq!(miss_reason(&tr), Some(Miss::OutOfSteps));
        assert_eq!(tr.work().steps, 3);
    }
}

#[test]
fn step_rays_matches_step_and_leaves_outputs_on_error() {
    let scene = objects();
    let cam = camera(1.0, f32::INFINITY, 64, 48);
    let c = Cam64::new(&cam);
    let img = render(&cam, &scene, DepthConvention::ZeroToOne);
    let d = di(&cam, &img.front, DepthConvention::ZeroToOne);
    let th = Thickness::Constant(0.4);
    let opts = StepOptions {
        stride: 4,
        max_steps: 500,
    };
    let mut rng = Rng(9);
    let (rays, tms): (Vec<Ray>, Vec<f32>) = (0..100)
        .map(|_| random_ray(&mut rng, &c, &scene, 1.0))
        .unzip();
    let sentinel = Trace::Miss {
        reason: Miss::OutOfSteps,
        work: Default::default(),
    };
    let mut out = vec![sentinel; 101];
    try_step_rays(&mut out, &d, th, &rays, &tms, opts).unwrap();
    for i in 0..100 {
        assert_eq!(out[i], try_step(&d, th, rays[i], tms[i], opts).unwrap());
    }
    assert_eq!(out[100], sentinel, "past rays.len() untouched");
    // One t_max for all rays.
    try_step_rays(&mut out, &d, th, &rays, &[7.0], opts).unwrap();
    assert_eq!(out[3], try_step(&d, th, rays[3], 7.0, opts).unwrap());
    // Errors leave `out` alone.
    let mut out = vec![sentinel; 100];
    assert_eq!(
        try_step_rays(&mut out[..99], &d, th, &rays, &tms, opts),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_step_rays(&mut out, &d, th, &rays, &tms[..50], opts),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_step_rays(&mut out, &d, th, &rays, &[], opts),
        Err(Error::InvalidArgument)
    );
    let mut bad = rays.clone();
    bad[77].dir = Vec3::NAN;
    assert_eq!(
        try_step_rays(&mut out, &d, th, &bad, &tms, opts),
        Err(Error::InvalidArgument)
    );
    let mut bad_t = tms.clone();
    bad_t[99] = f32::NAN;
    assert_eq!(
        try_step_rays(&mut out, &d, th, &rays, &bad_t, opts),
        Err(Error::InvalidArgument)
    );
    assert!(out.iter().all(|o| *o == sentinel));
    // Empty input is fine.
    try_step_rays::<Trace, Ray>(&mut [], &d, th, &[], &[1.0], opts).unwrap();
}

// ---------------------------------------------------------------------------
// Property tests.

fn room_fixture() -> &'static (Camera, Vec<f32>, Vec<Shape>) {
    static F: std::sync::OnceLock<(Camera, Vec<f32>, Vec<Shape>)> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let cam = camera(1.0, f32::INFINITY, 96, 72);
        let scene = room();
        let img = render(&cam, &scene, DepthConvention::ReversedZ);
        (cam, img.front, scene)
    })
}

proptest! {
    #![proptest_config(common::proptest_config(256))]
    /// Random rays in the room: visible true hits are found within a texel
    /// (or a pixel of the surface), clear misses are not hit away from a
    /// surface, at strides 1 and 8 (at 8, a visible hit stride 8 passes
    /// over must be one stride 1 finds).
    #[test]
    fn prop_random_rays_against_the_room_oracle(
        px in 0.0f64..96.0, py in 0.0f64..72.0, f in 0.02f64..0.98,
        dx in -1.0f64..1.0, dy in -1.0f64..1.0, dz in -1.0f64..1.0,
        t_max in prop_oneof![Just(f32::INFINITY), 0.5f32..20.0],
        stride in prop_oneof![Just(1u32), Just(8u32)],
    ) {
        let (cam, front, scene) = room_fixture();
        let c = Cam64::new(cam);
        let dir = DVec3::new(dx, dy, dz);
        prop_assume!(dir.length() > 0.1);
        let zs = c.surface(scene, px, py).unwrap().0;
        let o = c.eye() + c.dir(px, py) * (c.near + f * (zs - c.near));
        let ray = Ray { origin: o.as_vec3(), dir: dir.normalize().as_vec3() };
        let d = di(cam, front, DepthConvention::ReversedZ);
        let opts = StepOptions { stride, ..StepOptions::default() };
        let tr = try_step(&d, Thickness::Constant(2.0), ray, t_max, opts).unwrap();
        assert_consistent(cam, &ray, &tr);
        let near_surface = |tr: &Trace| tr.hit().is_some_and(|h| {
            on_surface(&c, scene, ray.origin.as_dvec3() + ray.dir.as_dvec3() * f64::from(h.t), 2.0)
        });
        match truth(&c, scene, &ray, t_max) {
            // The image stores one depth per texel center; a ray that ends
            // (t_max) between the true surface and the depth sampled at the
            // texel centers near the hit never touches the image's shell
            // there, so no kernel can report it (issue 12's case).
            Truth::Visible { px, py, .. } if !image_shell_near_hit(cam, &c, front, &ray, t_max, px, py, 2.0) => {}
            Truth::Visible { px, py, .. } => {
                let found = |tr: &Trace| tr.hit().is_some_and(|h| texel_dist(h.pixel, px, py) <= 1) || near_surface(tr);
                if stride == 1 {
                    prop_assert!(found(&tr), "{:?} vs ({}, {})", tr, px, py);
                } else if !found(&tr) {
                    // Stride > 1 samples every stride-th texel; a ray that
                    // enters and leaves a surface's discrete shell between
                    // two samples is passed over (the documented limit of
                    // striding, step.rs module docs; explore.sh found such
                    // grazing rays at stride 8, checked in as regression
                    // cases). What stride 1 must find, it does find; a
                    // stride-8 hit is never before stride 1's.
                    let unit = try_step(&d, Thickness::Constant(2.0), ray, t_max, StepOptions::default()).unwrap();
                    prop_assert!(found(&unit), "stride 1 {:?} vs ({}, {})", unit, px, py);
                    if let (Some(a), Some(b)) = (unit.hit(), tr.hit()) {
                        prop_assert!(b.t >= a.t * (1.0 - 1e-4), "stride {} hit before stride 1: {:?} vs {:?}", stride, tr, unit);
                    }
                }
            }
            Truth::ClearMiss => prop_assert!(tr.hit().is_none() || near_surface(&tr), "{:?}", tr),
            Truth::Other => {}
        }
    }

    /// Arbitrary finite rays and cameras: a result (never a panic or hang),
    /// hits inside the image and consistent with the ray.
    #[test]
    fn prop_arbitrary_rays_terminate_inside_the_image(
        o in prop::array::uniform3(-1e6f32..1e6),
        d in prop::array::uniform3(-1.0f32..1.0),
        t_max in prop_oneof![Just(f32::INFINITY), 1e-6f32..1e7],
        stride in 1u32..16,
        fov in 0.01f32..3.1,
        w in 1u32..40, h in 1u32..40,
        conv in 0usize..3,
        th in prop_oneof![Just(0.0f32), Just(f32::INFINITY), 0.0f32..100.0],
    ) {
        let dir = Vec3::from(d);
        prop_assume!(dir.length() > 0.1);
        let conv = DepthConvention::ALL[conv];
        let cam = Camera::try_look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 0.5, -4.0), Vec3::Y, fov, 0.05, 500.0, w, h).unwrap();
        // A bumpy depth image with holes.
        let data: Vec<f32> = (0..w * h).map(|i| {
            if i % 7 == 3 { f32::NAN } else { cam.encode_depth(1.0 + ((i * 37) % 50) as f32, conv) }
        }).collect();
        let img = di(&cam, &data, conv);
        let ray = Ray { origin: Vec3::from(o), dir: dir.normalize() };
        let opts = StepOptions { stride, ..StepOptions::default() };
        let tr = try_step(&img, Thickness::Constant(th), ray, t_max, opts).unwrap();
        // Touched texels T <= w + h - 1; coarse steps <= T / stride + 1,
        // refinement steps <= T.
        prop_assert!(tr.work().steps <= 2 * (w + h));
        if let Some(hit) = tr.hit() {
            prop_assert!(hit.pixel.x >= 0.0 && hit.pixel.x < w as f32);
            prop_assert!(hit.pixel.y >= 0.0 && hit.pixel.y < h as f32);
            prop_assert!(hit.t >= 0.0 && hit.t <= t_max);
            prop_assert!(hit.depth >= hit.surface_depth * (1.0 - 1e-4));
        }
    }
}

/// Fuzz finding F6: a ray from near the eye into a surface ~2^31 times
/// deeper, under an infinite far plane and an infinite thickness, got a
/// hit with `t = depth = +inf`; the hit now has finite values on the ray.
/// Fuzz finding F11: the far-surface fallback above rounded a hit 3% past
/// `t_max` (1x1 image, infinite far plane, a surface at 3.6e12 just before
/// `t_max`); the hit's `t` stays in `[0, t_max]`.
#[test]
fn far_surface_hit_stays_within_t_max() {
    let view = glam::Mat4::from_cols_array(&[
        -0.7150354,
        0.4547328,
        -0.53098255,
        0.0,
        0.0,
        0.7595358,
        0.65046555,
        0.0,
        0.6990882,
        0.4651059,
        -0.543095,
        0.0,
        -0.010881593,
        0.88679034,
        -4.2802224,
        1.0,
    ]);
    let cam = Camera::try_new(view, 0.9905882, 0.33611766, f32::INFINITY, 1, 1).unwrap();
    let ray = Ray {
        origin: Vec3::new(-2.6837568, 2.1105883, -2.7294116),
        dir: Vec3::new(0.72322553, -0.49385598, 0.48275372),
    };
    let t_max = 3_647_791_700_000f32;
    let mut hits = 0;
    for conv in DepthConvention::ALL {
        for z in [3_647_791_400_000f32, 3.0e12, 3.6e12, 3.64e12] {
            let data = [cam.encode_depth(z, conv)];
            let d = di(&cam, &data, conv);
            for th in [
                Thickness::Constant(f32::INFINITY),
                Thickness::Constant(1.0),
                Thickness::Constant(1e12),
            ] {
                let tr = try_step(&d, th, ray, t_max, StepOptions::default()).unwrap();
                if let Some(h) = tr.hit() {
                    hits += 1;
                    assert!(
                        h.t >= 0.0 && h.t <= t_max,
                        "{conv:?} z {z}: t {} outside [0, {t_max}]",
                        h.t
                    );
                }
            }
        }
    }
    assert!(hits > 0, "the case hits");
}

/// Fuzz finding F16: a ray toward its vanishing point (infinite far plane,
/// `t_max = inf`) hitting a surface 1.2e8 times deeper than the near plane
/// reported the hit at depth 3.4e7 for a surface at 5.4e7: near the
/// segment's end the screen parameter does not resolve depth. The hit's
/// depth is now the boundary it crossed, and `t` the point of the ray at
/// that depth.
#[test]
fn vanishing_point_hit_reports_the_depth_it_crossed() {
    let view = glam::Mat4::from_cols_array(&[
        2.253374e-38,
        -1.9129795e-38,
        1.0,
        0.0,
        0.0,
        1.0,
        1.9129795e-38,
        0.0,
        -1.0,
        -0.0,
        2.253374e-38,
        0.0,
        7.751461,
        -5.882646,
        -7.7714806,
        1.0,
    ]);
    let cam = Camera::try_new(view, 1.0187869, 0.44444588, f32::INFINITY, 1, 3).unwrap();
    let ray = Ray {
        origin: Vec3::new(4.1554685, 6.6984744, 8.023404),
        dir: Vec3::new(-0.9728666, -0.21949376, 0.07316459),
    };
    let th = 0.6039216f32;
    let mut hits = 0;
    for conv in DepthConvention::ALL {
        let data: Vec<f32> = [f32::INFINITY, 215274700.0, 53555504.0]
            .iter()
            .map(|&z| cam.encode_depth(z, conv))
            .collect();
        let d = di(&cam, &data, conv);
        for stride in [1, 6] {
            let opts = StepOptions {
                stride,
                ..StepOptions::default()
            };
            let tr = try_step(&d, Thickness::Constant(th), ray, f32::INFINITY, opts).unwrap();
            let Some(h) = tr.hit() else { continue };
            hits += 1;
            let tol = 1e-3 * h.surface_depth;
            assert!(
                h.depth >= h.surface_depth - tol && h.depth <= h.surface_depth + th + tol,
                "{conv:?} stride {stride}: {h:?}"
            );
            let z_at_t = cam.linear_depth(ray.at(h.t));
            assert!(
                (z_at_t - h.depth).abs() <= 1e-3 * h.depth,
                "{conv:?}: z(t) {z_at_t} vs {h:?}"
            );
        }
    }
    assert!(hits > 0, "the case hits");
}

/// Fuzz finding F31: as F16, but on a finite segment (`t_max = 1e30`)
/// that nearly reaches its vanishing point: a ray from depth about 3 hit a
/// surface at 6.65e6 and reported depth 2^23, where the screen parameter's
/// last representable step below 1 puts it. The F16 fallback applied only
/// to infinite segments; it now applies wherever the parameter's depth
/// disagrees with the depth the texel test found.
#[test]
fn near_vanishing_point_finite_segment_reports_the_depth_it_crossed() {
    let (cam, ray, th) = common::f31_case();
    let (w, h) = (cam.width(), cam.height());
    let mut hits = 0;
    for conv in DepthConvention::ALL {
        let data = vec![cam.encode_depth(common::F31_SURFACE, conv); (w * h) as usize];
        let d =
            DepthImage::try_new(ImageView::try_new(&data, w, h, w).unwrap(), cam, conv).unwrap();
        for stride in [1, 3] {
            let opts = StepOptions {
                stride,
                ..StepOptions::default()
            };
            let tr = try_step(&d, Thickness::Constant(th), ray, 1e30, opts).unwrap();
            let Some(hit) = tr.hit() else { continue };
            hits += 1;
            let tol = 1e-3 * hit.surface_depth;
            assert!(
                hit.depth >= hit.surface_depth - tol && hit.depth <= hit.surface_depth + th + tol,
                "{conv:?} stride {stride}: {hit:?}"
            );
            let z_at_t = cam.linear_depth(ray.at(hit.t));
            assert!(
                (z_at_t - hit.depth).abs() <= 1e-3 * hit.depth,
                "{conv:?} stride {stride}: z(t) {z_at_t} vs {hit:?}"
            );
        }
    }
    assert!(hits > 0, "the case hits");
}

#[test]
fn hit_far_beyond_the_start_depth_is_finite() {
    let cam = camera(1.0, f32::INFINITY, 16, 12);
    let mut hits = 0;
    for conv in DepthConvention::ALL {
        let far_z = 8.4e8f32;
        let data = vec![cam.encode_depth(far_z, conv); 16 * 12];
        let d = di(&cam, &data, conv);
        let ray = cam.primary_ray(Vec2::new(8.5, 6.5));
        let ray = Ray {
            origin: ray.origin + ray.dir * 0.38,
            dir: ray.dir,
        };
        for th in [Thickness::Constant(f32::INFINITY), Thickness::Constant(1.0)] {
            let tr = try_step(&d, th, ray, f32::INFINITY, StepOptions::default()).unwrap();
            if let Some(h) = tr.hit() {
                hits += 1;
                assert!(h.t.is_finite() && h.depth.is_finite(), "{conv:?}: {tr:?}");
                let z = f64::from(cam.decode_depth(data[0], conv));
                assert!(
                    (f64::from(h.depth) - z).abs() <= 1e-3 * z,
                    "{conv:?}: {tr:?}"
                );
                let p = ray.origin.as_dvec3() + ray.dir.as_dvec3() * f64::from(h.t);
                let vz = -(cam.view().as_dmat4().transform_point3(p)).z;
                assert!(
                    (vz - z).abs() <= 1e-3 * z,
                    "{conv:?}: ray.at(t) depth {vz} vs {z}"
                );
            }
        }
    }
    assert!(hits >= 3, "the far surface is hit ({hits})");
}
