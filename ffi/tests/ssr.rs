//! refl_ssr_*: the C pass equals refl-core's `MirrorPass` bit for bit (both
//! methods, every convention, whole image and row bands from threads),
//! error paths return their documented status and leave every output
//! untouched, and no export allocates (a counting global allocator).

use refl::*;
use refl_core::glam::Vec3;
use refl_core::{
    hiz_len, try_build_hiz, Camera, DepthConvention, DepthImage, GBuffer, HiZ, HiZTexel, HostRay,
    ImageView, ImageViewMut, MirrorMethod, MirrorOptions, MirrorPass, MirrorTexel, NormalSpace,
};
mod common;
use common::{conv_c, counted, render, Frame, H, W};

fn img_f32(d: &[f32]) -> refl_image_f32 {
    refl_image_f32 {
        data: d.as_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

fn img_vec3(d: &[[f32; 3]]) -> refl_image_vec3 {
    refl_image_vec3 {
        data: d.as_ptr().cast(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

fn none_f32() -> refl_image_f32 {
    refl_image_f32 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

impl Frame {
    fn gbuffer_c(&self, back: bool) -> refl_gbuffer {
        refl_gbuffer {
            depth: refl_depth_image {
                depth: img_f32(&self.depth),
                camera: (&self.cam).into(),
                convention: conv_c(self.conv),
            },
            normals: img_vec3(&self.normals),
            normal_space: refl_normal_space::World as u32,
            mask: refl_image_u8 {
                data: core::ptr::null(),
                len: 0,
                width: 0,
                height: 0,
                stride: 0,
            },
            roughness: none_f32(),
            color: img_vec3(&self.color),
            back_depth: if back {
                img_f32(&self.back)
            } else {
                none_f32()
            },
        }
    }

    fn gbuffer(&self, back: bool) -> GBuffer<'_> {
        let d = DepthImage::try_new(
            ImageView::try_new(&self.depth, W, H, W).unwrap(),
            self.cam,
            self.conv,
        )
        .unwrap();
        let g = GBuffer::try_new(
            d,
            ImageView::try_new(&self.normals, W, H, W).unwrap(),
            NormalSpace::World,
        )
        .unwrap()
        .try_with_color(ImageView::try_new(&self.color, W, H, W).unwrap())
        .unwrap();
        if back {
            g.try_with_back_depth(ImageView::try_new(&self.back, W, H, W).unwrap())
                .unwrap()
        } else {
            g
        }
    }
}

fn color_mut(c: &mut [[f32; 3]]) -> refl_image_vec3_mut {
    refl_image_vec3_mut {
        data: c.as_mut_ptr().cast(),
        len: c.len(),
        width: W,
        height: H,
        stride: W,
    }
}

fn status(s: refl_core::MirrorStatus) -> u32 {
    s as u32
}

/// The C pass over `rows` into fresh buffers.
struct CRun {
    texels: Vec<refl_ssr_texel>,
    color: Vec<[f32; 3]>,
    host: Vec<refl_host_ray>,
    stats: refl_ssr_stats,
}

fn c_run(
    g: &refl_gbuffer,
    o: &refl_ssr_options,
    scratch: &[refl_vec2],
) -> (refl_status, CRun, u64) {
    let n = (W * H) as usize;
    let mut r = CRun {
        texels: vec![refl_ssr_texel::default(); n],
        color: vec![[7.0; 3]; n],
        host: vec![refl_host_ray::default(); n],
        stats: refl_ssr_stats::default(),
    };
    let rows = refl_row_range { begin: 0, end: H };
    let cm = color_mut(&mut r.color);
    let (s, allocs) = counted(|| {
        // SAFETY: valid buffers of the stated lengths.
        unsafe {
            refl_ssr_trace_rows(
                &mut r.stats,
                r.texels.as_mut_ptr(),
                n,
                cm,
                r.host.as_mut_ptr(),
                n,
                g,
                o,
                if scratch.is_empty() {
                    core::ptr::null()
                } else {
                    scratch.as_ptr()
                },
                scratch.len(),
                rows,
            )
        }
    });
    r.host.truncate(r.stats.host_rays_written as usize);
    (s, r, allocs)
}

fn prepare(g: &refl_gbuffer, o: &refl_ssr_options) -> (Vec<refl_vec2>, u64) {
    let mut len = usize::MAX;
    // SAFETY: valid pointers.
    let (s, a0) = counted(|| unsafe { refl_ssr_scratch_len(&mut len, g, o) });
    assert_eq!(s, refl_status::Ok);
    let mut scratch = vec![refl_vec2 { x: 0.0, y: 0.0 }; len];
    // SAFETY: valid pointers.
    let (s, a1) = counted(|| unsafe {
        refl_ssr_prepare(
            if len == 0 {
                core::ptr::null_mut()
            } else {
                scratch.as_mut_ptr()
            },
            len,
            g,
            o,
        )
    });
    assert_eq!(s, refl_status::Ok);
    (scratch, a0 + a1)
}

#[test]
fn the_allocation_counter_counts() {
    let (v, n) = counted(|| Vec::<u8>::with_capacity(3));
    assert_eq!((v.capacity() >= 3, n), (true, 1));
}

#[test]
fn c_pass_equals_the_rust_pass_bit_for_bit_without_allocating() {
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let f = render(conv);
        for method in [MirrorMethod::Step, MirrorMethod::HiZ] {
            for back in [false, true] {
                let mut o = refl_ssr_options_default();
                o.method = match method {
                    MirrorMethod::Step => refl_ssr_method::Step as u32,
                    MirrorMethod::HiZ => refl_ssr_method::Hiz as u32,
                };
                let g = f.gbuffer_c(back);
                let (scratch, a_prep) = prepare(&g, &o);
                let (s, c, a_run) = c_run(&g, &o, &scratch);
                assert_eq!(s, refl_status::Ok);
                assert_eq!((a_prep, a_run), (0, 0), "allocations in refl_ssr_*");
                // The Rust pass.
                let mut pyr = vec![HiZTexel::default(); hiz_len(W, H).unwrap()];
                let gb = f.gbuffer(back);
                try_build_hiz(&mut pyr, gb.depth()).unwrap();
                if method == MirrorMethod::HiZ {
                    let same = scratch.iter().zip(&pyr).all(|(a, b)| {
                        a.x.to_bits() == b[0].to_bits() && a.y.to_bits() == b[1].to_bits()
                    });
                    assert!(same, "prepare's pyramid");
                }
                let hiz = HiZ::try_new(&pyr, f.cam, conv).unwrap();
                let opts = MirrorOptions {
                    method,
                    ..MirrorOptions::default()
                };
                let pass = MirrorPass::try_new(gb, opts, Some(hiz)).unwrap();
                let n = (W * H) as usize;
                let mut out = vec![MirrorTexel::default(); n];
                let mut color = vec![[0.0; 3]; n];
                let mut host = vec![HostRay::default(); n];
                let st = pass
                    .try_run(
                        &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
                        Some(&mut ImageViewMut::try_new(&mut color, W, H, W).unwrap()),
                        &mut host,
                    )
                    .unwrap();
                assert_eq!(
                    (
                        c.stats.traced,
                        c.stats.hits,
                        c.stats.sky,
                        c.stats.host_rays,
                        c.stats.host_rays_written
                    ),
                    (
                        st.traced,
                        st.hits,
                        st.sky,
                        st.host_rays,
                        st.host_rays_written
                    )
                );
                assert!(st.hits > 100, "{conv:?} {method:?}: {st:?}");
                for i in 0..n {
                    let (a, b) = (c.texels[i], out[i]);
                    assert_eq!(a.status, status(b.status), "{conv:?} {method:?} {i}");
                    assert_eq!(
                        [a.pixel.x, a.pixel.y, a.t, a.confidence].map(f32::to_bits),
                        [b.pixel.x, b.pixel.y, b.t, b.confidence].map(f32::to_bits)
                    );
                    assert_eq!(c.color[i], color[i]);
                }
                for (a, b) in c.host.iter().zip(&host) {
                    assert_eq!((a.x, a.y, a.status), (b.x, b.y, status(b.status)));
                    assert_eq!(
                        [
                            a.origin.x, a.origin.y, a.origin.z, a.dir.x, a.dir.y, a.dir.z, a.t_min,
                            a.t_max
                        ]
                        .map(f32::to_bits),
                        [
                            b.origin.x, b.origin.y, b.origin.z, b.dir.x, b.dir.y, b.dir.z, b.t_min,
                            b.t_max
                        ]
                        .map(f32::to_bits)
                    );
                }
            }
        }
    }
}

/// Descriptors shared by the band threads (each writes only its rows).
struct Shared<T>(T);
// SAFETY: the threads read the G-buffer and write disjoint rows.
unsafe impl<T> Sync for Shared<T> {}

#[test]
fn row_bands_from_threads_equal_the_whole_image() {
    let f = render(DepthConvention::ReversedZ);
    let mut o = refl_ssr_options_default();
    o.method = refl_ssr_method::Hiz as u32;
    let g = f.gbuffer_c(false);
    let (scratch, _) = prepare(&g, &o);
    let (_, whole, _) = c_run(&g, &o, &scratch);
    let n = (W * H) as usize;
    let mut texels = vec![refl_ssr_texel::default(); n];
    let mut color = vec![[0.0f32; 3]; n];
    let bands = 5u32;
    let tp = texels.as_mut_ptr() as usize;
    let shared = Shared((g, color_mut(&mut color)));
    let hosts: Vec<Vec<refl_host_ray>> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..bands)
            .map(|b| {
                let (shared, o, scratch) = (&shared, &o, &scratch);
                s.spawn(move || {
                    let (g, c) = shared.0;
                    let mut rows = refl_row_range::default();
                    // SAFETY: valid pointer.
                    assert_eq!(
                        unsafe { refl_row_band(&mut rows, H, b, bands) },
                        refl_status::Ok
                    );
                    let mut host = vec![refl_host_ray::default(); n];
                    let mut st = refl_ssr_stats::default();
                    // SAFETY: each thread writes only its own rows.
                    let r = unsafe {
                        refl_ssr_trace_rows(
                            &mut st,
                            tp as *mut refl_ssr_texel,
                            n,
                            c,
                            host.as_mut_ptr(),
                            n,
                            &g,
                            o,
                            scratch.as_ptr(),
                            scratch.len(),
                            rows,
                        )
                    };
                    assert_eq!(r, refl_status::Ok);
                    host.truncate(st.host_rays_written as usize);
                    host
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(texels, whole.texels);
    assert_eq!(color, whole.color);
    assert_eq!(hosts.concat(), whole.host);
}

/// Calls `refl_ssr_trace_rows` with every output filled with sentinels and
/// checks the status and that nothing was written.
fn refused(
    want: refl_status,
    g: &refl_gbuffer,
    o: &refl_ssr_options,
    scratch: &[refl_vec2],
    rows: refl_row_range,
    out_len: usize,
    with_color: bool,
) {
    let n = (W * H) as usize;
    let sentinel = refl_ssr_texel {
        status: 99,
        t: -3.0,
        ..Default::default()
    };
    let mut texels = vec![sentinel; n];
    let mut color = vec![[5.0f32; 3]; n];
    let mut host = vec![
        refl_host_ray {
            x: 77,
            ..Default::default()
        };
        8
    ];
    let mut st = refl_ssr_stats {
        traced: 55,
        ..Default::default()
    };
    let cm = if with_color {
        color_mut(&mut color)
    } else {
        refl_image_vec3_mut {
            data: core::ptr::null_mut(),
            len: 0,
            width: 0,
            height: 0,
            stride: 0,
        }
    };
    let (s, allocs) = counted(|| {
        // SAFETY: valid buffers (out_len <= n).
        unsafe {
            refl_ssr_trace_rows(
                &mut st,
                texels.as_mut_ptr(),
                out_len,
                cm,
                host.as_mut_ptr(),
                host.len(),
                g,
                o,
                if scratch.is_empty() {
                    core::ptr::null()
                } else {
                    scratch.as_ptr()
                },
                scratch.len(),
                rows,
            )
        }
    });
    assert_eq!(s, want);
    assert_eq!(allocs, 0, "allocations on the error path");
    assert!(texels.iter().all(|t| *t == sentinel));
    assert!(color.iter().all(|c| *c == [5.0; 3]));
    assert!(host.iter().all(|h| h.x == 77));
    assert_eq!(st.traced, 55);
}

#[test]
fn errors_name_their_cause_and_leave_every_output_untouched() {
    let f = render(DepthConvention::ZeroToOne);
    let g = f.gbuffer_c(false);
    let d = refl_ssr_options_default();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let inv = refl_status::InvalidArgument;
    // Options out of range.
    for o in [
        refl_ssr_options {
            thickness: -1.0,
            ..d
        },
        refl_ssr_options {
            start_pixels: f32::NAN,
            ..d
        },
        refl_ssr_options { t_max: 0.0, ..d },
        refl_ssr_options {
            border_fade: 0.9,
            ..d
        },
        refl_ssr_options { method: 7, ..d },
        refl_ssr_options {
            step: refl_step_options {
                stride: 0,
                max_steps: 9,
            },
            ..d
        },
    ] {
        refused(inv, &g, &o, &[], all, n, true);
    }
    // Rows, sizes, G-buffer fields.
    refused(
        inv,
        &g,
        &d,
        &[],
        refl_row_range { begin: 3, end: 2 },
        n,
        true,
    );
    refused(
        inv,
        &g,
        &d,
        &[],
        refl_row_range {
            begin: 0,
            end: H + 1,
        },
        n,
        true,
    );
    refused(refl_status::InsufficientSize, &g, &d, &[], all, n - 1, true);
    let mut g2 = g;
    g2.normal_space = 5;
    refused(inv, &g2, &d, &[], all, n, true);
    let mut g3 = g;
    g3.normals.width = W - 1;
    g3.normals.stride = W - 1;
    refused(inv, &g3, &d, &[], all, n, true);
    let mut g4 = g;
    g4.color = refl_image_vec3 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    };
    refused(inv, &g4, &d, &[], all, n, true);
    let mut g5 = g;
    g5.depth.depth.data = core::ptr::null();
    refused(refl_status::NullPointer, &g5, &d, &[], all, n, true);
    // Hi-Z: no scratch, a short one, one never prepared, one prepared for
    // another camera.
    let hz = refl_ssr_options {
        method: refl_ssr_method::Hiz as u32,
        ..d
    };
    refused(refl_status::NullPointer, &g, &hz, &[], all, n, true);
    let (scratch, _) = prepare(&g, &hz);
    refused(
        refl_status::InsufficientSize,
        &g,
        &hz,
        &scratch[..scratch.len() - 1],
        all,
        n,
        true,
    );
    let blank = vec![refl_vec2 { x: 0.0, y: 0.0 }; scratch.len()];
    refused(inv, &g, &hz, &blank, all, n, true);
    let other = Camera::try_look_at(
        Vec3::new(0.4, 2.0, 5.5),
        Vec3::new(0.0, 0.6, 0.0),
        Vec3::Y,
        1.0,
        0.1,
        50.0,
        W,
        H,
    )
    .unwrap();
    let mut g6 = g;
    g6.depth.camera = (&other).into();
    let (scratch6, _) = prepare(&g6, &hz);
    refused(inv, &g, &hz, &scratch6, all, n, true);
    // The last error names the argument.
    let mut buf = [0u8; 256];
    // SAFETY: valid buffer.
    let k = unsafe { refl_last_error_message(buf.as_mut_ptr().cast(), buf.len()) };
    let msg = String::from_utf8_lossy(&buf[..k.min(255)]).to_string();
    assert!(msg.contains("scratch"), "{msg}");
    // Prepare refuses a short scratch without writing.
    let mut short = vec![refl_vec2 { x: 1.5, y: 1.5 }; 10];
    // SAFETY: valid pointers.
    let s = unsafe { refl_ssr_prepare(short.as_mut_ptr(), short.len(), &g, &hz) };
    assert_eq!(s, refl_status::InsufficientSize);
    assert!(short.iter().all(|v| v.x == 1.5 && v.y == 1.5));
    // Prepare refuses a scratch that overlaps the depth it reads.
    let mut g7 = g;
    let mut aliased = vec![0.0f32; 2 * scratch.len()];
    g7.depth.depth.data = aliased.as_ptr();
    // SAFETY: valid (overlapping) pointers; refused before any write.
    let s = unsafe { refl_ssr_prepare(aliased.as_mut_ptr().cast(), scratch.len(), &g7, &hz) };
    assert_eq!(s, inv);
}
