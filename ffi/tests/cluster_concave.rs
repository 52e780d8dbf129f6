//! The concave clusters' second intersection (seed 003 Sec. 4.4) through
//! the C ABI: `refl_cluster_plan` marks concave cameras, and
//! `refl_cluster_finalize_rows` with `second_intersection` and the render's
//! reflector images gives refl-core's pass bit for bit, self hits included;
//! without those images a concave cluster is refused with the outputs
//! untouched.

use refl::*;

#[path = "common/gbuffer.rs"]
mod common;
use common::{none_f32, none_u32, none_vec3};
use refl_core::cluster::{ClusterPass, ClusterPassOptions, ClusterRender, ClusterTexel, Lobe};
use refl_core::glam::{DVec3, Vec2, Vec3};
use refl_core::{
    Camera, DepthConvention, DepthImage, GBuffer, ImageView, ImageViewMut, NormalSpace, RowRange,
};

const W: u32 = 96;
const H: u32 = 72;
const N: usize = (W * H) as usize;

fn img<T, C>(d: &[T], make: impl Fn(*const T, usize) -> C) -> C {
    make(d.as_ptr(), d.len())
}

/// A mirror bowl (the lower half of the unit sphere at (0, 1, 0)) seen
/// from above: linear depth, normals toward the eye's side, object 0;
/// the diffuse color of pixel `(x, y)` is `(x, y, 1)`.
struct Frame {
    cam: Camera,
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    ids: Vec<u32>,
    diffuse: Vec<[f32; 3]>,
}

fn frame() -> Frame {
    let cam = Camera::try_look_at(
        Vec3::new(0.4, 3.4, 1.6),
        Vec3::new(0.0, 0.4, 0.0),
        Vec3::Y,
        0.9,
        0.05,
        40.0,
        W,
        H,
    )
    .unwrap();
    let c = DVec3::new(0.0, 1.0, 0.0);
    let mut f = Frame {
        cam,
        depth: vec![cam.far(); N],
        normals: vec![[0.0; 3]; N],
        ids: vec![u32::MAX; N],
        diffuse: (0..N)
            .map(|i| [(i as u32 % W) as f32, (i as u32 / W) as f32, 1.0])
            .collect(),
    };
    for i in 0..N {
        let (x, y) = (i as u32 % W, i as u32 / W);
        let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
        let (o, d) = (r.origin.as_dvec3(), r.dir.as_dvec3());
        let b = (o - c).dot(d);
        let disc = b * b - ((o - c).length_squared() - 1.0);
        if !(disc > 0.0) {
            continue;
        }
        let Some(p) = [-b - disc.sqrt(), -b + disc.sqrt()]
            .into_iter()
            .map(|t| o + d * t)
            .find(|p| p.y < 1.0)
        else {
            continue;
        };
        let n = (p - c).normalize();
        let n = if n.dot(d) > 0.0 { -n } else { n };
        f.depth[i] = cam.linear_depth(p.as_vec3());
        f.normals[i] = n.as_vec3().to_array();
        f.ids[i] = 0;
    }
    f
}

#[test]
fn concave_second_intersection_through_the_c_abi_equals_core() {
    let f = frame();
    let cam_c: refl_camera = (&f.cam).into();
    let g = refl_gbuffer {
        depth: refl_depth_image {
            depth: img(&f.depth, |data, len| refl_image_f32 {
                data,
                len,
                width: W,
                height: H,
                stride: W,
            }),
            camera: cam_c,
            convention: refl_depth_convention::Linear as u32,
        },
        normals: img(&f.normals, |data, len| refl_image_vec3 {
            data: data.cast(),
            len,
            width: W,
            height: H,
            stride: W,
        }),
        normal_space: refl_normal_space::World as u32,
        mask: refl_image_u8 {
            data: core::ptr::null(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        },
        roughness: none_f32(),
        color: none_vec3(),
        back_depth: none_f32(),
    };
    let lobes = [refl_cluster_lobe {
        rays: 1,
        exponent: 0.0,
        max_angle: 0.0,
    }];
    let ids_c = img(&f.ids, |data, len| refl_image_u32 {
        data,
        len,
        width: W,
        height: H,
        stride: W,
    });
    let objects = refl_cluster_objects {
        ids: ids_c,
        lobes: lobes.as_ptr(),
        lobes_len: 1,
    };
    let mut o = refl_cluster_pass_options_default();
    o.camera.far_distance = 20.0;
    o.cluster.gain = 16.0;
    o.second_intersection = true;
    let mut sizes = refl_cluster_plan_sizes::default();
    assert_eq!(
        unsafe { refl_cluster_plan_len(&mut sizes, &g, &objects, &o) },
        refl_status::Ok
    );
    let mut scratch = vec![0u32; sizes.scratch_len];
    let blank = refl_cluster_plan_entry {
        id: 0,
        object: 0,
        first: 0,
        len: 0,
        rows: refl_row_range { begin: 0, end: 0 },
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
    let mut entries = vec![blank; sizes.clusters_len];
    let mut ps = refl_cluster_plan_stats::default();
    assert_eq!(
        unsafe {
            refl_cluster_plan(
                &mut ps,
                entries.as_mut_ptr(),
                entries.len(),
                scratch.as_mut_ptr(),
                scratch.len(),
                &g,
                &objects,
                &o,
            )
        },
        refl_status::Ok
    );
    assert!(
        ps.concave_cameras > 0 && ps.concave_cameras < ps.cameras,
        "{ps:?}"
    );

    // refl-core's pass over the same frame.
    let core_g = GBuffer::try_new(
        DepthImage::try_new(
            ImageView::try_new(&f.depth, W, H, W).unwrap(),
            f.cam,
            DepthConvention::Linear,
        )
        .unwrap(),
        ImageView::try_new(&f.normals, W, H, W).unwrap(),
        NormalSpace::World,
    )
    .unwrap();
    let core_o: ClusterPassOptions = o.into();
    let pass = ClusterPass::try_new(core_g, core_o).unwrap();
    let order = &scratch[N..2 * N];

    let (mut self_hits, mut concave_seen) = (0u64, false);
    for e in &entries[..ps.clusters as usize] {
        if e.camera.fallback != 0 {
            continue;
        }
        let cam = e.camera.camera;
        let (dw, dh) = (cam.width, cam.height);
        let empty = vec![f32::INFINITY; (dw * dh) as usize];
        let black = vec![[0.0f32; 3]; (dw * dh) as usize];
        let mut render = refl_cluster_render {
            depth: refl_depth_image {
                depth: img(&empty, |data, len| refl_image_f32 {
                    data,
                    len,
                    width: dw,
                    height: dh,
                    stride: dw,
                }),
                camera: cam,
                convention: refl_depth_convention::Linear as u32,
            },
            color: img(&black, |data, len| refl_image_vec3 {
                data: data.cast(),
                len,
                width: dw,
                height: dh,
                stride: dw,
            }),
            back_depth: none_f32(),
            reflector_diffuse: none_vec3(),
            reflector_ids: none_u32(),
        };
        let finalize = |render: &refl_cluster_render, out: &mut Vec<refl_cluster_texel>| {
            let mut st = refl_cluster_stats::default();
            let s = unsafe {
                refl_cluster_finalize_rows(
                    &mut st,
                    out.as_mut_ptr(),
                    out.len(),
                    core::ptr::null_mut(),
                    0,
                    &g,
                    &o,
                    scratch.as_ptr(),
                    scratch.len(),
                    e,
                    render,
                    e.rows,
                )
            };
            (s, st)
        };
        let sentinel = refl_cluster_texel {
            status: 77,
            ..Default::default()
        };
        // Without the reflector images: refused for a concave cluster,
        // nothing written.
        let mut out = vec![sentinel; N];
        let (s, _) = finalize(&render, &mut out);
        if e.camera.concave {
            concave_seen = true;
            assert_eq!(s, refl_status::InvalidArgument);
            assert!(out.iter().all(|t| *t == sentinel));
        } else {
            assert_eq!(s, refl_status::Ok);
        }
        // Ids of another size: refused likewise.
        let short_ids = &f.ids[..N - W as usize];
        render.reflector_diffuse = img(&f.diffuse, |data, len| refl_image_vec3 {
            data: data.cast(),
            len,
            width: W,
            height: H,
            stride: W,
        });
        render.reflector_ids = img(short_ids, |data, len| refl_image_u32 {
            data,
            len,
            width: W,
            height: H - 1,
            stride: W,
        });
        let mut out = vec![sentinel; N];
        let (s, _) = finalize(&render, &mut out);
        if e.camera.concave {
            assert_eq!(s, refl_status::InvalidArgument);
            assert!(out.iter().all(|t| *t == sentinel));
        }
        // With them: refl-core's pass bit for bit.
        render.reflector_ids = ids_c;
        let mut out = vec![sentinel; N];
        let (s, st) = finalize(&render, &mut out);
        assert_eq!(s, refl_status::Ok);
        self_hits += st.self_hits;
        let core_entry = refl_core::cluster::ClusterPlanEntry {
            id: e.id,
            object: e.object,
            first: e.first,
            len: e.len,
            rows: RowRange::try_new(e.rows.begin, e.rows.end, H).unwrap(),
            lobe: Lobe::MIRROR,
            view: refl_core::cluster::ClusterView::Camera((&e.camera).try_into().unwrap()),
            frustum: [refl_core::glam::Vec4::ZERO; 6],
        };
        let cam_core = core_entry.camera().unwrap().camera;
        let core_render = ClusterRender::try_new(
            DepthImage::try_new(
                ImageView::try_new(&empty, dw, dh, dw).unwrap(),
                cam_core,
                DepthConvention::Linear,
            )
            .unwrap(),
            ImageView::try_new(&black, dw, dh, dw).unwrap(),
        )
        .unwrap()
        .with_reflector(
            ImageView::try_new(&f.diffuse, W, H, W).unwrap(),
            ImageView::try_new(&f.ids, W, H, W).unwrap(),
        );
        let mut want = vec![ClusterTexel::default(); N];
        let cst = pass
            .try_finalize(
                &mut ImageViewMut::try_new(&mut want, W, H, W).unwrap(),
                &mut [],
                &core_entry,
                order,
                Some(&core_render),
            )
            .unwrap();
        assert_eq!(cst.self_hits, st.self_hits);
        for &p in &order[e.first as usize..(e.first + e.len) as usize] {
            let (a, b) = (&out[p as usize], &want[p as usize]);
            assert_eq!(a.shade, refl_cluster_shade::from(&b.shade));
            assert_eq!(a.status, refl_ssr_status::from(b.status) as u32);
        }
    }
    assert!(concave_seen);
    assert!(self_hits > 100, "{self_hits}");
}
