//! Hi-Z pyramid and traversal (seed 004 Sec. 4.4.1, 4.4.3, 4.6.6, 4.6.7,
//! 4.7.1) against f64 oracles: brute-force min/max over closed-form
//! footprints, and a brute-force ray marcher over analytic scenes.
#![cfg(feature = "hiz")]

use glam::{DMat4, DVec3, Vec3};
use proptest::prelude::*;

mod common;
use refl_core::hiz::MAX_LEVELS;
use refl_core::{
    try_build_hiz, try_build_hiz_level0_rows, try_build_hiz_level_rows, try_hiz_len, try_stamp_hiz,
    try_trace_hiz, try_trace_hiz_rays, try_trace_hiz_stats, Camera, DepthConvention, DepthImage,
    Error, HiZ, HiZLayout, HiZOptions, HiZTexel, ImageView, Miss, PyramidStamp, Ray, RowRange,
    Thickness, Trace, HIZ_STAMP_TEXELS,
};

// ---------------------------------------------------------------- helpers

/// SplitMix64: a small deterministic generator for test data.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn f(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.f()
    }
    fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

/// f64 encode of linear depth `z` (camera.rs module table).
fn encode64(z: f64, n: f64, f: f64, c: DepthConvention) -> f64 {
    match c {
        DepthConvention::Linear => z,
        DepthConvention::ZeroToOne if f.is_infinite() => 1.0 - n / z,
        DepthConvention::ZeroToOne => f * (z - n) / (z * (f - n)),
        DepthConvention::ReversedZ if f.is_infinite() => n / z,
        DepthConvention::ReversedZ => n * (f - z) / (z * (f - n)),
    }
}

/// f64 decode of a stored depth.
fn decode64(d: f64, n: f64, f: f64, c: DepthConvention) -> f64 {
    match c {
        DepthConvention::Linear => d,
        DepthConvention::ZeroToOne if f.is_infinite() => n / (1.0 - d),
        DepthConvention::ZeroToOne => n * f / (f - d * (f - n)),
        DepthConvention::ReversedZ if f.is_infinite() => n / d,
        DepthConvention::ReversedZ => n * f / (n + d * (f - n)),
    }
}

/// The cleared (background) value of a convention.
fn background(far: f32, c: DepthConvention) -> f32 {
    match c {
        DepthConvention::Linear => far,
        DepthConvention::ZeroToOne => 1.0,
        DepthConvention::ReversedZ => 0.0,
    }
}

#[derive(Clone, Copy, Debug)]
enum Prim {
    /// `n . p + d = 0`, unit `n`; seen from its front (n . dir < 0).
    Plane(DVec3, f64),
    /// Axis-aligned box.
    Box(DVec3, DVec3),
}

/// First positive intersection of `o + t d` with the primitives: `(t, normal)`.
fn intersect(scene: &[Prim], o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
    let mut best: Option<(f64, DVec3)> = None;
    for p in scene {
        let hit = match *p {
            Prim::Plane(n, dd) => {
                let den = n.dot(d);
                let t = -(n.dot(o) + dd) / den;
                (den < 0.0 && t > 0.0).then_some((t, n))
            }
            Prim::Box(lo, hi) => {
                let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
                let mut nrm = DVec3::ZERO;
                let mut ok = true;
                for a in 0..3 {
                    let inv = 1.0 / d[a];
                    let (mut ta, mut tb) = ((lo[a] - o[a]) * inv, (hi[a] - o[a]) * inv);
                    let mut na = DVec3::ZERO;
                    na[a] = -inv.signum();
                    if ta > tb {
                        core::mem::swap(&mut ta, &mut tb);
                    }
                    if ta > t0 {
                        t0 = ta;
                        nrm = na;
                    }
                    t1 = t1.min(tb);
                    if t0 > t1 {
                        ok = false;
                        break;
                    }
                }
                (ok && t0 > 0.0 && nrm != DVec3::ZERO).then_some((t0, nrm))
            }
        };
        if let Some(h) = hit {
            if best.is_none_or(|b| h.0 < b.0) {
                best = Some(h);
            }
        }
    }
    best
}

/// A rendered scene: camera, stored depths, the f64 view matrix.
struct Img {
    cam: Camera,
    conv: DepthConvention,
    depth: Vec<f32>,
    view: DMat4,
    tx: f64,
    ty: f64,
    scene: Vec<Prim>,
}

impl Img {
    fn new(cam: Camera, conv: DepthConvention, scene: Vec<Prim>) -> Self {
        let (w, h) = (cam.width() as usize, cam.height() as usize);
        let ty = (cam.fov_y() as f64 * 0.5).tan();
        let tx = ty * w as f64 / h as f64;
        let view = cam.view().as_dmat4();
        let inv = view.inverse();
        let eye = inv.transform_point3(DVec3::ZERO);
        let (n, f) = (cam.near() as f64, cam.far() as f64);
        let mut depth = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let nx = 2.0 * (x as f64 + 0.5) / w as f64 - 1.0;
                let ny = 1.0 - 2.0 * (y as f64 + 0.5) / h as f64;
                let dv = DVec3::new(nx * tx, ny * ty, -1.0);
                let dw = inv.transform_vector3(dv);
                // t along dw is the linear depth (dv.z = -1, rigid view).
                depth[y * w + x] = match intersect(&scene, eye, dw) {
                    Some((z, _)) if z < f => encode64(z, n, f, conv) as f32,
                    _ => background(cam.far(), conv),
                };
            }
        }
        Self {
            cam,
            conv,
            depth,
            view,
            tx,
            ty,
            scene,
        }
    }

    fn view(&self) -> ImageView<'_, f32> {
        ImageView::try_new(
            &self.depth,
            self.cam.width(),
            self.cam.height(),
            self.cam.width(),
        )
        .unwrap()
    }

    fn depth_image(&self) -> DepthImage<'_> {
        DepthImage::try_new(self.view(), self.cam, self.conv).unwrap()
    }

    fn pyramid(&self) -> Vec<HiZTexel> {
        let mut p = vec![[0.0; 2]; try_hiz_len(self.cam.width(), self.cam.height()).unwrap()];
        try_build_hiz(&mut p, &self.depth_image()).unwrap();
        p
    }

    /// Linear depth of texel (x, y) in f64, or None for no surface.
    fn texel_z(&self, x: i64, y: i64) -> Option<f64> {
        let (w, h) = (self.cam.width() as i64, self.cam.height() as i64);
        if x < 0 || y < 0 || x >= w || y >= h {
            return None;
        }
        let d = self.depth[(y * w + x) as usize] as f64;
        let z = decode64(d, self.cam.near() as f64, self.cam.far() as f64, self.conv);
        (z > 0.0 && z < self.cam.far() as f64).then_some(z)
    }

    /// Absolute error bound of the f32 decode of a stored depth at linear
    /// depth `z` (post-projection depth amplifies rounding by about
    /// `z / near`).
    fn ztol(&self, z: f64) -> f64 {
        ztol(z, self.cam.near() as f64, self.conv)
    }

    /// f64 projection of a world point: (px, py, z).
    fn project(&self, p: DVec3) -> (f64, f64, f64) {
        let v = self.view.transform_point3(p);
        let z = -v.z;
        let (w, h) = (self.cam.width() as f64, self.cam.height() as f64);
        (
            (v.x / (z * self.tx) + 1.0) * 0.5 * w,
            (1.0 - v.y / (z * self.ty)) * 0.5 * h,
            z,
        )
    }

    fn eye(&self) -> DVec3 {
        self.view.inverse().transform_point3(DVec3::ZERO)
    }

    /// World point and normal of the surface seen through pixel center
    /// (x, y), f64.
    fn surface(&self, x: f64, y: f64) -> Option<(DVec3, DVec3)> {
        let (w, h) = (self.cam.width() as f64, self.cam.height() as f64);
        let nx = 2.0 * x / w - 1.0;
        let ny = 1.0 - 2.0 * y / h;
        let dw =
            self.view
                .inverse()
                .transform_vector3(DVec3::new(nx * self.tx, ny * self.ty, -1.0));
        let eye = self.eye();
        intersect(&self.scene, eye, dw)
            .filter(|(z, _)| *z < self.cam.far() as f64)
            .map(|(t, n)| (eye + dw * t, n))
    }
}

/// The oracle's first hit: ray parameter, pixel position, ray depth.
#[derive(Clone, Copy, Debug)]
#[allow(dead_code)] // `t` is shown in failure messages.
struct OHit {
    t: f64,
    px: f64,
    py: f64,
}

/// Brute-force f64 marcher: samples the ray at most 0.04 px apart in screen
/// space and tests each sample against its texel with the thickness rule
/// (`z_front <= z <= z_front + thickness`); between two samples over the
/// same texel the linear depth is linear in t, so the first point inside the
/// slab is solved exactly.
fn oracle(img: &Img, thick: f64, o: DVec3, d: DVec3, t_max: f64) -> Option<OHit> {
    let vo = img.view.transform_point3(o);
    let vd = img.view.transform_vector3(d);
    let (n, f) = (img.cam.near() as f64, img.cam.far() as f64);
    let (w, h) = (img.cam.width() as f64, img.cam.height() as f64);
    let zat = |t: f64| -(vo.z + t * vd.z);
    let dz = -vd.z;
    // The deepest hittable point of the image bounds rays moving away.
    let mut zmax = 0.0f64;
    for y in 0..img.cam.height() as i64 {
        for x in 0..img.cam.width() as i64 {
            if let Some(z) = img.texel_z(x, y) {
                zmax = zmax.max(z + thick);
            }
        }
    }
    let slab_t = |z0: f64, lo: f64, hi: f64, ta: f64, tb: f64| -> Option<f64> {
        // first t in [ta, tb] with lo <= z0 + (t - ta) dz <= hi
        let (mut a, mut b) = (ta, tb);
        if dz > 0.0 {
            a = a.max(ta + (lo - z0) / dz);
            b = b.min(ta + (hi - z0) / dz);
        } else if dz < 0.0 {
            a = a.max(ta + (hi - z0) / dz);
            b = b.min(ta + (lo - z0) / dz);
        } else if !(z0 >= lo && z0 <= hi) {
            return None;
        }
        (a <= b).then_some(a)
    };
    let mut t = 0.0f64;
    let mut prev: Option<(f64, i64, i64)> = None;
    let mut guard = 0u64;
    loop {
        guard += 1;
        assert!(guard < 50_000_000, "oracle did not terminate");
        if t > t_max {
            return None;
        }
        let z = zat(t);
        if z < n {
            if dz > 0.0 {
                t += (n - z) / dz * (1.0 + 1e-12) + 1e-300;
                prev = None;
                continue;
            }
            return None;
        }
        if z > f || (z > zmax && dz >= 0.0) {
            return None;
        }
        let v = vo + vd * t;
        let px = (v.x / (z * img.tx) + 1.0) * 0.5 * w;
        let py = (1.0 - v.y / (z * img.ty)) * 0.5 * h;
        // Screen velocity.
        let dpx = 0.5 * w / img.tx * (vd.x * z - v.x * dz) / (z * z);
        let dpy = -0.5 * h / img.ty * (vd.y * z - v.y * dz) / (z * z);
        if (px < 0.0 && dpx <= 0.0)
            || (px >= w && dpx >= 0.0)
            || (py < 0.0 && dpy <= 0.0)
            || (py >= h && dpy >= 0.0)
        {
            return None;
        }
        let inside = px >= 0.0 && px < w && py >= 0.0 && py < h;
        let dt = (0.04 / dpx.abs().max(dpy.abs()).max(1e-300)).min(1e30);
        if inside {
            let (ix, iy) = (px.floor() as i64, py.floor() as i64);
            // The previous sample's texel, from the previous sample up to
            // where the ray leaves it (bisection on the f64 projection):
            // no sliver of a texel between two samples is skipped.
            let mut entry = t;
            if let Some((tp, jx, jy)) = prev {
                if (jx, jy) != (ix, iy) {
                    let (mut a, mut b) = (tp, t);
                    for _ in 0..60 {
                        let m = 0.5 * (a + b);
                        let q = img.project(o + d * m);
                        if (q.0.floor() as i64, q.1.floor() as i64) == (jx, jy) {
                            a = m;
                        } else {
                            b = m;
                        }
                    }
                    entry = b;
                    if let Some(zf) = img.texel_z(jx, jy) {
                        if let Some(th) = slab_t(zat(tp), zf, zf + thick, tp, a) {
                            let p = img.project(o + d * th);
                            return Some(OHit {
                                t: th,
                                px: p.0,
                                py: p.1,
                            });
                        }
                    }
                }
            }
            if let Some(zf) = img.texel_z(ix, iy) {
                let hi = zf + thick;
                // Exact first point since the previous sample, same texel.
                let from = match prev {
                    Some((tp, jx, jy)) if jx == ix && jy == iy => tp,
                    _ => entry,
                };
                if let Some(th) = slab_t(zat(from), zf, hi, from, t) {
                    let p = img.project(o + d * th);
                    return Some(OHit {
                        t: th,
                        px: p.0,
                        py: p.1,
                    });
                }
            }
            prev = Some((t, ix, iy));
        } else {
            prev = None;
        }
        if t >= t_max {
            return None;
        }
        t = (t + dt).min(t_max);
        if t > 1e15 {
            return None;
        }
    }
}

fn ray(o: DVec3, d: DVec3) -> Ray {
    Ray {
        origin: o.as_vec3(),
        dir: d.normalize().as_vec3(),
    }
}

/// `true` if Hi-Z and the oracle agree: both miss, or both hit within one
/// pixel (Chebyshev distance of the hit positions).
fn agrees(tr: &Trace, o: &Option<OHit>) -> bool {
    match (tr.hit(), o) {
        (None, None) => true,
        (Some(h), Some(o)) => {
            (h.pixel.x as f64 - o.px).abs() <= 1.0 + 1e-3
                && (h.pixel.y as f64 - o.py).abs() <= 1.0 + 1e-3
        }
        _ => false,
    }
}

fn camera(eye: Vec3, target: Vec3, far: f32, w: u32, h: u32) -> Camera {
    Camera::try_look_at(eye, target, Vec3::Y, 60f32.to_radians(), 0.1, far, w, h).unwrap()
}

/// A closed room (floor, ceiling, walls), a box on the floor, a thin pillar
/// in front of the back wall, and a raised step: planes, boxes and a step
/// edge. Scaled by `s`.
fn room(s: f64) -> Vec<Prim> {
    let p = |n: DVec3, d: f64| Prim::Plane(n, d * s);
    let b = |lo: DVec3, hi: DVec3| Prim::Box(lo * s, hi * s);
    vec![
        p(DVec3::Y, 0.0),                                            // floor y = 0
        p(-DVec3::Y, 4.0),                                           // ceiling y = 4
        p(DVec3::Z, 10.0),                                           // back wall z = -10
        p(-DVec3::Z, 10.0), // wall behind the camera z = 10
        p(DVec3::X, 5.0),   // left wall x = -5
        p(-DVec3::X, 5.0),  // right wall x = 5
        b(DVec3::new(-2.5, 0.0, -4.0), DVec3::new(-1.0, 1.2, -2.5)), // box
        b(DVec3::new(1.0, 0.0, -6.05), DVec3::new(1.3, 3.0, -5.95)), // thin pillar
        b(DVec3::new(-5.0, 0.0, -10.0), DVec3::new(5.0, 0.3, -7.5)), // step edge
    ]
}

/// An open scene: a floor plane and a back wall that does not reach the
/// ceiling (background above it), plus a box.
fn open_scene() -> Vec<Prim> {
    vec![
        Prim::Plane(DVec3::Y, 0.0),
        Prim::Box(DVec3::new(-20.0, 0.0, -22.0), DVec3::new(20.0, 3.0, -20.0)),
        Prim::Box(DVec3::new(0.5, 0.0, -6.0), DVec3::new(2.0, 1.5, -4.5)),
    ]
}

/// Rays of a rendered image: half reflect the view ray off a visible
/// surface (starting slightly off it), half start at random points in the
/// view with random directions. `t_max` is infinite for a third of them.
fn rays_for(img: &Img, rng: &mut Rng, count: usize, scale: f64) -> Vec<(Ray, f32)> {
    let (w, h) = (img.cam.width() as f64, img.cam.height() as f64);
    let eye = img.eye();
    let mut out = Vec::new();
    while out.len() < count {
        let (x, y) = (rng.range(0.0, w), rng.range(0.0, h));
        let Some((p, nrm)) = img.surface(x, y) else {
            continue;
        };
        let t_max = if rng.f() < 0.33 {
            f32::INFINITY
        } else {
            (rng.range(1.0, 30.0) * scale) as f32
        };
        if rng.f() < 0.5 {
            let v = (p - eye).normalize();
            let r = v - 2.0 * v.dot(nrm) * nrm;
            let d = (r + rng.unit() * 0.2).normalize();
            if d.dot(nrm) <= 0.05 {
                continue;
            }
            out.push((ray(p + nrm * (0.01 * scale), d), t_max));
        } else {
            let f = rng.range(0.2, 0.95);
            let o = eye + (p - eye) * f;
            out.push((ray(o, rng.unit()), t_max));
        }
    }
    out
}

/// Runs Hi-Z and the oracle over `rays`; returns (agreements, total).
fn agreement(img: &Img, pyr: &[HiZTexel], thick: f32, rays: &[(Ray, f32)]) -> (usize, usize) {
    let hiz = HiZ::try_new(pyr, img.cam, img.conv).unwrap();
    let mut ok = 0;
    for (r, tm) in rays {
        let tr = try_trace_hiz(
            &hiz,
            Thickness::Constant(thick),
            *r,
            *tm,
            &HiZOptions::default(),
        )
        .unwrap();
        let o = oracle(
            img,
            thick as f64,
            r.origin.as_dvec3(),
            r.dir.as_dvec3(),
            *tm as f64,
        );
        if agrees(&tr, &o) {
            ok += 1;
        } else {
            eprintln!("disagree: {r:?} t_max {tm}: hiz {tr:?} oracle {o:?}");
        }
    }
    (ok, rays.len())
}

// ---------------------------------------------------------------- pyramid

/// See [`Img::ztol`].
fn ztol(z: f64, near: f64, conv: DepthConvention) -> f64 {
    let amp = match conv {
        DepthConvention::Linear => 1.0,
        _ => 1.0 + z / near,
    };
    4.0 * f32::EPSILON as f64 * amp * z
}

/// Closed-form footprint of texel `c` of level `l` along an axis of `full`
/// pixels with `cells` cells: `[c 2^l, (c + 1) 2^l)`, the last cell reaching
/// the edge.
fn footprint(c: u32, l: u32, cells: u32, full: u32) -> std::ops::Range<u32> {
    let lo = (c as u64) << l;
    let hi = if c + 1 == cells {
        full as u64
    } else {
        ((c + 1) as u64) << l
    };
    lo as u32..hi as u32
}

/// Checks every texel of every level against f64 min/max over its level-0
/// footprint, and the exact conservativeness of each level against the
/// level below.
fn check_pyramid(depth: &[f32], w: u32, h: u32, cam: &Camera, conv: DepthConvention) {
    let view = ImageView::try_new(depth, w, h, w).unwrap();
    let img = DepthImage::try_new(view, *cam, conv).unwrap();
    let layout = HiZLayout::try_new(w, h).unwrap();
    let mut pyr = vec![[7.0f32; 2]; try_hiz_len(w, h).unwrap()];
    try_build_hiz(&mut pyr, &img).unwrap();
    let hiz = HiZ::try_new(&pyr, *cam, conv).unwrap();
    let (n, f) = (cam.near() as f64, cam.far() as f64);
    let z64 = |x: u32, y: u32| {
        let z = decode64(depth[(y * w + x) as usize] as f64, n, f, conv);
        (z > 0.0).then_some(z)
    };
    // Level 0 is `Camera::decode_depth` bit for bit (the build hoists its
    // branches out of the row loop), NaN where it is not positive.
    for y in 0..h {
        for x in 0..w {
            let z = cam.decode_depth(depth[(y * w + x) as usize], conv);
            let t = hiz.texel(0, x, y).unwrap();
            if z > 0.0 {
                assert_eq!(
                    t.map(f32::to_bits),
                    [z.to_bits(); 2],
                    "level 0 ({x}, {y}) {conv:?}"
                );
            } else {
                assert!(
                    t[0].is_nan() && t[1].is_nan(),
                    "level 0 ({x}, {y}) {conv:?}: {t:?}"
                );
            }
        }
    }
    for l in 0..layout.level_count() {
        let lv = layout.level(l).unwrap();
        assert_eq!(lv.width, (w >> l).max(1));
        assert_eq!(lv.height, (h >> l).max(1));
        let mut covered = 0u64;
        for cy in 0..lv.height {
            for cx in 0..lv.width {
                let (xs, ys) = (
                    footprint(cx, l, lv.width, w),
                    footprint(cy, l, lv.height, h),
                );
                assert_eq!(layout.footprint(l, cx, cy), Some((xs.clone(), ys.clone())));
                covered += (xs.len() * ys.len()) as u64;
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                let mut any = false;
                for y in ys.clone() {
                    for x in xs.clone() {
                        if let Some(z) = z64(x, y) {
                            any = true;
                            lo = lo.min(z);
                            hi = hi.max(z);
                        }
                        // Exact conservativeness against level 0.
                        let t0 = hiz.texel(0, x, y).unwrap();
                        let t = hiz.texel(l, cx, cy).unwrap();
                        if !t0[0].is_nan() {
                            assert!(t[0] <= t0[0] && t[1] >= t0[1], "level {l} ({cx},{cy})");
                        }
                    }
                }
                let t = hiz.texel(l, cx, cy).unwrap();
                if any {
                    // The bounds are attained by a level-0 texel, bit for bit.
                    let attained = |k: usize| {
                        ys.clone()
                            .any(|y| xs.clone().any(|x| hiz.texel(0, x, y).unwrap()[k] == t[k]))
                    };
                    assert!(
                        attained(0) && attained(1),
                        "level {l} ({cx},{cy}) not attained"
                    );
                    let tol = |v: f64| ztol(v, n, conv) + 1e-30;
                    assert!(
                        (t[0] as f64 - lo).abs() <= tol(lo)
                            || (lo.is_infinite() && t[0] == lo as f32),
                        "min level {l} ({cx},{cy}) {w}x{h} {conv:?}: {} vs {lo}",
                        t[0]
                    );
                    assert!(
                        (t[1] as f64 - hi).abs() <= tol(hi)
                            || (hi.is_infinite() && t[1] == hi as f32),
                        "max level {l} ({cx},{cy}) {w}x{h} {conv:?}: {} vs {hi}",
                        t[1]
                    );
                } else {
                    assert!(
                        t[0].is_nan() && t[1].is_nan(),
                        "no-surface texel must be NaN"
                    );
                }
            }
        }
        // Footprints partition the image.
        assert_eq!(covered, w as u64 * h as u64);
    }
    assert_eq!(
        layout
            .level(layout.level_count() - 1)
            .map(|l| (l.width, l.height)),
        Some((1, 1))
    );
}

/// Random stored depths of a convention: surfaces in [near, 50], plus NaN,
/// background, negative and out-of-range values.
fn random_depths(rng: &mut Rng, w: u32, h: u32, cam: &Camera, conv: DepthConvention) -> Vec<f32> {
    let (n, f) = (cam.near() as f64, cam.far() as f64);
    (0..w * h)
        .map(|_| match rng.next() % 20 {
            0 => f32::NAN,
            1 => background(cam.far(), conv),
            2 => -1.0,
            _ => encode64(rng.range(n, 50.0), n, f, conv) as f32,
        })
        .collect()
}

#[test]
fn layout_sizes_offsets_and_errors() {
    // The levels, then the stamp (HIZ_STAMP_TEXELS).
    assert_eq!(HIZ_STAMP_TEXELS, 2);
    assert_eq!(try_hiz_len(1, 1), Ok(1 + 2));
    assert_eq!(try_hiz_len(2, 2), Ok(5 + 2));
    assert_eq!(try_hiz_len(3, 5), Ok(15 + 2 + 1 + 2));
    assert_eq!(try_hiz_len(1, 7), Ok(7 + 3 + 1 + 2));
    assert_eq!(HiZLayout::try_new(3, 5).unwrap().len(), 15 + 2 + 1);
    assert_eq!(try_hiz_len(0, 4), Err(Error::InvalidArgument));
    assert_eq!(try_hiz_len(4, 0), Err(Error::InvalidArgument));
    let l = HiZLayout::try_new(640, 480).unwrap();
    assert_eq!(l.level_count(), 10);
    let mut off = 0;
    for i in 0..l.level_count() {
        let lv = l.level(i).unwrap();
        assert_eq!(lv.offset, off);
        off += lv.len();
    }
    assert_eq!(off, l.len());
    assert_eq!(l.level(10), None);
    let big = HiZLayout::try_new(u32::MAX, 1);
    if usize::BITS >= 64 {
        let big = big.unwrap();
        assert_eq!(big.level_count() as usize, MAX_LEVELS);
    }
    // (2^32 - 1)^2 texels at level 0 plus the coarser levels overflow u64.
    assert_eq!(
        HiZLayout::try_new(u32::MAX, u32::MAX),
        Err(Error::InvalidArgument)
    );
    let rr = l
        .rows_range(3, RowRange::try_new(2, 5, 60).unwrap())
        .unwrap();
    let l3 = l.level(3).unwrap();
    assert_eq!(rr, l3.offset + 2 * 80..l3.offset + 5 * 80);
    assert_eq!(l.rows_range(3, RowRange::try_new(0, 61, 61).unwrap()), None);
}

#[test]
fn pyramid_matches_brute_force_on_odd_sizes_all_conventions() {
    let mut rng = Rng(11);
    let sizes = [
        (1, 1),
        (1, 9),
        (9, 1),
        (1, 2),
        (3, 5),
        (5, 3),
        (7, 9),
        (2, 3),
        (33, 17),
        (641, 481),
    ];
    for &(w, h) in &sizes {
        for far in [100.0, f32::INFINITY] {
            let cam = camera(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, far, w, h);
            for conv in DepthConvention::ALL {
                let d = random_depths(&mut rng, w, h, &cam, conv);
                check_pyramid(&d, w, h, &cam, conv);
            }
        }
    }
}

proptest! {
    #![proptest_config(common::proptest_config(48))]
    #[test]
    fn prop_pyramid_matches_brute_force_on_random_sizes(
        w in 1u32..70, h in 1u32..70, conv in 0usize..3, inf in any::<bool>(), seed in any::<u64>()
    ) {
        let conv = DepthConvention::ALL[conv];
        let far = if inf { f32::INFINITY } else { 80.0 };
        let cam = camera(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, far, w, h);
        let d = random_depths(&mut Rng(seed), w, h, &cam, conv);
        check_pyramid(&d, w, h, &cam, conv);
    }
}

/// Every coarse texel is, bit for bit, the NaN-ignoring `f32::min` and
/// `f32::max` of the level-0 texels of its footprint (`min`/`max` are exact
/// and associative, so any fold order gives these bits). The build folds
/// four texels at a time with SSE2 on x86-64 and the rest one by one:
/// widths from 1 to 40 and 67 cover every tail, and NaN densities from none
/// to nearly all cover every NaN pattern of a 2x2 footprint.
#[test]
fn coarse_levels_are_the_exact_nan_ignoring_fold_of_their_footprint() {
    let mut rng = Rng(0x5eed_f01d);
    let mut sizes: Vec<(u32, u32)> = (1..=40).map(|w| (w, 2 + w % 7)).collect();
    sizes.extend([(67, 13), (128, 3), (131, 64)]);
    for &(w, h) in &sizes {
        let cam = camera(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, 100.0, w, h);
        for nan_percent in [0u64, 30, 70, 95] {
            let depth: Vec<f32> = (0..w * h)
                .map(|_| {
                    if rng.next() % 100 < nan_percent {
                        f32::NAN
                    } else {
                        rng.range(0.5, 60.0) as f32
                    }
                })
                .collect();
            let view = ImageView::try_new(&depth, w, h, w).unwrap();
            let img = DepthImage::try_new(view, cam, DepthConvention::Linear).unwrap();
            let layout = HiZLayout::try_new(w, h).unwrap();
            let mut pyr = vec![[7.0f32; 2]; try_hiz_len(w, h).unwrap()];
            try_build_hiz(&mut pyr, &img).unwrap();
            let hiz = HiZ::try_new(&pyr, cam, DepthConvention::Linear).unwrap();
            for l in 1..layout.level_count() {
                let lv = layout.level(l).unwrap();
                for cy in 0..lv.height {
                    for cx in 0..lv.width {
                        let (mut lo, mut hi) = (f32::NAN, f32::NAN);
                        for y in footprint(cy, l, lv.height, h) {
                            for x in footprint(cx, l, lv.width, w) {
                                let z = depth[(y * w + x) as usize];
                                lo = lo.min(z);
                                hi = hi.max(z);
                            }
                        }
                        let t = hiz.texel(l, cx, cy).unwrap();
                        assert_eq!(
                            t.map(f32::to_bits),
                            [lo.to_bits(), hi.to_bits()],
                            "level {l} ({cx}, {cy}) of {w}x{h}, {nan_percent}% NaN"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn row_band_build_threaded_equals_whole_build() {
    let img = Img::new(
        camera(
            Vec3::new(0.0, 2.0, 6.0),
            Vec3::new(0.0, 1.0, -5.0),
            100.0,
            203,
            117,
        ),
        DepthConvention::ReversedZ,
        room(1.0),
    );
    let whole = img.pyramid();
    let layout = HiZLayout::try_new(203, 117).unwrap();
    let mut banded = vec![[0.0f32; 2]; try_hiz_len(203, 117).unwrap()];
    let di = img.depth_image();
    for level in 0..layout.level_count() {
        let lv = layout.level(level).unwrap();
        let (head, tail) = banded.split_at_mut(lv.offset);
        let cur = &mut tail[..lv.len()];
        let finer: &[HiZTexel] = if level == 0 {
            &[]
        } else {
            &head[layout.level(level - 1).unwrap().range()]
        };
        let all = RowRange::try_all(lv.height).unwrap();
        let bands = 3;
        std::thread::scope(|sc| {
            let mut rest = cur;
            for i in 0..bands {
                let Some(b) = all.band(i, bands) else {
                    continue;
                };
                let (mine, r) = rest.split_at_mut(b.len() as usize * lv.width as usize);
                rest = r;
                let (di, layout) = (&di, &layout);
                sc.spawn(move || {
                    if level == 0 {
                        try_build_hiz_level0_rows(mine, di, b).unwrap();
                    } else {
                        try_build_hiz_level_rows(mine, finer, layout, level, b).unwrap();
                    }
                });
            }
        });
    }
    let bits = |p: &[HiZTexel]| {
        p.iter()
            .map(|t| [t[0].to_bits(), t[1].to_bits()])
            .collect::<Vec<_>>()
    };
    // A row-band build ends with the stamp, which the whole build writes.
    assert_eq!(
        HiZ::try_new(&banded, img.cam, img.conv).err(),
        Some(Error::InvalidArgument)
    );
    try_stamp_hiz(&mut banded, &img.cam).unwrap();
    assert_eq!(bits(&whole), bits(&banded));
}

#[test]
fn build_rejects_bad_input_and_writes_nothing() {
    let img = Img::new(
        camera(Vec3::new(0.0, 2.0, 6.0), Vec3::ZERO, 100.0, 9, 7),
        DepthConvention::Linear,
        room(1.0),
    );
    let n = try_hiz_len(9, 7).unwrap();
    let mut short = vec![[5.0f32; 2]; n - 1];
    assert_eq!(
        try_build_hiz(&mut short, &img.depth_image()),
        Err(Error::InsufficientSize)
    );
    assert!(short.iter().all(|t| *t == [5.0, 5.0]));
    let layout = HiZLayout::try_new(9, 7).unwrap();
    let mut band = vec![[5.0f32; 2]; 100];
    let fine = vec![[1.0f32; 2]; 63];
    let r = RowRange::try_all(3).unwrap();
    assert_eq!(
        try_build_hiz_level_rows(&mut band, &fine, &layout, 0, r),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_build_hiz_level_rows(&mut band, &fine, &layout, 9, r),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_build_hiz_level_rows(&mut band, &fine[..10], &layout, 1, r),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_build_hiz_level_rows(&mut band[..5], &fine, &layout, 1, r),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_build_hiz_level_rows(&mut band, &fine, &layout, 1, RowRange::try_all(4).unwrap()),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_build_hiz_level0_rows(&mut band, &img.depth_image(), RowRange::try_all(8).unwrap()),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_build_hiz_level0_rows(
            &mut band[..17],
            &img.depth_image(),
            RowRange::try_all(2).unwrap()
        ),
        Err(Error::InsufficientSize)
    );
    assert!(band.iter().all(|t| *t == [5.0, 5.0]));
    let pyr = vec![[0.0f32; 2]; n - 1];
    assert!(matches!(
        HiZ::try_new(&pyr, img.cam, img.conv),
        Err(Error::InsufficientSize)
    ));
}

// ---------------------------------------------------------------- traversal

#[test]
fn agrees_with_oracle_on_room_all_conventions_finite_and_infinite_far() {
    let mut total = (0, 0);
    for far in [60.0f32, f32::INFINITY] {
        for conv in DepthConvention::ALL {
            let img = Img::new(
                camera(
                    Vec3::new(0.5, 2.0, 6.0),
                    Vec3::new(-0.5, 0.8, -6.0),
                    far,
                    160,
                    96,
                ),
                conv,
                room(1.0),
            );
            let pyr = img.pyramid();
            let mut rng = Rng(far.to_bits() as u64 ^ conv as u64);
            let rays = rays_for(&img, &mut rng, 150, 1.0);
            for thick in [0.25f32, f32::INFINITY] {
                let (a, n) = agreement(&img, &pyr, thick, &rays);
                total.0 += a;
                total.1 += n;
            }
        }
    }
    let share = total.0 as f64 / total.1 as f64;
    eprintln!("room agreement {}/{} = {share:.4}", total.0, total.1);
    assert!(share >= 0.99, "agreement {share}");
}

#[test]
fn agrees_with_oracle_on_open_scene_with_background() {
    let mut total = (0, 0);
    for far in [80.0f32, f32::INFINITY] {
        for conv in DepthConvention::ALL {
            let img = Img::new(
                camera(
                    Vec3::new(0.0, 1.5, 4.0),
                    Vec3::new(0.0, 1.0, -10.0),
                    far,
                    128,
                    80,
                ),
                conv,
                open_scene(),
            );
            let pyr = img.pyramid();
            let mut rng = Rng(77 + conv as u64);
            let rays = rays_for(&img, &mut rng, 150, 1.0);
            let (a, n) = agreement(&img, &pyr, 0.5, &rays);
            total.0 += a;
            total.1 += n;
        }
    }
    let share = total.0 as f64 / total.1 as f64;
    eprintln!("open-scene agreement {}/{} = {share:.4}", total.0, total.1);
    assert!(share >= 0.99, "agreement {share}");
}

proptest! {
    #![proptest_config(common::proptest_config(24))]
    /// Random scenes parameters and rays: Hi-Z equals plain per-pixel
    /// stepping (prologue only) and every stop level, and every hit is a
    /// genuine hit (the ray point projects into the texel and lies in its
    /// slab). Agreement with the oracle (>= 99% overall) is asserted by the
    /// deterministic tests above.
    #[test]
    fn prop_random_rays_hierarchy_never_skips_a_hit(
        conv in 0usize..3, inf in any::<bool>(), seed in any::<u64>(),
        thick in prop_oneof![Just(0.0f32), 0.01f32..2.0, Just(f32::INFINITY)],
        ex in -2.0f32..2.0, ey in 0.5f32..3.5,
    ) {
        let conv = DepthConvention::ALL[conv];
        let far = if inf { f32::INFINITY } else { 40.0 };
        let img = Img::new(
            camera(Vec3::new(ex, ey, 7.0), Vec3::new(-ex, 1.0, -8.0), far, 97, 61),
            conv,
            room(1.0),
        );
        let pyr = img.pyramid();
        let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
        let mut rng = Rng(seed);
        let rays = rays_for(&img, &mut rng, 20, 1.0);
        // Agreement with the oracle is a statistic, not a property: 20 rays
        // with a zero-thickness shell agreed 18 times under a random seed
        // (scripts/explore.sh, checked in as a regression case). The
        // overall >= 99% is asserted by the fixed-seed tests above.
        for (r, tm) in &rays {
            let th = Thickness::Constant(thick);
            let base = try_trace_hiz(&hiz, th, *r, *tm, &HiZOptions::default()).unwrap();
            let linear = try_trace_hiz(&hiz, th, *r, *tm, &HiZOptions { prologue_steps: u32::MAX, ..Default::default() }).unwrap();
            prop_assert!(same(&base, &linear), "hiz {base:?} vs linear {linear:?}");
            for stop in [1, 3] {
                let o = HiZOptions { stop_level: stop, start_level: 4, prologue_steps: 0, ..Default::default() };
                let s = try_trace_hiz(&hiz, th, *r, *tm, &o).unwrap();
                prop_assert!(same(&base, &s), "stop {stop}: {base:?} vs {s:?}");
            }
            if let Some(h) = base.hit() {
                check_genuine(&img, thick as f64, r, h);
            }
        }
    }
}

/// Two traces find the same hit (within a pixel) or both miss.
fn same(a: &Trace, b: &Trace) -> bool {
    match (a.hit(), b.hit()) {
        (None, None) => true,
        (Some(x), Some(y)) => (x.pixel - y.pixel).abs().max_element() <= 1.0,
        _ => false,
    }
}

/// The hit point `ray.at(t)` projects into the reported texel (within
/// rounding) at the reported depth, which lies in the texel's slab.
fn check_genuine(img: &Img, thick: f64, r: &Ray, h: &refl_core::DepthHit) {
    let p = r.origin.as_dvec3() + r.dir.as_dvec3() * h.t as f64;
    let (px, py, z) = img.project(p);
    let tol_px = 2e-3 * (1.0 + px.abs().max(py.abs()) * 1e-2) + 1e-3 * z.abs().max(1.0);
    assert!(
        (px - h.pixel.x as f64).abs() < 0.05 + tol_px
            && (py - h.pixel.y as f64).abs() < 0.05 + tol_px,
        "ray.at(t) projects to ({px}, {py}), hit says {:?}",
        h.pixel
    );
    assert!(
        (z - h.depth as f64).abs() <= 1e-3 * z,
        "depth {z} vs {}",
        h.depth
    );
    let (ix, iy) = (h.pixel.x.floor() as i64, h.pixel.y.floor() as i64);
    let zf = img.texel_z(ix, iy).expect("hit texel has a surface");
    assert!((h.surface_depth as f64 - zf).abs() <= img.ztol(zf));
    let rel = 1e-4 * zf + img.ztol(zf);
    assert!(
        h.depth as f64 >= zf - rel && h.depth as f64 <= zf + thick + rel,
        "hit depth {} outside slab [{zf}, {}]",
        h.depth,
        zf + thick
    );
}

#[test]
fn rays_toward_the_camera_hit_through_the_max_pyramid() {
    for conv in DepthConvention::ALL {
        let img = Img::new(
            camera(
                Vec3::new(0.0, 2.0, 6.0),
                Vec3::new(0.0, 1.5, -10.0),
                100.0,
                160,
                100,
            ),
            conv,
            room(1.0),
        );
        let pyr = img.pyramid();
        let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
        // From the back wall toward the camera, passing behind the box on
        // the floor (front face z = -2.5, 1.5 deep); with a thickness that
        // covers its depth, the ray enters the box's slab from behind, at
        // the farthest bound (zf + thickness).
        let mut hits = 0;
        for k in 0..20 {
            let o = DVec3::new(-1.75 + 0.02 * k as f64, 0.6, -9.9);
            let d = DVec3::new(0.0, 0.05, 1.0).normalize();
            let r = ray(o, d);
            let cz = img.cam.linear_depth(r.dir + r.origin) - img.cam.linear_depth(r.origin);
            assert!(cz < 0.0, "the ray must move toward the camera");
            let tr = try_trace_hiz(
                &hiz,
                Thickness::Constant(1.5),
                r,
                f32::INFINITY,
                &HiZOptions::default(),
            )
            .unwrap();
            let orc = oracle(&img, 1.5, o, d, f64::INFINITY);
            assert!(agrees(&tr, &orc), "{conv:?}: {tr:?} vs {orc:?}");
            if let Some(h) = tr.hit() {
                hits += 1;
                // Entered through the back of the slab.
                assert!((h.depth - (h.surface_depth + 1.5)).abs() < 2e-3 * h.depth);
                check_genuine(&img, 1.5, &r, h);
            }
        }
        assert!(hits >= 15, "{conv:?}: only {hits} hits");
    }
}

#[test]
fn thin_object_is_passed_behind_and_the_wall_is_hit() {
    for conv in DepthConvention::ALL {
        for far in [50.0f32, f32::INFINITY] {
            let img = Img::new(
                camera(
                    Vec3::new(0.0, 2.0, 6.0),
                    Vec3::new(0.0, 1.5, -10.0),
                    far,
                    200,
                    120,
                ),
                conv,
                room(1.0),
            );
            let pyr = img.pyramid();
            let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
            // From the left, across behind the thin pillar (x in [1, 1.3],
            // z in [-6.05, -5.95]) at z = -7, to the right wall x = 5.
            for k in 0..10 {
                let o = DVec3::new(-3.0, 1.0 + 0.1 * k as f64, -7.0);
                let d = DVec3::new(1.0, 0.0, 0.0);
                let r = ray(o, d);
                let thin = try_trace_hiz(
                    &hiz,
                    Thickness::Constant(0.2),
                    r,
                    f32::INFINITY,
                    &HiZOptions::default(),
                )
                .unwrap();
                let h = thin.hit().expect("hits the right wall");
                let p = r.at(h.t);
                assert!(
                    (p.x - 5.0).abs() < 0.1,
                    "{conv:?} {far}: hit at {p:?}, expected the right wall"
                );
                assert!(agrees(&thin, &oracle(&img, 0.2, o, d, f64::INFINITY)));
                // A solid pillar (infinite thickness) stops the ray at x = 1.
                let solid = try_trace_hiz(
                    &hiz,
                    Thickness::Constant(f32::INFINITY),
                    r,
                    f32::INFINITY,
                    &HiZOptions::default(),
                )
                .unwrap();
                let p = r.at(solid.hit().expect("hits the pillar").t);
                assert!((p.x - 1.0).abs() < 0.15, "{conv:?}: solid hit at {p:?}");
            }
        }
    }
}

#[test]
fn back_face_image_thickness_matches_oracle_of_constant_equivalent() {
    // Back faces at front + 0.3 everywhere equal a constant thickness 0.3.
    let conv = DepthConvention::ZeroToOne;
    let img = Img::new(
        camera(
            Vec3::new(0.0, 2.0, 6.0),
            Vec3::new(0.0, 1.5, -10.0),
            100.0,
            120,
            80,
        ),
        conv,
        room(1.0),
    );
    let (n, f) = (img.cam.near() as f64, img.cam.far() as f64);
    let back: Vec<f32> = img
        .depth
        .iter()
        .map(|&d| {
            let z = decode64(d as f64, n, f, conv);
            encode64(z + 0.3, n, f, conv) as f32
        })
        .collect();
    let bv = ImageView::try_new(&back, 120, 80, 120).unwrap();
    let pyr = img.pyramid();
    let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
    let mut rng = Rng(5);
    let rays = rays_for(&img, &mut rng, 200, 1.0);
    let mut ok = 0;
    for (r, tm) in &rays {
        let tb = try_trace_hiz(
            &hiz,
            Thickness::BackFaces(bv),
            *r,
            *tm,
            &HiZOptions::default(),
        )
        .unwrap();
        let o = oracle(&img, 0.3, r.origin.as_dvec3(), r.dir.as_dvec3(), *tm as f64);
        ok += agrees(&tb, &o) as usize;
        if let Some(h) = tb.hit() {
            // One extra fetch per level-0 texel tested.
            assert!(h.work.fetches >= 2);
        }
    }
    assert!(ok * 100 >= rays.len() * 99, "{ok}/{}", rays.len());
}

/// Rays whose projection runs exactly along pixel (and cell) boundaries,
/// axis-aligned in screen space, or starting exactly on cell corners.
/// A camera looking straight down -Z (world x/y lines map to image
/// rows/columns; 128x128: the center row/column are cell boundaries at
/// every level) at a back wall z = -5 (depth 10) with a box in front of it.
fn edge_scene(conv: DepthConvention) -> Img {
    let cam = Camera::try_look_at(
        Vec3::new(0.0, 0.0, 5.0),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::Y,
        90f32.to_radians(),
        0.1,
        100.0,
        128,
        128,
    )
    .unwrap();
    let scene = vec![
        Prim::Plane(DVec3::Z, 5.0),
        Prim::Box(DVec3::new(2.0, -1.0, -3.0), DVec3::new(3.0, 1.0, -2.0)),
    ];
    Img::new(cam, conv, scene)
}

#[test]
fn cell_edge_rays_never_stall() {
    for conv in DepthConvention::ALL {
        let img = edge_scene(conv);
        let pyr = img.pyramid();
        let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
        let mut ties = 0;
        let eye = img.eye();
        for (o, d) in [
            // In the plane y = 0 (image row boundary 64), moving +x, -x.
            (DVec3::new(-3.0, 0.0, -1.0), DVec3::new(1.0, 0.0, -0.2)),
            (DVec3::new(3.9, 0.0, -1.0), DVec3::new(-1.0, 0.0, -0.2)),
            // In the plane x = 0 (column boundary 64), moving +y, -y.
            (DVec3::new(0.0, -3.0, -1.0), DVec3::new(0.0, 1.0, -0.3)),
            (DVec3::new(0.0, 3.0, -1.0), DVec3::new(0.0, -1.0, -0.3)),
            // Exactly parallel to the image plane along a boundary.
            (DVec3::new(-4.0, 0.0, -1.0), DVec3::new(1.0, 0.0, 0.0)),
            (DVec3::new(4.0, 0.0, -1.0), DVec3::new(-1.0, 0.0, 0.0)),
            // Diagonal through cell corners (x = y).
            (DVec3::new(-2.0, -2.0, -1.0), DVec3::new(1.0, 1.0, -0.5)),
            (DVec3::new(2.0, 2.0, -1.0), DVec3::new(-1.0, -1.0, -0.5)),
            // Starting on the view axis (the corner of the four center
            // cells at every level), going away.
            (eye + DVec3::new(0.0, 0.0, -1.0), DVec3::new(1.0, 0.0, -1.0)),
            (
                eye + DVec3::new(0.0, 0.0, -1.0),
                DVec3::new(-1.0, -1.0, -1.0),
            ),
        ] {
            let r = ray(o, d);
            let (tr, st) = try_trace_hiz_stats(
                &hiz,
                Thickness::Constant(0.5),
                r,
                f32::INFINITY,
                &HiZOptions::default(),
            )
            .unwrap();
            ties += st.boundary_ties;
            assert!(
                !matches!(
                    tr,
                    Trace::Miss {
                        reason: Miss::OutOfSteps,
                        ..
                    }
                ),
                "{conv:?} {o:?} {d:?} stalled: {tr:?}"
            );
            // Bound: each iteration descends or advances one pixel.
            let levels = hiz.layout().level_count();
            assert!(tr.work().iterations <= (128 + 128) * (levels + 1));
            let lin = try_trace_hiz(
                &hiz,
                Thickness::Constant(0.5),
                r,
                f32::INFINITY,
                &HiZOptions {
                    prologue_steps: u32::MAX,
                    ..Default::default()
                },
            )
            .unwrap();
            assert!(same(&tr, &lin), "{conv:?} {o:?}: {tr:?} vs {lin:?}");
            let orc = oracle(
                &img,
                0.5,
                r.origin.as_dvec3(),
                r.dir.as_dvec3(),
                f64::INFINITY,
            );
            assert!(agrees(&tr, &orc), "{conv:?} {o:?}: {tr:?} vs {orc:?}");
            // A tiny cap stops it early, and only then.
            for cap in [0u32, 1, 2] {
                let t = try_trace_hiz(
                    &hiz,
                    Thickness::Constant(0.5),
                    r,
                    f32::INFINITY,
                    &HiZOptions {
                        max_iterations: cap,
                        prologue_steps: 0,
                        ..Default::default()
                    },
                )
                .unwrap();
                assert!(t.work().iterations <= cap);
            }
        }
        assert!(ties > 0, "the boundary cases were not exercised");
    }
}

#[test]
fn grazing_rays_and_rays_parallel_to_the_image_plane() {
    for conv in DepthConvention::ALL {
        let img = Img::new(
            camera(
                Vec3::new(0.0, 2.0, 6.0),
                Vec3::new(0.0, 1.0, -10.0),
                100.0,
                160,
                100,
            ),
            conv,
            room(1.0),
        );
        let pyr = img.pyramid();
        let eye = img.eye();
        let mut rays = Vec::new();
        // Grazing: just above the floor, nearly parallel to it.
        for k in 0..40 {
            let a = -1.0 + 0.05 * k as f64;
            rays.push((
                ray(DVec3::new(a, 0.02, 2.0), DVec3::new(0.1 * a, 0.001, -1.0)),
                f32::INFINITY,
            ));
        }
        // Parallel to the image plane: perpendicular to the view axis.
        let fwd = (DVec3::new(0.0, 1.0, -10.0) - eye).normalize();
        let right = fwd.cross(DVec3::Y).normalize();
        let up = right.cross(fwd);
        for k in 0..40 {
            let o = eye + fwd * (3.0 + 0.1 * k as f64);
            let d = (right * (k as f64 - 20.0)).normalize_or(up) + up * 0.3 * (k % 3) as f64;
            rays.push((ray(o, d), f32::INFINITY));
        }
        let (a, n) = agreement(&img, &pyr, 0.3, &rays);
        assert!(a * 100 >= n * 95, "{conv:?}: {a}/{n}");
    }
}

#[test]
fn rays_along_the_view_axis_project_to_one_pixel() {
    for conv in DepthConvention::ALL {
        for far in [100.0f32, f32::INFINITY] {
            let img = Img::new(
                camera(
                    Vec3::new(0.0, 2.0, 6.0),
                    Vec3::new(0.0, 1.0, -10.0),
                    far,
                    64,
                    48,
                ),
                conv,
                room(1.0),
            );
            let pyr = img.pyramid();
            let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
            for (x, y) in [(10.5, 7.5), (32.0, 24.0), (60.25, 3.75)] {
                let pr = img.cam.primary_ray(glam::Vec2::new(x, y));
                let r = Ray {
                    origin: pr.origin + pr.dir * 0.5,
                    dir: pr.dir,
                };
                let tr = try_trace_hiz(
                    &hiz,
                    Thickness::Constant(0.1),
                    r,
                    f32::INFINITY,
                    &HiZOptions::default(),
                )
                .unwrap();
                let h = tr.hit().expect("hits the surface behind the pixel");
                // The projected ray is one point: the hit is there (to f32
                // rounding; (32, 24) is a pixel corner, where rounding picks
                // the texel).
                let p = glam::Vec2::new(x, y);
                assert!(
                    (h.pixel - p).abs().max_element() < 1e-3,
                    "{:?} vs {p:?}",
                    h.pixel
                );
                if p.fract() != glam::Vec2::ZERO {
                    assert_eq!(h.pixel.floor(), p.floor());
                }
                let (hx, hy) = (h.pixel.x.floor() as i64, h.pixel.y.floor() as i64);
                let texel_z = img.texel_z(hx, hy).unwrap();
                // The hit is where the ray reaches the texel's depth.
                assert!((h.depth as f64 - texel_z).abs() <= 1e-3 * texel_z);
                assert!(h.work.fetches < 40, "{:?}", h.work);
            }
        }
    }
}

#[test]
fn invalid_input_is_rejected_and_outputs_untouched() {
    let img = Img::new(
        camera(Vec3::new(0.0, 2.0, 6.0), Vec3::ZERO, 100.0, 16, 12),
        DepthConvention::Linear,
        room(1.0),
    );
    let pyr = img.pyramid();
    let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
    let good = ray(DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, 0.0, -1.0));
    let o = HiZOptions::default();
    let th = Thickness::Constant(0.1);
    for bad in [
        Ray {
            origin: Vec3::new(f32::NAN, 0.0, 0.0),
            ..good
        },
        Ray {
            origin: Vec3::new(f32::INFINITY, 0.0, 0.0),
            ..good
        },
        Ray {
            dir: Vec3::new(0.0, f32::NAN, -1.0),
            ..good
        },
        Ray {
            dir: Vec3::new(0.0, 0.0, -2.0),
            ..good
        },
        Ray {
            dir: Vec3::ZERO,
            ..good
        },
    ] {
        assert_eq!(
            try_trace_hiz(&hiz, th, bad, 1.0, &o),
            Err(Error::InvalidArgument)
        );
    }
    for tm in [f32::NAN, 0.0, -1.0] {
        assert_eq!(
            try_trace_hiz(&hiz, th, good, tm, &o),
            Err(Error::InvalidArgument)
        );
    }
    for t in [f32::NAN, -0.5, f32::NEG_INFINITY] {
        assert_eq!(
            try_trace_hiz(&hiz, Thickness::Constant(t), good, 1.0, &o),
            Err(Error::InvalidArgument)
        );
    }
    let small = [0.0f32; 4];
    let bv = ImageView::try_new(&small, 2, 2, 2).unwrap();
    assert_eq!(
        try_trace_hiz(&hiz, Thickness::BackFaces(bv), good, 1.0, &o),
        Err(Error::InvalidArgument)
    );
    // Batch: a bad ray anywhere, a short output or t_max: nothing written.
    let sentinel = Trace::Miss {
        reason: Miss::EndOfRay,
        work: refl_core::Work {
            steps: 99,
            fetches: 99,
            iterations: 99,
        },
    };
    let mut out = [sentinel; 3];
    let bad = Ray {
        dir: Vec3::new(0.0, f32::NAN, -1.0),
        ..good
    };
    assert_eq!(
        try_trace_hiz_rays(&mut out, &hiz, th, &[good, good, bad], &[1.0], &o),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_trace_hiz_rays(&mut out[..2], &hiz, th, &[good, good, good], &[1.0], &o),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_trace_hiz_rays(&mut out, &hiz, th, &[good, good, good], &[1.0, 2.0], &o),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_trace_hiz_rays(&mut out, &hiz, th, &[good], &[], &o),
        Err(Error::InvalidArgument)
    );
    assert!(out.iter().all(|t| *t == sentinel));
    // A valid batch equals single traces.
    let rays = [
        good,
        ray(DVec3::new(0.5, 1.0, 1.0), DVec3::new(0.2, -0.3, -1.0)),
    ];
    try_trace_hiz_rays(&mut out, &hiz, th, &rays, &[f32::INFINITY, 3.0], &o).unwrap();
    assert_eq!(
        out[0],
        try_trace_hiz(&hiz, th, rays[0], f32::INFINITY, &o).unwrap()
    );
    assert_eq!(out[1], try_trace_hiz(&hiz, th, rays[1], 3.0, &o).unwrap());
    assert_eq!(out[2], sentinel);
}

#[test]
fn degenerate_projection_and_miss_reasons() {
    let img = Img::new(
        camera(
            Vec3::new(0.0, 2.0, 6.0),
            Vec3::new(0.0, 2.0, -10.0),
            100.0,
            32,
            24,
        ),
        DepthConvention::ReversedZ,
        open_scene(),
    );
    let pyr = img.pyramid();
    let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
    let th = Thickness::Constant(0.5);
    let o = HiZOptions::default();
    // Entirely behind the camera.
    let behind = ray(DVec3::new(0.0, 2.0, 8.0), DVec3::new(0.0, 0.0, 1.0));
    let tr = try_trace_hiz(&hiz, th, behind, f32::INFINITY, &o).unwrap();
    assert!(matches!(
        tr,
        Trace::Miss {
            reason: Miss::DegenerateProjection,
            ..
        }
    ));
    // Leaves through the top (background above the wall): LeftImage.
    let up = ray(DVec3::new(0.0, 2.5, 0.0), DVec3::new(0.0, 1.0, -0.2));
    let tr = try_trace_hiz(&hiz, th, up, f32::INFINITY, &o).unwrap();
    assert!(
        matches!(
            tr,
            Trace::Miss {
                reason: Miss::LeftImage,
                ..
            }
        ),
        "{tr:?}"
    );
    // Ends short of everything: EndOfRay.
    let short = ray(DVec3::new(0.0, 2.0, 0.0), DVec3::new(0.0, 0.0, -1.0));
    let tr = try_trace_hiz(&hiz, th, short, 1.0, &o).unwrap();
    assert!(
        matches!(
            tr,
            Trace::Miss {
                reason: Miss::EndOfRay,
                ..
            }
        ),
        "{tr:?}"
    );
    // Ends behind the box (deeper than its thickness): BehindGeometry.
    let into = ray(DVec3::new(1.25, 3.0, -3.0), DVec3::new(0.0, -0.6, -1.0));
    let tr = try_trace_hiz(&hiz, Thickness::Constant(0.01), into, 3.5, &o).unwrap();
    assert!(
        matches!(
            tr,
            Trace::Miss {
                reason: Miss::BehindGeometry,
                ..
            }
        ),
        "{tr:?}"
    );
}

#[test]
fn one_by_one_image() {
    for conv in DepthConvention::ALL {
        let cam = camera(
            Vec3::new(0.0, 1.0, 5.0),
            Vec3::new(0.0, 1.0, 0.0),
            100.0,
            1,
            1,
        );
        let img = Img::new(cam, conv, vec![Prim::Plane(DVec3::Z, 0.0)]);
        assert_eq!(try_hiz_len(1, 1), Ok(1 + HIZ_STAMP_TEXELS));
        let pyr = img.pyramid();
        assert_eq!(pyr.len(), 1 + HIZ_STAMP_TEXELS);
        assert!((pyr[0][0] - 5.0).abs() < 1e-4 && pyr[0][0] == pyr[0][1]);
        let hiz = HiZ::try_new(&pyr, cam, conv).unwrap();
        let r = ray(DVec3::new(0.0, 1.0, 3.0), DVec3::new(0.0, 0.0, -1.0));
        let tr = try_trace_hiz(
            &hiz,
            Thickness::Constant(0.1),
            r,
            f32::INFINITY,
            &HiZOptions {
                start_level: 7,
                ..Default::default()
            },
        )
        .unwrap();
        let h = tr.hit().expect("hits the plane");
        assert!((h.t - 3.0).abs() < 1e-3, "{h:?}");
        assert_eq!(h.pixel.floor(), glam::Vec2::ZERO);
    }
}

#[test]
fn start_level_beyond_the_pyramid_clamps() {
    let img = Img::new(
        camera(
            Vec3::new(0.5, 2.0, 6.0),
            Vec3::new(-0.5, 0.8, -6.0),
            100.0,
            90,
            70,
        ),
        DepthConvention::ZeroToOne,
        room(1.0),
    );
    let pyr = img.pyramid();
    let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
    let top = hiz.layout().level_count() - 1;
    let mut rng = Rng(3);
    for (r, tm) in rays_for(&img, &mut rng, 60, 1.0) {
        let th = Thickness::Constant(0.3);
        let a = try_trace_hiz(
            &hiz,
            th,
            r,
            tm,
            &HiZOptions {
                start_level: 100,
                stop_level: 100,
                ..Default::default()
            },
        )
        .unwrap();
        let b = try_trace_hiz(
            &hiz,
            th,
            r,
            tm,
            &HiZOptions {
                start_level: top,
                stop_level: top,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(a, b);
        let c = try_trace_hiz(
            &hiz,
            th,
            r,
            tm,
            &HiZOptions {
                start_level: 100,
                ..Default::default()
            },
        )
        .unwrap();
        let d = try_trace_hiz(
            &hiz,
            th,
            r,
            tm,
            &HiZOptions {
                start_level: top,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(c, d);
        assert!(same(&a, &c));
    }
}

#[test]
fn scaled_scenes_agree_with_oracle() {
    for scale in [1e-3f64, 1e4] {
        for conv in DepthConvention::ALL {
            let s = scale as f32;
            let cam = Camera::try_look_at(
                Vec3::new(0.5, 2.0, 6.0) * s,
                Vec3::new(-0.5, 0.8, -6.0) * s,
                Vec3::Y,
                60f32.to_radians(),
                0.1 * s,
                f32::INFINITY,
                120,
                80,
            )
            .unwrap();
            let img = Img::new(cam, conv, room(scale));
            let pyr = img.pyramid();
            let mut rng = Rng(21);
            let rays = rays_for(&img, &mut rng, 120, scale);
            let (a, n) = agreement(&img, &pyr, 0.25 * s, &rays);
            assert!(a * 100 >= n * 99, "scale {scale} {conv:?}: {a}/{n}");
        }
    }
}

/// Long rays (projected length > 256 pixels) over the room: Hi-Z reads at
/// least 10x fewer depth texels than unit stepping.
#[test]
fn hiz_fetches_ten_times_fewer_texels_than_unit_stepping_on_long_rays() {
    let img = Img::new(
        camera(
            Vec3::new(0.0, 2.5, 9.0),
            Vec3::new(0.0, 1.2, -10.0),
            f32::INFINITY,
            640,
            480,
        ),
        DepthConvention::ReversedZ,
        room(1.0),
    );
    let pyr = img.pyramid();
    let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
    let eye = img.eye();
    let mut rng = Rng(9);
    let (mut hiz_f, mut lin_f, mut n, mut agree) = (0u64, 0u64, 0, 0);
    #[allow(unused_mut)]
    let mut step_f = 0u64;
    let mut ratios = Vec::new();
    while n < 100 {
        // Reflection rays off the floor in the lower half of the image.
        let (x, y) = (rng.range(100.0, 540.0), rng.range(300.0, 479.0));
        let Some((p, nrm)) = img.surface(x, y) else {
            continue;
        };
        if nrm != DVec3::Y {
            continue;
        }
        let v = (p - eye).normalize();
        let d = (v - 2.0 * v.dot(nrm) * nrm + rng.unit() * 0.1).normalize();
        let r = ray(p + nrm * 0.01, d);
        let th = Thickness::Constant(f32::INFINITY);
        let lin = try_trace_hiz(
            &hiz,
            th,
            r,
            f32::INFINITY,
            &HiZOptions {
                prologue_steps: u32::MAX,
                ..Default::default()
            },
        )
        .unwrap();
        let Some(lh) = lin.hit() else { continue };
        let (sx, sy, _) = img.project(r.origin.as_dvec3());
        let len = (lh.pixel.x as f64 - sx)
            .abs()
            .max((lh.pixel.y as f64 - sy).abs());
        if len <= 256.0 {
            continue;
        }
        let h = try_trace_hiz(&hiz, th, r, f32::INFINITY, &HiZOptions::default()).unwrap();
        agree += same(&h, &lin) as usize;
        #[cfg(feature = "depth-image")]
        {
            let st =
                refl_core::try_step(&img.depth_image(), th, r, f32::INFINITY, Default::default())
                    .unwrap();
            assert!(same(&h, &st), "{h:?} vs step {st:?}");
            step_f += st.work().fetches as u64;
        }
        hiz_f += h.work().fetches as u64;
        lin_f += lin.work().fetches as u64;
        ratios.push(lin.work().fetches as f64 / h.work().fetches as f64);
        n += 1;
    }
    ratios.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let ratio = lin_f as f64 / hiz_f as f64;
    eprintln!(
        "long rays: unit stepping {lin_f} fetches, Hi-Z {hiz_f}: ratio {ratio:.1} (median {:.1}, min {:.1}); agree {agree}/{n}",
        ratios[ratios.len() / 2],
        ratios[0]
    );
    assert_eq!(agree, n);
    assert!(ratio >= 10.0, "ratio {ratio}");
    #[cfg(feature = "depth-image")]
    {
        eprintln!(
            "refl_core::step on the same rays: {step_f} fetches, ratio {:.1}",
            step_f as f64 / hiz_f as f64
        );
        assert!(step_f >= 10 * hiz_f, "step {step_f} vs hiz {hiz_f}");
    }
    let _ = step_f;
}

/// Against the per-pixel stepping kernel of `refl_core::step` (seed 003
/// Sec. 3.4) on the same rays and thickness: same hit within one pixel on
/// at least 99% of the rays (the fetch ratio against it is asserted in
/// `hiz_fetches_ten_times_fewer_texels_than_unit_stepping_on_long_rays`).
#[cfg(feature = "depth-image")]
#[test]
fn agrees_with_per_pixel_stepping() {
    use refl_core::{try_step, StepOptions};
    let (mut ok, mut n) = (0, 0);
    for far in [60.0f32, f32::INFINITY] {
        for conv in DepthConvention::ALL {
            let img = Img::new(
                camera(
                    Vec3::new(0.5, 2.0, 6.0),
                    Vec3::new(-0.5, 0.8, -6.0),
                    far,
                    320,
                    200,
                ),
                conv,
                room(1.0),
            );
            let pyr = img.pyramid();
            let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
            let di = img.depth_image();
            let mut rng = Rng(1234 + conv as u64);
            for (r, tm) in rays_for(&img, &mut rng, 200, 1.0) {
                for thick in [0.25f32, f32::INFINITY] {
                    let th = Thickness::Constant(thick);
                    let a = try_trace_hiz(&hiz, th, r, tm, &HiZOptions::default()).unwrap();
                    let b = try_step(&di, th, r, tm, StepOptions::default()).unwrap();
                    n += 1;
                    if same(&a, &b) {
                        ok += 1;
                    } else {
                        eprintln!("hiz {a:?} vs step {b:?}");
                    }
                }
            }
        }
    }
    eprintln!("hiz vs step: {ok}/{n}");
    assert!(ok * 100 >= n * 99, "{ok}/{n}");
}

/// Issue 12: a pyramid carries the size and camera it was built for; bound
/// to another camera (another size, another pose, or never built) it is an
/// error, not a pyramid that every ray misses.
#[test]
fn pyramid_stamp_refuses_another_camera() {
    let conv = DepthConvention::ReversedZ;
    let big = camera(
        Vec3::new(0.0, 2.0, 6.0),
        Vec3::new(0.0, 1.0, -5.0),
        100.0,
        512,
        384,
    );
    let small = camera(
        Vec3::new(0.0, 2.0, 6.0),
        Vec3::new(0.0, 1.0, -5.0),
        100.0,
        256,
        192,
    );
    let moved = camera(
        Vec3::new(0.1, 2.0, 6.0),
        Vec3::new(0.0, 1.0, -5.0),
        100.0,
        512,
        384,
    );
    let img = Img::new(big, conv, room(1.0));
    let pyr = img.pyramid();
    assert_eq!(pyr.len(), try_hiz_len(512, 384).unwrap());
    assert!(HiZ::try_new(&pyr, big, conv).is_ok());
    // The buffer is long enough for the small camera, but not its pyramid.
    assert_eq!(
        HiZ::try_new(&pyr, small, conv).err(),
        Some(Error::InvalidArgument)
    );
    assert_eq!(
        HiZ::try_new(&pyr, moved, conv).err(),
        Some(Error::InvalidArgument)
    );
    // What the stamp says, for diagnostics.
    let tail = PyramidStamp::read_tail(&pyr).unwrap();
    assert_eq!((tail.width, tail.height), (512, 384));
    assert_eq!(tail, PyramidStamp::of(&big));
    assert_ne!(big.fingerprint(), moved.fingerprint());
    assert_eq!(
        big.fingerprint(),
        camera(
            Vec3::new(0.0, 2.0, 6.0),
            Vec3::new(0.0, 1.0, -5.0),
            100.0,
            512,
            384
        )
        .fingerprint()
    );
    // Never built: refused.
    let blank = vec![[0.0f32; 2]; pyr.len()];
    assert_eq!(
        HiZ::try_new(&blank, big, conv).err(),
        Some(Error::InvalidArgument)
    );
    // Short: InsufficientSize before the stamp is looked at.
    assert_eq!(
        HiZ::try_new(&pyr[..pyr.len() - 1], big, conv).err(),
        Some(Error::InsufficientSize)
    );
    // A longer buffer (reused at a larger size) is fine: the stamp sits
    // where the camera's layout ends.
    let mut long = pyr.clone();
    long.extend_from_slice(&[[1.0, 2.0]; 9]);
    assert!(HiZ::try_new(&long, big, conv).is_ok());
    // Stamping a too-short buffer writes nothing.
    let mut short = vec![[5.0f32; 2]; try_hiz_len(512, 384).unwrap() - 1];
    assert_eq!(
        try_stamp_hiz(&mut short, &big),
        Err(Error::InsufficientSize)
    );
    assert!(short.iter().all(|t| *t == [5.0, 5.0]));
}

/// Regression (scripts/explore.sh): a reflection ray leaving the floor
/// touches its own texel's zero-thickness slab 3e-5 px before the texel's
/// edge, where the f32 position already rounds onto the edge. Descending
/// from a coarser level moved the frontier past the texel by position and
/// skipped the hit; every option setting now finds the oracle's hit.
#[test]
fn zero_thickness_hit_in_the_last_sliver_of_a_texel() {
    let conv = DepthConvention::ALL[1];
    let (ex, ey) = (0.07972314f32, 0.8701805f32);
    let img = Img::new(
        camera(
            Vec3::new(ex, ey, 7.0),
            Vec3::new(-ex, 1.0, -8.0),
            40.0,
            97,
            61,
        ),
        conv,
        room(1.0),
    );
    let pyr = img.pyramid();
    let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
    let mut rng = Rng(16996242128816185205);
    let (r, tm) = rays_for(&img, &mut rng, 20, 1.0)[7];
    let orc =
        oracle(&img, 0.0, r.origin.as_dvec3(), r.dir.as_dvec3(), tm as f64).expect("oracle hit");
    assert!(
        orc.t < 0.03,
        "the case: a hit right after the start, t = {}",
        orc.t
    );
    for stop in 0..4 {
        for start in stop..5 {
            for prologue_steps in [0, 1, 2] {
                let o = HiZOptions {
                    stop_level: stop,
                    start_level: start,
                    prologue_steps,
                    ..Default::default()
                };
                let tr = try_trace_hiz(&hiz, Thickness::Constant(0.0), r, tm, &o).unwrap();
                let h = tr.hit().unwrap_or_else(|| panic!("{o:?}: {tr:?}"));
                assert!(
                    (f64::from(h.t) - orc.t).abs() < 1e-4,
                    "{o:?}: t {} vs oracle {}",
                    h.t,
                    orc.t
                );
            }
        }
    }
}

/// Fuzz finding F14: with a near plane of 1.6e-33 a ray starting at the eye
/// is clipped to `q0 = 1 / near = 6e32`, and `q0 + s (q1 - q0)` at `s = 1`
/// lost `q1`: a hit at the segment's end reported depth `1 / 0 = inf`. The
/// hit's depth is finite and is the ray's depth at the hit.
#[test]
fn tiny_near_plane_hit_at_the_segment_end_has_a_finite_depth() {
    let view = glam::Mat4::from_cols_array(&[
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.9363292,
        0.35112345,
        0.0,
        0.0,
        -0.35112345,
        0.9363292,
        0.0,
        0.0,
        0.0,
        -4.2720017,
        1.0,
    ]);
    let cam = Camera::try_new(view, 1.0, 1.649_077_5e-33, 100.0, 10, 10).unwrap();
    let ray = Ray {
        origin: Vec3::new(0.0, 1.5, 4.0),
        dir: Vec3::new(0.43017733, -0.68145996, -0.59208095),
    };
    let mut hits = 0;
    for conv in DepthConvention::ALL {
        // Every texel holds a surface at linear depth 9.56 (fronto-parallel).
        let depth = vec![cam.encode_depth(9.56353, conv); 100];
        let img = DepthImage::try_new(ImageView::try_new(&depth, 10, 10, 10).unwrap(), cam, conv)
            .unwrap();
        let mut pyr = vec![[0.0; 2]; try_hiz_len(10, 10).unwrap()];
        try_build_hiz(&mut pyr, &img).unwrap();
        let hiz = HiZ::try_new(&pyr, cam, conv).unwrap();
        for t_max in [49.804314f32, 20.0, 15.0, 12.0, f32::INFINITY] {
            for th in [
                Thickness::Constant(f32::INFINITY),
                Thickness::Constant(100.0),
            ] {
                let tr = try_trace_hiz(&hiz, th, ray, t_max, &HiZOptions::default()).unwrap();
                if let Some(h) = tr.hit() {
                    hits += 1;
                    assert!(
                        h.depth.is_finite() && h.t.is_finite() && h.t <= t_max,
                        "{conv:?} {t_max}: {tr:?}"
                    );
                    let z = -(cam.view().as_dmat4().transform_point3(
                        ray.origin.as_dvec3() + ray.dir.as_dvec3() * f64::from(h.t),
                    ))
                    .z;
                    assert!(
                        (f64::from(h.depth) - z).abs() <= 1e-3 * z,
                        "{conv:?} {t_max}: depth {} vs ray depth {z}",
                        h.depth
                    );
                }
            }
        }
    }
    assert!(hits > 0);
}

#[test]
fn pyramid_bands_are_the_rows_and_the_finer_level() {
    let layout = HiZLayout::try_new(37, 23).unwrap();
    let len = layout.len();
    for level in 0..layout.level_count() {
        let lv = layout.level(level).unwrap();
        for (a, b) in [(0, lv.height), (lv.height / 2, lv.height)] {
            let Ok(rows) = RowRange::try_new(a, b, lv.height) else {
                continue;
            };
            let band = layout.try_band(level, rows, len).unwrap();
            // Closed form: rows a..b of the level, row stride = its width.
            let w = lv.width as usize;
            assert_eq!(
                band.band,
                lv.offset + a as usize * w..lv.offset + b as usize * w
            );
            let finer = (level > 0).then(|| layout.level(level - 1).unwrap().range());
            assert_eq!(band.finer, finer);
            if let Some(f) = &band.finer {
                assert!(f.end <= band.band.start, "the finer level lies before");
            }
            // The slices of one buffer are those ranges.
            let mut buf: Vec<u32> = (0..len as u32).collect();
            let (out, fin) = layout.try_split_band(&mut buf, level, rows).unwrap();
            assert_eq!(out.first().copied(), Some(band.band.start as u32));
            assert_eq!(out.len(), band.band.len());
            assert_eq!(
                fin.map(|f| (f[0], f.len())),
                finer.map(|f| (f.start as u32, f.len()))
            );
        }
    }
    // A level past the last, rows beyond the level, a short buffer.
    let last = layout.level_count();
    let one = RowRange::try_new(0, 1, 1).unwrap();
    assert_eq!(layout.try_band(last, one, len), Err(Error::InvalidArgument));
    let tall = RowRange::try_new(0, 12, 23).unwrap();
    assert_eq!(layout.try_band(1, tall, len), Err(Error::InvalidArgument));
    assert_eq!(
        layout.try_band(0, tall, len - 1),
        Err(Error::InsufficientSize)
    );
    let mut short = vec![0u8; len - 1];
    assert_eq!(
        layout.try_split_band(&mut short, 0, tall).err(),
        Some(Error::InsufficientSize)
    );
}

/// The step target's F31 case (`core/tests/step.rs`,
/// `near_vanishing_point_finite_segment_reports_the_depth_it_crossed`)
/// through Hi-Z: a finite segment nearly reaching its vanishing point,
/// a surface at 6.65e6 seen from depth about 3; the hit's depth and `t`
/// stay on the surface.
#[test]
fn near_vanishing_point_finite_segment_hit_depth() {
    let (cam, ray, th) = common::f31_case();
    let (w, h) = (cam.width(), cam.height());
    let mut hits = 0;
    for conv in DepthConvention::ALL {
        let data = vec![cam.encode_depth(common::F31_SURFACE, conv); (w * h) as usize];
        let img =
            DepthImage::try_new(ImageView::try_new(&data, w, h, w).unwrap(), cam, conv).unwrap();
        let mut pyr = vec![[0.0f32; 2]; try_hiz_len(w, h).unwrap()];
        try_build_hiz(&mut pyr, &img).unwrap();
        let hiz = HiZ::try_new(&pyr, cam, conv).unwrap();
        let tr = try_trace_hiz(
            &hiz,
            Thickness::Constant(th),
            ray,
            1e30,
            &HiZOptions::default(),
        )
        .unwrap();
        let Some(hit) = tr.hit() else { continue };
        hits += 1;
        let tol = 1e-3 * hit.surface_depth;
        assert!(
            hit.depth >= hit.surface_depth - tol && hit.depth <= hit.surface_depth + th + tol,
            "{conv:?}: {hit:?}"
        );
        let z_at_t = cam.linear_depth(ray.at(hit.t));
        assert!(
            (z_at_t - hit.depth).abs() <= 1e-3 * hit.depth,
            "{conv:?}: z(t) {z_at_t} vs {hit:?}"
        );
    }
    assert!(hits > 0, "the case hits");
}

/// Fuzz finding F39 (F6's rounding, in Hi-Z): a near plane of 7.5e-27 and
/// an infinite far plane clip the ray to `q` from `1 / near = 1.3e26` down
/// to 0 at its vanishing point. A surface at depth 39.7 is entered at
/// `s = 1 - 2e-28`, which rounds to 1, where `1 / q` is infinite: the hit
/// came back with `t = depth = inf`. The hit's depth is the surface's (the
/// ray enters its front) and `t` the ray parameter at that depth.
#[test]
fn tiny_near_plane_infinite_far_hit_has_the_surface_depth_and_a_finite_t() {
    let view = glam::Mat4::from_cols_array(&[
        6.735667e-29,
        6.938375e-29,
        -1.0,
        0.0,
        -0.0,
        1.0,
        6.938375e-29,
        0.0,
        1.0,
        -0.0,
        6.735667e-29,
        0.0,
        -2.6993818,
        -3.9425864,
        -1.0952567e-18,
        1.0,
    ]);
    let cam = Camera::try_new(view, 2.0447059, 7.483172e-27, f32::INFINITY, 1, 18).unwrap();
    let ray = Ray {
        origin: Vec3::new(-1.0952567e-18, 3.9425864, 2.6993818),
        dir: Vec3::new(0.9905635, -0.1266419, -0.052399803),
    };
    let surface = 39.670746f32;
    let mut hits = 0;
    for conv in DepthConvention::ALL {
        let depth = vec![cam.encode_depth(surface, conv); 18];
        let img =
            DepthImage::try_new(ImageView::try_new(&depth, 1, 18, 1).unwrap(), cam, conv).unwrap();
        let z = img.linear_at(0, 9).unwrap();
        if z.is_infinite() {
            // ZeroToOne with an infinite far plane: `1 - near / z` rounds
            // to 1, the encoding of "no surface".
            assert_eq!(conv, DepthConvention::ZeroToOne);
            continue;
        }
        let mut pyr = vec![[0.0; 2]; try_hiz_len(1, 18).unwrap()];
        try_build_hiz(&mut pyr, &img).unwrap();
        let hiz = HiZ::try_new(&pyr, cam, conv).unwrap();
        for t_max in [f32::INFINITY, 1e30, 100.0] {
            for th in [
                Thickness::Constant(f32::INFINITY),
                Thickness::Constant(1.0),
                Thickness::Constant(0.0),
            ] {
                let tr = try_trace_hiz(&hiz, th, ray, t_max, &HiZOptions::default()).unwrap();
                let h = tr
                    .hit()
                    .unwrap_or_else(|| panic!("{conv:?} {t_max}: {tr:?}"));
                hits += 1;
                assert!(
                    h.depth.is_finite() && h.t.is_finite() && h.t <= t_max,
                    "{conv:?} {t_max}: {tr:?}"
                );
                assert!((h.depth - z).abs() <= 1e-6 * z, "{conv:?} {t_max}: {tr:?}");
                // Oracle: the ray's depth at `t`, in f64.
                let zt = -(cam
                    .view()
                    .as_dmat4()
                    .transform_point3(ray.origin.as_dvec3() + ray.dir.as_dvec3() * f64::from(h.t)))
                .z;
                assert!(
                    (zt - f64::from(z)).abs() <= 1e-5 * f64::from(z),
                    "{conv:?} {t_max}: t {} has ray depth {zt}, surface {z}",
                    h.t
                );
            }
        }
    }
    assert_eq!(hits, 2 * 3 * 3);
}

// ---------------------------------------------------------------- AVX2 stream

/// Every word of a trace, floats as bits: equal words are equal results.
fn trace_bits(t: &Trace) -> Vec<u32> {
    match t {
        Trace::Hit(h) => vec![
            0,
            h.pixel.x.to_bits(),
            h.pixel.y.to_bits(),
            h.t.to_bits(),
            h.depth.to_bits(),
            h.surface_depth.to_bits(),
            h.work.steps,
            h.work.fetches,
            h.work.iterations,
        ],
        Trace::Miss { reason, work } => {
            vec![1, *reason as u32, work.steps, work.fetches, work.iterations]
        }
    }
}

/// The batch call (the AVX2 ray stream where the CPU has AVX2) returns the
/// scalar walk's results bit for bit: every depth convention, finite and
/// infinite far planes, rendered scenes and random depth images with
/// holes, background and negative depths, odd and one-pixel-wide sizes, a
/// tiny near plane, thicknesses 0 to infinity, prologue lengths 0 to
/// `u32::MAX`, start levels 0 to past the top, caps that end walks with
/// `OutOfSteps`, rays that project to nothing, one `t_max` and one per
/// ray, batches below and above the stream's minimum.
#[test]
fn batch_stream_equals_the_scalar_walk_bit_for_bit() {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        assert_eq!(refl_core::hiz_stream_lanes(), 8, "the stream runs here");
    }
    let options = [
        HiZOptions::default(),
        HiZOptions {
            start_level: 0,
            prologue_steps: 0,
            ..HiZOptions::default()
        },
        HiZOptions {
            start_level: 40,
            prologue_steps: 1,
            ..HiZOptions::default()
        },
        HiZOptions {
            prologue_steps: u32::MAX,
            ..HiZOptions::default()
        },
        HiZOptions {
            max_iterations: 3,
            prologue_steps: 0,
            start_level: 5,
            ..HiZOptions::default()
        },
        HiZOptions {
            max_iterations: 0,
            ..HiZOptions::default()
        },
    ];
    let mut rng = Rng(0x5EED_57E4);
    let mut compared = 0usize;
    let mut hits = 0usize;
    let mut misses = std::collections::BTreeSet::new();
    let mut check = |img: &Img, rays: &[(Ray, f32)], rng: &mut Rng| {
        let pyr = img.pyramid();
        let hiz = HiZ::try_new(&pyr, img.cam, img.conv).unwrap();
        let rs: Vec<Ray> = rays.iter().map(|r| r.0).collect();
        let tm: Vec<f32> = rays.iter().map(|r| r.1).collect();
        for o in &options {
            for th in [0.0f32, 0.25, 3.0, f32::INFINITY] {
                let th = Thickness::Constant(th);
                // Per-ray t_max, then one t_max for all; batches below and at the
                // stream's minimum (8 rays) too.
                for (n, t) in [
                    (rs.len(), &tm[..]),
                    (rs.len(), &tm[..1]),
                    (5, &tm[..5]),
                    (9, &tm[..9]),
                ] {
                    let mut a = vec![
                        Trace::Miss {
                            reason: Miss::LeftImage,
                            work: Default::default()
                        };
                        n
                    ];
                    let mut b = a.clone();
                    try_trace_hiz_rays(&mut a, &hiz, th, &rs[..n], t, o).unwrap();
                    refl_core::try_trace_hiz_rays_scalar(&mut b, &hiz, th, &rs[..n], t, o).unwrap();
                    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
                        assert_eq!(
                            trace_bits(x),
                            trace_bits(y),
                            "ray {i} {:?} t_max {} {o:?} {th:?} {:?}: stream {x:?} scalar {y:?}",
                            rs[i],
                            t[if t.len() == 1 { 0 } else { i }],
                            img.conv
                        );
                        compared += 1;
                        hits += usize::from(x.hit().is_some());
                        if let Trace::Miss { reason, .. } = x {
                            misses.insert(*reason as u32);
                        }
                    }
                }
            }
        }
        let _ = rng;
    };
    for conv in DepthConvention::ALL {
        for far in [60.0f32, f32::INFINITY] {
            for (w, h) in [(160u32, 96u32), (37, 23), (1, 18), (200, 1)] {
                let cam = camera(
                    Vec3::new(0.5, 2.0, 6.0),
                    Vec3::new(-0.5, 0.8, -6.0),
                    far,
                    w,
                    h,
                );
                let img = Img::new(cam, conv, room(1.0));
                let mut rays = rays_for(&img, &mut rng, 60, 1.0);
                // Axis-aligned, toward the camera, behind it (no
                // projection), along the view axis.
                let eye = img.eye();
                rays.push((ray(DVec3::new(0.0, 1.0, 0.0), DVec3::X), f32::INFINITY));
                rays.push((ray(DVec3::new(0.0, 1.0, -3.0), DVec3::Y), 5.0));
                rays.push((ray(DVec3::new(0.0, 1.0, -8.0), DVec3::Z), f32::INFINITY));
                rays.push((ray(eye + DVec3::Z, DVec3::Z), f32::INFINITY));
                rays.push((
                    ray(eye, (DVec3::new(-0.5, 0.8, -6.0) - eye).normalize()),
                    40.0,
                ));
                check(&img, &rays, &mut rng);
                // A random depth image of the same camera: holes,
                // background, negative depths.
                let mut noisy = Img::new(cam, conv, room(1.0));
                noisy.depth = random_depths(&mut rng, w, h, &cam, conv);
                check(&noisy, &rays, &mut rng);
            }
        }
        // Rays along pixel boundaries and through pixel corners (`edge_scene`:
        // 90 degrees, 128 pixels, so at depth 6 a pixel is 3/32 wide),
        // where the frontier's one-pixel exit rule decides.
        let img = edge_scene(conv);
        let px = 3.0 / 32.0;
        let mut rays = Vec::new();
        for j in -24..24 {
            let b = j as f64 * px;
            for dz in [0.0, -0.2, 0.1, -1.0] {
                for sx in [1.0, -1.0] {
                    rays.push((
                        ray(DVec3::new(-sx * 3.0, b, -1.0), DVec3::new(sx, 0.0, dz)),
                        f32::INFINITY,
                    ));
                    rays.push((
                        ray(DVec3::new(b, -sx * 3.0, -1.0), DVec3::new(0.0, sx, dz)),
                        f32::INFINITY,
                    ));
                    for sy in [1.0, -1.0] {
                        let o = DVec3::new(b - sx * 2.0 * px * 8.0, b - sy * 2.0 * px * 8.0, -1.0);
                        rays.push((ray(o, DVec3::new(sx, sy, dz)), f32::INFINITY));
                        let o = DVec3::new(b, 2.0 * b, -1.0);
                        rays.push((ray(o, DVec3::new(sx, 2.0 * sy, dz)), 9.0));
                    }
                }
            }
        }
        check(&img, &rays, &mut rng);
        // A tiny near plane with an infinite far plane (F39's camera).
        let cam = Camera::try_look_at(
            Vec3::new(0.5, 2.0, 6.0),
            Vec3::new(-0.5, 0.8, -6.0),
            Vec3::Y,
            1.0,
            7.5e-27,
            f32::INFINITY,
            64,
            48,
        )
        .unwrap();
        let img = Img::new(cam, conv, room(1.0));
        let rays = rays_for(&img, &mut rng, 40, 1.0);
        check(&img, &rays, &mut rng);
    }
    eprintln!("stream = scalar on {compared} traces, {hits} hits, miss reasons {misses:?}");
    assert!(
        hits > compared / 10 && misses.len() >= 4,
        "the cases reach every outcome"
    );
}
