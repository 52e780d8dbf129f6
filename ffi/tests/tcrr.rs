//! The TCRR exports (seed 000) called from Rust: the banded pipeline
//! through the ABI equals refl-core's on a mirror floor reflecting a wall,
//! and every error path returns its documented status with outputs
//! untouched.

use core::mem::MaybeUninit;
use refl::*;
use refl_core::glam::Vec3;
use refl_core::tcrr::{self, CurrentView, ReflectionBuffers, TcrrOptions, INVALID_OFFSET};
use refl_core::{Camera, DepthConvention, ImageView, ImageViewMut};

const W: u32 = 48;
const H: u32 = 36;

fn ok<T>(f: impl FnOnce(*mut T) -> refl_status) -> T {
    let mut v = MaybeUninit::<T>::uninit();
    assert_eq!(f(v.as_mut_ptr()), refl_status::Ok);
    // SAFETY: the function returned OK, so it wrote the output.
    unsafe { v.assume_init() }
}

fn v3(v: Vec3) -> refl_vec3 {
    refl_vec3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

fn camera(eye: Vec3) -> refl_camera {
    ok(|o| unsafe {
        refl_camera_look_at(
            o,
            v3(eye),
            v3(Vec3::new(0.0, 0.4, 0.0)),
            v3(Vec3::Y),
            1.0,
            0.1,
            100.0,
            W,
            H,
        )
    })
}

/// One frame of the scene: a mirror floor (y = 0, specular 0.9) in front
/// of a diffuse wall (z = -6) with a smooth pattern, sky elsewhere.
struct Frame {
    cam: refl_camera,
    depth: Vec<f32>,
    normal: Vec<[f32; 3]>,
    spec: Vec<f32>,
    color: Vec<[f32; 3]>,
    dist: Vec<f32>,
}

fn wall(p: Vec3) -> [f32; 3] {
    [
        0.5 + 0.2 * (p.x * 0.7).sin(),
        0.5 + 0.2 * (p.y * 0.9).cos(),
        0.3,
    ]
}

fn render(eye: Vec3) -> Frame {
    let cam = camera(eye);
    let core = Camera::try_from(&cam).unwrap();
    let n = (W * H) as usize;
    let mut f = Frame {
        cam,
        depth: vec![f32::INFINITY; n],
        normal: vec![[0.0, 0.0, 1.0]; n],
        spec: vec![0.0; n],
        color: vec![[0.0; 3]; n],
        dist: vec![f32::INFINITY; n],
    };
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let ray = core.primary_ray(refl_core::glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (o, d) = (ray.origin, ray.dir);
            let t_floor = if d.y < 0.0 { -o.y / d.y } else { f32::INFINITY };
            let t_wall = if d.z < 0.0 {
                (-6.0 - o.z) / d.z
            } else {
                f32::INFINITY
            };
            if t_floor < t_wall {
                let p = o + d * t_floor;
                f.depth[i] = core.linear_depth(p);
                f.normal[i] = [0.0, 1.0, 0.0];
                f.spec[i] = 0.9;
                let r = Vec3::new(d.x, -d.y, d.z);
                if r.z < 0.0 {
                    let t = (-6.0 - p.z) / r.z;
                    f.dist[i] = t;
                    f.color[i] = wall(p + r * t);
                } else {
                    f.color[i] = [0.2, 0.3, 0.9];
                }
            } else if t_wall.is_finite() {
                f.depth[i] = core.linear_depth(o + d * t_wall);
            }
        }
    }
    f
}

fn img_f32(v: &[f32]) -> refl_image_f32 {
    refl_image_f32 {
        data: v.as_ptr(),
        len: v.len(),
        width: W,
        height: H,
        stride: W,
    }
}
fn img_vec3(v: &[[f32; 3]]) -> refl_image_vec3 {
    refl_image_vec3 {
        data: v.as_ptr().cast(),
        len: v.len(),
        width: W,
        height: H,
        stride: W,
    }
}
fn img_vec2(v: &[[f32; 2]]) -> refl_image_vec2 {
    refl_image_vec2 {
        data: v.as_ptr().cast(),
        len: v.len(),
        width: W,
        height: H,
        stride: W,
    }
}
fn img_u8(v: &[u8]) -> refl_image_u8 {
    refl_image_u8 {
        data: v.as_ptr(),
        len: v.len(),
        width: W,
        height: H,
        stride: W,
    }
}
fn mut_f32(v: &mut [f32]) -> refl_image_f32_mut {
    refl_image_f32_mut {
        data: v.as_mut_ptr(),
        len: v.len(),
        width: W,
        height: H,
        stride: W,
    }
}
fn mut_vec3(v: &mut [[f32; 3]]) -> refl_image_vec3_mut {
    refl_image_vec3_mut {
        data: v.as_mut_ptr().cast(),
        len: v.len(),
        width: W,
        height: H,
        stride: W,
    }
}
fn mut_vec2(v: &mut [[f32; 2]]) -> refl_image_vec2_mut {
    refl_image_vec2_mut {
        data: v.as_mut_ptr().cast(),
        len: v.len(),
        width: W,
        height: H,
        stride: W,
    }
}
fn mut_u8(v: &mut [u8]) -> refl_image_u8_mut {
    refl_image_u8_mut {
        data: v.as_mut_ptr(),
        len: v.len(),
        width: W,
        height: H,
        stride: W,
    }
}

fn key_desc(f: &Frame, surfels: Option<&[refl_tcrr_surfel]>) -> refl_tcrr_key {
    refl_tcrr_key {
        camera: f.cam,
        convention: refl_depth_convention::Linear as u32,
        depth: img_f32(&f.depth),
        normal: img_vec3(&f.normal),
        specular: img_f32(&f.spec),
        color: img_vec3(&f.color),
        distance: img_f32(&f.dist),
        surfels: refl_image_tcrr_surfel {
            data: surfels.map_or(core::ptr::null(), <[_]>::as_ptr),
            len: surfels.map_or(0, <[_]>::len),
            width: W,
            height: H,
            stride: W,
        },
    }
}

fn current_desc(f: &Frame) -> refl_tcrr_current {
    refl_tcrr_current {
        camera: f.cam,
        convention: refl_depth_convention::Linear as u32,
        depth: img_f32(&f.depth),
        specular: img_f32(&f.spec),
    }
}

fn rows(begin: u32, end: u32) -> refl_row_range {
    refl_row_range { begin, end }
}

const BANDS: [(u32, u32); 2] = [(0, 17), (17, H)];

/// Everything one frame produces.
#[derive(Debug, PartialEq)]
struct Out {
    offsets: Vec<[f32; 2]>,
    inter: Vec<[f32; 3]>,
    idepth: Vec<f32>,
    coverage: Vec<u8>,
    color: Vec<[f32; 3]>,
    mask: Vec<u8>,
    list: Vec<u32>,
    final_: Vec<[f32; 3]>,
    stats: (u32, u32, u32),
}

fn through_ffi(key: &Frame, cur: &Frame) -> Out {
    let n = (W * H) as usize;
    let params: refl_tcrr_options = refl_tcrr_options_default();
    let mut surfels = vec![refl_tcrr_surfel::default(); n];
    let plain = key_desc(key, None);
    let mut reflective = 0;
    for (a, b) in BANDS {
        let img = refl_image_tcrr_surfel_mut {
            data: surfels.as_mut_ptr(),
            len: n,
            width: W,
            height: H,
            stride: W,
        };
        let r: u32 = ok(|o| unsafe { refl_tcrr_prepare(img, o, &plain, rows(a, b)) });
        reflective += r;
    }
    assert!(reflective > 0);
    let k = key_desc(key, Some(&surfels));
    let mut offsets = vec![[0.0f32; 2]; n];
    let (mut matched, mut drawn, mut retrace) = (0, 0, 0);
    for (a, b) in BANDS {
        assert_eq!(
            unsafe { refl_tcrr_reset_offsets(mut_vec2(&mut offsets), rows(a, b)) },
            refl_status::Ok
        );
        let s: refl_tcrr_search_stats = ok(|o| unsafe {
            refl_tcrr_search(
                mut_vec2(&mut offsets),
                o,
                &k,
                v3(Camera::try_from(&cur.cam).unwrap().eye()),
                &params,
                rows(a, b),
            )
        });
        matched += s.matched;
    }
    let (mut inter, mut idepth, mut coverage) =
        (vec![[0.0f32; 3]; n], vec![0.0f32; n], vec![0u8; n]);
    for (a, b) in BANDS {
        let s: refl_tcrr_shift_stats = ok(|o| unsafe {
            refl_tcrr_shift(
                mut_vec3(&mut inter),
                mut_f32(&mut idepth),
                mut_u8(&mut coverage),
                o,
                &k,
                img_vec2(&offsets),
                &params,
                rows(a, b),
            )
        });
        drawn += s.drawn;
    }
    let (mut color, mut mask) = (vec![[0.0f32; 3]; n], vec![0u8; n]);
    let cd = current_desc(cur);
    for (a, b) in BANDS {
        let s: refl_tcrr_warp_stats = ok(|o| unsafe {
            refl_tcrr_warp(
                mut_vec3(&mut color),
                mut_u8(&mut mask),
                o,
                &cd,
                &k,
                img_vec3(&inter),
                img_f32(&idepth),
                img_u8(&coverage),
                &params,
                rows(a, b),
            )
        });
        retrace += s.retrace;
    }
    let count: usize =
        ok(|o| unsafe { refl_tcrr_retrace_list(core::ptr::null_mut(), 0, o, img_u8(&mask)) });
    let mut list = vec![0u32; count];
    let wrote: usize =
        ok(|o| unsafe { refl_tcrr_retrace_list(list.as_mut_ptr(), list.len(), o, img_u8(&mask)) });
    assert_eq!(wrote, count);
    let diffuse = vec![[0.25f32, 0.5, 0.75]; n];
    let mut final_ = vec![[0.0f32; 3]; n];
    for (a, b) in BANDS {
        assert_eq!(
            unsafe {
                refl_tcrr_compose(
                    mut_vec3(&mut final_),
                    img_vec3(&diffuse),
                    img_vec3(&color),
                    img_vec3(&cur.normal),
                    &cd,
                    refl_tcrr_fresnel::Schlick as u32,
                    rows(a, b),
                )
            },
            refl_status::Ok
        );
    }
    Out {
        offsets,
        inter,
        idepth,
        coverage,
        color,
        mask,
        list,
        final_,
        stats: (matched, drawn, retrace),
    }
}

fn through_core(key: &Frame, cur: &Frame) -> Out {
    let n = (W * H) as usize;
    let p = TcrrOptions::default();
    let b = ReflectionBuffers::try_new(
        Camera::try_from(&key.cam).unwrap(),
        DepthConvention::Linear,
        ImageView::try_new(&key.depth, W, H, W).unwrap(),
        ImageView::try_new(&key.normal, W, H, W).unwrap(),
        ImageView::try_new(&key.spec, W, H, W).unwrap(),
        ImageView::try_new(&key.color, W, H, W).unwrap(),
        ImageView::try_new(&key.dist, W, H, W).unwrap(),
    )
    .unwrap();
    let ccam = Camera::try_from(&cur.cam).unwrap();
    let mut offsets = vec![INVALID_OFFSET; n];
    let s = tcrr::try_search(
        &mut ImageViewMut::try_new(&mut offsets, W, H, W).unwrap(),
        &b,
        ccam.eye(),
        &p,
    )
    .unwrap();
    let (mut inter, mut idepth, mut coverage) =
        (vec![[0.0f32; 3]; n], vec![0.0f32; n], vec![0u8; n]);
    let sh = tcrr::try_shift(
        &mut ImageViewMut::try_new(&mut inter, W, H, W).unwrap(),
        &mut ImageViewMut::try_new(&mut idepth, W, H, W).unwrap(),
        &mut ImageViewMut::try_new(&mut coverage, W, H, W).unwrap(),
        &b,
        &ImageView::try_new(&offsets, W, H, W).unwrap(),
        &p,
    )
    .unwrap();
    let cv = CurrentView::try_new(
        ccam,
        DepthConvention::Linear,
        ImageView::try_new(&cur.depth, W, H, W).unwrap(),
        ImageView::try_new(&cur.spec, W, H, W).unwrap(),
    )
    .unwrap();
    let (mut color, mut mask) = (vec![[0.0f32; 3]; n], vec![0u8; n]);
    let ws = tcrr::try_warp(
        &mut ImageViewMut::try_new(&mut color, W, H, W).unwrap(),
        &mut ImageViewMut::try_new(&mut mask, W, H, W).unwrap(),
        &cv,
        &b,
        &ImageView::try_new(&inter, W, H, W).unwrap(),
        &ImageView::try_new(&idepth, W, H, W).unwrap(),
        &ImageView::try_new(&coverage, W, H, W).unwrap(),
        &p,
    )
    .unwrap();
    let mv = ImageView::try_new(&mask, W, H, W).unwrap();
    let mut list = vec![0u32; tcrr::retrace_count(&mv)];
    tcrr::try_retrace_list(&mut list, &mv).unwrap();
    let diffuse = vec![[0.25f32, 0.5, 0.75]; n];
    let mut final_ = vec![[0.0f32; 3]; n];
    tcrr::try_compose(
        &mut ImageViewMut::try_new(&mut final_, W, H, W).unwrap(),
        &ImageView::try_new(&diffuse, W, H, W).unwrap(),
        &ImageView::try_new(&color, W, H, W).unwrap(),
        &ImageView::try_new(&cur.normal, W, H, W).unwrap(),
        &cv,
        tcrr::Fresnel::Schlick,
    )
    .unwrap();
    Out {
        offsets,
        inter,
        idepth,
        coverage,
        color,
        mask,
        list,
        final_,
        stats: (s.matched, sh.drawn, ws.retrace),
    }
}

#[test]
fn banded_pipeline_through_the_abi_equals_refl_core() {
    let key = render(Vec3::new(0.0, 1.5, 3.0));
    let cur = render(Vec3::new(0.12, 1.56, 2.9));
    let a = through_ffi(&key, &cur);
    let b = through_core(&key, &cur);
    // Triangles crossing the band boundary are counted in both bands.
    assert!(a.stats.1 >= b.stats.1);
    assert_eq!((a.stats.0, a.stats.2), (b.stats.0, b.stats.2));
    let Out {
        offsets,
        inter,
        idepth,
        coverage,
        color,
        mask,
        list,
        final_,
        ..
    } = a;
    assert_eq!(offsets, b.offsets);
    assert_eq!(inter, b.inter);
    assert_eq!(idepth, b.idepth);
    assert_eq!(coverage, b.coverage);
    assert_eq!(color, b.color);
    assert_eq!(mask, b.mask);
    assert_eq!(list, b.list);
    assert_eq!(final_, b.final_);
    // Most of the floor is reused, some of it is re-traced.
    let reused = mask.iter().filter(|&&m| m == REFL_TCRR_MASK_REUSED).count();
    assert!(reused > 300, "{reused}");
    assert!(!list.is_empty());
}

#[test]
fn scalar_exports_match_refl_core() {
    let p: refl_tcrr_options = refl_tcrr_options_default();
    assert_eq!(TcrrOptions::try_from(&p).unwrap(), TcrrOptions::default());
    let bytes: usize = ok(|o| unsafe { refl_tcrr_frame_bytes(o, 4, 3) });
    assert_eq!(bytes, 12 * REFL_TCRR_BYTES_PER_PIXEL);
    let (eye, w, n, r) = (
        Vec3::new(0.3, 2.0, 1.0),
        Vec3::ZERO,
        Vec3::Y,
        Vec3::new(1.0, 1.5, -2.0),
    );
    for (kind, refl) in [
        (refl_tcrr_reflected::Point, tcrr::Reflected::Point(r)),
        (
            refl_tcrr_reflected::Direction,
            tcrr::Reflected::Direction(r),
        ),
    ] {
        let d: f32 = ok(|o| unsafe {
            refl_tcrr_reflection_distance(o, v3(eye), v3(w), v3(n), v3(r), kind as u32)
        });
        assert_eq!(Some(d), tcrr::reflection_distance(eye, w, n, refl));
    }
    for mode in [refl_tcrr_fresnel::Off, refl_tcrr_fresnel::Schlick] {
        let f: f32 = ok(|o| unsafe { refl_tcrr_fresnel_weight(o, 0.3, 0.4, mode as u32) });
        let m = if mode == refl_tcrr_fresnel::Off {
            tcrr::Fresnel::Off
        } else {
            tcrr::Fresnel::Schlick
        };
        assert_eq!(f, tcrr::fresnel_weight(0.3, 0.4, m));
    }
    let yes: bool = ok(|o| unsafe { refl_tcrr_needs_key_frame(o, 0.3, 31, 100) });
    let no: bool = ok(|o| unsafe { refl_tcrr_needs_key_frame(o, 0.3, 30, 100) });
    assert_eq!((yes, no), (true, false));
}

/// Sentinel-checked scalar output: `expected` status and the output
/// untouched.
fn untouched_f32(expected: refl_status, f: impl FnOnce(*mut f32) -> refl_status) {
    let mut v = -7.5f32;
    assert_eq!(f(&mut v), expected);
    assert_eq!(v, -7.5);
}

use refl_status::{DegenerateGeometry, InsufficientSize, InvalidArgument, NullPointer};

#[test]
fn scalar_exports_refuse_bad_input_untouched() {
    let (eye, w, n, r) = (
        v3(Vec3::Y * 2.0),
        v3(Vec3::ZERO),
        v3(Vec3::Y),
        v3(Vec3::ONE),
    );
    untouched_f32(NullPointer, |_| unsafe {
        refl_tcrr_reflection_distance(core::ptr::null_mut(), eye, w, n, r, 0)
    });
    untouched_f32(InvalidArgument, |o| unsafe {
        refl_tcrr_reflection_distance(o, v3(Vec3::NAN), w, n, r, 0)
    });
    untouched_f32(InvalidArgument, |o| unsafe {
        refl_tcrr_reflection_distance(o, eye, w, n, r, 2)
    });
    // R on the tangent plane: undefined.
    untouched_f32(DegenerateGeometry, |o| unsafe {
        refl_tcrr_reflection_distance(o, eye, w, n, v3(Vec3::X), 0)
    });
    untouched_f32(InvalidArgument, |o| unsafe {
        refl_tcrr_fresnel_weight(o, 0.5, 0.5, 7)
    });
    let mut flag = true;
    assert_eq!(
        unsafe { refl_tcrr_needs_key_frame(&mut flag, f32::NAN, 1, 2) },
        InvalidArgument
    );
    assert_eq!(
        unsafe { refl_tcrr_needs_key_frame(&mut flag, 0.3, 3, 2) },
        InvalidArgument
    );
    assert!(flag);
    let mut bytes = 5usize;
    assert_eq!(
        unsafe { refl_tcrr_frame_bytes(&mut bytes, 0, 3) },
        InvalidArgument
    );
    assert_eq!(bytes, 5);
}

/// The key frame of the error tests.
fn error_key() -> Frame {
    render(Vec3::new(0.0, 1.5, 3.0))
}

/// The eye of the error tests' current frame.
fn error_eye() -> refl_vec3 {
    v3(Vec3::new(0.1, 1.5, 2.9))
}

/// `refl_tcrr_search` without stats.
fn search(
    off: refl_image_vec2_mut,
    k: *const refl_tcrr_key,
    eye: refl_vec3,
    p: *const refl_tcrr_options,
    r: refl_row_range,
) -> refl_status {
    unsafe { refl_tcrr_search(off, core::ptr::null_mut(), k, eye, p, r) }
}

/// The search offsets of the error tests' frame (checked to succeed).
fn searched_offsets(k: &refl_tcrr_key) -> Vec<[f32; 2]> {
    let mut offsets = vec![[3.25f32, -1.0]; (W * H) as usize];
    let p = refl_tcrr_options_default();
    assert_eq!(
        search(mut_vec2(&mut offsets), k, error_eye(), &p, rows(0, H)),
        refl_status::Ok
    );
    offsets
}

#[test]
fn search_refuses_bad_input_untouched_and_accepts_it_repaired() {
    let key = error_key();
    let k = key_desc(&key, None);
    let mut p: refl_tcrr_options = refl_tcrr_options_default();
    let n = (W * H) as usize;
    let sentinel = [3.25f32, -1.0];
    let mut offsets = vec![sentinel; n];
    let all = rows(0, H);
    let eye = error_eye();
    assert_eq!(
        search(mut_vec2(&mut offsets), core::ptr::null(), eye, &p, all),
        NullPointer
    );
    assert_eq!(
        search(mut_vec2(&mut offsets), &k, eye, core::ptr::null(), all),
        NullPointer
    );
    assert_eq!(
        search(mut_vec2(&mut offsets), &k, v3(Vec3::NAN), &p, all),
        InvalidArgument
    );
    assert_eq!(
        search(mut_vec2(&mut offsets), &k, eye, &p, rows(5, H + 1)),
        InvalidArgument
    );
    let mut short = mut_vec2(&mut offsets);
    short.len = n - 1;
    assert_eq!(search(short, &k, eye, &p, all), InsufficientSize);
    let mut bad = k;
    bad.convention = 3;
    assert_eq!(
        search(mut_vec2(&mut offsets), &bad, eye, &p, all),
        InvalidArgument
    );
    let mut bad = k;
    bad.specular.len = 3;
    assert_eq!(
        search(mut_vec2(&mut offsets), &bad, eye, &p, all),
        InsufficientSize
    );
    p.magnification = f32::NAN;
    assert_eq!(
        search(mut_vec2(&mut offsets), &k, eye, &p, all),
        InvalidArgument
    );
    p = refl_tcrr_options_default();
    assert!(offsets.iter().all(|o| *o == sentinel));
    assert_eq!(
        search(mut_vec2(&mut offsets), &k, eye, &p, all),
        refl_status::Ok
    );
}

#[test]
fn shift_refuses_bad_input_untouched() {
    let key = error_key();
    let k = key_desc(&key, None);
    let p = refl_tcrr_options_default();
    let n = (W * H) as usize;
    let all = rows(0, H);
    let offsets = searched_offsets(&k);
    let mut inter = vec![[4.0f32; 3]; n];
    let mut idepth = vec![4.0f32; n];
    let mut cov = vec![4u8; n];
    let shift = |c: refl_image_vec3_mut, d, v, k: *const refl_tcrr_key| unsafe {
        refl_tcrr_shift(
            c,
            d,
            v,
            core::ptr::null_mut(),
            k,
            img_vec2(&offsets),
            &p,
            all,
        )
    };
    let mut c = mut_vec3(&mut inter);
    c.data = core::ptr::null_mut();
    assert_eq!(
        shift(c, mut_f32(&mut idepth), mut_u8(&mut cov), &k),
        NullPointer
    );
    let mut v = mut_u8(&mut cov);
    v.len = 1;
    assert_eq!(
        shift(mut_vec3(&mut inter), mut_f32(&mut idepth), v, &k),
        InsufficientSize
    );
    assert!(inter.iter().all(|c| *c == [4.0; 3]) && idepth.iter().all(|d| *d == 4.0));
    assert!(cov.iter().all(|c| *c == 4));
}

#[test]
fn warp_and_compose_refuse_bad_input_untouched() {
    let key = error_key();
    let k = key_desc(&key, None);
    let p = refl_tcrr_options_default();
    let n = (W * H) as usize;
    let all = rows(0, H);
    let (inter, idepth, cov) = (vec![[4.0f32; 3]; n], vec![4.0f32; n], vec![4u8; n]);
    let cur = current_desc(&key);
    let mut color = vec![[6.0f32; 3]; n];
    let mut mask = vec![6u8; n];
    let mut bad_cur = cur;
    bad_cur.depth.data = core::ptr::null();
    assert_eq!(
        unsafe {
            refl_tcrr_warp(
                mut_vec3(&mut color),
                mut_u8(&mut mask),
                core::ptr::null_mut(),
                &bad_cur,
                &k,
                img_vec3(&inter),
                img_f32(&idepth),
                img_u8(&cov),
                &p,
                all,
            )
        },
        NullPointer
    );
    assert_eq!(
        unsafe {
            refl_tcrr_compose(
                mut_vec3(&mut color),
                img_vec3(&inter),
                img_vec3(&inter),
                img_vec3(&inter),
                &cur,
                5,
                all,
            )
        },
        InvalidArgument
    );
    assert!(color.iter().all(|c| *c == [6.0; 3]) && mask.iter().all(|m| *m == 6));
}

#[test]
fn retrace_list_refuses_a_short_list_and_a_null_count_untouched() {
    let n = (W * H) as usize;
    let mut count = 11usize;
    let mut list = [77u32; 2];
    let all_retrace = vec![REFL_TCRR_MASK_RETRACE; n];
    assert_eq!(
        unsafe { refl_tcrr_retrace_list(list.as_mut_ptr(), 2, &mut count, img_u8(&all_retrace)) },
        InsufficientSize
    );
    assert_eq!((count, list), (11, [77, 77]));
    assert_eq!(
        unsafe {
            refl_tcrr_retrace_list(
                list.as_mut_ptr(),
                2,
                core::ptr::null_mut(),
                img_u8(&all_retrace),
            )
        },
        NullPointer
    );
}

#[test]
fn prepare_refuses_a_wrong_size_and_a_null_key_untouched() {
    let key = error_key();
    let k = key_desc(&key, None);
    let n = (W * H) as usize;
    let all = rows(0, H);
    let mut surfels = vec![refl_tcrr_surfel::default(); n];
    let img = refl_image_tcrr_surfel_mut {
        data: surfels.as_mut_ptr(),
        len: n,
        width: W,
        height: H - 1,
        stride: W,
    };
    assert_eq!(
        unsafe { refl_tcrr_prepare(img, core::ptr::null_mut(), &k, all) },
        InvalidArgument
    );
    assert_eq!(
        unsafe { refl_tcrr_prepare(img, core::ptr::null_mut(), core::ptr::null(), rows(0, 1)) },
        NullPointer
    );
    assert!(surfels.iter().all(|s| *s == refl_tcrr_surfel::default()));
}
