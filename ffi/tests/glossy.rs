//! refl_glossy_*: the C pass equals refl-core's `GlossyPass` bit for bit
//! (cone and multi-ray, every convention, with and without a back-face
//! image, whole image and row bands from threads), error paths return
//! their documented status and leave every output untouched, and no export
//! allocates (the counting global allocator of `common/gbuffer.rs`).

#[path = "common/gbuffer.rs"]
mod common;

use common::{
    bands_from_threads, color_mut, counted, img_f32, no_color, refused_outputs, render, Frame,
    Shared, H, W,
};
use refl::*;
use refl_core::cone::{FadeRange, Fades};
use refl_core::glam::Vec3;
use refl_core::{
    try_glossy_scratch_len, try_prepare_glossy, Camera, ColorTexel, DepthConvention, GlossyMethod,
    GlossyOptions, GlossyPass, GlossyScratch, GlossyScratchMut, GlossyStats, GlossyTexel, HostRay,
    ImageView, ImageViewMut,
};

/// Roughness of the frame: the floor ramps from 0.05 to 0.6 across the
/// image, the sphere is 0.3, the sky NaN.
fn roughness(f: &Frame) -> Vec<f32> {
    (0..W * H)
        .map(|i| {
            let (x, c) = (i % W, f.color[i as usize][0]);
            if f.normals[i as usize] == [0.0; 3] {
                f32::NAN
            } else if c == 0.0 {
                0.05 + 0.55 * x as f32 / W as f32
            } else {
                0.3
            }
        })
        .collect()
}

fn gbuffer_c(f: &Frame, rough: &[f32], back: bool) -> refl_gbuffer {
    let mut g = f.gbuffer_c(back);
    g.roughness = img_f32(rough);
    g
}

/// The C options of refl-core options (the ABI's conversion; the
/// bit-for-bit test below holds the pass it configures against the Rust
/// one).
fn c_options(o: &GlossyOptions) -> refl_glossy_options {
    (*o).into()
}

fn option_sets() -> Vec<GlossyOptions> {
    let d = GlossyOptions::default();
    vec![
        d,
        GlossyOptions {
            cone: refl_core::ConeOptions {
                use_visibility: true,
                normalize: false,
                max_stretch: 3.0,
                ..d.cone
            },
            fades: Fades {
                toward_camera: Some(FadeRange {
                    start: 0.2,
                    end: 0.6,
                }),
                border: Some(FadeRange {
                    start: 0.8,
                    end: 1.0,
                }),
                travel: Some(FadeRange {
                    start: 1.0,
                    end: 9.0,
                }),
            },
            view_space: true,
            min_roughness: -1.0,
            ..d
        },
        GlossyOptions {
            method: GlossyMethod::MultiRay,
            rays: 5,
            ..d
        },
    ]
}

#[test]
fn options_default_is_the_rust_default() {
    let c = refl_glossy_options_default();
    assert_eq!(c, c_options(&GlossyOptions::default()));
    // Field by field where C and Rust name them differently.
    let d = GlossyOptions::default();
    assert_eq!(c.method, refl_glossy_method::Cone as u32);
    assert_eq!(
        (
            c.max_circles,
            c.use_visibility,
            c.normalize,
            c.rays,
            c.sigma
        ),
        (
            d.cone.max_circles,
            d.cone.use_visibility,
            d.cone.normalize,
            d.rays,
            d.sigma
        )
    );
    assert!(!c.fade_border.enabled && !c.fade_travel.enabled && !c.fade_toward_camera.enabled);
}

/// The C pass over all rows into fresh buffers.
struct CRun {
    texels: Vec<refl_glossy_texel>,
    color: Vec<[f32; 3]>,
    host: Vec<refl_host_ray>,
    stats: refl_glossy_stats,
}

fn c_run(g: &refl_gbuffer, o: &refl_glossy_options, scratch: &[f32]) -> (refl_status, CRun, u64) {
    let n = (W * H) as usize;
    let mut r = CRun {
        texels: vec![refl_glossy_texel::default(); n],
        color: vec![[7.0; 3]; n],
        host: vec![refl_host_ray::default(); n],
        stats: refl_glossy_stats::default(),
    };
    let cm = color_mut(&mut r.color);
    let (s, allocs) = counted(|| {
        // SAFETY: valid buffers of the stated lengths.
        unsafe {
            refl_glossy_trace_rows(
                &mut r.stats,
                r.texels.as_mut_ptr(),
                n,
                cm,
                r.host.as_mut_ptr(),
                n,
                g,
                o,
                scratch.as_ptr(),
                scratch.len(),
                refl_row_range { begin: 0, end: H },
            )
        }
    });
    r.host.truncate(r.stats.host_rays_written as usize);
    (s, r, allocs)
}

fn prepare(g: &refl_gbuffer, o: &refl_glossy_options) -> (Vec<f32>, u64) {
    let mut len = usize::MAX;
    // SAFETY: valid pointers.
    let (s, a0) = counted(|| unsafe { refl_glossy_scratch_len(&mut len, g, o) });
    assert_eq!(s, refl_status::Ok);
    let mut scratch = vec![0.0f32; len];
    // SAFETY: valid pointers.
    let (s, a1) = counted(|| unsafe { refl_glossy_prepare(scratch.as_mut_ptr(), len, g, o) });
    assert_eq!(s, refl_status::Ok);
    (scratch, a0 + a1)
}

fn texel_bits(t: &refl_glossy_texel) -> (u32, [u32; 9]) {
    (
        t.status,
        [
            t.pixel.x,
            t.pixel.y,
            t.t,
            t.coverage,
            t.fade,
            t.fallback_weight,
            t.dir.x,
            t.dir.y,
            t.dir.z,
        ]
        .map(f32::to_bits),
    )
}

fn host_bits(a: &refl_host_ray) -> (u32, u32, u32, [u32; 8]) {
    (
        a.x,
        a.y,
        a.status,
        [
            a.origin.x, a.origin.y, a.origin.z, a.dir.x, a.dir.y, a.dir.z, a.t_min, a.t_max,
        ]
        .map(f32::to_bits),
    )
}

#[test]
fn c_pass_equals_the_rust_pass_bit_for_bit_without_allocating() {
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let f = render(conv);
        let rough = roughness(&f);
        for back in [false, true] {
            for o in option_sets() {
                let oc = c_options(&o);
                let g = gbuffer_c(&f, &rough, back);
                let (scratch, a_prep) = prepare(&g, &oc);
                let (s, c, a_run) = c_run(&g, &oc, &scratch);
                assert_eq!(s, refl_status::Ok);
                assert_eq!((a_prep, a_run), (0, 0), "allocations in refl_glossy_*");
                // The Rust pass.
                let gb = f
                    .gbuffer(back)
                    .try_with_roughness(ImageView::try_new(&rough, W, H, W).unwrap())
                    .unwrap();
                let n = try_glossy_scratch_len(W, H, &o).unwrap();
                assert_eq!(Some(scratch.len()), n.floats());
                let mut hz = vec![[0.0; 2]; n.hiz];
                let mut col = vec![[0.0; 3]; n.color];
                let mut vis = vec![0.0; n.visibility];
                try_prepare_glossy(
                    GlossyScratchMut {
                        hiz: &mut hz,
                        color: &mut col,
                        visibility: &mut vis,
                    },
                    &gb,
                    &o,
                )
                .unwrap();
                let rust_floats: Vec<u32> = hz
                    .iter()
                    .flatten()
                    .chain(col.iter().flatten())
                    .chain(&vis)
                    .map(|v| v.to_bits())
                    .collect();
                let c_floats: Vec<u32> = scratch.iter().map(|v| v.to_bits()).collect();
                assert!(rust_floats == c_floats, "prepare's pyramids");
                let pass = GlossyPass::try_new(
                    gb,
                    o,
                    GlossyScratch {
                        hiz: &hz,
                        color: &col,
                        visibility: &vis,
                    },
                )
                .unwrap();
                let np = (W * H) as usize;
                let mut out = vec![GlossyTexel::default(); np];
                let mut color: Vec<ColorTexel> = vec![[0.0; 3]; np];
                let mut host = vec![HostRay::default(); np];
                let st: GlossyStats = pass
                    .try_run(
                        &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
                        Some(&mut ImageViewMut::try_new(&mut color, W, H, W).unwrap()),
                        &mut host,
                    )
                    .unwrap();
                assert_eq!(c.stats, st.into());
                assert!(st.hits > 100, "{conv:?} {:?}: {st:?}", o.method);
                for i in 0..np {
                    assert_eq!(
                        texel_bits(&c.texels[i]),
                        texel_bits(&out[i].into()),
                        "{conv:?} {i}"
                    );
                    assert_eq!(c.color[i].map(f32::to_bits), color[i].map(f32::to_bits));
                }
                assert_eq!(c.host.len(), st.host_rays_written as usize);
                for (a, b) in c.host.iter().zip(&host) {
                    let o = [b.origin.to_array(), b.dir.to_array()].concat();
                    let want = [&o[..], &[b.t_min, b.t_max]].concat();
                    let want: Vec<u32> = want.iter().map(|v| v.to_bits()).collect();
                    let got = host_bits(a);
                    assert_eq!((got.0, got.1, got.2), (b.x, b.y, b.status as u32));
                    assert_eq!(got.3.to_vec(), want);
                }
            }
        }
    }
}

#[test]
fn row_bands_from_threads_equal_the_whole_image() {
    let f = render(DepthConvention::ReversedZ);
    let rough = roughness(&f);
    for o in option_sets() {
        let oc = c_options(&o);
        let g = gbuffer_c(&f, &rough, false);
        let (scratch, _) = prepare(&g, &oc);
        let (_, whole, _) = c_run(&g, &oc, &scratch);
        let n = (W * H) as usize;
        let mut texels = vec![refl_glossy_texel::default(); n];
        let mut color = vec![[0.0f32; 3]; n];
        let gs = Shared(g);
        let runs = bands_from_threads(
            &mut texels,
            &mut color,
            5,
            &|st, out, out_len, c, host, host_len, rows| {
                // SAFETY: valid buffers; each band writes only its own rows.
                unsafe {
                    refl_glossy_trace_rows(
                        st,
                        out,
                        out_len,
                        c,
                        host,
                        host_len,
                        gs.get(),
                        &oc,
                        scratch.as_ptr(),
                        scratch.len(),
                        rows,
                    )
                }
            },
        );
        assert_eq!(texels, whole.texels);
        assert_eq!(color, whole.color);
        let hosts: Vec<refl_host_ray> = runs.iter().flat_map(|r| r.0.clone()).collect();
        assert_eq!(hosts, whole.host);
        let sum = runs.iter().fold(refl_glossy_stats::default(), |a, (_, s)| {
            refl_glossy_stats {
                traced: a.traced + s.traced,
                hits: a.hits + s.hits,
                sky: a.sky + s.sky,
                host_rays: a.host_rays + s.host_rays,
                host_rays_written: a.host_rays_written + s.host_rays_written,
                circles: a.circles + s.circles,
                lobe_rays: a.lobe_rays + s.lobe_rays,
                lobe_hits: a.lobe_hits + s.lobe_hits,
            }
        });
        assert_eq!(sum, whole.stats);
    }
}

/// Calls `refl_glossy_trace_rows` with every output filled with sentinels
/// and checks the status and that nothing was written or allocated.
#[allow(clippy::too_many_arguments)]
fn refused(
    want: refl_status,
    g: &refl_gbuffer,
    o: &refl_glossy_options,
    scratch: &[f32],
    null_scratch: bool,
    rows: refl_row_range,
    out_len: usize,
    with_color: bool,
) {
    let texel = refl_glossy_texel {
        status: 99,
        t: -3.0,
        ..Default::default()
    };
    let stats = refl_glossy_stats {
        traced: 55,
        ..Default::default()
    };
    refused_outputs(
        want,
        texel,
        stats,
        with_color,
        |st, out, cm, host, host_len| {
            let scratch_ptr = if null_scratch {
                core::ptr::null()
            } else {
                scratch.as_ptr()
            };
            // SAFETY: valid buffers (out_len <= n).
            unsafe {
                refl_glossy_trace_rows(
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

/// `refl_glossy_prepare` into a sentinel scratch of `len` floats: the
/// status, and the scratch untouched.
fn prepare_refused(want: refl_status, g: &refl_gbuffer, o: &refl_glossy_options, len: usize) {
    let mut scratch = vec![-9.0f32; len];
    // SAFETY: valid pointers.
    let (s, allocs) = counted(|| unsafe { refl_glossy_prepare(scratch.as_mut_ptr(), len, g, o) });
    assert_eq!(s, want);
    assert_eq!(allocs, 0);
    assert!(scratch.iter().all(|v| *v == -9.0));
}

fn last_error() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: valid buffer.
    let k = unsafe { refl_last_error_message(buf.as_mut_ptr().cast(), buf.len()) };
    String::from_utf8_lossy(&buf[..k.min(255)]).to_string()
}

/// The inputs of the error tests: the ZeroToOne scene and its roughness.
struct ErrorSetup {
    f: Frame,
    rough: Vec<f32>,
}

impl ErrorSetup {
    fn new() -> ErrorSetup {
        let f = render(DepthConvention::ZeroToOne);
        let rough = roughness(&f);
        ErrorSetup { f, rough }
    }

    /// The G-buffer (no back faces), the default options and a scratch
    /// prepared for them.
    fn c(&self) -> (refl_gbuffer, refl_glossy_options, Vec<f32>) {
        let g = gbuffer_c(&self.f, &self.rough, false);
        let d = refl_glossy_options_default();
        let (scratch, _) = prepare(&g, &d);
        (g, d, scratch)
    }
}

#[test]
fn options_out_of_range_are_refused_by_prepare_and_trace_naming_them() {
    let e = ErrorSetup::new();
    let (g, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let inv = refl_status::InvalidArgument;
    let on = refl_glossy_fade {
        enabled: true,
        start: 1.0,
        end: 1.0,
    };
    // Options out of range, in prepare and in trace.
    for o in [
        refl_glossy_options { method: 2, ..d },
        refl_glossy_options { sigma: 0.0, ..d },
        refl_glossy_options { rays: 0, ..d },
        refl_glossy_options {
            thickness: -1.0,
            ..d
        },
        refl_glossy_options {
            start_pixels: f32::NAN,
            ..d
        },
        refl_glossy_options { t_max: 0.0, ..d },
        refl_glossy_options {
            min_roughness: f32::NAN,
            ..d
        },
        refl_glossy_options {
            min_roughness: 1.0,
            ..d
        },
        refl_glossy_options {
            max_stretch: 0.0,
            ..d
        },
        refl_glossy_options {
            level_bias: f32::INFINITY,
            ..d
        },
        refl_glossy_options {
            depth_tolerance: -1.0,
            ..d
        },
        refl_glossy_options {
            fade_border: on,
            ..d
        },
    ] {
        prepare_refused(inv, &g, &o, scratch.len());
        refused(inv, &g, &o, &scratch, false, all, n, true);
        if o.method == 2 {
            assert!(last_error().contains("method"), "{}", last_error());
        } else {
            assert!(last_error().contains("options"), "{}", last_error());
        }
    }
}

#[test]
fn a_gbuffer_without_roughness_or_color_is_refused_naming_the_roughness() {
    let e = ErrorSetup::new();
    let (g, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let inv = refl_status::InvalidArgument;
    for gb in [
        refl_gbuffer {
            roughness: common::none_f32(),
            ..g
        },
        refl_gbuffer {
            color: refl_image_vec3 {
                data: core::ptr::null(),
                len: 0,
                width: 0,
                height: 0,
                stride: 0,
            },
            ..g
        },
    ] {
        prepare_refused(inv, &gb, &d, scratch.len());
        refused(inv, &gb, &d, &scratch, false, all, n, true);
        assert!(last_error().contains("roughness"), "{}", last_error());
    }
}

#[test]
fn bad_rows_sizes_and_gbuffer_fields_are_refused() {
    let e = ErrorSetup::new();
    let (g, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let inv = refl_status::InvalidArgument;
    refused(
        inv,
        &g,
        &d,
        &scratch,
        false,
        refl_row_range { begin: 3, end: 2 },
        n,
        true,
    );
    refused(
        inv,
        &g,
        &d,
        &scratch,
        false,
        refl_row_range {
            begin: 0,
            end: H + 1,
        },
        n,
        true,
    );
    refused(
        refl_status::InsufficientSize,
        &g,
        &d,
        &scratch,
        false,
        all,
        n - 1,
        true,
    );
    let mut g2 = g;
    g2.normal_space = 5;
    refused(inv, &g2, &d, &scratch, false, all, n, true);
    let mut g3 = g;
    g3.roughness.width = W - 1;
    g3.roughness.stride = W - 1;
    refused(inv, &g3, &d, &scratch, false, all, n, true);
    let mut g5 = g;
    g5.depth.depth.data = core::ptr::null();
    refused(
        refl_status::NullPointer,
        &g5,
        &d,
        &scratch,
        false,
        all,
        n,
        true,
    );
}

/// Scratch: NULL, short, never prepared, prepared for another camera,
/// prepared without the visibility pyramid the options read.
#[test]
fn a_null_short_or_foreign_scratch_is_refused() {
    let e = ErrorSetup::new();
    let (g, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let inv = refl_status::InvalidArgument;
    refused(
        refl_status::NullPointer,
        &g,
        &d,
        &scratch,
        true,
        all,
        n,
        true,
    );
    refused(
        refl_status::InsufficientSize,
        &g,
        &d,
        &scratch[..scratch.len() - 1],
        false,
        all,
        n,
        true,
    );
    let blank = vec![0.0f32; scratch.len()];
    refused(inv, &g, &d, &blank, false, all, n, true);
    assert!(last_error().contains("scratch"), "{}", last_error());
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
    let (scratch6, _) = prepare(&g6, &d);
    refused(inv, &g, &d, &scratch6, false, all, n, true);
    assert!(last_error().contains("scratch"), "{}", last_error());
    let vis = refl_glossy_options {
        use_visibility: true,
        ..d
    };
    let mut vis_len = 0usize;
    // SAFETY: valid pointers.
    assert_eq!(
        unsafe { refl_glossy_scratch_len(&mut vis_len, &g, &vis) },
        refl_status::Ok
    );
    assert!(vis_len > scratch.len());
    let mut padded = scratch.clone();
    padded.resize(vis_len, 0.0);
    refused(inv, &g, &vis, &padded, false, all, n, true);
}

#[test]
fn trace_output_over_the_scratch_is_refused() {
    let e = ErrorSetup::new();
    let (g, d, scratch) = e.c();
    let all = refl_row_range { begin: 0, end: H };
    let n = (W * H) as usize;
    let inv = refl_status::InvalidArgument;
    let mut big = scratch.clone();
    big.resize(scratch.len() + 16 * n, 0.0);
    let mut st = refl_glossy_stats::default();
    // SAFETY: valid (overlapping) pointers; refused before any write.
    let s = unsafe {
        refl_glossy_trace_rows(
            &mut st,
            big.as_mut_ptr().add(8).cast(),
            n,
            no_color(),
            core::ptr::null_mut(),
            0,
            &g,
            &d,
            big.as_ptr(),
            scratch.len(),
            all,
        )
    };
    assert_eq!(s, inv);
}

#[test]
fn prepare_refuses_a_short_scratch_one_over_the_depth_image_and_a_non_finite_color() {
    let e = ErrorSetup::new();
    let (g, d, scratch) = e.c();
    let n = (W * H) as usize;
    let inv = refl_status::InvalidArgument;
    let f = &e.f;
    prepare_refused(refl_status::InsufficientSize, &g, &d, scratch.len() - 1);
    let mut g7 = g;
    let aliased = vec![0.0f32; scratch.len() + n];
    g7.depth.depth.data = aliased.as_ptr();
    // SAFETY: valid (overlapping) pointers; refused before any write.
    let s = unsafe { refl_glossy_prepare(aliased.as_ptr().cast_mut(), scratch.len(), &g7, &d) };
    assert_eq!(s, inv);
    // A non-finite lit color.
    let mut hot = f.color.clone();
    hot[100] = [f32::NAN, 0.0, 0.0];
    let mut g8 = g;
    g8.color.data = hot.as_ptr().cast();
    prepare_refused(inv, &g8, &d, scratch.len());
}

#[test]
fn scratch_len_refuses_nulls_and_an_unknown_method_untouched() {
    let e = ErrorSetup::new();
    let (g, d, _) = e.c();
    let inv = refl_status::InvalidArgument;
    let mut len = 5usize;
    // SAFETY: valid or NULL pointers.
    unsafe {
        assert_eq!(
            refl_glossy_scratch_len(core::ptr::null_mut(), &g, &d),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_glossy_scratch_len(&mut len, core::ptr::null(), &d),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_glossy_scratch_len(&mut len, &g, &refl_glossy_options { method: 9, ..d }),
            inv
        );
    }
    assert_eq!(len, 5);
}

/// A NULL required pointer is reported as `REFL_STATUS_NULL_POINTER` even
/// when a G-buffer image is also too short (as `refl_ssr_*`; the `ssr` fuzz
/// target found the ordering fault there).
#[test]
fn a_null_required_pointer_is_reported_before_a_short_image() {
    let f = render(DepthConvention::ZeroToOne);
    let rough = roughness(&f);
    let mut g = gbuffer_c(&f, &rough, false);
    g.depth.depth.len -= 1;
    let o = refl_glossy_options_default();
    // SAFETY: NULL scratch with a length: refused before it is read.
    let s = unsafe { refl_glossy_prepare(core::ptr::null_mut(), 100, &g, &o) };
    assert_eq!(s, refl_status::NullPointer);
    let n = (W * H) as usize;
    let mut texels = vec![refl_glossy_texel::default(); n];
    let mut stats = refl_glossy_stats::default();
    let scratch = vec![0.0f32; 100];
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
        let all = refl_row_range { begin: 0, end: H };
        // SAFETY: pointers NULL or valid for the lengths given.
        let s = unsafe {
            refl_glossy_trace_rows(
                &mut stats,
                out,
                n,
                no_color(),
                hp,
                4,
                &g,
                &o,
                scratch_ptr,
                100,
                all,
            )
        };
        assert_eq!(s, refl_status::NullPointer, "NULL {what}");
    }
}
