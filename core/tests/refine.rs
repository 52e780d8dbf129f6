//! Sub-texel hit refinement (`refl_core::trace::refine_hit`) against a
//! closed-form f64 ray/plane intersection: a ground plane seen at grazing
//! angles, where the flat-plate texel test lands pixels off, and a
//! silhouette, where refinement must not interpolate across the jump.
#![cfg(feature = "depth-image")]

use glam::{DVec3, Vec2, Vec3};
use refl_core::trace::refine_hit;
use refl_core::{
    try_step, Camera, DepthConvention, DepthImage, ImageView, Ray, StepOptions, Thickness, Trace,
};

const W: u32 = 160;
const H: u32 = 120;

fn camera() -> Camera {
    Camera::try_look_at(
        Vec3::new(0.0, 1.0, 6.0),
        Vec3::new(0.0, 0.2, -4.0),
        Vec3::Y,
        0.9,
        0.05,
        200.0,
        W,
        H,
    )
    .expect("camera")
}

/// Linear depth of the ground plane y = 0 (and a wall at z = `wall`) per
/// pixel center, in f64.
fn depth_image(cam: &Camera, wall: Option<f64>) -> Vec<f32> {
    let mut d = vec![0.0f32; (W * H) as usize];
    for y in 0..H {
        for x in 0..W {
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (o, dir) = (r.origin.as_dvec3(), r.dir.as_dvec3());
            let mut t = f64::INFINITY;
            if dir.y < 0.0 {
                t = -o.y / dir.y;
            }
            if let Some(zw) = wall {
                if dir.z < 0.0 {
                    let tw = (zw - o.z) / dir.z;
                    let p = o + dir * tw;
                    if p.y >= 0.0 && p.x < 0.0 {
                        t = t.min(tw);
                    }
                }
            }
            let z = if t.is_finite() {
                cam.linear_depth((o + dir * t).as_vec3())
            } else {
                f32::NAN
            };
            d[(y * W + x) as usize] = z;
        }
    }
    d
}

/// Rays grazing down onto the ground: the refined hit is within a pixel of
/// the exact intersection far more often than the plate hit.
#[test]
fn grazing_ground_hits_refine_to_the_exact_point() {
    let cam = camera();
    let data = depth_image(&cam, None);
    let view = ImageView::try_new(&data, W, H, W).expect("view");
    let img = DepthImage::try_new(view, cam, DepthConvention::Linear).expect("image");
    let (mut raw_ok, mut refined_ok, mut n, mut refined) = (0, 0, 0, 0);
    for i in 0..400 {
        let a = i as f64 * 0.618_033_988_75;
        let origin = DVec3::new(-2.0 + 4.0 * a.fract(), 0.3 + 0.4 * (a * 3.1).fract(), -1.0);
        // 1..8 degrees below the horizon, away from the camera.
        let pitch = (1.0 + 7.0 * (a * 7.3).fract()).to_radians();
        let yaw = -0.5 + (a * 5.7).fract();
        let dir = DVec3::new(
            yaw.sin() * pitch.cos(),
            -pitch.sin(),
            -yaw.cos() * pitch.cos(),
        );
        let t_exact = -origin.y / dir.y;
        let p = origin + dir * t_exact;
        let Some(q) = cam.project(p.as_vec3()) else {
            continue;
        };
        if !(q.x >= 1.0 && q.y >= 1.0 && q.x < (W - 1) as f32 && q.y < (H - 1) as f32) {
            continue;
        }
        let ray = Ray {
            origin: origin.as_vec3(),
            dir: dir.as_vec3(),
        };
        let tr = try_step(
            &img,
            Thickness::Constant(0.5),
            ray,
            f32::INFINITY,
            StepOptions::default(),
        )
        .expect("step");
        let Trace::Hit(h) = tr else { continue };
        n += 1;
        let r = refine_hit(&img, &ray, f32::INFINITY, &h);
        raw_ok += usize::from((h.pixel - q.truncate()).length() <= 1.0);
        refined_ok += usize::from((r.pixel - q.truncate()).length() <= 1.0);
        // The refined point lies on the ray and projects to its pixel.
        let back = cam.project(ray.at(r.t)).expect("in front");
        assert!(
            (back.truncate() - r.pixel).length() < 1e-2,
            "{back:?} vs {:?}",
            r.pixel
        );
        assert!(r.work.fetches > h.work.fetches);
        // Where the refined hit is found, its point lies on the ground
        // plane (the plane through the texel centers is y = 0 up to f32).
        if r.t != h.t {
            refined += 1;
            let y = f64::from(ray.at(r.t).y);
            assert!(y.abs() < 1e-3 * t_exact.max(1.0), "y = {y} at t {}", r.t);
        }
    }
    assert!(n > 200, "{n} hits");
    assert!(refined * 2 > n, "refined {refined} of {n}");
    assert!(
        refined_ok as f64 >= 0.99 * n as f64,
        "refined {refined_ok} of {n} (raw {raw_ok}, changed {refined})"
    );
    assert!(
        refined_ok > raw_ok,
        "raw {raw_ok}, refined {refined_ok} of {n}"
    );
    eprintln!("grazing ground: plate hits within 1 px {raw_ok}/{n}, refined {refined_ok}/{n} ({refined} changed)");
}

/// At a silhouette (wall edge in front of far ground) the neighbors across
/// the jump are not used: a hit on the wall's edge texel stays on the wall.
#[test]
fn silhouettes_are_not_interpolated() {
    let cam = camera();
    let data = depth_image(&cam, Some(-3.0));
    let view = ImageView::try_new(&data, W, H, W).expect("view");
    let img = DepthImage::try_new(view, cam, DepthConvention::Linear).expect("image");
    // Every wall texel on the silhouette column: a hit there, refined.
    let mut checked = 0;
    for y in 10..H - 10 {
        for x in 1..W - 1 {
            let z = data[(y * W + x) as usize];
            let right = data[(y * W + x + 1) as usize];
            if !(z.is_finite() && right.is_finite() && (right - z).abs() > z * 0.15) {
                continue;
            }
            // A ray straight into this texel's center from the eye.
            let px = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let ray = cam.primary_ray(px);
            let t = z / (-cam.world_to_view(cam.eye() + ray.dir).z);
            let hit = refl_core::DepthHit {
                pixel: px,
                t,
                depth: z,
                surface_depth: z,
                work: refl_core::Work::default(),
            };
            let r = refine_hit(&img, &ray, f32::INFINITY, &hit);
            // Still on the wall: depth close to the wall texel's.
            assert!(
                (r.depth - z).abs() <= 0.02 * z,
                "({x},{y}): {} vs {z}",
                r.depth
            );
            checked += 1;
        }
    }
    assert!(checked > 5, "{checked} silhouette texels");
}

/// Without continuous neighbors (a 1x1 image) or with a non-finite
/// surface the hit comes back unchanged.
#[test]
fn isolated_texels_are_left_alone() {
    let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 0.1, 10.0, 1, 1)
        .expect("camera");
    let data = [2.0f32];
    let view = ImageView::try_new(&data, 1, 1, 1).expect("view");
    let img = DepthImage::try_new(view, cam, DepthConvention::Linear).expect("image");
    let ray = cam.primary_ray(Vec2::new(0.5, 0.5));
    let hit = refl_core::DepthHit {
        pixel: Vec2::new(0.5, 0.5),
        t: 2.0,
        depth: 2.0,
        surface_depth: 2.0,
        work: refl_core::Work::default(),
    };
    let r = refine_hit(&img, &ray, f32::INFINITY, &hit);
    assert_eq!(r.pixel, hit.pixel);
    assert_eq!(r.t, hit.t);
}
