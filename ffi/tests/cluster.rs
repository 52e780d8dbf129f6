//! The seed 003 cluster exports: the whole pipeline through the C ABI
//! (count per band, layout, assign per band, ranges, cameras, finalize)
//! equals refl-core's, and error statuses leave outputs untouched.

use refl::*;
use refl_core::cluster::{self, ClusterCameraOptions, ClusterInput, ClusterOptions, ClusterView};
use refl_core::glam::{DVec3, Vec2, Vec3};
use refl_core::{Camera, DepthConvention, DepthImage, ImageView, ImageViewMut, RowRange};

const W: u32 = 40;
const H: u32 = 30;

struct Frame {
    pos: Vec<[f32; 3]>,
    nor: Vec<[f32; 3]>,
    obj: Vec<u32>,
    eye: Vec3,
}

/// A floor (object 0) and a sphere (object 1) seen by a camera, per pixel
/// center in f64.
fn frame() -> Frame {
    let cam = Camera::try_look_at(
        Vec3::new(0.0, 2.0, 5.0),
        Vec3::new(0.0, 0.3, -1.0),
        Vec3::Y,
        1.0,
        0.05,
        100.0,
        W,
        H,
    )
    .unwrap();
    let n = (W * H) as usize;
    let mut f = Frame {
        pos: vec![[0.0; 3]; n],
        nor: vec![[0.0, 1.0, 0.0]; n],
        obj: vec![u32::MAX; n],
        eye: cam.eye(),
    };
    let c = DVec3::new(0.0, 1.3, -1.0);
    for y in 0..H {
        for x in 0..W {
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (o, d) = (r.origin.as_dvec3(), r.dir.as_dvec3());
            let oc = o - c;
            let b = oc.dot(d);
            let disc = b * b - (oc.length_squared() - 1.69);
            let i = (y * W + x) as usize;
            if disc > 0.0 {
                let p = o + d * (-b - disc.sqrt());
                f.pos[i] = p.as_vec3().to_array();
                f.nor[i] = (p - c).normalize().as_vec3().to_array();
                f.obj[i] = 1;
            } else if d.y < 0.0 {
                let p = o + d * (-o.y / d.y);
                f.pos[i] = p.as_vec3().to_array();
                f.obj[i] = 0;
            }
        }
    }
    f
}

fn u32_img(d: &[u32]) -> refl_image_u32 {
    refl_image_u32 {
        data: d.as_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

fn vec3_img(d: &[[f32; 3]], w: u32, h: u32) -> refl_image_vec3 {
    refl_image_vec3 {
        data: d.as_ptr().cast(),
        len: d.len(),
        width: w,
        height: h,
        stride: w,
    }
}

/// The clustering options of the pipeline tests.
fn params() -> refl_cluster_options {
    let mut params = refl_cluster_options_default();
    params.gain = 8.0;
    params
}

/// The pipeline through the C ABI up to the pixel lists, each call
/// checked to succeed: object counts (in two bands), the bin layout and
/// cluster ids (in two bands) give the bin count and the pixels of every
/// cluster in order.
struct Pipeline {
    counts: [u32; 2],
    total: u32,
    offsets: Vec<u32>,
    order: Vec<u32>,
    clustered: u32,
}

fn c_counts(f: &Frame) -> [u32; 2] {
    let mut counts = [0u32; 2];
    for (b, e) in [(0, 13), (13, H)] {
        let st = unsafe {
            refl_cluster_count_objects(
                counts.as_mut_ptr(),
                2,
                u32_img(&f.obj),
                refl_row_range { begin: b, end: e },
            )
        };
        assert_eq!(st, refl_status::Ok);
    }
    counts
}

fn c_layout(counts: &[u32; 2]) -> ([refl_cluster_object_bins; 2], u32) {
    let mut layout = [refl_cluster_object_bins::default(); 2];
    let mut total = 0u32;
    let st = unsafe {
        refl_cluster_bin_layout(
            &mut total,
            layout.as_mut_ptr(),
            2,
            counts.as_ptr(),
            2,
            u64::from(W * H),
            &params(),
        )
    };
    assert_eq!(st, refl_status::Ok);
    (layout, total)
}

fn c_ids(f: &Frame, layout: &[refl_cluster_object_bins; 2]) -> Vec<u32> {
    let mut ids = vec![0u32; (W * H) as usize];
    for (b, e) in [(0, 7), (7, H)] {
        let img = refl_image_u32_mut {
            data: ids.as_mut_ptr(),
            len: ids.len(),
            width: W,
            height: H,
            stride: W,
        };
        let st = unsafe {
            refl_cluster_assign(
                img,
                refl_row_range { begin: b, end: e },
                vec3_img(&f.nor, W, H),
                u32_img(&f.obj),
                layout.as_ptr(),
                2,
            )
        };
        assert_eq!(st, refl_status::Ok);
    }
    ids
}

fn pipeline(f: &Frame) -> Pipeline {
    let counts = c_counts(f);
    let (layout, total) = c_layout(&counts);
    let ids = c_ids(f, &layout);
    let mut offsets = vec![0u32; total as usize + 1];
    let mut order = vec![0u32; (W * H) as usize];
    let mut clustered = 0u32;
    let st = unsafe {
        refl_cluster_ranges(
            &mut clustered,
            offsets.as_mut_ptr(),
            offsets.len(),
            order.as_mut_ptr(),
            order.len(),
            u32_img(&ids),
            total,
        )
    };
    assert_eq!(st, refl_status::Ok);
    Pipeline {
        counts,
        total,
        offsets,
        order,
        clustered,
    }
}

/// refl-core's bin layout for the object counts `counts`.
fn core_layout(counts: &[u32; 2]) -> ([cluster::ObjectBins; 2], u32) {
    let mut core_layout = [cluster::ObjectBins::default(); 2];
    let core_total = cluster::try_bin_layout(
        &mut core_layout,
        counts,
        u64::from(W * H),
        &ClusterOptions::from(params()),
    )
    .unwrap();
    (core_layout, core_total)
}

#[test]
fn counts_in_row_bands_equal_core() {
    let f = frame();
    let counts = c_counts(&f);
    let mut core_counts = [0u32; 2];
    let ov = ImageView::try_new(&f.obj, W, H, W).unwrap();
    cluster::try_count_objects(&mut core_counts, &ov, RowRange::try_all(H).unwrap()).unwrap();
    assert_eq!(counts, core_counts);
    assert!(counts[0] > 100 && counts[1] > 50, "{counts:?}");
}

#[test]
fn bin_layout_equals_core_within_bins_max() {
    let f = frame();
    let params = params();
    let counts = c_counts(&f);
    let (layout, total) = c_layout(&counts);
    let (core_layout, core_total) = core_layout(&counts);
    assert_eq!(total, core_total);
    for k in 0..2 {
        assert_eq!(cluster::ObjectBins::from(layout[k]), core_layout[k]);
    }
    let mut max = 0u32;
    assert_eq!(
        unsafe { refl_cluster_bins_max(&mut max, 2, &params) },
        refl_status::Ok
    );
    assert!(total <= max);
}

#[test]
fn assign_in_row_bands_equals_core() {
    let f = frame();
    let counts = c_counts(&f);
    let (layout, _) = c_layout(&counts);
    let ids = c_ids(&f, &layout);
    let (core_layout, _) = core_layout(&counts);
    let mut core_ids = vec![0u32; (W * H) as usize];
    let ov = ImageView::try_new(&f.obj, W, H, W).unwrap();
    let nv = ImageView::try_new(&f.nor, W, H, W).unwrap();
    cluster::try_assign_clusters(
        &mut ImageViewMut::try_new(&mut core_ids, W, H, W).unwrap(),
        &nv,
        &ov,
        &core_layout,
    )
    .unwrap();
    assert_eq!(ids, core_ids);
}

#[test]
fn ranges_hold_every_counted_pixel() {
    let f = frame();
    let p = pipeline(&f);
    assert_eq!(p.clustered, p.counts[0] + p.counts[1]);
}

/// The camera options of the pipeline tests.
fn cam_params() -> refl_cluster_camera_options {
    let mut cam_params = refl_cluster_camera_options_default();
    cam_params.far_distance = 30.0;
    cam_params
}

/// Runs `check(px, camera, core view)` on every non-empty cluster of the
/// pipeline: its pixels, its camera through the C ABI (checked to
/// succeed) and refl-core's.
fn for_each_cluster_camera(
    f: &Frame,
    mut check: impl FnMut(&[u32], &refl_cluster_camera, ClusterView),
) {
    let p = pipeline(f);
    let (offsets, order, total) = (&p.offsets, &p.order, p.total);
    let cam_params = cam_params();
    let input = ClusterInput {
        positions: ImageView::try_new(&f.pos, W, H, W).unwrap(),
        normals: ImageView::try_new(&f.nor, W, H, W).unwrap(),
    };
    for c in 0..total as usize {
        let px = &order[offsets[c] as usize..offsets[c + 1] as usize];
        if px.is_empty() {
            continue;
        }
        let mut out = core::mem::MaybeUninit::<refl_cluster_camera>::uninit();
        let st = unsafe {
            refl_cluster_build_camera(
                out.as_mut_ptr(),
                vec3_img(&f.pos, W, H),
                vec3_img(&f.nor, W, H),
                px.as_ptr(),
                px.len(),
                f.eye.into(),
                &cam_params,
            )
        };
        assert_eq!(st, refl_status::Ok);
        let out = unsafe { out.assume_init() };
        let core_view =
            cluster::try_cluster_camera(&input, px, f.eye, &ClusterCameraOptions::from(cam_params))
                .unwrap();
        check(px, &out, core_view);
    }
}

#[test]
fn cluster_cameras_equal_core() {
    let f = frame();
    let mut cameras = 0;
    for_each_cluster_camera(&f, |_, out, core_view| {
        assert_eq!(*out, refl_cluster_camera::from_view(&core_view));
        let ClusterView::Camera(_) = core_view else {
            assert_ne!(out.fallback, 0);
            return;
        };
        cameras += 1;
    });
    assert!(cameras >= 3, "{cameras}");
}

/// The glossy far plane's radius (seed 003 Sec. 3.5 item 2) crosses the
/// ABI: +inf by default (D kept), and a radius that is not > 0 is refused
/// with the camera record untouched.
#[test]
fn glossy_blur_radius_defaults_to_infinity_and_is_checked() {
    let d = refl_cluster_camera_options_default();
    assert_eq!(d.glossy_blur_radius, f32::INFINITY);
    assert_eq!(
        ClusterCameraOptions::from(d),
        ClusterCameraOptions::default()
    );
    let f = frame();
    let p = pipeline(&f);
    let c = (0..p.total as usize)
        .find(|&c| p.offsets[c] < p.offsets[c + 1])
        .unwrap();
    let px = &p.order[p.offsets[c] as usize..p.offsets[c + 1] as usize];
    for bad in [0.0, -2.0, f32::NAN] {
        let k = refl_cluster_camera_options {
            glossy_blur_radius: bad,
            ..cam_params()
        };
        let mut out =
            core::mem::MaybeUninit::<refl_cluster_camera>::new(unsafe { core::mem::zeroed() });
        let st = unsafe {
            refl_cluster_build_camera(
                out.as_mut_ptr(),
                vec3_img(&f.pos, W, H),
                vec3_img(&f.nor, W, H),
                px.as_ptr(),
                px.len(),
                f.eye.into(),
                &k,
            )
        };
        assert_eq!(st, refl_status::InvalidArgument, "{bad}");
        let zero: refl_cluster_camera = unsafe { core::mem::zeroed() };
        assert_eq!(unsafe { out.assume_init() }, zero);
    }
}

/// [`for_each_cluster_camera`] on the clusters refl-core gives a camera.
fn for_each_cluster_with_a_camera(
    f: &Frame,
    mut check: impl FnMut(&[u32], &refl_cluster_camera, cluster::ClusterCamera),
) {
    for_each_cluster_camera(f, |px, out, core_view| {
        if let ClusterView::Camera(cc) = core_view {
            check(px, out, cc);
        }
    });
}

/// A flat depth image at half the far distance of a cluster camera,
/// colored by texel: its size, depth, color and C depth image.
fn flat_render(cam: &Camera) -> (u32, u32, Vec<f32>, Vec<[f32; 3]>, refl_depth_image) {
    let (dw, dh) = (cam.width(), cam.height());
    let depth = vec![cam.far() * 0.5; (dw * dh) as usize];
    let color: Vec<[f32; 3]> = (0..dw * dh)
        .map(|i| [i as f32 / (dw * dh) as f32, 0.5, 0.25])
        .collect();
    let di_c = depth_c(cam, &depth, dw, dh);
    (dw, dh, depth, color, di_c)
}

/// The depth image `depth` (`dw x dh`, linear) seen by `cam`.
fn depth_c(cam: &Camera, depth: &[f32], dw: u32, dh: u32) -> refl_depth_image {
    refl_depth_image {
        depth: refl_image_f32 {
            data: depth.as_ptr(),
            len: depth.len(),
            width: dw,
            height: dh,
            stride: dw,
        },
        camera: cam.into(),
        convention: DepthConvention::Linear as u32,
    }
}

/// The finalize input of the pipeline tests.
fn finalize_input() -> refl_cluster_finalize_input {
    refl_cluster_finalize_input {
        thickness: refl_trace_thickness {
            constant: f32::INFINITY,
            back_faces: refl_image_f32 {
                data: core::ptr::null(),
                len: 0,
                width: 0,
                height: 0,
                stride: 0,
            },
        },
        step: refl_step_options {
            stride: 1,
            max_steps: u32::MAX,
        },
        refine: false,
        lobe: refl_cluster_lobe {
            rays: 8,
            exponent: 30.0,
            max_angle: 0.4,
        },
        fade: false,
        seed: 3,
        single_ray: false,
    }
}

#[test]
fn finalize_of_every_cluster_camera_equals_core() {
    let f = frame();
    let input = ClusterInput {
        positions: ImageView::try_new(&f.pos, W, H, W).unwrap(),
        normals: ImageView::try_new(&f.nor, W, H, W).unwrap(),
    };
    for single_ray in [false, true] {
        for_each_cluster_with_a_camera(&f, |px, out, cc| {
            let (dw, dh, depth, color, di_c) = flat_render(&cc.camera);
            let fp = refl_cluster_finalize_input {
                single_ray,
                ..finalize_input()
            };
            let mut shades = vec![refl_cluster_shade::default(); px.len()];
            let mut fell = 0u32;
            let st = unsafe {
                refl_cluster_finalize(
                    &mut fell,
                    shades.as_mut_ptr(),
                    shades.len(),
                    vec3_img(&f.pos, W, H),
                    vec3_img(&f.nor, W, H),
                    px.as_ptr(),
                    px.len(),
                    f.eye.into(),
                    out,
                    &di_c,
                    vec3_img(&color, dw, dh),
                    &fp,
                )
            };
            assert_eq!(st, refl_status::Ok);
            let di = DepthImage::try_new(
                ImageView::try_new(&depth, dw, dh, dw).unwrap(),
                cc.camera,
                DepthConvention::Linear,
            )
            .unwrap();
            let cv = ImageView::try_new(&color, dw, dh, dw).unwrap();
            let mut core_shades = vec![cluster::ClusterShade::default(); px.len()];
            let core_fell = cluster::try_finalize_cluster(
                &mut core_shades,
                &input,
                px,
                f.eye,
                &cc,
                &di,
                &cv,
                &cluster::FinalizeInput {
                    thickness: refl_core::Thickness::Constant(f32::INFINITY),
                    step: refl_core::StepOptions::default(),
                    refine: false,
                    lobe: cluster::Lobe {
                        rays: 8,
                        exponent: 30.0,
                        max_angle: 0.4,
                    },
                    fade: false,
                    seed: 3,
                    single_ray,
                },
            )
            .unwrap();
            assert_eq!(fell, core_fell);
            for (a, b) in shades.iter().zip(&core_shades) {
                assert_eq!(*a, refl_cluster_shade::from(b));
                // One ray per pixel in the single-ray variant (seed 003 Sec. 4.2.2).
                assert!(!single_ray || a.rays == 1);
            }
        });
    }
}

/// Hostile finalize input: short output, NaN eye, fallback record; the
/// shades and the fallen count untouched.
#[test]
fn finalize_errors_leave_the_shades_untouched() {
    let f = frame();
    for_each_cluster_with_a_camera(&f, |px, out, cc| {
        // `_depth` is the buffer `di_c` points into: kept to the end.
        let (dw, dh, _depth, color, di_c) = flat_render(&cc.camera);
        let fp = finalize_input();
        let sentinel = refl_cluster_shade {
            rays: 99,
            ..Default::default()
        };
        let mut keep = vec![sentinel; px.len()];
        let mut fell2 = 1234u32;
        let call = |keep: &mut [refl_cluster_shade],
                    len: usize,
                    eye: Vec3,
                    cam: &refl_cluster_camera,
                    fell2: &mut u32| unsafe {
            refl_cluster_finalize(
                fell2,
                keep.as_mut_ptr(),
                len,
                vec3_img(&f.pos, W, H),
                vec3_img(&f.nor, W, H),
                px.as_ptr(),
                px.len(),
                eye.into(),
                cam,
                &di_c,
                vec3_img(&color, dw, dh),
                &fp,
            )
        };
        assert_eq!(
            call(&mut keep, px.len() - 1, f.eye, out, &mut fell2),
            refl_status::InsufficientSize
        );
        assert_eq!(
            call(&mut keep, px.len(), Vec3::NAN, out, &mut fell2),
            refl_status::InvalidArgument
        );
        let fallback = refl_cluster_camera {
            fallback: 1,
            ..*out
        };
        assert_eq!(
            call(&mut keep, px.len(), f.eye, &fallback, &mut fell2),
            refl_status::InvalidArgument
        );
        assert!(keep.iter().all(|s| *s == sentinel) && fell2 == 1234);
    });
}

#[test]
fn bins_max_errors_leave_the_output_untouched() {
    let params = refl_cluster_options {
        max_theta_bins: 13,
        max_phi_bins: 8,
        gain: f32::NAN,
    };
    let mut max = 7u32;
    assert_eq!(
        unsafe { refl_cluster_bins_max(&mut max, 2, &params) },
        refl_status::InvalidArgument
    );
    assert_eq!(
        unsafe { refl_cluster_bins_max(core::ptr::null_mut(), 2, &params) },
        refl_status::NullPointer
    );
    assert_eq!(max, 7);
}

#[test]
fn counts_of_rows_beyond_the_image_are_refused_untouched() {
    let f = frame();
    let mut counts = [5u32; 2];
    let st = unsafe {
        refl_cluster_count_objects(
            counts.as_mut_ptr(),
            2,
            u32_img(&f.obj),
            refl_row_range {
                begin: 0,
                end: H + 1,
            },
        )
    };
    assert_eq!(st, refl_status::InvalidArgument);
    assert_eq!(counts, [5, 5]);
}

/// The first pixel of object 0.
fn first_of_object_0(f: &Frame) -> usize {
    f.obj.iter().position(|&o| o == 0).unwrap()
}

#[test]
fn assign_refuses_a_nan_normal_on_a_clustered_pixel_untouched() {
    let f = frame();
    let mut nor = f.nor.clone();
    let first = first_of_object_0(&f);
    nor[first] = [f32::NAN, 1.0, 0.0];
    let layout = [refl_cluster_object_bins {
        theta_bins: 1,
        phi_bins: 1,
        first: 0,
    }; 2];
    let mut ids = vec![42u32; (W * H) as usize];
    let img = refl_image_u32_mut {
        data: ids.as_mut_ptr(),
        len: ids.len(),
        width: W,
        height: H,
        stride: W,
    };
    let st = unsafe {
        refl_cluster_assign(
            img,
            refl_row_range { begin: 0, end: H },
            vec3_img(&nor, W, H),
            u32_img(&f.obj),
            layout.as_ptr(),
            2,
        )
    };
    assert_eq!(st, refl_status::InvalidArgument);
    assert!(ids.iter().all(|&v| v == 42));
}

#[test]
fn ranges_refuse_too_few_offsets_untouched() {
    let f = frame();
    let mut offsets = [9u32; 1];
    let mut order = vec![9u32; (W * H) as usize];
    let mut total = 9u32;
    let st = unsafe {
        refl_cluster_ranges(
            &mut total,
            offsets.as_mut_ptr(),
            1,
            order.as_mut_ptr(),
            order.len(),
            u32_img(&f.obj),
            2,
        )
    };
    assert_eq!(st, refl_status::InsufficientSize);
    assert!(total == 9 && offsets == [9] && order.iter().all(|&v| v == 9));
}

#[test]
fn build_camera_refuses_a_nan_position_untouched() {
    let f = frame();
    let first = first_of_object_0(&f);
    let mut pos = f.pos.clone();
    pos[first] = [f32::NAN; 3];
    let px = [
        first as u32,
        first as u32 + 1,
        first as u32 + 2,
        first as u32 + 3,
    ];
    let cp = refl_cluster_camera_options::from(ClusterCameraOptions::default());
    let mut out = core::mem::MaybeUninit::<refl_cluster_camera>::zeroed();
    let st = unsafe {
        refl_cluster_build_camera(
            out.as_mut_ptr(),
            vec3_img(&pos, W, H),
            vec3_img(&f.nor, W, H),
            px.as_ptr(),
            4,
            f.eye.into(),
            &cp,
        )
    };
    assert_eq!(st, refl_status::InvalidArgument);
    assert_eq!(unsafe { out.assume_init() }.camera.width, 0);
}

#[test]
fn lobe_angle_refuses_a_negative_exponent_untouched() {
    let mut a = 3.0f32;
    assert_eq!(
        unsafe { refl_cluster_lobe_angle(&mut a, -1.0, 0.5) },
        refl_status::InvalidArgument
    );
    assert_eq!(a, 3.0);
}
