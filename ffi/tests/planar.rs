//! refl_planar_* and the back-face exports (refl_trace_back_depth_*): the
//! C calls equal refl-core's `PlanarPass` and `backface` functions bit for
//! bit (every convention, full and reduced resolution, whole image and row
//! bands from threads), error paths return their documented status and
//! leave every output untouched, and no export allocates (a counting
//! global allocator, as in ssr.rs).

use refl::*;
use refl_core::glam::Vec3;
use refl_core::layered::{LayerHit, LayeredGrid, LayeredMapMut};
use refl_core::{
    try_back_depth, try_back_depth_layered, try_layered_len, DepthConvention, DepthImage, Face,
    GBuffer, ImageView, ImageViewMut, NormalSpace, PlanarOptions, PlanarPass, PlanarRay,
    PlanarRender, PlanarStatus, PlanarTexel, Plane,
};
#[path = "common/gbuffer.rs"]
mod common;
use common::{
    color_mut, conv_c, counted, no_color, none_f32, render as render_scene, Frame, Shared, H, W,
};

const N: usize = (W * H) as usize;

const CONVENTIONS: [DepthConvention; 3] = [
    DepthConvention::Linear,
    DepthConvention::ZeroToOne,
    DepthConvention::ReversedZ,
];

/// The shared scene with a few back texels damaged: NaN, or equal to the
/// front (a zero-thick shell).
fn render(conv: DepthConvention) -> Frame {
    let mut f = render_scene(conv);
    for i in (0..N).step_by(13) {
        f.back[i] = if i % 2 == 0 { f32::NAN } else { f.depth[i] };
    }
    f
}

fn img_f32(d: &[f32], w: u32, h: u32) -> refl_image_f32 {
    refl_image_f32 {
        data: d.as_ptr(),
        len: d.len(),
        width: w,
        height: h,
        stride: w,
    }
}

fn img_vec3(d: &[[f32; 3]], w: u32, h: u32) -> refl_image_vec3 {
    refl_image_vec3 {
        data: d.as_ptr().cast(),
        len: d.len(),
        width: w,
        height: h,
        stride: w,
    }
}

const NO_VEC3: refl_image_vec3 = refl_image_vec3 {
    data: core::ptr::null(),
    len: 0,
    width: 0,
    height: 0,
    stride: 0,
};

impl Frame {
    fn depth_c(&self) -> refl_depth_image {
        refl_depth_image {
            depth: img_f32(&self.depth, W, H),
            camera: (&self.cam).into(),
            convention: conv_c(self.conv),
        }
    }

    fn planar_gbuffer_c(&self) -> refl_gbuffer {
        refl_gbuffer {
            depth: self.depth_c(),
            normals: img_vec3(&self.normals, W, H),
            normal_space: refl_normal_space::World as u32,
            mask: refl_image_u8 {
                data: core::ptr::null(),
                len: 0,
                width: 0,
                height: 0,
                stride: 0,
            },
            roughness: none_f32(),
            color: NO_VEC3,
            back_depth: none_f32(),
        }
    }

    fn mirror_c(&self, with_ids: bool) -> refl_planar_mirror {
        refl_planar_mirror {
            plane: refl_plane {
                normal: refl_vec3 {
                    x: 0.0,
                    y: -1.0,
                    z: 0.0,
                },
                d: 0.0,
            },
            ids: if with_ids {
                refl_image_u32 {
                    data: self.ids.as_ptr(),
                    len: N,
                    width: W,
                    height: H,
                    stride: W,
                }
            } else {
                refl_image_u32 {
                    data: core::ptr::null(),
                    len: 0,
                    width: 0,
                    height: 0,
                    stride: 0,
                }
            },
            id: 0,
        }
    }

    fn front(&self) -> DepthImage<'_> {
        DepthImage::try_new(
            ImageView::try_new(&self.depth, W, H, W).unwrap(),
            self.cam,
            self.conv,
        )
        .unwrap()
    }

    fn pass(&self, o: PlanarOptions, with_ids: bool) -> PlanarPass<'_> {
        let g = GBuffer::try_new(
            self.front(),
            ImageView::try_new(&self.normals, W, H, W).unwrap(),
            NormalSpace::World,
        )
        .unwrap();
        let plane = Plane::try_new(Vec3::NEG_Y, 0.0).unwrap();
        let p = PlanarPass::try_new(g, plane, o).unwrap();
        if with_ids {
            p.try_with_ids(ImageView::try_new(&self.ids, W, H, W).unwrap(), 0)
                .unwrap()
        } else {
            p
        }
    }
}

/// A mirrored render of `rw x rh` texels in convention `conv`: depths on a
/// ramp with depth edges, some texels cleared, colors from the position.
fn fake_render(conv: DepthConvention, rw: u32, rh: u32) -> (Vec<f32>, Vec<[f32; 3]>) {
    let n = (rw * rh) as usize;
    let mut depth = vec![0.0f32; n];
    let mut color = vec![[0.0f32; 3]; n];
    for k in 0..n {
        let (i, j) = (k as u32 % rw, k as u32 / rw);
        let z = if (i / 5 + j / 3) % 3 == 0 { 12.0 } else { 6.0 } + 0.01 * i as f32;
        depth[k] = match (conv, k % 17) {
            (DepthConvention::Linear, 0) => f32::INFINITY,
            (DepthConvention::ZeroToOne, 0) => 1.0,
            (DepthConvention::ReversedZ, 0) => 0.0,
            (DepthConvention::Linear, _) => z,
            // Post-projection values in (0, 1): what an oblique projection
            // writes for these depths is not needed for bit equality.
            (_, _) => 1.0 / z,
        };
        color[k] = [i as f32 / rw as f32, j as f32 / rh as f32, (k % 7) as f32];
    }
    (depth, color)
}

fn setup_c(
    g: &refl_gbuffer,
    m: &refl_planar_mirror,
    o: &refl_planar_options,
) -> (refl_status, refl_planar_setup, u64) {
    let mut s = core::mem::MaybeUninit::<refl_planar_setup>::zeroed();
    // SAFETY: valid pointers.
    let (st, a) = counted(|| unsafe { refl_planar_prepare(s.as_mut_ptr(), g, m, o) });
    // SAFETY: zero-initialized plain data (bools false).
    (st, unsafe { s.assume_init() }, a)
}

fn opts_c(o: PlanarOptions) -> refl_planar_options {
    refl_planar_options {
        scale: o.scale,
        oblique: o.oblique,
        plane_tolerance: o.plane_tolerance,
        normal_cos: o.normal_cos,
        edge_threshold: o.edge_threshold,
    }
}

fn bits_m(m: refl_mat4) -> [u32; 16] {
    m.m.map(f32::to_bits)
}

#[test]
fn the_allocation_counter_counts() {
    let (v, n) = counted(|| Vec::<u8>::with_capacity(3));
    assert_eq!((v.capacity() >= 3, n), (true, 1));
}

#[test]
fn defaults_are_refl_cores() {
    let d = refl_planar_options_default();
    assert_eq!(d, opts_c(PlanarOptions::default()));
}

/// Runs `check(conv, f, g, m, oc, pass)` on the scene in every convention
/// at full resolution with ids and an oblique projection, at half
/// resolution without ids and at a quarter without the oblique projection:
/// `g`, `m` and `oc` the C descriptors of the Rust `pass`.
fn for_each_pass_case(
    mut check: impl FnMut(
        DepthConvention,
        &refl_gbuffer,
        &refl_planar_mirror,
        &refl_planar_options,
        &PlanarPass<'_>,
    ),
) {
    for conv in CONVENTIONS {
        let f = render(conv);
        let g = f.planar_gbuffer_c();
        for (scale, oblique, with_ids) in [(1, true, true), (2, true, false), (4, false, true)] {
            let o = PlanarOptions {
                scale,
                oblique,
                ..PlanarOptions::default()
            };
            let oc = opts_c(o);
            let m = f.mirror_c(with_ids);
            let pass = f.pass(o, with_ids);
            check(conv, &g, &m, &oc, &pass);
        }
    }
}

#[test]
fn c_prepare_equals_the_rust_pass_bit_for_bit_without_allocating() {
    for_each_pass_case(|_, g, m, oc, pass| {
        let (st, s, a) = setup_c(g, m, oc);
        assert_eq!((st, a), (refl_status::Ok, 0));
        let r = pass.prepare();
        assert_eq!(s.camera, refl_camera::from(&r.camera));
        assert_eq!(bits_m(s.projection), bits_m(r.projection.into()));
        assert_eq!(s.clip_plane, refl_plane::from(&r.clip_plane));
        assert_eq!(
            [
                s.view_clip_plane.x,
                s.view_clip_plane.y,
                s.view_clip_plane.z,
                s.view_clip_plane.w
            ]
            .map(f32::to_bits),
            r.view_clip_plane.to_array().map(f32::to_bits)
        );
        assert_eq!(
            (s.flip_winding, s.covered, s.covered_pixels),
            (r.flip_winding, r.covered, r.covered_pixels)
        );
        assert_eq!(
            (s.rect.x0, s.rect.y0, s.rect.x1, s.rect.y1),
            (r.rect.x0, r.rect.y0, r.rect.x1, r.rect.y1)
        );
        assert_eq!(
            (s.scissor.x0, s.scissor.y0, s.scissor.x1, s.scissor.y1),
            (r.scissor.x0, r.scissor.y0, r.scissor.x1, r.scissor.y1)
        );
        assert!(s.covered && s.covered_pixels > 1000);
    });
}

#[test]
fn c_cover_equals_the_rust_pass_without_allocating_with_or_without_output() {
    for_each_pass_case(|_, g, m, oc, pass| {
        let all = refl_row_range { begin: 0, end: H };
        let mut bytes = vec![0xEEu8; N];
        let mut cs = refl_planar_stats::default();
        // SAFETY: valid buffers.
        let (st, a) = counted(|| unsafe {
            refl_planar_cover_rows(&mut cs, bytes.as_mut_ptr(), N, g, m, oc, all)
        });
        assert_eq!((st, a), (refl_status::Ok, 0));
        let mut rs = vec![PlanarStatus::Environment; N];
        let rst = pass
            .try_cover(&mut ImageViewMut::try_new(&mut rs, W, H, W).unwrap())
            .unwrap();
        assert!(bytes.iter().zip(&rs).all(|(b, s)| *b == *s as u8));
        assert_eq!(cs, refl_planar_stats::from(rst));
        // Counts alone (no output).
        let mut cs2 = refl_planar_stats::default();
        // SAFETY: valid pointers.
        let st =
            unsafe { refl_planar_cover_rows(&mut cs2, core::ptr::null_mut(), 0, g, m, oc, all) };
        assert_eq!((st, cs2), (refl_status::Ok, cs));
    });
}

#[test]
fn c_resolve_equals_the_rust_pass_bit_for_bit_without_allocating() {
    for_each_pass_case(|conv, g, m, oc, pass| {
        let all = refl_row_range { begin: 0, end: H };
        let (rw, rh) = pass.render_size();
        let (depth, color) = fake_render(conv, rw, rh);
        let render_c = refl_planar_render {
            depth: img_f32(&depth, rw, rh),
            color: img_vec3(&color, rw, rh),
        };
        let mut texels = vec![refl_planar_texel::default(); N];
        let mut col = vec![[7.0f32; 3]; N];
        let mut host = vec![refl_host_ray::default(); N];
        let mut ss = refl_planar_stats::default();
        let cm = color_mut(&mut col);
        // SAFETY: valid buffers.
        let (st, a) = counted(|| unsafe {
            refl_planar_resolve_rows(
                &mut ss,
                texels.as_mut_ptr(),
                N,
                cm,
                host.as_mut_ptr(),
                N,
                g,
                m,
                oc,
                &render_c,
                all,
            )
        });
        assert_eq!((st, a), (refl_status::Ok, 0));
        let rv = PlanarRender::try_new(
            ImageView::try_new(&depth, rw, rh, rw).unwrap(),
            Some(ImageView::try_new(&color, rw, rh, rw).unwrap()),
        )
        .unwrap();
        let mut rt = vec![PlanarTexel::default(); N];
        let mut rc = vec![[0.0f32; 3]; N];
        let mut rh_ = vec![PlanarRay::default(); N];
        let rst = pass
            .try_resolve(
                &mut ImageViewMut::try_new(&mut rt, W, H, W).unwrap(),
                Some(&mut ImageViewMut::try_new(&mut rc, W, H, W).unwrap()),
                &mut rh_,
                &rv,
            )
            .unwrap();
        assert_eq!(ss, refl_planar_stats::from(rst));
        assert!(rst.hits > 500 && rst.environment > 10, "{rst:?}");
        for i in 0..N {
            let (a, b) = (texels[i], rt[i]);
            assert_eq!(a.status, b.status as u32);
            assert_eq!(
                [a.pixel.x, a.pixel.y, a.t].map(f32::to_bits),
                [b.pixel.x, b.pixel.y, b.t].map(f32::to_bits)
            );
            assert_eq!([a.texel_x, a.texel_y], b.texel);
            assert_eq!(col[i].map(f32::to_bits), rc[i].map(f32::to_bits));
        }
        for k in 0..rst.host_rays_written as usize {
            let (a, b) = (host[k], rh_[k]);
            assert_eq!((a.x, a.y), (b.x, b.y));
            assert_eq!(a.status, refl_planar_status::Environment as u32);
            assert_eq!((a.t_min, a.t_max), (0.0, f32::INFINITY));
            assert_eq!(
                [a.origin.x, a.origin.y, a.origin.z, a.dir.x, a.dir.y, a.dir.z].map(f32::to_bits),
                [b.origin.x, b.origin.y, b.origin.z, b.dir.x, b.dir.y, b.dir.z].map(f32::to_bits)
            );
        }
    });
}

/// The C descriptors of the row-band tests: the ReversedZ scene with ids
/// at half resolution, and a render of that size.
struct BandInputs {
    g: refl_gbuffer,
    m: refl_planar_mirror,
    oc: refl_planar_options,
    render_c: refl_planar_render,
    // The buffers the descriptors point into.
    _f: Frame,
    _render: (Vec<f32>, Vec<[f32; 3]>),
}

fn band_inputs() -> BandInputs {
    let f = render(DepthConvention::ReversedZ);
    let g = f.planar_gbuffer_c();
    let m = f.mirror_c(true);
    let oc = opts_c(PlanarOptions {
        scale: 2,
        ..PlanarOptions::default()
    });
    let (rw, rh) = f
        .pass(
            PlanarOptions {
                scale: 2,
                ..PlanarOptions::default()
            },
            true,
        )
        .render_size();
    let (depth, color) = fake_render(DepthConvention::ReversedZ, rw, rh);
    let render_c = refl_planar_render {
        depth: img_f32(&depth, rw, rh),
        color: img_vec3(&color, rw, rh),
    };
    BandInputs {
        g,
        m,
        oc,
        render_c,
        _f: f,
        _render: (depth, color),
    }
}

/// Resolves and covers the image in `bands` row bands, one thread each,
/// all writing into `texels`, `col` and `bytes`; returns each band's host
/// rays and coverage rectangle, in band order.
fn resolve_and_cover_in_bands(
    inputs: &BandInputs,
    texels: &mut [refl_planar_texel],
    col: &mut [[f32; 3]],
    bytes: &mut [u8],
    bands: u32,
) -> Vec<(Vec<refl_host_ray>, refl_planar_rect)> {
    let tp = texels.as_mut_ptr() as usize;
    let bp = bytes.as_mut_ptr() as usize;
    let cm = color_mut(col);
    let shared = Shared((inputs.g, inputs.m, inputs.oc, inputs.render_c, cm));
    std::thread::scope(|s| {
        let hs: Vec<_> = (0..bands)
            .map(|b| {
                let shared = &shared;
                s.spawn(move || {
                    let (g, m, oc, r, cm) = shared.0;
                    let mut rows = refl_row_range::default();
                    // SAFETY: valid pointer.
                    assert_eq!(
                        unsafe { refl_image_row_band(&mut rows, H, b, bands) },
                        refl_status::Ok
                    );
                    let mut host = vec![refl_host_ray::default(); N];
                    let mut st = refl_planar_stats::default();
                    let mut cst = refl_planar_stats::default();
                    // SAFETY: each thread writes only its own rows.
                    unsafe {
                        assert_eq!(
                            refl_planar_resolve_rows(
                                &mut st,
                                tp as *mut refl_planar_texel,
                                N,
                                cm,
                                host.as_mut_ptr(),
                                N,
                                &g,
                                &m,
                                &oc,
                                &r,
                                rows
                            ),
                            refl_status::Ok
                        );
                        assert_eq!(
                            refl_planar_cover_rows(&mut cst, bp as *mut u8, N, &g, &m, &oc, rows),
                            refl_status::Ok
                        );
                    }
                    host.truncate(st.host_rays_written as usize);
                    (host, cst.rect)
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

#[test]
fn row_bands_from_threads_equal_the_whole_image() {
    let inputs = band_inputs();
    let mut t1 = vec![refl_planar_texel::default(); N];
    let mut c1 = vec![[0.0f32; 3]; N];
    let mut b1 = vec![0u8; N];
    let whole = resolve_and_cover_in_bands(&inputs, &mut t1, &mut c1, &mut b1, 1);
    let mut t5 = vec![refl_planar_texel::default(); N];
    let mut c5 = vec![[0.0f32; 3]; N];
    let mut b5 = vec![0u8; N];
    let bands = resolve_and_cover_in_bands(&inputs, &mut t5, &mut c5, &mut b5, 5);
    assert_eq!(t1, t5);
    assert_eq!(c1, c5);
    assert_eq!(b1, b5);
    let hosts: Vec<refl_host_ray> = bands.iter().flat_map(|b| b.0.clone()).collect();
    assert_eq!(hosts, whole[0].0);
}

#[test]
fn row_bands_coverage_rectangles_merge_to_the_setups() {
    let inputs = band_inputs();
    let mut t5 = vec![refl_planar_texel::default(); N];
    let mut c5 = vec![[0.0f32; 3]; N];
    let mut b5 = vec![0u8; N];
    let bands = resolve_and_cover_in_bands(&inputs, &mut t5, &mut c5, &mut b5, 5);
    let (_, s, _) = setup_c(&inputs.g, &inputs.m, &inputs.oc);
    let merged = bands
        .iter()
        .map(|b| b.1)
        .fold(refl_planar_rect::default(), |a, r| {
            if a == refl_planar_rect::default() {
                r
            } else if r == refl_planar_rect::default() {
                a
            } else {
                refl_planar_rect {
                    x0: a.x0.min(r.x0),
                    y0: a.y0.min(r.y0),
                    x1: a.x1.max(r.x1),
                    y1: a.y1.max(r.y1),
                }
            }
        });
    assert_eq!(merged, s.rect);
}

/// Calls `refl_planar_resolve_rows` with every output filled with
/// sentinels and checks the status and that nothing was written.
#[allow(clippy::too_many_arguments)]
fn refused(
    want: refl_status,
    g: &refl_gbuffer,
    m: &refl_planar_mirror,
    o: &refl_planar_options,
    r: &refl_planar_render,
    rows: refl_row_range,
    out_len: usize,
    with_color: bool,
) {
    let sentinel = refl_planar_texel {
        status: 99,
        t: -3.0,
        ..Default::default()
    };
    let mut texels = vec![sentinel; N];
    let mut color = vec![[5.0f32; 3]; N];
    let mut host = vec![
        refl_host_ray {
            x: 77,
            ..Default::default()
        };
        8
    ];
    let mut st = refl_planar_stats {
        covered: 55,
        ..Default::default()
    };
    let cm = if with_color {
        color_mut(&mut color)
    } else {
        no_color()
    };
    let (s, allocs) = counted(|| {
        // SAFETY: valid buffers (out_len <= N).
        unsafe {
            refl_planar_resolve_rows(
                &mut st,
                texels.as_mut_ptr(),
                out_len,
                cm,
                host.as_mut_ptr(),
                host.len(),
                g,
                m,
                o,
                r,
                rows,
            )
        }
    });
    assert_eq!(s, want);
    assert_eq!(allocs, 0, "allocations on the error path");
    assert!(texels.iter().all(|t| *t == sentinel));
    assert!(color.iter().all(|c| *c == [5.0; 3]));
    assert!(host.iter().all(|h| h.x == 77));
    assert_eq!(st.covered, 55);
    // The setup and the coverage refuse the same inputs (rows and sizes of
    // the resolve's own buffers aside) without writing either.
    if out_len == N && rows.end <= H && rows.begin <= rows.end && !with_color {
        let mut bytes = vec![0xEEu8; N];
        let mut cs = refl_planar_stats {
            covered: 55,
            ..Default::default()
        };
        // SAFETY: valid buffers.
        let s2 = unsafe { refl_planar_cover_rows(&mut cs, bytes.as_mut_ptr(), N, g, m, o, rows) };
        if s2 != refl_status::Ok {
            assert_eq!(s2, want);
            assert!(bytes.iter().all(|b| *b == 0xEE) && cs.covered == 55);
            let mut setup = core::mem::MaybeUninit::<refl_planar_setup>::zeroed();
            // SAFETY: valid pointers.
            assert_eq!(
                unsafe { refl_planar_prepare(setup.as_mut_ptr(), g, m, o) },
                want
            );
            // SAFETY: zeroed plain data.
            let s = unsafe { setup.assume_init() };
            assert!(!s.covered && s.covered_pixels == 0);
        }
    }
}

/// The inputs of the error tests: the ZeroToOne scene with ids and a
/// full-size render.
struct ErrorInputs {
    f: Frame,
    depth: Vec<f32>,
    color: Vec<[f32; 3]>,
}

impl ErrorInputs {
    fn new() -> Self {
        let f = render(DepthConvention::ZeroToOne);
        let (depth, color) = fake_render(DepthConvention::ZeroToOne, W, H);
        ErrorInputs { f, depth, color }
    }

    /// The G-buffer, the mirror, the default options and the render.
    fn c(
        &self,
    ) -> (
        refl_gbuffer,
        refl_planar_mirror,
        refl_planar_options,
        refl_planar_render,
    ) {
        let r = refl_planar_render {
            depth: img_f32(&self.depth, W, H),
            color: img_vec3(&self.color, W, H),
        };
        (
            self.f.planar_gbuffer_c(),
            self.f.mirror_c(true),
            refl_planar_options_default(),
            r,
        )
    }
}

const ALL: refl_row_range = refl_row_range { begin: 0, end: H };
const INV: refl_status = refl_status::InvalidArgument;

#[test]
fn options_out_of_range_are_refused_untouched() {
    let e = ErrorInputs::new();
    let (g, m, d, r) = e.c();
    for o in [
        refl_planar_options { scale: 0, ..d },
        refl_planar_options {
            plane_tolerance: f32::NAN,
            ..d
        },
        refl_planar_options {
            plane_tolerance: -1.0,
            ..d
        },
        refl_planar_options {
            normal_cos: 2.0,
            ..d
        },
        refl_planar_options {
            edge_threshold: f32::NAN,
            ..d
        },
    ] {
        refused(INV, &g, &m, &o, &r, ALL, N, false);
    }
}

#[test]
fn a_bad_plane_or_ids_are_refused_untouched() {
    let e = ErrorInputs::new();
    let (g, m, d, r) = e.c();
    // The plane: non-finite, zero normal.
    let mut m2 = m;
    m2.plane.d = f32::INFINITY;
    refused(INV, &g, &m2, &d, &r, ALL, N, false);
    m2 = m;
    m2.plane.normal = refl_vec3 {
        x: 0.0,
        y: 0.0,
        z: 0.0,
    };
    refused(
        refl_status::DegenerateGeometry,
        &g,
        &m2,
        &d,
        &r,
        ALL,
        N,
        false,
    );
    // Ids of another size, a short one.
    m2 = m;
    m2.ids.width = W - 1;
    m2.ids.stride = W - 1;
    refused(INV, &g, &m2, &d, &r, ALL, N, false);
    m2 = m;
    m2.ids.len = N - 1;
    refused(
        refl_status::InsufficientSize,
        &g,
        &m2,
        &d,
        &r,
        ALL,
        N,
        false,
    );
}

#[test]
fn bad_gbuffer_fields_are_refused_untouched() {
    let e = ErrorInputs::new();
    let (g, m, d, r) = e.c();
    let mut g2 = g;
    g2.normal_space = 5;
    refused(INV, &g2, &m, &d, &r, ALL, N, false);
    g2 = g;
    g2.depth.convention = 9;
    refused(INV, &g2, &m, &d, &r, ALL, N, false);
    g2 = g;
    g2.depth.depth.data = core::ptr::null();
    refused(refl_status::NullPointer, &g2, &m, &d, &r, ALL, N, false);
}

#[test]
fn bad_rows_sizes_and_renders_are_refused_untouched() {
    let e = ErrorInputs::new();
    let (g, m, d, r) = e.c();
    let (depth, color) = (&e.depth, &e.color);
    refused(
        INV,
        &g,
        &m,
        &d,
        &r,
        refl_row_range { begin: 3, end: 2 },
        N,
        false,
    );
    refused(
        INV,
        &g,
        &m,
        &d,
        &r,
        refl_row_range {
            begin: 0,
            end: H + 1,
        },
        N,
        false,
    );
    refused(
        refl_status::InsufficientSize,
        &g,
        &m,
        &d,
        &r,
        ALL,
        N - 1,
        false,
    );
    let small = refl_planar_render {
        depth: img_f32(&depth[..N / 4], W / 2, H / 2),
        color: NO_VEC3,
    };
    refused(INV, &g, &m, &d, &small, ALL, N, false);
    let nocolor = refl_planar_render {
        depth: img_f32(depth, W, H),
        color: NO_VEC3,
    };
    refused(INV, &g, &m, &d, &nocolor, ALL, N, true);
    let badcolor = refl_planar_render {
        depth: img_f32(depth, W, H),
        color: img_vec3(&color[..N / 4], W / 2, H / 2),
    };
    refused(INV, &g, &m, &d, &badcolor, ALL, N, false);
    let nodepth = refl_planar_render {
        depth: none_f32(),
        color: NO_VEC3,
    };
    refused(
        refl_status::NullPointer,
        &g,
        &m,
        &d,
        &nodepth,
        ALL,
        N,
        false,
    );
}

#[test]
fn the_last_error_names_the_call_and_the_argument() {
    let e = ErrorInputs::new();
    let (g, m, d, _) = e.c();
    let small = refl_planar_render {
        depth: img_f32(&e.depth[..N / 4], W / 2, H / 2),
        color: NO_VEC3,
    };
    let mut st = refl_planar_stats::default();
    let mut texels = vec![refl_planar_texel::default(); N];
    // SAFETY: valid buffers; refused (the render's size).
    let s = unsafe {
        refl_planar_resolve_rows(
            &mut st,
            texels.as_mut_ptr(),
            N,
            no_color(),
            core::ptr::null_mut(),
            0,
            &g,
            &m,
            &d,
            &small,
            ALL,
        )
    };
    assert_eq!(s, INV);
    let mut buf = [0u8; 256];
    // SAFETY: valid buffer.
    let k = unsafe { refl_last_error_message(buf.as_mut_ptr().cast(), buf.len()) };
    let msg = String::from_utf8_lossy(&buf[..k.min(255)]).to_string();
    assert!(
        msg.contains("refl_planar_resolve_rows") && msg.contains("render.depth"),
        "{msg}"
    );
}

#[test]
fn null_inputs_and_outputs_and_misaligned_texels_are_refused() {
    let e = ErrorInputs::new();
    let (g, m, d, r) = e.c();
    let mut st = refl_planar_stats::default();
    let mut texels = vec![refl_planar_texel::default(); N];
    // SAFETY: NULL pointers are refused before use.
    unsafe {
        let call = |st: *mut refl_planar_stats,
                    out: *mut refl_planar_texel,
                    g: *const refl_gbuffer,
                    m: *const refl_planar_mirror,
                    o: *const refl_planar_options,
                    r: *const refl_planar_render| {
            refl_planar_resolve_rows(
                st,
                out,
                N,
                no_color(),
                core::ptr::null_mut(),
                0,
                g,
                m,
                o,
                r,
                ALL,
            )
        };
        let tp = texels.as_mut_ptr();
        let null = refl_status::NullPointer;
        assert_eq!(call(core::ptr::null_mut(), tp, &g, &m, &d, &r), null);
        assert_eq!(call(&mut st, core::ptr::null_mut(), &g, &m, &d, &r), null);
        assert_eq!(call(&mut st, tp, core::ptr::null(), &m, &d, &r), null);
        assert_eq!(call(&mut st, tp, &g, core::ptr::null(), &d, &r), null);
        assert_eq!(call(&mut st, tp, &g, &m, core::ptr::null(), &r), null);
        assert_eq!(call(&mut st, tp, &g, &m, &d, core::ptr::null()), null);
        // A host list pointer NULL with a length.
        assert_eq!(
            refl_planar_resolve_rows(
                &mut st,
                tp,
                N,
                no_color(),
                core::ptr::null_mut(),
                4,
                &g,
                &m,
                &d,
                &r,
                ALL
            ),
            null
        );
        // Misaligned texels.
        let mis = (tp as *mut u8).add(1).cast::<refl_planar_texel>();
        assert_eq!(call(&mut st, mis, &g, &m, &d, &r), INV);
        let mut s = core::mem::MaybeUninit::<refl_planar_setup>::uninit();
        assert_eq!(refl_planar_prepare(core::ptr::null_mut(), &g, &m, &d), null);
        assert_eq!(
            refl_planar_prepare(s.as_mut_ptr(), core::ptr::null(), &m, &d),
            null
        );
        assert_eq!(
            refl_planar_prepare(s.as_mut_ptr(), &g, core::ptr::null(), &d),
            null
        );
        assert_eq!(
            refl_planar_prepare(s.as_mut_ptr(), &g, &m, core::ptr::null()),
            null
        );
        assert_eq!(
            refl_planar_cover_rows(
                core::ptr::null_mut(),
                core::ptr::null_mut(),
                0,
                &g,
                &m,
                &d,
                ALL
            ),
            null
        );
        assert_eq!(
            refl_planar_cover_rows(&mut st, core::ptr::null_mut(), N, &g, &m, &d, ALL),
            null
        );
    }
}

/// Aliasing: texels over the normals they read, the setup over the normals
/// it reads, a cover output over the ids.
#[test]
fn outputs_over_the_inputs_they_read_are_refused_untouched() {
    let e = ErrorInputs::new();
    let (g, m, d, r) = e.c();
    let f = &e.f;
    let mut st = refl_planar_stats::default();
    let mut big = vec![[0.0f32, 1.0, 0.0]; 4 * N];
    let mut g3 = g;
    g3.normals = img_vec3(&big[..N], W, H);
    // SAFETY: valid (overlapping) pointers; refused before any write.
    let s = unsafe {
        refl_planar_resolve_rows(
            &mut st,
            big.as_mut_ptr().cast(),
            N,
            no_color(),
            core::ptr::null_mut(),
            0,
            &g3,
            &m,
            &d,
            &r,
            ALL,
        )
    };
    assert_eq!(s, INV);
    assert!(big.iter().all(|v| *v == [0.0, 1.0, 0.0]));
    // The setup over the normals it reads.
    let mut big2 = vec![[0.0f32, 1.0, 0.0]; 4 * N];
    let mut g5 = g;
    g5.normals = img_vec3(&big2[..N], W, H);
    // SAFETY: valid (overlapping) pointers; refused before any write.
    let s = unsafe { refl_planar_prepare(big2.as_mut_ptr().cast(), &g5, &m, &d) };
    assert_eq!(s, INV);
    assert!(big2.iter().all(|v| *v == [0.0, 1.0, 0.0]));
    let mut ids = f.ids.clone();
    let mut m4 = m;
    m4.ids.data = ids.as_ptr();
    // SAFETY: valid (overlapping) pointers; refused before any write.
    let s =
        unsafe { refl_planar_cover_rows(&mut st, ids.as_mut_ptr().cast(), N, &g, &m4, &d, ALL) };
    assert_eq!(s, INV);
    assert_eq!(ids, f.ids);
}

// ------------------------------------------------------ back-face exports

/// A one-layer map of the unit sphere at `(0, 1, 0)`.
struct Map {
    grid: LayeredGrid,
    depth: Vec<f32>,
    payload: Vec<u32>,
    counts: Vec<u32>,
    bounds: Vec<f32>,
}

fn sphere_map() -> Map {
    let grid = LayeredGrid::try_new(
        Vec3::new(-1.05, -0.05, -1.05),
        Vec3::new(1.05, 2.05, 1.05),
        48,
        1,
    )
    .unwrap();
    let l = try_layered_len(48, 1).unwrap();
    let mut m = Map {
        grid,
        depth: vec![0.0; l.depth],
        payload: vec![0; l.payload],
        counts: vec![0; l.counts],
        bounds: vec![0.0; l.bounds],
    };
    let mut mm = LayeredMapMut::try_new(
        grid,
        &mut m.depth,
        &mut m.payload,
        &mut m.counts,
        &mut m.bounds,
    )
    .unwrap();
    mm.clear();
    for face in [Face::NegX, Face::NegY, Face::NegZ] {
        for j in 0..48 {
            for i in 0..48 {
                let r = grid.try_face_ray(face, i, j).unwrap();
                let (o, d) = (
                    r.origin.as_dvec3() - refl_core::glam::DVec3::Y,
                    r.dir.as_dvec3(),
                );
                let b = o.dot(d);
                let disc = b * b - (o.dot(o) - 1.0);
                let mut hits = Vec::new();
                if disc > 0.0 {
                    for (t, front) in [(-b - disc.sqrt(), true), (-b + disc.sqrt(), false)] {
                        if t >= 0.0 && t <= f64::from(r.t_max) {
                            hits.push(LayerHit {
                                t: t as f32,
                                id: 1,
                                front,
                            });
                        }
                    }
                }
                mm.try_fill_column(face, i, j, &mut hits).unwrap();
            }
        }
    }
    mm.build_bounds();
    m
}

impl Map {
    fn c(&self) -> refl_layered_map {
        let mn = self.grid.min();
        let mx = self.grid.max();
        refl_layered_map {
            grid: refl_layered_grid {
                min: mn.into(),
                max: mx.into(),
                face_res: 48,
                layers: 1,
                world_from_local: refl_core::glam::Mat4::IDENTITY.into(),
            },
            depth: self.depth.as_ptr(),
            depth_len: self.depth.len(),
            payload: self.payload.as_ptr(),
            payload_len: self.payload.len(),
            counts: self.counts.as_ptr(),
            counts_len: self.counts.len(),
            bounds: self.bounds.as_ptr(),
            bounds_len: self.bounds.len(),
        }
    }
}

fn f32_mut(d: &mut [f32]) -> refl_image_f32_mut {
    refl_image_f32_mut {
        data: d.as_mut_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

/// The second pass through the C ABI and refl-core on the scene `f`:
/// the C call's destination and stats (checked to succeed without
/// allocating), refl-core's destination and stats.
fn back_depth_both(
    f: &Frame,
) -> (
    Vec<f32>,
    refl_trace_back_depth_stats,
    Vec<f32>,
    refl_core::BackDepthStats,
) {
    let front_c = f.depth_c();
    let all = refl_row_range { begin: 0, end: H };
    let mut c_dst = vec![-1.0f32; N];
    let mut st = refl_trace_back_depth_stats::default();
    let dm = f32_mut(&mut c_dst);
    // SAFETY: valid buffers.
    let (s, a) = counted(|| unsafe {
        refl_trace_back_depth_rows(&mut st, dm, &front_c, img_f32(&f.back, W, H), all)
    });
    assert_eq!((s, a), (refl_status::Ok, 0));
    let mut r_dst = vec![-1.0f32; N];
    let rs = try_back_depth(
        &mut ImageViewMut::try_new(&mut r_dst, W, H, W).unwrap(),
        &f.front(),
        &ImageView::try_new(&f.back, W, H, W).unwrap(),
    )
    .unwrap();
    (c_dst, st, r_dst, rs)
}

#[test]
fn back_depth_rows_equals_refl_core_bit_for_bit_without_allocating() {
    for conv in CONVENTIONS {
        let f = render(conv);
        let (c_dst, st, r_dst, rs) = back_depth_both(&f);
        assert_eq!(st, refl_trace_back_depth_stats::from(rs));
        assert!(c_dst
            .iter()
            .zip(&r_dst)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(rs.clamped > 100 && rs.cleared > 1000, "{rs:?}");
    }
}

#[test]
fn back_depth_layered_rows_from_threads_equal_refl_core_bit_for_bit_without_allocating() {
    let map = sphere_map();
    let mc = map.c();
    for conv in CONVENTIONS {
        let f = render(conv);
        let front_c = f.depth_c();
        // On top of the second pass, per band from threads.
        let (mut c_dst, _, mut r_dst, _) = back_depth_both(&f);
        let tp = c_dst.as_mut_ptr() as usize;
        let shared = Shared((front_c, mc));
        let sums: Vec<u32> = std::thread::scope(|sc| {
            let hs: Vec<_> = (0..3u32)
                .map(|b| {
                    let shared = &shared;
                    sc.spawn(move || {
                        let (front_c, mc) = shared.0;
                        let mut rows = refl_row_range::default();
                        // SAFETY: valid pointer.
                        assert_eq!(
                            unsafe { refl_image_row_band(&mut rows, H, b, 3) },
                            refl_status::Ok
                        );
                        let dm = refl_image_f32_mut {
                            data: tp as *mut f32,
                            len: N,
                            width: W,
                            height: H,
                            stride: W,
                        };
                        let mut st = refl_trace_back_depth_stats::default();
                        // SAFETY: each thread writes its own rows.
                        let (s, a) = counted(|| unsafe {
                            refl_trace_back_depth_layered_rows(&mut st, dm, &front_c, &mc, rows)
                        });
                        assert_eq!((s, a), (refl_status::Ok, 0));
                        st.exits
                    })
                })
                .collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let rl = try_back_depth_layered(
            &mut ImageViewMut::try_new(&mut r_dst, W, H, W).unwrap(),
            &f.front(),
            &refl_core::LayeredMap::try_new(
                map.grid,
                &map.depth,
                &map.payload,
                &map.counts,
                &map.bounds,
            )
            .unwrap(),
        )
        .unwrap();
        assert_eq!(sums.iter().sum::<u32>(), rl.exits);
        assert!(rl.exits > 200, "{rl:?}");
        assert!(c_dst
            .iter()
            .zip(&r_dst)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}

/// Calls `call(dst, stats)` with a destination of -1 and stats with 55
/// surfaces, expects status `want`, no allocation and both untouched.
fn back_depth_refused(
    want: refl_status,
    call: &dyn Fn(refl_image_f32_mut, *mut refl_trace_back_depth_stats) -> refl_status,
) {
    let mut dst = vec![-1.0f32; N];
    let mut st = refl_trace_back_depth_stats {
        surfaces: 55,
        ..Default::default()
    };
    let (s, a) = counted(|| call(f32_mut(&mut dst), &mut st));
    assert_eq!((s, a), (want, 0));
    assert!(dst.iter().all(|v| *v == -1.0));
    assert_eq!(st.surfaces, 55);
}

#[test]
fn back_depth_rows_errors_leave_dst_untouched() {
    let f = render(DepthConvention::ReversedZ);
    let front_c = f.depth_c();
    let all = refl_row_range { begin: 0, end: H };
    let check = back_depth_refused;
    let back = img_f32(&f.back, W, H);
    let inv = refl_status::InvalidArgument;
    // SAFETY (all closures): valid or deliberately bad descriptors, refused
    // before any write.
    check(inv, &|d, s| unsafe {
        refl_trace_back_depth_rows(
            s,
            d,
            &front_c,
            img_f32(&f.back[..N - W as usize], W, H - 1),
            all,
        )
    });
    check(inv, &|d, s| unsafe {
        refl_trace_back_depth_rows(s, d, &front_c, back, refl_row_range { begin: 2, end: 1 })
    });
    check(inv, &|mut d, s| unsafe {
        d.width = W - 1;
        refl_trace_back_depth_rows(s, d, &front_c, back, all)
    });
    check(refl_status::NullPointer, &|d, _| unsafe {
        refl_trace_back_depth_rows(core::ptr::null_mut(), d, &front_c, back, all)
    });
    check(refl_status::NullPointer, &|d, s| unsafe {
        refl_trace_back_depth_rows(s, d, core::ptr::null(), back, all)
    });
    check(refl_status::NullPointer, &|d, s| unsafe {
        refl_trace_back_depth_rows(s, d, &front_c, none_f32(), all)
    });
    check(refl_status::InsufficientSize, &|mut d, s| unsafe {
        d.len = N - 1;
        refl_trace_back_depth_rows(s, d, &front_c, back, all)
    });
    let mut bad = front_c;
    bad.convention = 3;
    check(inv, &|d, s| unsafe {
        refl_trace_back_depth_rows(s, d, &bad, back, all)
    });
}

#[test]
fn back_depth_layered_rows_errors_leave_dst_untouched() {
    let f = render(DepthConvention::ReversedZ);
    let map = sphere_map();
    let mc = map.c();
    let front_c = f.depth_c();
    let all = refl_row_range { begin: 0, end: H };
    let check = back_depth_refused;
    let inv = refl_status::InvalidArgument;
    // SAFETY (all closures): valid or deliberately bad descriptors, refused
    // before any write.
    check(refl_status::NullPointer, &|d, s| unsafe {
        refl_trace_back_depth_layered_rows(s, d, &front_c, core::ptr::null(), all)
    });
    let mut m2 = mc;
    m2.counts_len -= 1;
    check(refl_status::InsufficientSize, &|d, s| unsafe {
        refl_trace_back_depth_layered_rows(s, d, &front_c, &m2, all)
    });
    check(inv, &|d, s| unsafe {
        refl_trace_back_depth_layered_rows(
            s,
            d,
            &front_c,
            &mc,
            refl_row_range {
                begin: 0,
                end: H + 1,
            },
        )
    });
}

/// dst over the front it reads, over a map buffer.
#[test]
fn back_depth_dst_over_its_inputs_is_refused() {
    let f = render(DepthConvention::ReversedZ);
    let map = sphere_map();
    let mc = map.c();
    let front_c = f.depth_c();
    let all = refl_row_range { begin: 0, end: H };
    let back = img_f32(&f.back, W, H);
    let inv = refl_status::InvalidArgument;
    let mut alias = f.depth.clone();
    let mut fa = front_c;
    fa.depth.data = alias.as_ptr();
    // SAFETY: overlapping pointers, refused before any write.
    let s = unsafe {
        let mut st = refl_trace_back_depth_stats::default();
        refl_trace_back_depth_rows(&mut st, f32_mut(&mut alias), &fa, back, all)
    };
    assert_eq!(s, inv);
    assert_eq!(
        alias.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        f.depth.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    let mut depth_buf = map.depth.clone();
    depth_buf.resize(depth_buf.len().max(N), 0.0);
    let mut m3 = mc;
    m3.depth = depth_buf.as_ptr();
    // SAFETY: overlapping pointers, refused before any write.
    let s = unsafe {
        let mut st = refl_trace_back_depth_stats::default();
        let d = refl_image_f32_mut {
            data: depth_buf.as_mut_ptr(),
            len: N,
            width: W,
            height: H,
            stride: W,
        };
        refl_trace_back_depth_layered_rows(&mut st, d, &front_c, &m3, all)
    };
    assert_eq!(s, inv);
}
