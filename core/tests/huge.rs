//! A 16384 x 16384 depth image (1 GiB of f32, 2^28 texels): stepping walks
//! a ray across the whole image, Hi-Z's size query and a traced ray through
//! a full pyramid agree with stepping, and the pixel coordinates stay
//! exact; no index or size arithmetic overflows. One test allocates the
//! image once (about 1 GiB, and 2.9 GiB more for the pyramid).
#![cfg(all(feature = "depth-image", feature = "hiz"))]

use glam::{DVec3, Vec3};
use refl_core::hiz::{try_build_hiz, try_hiz_len, try_trace_hiz, HiZ, HiZOptions};
use refl_core::{
    try_step, Camera, DepthConvention, DepthImage, ImageView, Ray, StepOptions, Thickness, Trace,
};

const N: u32 = 16384;

#[test]
fn image_16384_squared_steps_and_hiz_without_overflow() {
    // Camera at the origin looking down -Z at a wall z = -10 (linear depth
    // 10 everywhere: a wall facing the camera has constant view depth).
    let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.2, 0.1, 1000.0, N, N)
        .expect("camera");
    let depth = vec![10.0f32; N as usize * N as usize];
    let view = ImageView::try_new(&depth, N, N, N).expect("view");
    let img = DepthImage::try_new(view, cam, DepthConvention::Linear).expect("image");

    // A ray from near the top-left corner of the view toward the wall's
    // bottom-right region: its projection crosses most of the image.
    let tan = (0.6f64).tan();
    let corner = DVec3::new(-tan * 0.98, tan * 0.98, -1.0);
    let origin = corner * 0.5; // depth 0.5, in front of the wall
    let target = DVec3::new(tan * 0.9 * 10.0, -tan * 0.9 * 10.0, -10.0);
    let dir = (target - origin).normalize();
    let ray = Ray {
        origin: origin.as_vec3(),
        dir: dir.as_vec3(),
    };
    // f64 oracle: the ray meets the plane z = -10.
    let t_exact = (-10.0 - origin.z) / dir.z;
    let q = cam
        .project((origin + dir * t_exact).as_vec3())
        .expect("in front");

    let step = try_step(
        &img,
        Thickness::Constant(1.0),
        ray,
        f32::INFINITY,
        StepOptions::default(),
    )
    .expect("step");
    let Trace::Hit(h) = step else {
        panic!("no hit: {step:?}");
    };
    // The walk crosses on the order of 2 * 16384 texels without a cap.
    assert!(h.work.steps > 16_384, "{} steps", h.work.steps);
    assert!(
        (h.pixel - q.truncate()).length() <= 1.0,
        "{:?} vs {q:?}",
        h.pixel
    );
    assert!(((f64::from(h.t) - t_exact) / t_exact).abs() < 1e-3);

    // Hi-Z: size query in closed form, a full pyramid, the same hit.
    let mut expect = 0usize;
    let mut side = N as usize;
    loop {
        expect += side * side;
        if side == 1 {
            break;
        }
        side /= 2;
    }
    // The levels, then the stamp.
    expect += refl_core::HIZ_STAMP_TEXELS;
    assert_eq!(try_hiz_len(N, N).expect("len"), expect);
    let mut pyramid = vec![[0.0f32; 2]; expect];
    try_build_hiz(&mut pyramid, &img).expect("build");
    let hiz = HiZ::try_new(&pyramid, cam, DepthConvention::Linear).expect("hiz");
    let t = try_trace_hiz(
        &hiz,
        Thickness::Constant(1.0),
        ray,
        f32::INFINITY,
        &HiZOptions::default(),
    )
    .expect("hiz trace");
    let Trace::Hit(hh) = t else {
        panic!("no Hi-Z hit: {t:?}");
    };
    assert!(
        (hh.pixel - h.pixel).length() <= 1.0,
        "{:?} vs {:?}",
        hh.pixel,
        h.pixel
    );
    // Far fewer fetches than the walk.
    assert!(
        hh.work.fetches * 100 < h.work.fetches,
        "{} vs {}",
        hh.work.fetches,
        h.work.fetches
    );
}
