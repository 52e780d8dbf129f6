//! No export of the C ABI allocates: every function of `include/refl.h`
//! is called at least once on a success path and once on an error path
//! (functions that cannot fail: once) under a counting global allocator,
//! and each call must make zero allocations. `every_header_function_is_covered`
//! fails if the header gains a function this test does not call.
#![allow(clippy::undocumented_unsafe_blocks)]

#[path = "common/counting.rs"]
mod counting;

use counting::counted;
use refl::*;
use refl_core::glam::{Vec2, Vec3};
use refl_core::{try_build_hiz, try_hiz_len, Camera, DepthConvention, DepthImage, ImageView};
use std::collections::BTreeSet;
use std::mem::MaybeUninit;

#[global_allocator]
static GLOBAL: counting::Counting = counting::Counting;

const W: u32 = 32;
const H: u32 = 24;
const N: usize = (W * H) as usize;

/// The functions covered on a success path and on an error path.
#[derive(Default)]
struct Coverage {
    ok: BTreeSet<&'static str>,
    err: BTreeSet<&'static str>,
}

impl Coverage {
    /// Runs `f`, the export `name`, expecting `REFL_STATUS_OK` and no
    /// allocation.
    fn ok(&mut self, name: &'static str, f: impl FnOnce() -> refl_status) {
        let (s, allocs) = counted(f);
        let why = with_last_error_message(|m| m.to_owned());
        assert_eq!(s, refl_status::Ok, "{name} failed: {why}");
        assert_eq!(allocs, 0, "{name} allocated {allocs} times on success");
        self.ok.insert(name);
    }

    /// Runs `f`, the export `name`, expecting an error status and no
    /// allocation.
    fn err(&mut self, name: &'static str, f: impl FnOnce() -> refl_status) {
        let (s, allocs) = counted(f);
        assert_ne!(s, refl_status::Ok, "{name} accepted bad input");
        assert_eq!(allocs, 0, "{name} allocated {allocs} times on error");
        self.err.insert(name);
    }

    /// Runs `f`, the export `name` that returns a value rather than a
    /// status, expecting no allocation.
    fn value<R>(&mut self, name: &'static str, f: impl FnOnce() -> R) -> R {
        let (r, allocs) = counted(f);
        assert_eq!(allocs, 0, "{name} allocated {allocs} times");
        self.ok.insert(name);
        r
    }
}

/// `cov.ok("refl_x", || unsafe { refl_x(args) })` with the name taken from
/// the function called.
macro_rules! ok {
    ($cov:expr, $f:ident ( $($a:expr),* $(,)? )) => {
        $cov.ok(stringify!($f), || unsafe { $f($($a),*) })
    };
}
macro_rules! err {
    ($cov:expr, $f:ident ( $($a:expr),* $(,)? )) => {
        $cov.err(stringify!($f), || unsafe { $f($($a),*) })
    };
}
macro_rules! value {
    ($cov:expr, $f:ident ( $($a:expr),* $(,)? )) => {
        $cov.value(stringify!($f), || {
            #[allow(unused_unsafe, clippy::let_and_return)]
            let r = unsafe { $f($($a),*) };
            r
        })
    };
}

/// Functions that return a value, not a `refl_status`, and have no error
/// path (`refl_last_error_message` takes any buffer, NULL included), besides
/// the `refl_<module>_options_default` functions.
const INFALLIBLE: [&str; 4] = [
    "refl_version",
    "refl_version_number",
    "refl_status_string",
    "refl_last_error_message",
];

fn infallible(f: &str) -> bool {
    INFALLIBLE.contains(&f) || f.ends_with("_options_default")
}

fn v3(x: f32, y: f32, z: f32) -> refl_vec3 {
    refl_vec3 { x, y, z }
}

fn v2(x: f32, y: f32) -> refl_vec2 {
    refl_vec2 { x, y }
}

fn uninit<T>() -> MaybeUninit<T> {
    MaybeUninit::uninit()
}

fn rows(begin: u32, end: u32) -> refl_row_range {
    refl_row_range { begin, end }
}

/// Image descriptors of `W x H` texels, tightly packed, over test buffers:
/// `name(&[texel])` (read-only) and `name_mut(&mut [texel])`.
macro_rules! images {
    ($($f:ident, $fm:ident: $texel:ty => $c:ident, $cm:ident;)*) => {$(
        fn $f(d: &[$texel]) -> $c {
            $c { data: d.as_ptr().cast(), len: d.len(), width: W, height: H, stride: W }
        }
        #[allow(dead_code)]
        fn $fm(d: &mut [$texel]) -> $cm {
            $cm { data: d.as_mut_ptr().cast(), len: d.len(), width: W, height: H, stride: W }
        }
    )*};
}

images! {
    f32_img, f32_mut: f32 => refl_image_f32, refl_image_f32_mut;
    vec3_img, vec3_mut: [f32; 3] => refl_image_vec3, refl_image_vec3_mut;
    vec2_img, vec2_mut: [f32; 2] => refl_image_vec2, refl_image_vec2_mut;
    u8_img, u8_mut: u8 => refl_image_u8, refl_image_u8_mut;
    u32_img, u32_mut: u32 => refl_image_u32, refl_image_u32_mut;
}

fn no_vec3() -> refl_image_vec3 {
    refl_image_vec3 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

fn no_u32() -> refl_image_u32 {
    refl_image_u32 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

fn no_f32() -> refl_image_f32 {
    refl_image_f32 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

/// A floor (y = 0, object 0) and a wall (z = -3, object 1) seen from above
/// the floor, in linear depth, with normals, positions, colors, specular
/// factors and reflected distances.
struct Scene {
    cam: Camera,
    depth: Vec<f32>,
    back: Vec<f32>,
    normals: Vec<[f32; 3]>,
    positions: Vec<[f32; 3]>,
    color: Vec<[f32; 3]>,
    objects: Vec<u32>,
    spec: Vec<f32>,
    dist: Vec<f32>,
}

fn scene() -> Scene {
    let cam = Camera::try_look_at(
        Vec3::new(0.2, 1.5, 4.0),
        Vec3::new(0.0, 0.4, 0.0),
        Vec3::Y,
        1.0,
        0.1,
        50.0,
        W,
        H,
    )
    .unwrap();
    let mut s = Scene {
        cam,
        depth: vec![f32::INFINITY; N],
        back: vec![f32::INFINITY; N],
        normals: vec![[0.0, 0.0, 1.0]; N],
        positions: vec![[0.0; 3]; N],
        color: vec![[0.1, 0.2, 0.3]; N],
        objects: vec![u32::MAX; N],
        spec: vec![0.0; N],
        dist: vec![f32::INFINITY; N],
    };
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let t_floor = if r.dir.y < 0.0 {
                -r.origin.y / r.dir.y
            } else {
                f32::INFINITY
            };
            let t_wall = if r.dir.z < 0.0 {
                (-3.0 - r.origin.z) / r.dir.z
            } else {
                f32::INFINITY
            };
            let (t, n, id) = if t_floor < t_wall {
                (t_floor, [0.0, 1.0, 0.0], 0)
            } else {
                (t_wall, [0.0, 0.0, 1.0], 1)
            };
            if !t.is_finite() {
                continue;
            }
            let p = r.at(t);
            let z = cam.linear_depth(p);
            s.depth[i] = z;
            s.back[i] = z + 0.5;
            s.normals[i] = n;
            s.positions[i] = p.to_array();
            s.objects[i] = id;
            s.color[i] = [x as f32 / W as f32, y as f32 / H as f32, id as f32];
            if id == 0 {
                s.spec[i] = 0.9;
                let d = Vec3::new(r.dir.x, -r.dir.y, r.dir.z);
                if d.z < 0.0 {
                    s.dist[i] = (-3.0 - p.z) / d.z;
                }
            }
        }
    }
    s
}

impl Scene {
    fn camera(&self) -> refl_camera {
        (&self.cam).into()
    }

    fn depth_image(&self) -> refl_depth_image {
        refl_depth_image {
            depth: f32_img(&self.depth),
            camera: self.camera(),
            convention: refl_depth_convention::Linear as u32,
        }
    }

    /// The floor pixels' indices.
    fn floor(&self) -> Vec<u32> {
        (0..N as u32)
            .filter(|&i| self.objects[i as usize] == 0)
            .collect()
    }
}

fn thickness(constant: f32) -> refl_trace_thickness {
    refl_trace_thickness {
        constant,
        back_faces: no_f32(),
    }
}

/// A reflected ray off the floor pixel nearest the image center.
fn floor_ray(s: &Scene) -> refl_ray {
    let p = Vec3::new(0.0, 0.0, 0.5);
    let d = (p - s.cam.eye()).normalize();
    refl_ray {
        origin: p.into(),
        dir: Vec3::new(d.x, -d.y, d.z).into(),
    }
}

fn bad_ray() -> refl_ray {
    refl_ray {
        origin: v3(0.0, 0.0, 0.0),
        dir: v3(0.0, f32::NAN, 0.0),
    }
}

#[test]
fn the_allocation_counter_counts() {
    let (v, n) = counted(|| Vec::<u8>::with_capacity(3));
    assert_eq!((v.capacity() >= 3, n), (true, 1));
    let (_, n) = counted(|| ());
    assert_eq!(n, 0);
}

#[test]
fn no_export_allocates() {
    let mut cov = Coverage::default();
    camera_and_mirror(&mut cov);
    image_and_status(&mut cov);
    depth_tracing(&mut cov);
    cone(&mut cov);
    ssr(&mut cov);
    glossy(&mut cov);
    planar(&mut cov);
    layered(&mut cov);
    layered_pass(&mut cov);
    cluster(&mut cov);
    cluster_pass(&mut cov);
    tcrr(&mut cov);
    epipolar(&mut cov);
    summary(&mut cov);
    temporal(&mut cov);
    bounce_extrapolate_upsample(&mut cov);
    check_coverage(&cov, &header_functions(&header()));
}

fn camera_and_mirror(cov: &mut Coverage) {
    let s = scene();
    let cam = s.camera();
    let mut bad = cam;
    bad.width = 0;
    let c = &raw const cam;
    let p = v3(0.0, 0.0, 0.5);
    let px = v2(10.5, 20.5);
    let (mut cam_o, mut ray_o, mut proj_o) = (uninit(), uninit(), uninit());
    let (mut f_o, mut v3_o, mut m_o, mut b_o) = (uninit(), uninit(), uninit(), uninit());
    ok!(
        cov,
        refl_camera_look_at(
            cam_o.as_mut_ptr(),
            v3(0.0, 1.0, 3.0),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 1.0, 0.0),
            1.0,
            0.1,
            50.0,
            W,
            H
        )
    );
    err!(
        cov,
        refl_camera_look_at(
            cam_o.as_mut_ptr(),
            v3(0.0, 1.0, 3.0),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 1.0, 0.0),
            0.0,
            0.1,
            50.0,
            W,
            H
        )
    );
    ok!(cov, refl_camera_validate(c));
    err!(cov, refl_camera_validate(&bad));
    ok!(cov, refl_camera_primary_ray(ray_o.as_mut_ptr(), c, px));
    err!(cov, refl_camera_primary_ray(ray_o.as_mut_ptr(), &bad, px));
    ok!(cov, refl_camera_project(proj_o.as_mut_ptr(), c, p));
    err!(cov, refl_camera_project(proj_o.as_mut_ptr(), &bad, p));
    ok!(cov, refl_camera_linear_depth(f_o.as_mut_ptr(), c, p));
    err!(cov, refl_camera_linear_depth(f_o.as_mut_ptr(), &bad, p));
    ok!(cov, refl_camera_unproject(v3_o.as_mut_ptr(), c, px, 3.0, 0));
    err!(cov, refl_camera_unproject(v3_o.as_mut_ptr(), c, px, 3.0, 9));
    ok!(cov, refl_camera_encode_depth(f_o.as_mut_ptr(), c, 3.0, 2));
    err!(cov, refl_camera_encode_depth(f_o.as_mut_ptr(), c, 3.0, 9));
    ok!(cov, refl_camera_decode_depth(f_o.as_mut_ptr(), c, 0.5, 1));
    err!(cov, refl_camera_decode_depth(f_o.as_mut_ptr(), c, 0.5, 9));
    ok!(cov, refl_camera_projection_matrix(m_o.as_mut_ptr(), c, 1));
    err!(cov, refl_camera_projection_matrix(m_o.as_mut_ptr(), c, 9));
    ok!(
        cov,
        refl_camera_world_to_pixel_matrix(m_o.as_mut_ptr(), c, 2)
    );
    err!(
        cov,
        refl_camera_world_to_pixel_matrix(m_o.as_mut_ptr(), c, 9)
    );
    ok!(cov, refl_camera_inverse_view(m_o.as_mut_ptr(), c));
    err!(cov, refl_camera_inverse_view(m_o.as_mut_ptr(), &bad));
    ok!(cov, refl_camera_eye(v3_o.as_mut_ptr(), c));
    err!(cov, refl_camera_eye(core::ptr::null_mut(), c));
    ok!(cov, refl_camera_is_mirrored(b_o.as_mut_ptr(), c));
    err!(cov, refl_camera_is_mirrored(b_o.as_mut_ptr(), &bad));
    let mut moved = cam;
    moved.view.m[12] += 0.1;
    ok!(
        cov,
        refl_camera_reprojection_matrix(m_o.as_mut_ptr(), c, &moved, 1)
    );
    err!(
        cov,
        refl_camera_reprojection_matrix(m_o.as_mut_ptr(), c, &moved, 9)
    );
    ok!(
        cov,
        refl_camera_reproject(proj_o.as_mut_ptr(), c, &moved, px, 3.0, 0)
    );
    err!(
        cov,
        refl_camera_reproject(proj_o.as_mut_ptr(), c, &bad, px, 3.0, 0)
    );
    let m = refl_mat4::from(refl_core::glam::Mat4::IDENTITY);
    ok!(
        cov,
        refl_camera_apply_reprojection(proj_o.as_mut_ptr(), &m, px, 3.0)
    );
    err!(
        cov,
        refl_camera_apply_reprojection(proj_o.as_mut_ptr(), core::ptr::null(), px, 3.0)
    );

    let floor = refl_plane {
        normal: v3(0.0, 1.0, 0.0),
        d: 0.0,
    };
    let (mut plane_o, mut t_o) = (uninit(), uninit());
    ok!(
        cov,
        refl_mirror_reflect(v3_o.as_mut_ptr(), v3(1.0, -1.0, 0.0), v3(0.0, 1.0, 0.0))
    );
    err!(
        cov,
        refl_mirror_reflect(v3_o.as_mut_ptr(), v3(1.0, -1.0, 0.0), v3(0.0, 0.0, 0.0))
    );
    ok!(
        cov,
        refl_plane_from_triangle(
            plane_o.as_mut_ptr(),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 0.0, 1.0),
            v3(1.0, 0.0, 0.0)
        )
    );
    err!(
        cov,
        refl_plane_from_triangle(
            plane_o.as_mut_ptr(),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 0.0, 0.0),
            v3(1.0, 0.0, 0.0)
        )
    );
    ok!(
        cov,
        refl_plane_from_point_normal(plane_o.as_mut_ptr(), p, v3(0.0, 1.0, 0.0))
    );
    err!(
        cov,
        refl_plane_from_point_normal(plane_o.as_mut_ptr(), p, v3(0.0, 0.0, 0.0))
    );
    ok!(cov, refl_plane_signed_distance(f_o.as_mut_ptr(), &floor, p));
    err!(
        cov,
        refl_plane_signed_distance(f_o.as_mut_ptr(), &floor, v3(f32::NAN, 0.0, 0.0))
    );
    let down = refl_ray {
        origin: v3(0.0, 1.0, 0.0),
        dir: v3(0.0, -1.0, 0.0),
    };
    ok!(
        cov,
        refl_plane_intersect_ray(t_o.as_mut_ptr(), &floor, down)
    );
    err!(
        cov,
        refl_plane_intersect_ray(t_o.as_mut_ptr(), &floor, bad_ray())
    );
    ok!(cov, refl_mirror_matrix(m_o.as_mut_ptr(), &floor));
    err!(cov, refl_mirror_matrix(m_o.as_mut_ptr(), core::ptr::null()));
    ok!(cov, refl_mirror_point(v3_o.as_mut_ptr(), &floor, p));
    err!(
        cov,
        refl_mirror_point(v3_o.as_mut_ptr(), &floor, v3(f32::INFINITY, 0.0, 0.0))
    );
    ok!(cov, refl_mirror_camera(cam_o.as_mut_ptr(), c, &floor));
    err!(cov, refl_mirror_camera(cam_o.as_mut_ptr(), &bad, &floor));
    let mirrored = unsafe { cam_o.assume_init() };
    ok!(
        cov,
        refl_mirror_oblique_projection(m_o.as_mut_ptr(), &mirrored, &floor, 1)
    );
    err!(
        cov,
        refl_mirror_oblique_projection(m_o.as_mut_ptr(), &mirrored, &floor, 0)
    );
}

fn image_and_status(cov: &mut Coverage) {
    let s = scene();
    let (mut band_o, mut len_o) = (uninit(), uninit());
    ok!(cov, refl_image_row_band(band_o.as_mut_ptr(), H, 1, 4));
    err!(cov, refl_image_row_band(band_o.as_mut_ptr(), H, 4, 4));
    ok!(
        cov,
        refl_image_required_len(len_o.as_mut_ptr(), W, H, W + 3)
    );
    err!(
        cov,
        refl_image_required_len(len_o.as_mut_ptr(), W, H, W - 1)
    );
    let mut out = vec![0.0f32; N];
    let cam = s.camera();
    ok!(
        cov,
        refl_image_convert_depth(f32_mut(&mut out), f32_img(&s.depth), &cam, 0, 2, rows(0, H))
    );
    let mut in_place = s.depth.clone();
    let same = f32_mut(&mut in_place);
    ok!(
        cov,
        refl_image_convert_depth(same, same.as_const(), &cam, 0, 1, rows(3, 9))
    );
    err!(
        cov,
        refl_image_convert_depth(f32_mut(&mut out), f32_img(&s.depth), &cam, 0, 7, rows(0, H))
    );
    err!(
        cov,
        refl_image_convert_depth(f32_mut(&mut out), f32_img(&s.depth), &cam, 0, 2, rows(5, 5))
    );

    let v = value!(cov, refl_version());
    assert!(!v.is_null());
    let n = value!(cov, refl_version_number());
    assert!(n > 0);
    let ok_str = value!(cov, refl_status_string(0));
    let unknown = value!(cov, refl_status_string(99));
    assert!(!ok_str.is_null() && !unknown.is_null());
    let mut buf = [0 as core::ffi::c_char; 16];
    value!(cov, refl_last_error_message(buf.as_mut_ptr(), buf.len()));
    value!(cov, refl_last_error_message(core::ptr::null_mut(), 0));
}

fn depth_tracing(cov: &mut Coverage) {
    let s = scene();
    let di = s.depth_image();
    let th = thickness(0.3);
    let back = refl_trace_thickness {
        constant: 0.0,
        back_faces: f32_img(&s.back),
    };
    let step = value!(cov, refl_step_options_default());
    let ray = floor_ray(&s);
    let mut res = uninit::<refl_trace_result>();
    ok!(
        cov,
        refl_step_ray(res.as_mut_ptr(), &di, &th, ray, f32::INFINITY, &step)
    );
    err!(
        cov,
        refl_step_ray(res.as_mut_ptr(), &di, &th, bad_ray(), f32::INFINITY, &step)
    );
    let hit = unsafe { res.assume_init() };
    ok!(
        cov,
        refl_trace_refine_hit(res.as_mut_ptr(), &di, ray, f32::INFINITY, &hit)
    );
    err!(
        cov,
        refl_trace_refine_hit(res.as_mut_ptr(), &di, ray, -1.0, &hit)
    );
    let rays = vec![ray; 40];
    let t_max = [f32::INFINITY];
    let mut out = vec![refl_trace_result::default(); 40];
    ok!(
        cov,
        refl_step_rays(
            out.as_mut_ptr(),
            out.len(),
            &di,
            &back,
            rays.as_ptr(),
            rays.len(),
            t_max.as_ptr(),
            1,
            &step
        )
    );
    let mut with_bad = rays.clone();
    with_bad[30] = bad_ray();
    err!(
        cov,
        refl_step_rays(
            out.as_mut_ptr(),
            out.len(),
            &di,
            &th,
            with_bad.as_ptr(),
            with_bad.len(),
            t_max.as_ptr(),
            1,
            &step
        )
    );
    err!(
        cov,
        refl_step_rays(
            out.as_mut_ptr(),
            39,
            &di,
            &th,
            rays.as_ptr(),
            rays.len(),
            t_max.as_ptr(),
            1,
            &step
        )
    );

    // Hi-Z.
    let (mut len_o, mut levels_o, mut level_o) = (uninit(), uninit(), uninit());
    ok!(
        cov,
        refl_hiz_len(len_o.as_mut_ptr(), levels_o.as_mut_ptr(), W, H)
    );
    err!(
        cov,
        refl_hiz_len(len_o.as_mut_ptr(), levels_o.as_mut_ptr(), 0, H)
    );
    let len: usize = unsafe { len_o.assume_init() };
    let levels: u32 = unsafe { levels_o.assume_init() };
    ok!(cov, refl_hiz_level(level_o.as_mut_ptr(), W, H, levels - 1));
    err!(cov, refl_hiz_level(level_o.as_mut_ptr(), W, H, levels));
    let opts = value!(cov, refl_hiz_options_default());
    let mut pyr = vec![v2(0.0, 0.0); len];
    ok!(cov, refl_hiz_build(pyr.as_mut_ptr(), len, &di));
    err!(cov, refl_hiz_build(pyr.as_mut_ptr(), len - 1, &di));
    let mut banded = vec![v2(0.0, 0.0); len];
    for level in 0..levels {
        let mut info = uninit::<refl_hiz_level_info>();
        assert_eq!(
            unsafe { refl_hiz_level(info.as_mut_ptr(), W, H, level) },
            refl_status::Ok
        );
        let h = unsafe { info.assume_init() }.height;
        ok!(
            cov,
            refl_hiz_build_rows(banded.as_mut_ptr(), len, &di, level, rows(0, h))
        );
    }
    err!(
        cov,
        refl_hiz_build_rows(banded.as_mut_ptr(), len, &di, 1, rows(0, H))
    );
    assert_eq!(banded, pyr);
    let hiz = refl_hiz {
        data: pyr.as_ptr(),
        len,
        camera: s.camera(),
        convention: 0,
    };
    let mut lanes = 0u32;
    ok!(cov, refl_hiz_stream_lanes(&mut lanes));
    assert!(lanes == 1 || lanes == 8);
    err!(cov, refl_hiz_stream_lanes(std::ptr::null_mut()));
    ok!(
        cov,
        refl_hiz_trace_ray(res.as_mut_ptr(), &hiz, &th, ray, f32::INFINITY, &opts)
    );
    err!(
        cov,
        refl_hiz_trace_ray(res.as_mut_ptr(), &hiz, &th, bad_ray(), f32::INFINITY, &opts)
    );
    ok!(
        cov,
        refl_hiz_trace_rays(
            out.as_mut_ptr(),
            out.len(),
            &hiz,
            &back,
            rays.as_ptr(),
            rays.len(),
            t_max.as_ptr(),
            1,
            &opts
        )
    );
    err!(
        cov,
        refl_hiz_trace_rays(
            out.as_mut_ptr(),
            out.len(),
            &hiz,
            &th,
            with_bad.as_ptr(),
            with_bad.len(),
            t_max.as_ptr(),
            1,
            &opts
        )
    );
    let aliased = out.as_ptr().cast::<refl_ray>();
    err!(
        cov,
        refl_hiz_trace_rays(
            out.as_mut_ptr(),
            out.len(),
            &hiz,
            &th,
            aliased,
            10,
            t_max.as_ptr(),
            1,
            &opts
        )
    );
}

/// A Hi-Z pyramid of the scene (built through the core).
fn hiz_of(s: &Scene) -> Vec<refl_vec2> {
    let d = DepthImage::try_new(
        ImageView::try_new(&s.depth, W, H, W).unwrap(),
        s.cam,
        DepthConvention::Linear,
    )
    .unwrap();
    let mut hz = vec![[0.0f32; 2]; try_hiz_len(W, H).unwrap()];
    try_build_hiz(&mut hz, &d).unwrap();
    hz.iter().map(|t| v2(t[0], t[1])).collect()
}

fn cone(cov: &mut Coverage) {
    let s = scene();
    let hz = hiz_of(&s);
    let hiz = refl_hiz {
        data: hz.as_ptr(),
        len: hz.len(),
        camera: s.camera(),
        convention: 0,
    };
    let mut f = uninit::<f32>();
    ok!(cov, refl_cone_angle_from_phong(f.as_mut_ptr(), 30.0));
    err!(cov, refl_cone_angle_from_phong(f.as_mut_ptr(), -1.0));
    ok!(cov, refl_cone_angle_from_roughness(f.as_mut_ptr(), 0.3));
    err!(
        cov,
        refl_cone_angle_from_roughness(f.as_mut_ptr(), f32::NAN)
    );
    let (mut cl, mut vl) = (uninit::<usize>(), uninit::<usize>());
    ok!(
        cov,
        refl_cone_pyramid_len(cl.as_mut_ptr(), vl.as_mut_ptr(), W, H)
    );
    err!(
        cov,
        refl_cone_pyramid_len(cl.as_mut_ptr(), vl.as_mut_ptr(), W, 0)
    );
    let (cl, vl) = unsafe { (cl.assume_init(), vl.assume_init()) };
    let image: Vec<refl_vec3> = s.color.iter().map(|c| v3(c[0], c[1], c[2])).collect();
    let image_c = refl_image_vec3 {
        data: image.as_ptr(),
        len: image.len(),
        width: W,
        height: H,
        stride: W,
    };
    let mut color = vec![v3(0.0, 0.0, 0.0); cl];
    ok!(
        cov,
        refl_cone_build_color(color.as_mut_ptr(), cl, &image_c, 1.0)
    );
    err!(
        cov,
        refl_cone_build_color(color.as_mut_ptr(), cl - 1, &image_c, 1.0)
    );
    let mut banded = vec![v3(0.0, 0.0, 0.0); cl];
    ok!(
        cov,
        refl_cone_build_color_rows(banded.as_mut_ptr(), cl, &image_c, 0, rows(0, H), 1.0)
    );
    ok!(
        cov,
        refl_cone_build_color_rows(banded.as_mut_ptr(), cl, &image_c, 1, rows(0, H / 2), 1.0)
    );
    err!(
        cov,
        refl_cone_build_color_rows(banded.as_mut_ptr(), cl, &image_c, 1, rows(0, H), 1.0)
    );
    let mut vis = vec![0.0f32; vl];
    ok!(cov, refl_cone_build_visibility(vis.as_mut_ptr(), vl, &hiz));
    err!(
        cov,
        refl_cone_build_visibility(vis.as_mut_ptr(), vl - 1, &hiz)
    );
    let mut vis_b = vec![0.0f32; vl];
    ok!(
        cov,
        refl_cone_build_visibility_rows(vis_b.as_mut_ptr(), vl, &hiz, 0, rows(0, H))
    );
    ok!(
        cov,
        refl_cone_build_visibility_rows(vis_b.as_mut_ptr(), vl, &hiz, 1, rows(0, H / 2))
    );
    err!(
        cov,
        refl_cone_build_visibility_rows(vis_b.as_mut_ptr(), vl, &hiz, 99, rows(0, 1))
    );
    let opts = value!(cov, refl_cone_options_default());
    let pyr = refl_cone_pyramids {
        hiz,
        color: color.as_ptr(),
        color_len: cl,
        visibility: vis.as_ptr(),
        visibility_len: vl,
    };
    let c = refl_cone {
        apex: v2(16.0, 20.0),
        apex_depth: 3.0,
        hit: v2(16.0, 8.0),
        hit_depth: 6.0,
        theta: 0.1,
        n_dot_v: 0.7,
        travel: 2.0,
    };
    let mut r = uninit::<refl_cone_result>();
    let fb = v3(0.1, 0.1, 0.1);
    ok!(cov, refl_cone_trace(r.as_mut_ptr(), &pyr, &c, fb, &opts));
    let bad_c = refl_cone { theta: 2.0, ..c };
    err!(
        cov,
        refl_cone_trace(r.as_mut_ptr(), &pyr, &bad_c, fb, &opts)
    );
    let fades = refl_cone_fades {
        toward_camera: refl_cone_fade_range {
            enabled: false,
            start: 0.0,
            end: 1.0,
        },
        border: refl_cone_fade_range {
            enabled: true,
            start: 0.8,
            end: 1.0,
        },
        travel: refl_cone_fade_range {
            enabled: true,
            start: 5.0,
            end: 10.0,
        },
    };
    let (up, toward) = (v3(0.0, 1.0, 0.0), v3(0.0, 0.0, 1.0));
    ok!(
        cov,
        refl_cone_fade(f.as_mut_ptr(), &fades, up, toward, v2(3.0, 4.0), W, H, 1.0)
    );
    let bad_f = refl_cone_fades {
        border: refl_cone_fade_range {
            enabled: true,
            start: 1.0,
            end: 0.8,
        },
        ..fades
    };
    err!(
        cov,
        refl_cone_fade(f.as_mut_ptr(), &bad_f, up, toward, v2(3.0, 4.0), W, H, 1.0)
    );
    let mo = refl_cone_multiray_options {
        rays: 5,
        rotation: v2(0.25, 0.5),
        ..value!(cov, refl_cone_multiray_options_default())
    };
    let th = thickness(0.3);
    let mut mr = uninit::<refl_cone_multiray_result>();
    let ray = floor_ray(&s);
    ok!(
        cov,
        refl_cone_multiray(
            mr.as_mut_ptr(),
            &pyr,
            &th,
            ray,
            up,
            100.0,
            0.2,
            30.0,
            &mo,
            fb
        )
    );
    let bad_mo = refl_cone_multiray_options { rays: 0, ..mo };
    err!(
        cov,
        refl_cone_multiray(
            mr.as_mut_ptr(),
            &pyr,
            &th,
            ray,
            up,
            100.0,
            0.2,
            30.0,
            &bad_mo,
            fb
        )
    );
}

fn ssr(cov: &mut Coverage) {
    let s = scene();
    let mut opts = value!(cov, refl_ssr_options_default());
    opts.method = refl_ssr_method::Hiz as u32;
    let g = refl_gbuffer {
        depth: s.depth_image(),
        normals: vec3_img(&s.normals),
        normal_space: refl_normal_space::World as u32,
        mask: refl_image_u8 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        roughness: no_f32(),
        color: vec3_img(&s.color),
        back_depth: f32_img(&s.back),
    };
    let mut len = uninit::<usize>();
    ok!(cov, refl_ssr_scratch_len(len.as_mut_ptr(), &g, &opts));
    let bad_o = refl_ssr_options { method: 9, ..opts };
    err!(cov, refl_ssr_scratch_len(len.as_mut_ptr(), &g, &bad_o));
    let len = unsafe { len.assume_init() };
    assert!(len > 0);
    let mut scratch = vec![v2(0.0, 0.0); len];
    ok!(cov, refl_ssr_prepare(scratch.as_mut_ptr(), len, &g, &opts));
    err!(
        cov,
        refl_ssr_prepare(scratch.as_mut_ptr(), len - 1, &g, &opts)
    );
    let mut texels = vec![refl_ssr_texel::default(); N];
    let mut color = vec![[0.0f32; 3]; N];
    let mut host = vec![refl_host_ray::default(); N];
    let mut stats = uninit::<refl_ssr_stats>();
    ok!(
        cov,
        refl_ssr_trace_rows(
            stats.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            vec3_mut(&mut color),
            host.as_mut_ptr(),
            N,
            &g,
            &opts,
            scratch.as_ptr(),
            len,
            rows(0, H)
        )
    );
    assert!(unsafe { stats.assume_init() }.hits > 0);
    err!(
        cov,
        refl_ssr_trace_rows(
            stats.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            vec3_mut(&mut color),
            host.as_mut_ptr(),
            N,
            &g,
            &opts,
            scratch.as_ptr(),
            len,
            rows(3, 2)
        )
    );
}

fn temporal(cov: &mut Coverage) {
    let s = scene();
    let opts = value!(cov, refl_temporal_options_default());
    let g = refl_gbuffer {
        depth: s.depth_image(),
        normals: vec3_img(&s.normals),
        normal_space: refl_normal_space::World as u32,
        mask: refl_image_u8 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        roughness: no_f32(),
        color: no_vec3(),
        back_depth: no_f32(),
    };
    let all = vec![1u8; N];
    let answered: Vec<u8> = (0..N).map(|i| u8::from(i % 5 != 0)).collect();
    let texels = |d: &[refl_temporal_texel]| refl_image_temporal_texel {
        data: d.as_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    };
    let texels_mut = |d: &mut [refl_temporal_texel]| refl_image_temporal_texel_mut {
        data: d.as_mut_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    };
    // The first frame (no history), then the next from its history.
    let mut first = vec![refl_temporal_texel::default(); N];
    let mut next = vec![refl_temporal_texel::default(); N];
    let mut status = vec![0u8; N];
    let none = refl_temporal_history {
        camera: s.camera(),
        texels: refl_image_temporal_texel {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
    };
    let mut stats = uninit::<refl_temporal_stats>();
    ok!(
        cov,
        refl_temporal_resolve_rows(
            stats.as_mut_ptr(),
            texels_mut(&mut first),
            u8_mut(&mut status),
            &g,
            vec3_img(&s.color),
            u8_img(&all),
            no_f32(),
            &none,
            &opts,
            rows(0, H)
        )
    );
    assert!(unsafe { stats.assume_init() }.reset > 0);
    let hist = refl_temporal_history {
        camera: s.camera(),
        texels: texels(&first),
    };
    ok!(
        cov,
        refl_temporal_resolve_rows(
            stats.as_mut_ptr(),
            texels_mut(&mut next),
            u8_mut(&mut status),
            &g,
            vec3_img(&s.color),
            u8_img(&answered),
            f32_img(&s.dist),
            &hist,
            &opts,
            rows(2, 9)
        )
    );
    let st = unsafe { stats.assume_init() };
    assert!(st.blended > 0 && st.recovered > 0, "{st:?}");
    // The next history written over the one read: refused.
    let mut in_place = first.clone();
    let hist_in_place = refl_temporal_history {
        camera: s.camera(),
        texels: texels(&in_place),
    };
    err!(
        cov,
        refl_temporal_resolve_rows(
            stats.as_mut_ptr(),
            texels_mut(&mut in_place),
            u8_mut(&mut status),
            &g,
            vec3_img(&s.color),
            u8_img(&answered),
            no_f32(),
            &hist_in_place,
            &opts,
            rows(0, H)
        )
    );
    let bad = refl_temporal_options {
        max_frames: f32::NAN,
        ..opts
    };
    err!(
        cov,
        refl_temporal_resolve_rows(
            stats.as_mut_ptr(),
            texels_mut(&mut next),
            u8_mut(&mut status),
            &g,
            vec3_img(&s.color),
            u8_img(&answered),
            no_f32(),
            &hist,
            &bad,
            rows(0, H)
        )
    );
}

/// The G-buffer of the scene, with its lit color.
fn lit_gbuffer(s: &Scene) -> refl_gbuffer {
    refl_gbuffer {
        depth: s.depth_image(),
        normals: vec3_img(&s.normals),
        normal_space: refl_normal_space::World as u32,
        mask: refl_image_u8 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        roughness: no_f32(),
        color: vec3_img(&s.color),
        back_depth: no_f32(),
    }
}

fn bounce_extrapolate_upsample(cov: &mut Coverage) {
    let s = scene();
    let g = lit_gbuffer(&s);
    let none_u8 = refl_image_u8_mut {
        data: core::ptr::null_mut(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    };
    let mut out = vec![[0.0f32; 3]; N];
    let mut status = vec![0u8; N];

    // Bounces: the scene's own frame as the previous one.
    let bo = value!(cov, refl_bounce_options_default());
    let prev = refl_bounce_previous {
        depth: s.depth_image(),
        color: vec3_img(&s.color),
    };
    let mut bs = uninit::<refl_bounce_stats>();
    ok!(
        cov,
        refl_bounce_source_rows(
            bs.as_mut_ptr(),
            vec3_mut(&mut out),
            u8_mut(&mut status),
            &g,
            &prev,
            &bo,
            rows(0, H)
        )
    );
    assert!(unsafe { bs.assume_init() }.reprojected > 0);
    let bad = refl_bounce_options {
        attenuation: 2.0,
        ..bo
    };
    err!(
        cov,
        refl_bounce_source_rows(
            bs.as_mut_ptr(),
            vec3_mut(&mut out),
            none_u8,
            &g,
            &prev,
            &bad,
            rows(0, H)
        )
    );

    // The mirror pass's texels, then the dilation of its holes.
    let so = refl_ssr_options_default();
    let mut texels = vec![refl_ssr_texel::default(); N];
    let mut color = vec![[0.0f32; 3]; N];
    let mut ss = uninit::<refl_ssr_stats>();
    ok!(
        cov,
        refl_ssr_trace_rows(
            ss.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            vec3_mut(&mut color),
            core::ptr::null_mut(),
            0,
            &g,
            &so,
            core::ptr::null(),
            0,
            rows(0, H)
        )
    );
    let tex = refl_image_ssr_texel {
        data: texels.as_ptr(),
        len: N,
        width: W,
        height: H,
        stride: W,
    };
    let eo = refl_extrapolate_options {
        all_host_rays: true,
        ..value!(cov, refl_extrapolate_options_default())
    };
    let mut host = vec![refl_image_pixel::default(); 4];
    let mut es = uninit::<refl_extrapolate_stats>();
    ok!(
        cov,
        refl_extrapolate_fill_rows(
            es.as_mut_ptr(),
            vec3_mut(&mut out),
            u8_mut(&mut status),
            host.as_mut_ptr(),
            host.len(),
            &g,
            tex,
            vec3_img(&color),
            &eo,
            rows(0, H)
        )
    );
    assert!(unsafe { es.assume_init() }.holes > 0);
    let mut broken = texels.clone();
    broken[3].status = 1000;
    err!(
        cov,
        refl_extrapolate_fill_rows(
            es.as_mut_ptr(),
            vec3_mut(&mut out),
            none_u8,
            host.as_mut_ptr(),
            host.len(),
            &g,
            refl_image_ssr_texel {
                data: broken.as_ptr(),
                ..tex
            },
            vec3_img(&color),
            &eo,
            rows(0, H)
        )
    );

    // One ray per 2x2 block, then the reconstruction.
    let (mut hw, mut hh) = (0u32, 0u32);
    ok!(cov, refl_upsample_half_size(&mut hw, &mut hh, W, H));
    err!(cov, refl_upsample_half_size(&mut hw, &mut hh, 0, H));
    let hn = (hw * hh) as usize;
    let sub = refl_upsample_subsample {
        pattern: refl_upsample_pattern::Staggered as u32,
        frame: 1,
    };
    let mut half = vec![refl_ssr_texel::default(); hn];
    let mut half_color = vec![[0.0f32; 3]; hn];
    let half_color_mut = refl_image_vec3_mut {
        data: half_color.as_mut_ptr().cast(),
        len: hn,
        width: hw,
        height: hh,
        stride: hw,
    };
    let mut rays = vec![refl_host_ray::default(); hn];
    ok!(
        cov,
        refl_upsample_trace_rows(
            ss.as_mut_ptr(),
            half.as_mut_ptr(),
            hn,
            half_color_mut,
            rays.as_mut_ptr(),
            hn,
            &g,
            &so,
            core::ptr::null(),
            0,
            &sub,
            rows(0, hh)
        )
    );
    err!(
        cov,
        refl_upsample_trace_rows(
            ss.as_mut_ptr(),
            half.as_mut_ptr(),
            hn - 1,
            half_color_mut,
            rays.as_mut_ptr(),
            hn,
            &g,
            &so,
            core::ptr::null(),
            0,
            &sub,
            rows(0, hh)
        )
    );
    let uo = value!(cov, refl_upsample_options_default());
    let half_img = refl_image_ssr_texel {
        data: half.as_ptr(),
        len: hn,
        width: hw,
        height: hh,
        stride: hw,
    };
    let half_color_img = refl_image_vec3 {
        data: half_color.as_ptr().cast(),
        len: hn,
        width: hw,
        height: hh,
        stride: hw,
    };
    let mut full = vec![refl_ssr_texel::default(); N];
    let mut list = vec![refl_image_pixel::default(); N];
    let mut us = uninit::<refl_upsample_stats>();
    ok!(
        cov,
        refl_upsample_resolve_rows(
            us.as_mut_ptr(),
            full.as_mut_ptr(),
            N,
            vec3_mut(&mut out),
            u8_mut(&mut status),
            list.as_mut_ptr(),
            N,
            &g,
            &so,
            core::ptr::null(),
            0,
            &sub,
            half_img,
            half_color_img,
            &uo,
            rows(0, H)
        )
    );
    assert!(unsafe { us.assume_init() }.copied > 0);
    let bad = refl_upsample_options {
        depth_sigma: 0.0,
        ..uo
    };
    err!(
        cov,
        refl_upsample_resolve_rows(
            us.as_mut_ptr(),
            full.as_mut_ptr(),
            N,
            vec3_mut(&mut out),
            u8_mut(&mut status),
            list.as_mut_ptr(),
            N,
            &g,
            &so,
            core::ptr::null(),
            0,
            &sub,
            half_img,
            half_color_img,
            &bad,
            rows(0, H)
        )
    );
}

fn summary(cov: &mut Coverage) {
    let s = scene();
    let g = refl_gbuffer {
        depth: s.depth_image(),
        normals: vec3_img(&s.normals),
        normal_space: refl_normal_space::World as u32,
        mask: refl_image_u8 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        roughness: no_f32(),
        color: vec3_img(&s.color),
        back_depth: no_f32(),
    };
    let no_ids = refl_image_u32 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    };
    let o = value!(cov, refl_summary_options_default());
    let mut frame = refl_summary_frame::default();
    let mut objects = [refl_summary_object::default(); 2];
    ok!(
        cov,
        refl_summary_rows(
            &mut frame,
            objects.as_mut_ptr(),
            2,
            &g,
            no_ids,
            &o,
            rows(0, H)
        )
    );
    assert!(frame.reflective > 0);
    err!(
        cov,
        refl_summary_rows(
            &mut frame,
            objects.as_mut_ptr(),
            2,
            &g,
            no_ids,
            &o,
            rows(3, H)
        )
    );
    let (f2, o2) = (frame, objects[0]);
    ok!(cov, refl_summary_merge_frame(&mut frame, &f2));
    err!(cov, refl_summary_merge_frame(core::ptr::null_mut(), &f2));
    ok!(cov, refl_summary_merge_object(&mut objects[0], &o2));
    err!(
        cov,
        refl_summary_merge_object(&mut objects[0], core::ptr::null())
    );
    let mut fit = uninit::<refl_summary_plane_fit>();
    ok!(
        cov,
        refl_summary_object_plane(fit.as_mut_ptr(), &objects[0], &o)
    );
    err!(
        cov,
        refl_summary_object_plane(fit.as_mut_ptr(), &objects[1], &o)
    );
    let po = value!(cov, refl_plan_options_default());
    let caps = refl_plan_host_caps {
        planar_views: true,
        ray_tracer: true,
        probe: true,
    };
    let mut plan = uninit::<refl_plan>();
    let mut planar = [false; 2];
    ok!(
        cov,
        refl_plan_passes(
            plan.as_mut_ptr(),
            planar.as_mut_ptr(),
            2,
            &frame,
            objects.as_ptr(),
            2,
            core::ptr::null(),
            0,
            &caps,
            &o,
            &po,
            W,
            H
        )
    );
    err!(
        cov,
        refl_plan_passes(
            plan.as_mut_ptr(),
            planar.as_mut_ptr(),
            1,
            &frame,
            objects.as_ptr(),
            2,
            core::ptr::null(),
            0,
            &caps,
            &o,
            &po,
            W,
            H
        )
    );
    let mut n_choices = 0usize;
    ok!(cov, refl_plan_choices_len(&mut n_choices, 2));
    assert_eq!(n_choices, 9);
    err!(cov, refl_plan_choices_len(core::ptr::null_mut(), 2));
    let mut choices = [refl_plan_choice {
        object: 0,
        roughness_class: 0,
        pixels: 0,
        entry: 0,
        reason: 0,
        applicable: 0,
        front: 0,
        faster: 0,
        more_accurate: 0,
        id: 0,
        passes: 0,
        time_ratio: 0.0,
        error_255: 0.0,
        time_share: 0.0,
        error_share: 0.0,
        planar: false,
    }; 9];
    let table = [refl_plan_cost_entry {
        id: 1,
        roughness_class: 0,
        surface: refl_plan_surface::Any as u32,
        passes: 1 << refl_plan_pass::HostRays as u32,
        time_ratio: 1.0,
        error_255: 0.0,
    }];
    let budget = refl_plan_budget {
        kind: refl_plan_budget_kind::MaxError as u32,
        value: 1.0,
    };
    let mut bplan = uninit::<refl_plan_budget_plan>();
    ok!(
        cov,
        refl_plan_choose_methods(
            bplan.as_mut_ptr(),
            choices.as_mut_ptr(),
            9,
            &frame,
            objects.as_ptr(),
            2,
            planar.as_ptr(),
            2,
            core::ptr::null(),
            0,
            &caps,
            table.as_ptr(),
            1,
            &budget
        )
    );
    err!(
        cov,
        refl_plan_choose_methods(
            bplan.as_mut_ptr(),
            choices.as_mut_ptr(),
            9,
            &frame,
            objects.as_ptr(),
            2,
            planar.as_ptr(),
            1,
            core::ptr::null(),
            0,
            &caps,
            table.as_ptr(),
            1,
            &budget
        )
    );
}

fn glossy(cov: &mut Coverage) {
    let s = scene();
    let opts = value!(cov, refl_glossy_options_default());
    let rough = vec![0.3f32; N];
    let g = refl_gbuffer {
        depth: s.depth_image(),
        normals: vec3_img(&s.normals),
        normal_space: refl_normal_space::World as u32,
        mask: refl_image_u8 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        roughness: f32_img(&rough),
        color: vec3_img(&s.color),
        back_depth: f32_img(&s.back),
    };
    let mut len = uninit::<usize>();
    ok!(cov, refl_glossy_scratch_len(len.as_mut_ptr(), &g, &opts));
    let bad_o = refl_glossy_options { method: 9, ..opts };
    err!(cov, refl_glossy_scratch_len(len.as_mut_ptr(), &g, &bad_o));
    let len = unsafe { len.assume_init() };
    assert!(len > 0);
    let mut scratch = vec![0.0f32; len];
    ok!(
        cov,
        refl_glossy_prepare(scratch.as_mut_ptr(), len, &g, &opts)
    );
    err!(
        cov,
        refl_glossy_prepare(scratch.as_mut_ptr(), len - 1, &g, &opts)
    );
    let mut texels = vec![refl_glossy_texel::default(); N];
    let mut color = vec![[0.0f32; 3]; N];
    let mut host = vec![refl_host_ray::default(); N];
    let mut stats = uninit::<refl_glossy_stats>();
    ok!(
        cov,
        refl_glossy_trace_rows(
            stats.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            vec3_mut(&mut color),
            host.as_mut_ptr(),
            N,
            &g,
            &opts,
            scratch.as_ptr(),
            len,
            rows(0, H)
        )
    );
    assert!(unsafe { stats.assume_init() }.traced > 0);
    err!(
        cov,
        refl_glossy_trace_rows(
            stats.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            vec3_mut(&mut color),
            host.as_mut_ptr(),
            N,
            &g,
            &opts,
            scratch.as_ptr(),
            len,
            rows(3, 2)
        )
    );
}

fn cluster_pass(cov: &mut Coverage) {
    let s = scene();
    let opts = value!(cov, refl_cluster_pass_options_default());
    let none_vec3 = refl_image_vec3 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    };
    let g = refl_gbuffer {
        depth: s.depth_image(),
        normals: vec3_img(&s.normals),
        normal_space: refl_normal_space::World as u32,
        mask: refl_image_u8 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        roughness: no_f32(),
        color: none_vec3,
        back_depth: no_f32(),
    };
    // The floor reflects (object 0); the wall (object 1) does not.
    let lobes = [refl_cluster_lobe {
        rays: 1,
        exponent: 0.0,
        max_angle: 0.0,
    }];
    let objects = refl_cluster_objects {
        ids: u32_img(&s.objects),
        lobes: lobes.as_ptr(),
        lobes_len: 1,
    };
    let mut sizes = uninit::<refl_cluster_plan_sizes>();
    ok!(
        cov,
        refl_cluster_plan_len(sizes.as_mut_ptr(), &g, &objects, &opts)
    );
    let bad = refl_cluster_pass_options {
        thickness: f32::NAN,
        cluster: refl_cluster_options {
            gain: f32::NAN,
            ..opts.cluster
        },
        ..opts
    };
    err!(
        cov,
        refl_cluster_plan_len(sizes.as_mut_ptr(), &g, &objects, &bad)
    );
    let sizes = unsafe { sizes.assume_init() };
    let mut scratch = vec![0u32; sizes.scratch_len];
    let zero = refl_cluster_plan_entry {
        id: 0,
        object: 0,
        first: 0,
        len: 0,
        rows: rows(0, 0),
        lobe: lobes[0],
        camera: refl_cluster_camera::from_view(&refl_core::cluster::ClusterView::Fallback(
            refl_core::cluster::ClusterFallback::NoRays,
        )),
        frustum: [refl_vec4 {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 0.0,
        }; 6],
    };
    let mut list = vec![zero; sizes.clusters_len];
    let mut pst = uninit::<refl_cluster_plan_stats>();
    ok!(
        cov,
        refl_cluster_plan(
            pst.as_mut_ptr(),
            list.as_mut_ptr(),
            list.len(),
            scratch.as_mut_ptr(),
            scratch.len(),
            &g,
            &objects,
            &opts
        )
    );
    err!(
        cov,
        refl_cluster_plan(
            pst.as_mut_ptr(),
            list.as_mut_ptr(),
            list.len(),
            scratch.as_mut_ptr(),
            scratch.len() - 1,
            &g,
            &objects,
            &opts
        )
    );
    let pst = unsafe { pst.assume_init() };
    assert!(pst.cameras >= 1);
    let e = *list[..pst.clusters as usize]
        .iter()
        .find(|e| e.camera.fallback == 0)
        .unwrap();
    // The host's render (here: a constant depth and color).
    let (rw, rh) = (e.camera.camera.width, e.camera.camera.height);
    let rn = (rw * rh) as usize;
    let rdepth = vec![5.0f32; rn];
    let rcolor = vec![[0.25f32, 0.5, 0.75]; rn];
    let render = refl_cluster_render {
        depth: refl_depth_image {
            depth: refl_image_f32 {
                data: rdepth.as_ptr(),
                len: rn,
                width: rw,
                height: rh,
                stride: rw,
            },
            camera: e.camera.camera,
            convention: refl_depth_convention::Linear as u32,
        },
        color: refl_image_vec3 {
            data: rcolor.as_ptr().cast(),
            len: rn,
            width: rw,
            height: rh,
            stride: rw,
        },
        back_depth: no_f32(),
        reflector_diffuse: no_vec3(),
        reflector_ids: no_u32(),
    };
    let mut texels = vec![refl_cluster_texel::default(); N];
    let mut host = vec![refl_host_ray::default(); N];
    let mut st = uninit::<refl_cluster_stats>();
    ok!(
        cov,
        refl_cluster_finalize_rows(
            st.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            host.as_mut_ptr(),
            N,
            &g,
            &opts,
            scratch.as_ptr(),
            scratch.len(),
            &e,
            &render,
            e.rows
        )
    );
    err!(
        cov,
        refl_cluster_finalize_rows(
            st.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            host.as_mut_ptr(),
            N,
            &g,
            &opts,
            scratch.as_ptr(),
            scratch.len(),
            &e,
            core::ptr::null(),
            e.rows
        )
    );
}

fn planar(cov: &mut Coverage) {
    let s = scene();
    let opts = value!(cov, refl_planar_options_default());
    let g = refl_gbuffer {
        depth: s.depth_image(),
        normals: vec3_img(&s.normals),
        normal_space: refl_normal_space::World as u32,
        mask: refl_image_u8 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        roughness: no_f32(),
        color: refl_image_vec3 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        back_depth: no_f32(),
    };
    let mirror = refl_planar_mirror {
        plane: refl_plane {
            normal: v3(0.0, 1.0, 0.0),
            d: 0.0,
        },
        ids: refl_image_u32 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        id: 0,
    };
    let mut setup = uninit::<refl_planar_setup>();
    ok!(
        cov,
        refl_planar_prepare(setup.as_mut_ptr(), &g, &mirror, &opts)
    );
    let bad = refl_planar_options { scale: 0, ..opts };
    err!(
        cov,
        refl_planar_prepare(setup.as_mut_ptr(), &g, &mirror, &bad)
    );
    let setup = unsafe { setup.assume_init() };
    assert!(setup.covered);
    let mut st = uninit::<refl_planar_stats>();
    let mut cover = vec![0u8; N];
    ok!(
        cov,
        refl_planar_cover_rows(
            st.as_mut_ptr(),
            cover.as_mut_ptr(),
            N,
            &g,
            &mirror,
            &opts,
            rows(0, H)
        )
    );
    err!(
        cov,
        refl_planar_cover_rows(
            st.as_mut_ptr(),
            cover.as_mut_ptr(),
            N,
            &g,
            &mirror,
            &opts,
            rows(3, 2)
        )
    );
    // The host's mirrored render (here: a constant color and depth).
    let (rw, rh) = (setup.camera.width, setup.camera.height);
    let rn = (rw * rh) as usize;
    let rdepth = vec![0.5f32; rn];
    let rcolor = vec![[0.25f32, 0.5, 0.75]; rn];
    let render = refl_planar_render {
        depth: refl_image_f32 {
            data: rdepth.as_ptr(),
            len: rn,
            width: rw,
            height: rh,
            stride: rw,
        },
        color: refl_image_vec3 {
            data: rcolor.as_ptr().cast(),
            len: rn,
            width: rw,
            height: rh,
            stride: rw,
        },
    };
    let mut texels = vec![refl_planar_texel::default(); N];
    let mut color = vec![[0.0f32; 3]; N];
    let mut host = vec![refl_host_ray::default(); N];
    ok!(
        cov,
        refl_planar_resolve_rows(
            st.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            vec3_mut(&mut color),
            host.as_mut_ptr(),
            N,
            &g,
            &mirror,
            &opts,
            &render,
            rows(0, H)
        )
    );
    err!(
        cov,
        refl_planar_resolve_rows(
            st.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            vec3_mut(&mut color),
            host.as_mut_ptr(),
            N,
            &g,
            &mirror,
            &opts,
            &render,
            rows(3, 2)
        )
    );
    // The back-face depth image from the host's second depth pass.
    let front = s.depth_image();
    let mut back = vec![0.0f32; N];
    let mut bst = uninit::<refl_trace_back_depth_stats>();
    ok!(
        cov,
        refl_trace_back_depth_rows(
            bst.as_mut_ptr(),
            f32_mut(&mut back),
            &front,
            f32_img(&s.back),
            rows(0, H)
        )
    );
    err!(
        cov,
        refl_trace_back_depth_rows(
            bst.as_mut_ptr(),
            f32_mut(&mut back),
            &front,
            f32_img(&s.back),
            rows(3, 2)
        )
    );
}

fn layered(cov: &mut Coverage) {
    let (res, layers) = (4u32, 2u32);
    let mut sizes = uninit::<refl_layered_sizes>();
    ok!(cov, refl_layered_len(sizes.as_mut_ptr(), res, layers));
    err!(cov, refl_layered_len(sizes.as_mut_ptr(), 0, layers));
    let sz = unsafe { sizes.assume_init() };
    let params = value!(cov, refl_layered_options_default());
    let grid = refl_layered_grid {
        min: v3(-1.0, -1.0, -1.0),
        max: v3(1.0, 1.0, 1.0),
        face_res: res,
        layers,
        world_from_local: refl_mat4::from(refl_core::glam::Mat4::IDENTITY),
    };
    let mut cr = uninit::<refl_layered_column_ray>();
    ok!(cov, refl_layered_face_ray(cr.as_mut_ptr(), &grid, 1, 2, 3));
    err!(cov, refl_layered_face_ray(cr.as_mut_ptr(), &grid, 6, 2, 3));
    let (mut depth, mut payload) = (vec![0.0f32; sz.depth_len], vec![0u32; sz.payload_len]);
    let (mut counts, mut bounds) = (vec![0u32; sz.counts_len], vec![0.0f32; sz.bounds_len]);
    let m = refl_layered_map_mut {
        grid,
        depth: depth.as_mut_ptr(),
        depth_len: depth.len(),
        payload: payload.as_mut_ptr(),
        payload_len: payload.len(),
        counts: counts.as_mut_ptr(),
        counts_len: counts.len(),
        bounds: bounds.as_mut_ptr(),
        bounds_len: bounds.len(),
    };
    let short = refl_layered_map_mut {
        counts_len: sz.counts_len - 1,
        ..m
    };
    ok!(cov, refl_layered_clear(&m));
    err!(cov, refl_layered_clear(&short));
    // A sphere of radius 0.8: two crossings per column that meets it.
    let mut hits = Vec::new();
    let mut offsets = vec![0usize];
    for j in 0..res {
        for i in 0..res {
            let mut r = uninit::<refl_layered_column_ray>();
            assert_eq!(
                unsafe { refl_layered_face_ray(r.as_mut_ptr(), &grid, 0, i, j) },
                refl_status::Ok
            );
            let r = unsafe { r.assume_init() };
            let (o, d) = (Vec3::from(r.origin), Vec3::from(r.dir));
            let b = o.dot(d);
            let disc = b * b - (o.dot(o) - 0.64);
            if disc > 0.0 {
                let q = disc.sqrt();
                hits.push(refl_layered_layer_hit {
                    t: -b + q,
                    id: 7,
                    front: false,
                });
                hits.push(refl_layered_layer_hit {
                    t: -b - q,
                    id: 7,
                    front: true,
                });
            }
            offsets.push(hits.len());
        }
    }
    let mut approx = uninit::<u32>();
    ok!(
        cov,
        refl_layered_fill_face(
            approx.as_mut_ptr(),
            &m,
            0,
            hits.as_mut_ptr(),
            hits.len(),
            offsets.as_ptr(),
            offsets.len()
        )
    );
    err!(
        cov,
        refl_layered_fill_face(
            approx.as_mut_ptr(),
            &m,
            0,
            hits.as_mut_ptr(),
            hits.len(),
            offsets.as_ptr(),
            offsets.len() - 1
        )
    );
    let mut col = [
        refl_layered_layer_hit {
            t: 1.5,
            id: 3,
            front: false,
        },
        refl_layered_layer_hit {
            t: 0.5,
            id: 3,
            front: true,
        },
    ];
    let mut fill = uninit::<refl_layered_column_fill>();
    ok!(
        cov,
        refl_layered_fill_column(fill.as_mut_ptr(), &m, 2, 1, 1, col.as_mut_ptr(), col.len())
    );
    col[0].t = f32::NAN;
    err!(
        cov,
        refl_layered_fill_column(fill.as_mut_ptr(), &m, 2, 1, 1, col.as_mut_ptr(), col.len())
    );
    ok!(cov, refl_layered_build_bounds(&m));
    err!(cov, refl_layered_build_bounds(&short));
    let map = refl_layered_map {
        grid,
        depth: depth.as_ptr(),
        depth_len: depth.len(),
        payload: payload.as_ptr(),
        payload_len: payload.len(),
        counts: counts.as_ptr(),
        counts_len: counts.len(),
        bounds: bounds.as_ptr(),
        bounds_len: bounds.len(),
    };
    let ray = refl_ray {
        origin: v3(3.0, 0.1, 0.0),
        dir: v3(-1.0, 0.0, 0.0),
    };
    let mut lr = uninit::<refl_layered_result>();
    ok!(
        cov,
        refl_layered_trace_ray(lr.as_mut_ptr(), &map, ray, f32::INFINITY, &params)
    );
    assert!(unsafe { lr.assume_init() }.hit);
    err!(
        cov,
        refl_layered_trace_ray(lr.as_mut_ptr(), &map, bad_ray(), f32::INFINITY, &params)
    );
    let rays = [ray; 8];
    let mut out = vec![refl_layered_result::default(); 8];
    ok!(
        cov,
        refl_layered_trace_rays(
            out.as_mut_ptr(),
            8,
            &map,
            rays.as_ptr(),
            8,
            f32::INFINITY,
            &params
        )
    );
    err!(
        cov,
        refl_layered_trace_rays(
            out.as_mut_ptr(),
            7,
            &map,
            rays.as_ptr(),
            8,
            f32::INFINITY,
            &params
        )
    );
    let mut class = uninit::<u32>();
    let (eye, center) = (v3(0.0, 2.0, 3.0), v3(0.0, 1.0, 0.0));
    let tri = [v3(-5.0, 0.0, -5.0), v3(5.0, 0.0, -5.0), v3(0.0, 0.0, 5.0)];
    ok!(
        cov,
        refl_layered_prr_classify(class.as_mut_ptr(), eye, center, 0.5, tri[0], tri[1], tri[2])
    );
    err!(
        cov,
        refl_layered_prr_classify(
            class.as_mut_ptr(),
            eye,
            center,
            -0.5,
            tri[0],
            tri[1],
            tri[2]
        )
    );
    // The back-face depth image from this map.
    let s = scene();
    let front = s.depth_image();
    let mut back = vec![0.0f32; N];
    let mut bst = uninit::<refl_trace_back_depth_stats>();
    ok!(
        cov,
        refl_trace_back_depth_layered_rows(
            bst.as_mut_ptr(),
            f32_mut(&mut back),
            &front,
            &map,
            rows(0, H)
        )
    );
    err!(
        cov,
        refl_trace_back_depth_layered_rows(
            bst.as_mut_ptr(),
            f32_mut(&mut back),
            &front,
            &map,
            rows(3, 2)
        )
    );
}

/// The layered-maps pass over the test scene with one map (a sphere of
/// radius 0.5 above the floor, built with refl-core).
fn layered_pass(cov: &mut Coverage) {
    use refl_core::layered::{Face, LayerHit, LayeredGrid, LayeredMapMut};
    let s = scene();
    let (res, c) = (8u32, Vec3::new(0.0, 0.6, -1.0));
    let grid = LayeredGrid::try_new(Vec3::splat(-0.52), Vec3::splat(0.52), res, 1)
        .unwrap()
        .try_with_transform(refl_core::glam::Affine3A::from_translation(c))
        .unwrap();
    let len = grid.len();
    let (mut depth, mut payload) = (vec![0.0f32; len.depth], vec![0u32; len.payload]);
    let (mut counts, mut bounds) = (vec![0u32; len.counts], vec![0.0f32; len.bounds]);
    {
        let mut m =
            LayeredMapMut::try_new(grid, &mut depth, &mut payload, &mut counts, &mut bounds)
                .unwrap();
        m.clear();
        for face in [Face::NegX, Face::NegY, Face::NegZ] {
            for j in 0..res {
                for i in 0..res {
                    let r = grid.try_face_ray(face, i, j).unwrap();
                    let o = r.origin - c;
                    let b = o.dot(r.dir);
                    let disc = b * b - (o.dot(o) - 0.25);
                    let mut hits = Vec::new();
                    if disc > 0.0 {
                        let q = disc.sqrt();
                        hits.push(LayerHit {
                            t: -b - q,
                            id: 3,
                            front: true,
                        });
                        hits.push(LayerHit {
                            t: -b + q,
                            id: 3,
                            front: false,
                        });
                    }
                    m.try_fill_column(face, i, j, &mut hits).unwrap();
                }
            }
        }
        m.build_bounds();
    }
    let maps = [refl_layered_map {
        grid: (&grid).into(),
        depth: depth.as_ptr(),
        depth_len: depth.len(),
        payload: payload.as_ptr(),
        payload_len: payload.len(),
        counts: counts.as_ptr(),
        counts_len: counts.len(),
        bounds: bounds.as_ptr(),
        bounds_len: bounds.len(),
    }];
    let map_ids = [7u32];
    let input = refl_layered_pass_input {
        gbuffer: refl_gbuffer {
            depth: s.depth_image(),
            normals: vec3_img(&s.normals),
            normal_space: refl_normal_space::World as u32,
            mask: refl_image_u8 {
                data: core::ptr::null(),
                len: 0,
                width: 0,
                height: 0,
                stride: 0,
            },
            roughness: no_f32(),
            color: vec3_img(&s.color),
            back_depth: no_f32(),
        },
        maps: maps.as_ptr(),
        maps_len: 1,
        ids: u32_img(&s.objects),
        map_ids: map_ids.as_ptr(),
        map_ids_len: 1,
        regions: refl_image_u32 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        region_masks: core::ptr::null(),
        region_masks_len: 0,
    };
    let opts = value!(cov, refl_layered_pass_options_default());
    let bad_o = refl_layered_pass_options {
        t_max: f32::NAN,
        ..opts
    };
    let mut len = uninit::<usize>();
    ok!(
        cov,
        refl_layered_pass_scratch_len(len.as_mut_ptr(), &input, &opts)
    );
    err!(
        cov,
        refl_layered_pass_scratch_len(len.as_mut_ptr(), core::ptr::null(), &opts)
    );
    let len = unsafe { len.assume_init() };
    assert_eq!(len, 1);
    let mut scratch = vec![refl_layered_bound::default(); len];
    ok!(
        cov,
        refl_layered_pass_prepare(scratch.as_mut_ptr(), len, &input, &opts)
    );
    err!(
        cov,
        refl_layered_pass_prepare(scratch.as_mut_ptr(), len, &input, &bad_o)
    );
    let mut texels = vec![refl_layered_pass_texel::default(); N];
    let mut host = vec![refl_host_ray::default(); N];
    let mut stats = uninit::<refl_layered_pass_stats>();
    let no_color = refl_image_vec3_mut {
        data: core::ptr::null_mut(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    };
    ok!(
        cov,
        refl_layered_trace_rows(
            stats.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            no_color,
            host.as_mut_ptr(),
            N,
            &input,
            &opts,
            scratch.as_ptr(),
            len,
            rows(0, H)
        )
    );
    let st = unsafe { stats.assume_init() };
    assert!(st.hits > 0 && st.host_rays > 0, "{st:?}");
    err!(
        cov,
        refl_layered_trace_rows(
            stats.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            no_color,
            host.as_mut_ptr(),
            N,
            &input,
            &opts,
            scratch.as_ptr(),
            len,
            rows(3, 2)
        )
    );
    let rays: Vec<refl_host_ray> = host[..8].to_vec();
    let mut out = vec![refl_layered_pass_texel::default(); 8];
    let mut host2 = vec![refl_host_ray::default(); 8];
    ok!(
        cov,
        refl_layered_trace_host_rays(
            stats.as_mut_ptr(),
            out.as_mut_ptr(),
            8,
            core::ptr::null_mut(),
            0,
            host2.as_mut_ptr(),
            8,
            &input,
            &opts,
            scratch.as_ptr(),
            len,
            rays.as_ptr(),
            8
        )
    );
    let mut bad = rays.clone();
    bad[3].dir = v3(0.0, f32::NAN, 0.0);
    err!(
        cov,
        refl_layered_trace_host_rays(
            stats.as_mut_ptr(),
            out.as_mut_ptr(),
            8,
            core::ptr::null_mut(),
            0,
            host2.as_mut_ptr(),
            8,
            &input,
            &opts,
            scratch.as_ptr(),
            len,
            bad.as_ptr(),
            8
        )
    );
    // Potential reflection regions: the masks of two reflector triangles
    // (a floor under the sphere and one far behind the camera), then the
    // pass with every pixel in the floor's region.
    let floor = |z: f32| {
        let t = refl_core::PrrTriangle::flat([
            Vec3::new(-3.0, -0.5, z),
            Vec3::new(3.0, -0.5, z),
            Vec3::new(0.0, -0.5, z - 6.0),
        ]);
        refl_layered_prr_triangle {
            corners: t.corners.map(|c| v3(c[0], c[1], c[2])),
            normals: t.normals.map(|c| v3(c[0], c[1], c[2])),
        }
    };
    let tris = [floor(2.0), floor(60.0)];
    let mut words = uninit::<usize>();
    ok!(
        cov,
        refl_layered_prr_masks_len(words.as_mut_ptr(), 2, len as u32)
    );
    err!(
        cov,
        refl_layered_prr_masks_len(core::ptr::null_mut(), 2, 65)
    );
    assert_eq!(unsafe { words.assume_init() }, 2);
    let mut masks = [0u64; 2];
    let mut prr = uninit::<refl_layered_prr_stats>();
    ok!(
        cov,
        refl_layered_prr_masks(
            prr.as_mut_ptr(),
            masks.as_mut_ptr(),
            2,
            tris.as_ptr(),
            2,
            v3(0.0, 0.0, 2.0),
            scratch.as_ptr(),
            len
        )
    );
    err!(
        cov,
        refl_layered_prr_masks(
            prr.as_mut_ptr(),
            masks.as_mut_ptr(),
            1,
            tris.as_ptr(),
            2,
            v3(0.0, 0.0, 2.0),
            scratch.as_ptr(),
            len
        )
    );
    let regions = vec![0u32; N];
    let with_regions = refl_layered_pass_input {
        regions: u32_img(&regions),
        region_masks: masks.as_ptr(),
        region_masks_len: 2,
        ..input
    };
    ok!(
        cov,
        refl_layered_trace_rows(
            stats.as_mut_ptr(),
            texels.as_mut_ptr(),
            N,
            no_color,
            host.as_mut_ptr(),
            N,
            &with_regions,
            &opts,
            scratch.as_ptr(),
            len,
            rows(0, H)
        )
    );
}

fn cluster(cov: &mut Coverage) {
    let s = scene();
    let params = value!(cov, refl_cluster_options_default());
    let mut cam_params = value!(cov, refl_cluster_camera_options_default());
    cam_params.max_resolution = 48;
    cam_params.far_distance = 20.0;
    let mut max = uninit::<u32>();
    ok!(cov, refl_cluster_bins_max(max.as_mut_ptr(), 2, &params));
    let bad_p = refl_cluster_options {
        gain: -1.0,
        ..params
    };
    err!(cov, refl_cluster_bins_max(max.as_mut_ptr(), 2, &bad_p));
    let max = unsafe { max.assume_init() };

    let mut counts = [0u32; 2];
    ok!(
        cov,
        refl_cluster_count_objects(counts.as_mut_ptr(), 2, u32_img(&s.objects), rows(0, H))
    );
    err!(
        cov,
        refl_cluster_count_objects(counts.as_mut_ptr(), 2, u32_img(&s.objects), rows(0, H + 1))
    );
    let mut layout = [refl_cluster_object_bins::default(); 2];
    let mut total = uninit::<u32>();
    ok!(
        cov,
        refl_cluster_bin_layout(
            total.as_mut_ptr(),
            layout.as_mut_ptr(),
            2,
            counts.as_ptr(),
            2,
            N as u64,
            &params
        )
    );
    err!(
        cov,
        refl_cluster_bin_layout(
            total.as_mut_ptr(),
            layout.as_mut_ptr(),
            1,
            counts.as_ptr(),
            2,
            N as u64,
            &params
        )
    );
    let clusters = unsafe { total.assume_init() };
    assert!(clusters <= max);
    let mut ids = vec![0u32; N];
    ok!(
        cov,
        refl_cluster_assign(
            u32_mut(&mut ids),
            rows(0, H),
            vec3_img(&s.normals),
            u32_img(&s.objects),
            layout.as_ptr(),
            2
        )
    );
    let mut bad_n = s.normals.clone();
    bad_n[s.floor()[0] as usize] = [0.0; 3];
    err!(
        cov,
        refl_cluster_assign(
            u32_mut(&mut ids),
            rows(0, H),
            vec3_img(&bad_n),
            u32_img(&s.objects),
            layout.as_ptr(),
            2
        )
    );
    let mut offsets = vec![0u32; clusters as usize + 1];
    let mut order = vec![0u32; N];
    let mut placed = uninit::<u32>();
    ok!(
        cov,
        refl_cluster_ranges(
            placed.as_mut_ptr(),
            offsets.as_mut_ptr(),
            offsets.len(),
            order.as_mut_ptr(),
            N,
            u32_img(&ids),
            clusters
        )
    );
    err!(
        cov,
        refl_cluster_ranges(
            placed.as_mut_ptr(),
            offsets.as_mut_ptr(),
            offsets.len() - 1,
            order.as_mut_ptr(),
            N,
            u32_img(&ids),
            clusters
        )
    );

    let floor = s.floor();
    let eye = refl_vec3::from(s.cam.eye());
    let (pos, nrm) = (vec3_img(&s.positions), vec3_img(&s.normals));
    let mut cc = uninit::<refl_cluster_camera>();
    ok!(
        cov,
        refl_cluster_build_camera(
            cc.as_mut_ptr(),
            pos,
            nrm,
            floor.as_ptr(),
            floor.len(),
            eye,
            &cam_params
        )
    );
    let bad_cp = refl_cluster_camera_options {
        far_distance: -1.0,
        ..cam_params
    };
    err!(
        cov,
        refl_cluster_build_camera(
            cc.as_mut_ptr(),
            pos,
            nrm,
            floor.as_ptr(),
            floor.len(),
            eye,
            &bad_cp
        )
    );
    let cc = unsafe { cc.assume_init() };
    assert_eq!(cc.fallback, 0, "the floor cluster has a camera");
    let mut angle = uninit::<f32>();
    ok!(cov, refl_cluster_lobe_angle(angle.as_mut_ptr(), 20.0, 0.9));
    err!(cov, refl_cluster_lobe_angle(angle.as_mut_ptr(), 20.0, 1.5));

    let (cw, ch) = (cc.camera.width, cc.camera.height);
    let cn = (cw * ch) as usize;
    let cdepth = vec![5.0f32; cn];
    let ccolor = vec![[0.5f32; 3]; cn];
    let depth = refl_depth_image {
        depth: refl_image_f32 {
            data: cdepth.as_ptr(),
            len: cn,
            width: cw,
            height: ch,
            stride: cw,
        },
        camera: cc.camera,
        convention: 0,
    };
    let color = refl_image_vec3 {
        data: ccolor.as_ptr().cast(),
        len: cn,
        width: cw,
        height: ch,
        stride: cw,
    };
    let fp = refl_cluster_finalize_input {
        thickness: thickness(0.5),
        step: refl_step_options {
            stride: 1,
            max_steps: u32::MAX,
        },
        refine: true,
        lobe: refl_cluster_lobe {
            rays: 4,
            exponent: 20.0,
            max_angle: 0.5,
        },
        fade: true,
        seed: 3,
        single_ray: false,
    };
    let mut shades = vec![refl_cluster_shade::default(); floor.len()];
    let mut fell = uninit::<u32>();
    ok!(
        cov,
        refl_cluster_finalize(
            fell.as_mut_ptr(),
            shades.as_mut_ptr(),
            shades.len(),
            pos,
            nrm,
            floor.as_ptr(),
            floor.len(),
            eye,
            &cc,
            &depth,
            color,
            &fp
        )
    );
    err!(
        cov,
        refl_cluster_finalize(
            fell.as_mut_ptr(),
            shades.as_mut_ptr(),
            shades.len() - 1,
            pos,
            nrm,
            floor.as_ptr(),
            floor.len(),
            eye,
            &cc,
            &depth,
            color,
            &fp
        )
    );
}

fn tcrr(cov: &mut Coverage) {
    let s = scene();
    let params = value!(cov, refl_tcrr_options_default());
    let mut bytes = uninit::<usize>();
    ok!(cov, refl_tcrr_frame_bytes(bytes.as_mut_ptr(), W, H));
    err!(cov, refl_tcrr_frame_bytes(bytes.as_mut_ptr(), 0, H));
    let mut f = uninit::<f32>();
    let (eye, surface, normal) = (v3(0.0, 1.0, 2.0), v3(0.0, 0.0, 0.0), v3(0.0, 1.0, 0.0));
    ok!(
        cov,
        refl_tcrr_reflection_distance(
            f.as_mut_ptr(),
            eye,
            surface,
            normal,
            v3(0.0, 1.0, -2.0),
            refl_tcrr_reflected::Point as u32
        )
    );
    err!(
        cov,
        refl_tcrr_reflection_distance(f.as_mut_ptr(), eye, surface, normal, v3(0.0, 1.0, -2.0), 9)
    );
    let key = |surfels: Option<&[refl_tcrr_surfel]>| refl_tcrr_key {
        camera: s.camera(),
        convention: 0,
        depth: f32_img(&s.depth),
        normal: vec3_img(&s.normals),
        specular: f32_img(&s.spec),
        color: vec3_img(&s.color),
        distance: f32_img(&s.dist),
        surfels: refl_image_tcrr_surfel {
            data: surfels.map_or(core::ptr::null(), <[_]>::as_ptr),
            len: surfels.map_or(0, <[_]>::len),
            width: W,
            height: H,
            stride: W,
        },
    };
    let mut surfels = vec![refl_tcrr_surfel::default(); N];
    let surfels_mut = refl_image_tcrr_surfel_mut {
        data: surfels.as_mut_ptr(),
        len: N,
        width: W,
        height: H,
        stride: W,
    };
    let plain = key(None);
    let mut reflective = uninit::<u32>();
    ok!(
        cov,
        refl_tcrr_prepare(surfels_mut, reflective.as_mut_ptr(), &plain, rows(0, H))
    );
    err!(
        cov,
        refl_tcrr_prepare(surfels_mut, reflective.as_mut_ptr(), &plain, rows(0, H + 1))
    );
    let k = key(Some(&surfels));
    let mut offsets = vec![[0.0f32; 2]; N];
    ok!(
        cov,
        refl_tcrr_reset_offsets(vec2_mut(&mut offsets), rows(0, H))
    );
    err!(
        cov,
        refl_tcrr_reset_offsets(vec2_mut(&mut offsets), rows(2, 1))
    );
    let cur_eye = v3(0.25, 1.5, 4.0);
    let mut ss = uninit::<refl_tcrr_search_stats>();
    ok!(
        cov,
        refl_tcrr_search(
            vec2_mut(&mut offsets),
            ss.as_mut_ptr(),
            &k,
            cur_eye,
            &params,
            rows(0, H)
        )
    );
    let bad_p = refl_tcrr_options {
        magnification: -1.0,
        ..params
    };
    err!(
        cov,
        refl_tcrr_search(
            vec2_mut(&mut offsets),
            ss.as_mut_ptr(),
            &k,
            cur_eye,
            &bad_p,
            rows(0, H)
        )
    );
    let (mut inter, mut idepth, mut coverage) =
        (vec![[0.0f32; 3]; N], vec![0.0f32; N], vec![0u8; N]);
    let mut sh = uninit::<refl_tcrr_shift_stats>();
    ok!(
        cov,
        refl_tcrr_shift(
            vec3_mut(&mut inter),
            f32_mut(&mut idepth),
            u8_mut(&mut coverage),
            sh.as_mut_ptr(),
            &k,
            vec2_img(&offsets),
            &params,
            rows(0, H)
        )
    );
    err!(
        cov,
        refl_tcrr_shift(
            vec3_mut(&mut inter),
            f32_mut(&mut idepth),
            u8_mut(&mut coverage),
            sh.as_mut_ptr(),
            &k,
            vec2_img(&offsets),
            &bad_p,
            rows(0, H)
        )
    );
    let cur = refl_tcrr_current {
        camera: s.camera(),
        convention: 0,
        depth: f32_img(&s.depth),
        specular: f32_img(&s.spec),
    };
    let (mut color, mut mask) = (vec![[0.0f32; 3]; N], vec![0u8; N]);
    let mut ws = uninit::<refl_tcrr_warp_stats>();
    ok!(
        cov,
        refl_tcrr_warp(
            vec3_mut(&mut color),
            u8_mut(&mut mask),
            ws.as_mut_ptr(),
            &cur,
            &k,
            vec3_img(&inter),
            f32_img(&idepth),
            u8_img(&coverage),
            &params,
            rows(0, H)
        )
    );
    err!(
        cov,
        refl_tcrr_warp(
            vec3_mut(&mut color),
            u8_mut(&mut mask),
            ws.as_mut_ptr(),
            &cur,
            &k,
            vec3_img(&inter),
            f32_img(&idepth),
            u8_img(&coverage),
            &bad_p,
            rows(0, H)
        )
    );
    mask[5] = REFL_TCRR_MASK_RETRACE;
    let mut list = vec![0u32; N];
    let mut count = uninit::<usize>();
    ok!(
        cov,
        refl_tcrr_retrace_list(list.as_mut_ptr(), N, count.as_mut_ptr(), u8_img(&mask))
    );
    ok!(
        cov,
        refl_tcrr_retrace_list(core::ptr::null_mut(), 0, count.as_mut_ptr(), u8_img(&mask))
    );
    err!(
        cov,
        refl_tcrr_retrace_list(list.as_mut_ptr(), 0, count.as_mut_ptr(), u8_img(&mask))
    );
    let diffuse = vec![[0.2f32; 3]; N];
    let mut fin = vec![[0.0f32; 3]; N];
    ok!(
        cov,
        refl_tcrr_compose(
            vec3_mut(&mut fin),
            vec3_img(&diffuse),
            vec3_img(&color),
            vec3_img(&s.normals),
            &cur,
            1,
            rows(0, H)
        )
    );
    err!(
        cov,
        refl_tcrr_compose(
            vec3_mut(&mut fin),
            vec3_img(&diffuse),
            vec3_img(&color),
            vec3_img(&s.normals),
            &cur,
            9,
            rows(0, H)
        )
    );
    ok!(cov, refl_tcrr_fresnel_weight(f.as_mut_ptr(), 0.5, 0.7, 1));
    err!(cov, refl_tcrr_fresnel_weight(f.as_mut_ptr(), 0.5, 0.7, 9));
    let mut need = uninit::<bool>();
    ok!(
        cov,
        refl_tcrr_needs_key_frame(need.as_mut_ptr(), 0.3, 10, 100)
    );
    err!(
        cov,
        refl_tcrr_needs_key_frame(need.as_mut_ptr(), 0.3, 101, 100)
    );
}

fn epipolar(cov: &mut Coverage) {
    let s = scene();
    let params = value!(cov, refl_epipolar_options_default());
    let mut len = uninit::<usize>();
    ok!(cov, refl_epipolar_scratch_len(len.as_mut_ptr(), W, H));
    err!(cov, refl_epipolar_scratch_len(len.as_mut_ptr(), 0, H));
    let len = unsafe { len.assume_init() };
    let pos: Vec<refl_epipolar_pos_entry> = (0..N)
        .map(|i| {
            let y = i as u32 / W;
            let x = i as u32 % W;
            let r = s.cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (e, t) = if s.depth[i].is_finite() {
                (
                    Vec3::from(s.positions[i]),
                    r.origin.distance(Vec3::from(s.positions[i])),
                )
            } else {
                (r.at(40.0), 40.0)
            };
            refl_epipolar_pos_entry {
                point: e.to_array(),
                object: if s.depth[i].is_finite() {
                    s.objects[i]
                } else {
                    REFL_EPIPOLAR_INVALID_OBJECT - 1
                },
                t,
            }
        })
        .collect();
    let mut aip = vec![
        refl_epipolar_aip_entry {
            object: 0,
            t: 0.0,
            cnt: 0,
            t_other: 0.0,
            flags: 0,
        };
        N
    ];
    let mut scratch = vec![0.0f32; len];
    let mut st = uninit::<refl_epipolar_stats>();
    let prev = s.camera();
    let mut cur = prev;
    cur.view.m[12] += 0.05;
    ok!(
        cov,
        refl_epipolar_reproject(
            aip.as_mut_ptr(),
            N,
            scratch.as_mut_ptr(),
            len,
            st.as_mut_ptr(),
            pos.as_ptr(),
            N,
            &prev,
            &cur,
            &params
        )
    );
    err!(
        cov,
        refl_epipolar_reproject(
            aip.as_mut_ptr(),
            N,
            scratch.as_mut_ptr(),
            len - 1,
            st.as_mut_ptr(),
            pos.as_ptr(),
            N,
            &prev,
            &cur,
            &params
        )
    );
    let mut dec = vec![
        refl_epipolar_decision {
            object: 0,
            tmax: 0.0,
            tmin: 0.0,
            reason: 0,
        };
        N
    ];
    ok!(
        cov,
        refl_epipolar_decide_rows(
            dec.as_mut_ptr(),
            N,
            aip.as_ptr(),
            N,
            W,
            rows(0, H),
            1,
            &params
        )
    );
    err!(
        cov,
        refl_epipolar_decide_rows(
            dec.as_mut_ptr(),
            N,
            aip.as_ptr(),
            N,
            W,
            rows(4, 2),
            1,
            &params
        )
    );
}

/// `include/refl.h`.
fn header() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../include/refl.h");
    std::fs::read_to_string(path).expect("include/refl.h")
}

/// The names of the functions a C header declares: identifiers starting
/// with `refl_` followed by `(` outside comments and macros.
fn header_functions(h: &str) -> BTreeSet<String> {
    let mut code = String::new();
    let mut rest = h;
    while let Some(i) = rest.find("/*") {
        code.push_str(&rest[..i]);
        rest = rest[i..].find("*/").map_or("", |j| &rest[i + j + 2..]);
    }
    code.push_str(rest);
    let mut names = BTreeSet::new();
    for line in code.lines().filter(|l| !l.trim_start().starts_with('#')) {
        let mut s = line;
        while let Some(i) = s.find("refl_") {
            let tail = &s[i..];
            let end = tail
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(tail.len());
            let before_ok = i == 0 || !s.as_bytes()[i - 1].is_ascii_alphanumeric();
            if before_ok && tail[end..].trim_start().starts_with('(') {
                names.insert(tail[..end].to_owned());
            }
            s = &tail[end..];
        }
    }
    names
}

/// Panics naming every header function not called on a success path, and
/// every fallible one not called on an error path.
fn check_coverage(cov: &Coverage, functions: &BTreeSet<String>) {
    let no_ok: Vec<&String> = functions
        .iter()
        .filter(|f| !cov.ok.contains(f.as_str()))
        .collect();
    let no_err: Vec<&String> = functions
        .iter()
        .filter(|f| !cov.err.contains(f.as_str()) && !infallible(f))
        .collect();
    assert!(
        no_ok.is_empty() && no_err.is_empty(),
        "not called on a success path: {no_ok:?}; not called on an error path: {no_err:?}"
    );
    let unknown: Vec<&&str> = cov
        .ok
        .iter()
        .chain(&cov.err)
        .filter(|f| !functions.contains(**f))
        .collect();
    assert!(
        unknown.is_empty(),
        "called but not in the header: {unknown:?}"
    );
}

#[test]
fn every_header_function_is_covered() {
    let functions = header_functions(&header());
    assert!(functions.len() > 90, "{}", functions.len());
    assert!(functions.contains("refl_version") && functions.contains("refl_step_rays"));
    // Types, macros and comments are not functions.
    assert!(!functions.contains("refl_status") && !functions.contains("refl_camera"));
}

#[test]
fn the_coverage_check_fails_on_a_missing_function() {
    let h = "/* refl_in_comment(x) */\n#define REFL_X refl_macro(1)\n\
             refl_status refl_a(int x);\nconst char *refl_version(void);\n\
             refl_status refl_b(struct refl_thing *t);";
    let functions = header_functions(h);
    let names: Vec<&str> = functions.iter().map(String::as_str).collect();
    assert_eq!(names, ["refl_a", "refl_b", "refl_version"]);
    let mut cov = Coverage::default();
    cov.ok.extend(["refl_a", "refl_b", "refl_version"]);
    cov.err.extend(["refl_a", "refl_b"]);
    check_coverage(&cov, &functions);
    cov.err.remove("refl_b");
    let missing_err = std::panic::catch_unwind(|| check_coverage(&cov, &functions));
    assert!(missing_err.is_err());
    cov.err.insert("refl_b");
    cov.ok.remove("refl_a");
    let missing_ok = std::panic::catch_unwind(|| check_coverage(&cov, &functions));
    assert!(missing_ok.is_err());
}
