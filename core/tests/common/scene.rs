//! The analytic test scene of the screen-space passes (`tests/ssr.rs`,
//! `tests/glossy.rs`; included with `#[path]`): a mirror floor with a
//! sphere and a box standing on it, depth, back-face depth and normals
//! rendered exactly in f64, and the cameras the tests look at it with.
#![allow(dead_code)]

use refl_core::glam::{DVec3, Vec2, Vec3};
use refl_core::{
    try_build_hiz, try_hiz_len, Camera, DepthConvention, DepthImage, GBuffer, HiZTexel, ImageView,
    NormalSpace,
};

pub const CONVENTIONS: [DepthConvention; 3] = [
    DepthConvention::Linear,
    DepthConvention::ZeroToOne,
    DepthConvention::ReversedZ,
];

/// The analytic scene: the floor `y = 0`, a unit sphere at `(0, 1, 0)`, an
/// axis-aligned box `[1.2, 2.2] x [0, 1.5] x [-1.5, -0.5]`.
pub struct Scene;

#[derive(Clone, Copy)]
pub struct Hit {
    pub t: f64,
    pub n: DVec3,
    /// Object id (0 floor, 1 sphere, 2 box).
    pub id: u32,
    /// Ray parameter where the ray leaves the object (the floor: +inf, a
    /// half-space is not used; the floor is a thin sheet).
    pub t_exit: f64,
}

pub const BOX_LO: DVec3 = DVec3::new(1.2, 0.0, -1.5);
pub const BOX_HI: DVec3 = DVec3::new(2.2, 1.5, -0.5);

impl Scene {
    /// The first hit past `t_min`, not on object `skip` (every object is
    /// convex or planar, so no reflection ray hits its own object).
    pub fn trace(&self, o: DVec3, d: DVec3, t_min: f64, skip: u32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut take = |h: Hit| {
            if h.id != skip && h.t > t_min && best.is_none_or(|b| h.t < b.t) {
                best = Some(h);
            }
        };
        // Floor (a sheet: it is left where it is entered).
        if d.y.abs() > 1e-12 {
            let t = -o.y / d.y;
            let p = o + d * t;
            if p.x.abs() < 8.0 && p.z.abs() < 8.0 {
                // A back-face pass sees nothing behind a one-sided
                // floor: the clear value, solid down to the far plane.
                take(Hit {
                    t,
                    n: DVec3::Y,
                    id: 0,
                    t_exit: f64::INFINITY,
                });
            }
        }
        // Sphere.
        let c = DVec3::new(0.0, 1.0, 0.0);
        let oc = o - c;
        let b = oc.dot(d);
        let disc = b * b - (oc.dot(oc) - 1.0);
        if disc > 0.0 {
            let s = disc.sqrt();
            let (t0, t1) = (-b - s, -b + s);
            for t in [t0, t1] {
                if t > t_min {
                    let n = (o + d * t - c).normalize();
                    take(Hit {
                        t,
                        n,
                        id: 1,
                        t_exit: t1,
                    });
                    break;
                }
            }
        }
        // Box (slabs).
        let inv = d.recip();
        let (a, bb) = ((BOX_LO - o) * inv, (BOX_HI - o) * inv);
        let (lo, hi) = (a.min(bb), a.max(bb));
        let (tn, tf) = (lo.max_element(), hi.min_element());
        if tn <= tf {
            for t in [tn, tf] {
                if t > t_min {
                    let p = o + d * t;
                    let mut n = DVec3::ZERO;
                    let rel = (p - (BOX_LO + BOX_HI) * 0.5) / ((BOX_HI - BOX_LO) * 0.5);
                    let k = rel.abs().max_position();
                    n[k] = rel[k].signum();
                    take(Hit {
                        t,
                        n,
                        id: 2,
                        t_exit: tf,
                    });
                    break;
                }
            }
        }
        best
    }
}

#[derive(Clone)]
pub struct Frame {
    pub camera: Camera,
    pub conv: DepthConvention,
    pub depth: Vec<f32>,
    pub back: Vec<f32>,
    pub normals: Vec<[f32; 3]>,
    pub color: Vec<[f32; 3]>,
    /// Object id per pixel (u32::MAX: sky).
    pub id: Vec<u32>,
}

pub fn camera(eye: Vec3, target: Vec3, w: u32, h: u32) -> Camera {
    Camera::try_look_at(eye, target, Vec3::Y, 1.0, 0.1, 100.0, w, h).unwrap()
}

pub fn render(camera: Camera, conv: DepthConvention) -> Frame {
    let (w, h) = (camera.width(), camera.height());
    let n = (w * h) as usize;
    let mut f = Frame {
        camera,
        conv,
        // The cleared value: the far plane.
        depth: vec![camera.encode_depth(camera.far(), conv); n],
        back: vec![camera.encode_depth(camera.far(), conv); n],
        normals: vec![[0.0; 3]; n],
        color: vec![[0.0; 3]; n],
        id: vec![u32::MAX; n],
    };
    let eye = camera.eye().as_dvec3();
    let fwd = -camera.inverse_view().z_axis.truncate().as_dvec3();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let d = camera
                .primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
                .dir
                .as_dvec3()
                .normalize();
            if let Some(hit) = Scene.trace(eye, d, 0.0, u32::MAX) {
                let z = hit.t * d.dot(fwd);
                let zb = hit.t_exit * d.dot(fwd);
                f.depth[i] = camera.encode_depth(z as f32, conv);
                f.back[i] = camera.encode_depth((zb as f32).min(camera.far()), conv);
                f.normals[i] = hit.n.as_vec3().to_array();
                f.id[i] = hit.id;
                f.color[i] = [hit.id as f32, x as f32, y as f32];
            }
        }
    }
    f
}

impl Frame {
    pub fn gbuffer(&self, back: bool) -> GBuffer<'_> {
        let (w, h) = (self.camera.width(), self.camera.height());
        let d = DepthImage::try_new(
            ImageView::try_new(&self.depth, w, h, w).unwrap(),
            self.camera,
            self.conv,
        )
        .unwrap();
        let g = GBuffer::try_new(
            d,
            ImageView::try_new(&self.normals, w, h, w).unwrap(),
            NormalSpace::World,
        )
        .unwrap()
        .try_with_color(ImageView::try_new(&self.color, w, h, w).unwrap())
        .unwrap();
        if back {
            g.try_with_back_depth(ImageView::try_new(&self.back, w, h, w).unwrap())
                .unwrap()
        } else {
            g
        }
    }

    pub fn pyramid(&self) -> Vec<HiZTexel> {
        let g = self.gbuffer(false);
        let mut p = vec![HiZTexel::default(); try_hiz_len(g.width(), g.height()).unwrap()];
        try_build_hiz(&mut p, g.depth()).unwrap();
        p
    }
}

/// Low over the floor, looking along it at a grazing angle.
pub fn grazing_camera() -> Camera {
    camera(
        Vec3::new(-0.5, 0.35, 7.0),
        Vec3::new(0.2, 0.5, 0.0),
        200,
        120,
    )
}

pub fn default_camera() -> Camera {
    camera(Vec3::new(0.5, 2.2, 6.0), Vec3::new(0.3, 0.7, 0.0), 160, 120)
}
