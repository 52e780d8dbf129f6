//! refl_cone_*: results equal refl-core's, row-band builds equal whole
//! builds, and error paths return their documented status with outputs
//! untouched.
#![allow(clippy::undocumented_unsafe_blocks)]

use refl::*;
use refl_core::cone::{ConeOptions, FadeRange, Fades, MultiRayOptions};
use refl_core::glam::{Vec2, Vec3};
use refl_core::{
    try_build_hiz, try_hiz_len, Camera, Cone, ConePyramids, DepthConvention, DepthImage, HiZ,
    HiZOptions, ImageView, Ray, Thickness,
};

const W: u32 = 37;
const H: u32 = 23;

fn camera() -> Camera {
    Camera::try_look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 1.0, 0.1, 100.0, W, H).unwrap()
}

struct Frame {
    cam: Camera,
    hiz: Vec<refl_vec2>,
    img: Vec<refl_vec3>,
}

fn frame(conv: DepthConvention) -> Frame {
    let cam = camera();
    let mut depth = vec![cam.encode_depth(8.0, conv); (W * H) as usize];
    for y in 12..H {
        for x in 0..W {
            depth[(y * W + x) as usize] = cam.encode_depth(3.0 + 0.2 * (y - 12) as f32, conv);
        }
    }
    let di = DepthImage::try_new(ImageView::try_new(&depth, W, H, W).unwrap(), cam, conv).unwrap();
    let mut hz = vec![[0.0f32; 2]; try_hiz_len(W, H).unwrap()];
    try_build_hiz(&mut hz, &di).unwrap();
    let hiz = hz.iter().map(|t| refl_vec2 { x: t[0], y: t[1] }).collect();
    let img = (0..W * H)
        .map(|i| refl_vec3 {
            x: (i % W) as f32 / W as f32,
            y: (i / W) as f32 / H as f32,
            z: 0.5,
        })
        .collect();
    Frame { cam, hiz, img }
}

fn hiz_c(f: &Frame, conv: DepthConvention) -> refl_hiz {
    refl_hiz {
        data: f.hiz.as_ptr(),
        len: f.hiz.len(),
        camera: (&f.cam).into(),
        convention: conv as u32,
    }
}

fn image_c(f: &Frame) -> refl_image_vec3 {
    refl_image_vec3 {
        data: f.img.as_ptr(),
        len: f.img.len(),
        width: W,
        height: H,
        stride: W,
    }
}

/// The pyramid lengths through the C ABI (checked to succeed).
fn pyramid_lens() -> (usize, usize) {
    let (mut n, mut nv) = (0usize, 0usize);
    assert_eq!(
        unsafe { refl_cone_pyramid_len(&mut n, &mut nv, W, H) },
        refl_status::Ok
    );
    (n, nv)
}

/// The Hi-Z level count through the C ABI (checked to succeed).
fn hiz_levels() -> u32 {
    let mut levels = 0u32;
    let mut hiz_n = 0usize;
    assert_eq!(
        unsafe { refl_hiz_len(&mut hiz_n, &mut levels, W, H) },
        refl_status::Ok
    );
    levels
}

/// Level `level` of the Hi-Z layout through the C ABI (checked to
/// succeed).
fn hiz_level(level: u32) -> refl_hiz_level_info {
    let mut info = refl_hiz_level_info::default();
    assert_eq!(
        unsafe { refl_hiz_level(&mut info, W, H, level) },
        refl_status::Ok
    );
    info
}

/// A frame's cone pyramids built whole through the C ABI (checked to
/// succeed), and refl-core's.
struct Pyramids {
    f: Frame,
    conv: DepthConvention,
    color: Vec<refl_vec3>,
    vis: Vec<f32>,
    core_color: Vec<[f32; 3]>,
    core_hiz: Vec<[f32; 2]>,
    core_vis: Vec<f32>,
}

fn pyramids(conv: DepthConvention) -> Pyramids {
    let f = frame(conv);
    let (n, nv) = pyramid_lens();
    let img = image_c(&f);
    let mut color = vec![refl_vec3::default(); n];
    assert_eq!(
        unsafe { refl_cone_build_color(color.as_mut_ptr(), n, &img, 1.0) },
        refl_status::Ok
    );
    let core_img: Vec<[f32; 3]> = f.img.iter().map(|v| [v.x, v.y, v.z]).collect();
    let mut core_color = vec![[0.0f32; 3]; n];
    refl_core::try_build_color_pyramid(
        &mut core_color,
        &ImageView::try_new(&core_img, W, H, W).unwrap(),
        1.0,
    )
    .unwrap();
    let hz = hiz_c(&f, conv);
    let mut vis = vec![0.0f32; nv];
    assert_eq!(
        unsafe { refl_cone_build_visibility(vis.as_mut_ptr(), nv, &hz) },
        refl_status::Ok
    );
    let core_hiz: Vec<[f32; 2]> = f.hiz.iter().map(|t| [t.x, t.y]).collect();
    let chz = HiZ::try_new(&core_hiz, f.cam, conv).unwrap();
    let mut core_vis = vec![0.0f32; nv];
    refl_core::try_build_visibility_pyramid(&mut core_vis, &chz).unwrap();
    Pyramids {
        f,
        conv,
        color,
        vis,
        core_color,
        core_hiz,
        core_vis,
    }
}

impl Pyramids {
    /// The C pyramids.
    fn c(&self) -> refl_cone_pyramids {
        refl_cone_pyramids {
            hiz: hiz_c(&self.f, self.conv),
            color: self.color.as_ptr(),
            color_len: self.color.len(),
            visibility: self.vis.as_ptr(),
            visibility_len: self.vis.len(),
        }
    }

    /// refl-core's pyramids.
    fn core(&self) -> ConePyramids<'_> {
        let chz = HiZ::try_new(&self.core_hiz, self.f.cam, self.conv).unwrap();
        ConePyramids::try_new(chz, &self.core_color, &self.core_vis).unwrap()
    }
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn pyramid_lengths_equal_core_and_match_the_hiz_layout() {
    let (n, nv) = pyramid_lens();
    assert_eq!(n, refl_core::try_color_pyramid_len(W, H).unwrap());
    assert_eq!(nv, refl_core::try_visibility_pyramid_len(W, H).unwrap());
    let mut levels = 0u32;
    let mut hiz_n = 0usize;
    assert_eq!(
        unsafe { refl_hiz_len(&mut hiz_n, &mut levels, W, H) },
        refl_status::Ok
    );
    // The Hi-Z pyramid ends with its stamp; the cone pyramids do not.
    assert_eq!(
        hiz_n - refl_core::HIZ_STAMP_TEXELS,
        n - refl_core::COLOR_STAMP_TEXELS
    );
}

#[test]
fn color_pyramid_equals_core() {
    for conv in DepthConvention::ALL {
        let p = pyramids(conv);
        assert!(p
            .color
            .iter()
            .zip(&p.core_color)
            .all(|(a, b)| [a.x, a.y, a.z] == *b));
    }
}

#[test]
fn color_pyramid_row_bands_equal_the_whole_build() {
    for conv in DepthConvention::ALL {
        let p = pyramids(conv);
        let n = p.color.len();
        let img = image_c(&p.f);
        // Row bands, level by level, equal the whole build.
        let mut banded = vec![refl_vec3::default(); n];
        for level in 0..hiz_levels() {
            let info = hiz_level(level);
            let mid = info.height / 2;
            for (a, b) in [(0, mid), (mid, info.height)] {
                if a == b {
                    continue;
                }
                assert_eq!(
                    unsafe {
                        refl_cone_build_color_rows(
                            banded.as_mut_ptr(),
                            n,
                            &img,
                            level,
                            refl_row_range { begin: a, end: b },
                            1.0,
                        )
                    },
                    refl_status::Ok
                );
            }
        }
        assert_eq!(banded, p.color);
    }
}

#[test]
fn visibility_pyramid_rows_equal_the_whole_build() {
    for conv in DepthConvention::ALL {
        let p = pyramids(conv);
        let nv = p.vis.len();
        let hz = hiz_c(&p.f, conv);
        let mut vb = vec![0.0f32; nv];
        for level in 0..hiz_levels() {
            let info = hiz_level(level);
            assert_eq!(
                unsafe {
                    refl_cone_build_visibility_rows(
                        vb.as_mut_ptr(),
                        nv,
                        &hz,
                        level,
                        refl_row_range {
                            begin: 0,
                            end: info.height,
                        },
                    )
                },
                refl_status::Ok
            );
        }
        assert_eq!(bits(&vb), bits(&p.vis));
    }
}

#[test]
fn visibility_pyramid_equals_core() {
    for conv in DepthConvention::ALL {
        let p = pyramids(conv);
        assert_eq!(bits(&p.core_vis), bits(&p.vis));
    }
}

#[test]
fn cone_options_default_is_cores() {
    let opts = refl_cone_options_default();
    assert_eq!(ConeOptions::from(opts), ConeOptions::default());
}

/// The traced cone, through the C ABI.
const CONE: refl_cone = refl_cone {
    apex: refl_vec2 { x: 18.0, y: 20.0 },
    apex_depth: 4.0,
    hit: refl_vec2 { x: 20.0, y: 5.0 },
    hit_depth: 8.0,
    theta: 0.1,
    n_dot_v: 0.7,
    travel: 3.0,
};

/// The fallback color.
const FALLBACK: refl_vec3 = refl_vec3 {
    x: 0.1,
    y: 0.2,
    z: 0.3,
};

#[test]
fn cone_trace_equals_core() {
    for conv in DepthConvention::ALL {
        let p = pyramids(conv);
        let pyr = p.c();
        let opts = refl_cone_options_default();
        let (c, fb) = (CONE, FALLBACK);
        let mut out = refl_cone_result::default();
        assert_eq!(
            unsafe { refl_cone_trace(&mut out, &pyr, &c, fb, &opts) },
            refl_status::Ok
        );
        let r = refl_core::try_cone_trace(
            &p.core(),
            &Cone {
                apex: Vec2::new(18.0, 20.0),
                apex_depth: 4.0,
                hit: Vec2::new(20.0, 5.0),
                hit_depth: 8.0,
                theta: 0.1,
                n_dot_v: 0.7,
                travel: 3.0,
            },
            [0.1, 0.2, 0.3],
            &ConeOptions::default(),
        )
        .unwrap();
        assert_eq!([out.color.x, out.color.y, out.color.z], r.color);
        assert_eq!(
            (out.coverage, out.circles, out.fetches),
            (r.coverage, r.circles, r.fetches)
        );
        assert!(out.coverage > 0.0);
    }
}

#[test]
fn cone_trace_errors_leave_the_output_untouched() {
    for conv in DepthConvention::ALL {
        let p = pyramids(conv);
        let pyr = p.c();
        let n = p.color.len();
        let opts = refl_cone_options_default();
        let (c, fb) = (CONE, FALLBACK);
        let sentinel = refl_cone_result {
            coverage: 42.0,
            ..Default::default()
        };
        for (bad_c, bad_fb) in [
            (
                refl_cone {
                    theta: f32::NAN,
                    ..c
                },
                fb,
            ),
            (
                refl_cone {
                    apex_depth: -1.0,
                    ..c
                },
                fb,
            ),
            (
                c,
                refl_vec3 {
                    x: f32::INFINITY,
                    y: 0.0,
                    z: 0.0,
                },
            ),
        ] {
            let mut o = sentinel;
            assert_eq!(
                unsafe { refl_cone_trace(&mut o, &pyr, &bad_c, bad_fb, &opts) },
                refl_status::InvalidArgument
            );
            assert_eq!(o, sentinel);
        }
        let mut o = sentinel;
        assert_eq!(
            unsafe { refl_cone_trace(&mut o, core::ptr::null(), &c, fb, &opts) },
            refl_status::NullPointer
        );
        let short = refl_cone_pyramids {
            color_len: n - 1,
            ..pyr
        };
        assert_eq!(
            unsafe { refl_cone_trace(&mut o, &short, &c, fb, &opts) },
            refl_status::InsufficientSize
        );
        assert_eq!(o, sentinel);
    }
}

/// The multi-ray options of the tests, through the C ABI.
const MULTIRAY_OPTIONS: refl_cone_multiray_options = refl_cone_multiray_options {
    rays: 9,
    rotation: refl_vec2 { x: 0.25, y: 0.5 },
    hiz: refl_hiz_options {
        start_level: 2,
        stop_level: 0,
        max_iterations: 256,
        prologue_steps: 4,
    },
};

/// The multi-ray tests' ray.
fn multiray_ray() -> Ray {
    Ray {
        origin: Vec3::new(0.0, -0.5, -3.5),
        dir: Vec3::new(0.0, 0.2, -1.0).normalize(),
    }
}

/// `refl_cone_multiray` on the pyramids `pyr` with the tests' ray, an
/// infinite constant thickness, normal +y, the fallback color and the
/// options `mo`.
fn multiray_c(
    out: &mut refl_cone_multiray_result,
    pyr: &refl_cone_pyramids,
    mo: &refl_cone_multiray_options,
) -> refl_status {
    let th = refl_trace_thickness {
        constant: f32::INFINITY,
        back_faces: refl_image_f32 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
    };
    unsafe {
        refl_cone_multiray(
            out,
            pyr,
            &th,
            multiray_ray().into(),
            Vec3::Y.into(),
            100.0,
            0.2,
            30.0,
            mo,
            FALLBACK,
        )
    }
}

#[test]
fn multiray_equals_core() {
    for conv in DepthConvention::ALL {
        let p = pyramids(conv);
        let ray = multiray_ray();
        let mut mr = refl_cone_multiray_result::default();
        assert_eq!(
            multiray_c(&mut mr, &p.c(), &MULTIRAY_OPTIONS),
            refl_status::Ok
        );
        let cr = refl_core::try_multiray(
            &p.core(),
            Thickness::Constant(f32::INFINITY),
            ray,
            Vec3::Y,
            100.0,
            0.2,
            30.0,
            &MultiRayOptions {
                rays: 9,
                rotation: Vec2::new(0.25, 0.5),
                hiz: HiZOptions {
                    start_level: 2,
                    stop_level: 0,
                    max_iterations: 256,
                    prologue_steps: 4,
                },
            },
            |_| [0.1, 0.2, 0.3],
        )
        .unwrap();
        assert_eq!([mr.color.x, mr.color.y, mr.color.z], cr.color);
        assert_eq!((mr.traced, mr.hits), (cr.traced, cr.hits));
    }
}

#[test]
fn multiray_refuses_zero_rays_untouched() {
    for conv in DepthConvention::ALL {
        let p = pyramids(conv);
        let mut mr2 = refl_cone_multiray_result {
            traced: 77,
            ..Default::default()
        };
        assert_eq!(
            multiray_c(
                &mut mr2,
                &p.c(),
                &refl_cone_multiray_options {
                    rays: 0,
                    ..MULTIRAY_OPTIONS
                }
            ),
            refl_status::InvalidArgument
        );
        assert_eq!(mr2.traced, 77);
    }
}

#[test]
fn cone_angles_equal_core_and_errors_leave_the_output_untouched() {
    let mut t = -1.0f32;
    assert_eq!(
        unsafe { refl_cone_angle_from_phong(&mut t, 10.0) },
        refl_status::Ok
    );
    assert_eq!(t, refl_core::try_cone_angle_from_phong(10.0).unwrap());
    assert_eq!(
        unsafe { refl_cone_angle_from_roughness(&mut t, 0.5) },
        refl_status::Ok
    );
    assert_eq!(t, refl_core::try_cone_angle_from_roughness(0.5).unwrap());
    let keep = t;
    assert_eq!(
        unsafe { refl_cone_angle_from_phong(&mut t, f32::NAN) },
        refl_status::InvalidArgument
    );
    assert_eq!(
        unsafe { refl_cone_angle_from_roughness(&mut t, 2.0) },
        refl_status::InvalidArgument
    );
    assert_eq!(t, keep);
    assert_eq!(
        unsafe { refl_cone_angle_from_phong(core::ptr::null_mut(), 1.0) },
        refl_status::NullPointer
    );
}

#[test]
fn fades_equal_core_and_bad_ranges_leave_the_output_untouched() {
    let fades = refl_cone_fades {
        toward_camera: refl_cone_fade_range {
            enabled: false,
            start: 0.0,
            end: 0.0,
        },
        border: refl_cone_fade_range {
            enabled: true,
            start: 0.8,
            end: 1.0,
        },
        travel: refl_cone_fade_range {
            enabled: true,
            start: 2.0,
            end: 6.0,
        },
    };
    let mut v = -1.0f32;
    let (r, e, h) = (
        Vec3::X.into(),
        Vec3::Z.into(),
        refl_vec2 { x: 95.0, y: 25.0 },
    );
    assert_eq!(
        unsafe { refl_cone_fade(&mut v, &fades, r, e, h, 100, 50, 5.0) },
        refl_status::Ok
    );
    let core = Fades {
        toward_camera: None,
        border: Some(FadeRange {
            start: 0.8,
            end: 1.0,
        }),
        travel: Some(FadeRange {
            start: 2.0,
            end: 6.0,
        }),
    }
    .try_factor(Vec3::X, Vec3::Z, Vec2::new(95.0, 25.0), 100, 50, 5.0)
    .unwrap();
    assert_eq!(v, core);
    // The disabled toward-camera range is invalid but ignored; enabling it
    // is an error, as is an enabled travel range that runs backward.
    let keep = v;
    let on = |r: refl_cone_fade_range| refl_cone_fade_range { enabled: true, ..r };
    let backward = refl_cone_fade_range {
        enabled: true,
        start: 6.0,
        end: 2.0,
    };
    for bad in [
        refl_cone_fades {
            toward_camera: on(fades.toward_camera),
            ..fades
        },
        refl_cone_fades {
            travel: backward,
            ..fades
        },
    ] {
        assert_eq!(
            unsafe { refl_cone_fade(&mut v, &bad, r, e, h, 100, 50, 5.0,) },
            refl_status::InvalidArgument
        );
    }
    assert_eq!(v, keep);
}

#[test]
fn color_pyramid_build_errors_leave_dst_untouched() {
    let f = frame(DepthConvention::ReversedZ);
    let n = refl_core::try_color_pyramid_len(W, H).unwrap();
    let mut color = vec![
        refl_vec3 {
            x: 7.0,
            y: 7.0,
            z: 7.0
        };
        n
    ];
    let img = image_c(&f);
    assert_eq!(
        unsafe { refl_cone_build_color(color.as_mut_ptr(), n - 1, &img, 1.0) },
        refl_status::InsufficientSize
    );
    assert_eq!(
        unsafe { refl_cone_build_color(color.as_mut_ptr(), n, &img, f32::NAN) },
        refl_status::InvalidArgument
    );
    assert_eq!(
        unsafe { refl_cone_build_color(color.as_mut_ptr(), n, core::ptr::null(), 1.0) },
        refl_status::NullPointer
    );
    assert_eq!(
        unsafe {
            refl_cone_build_color_rows(
                color.as_mut_ptr(),
                n,
                &img,
                99,
                refl_row_range { begin: 0, end: 1 },
                1.0,
            )
        },
        refl_status::InvalidArgument
    );
    let mut nan_img = f.img.clone();
    nan_img[5].y = f32::NAN;
    let bad = refl_image_vec3 {
        data: nan_img.as_ptr(),
        ..img
    };
    assert_eq!(
        unsafe { refl_cone_build_color(color.as_mut_ptr(), n, &bad, 1.0) },
        refl_status::InvalidArgument
    );
    assert!(color.iter().all(|c| c.x == 7.0));
}

#[test]
fn visibility_pyramid_build_errors_leave_dst_untouched() {
    let f = frame(DepthConvention::ReversedZ);
    let hz = hiz_c(&f, DepthConvention::ReversedZ);
    let n = refl_core::try_visibility_pyramid_len(W, H).unwrap();
    let mut vis = vec![7.0f32; n];
    assert_eq!(
        unsafe { refl_cone_build_visibility(vis.as_mut_ptr(), n - 1, &hz) },
        refl_status::InsufficientSize
    );
    assert_eq!(
        unsafe {
            refl_cone_build_visibility(
                vis.as_mut_ptr(),
                n,
                &refl_hiz {
                    convention: 9,
                    ..hz
                },
            )
        },
        refl_status::InvalidArgument
    );
    assert_eq!(
        unsafe {
            refl_cone_build_visibility_rows(
                vis.as_mut_ptr(),
                n,
                &hz,
                0,
                refl_row_range { begin: 3, end: 2 },
            )
        },
        refl_status::InvalidArgument
    );
    assert!(vis.iter().all(|&x| x == 7.0));
}
