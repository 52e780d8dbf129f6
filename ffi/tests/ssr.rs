//! refl_ssr_*: the C pass equals refl-core's `MirrorPass` bit for bit (both
//! methods, every convention, whole image and row bands from threads),
//! error paths return their documented status and leave every output
//! untouched, and no export allocates (the counting global allocator of
//! `tests/common`; `tests/alloc.rs` covers every export).

#[path = "common/gbuffer.rs"]
mod common;

use common::{
    bands_from_threads, color_mut, counted, refused_outputs, render, Frame, Shared, H, W,
};
use refl::*;
use refl_core::glam::Vec3;
use refl_core::{
    try_build_hiz, try_hiz_len, Camera, DepthConvention, HiZ, HiZTexel, HostRay, ImageViewMut,
    MirrorMethod, MirrorOptions, MirrorPass, MirrorTexel,
};

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
                let mut pyr = vec![HiZTexel::default(); try_hiz_len(W, H).unwrap()];
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
    let gs = Shared(g);
    let runs = bands_from_threads(
        &mut texels,
        &mut color,
        5,
        &|st, out, out_len, c, host, host_len, rows| {
            // SAFETY: valid buffers; each band writes only its own rows.
            unsafe {
                refl_ssr_trace_rows(
                    st,
                    out,
                    out_len,
                    c,
                    host,
                    host_len,
                    gs.get(),
                    &o,
                    scratch.as_ptr(),
                    scratch.len(),
                    rows,
                )
            }
        },
    );
    assert_eq!(texels, whole.texels);
    assert_eq!(color, whole.color);
    let hosts: Vec<refl_host_ray> = runs.into_iter().flat_map(|r| r.0).collect();
    assert_eq!(hosts, whole.host);
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
    let texel = refl_ssr_texel {
        status: 99,
        t: -3.0,
        ..Default::default()
    };
    let stats = refl_ssr_stats {
        traced: 55,
        ..Default::default()
    };
    refused_outputs(
        want,
        texel,
        stats,
        with_color,
        |st, out, cm, host, host_len| {
            let scratch_ptr = if scratch.is_empty() {
                core::ptr::null()
            } else {
                scratch.as_ptr()
            };
            // SAFETY: valid buffers (out_len <= n).
            unsafe {
                refl_ssr_trace_rows(
                    st,
                    out,
                    out_len,
                    cm,
                    host,
                    host_len,
                    g,
                    o,
                    scratch_ptr,
                    scratch.len(),
                    rows,
                )
            }
        },
    );
}

/// The ZeroToOne scene and its G-buffer (without back faces), which
/// points into it.
fn zero_to_one() -> (Frame, refl_gbuffer) {
    let f = render(DepthConvention::ZeroToOne);
    let g = f.gbuffer_c(false);
    (f, g)
}

#[test]
fn options_out_of_range_are_refused_untouched() {
    let (_f, g) = zero_to_one();
    let d = refl_ssr_options_default();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let inv = refl_status::InvalidArgument;
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
}

#[test]
fn bad_rows_sizes_and_gbuffer_fields_are_refused_untouched() {
    let (_f, g) = zero_to_one();
    let d = refl_ssr_options_default();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let inv = refl_status::InvalidArgument;
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
}

/// The Hi-Z method with the default options.
fn hiz_options() -> refl_ssr_options {
    refl_ssr_options {
        method: refl_ssr_method::Hiz as u32,
        ..refl_ssr_options_default()
    }
}

/// Hi-Z: no scratch, a short one, one never prepared, one prepared for
/// another camera; the last error names the scratch.
#[test]
fn a_missing_short_or_foreign_hiz_scratch_is_refused_naming_it() {
    let (_f, g) = zero_to_one();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let inv = refl_status::InvalidArgument;
    let hz = hiz_options();
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
}

#[test]
fn prepare_refuses_a_short_scratch_and_one_over_the_depth_untouched() {
    let f = render(DepthConvention::ZeroToOne);
    let g = f.gbuffer_c(false);
    let inv = refl_status::InvalidArgument;
    let hz = hiz_options();
    let (scratch, _) = prepare(&g, &hz);
    // A short scratch, not written.
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

/// A NULL required pointer is reported as `REFL_STATUS_NULL_POINTER` even
/// when a G-buffer image is also too short (the fuzz target `ssr` found
/// `REFL_STATUS_INSUFFICIENT_SIZE` for a NULL Hi-Z scratch with a short
/// depth image: sizes were checked before that pointer).
#[test]
fn a_null_required_pointer_is_reported_before_a_short_image() {
    let f = render(DepthConvention::ZeroToOne);
    let mut g = f.gbuffer_c(false);
    g.depth.depth.len -= 1;
    let hiz = refl_ssr_options {
        method: 1,
        ..refl_ssr_options_default()
    };
    let all = refl_row_range { begin: 0, end: H };
    // SAFETY: NULL scratch with a length: refused before it is read.
    let s = unsafe { refl_ssr_prepare(core::ptr::null_mut(), 100, &g, &hiz) };
    assert_eq!(s, refl_status::NullPointer);
    let n = (W * H) as usize;
    let mut texels = vec![refl_ssr_texel::default(); n];
    let mut stats = refl_ssr_stats::default();
    let scratch = vec![refl_vec2 { x: 0.0, y: 0.0 }; 100];
    for (out, host_null, scratch_ptr, what) in [
        (core::ptr::null_mut(), false, scratch.as_ptr(), "out"),
        (texels.as_mut_ptr(), true, scratch.as_ptr(), "host"),
        (texels.as_mut_ptr(), false, core::ptr::null(), "scratch"),
    ] {
        let mut host = vec![refl_host_ray::default(); 4];
        let hp = if host_null {
            core::ptr::null_mut()
        } else {
            host.as_mut_ptr()
        };
        // SAFETY: pointers NULL or valid for the lengths given.
        let s = unsafe {
            refl_ssr_trace_rows(
                &mut stats,
                out,
                n,
                common::no_color(),
                hp,
                4,
                &g,
                &hiz,
                scratch_ptr,
                100,
                all,
            )
        };
        assert_eq!(s, refl_status::NullPointer, "NULL {what}");
    }
}
