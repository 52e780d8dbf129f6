//! The planar mirror pass (`refl_core::planar`): its setup against the
//! kernels it wraps (bit for bit), its coverage against an f64 evaluation
//! of the same rule on exact geometry (a floor at grazing angles, a tilted
//! mirror, tiny and huge scales, every depth convention), its resolve
//! against a direct lookup (full resolution), against exact reflected rays
//! (an analytic mirrored render through the oblique projection) and
//! against depth edges (1/2 and 1/4 resolution), and its refusals.
#![cfg(feature = "mirror")]

use refl_core::glam::{DVec3, DVec4, Mat4, Vec2, Vec3};
use refl_core::planar::COVER_DEPTH_ULPS;
use refl_core::{
    try_mirrored_camera, try_oblique_projection, Camera, DepthConvention, DepthImage, Error,
    GBuffer, ImageView, ImageViewMut, NormalSpace, PlanarOptions, PlanarPass, PlanarRay,
    PlanarRect, PlanarRender, PlanarStatus, PlanarTexel, Plane, RowRange,
};

/// Conventions with their far planes (`None`: the camera's finite far).
const CASES: [(DepthConvention, bool); 4] = [
    (DepthConvention::Linear, false),
    (DepthConvention::ZeroToOne, false),
    (DepthConvention::ReversedZ, false),
    (DepthConvention::ReversedZ, true),
];

/// An analytic scene in f64: a mirror (a bounded piece of `plane`, id 0),
/// two spheres (ids 1, 2) and a back wall (id 3), all scaled by `s` and
/// moved by `off`.
#[derive(Clone, Copy)]
struct Scene {
    /// Unit normal and point of the mirror plane.
    n: DVec3,
    p0: DVec3,
    /// Half extent of the mirror around `p0`.
    half: f64,
    s: f64,
    off: DVec3,
}

#[derive(Clone, Copy, Debug)]
struct Hit {
    t: f64,
    n: DVec3,
    id: u32,
}

impl Scene {
    /// The floor `y = 0`.
    fn floor(s: f64, off: DVec3) -> Self {
        Self {
            n: DVec3::Y,
            p0: DVec3::ZERO,
            half: 8.0,
            s,
            off,
        }
    }

    /// A mirror tilted 25 degrees about x and 10 about z through `(0, 0.5, -1)`.
    fn tilted() -> Self {
        let (a, b) = (25f64.to_radians(), 10f64.to_radians());
        let n = DVec3::new(-b.sin() * a.cos(), a.cos() * b.cos(), a.sin()).normalize();
        Self {
            n,
            p0: DVec3::new(0.0, 0.5, -1.0),
            half: 6.0,
            s: 1.0,
            off: DVec3::ZERO,
        }
    }

    fn w(&self, p: DVec3) -> DVec3 {
        p * self.s + self.off
    }

    fn plane(&self) -> Plane {
        Plane::try_from_point_normal(self.w(self.p0).as_vec3(), self.n.as_vec3()).unwrap()
    }

    /// The first hit past `t_min` on an object other than `skip`.
    fn trace(&self, o: DVec3, d: DVec3, t_min: f64, skip: u32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut take = |h: Hit| {
            if h.id != skip && h.t > t_min && best.is_none_or(|b| h.t < b.t) {
                best = Some(h);
            }
        };
        let dn = d.dot(self.n);
        if dn.abs() > 1e-15 {
            let t = (self.w(self.p0) - o).dot(self.n) / dn;
            let q = (o + d * t - self.w(self.p0)) / self.s;
            // The mirror's extent: within `half` of p0 in the plane.
            if (q - self.n * q.dot(self.n)).abs().max_element() < self.half {
                let n = if dn < 0.0 { self.n } else { -self.n };
                take(Hit { t, n, id: 0 });
            }
        }
        for (id, c, r) in [
            (1, DVec3::new(0.0, 1.0, 0.0), 1.0),
            (2, DVec3::new(1.8, 0.45, -1.2), 0.4),
        ] {
            let c = self.w(c);
            let r = r * self.s;
            let oc = o - c;
            let b = oc.dot(d);
            let disc = b * b - (oc.dot(oc) - r * r);
            if disc > 0.0 {
                let t = -b - disc.sqrt();
                take(Hit {
                    t,
                    n: (o + d * t - c) / r,
                    id,
                });
            }
        }
        if d.z.abs() > 1e-15 {
            let z = self.w(DVec3::new(0.0, 0.0, -6.0)).z;
            let t = (z - o.z) / d.z;
            let q = (o + d * t - self.off) / self.s;
            if q.x.abs() < 8.0 && q.y > -8.0 && q.y < 6.0 {
                take(Hit {
                    t,
                    n: DVec3::new(0.0, 0.0, -d.z.signum()),
                    id: 3,
                });
            }
        }
        best
    }
}

/// A G-buffer rendered exactly: stored depth (f32, convention `conv`),
/// world normals, object ids, and the exact hits.
struct Frame {
    cam: Camera,
    conv: DepthConvention,
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    ids: Vec<u32>,
    hits: Vec<Option<Hit>>,
}

fn f64_ray(cam: &Camera, x: u32, y: u32) -> (DVec3, DVec3) {
    let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
    (r.origin.as_dvec3(), r.dir.as_dvec3().normalize())
}

fn forward(cam: &Camera) -> DVec3 {
    -cam.inverse_view().z_axis.truncate().as_dvec3()
}

#[allow(clippy::too_many_arguments)]
fn camera(sc: &Scene, eye: DVec3, target: DVec3, near: f64, far: f32, w: u32, h: u32) -> Camera {
    let far = if far.is_finite() {
        (f64::from(far) * sc.s) as f32
    } else {
        far
    };
    Camera::try_look_at(
        sc.w(eye).as_vec3(),
        sc.w(target).as_vec3(),
        Vec3::Y,
        1.0,
        (near * sc.s) as f32,
        far,
        w,
        h,
    )
    .unwrap()
}

/// The camera most tests look through: from above and in front of the
/// floor, toward the sphere standing on it.
fn overview(sc: &Scene, far: f32, w: u32, h: u32) -> Camera {
    camera(
        sc,
        DVec3::new(0.3, 2.0, 5.5),
        DVec3::new(0.0, 0.6, 0.0),
        0.1,
        far,
        w,
        h,
    )
}

fn render(sc: &Scene, cam: Camera, conv: DepthConvention) -> Frame {
    let (w, h) = (cam.width(), cam.height());
    let n = (w * h) as usize;
    let mut f = Frame {
        cam,
        conv,
        depth: vec![cam.encode_depth(cam.far(), conv); n],
        normals: vec![[0.0; 3]; n],
        ids: vec![u32::MAX; n],
        hits: vec![None; n],
    };
    let fwd = forward(&cam);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (o, d) = f64_ray(&cam, x, y);
            if let Some(hit) = sc.trace(o, d, 0.0, u32::MAX) {
                let z = hit.t * d.dot(fwd);
                if z < f64::from(cam.far()) && z as f32 >= cam.near() {
                    f.depth[i] = cam.encode_depth(z as f32, conv);
                    f.normals[i] = hit.n.as_vec3().to_array();
                    f.ids[i] = hit.id;
                    f.hits[i] = Some(hit);
                }
            }
        }
    }
    f
}

impl Frame {
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
    }

    fn ids(&self) -> ImageView<'_, u32> {
        let (w, h) = (self.cam.width(), self.cam.height());
        ImageView::try_new(&self.ids, w, h, w).unwrap()
    }
}

fn covers(pass: &PlanarPass<'_>, w: u32, h: u32) -> Vec<PlanarStatus> {
    let mut out = vec![PlanarStatus::Skipped; (w * h) as usize];
    pass.try_cover(&mut ImageViewMut::try_new(&mut out, w, h, w).unwrap())
        .unwrap();
    out
}

// ---------------------------------------------------------------- setup

#[test]
fn setup_equals_the_mirror_kernels_bit_for_bit() {
    // A floor through the origin (plane d = 0) and one below it (d != 0:
    // finding F24, a flipped plane's view-space planes were wrong there).
    for sc in [
        Scene::floor(1.0, DVec3::ZERO),
        Scene::floor(1.0, DVec3::new(0.3, -0.7, 0.2)),
    ] {
        setup_equals_the_mirror_kernels_on(&sc);
    }
}

fn setup_equals_the_mirror_kernels_on(sc: &Scene) {
    for (conv, inf) in CASES {
        let far = if inf { f32::INFINITY } else { 60.0 };
        let cam = overview(sc, far, 96, 64);
        let f = render(sc, cam, conv);
        // Either orientation of the input plane gives the one toward the
        // eye, and the same coverage.
        let base = covers(
            &PlanarPass::try_new(f.gbuffer(), sc.plane(), PlanarOptions::default()).unwrap(),
            96,
            64,
        );
        for plane in [sc.plane(), sc.plane().flipped()] {
            let pass = PlanarPass::try_new(f.gbuffer(), plane, PlanarOptions::default()).unwrap();
            assert!(
                covers(&pass, 96, 64) == base,
                "{conv:?}: coverage of {plane:?}"
            );
            for scale in [1u32, 2, 4, 3] {
                for oblique in [true, false] {
                    let o = PlanarOptions {
                        scale,
                        oblique,
                        ..PlanarOptions::default()
                    };
                    let pass = PlanarPass::try_new(f.gbuffer(), plane, o).unwrap();
                    let s = pass.prepare();
                    let toward = sc.plane();
                    assert_eq!(s.clip_plane, toward);
                    let m = try_mirrored_camera(&cam, &toward).unwrap();
                    assert_eq!(*pass.mirrored_camera(), m);
                    let r = if scale == 1 {
                        m
                    } else {
                        Camera::try_new(
                            m.view(),
                            m.fov_y(),
                            m.near(),
                            m.far(),
                            96u32.div_ceil(scale),
                            64u32.div_ceil(scale),
                        )
                        .unwrap()
                    };
                    assert_eq!(s.camera, r, "{conv:?} scale {scale}");
                    let pc = if conv == DepthConvention::Linear {
                        DepthConvention::ZeroToOne
                    } else {
                        conv
                    };
                    let want = if oblique {
                        try_oblique_projection(&r, &toward, pc).unwrap()
                    } else {
                        r.try_projection(pc).unwrap()
                    };
                    let bits = |m: Mat4| m.to_cols_array().map(f32::to_bits);
                    assert_eq!(bits(s.projection), bits(want), "{conv:?} {scale} {oblique}");
                    assert!(s.flip_winding && r.is_mirrored());
                    // The view-space clip plane: the world plane through the
                    // render camera (f64 oracle).
                    let cv = r.inverse_view().as_dmat4().transpose()
                        * DVec4::new(0.0, 1.0, 0.0, f64::from(toward.d()));
                    assert!(toward.normal() == Vec3::Y, "{toward:?}");
                    assert!((s.view_clip_plane.as_dvec4() - cv).abs().max_element() < 1e-6);
                    // The mirrored eye is on the negative side.
                    let e = r.world_to_view(r.eye());
                    assert!(s.view_clip_plane.truncate().dot(e) + s.view_clip_plane.w < 0.0);
                    assert!(s.covered && s.covered_pixels > 500);
                }
            }
        }
    }
}

#[test]
fn the_rectangles_and_scissor_hold_exactly_the_covered_pixels() {
    let sc = Scene::floor(1.0, DVec3::ZERO);
    let cam = overview(&sc, 60.0, 96, 64);
    let f = render(&sc, cam, DepthConvention::ReversedZ);
    // A mirror piece that covers part of the image: ids restrict it.
    let mut ids = f.ids.clone();
    for (i, id) in ids.iter_mut().enumerate() {
        let (x, y) = (i as u32 % 96, i as u32 / 96);
        if !(20..70).contains(&x) || !(30..60).contains(&y) {
            *id = u32::MAX;
        }
    }
    for scale in [1u32, 2, 4] {
        let o = PlanarOptions {
            scale,
            ..PlanarOptions::default()
        };
        let pass = PlanarPass::try_new(f.gbuffer(), sc.plane(), o)
            .unwrap()
            .try_with_ids(ImageView::try_new(&ids, 96, 64, 96).unwrap(), 0)
            .unwrap();
        let s = pass.prepare();
        let cov = covers(&pass, 96, 64);
        let mut want = PlanarRect::default();
        let mut n = 0;
        for (i, c) in cov.iter().enumerate() {
            if *c == PlanarStatus::Covered {
                n += 1;
                want = want.union(&PlanarRect {
                    x0: i as u32 % 96,
                    y0: i as u32 / 96,
                    x1: i as u32 % 96 + 1,
                    y1: i as u32 / 96 + 1,
                });
            }
        }
        assert_eq!((s.covered_pixels, s.rect), (n, want));
        assert_eq!(want.x0, 20);
        if scale == 1 {
            assert_eq!(s.scissor, s.rect);
        }
        // Every texel the resolve reads lies in the scissor: a render that
        // is empty outside it gives the same resolve.
        let (rw, rh) = pass.render_size();
        let depth: Vec<f32> = (0..rw * rh).map(|i| 0.3 + 0.001 * i as f32).collect();
        let color: Vec<[f32; 3]> = (0..rw * rh).map(|i| [i as f32, 1.0, 2.0]).collect();
        let mut cut = depth.clone();
        let mut cut_c = color.clone();
        for j in 0..rh {
            for i in 0..rw {
                let inside = (s.scissor.x0..s.scissor.x1).contains(&i)
                    && (s.scissor.y0..s.scissor.y1).contains(&j);
                if !inside {
                    cut[(j * rw + i) as usize] = f32::NAN;
                    cut_c[(j * rw + i) as usize] = [f32::NAN; 3];
                }
            }
        }
        let a = resolve(&pass, &depth, &color, rw, rh);
        let b = resolve(&pass, &cut, &cut_c, rw, rh);
        assert_eq!(a.0, b.0, "scale {scale}");
        assert!(a
            .1
            .iter()
            .zip(&b.1)
            .all(|(p, q)| p.map(f32::to_bits) == q.map(f32::to_bits)));
        // Bands merge to the whole.
        let mut r = PlanarRect::default();
        for band in 0..5 {
            let rows = RowRange::try_all(64).unwrap().band(band, 5).unwrap();
            let st = pass.try_cover_rows(rows, &mut |_, _, _| {}).unwrap();
            r = r.union(&st.rect);
        }
        assert_eq!(r, s.rect);
        assert_eq!(pass.scissor(&r), s.scissor);
    }
}

/// Resolves the whole image against a render; returns texels, colors, rays.
fn resolve(
    pass: &PlanarPass<'_>,
    depth: &[f32],
    color: &[[f32; 3]],
    rw: u32,
    rh: u32,
) -> (Vec<PlanarTexel>, Vec<[f32; 3]>, Vec<PlanarRay>) {
    let (w, h) = (pass.gbuffer().width(), pass.gbuffer().height());
    let n = (w * h) as usize;
    let render = PlanarRender::try_new(
        ImageView::try_new(depth, rw, rh, rw).unwrap(),
        Some(ImageView::try_new(color, rw, rh, rw).unwrap()),
    )
    .unwrap();
    let mut out = vec![PlanarTexel::default(); n];
    let mut col = vec![[9.0f32; 3]; n];
    let mut host = vec![PlanarRay::default(); n];
    let st = pass
        .try_resolve(
            &mut ImageViewMut::try_new(&mut out, w, h, w).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut col, w, h, w).unwrap()),
            &mut host,
            &render,
        )
        .unwrap();
    host.truncate(st.host_rays_written as usize);
    assert_eq!(st.host_rays, st.environment);
    assert_eq!(st.covered, st.hits + st.environment);
    (out, col, host)
}

// ------------------------------------------------------------- coverage

/// The f64 oracle of the coverage rule on the exact hit of pixel `i`:
/// `Some(true)` inside the tolerances with margin, `Some(false)` outside
/// with margin, `None` within the f32 quantization band of the boundary.
fn oracle(f: &Frame, sc: &Scene, o: &PlanarOptions, x: u32, y: u32) -> Option<bool> {
    let w = f.cam.width();
    let i = (y * w + x) as usize;
    let Some(hit) = f.hits[i] else {
        return Some(false);
    };
    let (org, d) = f64_ray(&f.cam, x, y);
    let p = org + d * hit.t;
    let z = hit.t * d.dot(forward(&f.cam));
    let dist = (p - sc.w(sc.p0)).dot(sc.n).abs();
    let cos = hit.n.dot(sc.n).abs();
    let cos_ok = cos >= f64::from(o.normal_cos);
    // The pass's own slack: depth quantization and f32 rounding.
    let stored = f.depth[i];
    let q = ulps(stored)
        .map(|s| (f64::from(f.cam.decode_depth(s, f.conv)) - z).abs())
        .into_iter()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let tol = f64::from(o.plane_tolerance) * z;
    let slack = 2.0 * f64::from(COVER_DEPTH_ULPS) * q * 2.0 + 1e-5 * z;
    if (cos - f64::from(o.normal_cos)).abs() < 1e-5 {
        return None;
    }
    if cos_ok && dist <= tol - slack {
        Some(true)
    } else if !cos_ok || dist > tol + slack {
        Some(false)
    } else {
        None
    }
}

/// The f32 values one step above and below `v` (finite, not zero).
fn ulps(v: f32) -> [f32; 2] {
    let b = v.to_bits();
    let (a, c) = (f32::from_bits(b + 1), f32::from_bits(b - 1));
    if v > 0.0 {
        [a, c]
    } else {
        [c, a]
    }
}

/// Coverage of `f` against the oracle: every mirror pixel covered, no
/// pixel the oracle refuses covered. Returns (mirror pixels, covered,
/// undecided).
fn check_coverage(f: &Frame, sc: &Scene, o: &PlanarOptions, what: &str) -> (u32, u32, u32) {
    let (w, h) = (f.cam.width(), f.cam.height());
    let pass = PlanarPass::try_new(f.gbuffer(), sc.plane(), *o).unwrap();
    let cov = covers(&pass, w, h);
    let (mut mirror, mut covered, mut undecided) = (0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let c = cov[i];
            assert_eq!(c, pass.cover(x, y));
            if c == PlanarStatus::Covered {
                covered += 1;
            }
            if f.ids[i] == 0 {
                mirror += 1;
                assert_eq!(c, PlanarStatus::Covered, "{what}: mirror pixel ({x}, {y})");
            }
            match oracle(f, sc, o, x, y) {
                Some(true) => assert_eq!(c, PlanarStatus::Covered, "{what} ({x}, {y})"),
                Some(false) => assert_ne!(c, PlanarStatus::Covered, "{what} ({x}, {y})"),
                None => undecided += 1,
            }
            if f.hits[i].is_none() {
                assert_eq!(c, PlanarStatus::NoSurface);
            }
        }
    }
    (mirror, covered, undecided)
}

#[test]
fn coverage_matches_the_f64_oracle_in_every_convention_and_view() {
    let sc = Scene::floor(1.0, DVec3::ZERO);
    let views = [
        (
            "overview",
            DVec3::new(0.3, 2.0, 5.5),
            DVec3::new(0.0, 0.6, 0.0),
        ),
        // Grazing: the eye 5 cm above the floor.
        (
            "grazing",
            DVec3::new(-0.4, 0.05, 7.5),
            DVec3::new(0.0, 0.3, -4.0),
        ),
        // Looking straight down.
        ("down", DVec3::new(0.2, 6.0, 0.5), DVec3::new(0.0, 0.0, 0.0)),
    ];
    for (name, eye, target) in views {
        for (conv, inf) in CASES {
            let far = if inf { f32::INFINITY } else { 60.0 };
            let cam = camera(&sc, eye, target, 0.1, far, 128, 96);
            let f = render(&sc, cam, conv);
            let o = PlanarOptions::default();
            let (mirror, covered, undecided) =
                check_coverage(&f, &sc, &o, &format!("{name} {conv:?} inf={inf}"));
            assert!(mirror > 1000, "{name}: {mirror}");
            assert!(undecided <= 20, "{name} {conv:?}: {undecided} undecided");
            // Besides the mirror, only points the rule accepts: the
            // bottoms of the spheres where they touch or hover.
            assert!(
                covered - mirror <= 40,
                "{name} {conv:?}: {covered} vs {mirror}"
            );
        }
    }
}

#[test]
fn coverage_of_a_tilted_mirror_matches_the_oracle() {
    let sc = Scene::tilted();
    for (conv, inf) in CASES {
        let far = if inf { f32::INFINITY } else { 60.0 };
        let cam = camera(
            &sc,
            DVec3::new(1.0, 3.5, 6.0),
            DVec3::new(0.0, 0.5, -1.0),
            0.1,
            far,
            128,
            96,
        );
        let f = render(&sc, cam, conv);
        let (mirror, _, undecided) = check_coverage(
            &f,
            &sc,
            &PlanarOptions::default(),
            &format!("tilted {conv:?}"),
        );
        assert!(mirror > 1000 && undecided <= 20, "{mirror} {undecided}");
    }
}

#[test]
fn coverage_is_scale_free_from_tiny_to_huge_scenes() {
    for s in [1e-4, 1e-2, 1.0, 1e2, 1e4] {
        for off in [DVec3::ZERO, DVec3::new(30.0, -20.0, 50.0)] {
            let sc = Scene::floor(s, off * s);
            for (conv, inf) in CASES {
                let far = if inf { f32::INFINITY } else { 60.0 };
                let cam = camera(
                    &sc,
                    DVec3::new(-0.4, 0.3, 7.5),
                    DVec3::new(0.0, 0.3, -4.0),
                    0.1,
                    far,
                    96,
                    64,
                );
                let f = render(&sc, cam, conv);
                let (mirror, _, undecided) = check_coverage(
                    &f,
                    &sc,
                    &PlanarOptions::default(),
                    &format!("scale {s} {conv:?}"),
                );
                assert!(
                    mirror > 1000 && undecided <= 20,
                    "{s}: {mirror} {undecided}"
                );
            }
        }
    }
}

#[test]
fn a_far_grazing_floor_in_zero_to_one_depth_needs_the_quantization_term() {
    // Near 0.01, floor out to 500: [0, 1] depth has relative steps of
    // about 3e-3 there. Every floor pixel is still covered, and without the
    // quantization term (tolerance alone) some would not be.
    let mut sc = Scene::floor(1.0, DVec3::ZERO);
    sc.half = 1000.0;
    let cam = Camera::try_look_at(
        Vec3::new(0.0, 3.0, 10.0),
        Vec3::new(0.0, 0.0, -500.0),
        Vec3::Y,
        0.6,
        0.01,
        2000.0,
        128,
        96,
    )
    .unwrap();
    let f = render(&sc, cam, DepthConvention::ZeroToOne);
    let o = PlanarOptions {
        plane_tolerance: 1e-5,
        ..PlanarOptions::default()
    };
    let pass = PlanarPass::try_new(f.gbuffer(), sc.plane(), o).unwrap();
    let cov = covers(&pass, 128, 96);
    let fwd = forward(&cam);
    let mut floor = 0;
    let mut need_q = 0;
    for (i, c) in cov.iter().enumerate() {
        if f.ids[i] != 0 {
            continue;
        }
        floor += 1;
        assert_eq!(*c, PlanarStatus::Covered, "floor pixel {i}");
        // The stored point's distance from the plane (f64) beyond the
        // tolerance alone.
        let (x, y) = (i as u32 % 128, i as u32 / 128);
        let z = f64::from(cam.decode_depth(f.depth[i], f.conv));
        let (o, d) = f64_ray(&cam, x, y);
        let p = o + d * (z / d.dot(fwd));
        if p.y.abs() > 1e-5 * z {
            need_q += 1;
        }
    }
    assert!(floor > 1500, "{floor}");
    eprintln!("{floor} floor pixels, {need_q} beyond the tolerance alone");
    assert!(
        need_q > 50,
        "the quantization term was never needed: {need_q}"
    );
}

#[test]
fn masks_ids_nan_and_the_eye_on_the_plane() {
    let sc = Scene::floor(1.0, DVec3::ZERO);
    let cam = overview(&sc, 60.0, 64, 48);
    let mut f = render(&sc, cam, DepthConvention::ZeroToOne);
    let i = (40 * 64 + 32) as usize;
    assert_eq!(f.ids[i], 0);
    let j = i + 1;
    let k = i + 2;
    f.depth[j] = f32::NAN;
    f.normals[k] = [f32::INFINITY, 0.0, 0.0];
    let mask: Vec<u8> = (0..64 * 48).map(|p| u8::from(p != i + 3)).collect();
    let g = f
        .gbuffer()
        .try_with_mask(ImageView::try_new(&mask, 64, 48, 64).unwrap())
        .unwrap();
    let pass = PlanarPass::try_new(g, sc.plane(), PlanarOptions::default())
        .unwrap()
        .try_with_ids(f.ids(), 0)
        .unwrap();
    assert_eq!(pass.cover(32, 40), PlanarStatus::Covered);
    assert_eq!(pass.cover(33, 40), PlanarStatus::NoSurface);
    assert_eq!(pass.cover(34, 40), PlanarStatus::NoSurface);
    assert_eq!(pass.cover(35, 40), PlanarStatus::Skipped);
    // A sphere pixel: other id.
    let s = f.ids.iter().position(|&id| id == 1).unwrap() as u32;
    assert_eq!(pass.cover(s % 64, s / 64), PlanarStatus::Skipped);
    // Without ids it is a surface off the plane.
    let pass2 = PlanarPass::try_new(f.gbuffer(), sc.plane(), PlanarOptions::default()).unwrap();
    assert_eq!(pass2.cover(s % 64, s / 64), PlanarStatus::OffPlane);
    // Outside the image.
    assert_eq!(pass2.cover(64, 0), PlanarStatus::Skipped);
    // The eye on the plane: nothing covered, the frame says so.
    let on = Plane::try_from_point_normal(cam.eye(), Vec3::Y).unwrap();
    let pass3 = PlanarPass::try_new(f.gbuffer(), on, PlanarOptions::default()).unwrap();
    let s3 = pass3.prepare();
    assert!(!s3.covered && s3.covered_pixels == 0 && s3.rect.is_empty() && s3.scissor.is_empty());
    assert_eq!(pass3.cover(32, 40), PlanarStatus::OffPlane);
    // A mirror plane nothing in view lies on: nothing covered.
    let away = Plane::try_from_point_normal(Vec3::new(0.0, -50.0, 0.0), Vec3::Y).unwrap();
    let s4 = PlanarPass::try_new(f.gbuffer(), away, PlanarOptions::default())
        .unwrap()
        .prepare();
    assert!(!s4.covered);
    assert_eq!(
        s4.projection,
        s4.camera
            .try_projection(DepthConvention::ZeroToOne)
            .unwrap()
    );
}

// -------------------------------------------------------------- resolve

/// The mirrored render of `sc` through `setup`: per render pixel, the
/// render camera's primary ray traced (f64) past the mirror plane, depth
/// written as the setup's projection writes it (or linear), color
/// `(id, x of the hit, z of the hit)`.
fn mirrored_render(
    sc: &Scene,
    pass: &PlanarPass<'_>,
    conv: DepthConvention,
) -> (Vec<f32>, Vec<[f32; 3]>) {
    let s = pass.prepare();
    let r = s.camera;
    let (rw, rh) = (r.width(), r.height());
    let mut depth = vec![0.0f32; (rw * rh) as usize];
    let mut color = vec![[0.0f32; 3]; (rw * rh) as usize];
    let plane = s.clip_plane;
    let m = s.projection.as_dmat4();
    let view = r.view().as_dmat4();
    for j in 0..rh {
        for i in 0..rw {
            let k = (j * rw + i) as usize;
            let (o, d) = f64_ray(&r, i, j);
            let tp = -(plane.normal().as_dvec3().dot(o) + f64::from(plane.d()))
                / plane.normal().as_dvec3().dot(d);
            depth[k] = match conv {
                DepthConvention::Linear => f32::INFINITY,
                DepthConvention::ZeroToOne => 1.0,
                DepthConvention::ReversedZ => 0.0,
            };
            if let Some(hit) = sc.trace(o, d, tp.max(0.0), 0) {
                let p = o + d * hit.t;
                let v = view * p.extend(1.0);
                depth[k] = match conv {
                    DepthConvention::Linear => (-v.z) as f32,
                    _ => {
                        let c = m * v;
                        (c.z / c.w) as f32
                    }
                };
                color[k] = [hit.id as f32, p.x as f32, p.z as f32];
            }
        }
    }
    (depth, color)
}

#[test]
fn full_resolution_resolve_is_a_direct_lookup_and_agrees_with_exact_reflections() {
    let sc = Scene::floor(1.0, DVec3::ZERO);
    for (conv, inf) in CASES {
        for oblique in [true, false] {
            let far = if inf { f32::INFINITY } else { 60.0 };
            let cam = overview(&sc, far, 96, 64);
            let f = render(&sc, cam, conv);
            let o = PlanarOptions {
                oblique,
                ..PlanarOptions::default()
            };
            let pass = PlanarPass::try_new(f.gbuffer(), sc.plane(), o).unwrap();
            let (depth, color) = mirrored_render(&sc, &pass, conv);
            let (out, col, host) = resolve(&pass, &depth, &color, 96, 64);
            let mirrored = pass.mirrored_camera();
            let (mut hits, mut agree, mut covered) = (0, 0, 0);
            let mut max_t_err = 0.0f64;
            let mut rays = host.iter();
            for y in 0..64u32 {
                for x in 0..96u32 {
                    let i = (y * 96 + x) as usize;
                    let t = out[i];
                    if !t.status.is_covered() {
                        assert_eq!(col[i], [0.0; 3]);
                        continue;
                    }
                    covered += 1;
                    // Direct lookup, bit for bit.
                    assert_eq!(t.texel, [x, y]);
                    assert_eq!(t.pixel, Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                    let want = if t.status == PlanarStatus::Hit {
                        color[i]
                    } else {
                        [0.0; 3]
                    };
                    assert_eq!(col[i].map(f32::to_bits), want.map(f32::to_bits));
                    // The exact reflection: from the mirror point along the
                    // reflected direction.
                    let (org, d) = f64_ray(&cam, x, y);
                    let hit0 = f.hits[i].unwrap();
                    let p = org + d * hit0.t;
                    let r = d - 2.0 * d.dot(sc.n) * sc.n;
                    let exact = sc.trace(p, r, 1e-9, 0);
                    match (t.status, exact) {
                        (PlanarStatus::Hit, Some(e)) => {
                            hits += 1;
                            if e.id as f32 == color[i][0] {
                                agree += 1;
                                max_t_err = max_t_err.max((f64::from(t.t) - e.t).abs() / e.t);
                            }
                        }
                        (PlanarStatus::Environment, None) => agree += 1,
                        _ => {}
                    }
                    if t.status == PlanarStatus::Environment {
                        let ray = rays.next().unwrap();
                        assert_eq!((ray.x, ray.y), (x, y));
                        let want = mirrored.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                        assert_eq!(ray.dir, want.dir);
                        assert!((ray.dir.as_dvec3() - r).length() < 1e-5);
                        assert!((ray.origin.as_dvec3() - p).length() < 1e-4 * hit0.t);
                    }
                }
            }
            assert!(rays.next().is_none());
            assert!(hits > 500, "{conv:?}: {hits}");
            assert!(
                agree as f64 >= 0.995 * covered as f64,
                "{conv:?} oblique={oblique}: {agree} of {covered}"
            );
            // The oblique depth decodes to the exact distance.
            assert!(max_t_err < 2e-3, "{conv:?} oblique={oblique}: {max_t_err}");
        }
    }
}

#[test]
fn reduced_resolution_never_blends_across_a_depth_edge() {
    let sc = Scene::floor(1.0, DVec3::ZERO);
    let cam = overview(&sc, 60.0, 96, 64);
    for conv in [DepthConvention::Linear, DepthConvention::ReversedZ] {
        let f = render(&sc, cam, conv);
        for scale in [2u32, 4] {
            for threshold in [0.05f32, f32::INFINITY] {
                let o = PlanarOptions {
                    scale,
                    oblique: false,
                    edge_threshold: threshold,
                    ..PlanarOptions::default()
                };
                let pass = PlanarPass::try_new(f.gbuffer(), sc.plane(), o).unwrap();
                let (rw, rh) = pass.render_size();
                let r = *pass.render_camera();
                // Stripes at two depths (10 and 20: a 100% edge), each
                // with a smooth 1% depth ramp and a color that is its depth.
                let mut depth = vec![0.0f32; (rw * rh) as usize];
                let mut color = vec![[0.0f32; 3]; (rw * rh) as usize];
                for j in 0..rh {
                    for i in 0..rw {
                        let z = if (i / 3 + j / 2) % 2 == 0 { 10.0 } else { 20.0 };
                        let z = z * (1.0 + 0.0005 * i as f32);
                        let k = (j * rw + i) as usize;
                        depth[k] = r.encode_depth(z, conv);
                        color[k] = [z, 0.0, 1.0];
                    }
                }
                let (out, col, _) = resolve(&pass, &depth, &color, rw, rh);
                let mut blended_across = 0;
                for (i, t) in out.iter().enumerate() {
                    if t.status != PlanarStatus::Hit {
                        continue;
                    }
                    let za = depth_at(&r, conv, &depth, rw, t.texel);
                    let c = col[i][0];
                    if (c - za).abs() > 0.05 * za {
                        blended_across += 1;
                    }
                    // The color is a convex mean of the footprint's colors.
                    assert!((9.9..=20.5).contains(&c), "{c}");
                    assert_eq!(col[i][2], 1.0);
                }
                if threshold.is_finite() {
                    assert_eq!(blended_across, 0, "scale {scale} {conv:?}");
                } else {
                    // The test can fail: without the guide the stripes blend.
                    assert!(blended_across > 100, "scale {scale}: {blended_across}");
                }
            }
        }
    }
}

fn depth_at(r: &Camera, conv: DepthConvention, depth: &[f32], rw: u32, t: [u32; 2]) -> f32 {
    r.decode_depth(depth[(t[1] * rw + t[0]) as usize], conv)
}

#[test]
fn reduced_resolution_on_a_smooth_surface_is_the_bilinear_mean() {
    let sc = Scene::floor(1.0, DVec3::ZERO);
    let cam = overview(&sc, 60.0, 96, 64);
    let f = render(&sc, cam, DepthConvention::Linear);
    let o = PlanarOptions {
        scale: 2,
        oblique: false,
        ..PlanarOptions::default()
    };
    let pass = PlanarPass::try_new(f.gbuffer(), sc.plane(), o).unwrap();
    let (rw, rh) = pass.render_size();
    assert_eq!((rw, rh), (48, 32));
    // A constant depth and a color linear in the texel position: the
    // resolve's color at q is q itself (f64 bilinear of a linear function),
    // except at the border where a footprint texel is outside.
    let depth = vec![15.0f32; (rw * rh) as usize];
    let color: Vec<[f32; 3]> = (0..rw * rh)
        .map(|k| [(k % rw) as f32 + 0.5, (k / rw) as f32 + 0.5, 0.0])
        .collect();
    let (out, col, _) = resolve(&pass, &depth, &color, rw, rh);
    let mut inner = 0;
    for (i, t) in out.iter().enumerate() {
        if t.status != PlanarStatus::Hit {
            continue;
        }
        let (x, y) = (i as u32 % 96, i as u32 / 96);
        assert_eq!(
            t.pixel,
            Vec2::new((x as f32 + 0.5) / 2.0, (y as f32 + 0.5) / 2.0)
        );
        assert_eq!(t.texel, [x / 2, y / 2]);
        let q = t.pixel;
        if q.x > 0.5 && q.y > 0.5 && q.x < rw as f32 - 0.5 && q.y < rh as f32 - 0.5 {
            inner += 1;
            assert!((col[i][0] - q.x).abs() < 1e-4 && (col[i][1] - q.y).abs() < 1e-4);
        }
        // t: from the mirror point at linear depth z to depth 15.
        let z = f.cam.decode_depth(f.depth[i], DepthConvention::Linear);
        let dir = f
            .cam
            .primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
            .dir;
        let fwd = forward(&f.cam).as_vec3();
        let want = (15.0 - z).max(0.0) / dir.dot(fwd);
        assert!((t.t - want).abs() < 1e-4 * want.max(1.0), "{} {want}", t.t);
    }
    assert!(inner > 1000);
    // Without a render color the anchor answers: same texels, t from the
    // anchor's depth (here the same constant depth), and only the anchors
    // are read (NaN everywhere else changes nothing).
    let mut anchors_only = vec![f32::NAN; (rw * rh) as usize];
    for t in out.iter().filter(|t| t.status == PlanarStatus::Hit) {
        anchors_only[(t.texel[1] * rw + t.texel[0]) as usize] = 15.0;
    }
    let render =
        PlanarRender::try_new(ImageView::try_new(&anchors_only, rw, rh, rw).unwrap(), None)
            .unwrap();
    let mut bare = vec![PlanarTexel::default(); 96 * 64];
    pass.try_resolve(
        &mut ImageViewMut::try_new(&mut bare, 96, 64, 96).unwrap(),
        None,
        &mut [],
        &render,
    )
    .unwrap();
    for (a, b) in out.iter().zip(&bare) {
        assert_eq!((a.status, a.texel, a.pixel), (b.status, b.texel, b.pixel));
        assert!((a.t - b.t).abs() <= 1e-5 * a.t.max(1.0));
    }
}

// ----------------------------------------------------------- refusals

#[test]
fn bad_input_is_refused_and_nothing_is_written() {
    let sc = Scene::floor(1.0, DVec3::ZERO);
    let cam = overview(&sc, 60.0, 64, 48);
    let f = render(&sc, cam, DepthConvention::ReversedZ);
    let d = PlanarOptions::default();
    for o in [
        PlanarOptions { scale: 0, ..d },
        PlanarOptions {
            plane_tolerance: f32::NAN,
            ..d
        },
        PlanarOptions {
            plane_tolerance: -1.0,
            ..d
        },
        PlanarOptions {
            plane_tolerance: f32::INFINITY,
            ..d
        },
        PlanarOptions {
            normal_cos: 1.5,
            ..d
        },
        PlanarOptions {
            normal_cos: f32::NAN,
            ..d
        },
        PlanarOptions {
            edge_threshold: f32::NAN,
            ..d
        },
        PlanarOptions {
            edge_threshold: -0.1,
            ..d
        },
    ] {
        assert_eq!(
            PlanarPass::try_new(f.gbuffer(), sc.plane(), o).err(),
            Some(Error::InvalidArgument),
            "{o:?}"
        );
    }
    let pass = PlanarPass::try_new(f.gbuffer(), sc.plane(), d).unwrap();
    let short = vec![0u32; 64 * 47];
    assert_eq!(
        pass.try_with_ids(ImageView::try_new(&short, 64, 47, 64).unwrap(), 0)
            .err(),
        Some(Error::InvalidArgument)
    );
    // Outputs and renders of the wrong size.
    let mut st = vec![PlanarStatus::Environment; 64 * 48];
    assert_eq!(
        pass.try_cover(&mut ImageViewMut::try_new(&mut st, 63, 48, 64).unwrap()),
        Err(Error::InvalidArgument)
    );
    assert!(st.iter().all(|s| *s == PlanarStatus::Environment));
    assert_eq!(
        pass.try_cover_rows(
            RowRange::try_new(0, 49, 49).unwrap(),
            &mut |_, _, _| panic!()
        ),
        Err(Error::InvalidArgument)
    );
    let depth = vec![0.5f32; 64 * 48];
    let color = vec![[1.0f32; 3]; 64 * 48];
    let small = vec![0.5f32; 32 * 24];
    let sentinel = PlanarTexel {
        t: -7.0,
        ..PlanarTexel::default()
    };
    let n = 64 * 48;
    let render_full = PlanarRender::try_new(
        ImageView::try_new(&depth, 64, 48, 64).unwrap(),
        Some(ImageView::try_new(&color, 64, 48, 64).unwrap()),
    )
    .unwrap();
    let render_nocolor =
        PlanarRender::try_new(ImageView::try_new(&depth, 64, 48, 64).unwrap(), None).unwrap();
    let render_small =
        PlanarRender::try_new(ImageView::try_new(&small, 32, 24, 32).unwrap(), None).unwrap();
    assert_eq!(
        PlanarRender::try_new(
            ImageView::try_new(&small, 32, 24, 32).unwrap(),
            Some(ImageView::try_new(&color, 64, 48, 64).unwrap())
        )
        .err(),
        Some(Error::InvalidArgument)
    );
    type Case<'r> = (&'r PlanarRender<'r>, u32, bool);
    let cases: [Case<'_>; 3] = [
        (&render_small, 64, false),
        (&render_full, 63, false),
        (&render_nocolor, 64, true),
    ];
    for (render, ow, with_color) in cases {
        let mut out = vec![sentinel; n];
        let mut col = vec![[3.0f32; 3]; n];
        let mut host = vec![
            PlanarRay {
                x: 99,
                ..Default::default()
            };
            4
        ];
        let mut cv = ImageViewMut::try_new(&mut col, 64, 48, 64).unwrap();
        let r = pass.try_resolve(
            &mut ImageViewMut::try_new(&mut out, ow, 48, 64).unwrap(),
            if with_color { Some(&mut cv) } else { None },
            &mut host,
            render,
        );
        assert_eq!(r, Err(Error::InvalidArgument));
        assert!(out.iter().all(|t| *t == sentinel));
        assert!(col.iter().all(|c| *c == [3.0; 3]));
        assert!(host.iter().all(|h| h.x == 99));
    }
    // NaN and infinite render depths are empty texels, never hits.
    let nan = vec![f32::NAN; n];
    let (out, _, _) = resolve(&pass, &nan, &color, 64, 48);
    assert!(out.iter().all(|t| t.status != PlanarStatus::Hit));
    assert!(out.iter().any(|t| t.status == PlanarStatus::Environment));
}

/// F27 (fuzz, `planar`): a render depth near `f32::MAX` times the view
/// ray's length overflowed the reflected distance to `+inf` on a `Hit`.
/// The distance saturates at `f32::MAX`, with and without a render color.
#[test]
fn a_render_depth_near_the_float_maximum_gives_a_finite_distance() {
    let sc = Scene::floor(1.0, DVec3::ZERO);
    let cam = overview(&sc, f32::INFINITY, 48, 32);
    let f = render(&sc, cam, DepthConvention::Linear);
    let pass = PlanarPass::try_new(f.gbuffer(), sc.plane(), PlanarOptions::default()).unwrap();
    let r = pass.prepare().camera;
    let (rw, rh) = (r.width(), r.height());
    let n = (rw * rh) as usize;
    let depth = vec![3.0e38f32; n];
    let color = vec![[0.5f32; 3]; n];
    let (out, _, _) = resolve(&pass, &depth, &color, rw, rh);
    let no_color =
        PlanarRender::try_new(ImageView::try_new(&depth, rw, rh, rw).unwrap(), None).unwrap();
    let hits = out.iter().filter(|t| t.status == PlanarStatus::Hit).count();
    assert!(hits > 0);
    for (k, t) in out.iter().enumerate() {
        if t.status == PlanarStatus::Hit {
            assert!(t.t.is_finite() && t.t > 1e38, "{k}: {}", t.t);
            let (x, y) = (k as u32 % 48, k as u32 / 48);
            let (bare, _, _) = pass.pixel(&no_color, x, y);
            assert_eq!(bare.status, PlanarStatus::Hit);
            assert!(bare.t.is_finite() && bare.t > 1e38, "{k}: {}", bare.t);
        }
    }
}
