//! refl_extrapolate_*: the C dilation equals refl-core's
//! `ExtrapolatePass` bit for bit on the mirror pass's own texels and
//! colors (every depth convention, several options, a roughness image,
//! with and without a status image, host lists long and short), two row
//! bands equal one call and leave the other rows untouched, every refusal
//! (a texel status that is not a `refl_ssr_status` included) returns its
//! documented status, names the argument in the last-error message and
//! leaves every output byte as it was, and no call allocates.

#[path = "common/gbuffer.rs"]
mod common;
#[path = "common/passes.rs"]
mod passes;

use common::{color_mut, counted, img_f32, img_vec3, render, Frame, H, W};
use passes::*;
use refl::*;
use refl_core::extrapolate::{
    ExtrapolateOptions, ExtrapolatePass, ExtrapolateStats, ExtrapolateStatus,
};
use refl_core::{DepthConvention, ImageView, ImageViewMut, MirrorPass, MirrorTexel};

/// A roughness per pixel in [0, 0.1) (every pixel stays traced by the
/// mirror pass, whose limit is 0.1).
fn roughness() -> Vec<f32> {
    (0..N).map(|i| (i % 10) as f32 * 0.01).collect()
}

struct CRun {
    out: Vec<[f32; 3]>,
    status: Vec<u8>,
    host: Vec<refl_image_pixel>,
    stats: refl_extrapolate_stats,
}

fn sentinel_stats() -> refl_extrapolate_stats {
    sentinel()
}

fn fresh(host_len: usize) -> CRun {
    let v = sentinel_f32();
    let p = sentinel_u32();
    CRun {
        out: vec![[v; 3]; N],
        status: vec![SENTINEL; N],
        host: vec![refl_image_pixel { x: p, y: p }; host_len],
        stats: sentinel_stats(),
    }
}

impl CRun {
    fn snapshot(&self) -> Vec<u8> {
        [
            bytes(&self.out),
            self.status.clone(),
            bytes(&self.host),
            bytes(&[self.stats]),
        ]
        .concat()
    }
}

/// The inputs of a C call: the G-buffer, the pass's texels and colors.
struct Inputs {
    g: refl_gbuffer,
    texels: Vec<refl_ssr_texel>,
    color: Vec<[f32; 3]>,
}

fn inputs(f: &Frame, rough: Option<&[f32]>) -> Inputs {
    let mut g = f.gbuffer_c(false);
    if let Some(r) = rough {
        g.roughness = img_f32(r);
    }
    let (texels, color) = c_mirror(&g);
    Inputs { g, texels, color }
}

/// One C call over `rows` into `r`.
fn c_call(
    r: &mut CRun,
    inp: &Inputs,
    o: &refl_extrapolate_options,
    with_status: bool,
    rows: refl_row_range,
) -> (refl_status, u64) {
    let out = color_mut(&mut r.out);
    let status = if with_status {
        u8_mut(&mut r.status)
    } else {
        no_u8_mut()
    };
    let (host, host_len) = (r.host.as_mut_ptr(), r.host.len());
    let stats = &mut r.stats;
    let texels = ssr_texels(&inp.texels, W, H);
    let color = img_vec3(&inp.color);
    // SAFETY: valid buffers of the stated lengths, outputs disjoint from
    // the inputs.
    counted(|| unsafe {
        refl_extrapolate_fill_rows(
            stats, out, status, host, host_len, &inp.g, texels, color, o, rows,
        )
    })
}

fn all_rows() -> refl_row_range {
    refl_row_range { begin: 0, end: H }
}

/// What refl-core's dilation writes: colors, statuses, host list, counts.
type RustRun = (Vec<[f32; 3]>, Vec<u8>, Vec<[u32; 2]>, ExtrapolateStats);

/// refl-core's mirror pass and dilation over the whole frame.
fn rust_run(f: &Frame, rough: Option<&[f32]>, o: ExtrapolateOptions, host_len: usize) -> RustRun {
    let mut g = f.gbuffer(false);
    if let Some(r) = rough {
        g = g
            .try_with_roughness(ImageView::try_new(r, W, H, W).unwrap())
            .unwrap();
    }
    let mirror = MirrorPass::try_new(g, refl_core::MirrorOptions::default(), None).unwrap();
    let (texels, color) = core_mirror_run(&mirror);
    let pass = ExtrapolatePass::try_new(
        g,
        ImageView::<MirrorTexel>::try_new(&texels, W, H, W).unwrap(),
        ImageView::try_new(&color, W, H, W).unwrap(),
        o,
    )
    .unwrap();
    let mut out = vec![[0.0f32; 3]; N];
    let mut status = vec![0u8; N];
    let mut host = vec![[0u32; 2]; host_len];
    let stats = pass
        .try_run(
            &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut status, W, H, W).unwrap()),
            &mut host,
        )
        .unwrap();
    host.truncate(stats.host_written as usize);
    (out, status, host, stats)
}

fn stats_of(s: &ExtrapolateStats) -> refl_extrapolate_stats {
    refl_extrapolate_stats {
        holes: s.holes,
        filled: s.filled,
        unfilled: s.unfilled,
        too_smooth: s.too_smooth,
        host_written: s.host_written,
    }
}

#[test]
fn the_defaults_and_statuses_are_refl_cores() {
    let d = refl_extrapolate_options_default();
    assert_eq!(ExtrapolateOptions::from(d), ExtrapolateOptions::default());
    assert_eq!(REFL_EXTRAPOLATE_MAX_RADIUS, 16);
    for (s, c) in [
        (ExtrapolateStatus::Kept, refl_extrapolate_status::Kept),
        (ExtrapolateStatus::Filled, refl_extrapolate_status::Filled),
        (
            ExtrapolateStatus::Unfilled,
            refl_extrapolate_status::Unfilled,
        ),
        (
            ExtrapolateStatus::TooSmooth,
            refl_extrapolate_status::TooSmooth,
        ),
    ] {
        assert_eq!(refl_extrapolate_status::from(s), c);
        assert_eq!(s as u32, c as u32);
    }
}

#[test]
fn c_dilation_equals_the_rust_dilation_bit_for_bit_without_allocating() {
    let rough = roughness();
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let f = render(conv);
        let d = refl_extrapolate_options_default();
        for (o, with_rough) in [
            (d, false),
            (
                refl_extrapolate_options {
                    all_host_rays: true,
                    radius: 2,
                    ..d
                },
                false,
            ),
            (
                refl_extrapolate_options {
                    all_host_rays: true,
                    min_roughness: 0.05,
                    spatial_sigma: f32::INFINITY,
                    normal_power: 0.0,
                    ..d
                },
                true,
            ),
            (
                refl_extrapolate_options {
                    radius: REFL_EXTRAPOLATE_MAX_RADIUS,
                    depth_threshold: f32::INFINITY,
                    normal_power: 2.5,
                    all_host_rays: true,
                    ..d
                },
                false,
            ),
        ] {
            let r = with_rough.then_some(&rough[..]);
            let inp = inputs(&f, r);
            for host_len in [N, 3] {
                let want = rust_run(&f, r, o.into(), host_len);
                for with_status in [true, false] {
                    let mut c = fresh(host_len);
                    let (s, allocs) = c_call(&mut c, &inp, &o, with_status, all_rows());
                    assert_eq!((s, allocs), (refl_status::Ok, 0), "{conv:?} {o:?}");
                    assert_eq!(c.stats, stats_of(&want.3), "{conv:?} {o:?}");
                    for i in 0..N {
                        assert_eq!(color_bits(&c.out[i]), color_bits(&want.0[i]), "pixel {i}");
                    }
                    if with_status {
                        assert_eq!(c.status, want.1);
                    } else {
                        assert!(c.status.iter().all(|&b| b == SENTINEL));
                    }
                    let n = c.stats.host_written as usize;
                    let got: Vec<[u32; 2]> = c.host[..n].iter().map(|p| [p.x, p.y]).collect();
                    assert_eq!(got, want.2);
                    // The rest of the list is untouched.
                    assert!(bytes(&c.host[n..]).iter().all(|&b| b == SENTINEL));
                }
            }
            // The frame has holes, some filled, some left to the host.
            let st = rust_run(&f, r, o.into(), N).3;
            assert!(st.holes > 0 && st.filled > 0, "{conv:?} {o:?}: {st:?}");
            if with_rough {
                assert!(st.too_smooth > 0, "{st:?}");
            }
        }
    }
}

#[test]
fn bands_equal_one_call_and_leave_other_rows_untouched() {
    let f = render(DepthConvention::ReversedZ);
    let inp = inputs(&f, None);
    let o = refl_extrapolate_options {
        all_host_rays: true,
        ..refl_extrapolate_options_default()
    };
    let mut whole = fresh(N);
    assert_eq!(
        c_call(&mut whole, &inp, &o, true, all_rows()).0,
        refl_status::Ok
    );
    let wn = whole.stats.host_written as usize;
    for k in [1, 17, H / 2, H - 1] {
        let mut c = fresh(N);
        let mut list = Vec::new();
        let mut sum = [0u32; 5];
        for band in [
            refl_row_range { begin: 0, end: k },
            refl_row_range { begin: k, end: H },
        ] {
            assert_eq!(c_call(&mut c, &inp, &o, true, band).0, refl_status::Ok);
            let s = c.stats;
            for (a, v) in
                sum.iter_mut()
                    .zip([s.holes, s.filled, s.unfilled, s.too_smooth, s.host_written])
            {
                *a += v;
            }
            list.extend_from_slice(&c.host[..s.host_written as usize]);
            if band.begin == 0 {
                let split = (k * W) as usize;
                assert!(bytes(&c.out[split..]).iter().all(|&b| b == SENTINEL));
                assert!(c.status[split..].iter().all(|&b| b == SENTINEL));
            }
        }
        let w = whole.stats;
        assert_eq!(
            sum,
            [w.holes, w.filled, w.unfilled, w.too_smooth, w.host_written],
            "band at {k}"
        );
        assert_eq!(list, whole.host[..wn], "band at {k}");
        assert_eq!(bytes(&c.out), bytes(&whole.out), "band at {k}");
        assert_eq!(c.status, whole.status, "band at {k}");
    }
}

#[test]
fn refusals_name_the_argument_and_write_nothing() {
    let f = render(DepthConvention::Linear);
    let inp = inputs(&f, None);
    let o0 = refl_extrapolate_options_default();
    let before = fresh(8).snapshot();
    let name = "refl_extrapolate_fill_rows";
    let bad = refl_status::InvalidArgument;
    type Edit<'e> = &'e dyn Fn(
        &mut refl_image_vec3_mut,
        &mut refl_image_u8_mut,
        &mut refl_image_ssr_texel,
        &mut refl_image_vec3,
        &mut refl_gbuffer,
    );
    let run = |o: refl_extrapolate_options, rows: refl_row_range, edit: Edit<'_>| {
        let mut c = fresh(8);
        let mut out = color_mut(&mut c.out);
        let mut status = u8_mut(&mut c.status);
        let mut texels = ssr_texels(&inp.texels, W, H);
        let mut color = img_vec3(&inp.color);
        let mut g = inp.g;
        edit(&mut out, &mut status, &mut texels, &mut color, &mut g);
        let (host, host_len) = (c.host.as_mut_ptr(), c.host.len());
        let stats = &mut c.stats;
        // SAFETY: valid buffers (or the defect under test, which the call
        // refuses before reading or writing).
        let (s, allocs) = counted(|| unsafe {
            refl_extrapolate_fill_rows(
                stats, out, status, host, host_len, &g, texels, color, &o, rows,
            )
        });
        (s, c.snapshot(), allocs)
    };
    let none: Edit<'_> = &|_, _, _, _, _| {};
    for (o, says) in [
        (
            refl_extrapolate_options { radius: 0, ..o0 },
            "`options.radius`",
        ),
        (
            refl_extrapolate_options { radius: 17, ..o0 },
            "`options.radius`",
        ),
        (
            refl_extrapolate_options {
                spatial_sigma: 0.0,
                ..o0
            },
            "`options.spatial_sigma`",
        ),
        (
            refl_extrapolate_options {
                depth_threshold: f32::NAN,
                ..o0
            },
            "`options.depth_threshold`",
        ),
        (
            refl_extrapolate_options {
                depth_sigma: -1.0,
                ..o0
            },
            "`options.depth_sigma`",
        ),
        (
            refl_extrapolate_options {
                normal_power: f32::INFINITY,
                ..o0
            },
            "`options.normal_power`",
        ),
        (
            refl_extrapolate_options {
                min_roughness: f32::NAN,
                ..o0
            },
            "`options.min_roughness`",
        ),
    ] {
        refused(name, bad, says, &before, || run(o, all_rows(), none));
    }
    for rows in [
        refl_row_range { begin: 5, end: 4 },
        refl_row_range {
            begin: 0,
            end: H + 1,
        },
    ] {
        refused(name, bad, "`rows`", &before, || run(o0, rows, none));
    }
    // A texel whose status is not a refl_ssr_status.
    let mut texels = inp.texels.clone();
    texels[N - 1].status = 10;
    let tp = texels.as_ptr();
    refused(
        name,
        bad,
        "`texels` texel 6143 has status 10",
        &before,
        || run(o0, all_rows(), &|_, _, t, _, _| t.data = tp),
    );
    let cases: [(refl_status, &str, Edit<'_>); 12] = [
        (bad, "`texels` is 95x64", &|_, _, t, _, _| t.width = W - 1),
        (
            refl_status::InsufficientSize,
            "`texels.len`",
            &|_, _, t, _, _| t.len -= 1,
        ),
        (
            refl_status::NullPointer,
            "`texels.data`",
            &|_, _, t, _, _| t.data = core::ptr::null(),
        ),
        (bad, "`color` is 96x63", &|_, _, _, c, _| c.height = H - 1),
        (
            refl_status::NullPointer,
            "`color.data`",
            &|_, _, _, c, _| c.data = core::ptr::null(),
        ),
        (bad, "`out` is 95x64", &|o, _, _, _, _| o.width = W - 1),
        (bad, "`status` is 96x63", &|_, s, _, _, _| s.height = H - 1),
        (
            refl_status::InsufficientSize,
            "`out.len`",
            &|o, _, _, _, _| o.len -= 1,
        ),
        (refl_status::NullPointer, "`out.data`", &|o, _, _, _, _| {
            o.data = core::ptr::null_mut()
        }),
        (bad, "`out` overlaps `color`", &|o, _, _, c, _| {
            o.data = c.data.cast_mut()
        }),
        (bad, "camera", &|_, _, _, _, g| {
            g.depth.camera.fov_y = f32::NAN
        }),
        (
            refl_status::NullPointer,
            "`gbuffer.normals.data`",
            &|_, _, _, _, g| g.normals.data = core::ptr::null(),
        ),
    ];
    for (want, says, edit) in cases {
        refused(name, want, says, &before, || run(o0, all_rows(), edit));
    }
    // The input color is unchanged by the aliased call.
    assert_eq!(bytes(&inp.color), bytes(&inputs(&f, None).color));
    // A NULL host list with a length.
    let mut c = fresh(0);
    let texels = ssr_texels(&inp.texels, W, H);
    // SAFETY: `host` NULL with a length is refused.
    let s = unsafe {
        refl_extrapolate_fill_rows(
            &mut c.stats,
            color_mut(&mut c.out),
            no_u8_mut(),
            core::ptr::null_mut(),
            4,
            &inp.g,
            texels,
            img_vec3(&inp.color),
            &o0,
            all_rows(),
        )
    };
    assert_eq!(s, refl_status::NullPointer);
    assert!(message().contains("`host` is NULL"), "{}", message());
    assert_eq!(c.stats, sentinel_stats());
}
