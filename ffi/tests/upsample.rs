//! refl_upsample_*: `refl_upsample_half_size` is refl-core's
//! `try_half_size`; `refl_upsample_trace_rows` equals refl-core's
//! `HalfPass` bit for bit (both patterns, four frames, every convention;
//! with Hi-Z, each block equals `refl_ssr_trace_rows` at its traced pixel);
//! `refl_upsample_resolve_rows` equals refl-core's `UpsamplePass` bit for
//! bit (options, colors, statuses, re-trace lists long and short); row
//! bands equal one call and leave the other rows untouched; every refusal
//! returns its documented status, names the argument and leaves every
//! output byte as it was; no call allocates.

#[path = "common/gbuffer.rs"]
mod common;
#[path = "common/passes.rs"]
mod passes;

use common::{color_mut, counted, render, Frame, H, W};
use passes::*;
use refl::*;
use refl_core::upsample::{
    try_half_size, HalfPass, Pattern, Subsample, UpsampleOptions, UpsamplePass, UpsampleStats,
    UpsampleStatus,
};
use refl_core::{DepthConvention, HostRay, ImageView, ImageViewMut, MirrorTexel};

const HW: u32 = W / 2;
const HH: u32 = H / 2;
const HN: usize = (HW * HH) as usize;

fn half_vec3_mut(c: &mut [[f32; 3]]) -> refl_image_vec3_mut {
    refl_image_vec3_mut {
        data: c.as_mut_ptr().cast(),
        len: c.len(),
        width: HW,
        height: HH,
        stride: HW,
    }
}

fn half_vec3(c: &[[f32; 3]]) -> refl_image_vec3 {
    refl_image_vec3 {
        data: c.as_ptr().cast(),
        len: c.len(),
        width: HW,
        height: HH,
        stride: HW,
    }
}

fn sub_c(s: Subsample) -> refl_upsample_subsample {
    refl_upsample_subsample {
        pattern: match s.pattern {
            Pattern::Uniform => refl_upsample_pattern::Uniform as u32,
            Pattern::Staggered => refl_upsample_pattern::Staggered as u32,
        },
        frame: s.frame,
    }
}

fn host_bits(r: &refl_host_ray) -> [u32; 11] {
    [
        r.x,
        r.y,
        r.origin.x.to_bits(),
        r.origin.y.to_bits(),
        r.origin.z.to_bits(),
        r.dir.x.to_bits(),
        r.dir.y.to_bits(),
        r.dir.z.to_bits(),
        r.t_min.to_bits(),
        r.t_max.to_bits(),
        r.status,
    ]
}

fn core_host_bits(r: &HostRay) -> [u32; 11] {
    [
        r.x,
        r.y,
        r.origin.x.to_bits(),
        r.origin.y.to_bits(),
        r.origin.z.to_bits(),
        r.dir.x.to_bits(),
        r.dir.y.to_bits(),
        r.dir.z.to_bits(),
        r.t_min.to_bits(),
        r.t_max.to_bits(),
        r.status as u32,
    ]
}

/// What `refl_upsample_trace_rows` writes.
struct Half {
    texels: Vec<refl_ssr_texel>,
    color: Vec<[f32; 3]>,
    host: Vec<refl_host_ray>,
    stats: refl_ssr_stats,
}

fn c_trace(
    g: &refl_gbuffer,
    o: &refl_ssr_options,
    scratch: &[refl_vec2],
    sub: &refl_upsample_subsample,
    rows: refl_row_range,
    h: &mut Half,
) -> (refl_status, u64) {
    let color = half_vec3_mut(&mut h.color);
    let (out, out_len) = (h.texels.as_mut_ptr(), h.texels.len());
    let (host, host_len) = (h.host.as_mut_ptr(), h.host.len());
    let stats = &mut h.stats;
    let sp = if scratch.is_empty() {
        core::ptr::null()
    } else {
        scratch.as_ptr()
    };
    // SAFETY: valid buffers of the stated lengths.
    counted(|| unsafe {
        refl_upsample_trace_rows(
            stats,
            out,
            out_len,
            color,
            host,
            host_len,
            g,
            o,
            sp,
            scratch.len(),
            sub,
            rows,
        )
    })
}

fn fresh_half() -> Half {
    Half {
        texels: vec![sentinel_texel(); HN],
        color: vec![[sentinel_f32(); 3]; HN],
        host: vec![refl_host_ray::default(); HN],
        stats: refl_ssr_stats::default(),
    }
}

fn half_rows() -> refl_row_range {
    refl_row_range { begin: 0, end: HH }
}

fn all_rows() -> refl_row_range {
    refl_row_range { begin: 0, end: H }
}

/// The C half-resolution trace of `sub` over the whole frame.
fn traced(g: &refl_gbuffer, sub: Subsample) -> Half {
    let mut h = fresh_half();
    let o = refl_ssr_options_default();
    let (s, _) = c_trace(g, &o, &[], &sub_c(sub), half_rows(), &mut h);
    assert_eq!(s, refl_status::Ok);
    h
}

/// refl-core's half-resolution trace.
fn core_trace(f: &Frame, sub: Subsample) -> (Vec<MirrorTexel>, Vec<[f32; 3]>) {
    let pass = core_mirror(f);
    let mut t = vec![MirrorTexel::default(); HN];
    let mut c = vec![[0.0f32; 3]; HN];
    HalfPass::new(pass, sub)
        .try_run(
            &mut ImageViewMut::try_new(&mut t, HW, HH, HW).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut c, HW, HH, HW).unwrap()),
            &mut [],
        )
        .unwrap();
    (t, c)
}

fn subsamples() -> Vec<Subsample> {
    (0..4)
        .flat_map(|f| [Subsample::uniform(f), Subsample::staggered(f)])
        .collect()
}

#[test]
fn the_defaults_sizes_and_statuses_are_refl_cores() {
    let d = refl_upsample_options_default();
    assert_eq!(UpsampleOptions::from(d), UpsampleOptions::default());
    for (w, h) in [(1, 1), (2, 3), (7, 8), (W, H), (u32::MAX, 5)] {
        let (mut a, mut b) = (0u32, 0u32);
        // SAFETY: valid outputs.
        let (s, allocs) = counted(|| unsafe { refl_upsample_half_size(&mut a, &mut b, w, h) });
        assert_eq!((s, allocs), (refl_status::Ok, 0));
        assert_eq!((a, b), try_half_size(w, h).unwrap());
    }
    for (w, h) in [(0, 4), (4, 0)] {
        let (mut a, mut b) = (7u32, 9u32);
        // SAFETY: valid outputs.
        let s = unsafe { refl_upsample_half_size(&mut a, &mut b, w, h) };
        assert_eq!((s, a, b), (refl_status::InvalidArgument, 7, 9));
        assert!(message().contains("not at least 1x1"), "{}", message());
    }
    // SAFETY: NULL is refused.
    let s = unsafe { refl_upsample_half_size(core::ptr::null_mut(), &mut 0, 4, 4) };
    assert_eq!(s, refl_status::NullPointer);
    for (s, c) in [
        (UpsampleStatus::Skipped, refl_upsample_status::Skipped),
        (UpsampleStatus::Copied, refl_upsample_status::Copied),
        (
            UpsampleStatus::Interpolated,
            refl_upsample_status::Interpolated,
        ),
        (UpsampleStatus::Retrace, refl_upsample_status::Retrace),
        (UpsampleStatus::Retraced, refl_upsample_status::Retraced),
    ] {
        assert_eq!(refl_upsample_status::from(s), c);
        assert_eq!(s as u32, c as u32);
    }
}

#[test]
fn c_half_trace_equals_the_rust_half_pass_bit_for_bit_without_allocating() {
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let f = render(conv);
        let g = f.gbuffer_c(false);
        let o = refl_ssr_options_default();
        for sub in subsamples() {
            let mut h = fresh_half();
            let (s, allocs) = c_trace(&g, &o, &[], &sub_c(sub), half_rows(), &mut h);
            assert_eq!((s, allocs), (refl_status::Ok, 0), "{conv:?} {sub:?}");
            let pass = core_mirror(&f);
            let half = HalfPass::new(pass, sub);
            let mut t = vec![MirrorTexel::default(); HN];
            let mut c = vec![[0.0f32; 3]; HN];
            let mut host = vec![HostRay::default(); HN];
            let st = half
                .try_run(
                    &mut ImageViewMut::try_new(&mut t, HW, HH, HW).unwrap(),
                    Some(&mut ImageViewMut::try_new(&mut c, HW, HH, HW).unwrap()),
                    &mut host,
                )
                .unwrap();
            assert_eq!(
                [
                    h.stats.traced,
                    h.stats.hits,
                    h.stats.sky,
                    h.stats.host_rays,
                    h.stats.host_rays_written
                ],
                [
                    st.traced,
                    st.hits,
                    st.sky,
                    st.host_rays,
                    st.host_rays_written
                ]
            );
            assert!(st.traced > 1000 && st.host_rays > 0, "{st:?}");
            for i in 0..HN {
                assert_eq!(bits(&h.texels[i]), core_bits(&t[i]), "{sub:?} block {i}");
                assert_eq!(color_bits(&h.color[i]), color_bits(&c[i]), "block {i}");
            }
            let n = st.host_rays_written as usize;
            for (k, (a, b)) in h.host[..n].iter().zip(&host[..n]).enumerate() {
                assert_eq!(host_bits(a), core_host_bits(b), "host {k}");
            }
        }
    }
}

/// With Hi-Z (the pyramid `refl_ssr_prepare` built), each block is what
/// `refl_ssr_trace_rows` writes at the block's traced pixel.
#[test]
fn hiz_blocks_equal_the_full_pass_at_their_traced_pixels() {
    let f = render(DepthConvention::ZeroToOne);
    let g = f.gbuffer_c(false);
    let mut o = refl_ssr_options_default();
    o.method = refl_ssr_method::Hiz as u32;
    let mut len = 0usize;
    // SAFETY: valid pointers.
    assert_eq!(
        unsafe { refl_ssr_scratch_len(&mut len, &g, &o) },
        refl_status::Ok
    );
    let mut scratch = vec![refl_vec2 { x: 0.0, y: 0.0 }; len];
    // SAFETY: valid pointers.
    assert_eq!(
        unsafe { refl_ssr_prepare(scratch.as_mut_ptr(), len, &g, &o) },
        refl_status::Ok
    );
    let mut full = vec![refl_ssr_texel::default(); N];
    let mut st = refl_ssr_stats::default();
    // SAFETY: valid buffers.
    let s = unsafe {
        refl_ssr_trace_rows(
            &mut st,
            full.as_mut_ptr(),
            N,
            common::no_color(),
            core::ptr::null_mut(),
            0,
            &g,
            &o,
            scratch.as_ptr(),
            len,
            all_rows(),
        )
    };
    assert_eq!(s, refl_status::Ok);
    for sub in subsamples() {
        let mut h = fresh_half();
        let (s, allocs) = c_trace(&g, &o, &scratch, &sub_c(sub), half_rows(), &mut h);
        assert_eq!((s, allocs), (refl_status::Ok, 0));
        for by in 0..HH {
            for bx in 0..HW {
                let (x, y) = sub.traced_pixel(bx, by, W, H).unwrap();
                assert_eq!(
                    bits(&h.texels[(by * HW + bx) as usize]),
                    bits(&full[(y * W + x) as usize]),
                    "{sub:?} block ({bx}, {by})"
                );
            }
        }
    }
}

/// What `refl_upsample_resolve_rows` writes.
struct Full {
    texels: Vec<refl_ssr_texel>,
    color: Vec<[f32; 3]>,
    status: Vec<u8>,
    retrace: Vec<refl_image_pixel>,
    stats: refl_upsample_stats,
}

fn sentinel_stats() -> refl_upsample_stats {
    sentinel()
}

fn fresh_full(retrace_len: usize) -> Full {
    let p = sentinel_u32();
    Full {
        texels: vec![sentinel_texel(); N],
        color: vec![[sentinel_f32(); 3]; N],
        status: vec![SENTINEL; N],
        retrace: vec![refl_image_pixel { x: p, y: p }; retrace_len],
        stats: sentinel_stats(),
    }
}

impl Full {
    fn snapshot(&self) -> Vec<u8> {
        [
            bytes(&self.texels),
            bytes(&self.color),
            self.status.clone(),
            bytes(&self.retrace),
            bytes(&[self.stats]),
        ]
        .concat()
    }
}

/// The arguments of one resolve call besides the outputs.
#[derive(Clone, Copy)]
struct Args<'a> {
    g: refl_gbuffer,
    so: refl_ssr_options,
    sub: refl_upsample_subsample,
    half: refl_image_ssr_texel,
    half_color: refl_image_vec3,
    o: refl_upsample_options,
    rows: refl_row_range,
    _life: core::marker::PhantomData<&'a ()>,
}

fn args<'a>(g: refl_gbuffer, sub: Subsample, h: &'a Half, o: refl_upsample_options) -> Args<'a> {
    Args {
        g,
        so: refl_ssr_options_default(),
        sub: sub_c(sub),
        half: ssr_texels(&h.texels, HW, HH),
        half_color: half_vec3(&h.color),
        o,
        rows: all_rows(),
        _life: core::marker::PhantomData,
    }
}

/// One resolve call into `r` (no color / status outputs unless asked).
fn c_resolve(
    r: &mut Full,
    a: &Args<'_>,
    with_color: bool,
    with_status: bool,
    edit: &dyn Fn(&mut refl_image_vec3_mut, &mut refl_image_u8_mut),
) -> (refl_status, u64) {
    let mut color = if with_color {
        color_mut(&mut r.color)
    } else {
        common::no_color()
    };
    let mut status = if with_status {
        u8_mut(&mut r.status)
    } else {
        no_u8_mut()
    };
    edit(&mut color, &mut status);
    let (out, out_len) = (r.texels.as_mut_ptr(), r.texels.len());
    let (list, list_len) = (r.retrace.as_mut_ptr(), r.retrace.len());
    let stats = &mut r.stats;
    // SAFETY: valid buffers of the stated lengths (or the defect under
    // test, refused before any access).
    counted(|| unsafe {
        refl_upsample_resolve_rows(
            stats,
            out,
            out_len,
            color,
            status,
            list,
            list_len,
            &a.g,
            &a.so,
            core::ptr::null(),
            0,
            &a.sub,
            a.half,
            a.half_color,
            &a.o,
            a.rows,
        )
    })
}

fn stats_of(s: &UpsampleStats) -> refl_upsample_stats {
    refl_upsample_stats {
        copied: s.copied,
        interpolated: s.interpolated,
        retrace: s.retrace,
        retrace_written: s.retrace_written,
        retraced: s.retraced,
        hits: s.hits,
    }
}

#[test]
fn c_resolve_equals_the_rust_upsample_pass_bit_for_bit_without_allocating() {
    let d = refl_upsample_options_default();
    let opts = [
        d,
        refl_upsample_options {
            plane_depth: true,
            ..d
        },
        refl_upsample_options {
            retrace_mixed: true,
            depth_threshold: 0.002,
            ..d
        },
        refl_upsample_options {
            retrace: true,
            retrace_mixed: true,
            depth_threshold: 0.002,
            ..d
        },
        refl_upsample_options {
            shade_hits: false,
            depth_threshold: f32::INFINITY,
            depth_sigma: f32::INFINITY,
            normal_power: 1.5,
            ..d
        },
    ];
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let f = render(conv);
        let g = f.gbuffer_c(false);
        for sub in [
            Subsample::uniform(0),
            Subsample::staggered(1),
            Subsample::uniform(3),
        ] {
            let h = traced(&g, sub);
            let (ct, cc) = core_trace(&f, sub);
            for o in opts {
                let up = UpsamplePass::try_new(
                    core_mirror(&f),
                    sub,
                    ImageView::try_new(&ct, HW, HH, HW).unwrap(),
                    Some(ImageView::try_new(&cc, HW, HH, HW).unwrap()),
                    o.into(),
                )
                .unwrap();
                for list_len in [N, 3] {
                    let mut t = vec![MirrorTexel::default(); N];
                    let mut c = vec![[0.0f32; 3]; N];
                    let mut s = vec![0u8; N];
                    let mut l = vec![[0u32; 2]; list_len];
                    let st = up
                        .try_run(
                            &mut ImageViewMut::try_new(&mut t, W, H, W).unwrap(),
                            Some(&mut ImageViewMut::try_new(&mut c, W, H, W).unwrap()),
                            Some(&mut ImageViewMut::try_new(&mut s, W, H, W).unwrap()),
                            &mut l,
                        )
                        .unwrap();
                    for (with_color, with_status) in [(true, true), (false, false)] {
                        let a = args(g, sub, &h, o);
                        let mut r = fresh_full(list_len);
                        let (status, allocs) =
                            c_resolve(&mut r, &a, with_color, with_status, &|_, _| {});
                        assert_eq!((status, allocs), (refl_status::Ok, 0), "{conv:?} {o:?}");
                        assert_eq!(r.stats, stats_of(&st), "{conv:?} {sub:?} {o:?}");
                        for i in 0..N {
                            assert_eq!(bits(&r.texels[i]), core_bits(&t[i]), "pixel {i}");
                            if with_color {
                                assert_eq!(color_bits(&r.color[i]), color_bits(&c[i]));
                            }
                        }
                        if with_status {
                            assert_eq!(r.status, s);
                        } else {
                            assert!(r.status.iter().all(|&b| b == SENTINEL));
                            assert!(bytes(&r.color).iter().all(|&b| b == SENTINEL));
                        }
                        let n = r.stats.retrace_written as usize;
                        let got: Vec<[u32; 2]> =
                            r.retrace[..n].iter().map(|p| [p.x, p.y]).collect();
                        assert_eq!(got, l[..n]);
                        assert!(bytes(&r.retrace[n..]).iter().all(|&b| b == SENTINEL));
                    }
                    // The frame reconstructs most pixels; a tight depth
                    // edge lists some.
                    assert!(st.copied > 1000 && st.interpolated > 1000, "{st:?}");
                    if o.depth_threshold < 0.01 {
                        assert!(st.retrace > 100, "{st:?}");
                    }
                    if o.retrace {
                        assert_eq!(st.retraced, st.retrace);
                    }
                }
            }
        }
    }
}

#[test]
fn bands_equal_one_call_and_leave_other_rows_untouched() {
    let f = render(DepthConvention::ReversedZ);
    let g = f.gbuffer_c(false);
    let sub = Subsample::staggered(2);
    let h = traced(&g, sub);
    let o = refl_upsample_options {
        depth_threshold: 0.002,
        ..refl_upsample_options_default()
    };
    let a = args(g, sub, &h, o);
    let mut whole = fresh_full(N);
    assert_eq!(
        c_resolve(&mut whole, &a, true, true, &|_, _| {}).0,
        refl_status::Ok
    );
    let wn = whole.stats.retrace_written as usize;
    assert!(wn > 100, "{:?}", whole.stats);
    for k in [1, 17, H / 2, H - 1] {
        let mut r = fresh_full(N);
        let mut list = Vec::new();
        let mut sum = [0u32; 6];
        for band in [
            refl_row_range { begin: 0, end: k },
            refl_row_range { begin: k, end: H },
        ] {
            let ab = Args { rows: band, ..a };
            assert_eq!(
                c_resolve(&mut r, &ab, true, true, &|_, _| {}).0,
                refl_status::Ok
            );
            let s = r.stats;
            for (t, v) in sum.iter_mut().zip([
                s.copied,
                s.interpolated,
                s.retrace,
                s.retrace_written,
                s.retraced,
                s.hits,
            ]) {
                *t += v;
            }
            list.extend_from_slice(&r.retrace[..s.retrace_written as usize]);
            if band.begin == 0 {
                let split = (k * W) as usize;
                assert!(bytes(&r.texels[split..]).iter().all(|&b| b == SENTINEL));
                assert!(bytes(&r.color[split..]).iter().all(|&b| b == SENTINEL));
                assert!(r.status[split..].iter().all(|&b| b == SENTINEL));
            }
        }
        let w = whole.stats;
        assert_eq!(
            sum,
            [
                w.copied,
                w.interpolated,
                w.retrace,
                w.retrace_written,
                w.retraced,
                w.hits
            ]
        );
        assert_eq!(list, whole.retrace[..wn]);
        assert_eq!(bytes(&r.texels), bytes(&whole.texels), "band at {k}");
        assert_eq!(bytes(&r.color), bytes(&whole.color), "band at {k}");
        assert_eq!(r.status, whole.status, "band at {k}");
    }
    // Half-resolution bands of the trace equal one call.
    let o = refl_ssr_options_default();
    let mut hb = fresh_half();
    for band in [
        refl_row_range { begin: 0, end: 5 },
        refl_row_range { begin: 5, end: HH },
    ] {
        let (s, _) = c_trace(&g, &o, &[], &sub_c(sub), band, &mut hb);
        assert_eq!(s, refl_status::Ok);
        if band.begin == 0 {
            let split = (5 * HW) as usize;
            assert!(bytes(&hb.texels[split..]).iter().all(|&b| b == SENTINEL));
        }
    }
    assert_eq!(bytes(&hb.texels), bytes(&h.texels));
    assert_eq!(bytes(&hb.color), bytes(&h.color));
}

#[test]
fn refusals_name_the_argument_and_write_nothing() {
    let f = render(DepthConvention::Linear);
    let g0 = f.gbuffer_c(false);
    let sub = Subsample::uniform(0);
    let h = traced(&g0, sub);
    let a0 = args(g0, sub, &h, refl_upsample_options_default());
    let before = fresh_full(8).snapshot();
    let name = "refl_upsample_resolve_rows";
    let bad = refl_status::InvalidArgument;
    let run = |a: Args<'_>, edit: &dyn Fn(&mut refl_image_vec3_mut, &mut refl_image_u8_mut)| {
        let mut r = fresh_full(8);
        let (s, allocs) = c_resolve(&mut r, &a, true, true, edit);
        (s, r.snapshot(), allocs)
    };
    let none = |_: &mut refl_image_vec3_mut, _: &mut refl_image_u8_mut| {};
    let o0 = a0.o;
    let mut bad_status = h.texels.clone();
    bad_status[7].status = 99;
    let short_half = &h.texels[..HN - 1];
    let mut other_color = h.color.clone();
    other_color.truncate(HN - HW as usize);
    let cases: Vec<(refl_status, &str, Args<'_>)> = vec![
        (
            bad,
            "`options.depth_threshold`",
            Args {
                o: refl_upsample_options {
                    depth_threshold: 0.0,
                    ..o0
                },
                ..a0
            },
        ),
        (
            bad,
            "`options.depth_sigma`",
            Args {
                o: refl_upsample_options {
                    depth_sigma: f32::NAN,
                    ..o0
                },
                ..a0
            },
        ),
        (
            bad,
            "`options.normal_power`",
            Args {
                o: refl_upsample_options {
                    normal_power: -1.0,
                    ..o0
                },
                ..a0
            },
        ),
        (
            bad,
            "`subsample.pattern`",
            Args {
                sub: refl_upsample_subsample {
                    pattern: 2,
                    frame: 0,
                },
                ..a0
            },
        ),
        (
            bad,
            "`options.method`",
            Args {
                so: refl_ssr_options { method: 5, ..a0.so },
                ..a0
            },
        ),
        (
            bad,
            "`rows`",
            Args {
                rows: refl_row_range { begin: 2, end: 1 },
                ..a0
            },
        ),
        (
            bad,
            "`rows`",
            Args {
                rows: refl_row_range {
                    begin: 0,
                    end: H + 1,
                },
                ..a0
            },
        ),
        (
            bad,
            "`half` texel 7 has status 99",
            Args {
                half: ssr_texels(&bad_status, HW, HH),
                ..a0
            },
        ),
        (
            refl_status::InsufficientSize,
            "`half.len`",
            Args {
                half: ssr_texels(short_half, HW, HH),
                ..a0
            },
        ),
        (
            bad,
            "`half` is 47x32, not the half size 48x32 of the 96x64 G-buffer",
            Args {
                half: refl_image_ssr_texel {
                    width: HW - 1,
                    stride: HW - 1,
                    ..a0.half
                },
                ..a0
            },
        ),
        (
            bad,
            "`half_color` is 48x31, not the half size",
            Args {
                half_color: refl_image_vec3 {
                    height: HH - 1,
                    ..half_vec3(&other_color)
                },
                ..a0
            },
        ),
        (
            refl_status::NullPointer,
            "`half.data`",
            Args {
                half: refl_image_ssr_texel {
                    data: core::ptr::null(),
                    ..a0.half
                },
                ..a0
            },
        ),
        (
            bad,
            "`color` is given without `half_color`",
            Args {
                half_color: no_vec3(),
                ..a0
            },
        ),
    ];
    for (want, says, a) in cases {
        refused(name, want, says, &before, || run(a, &none));
    }
    // A NULL required image is reported before an unknown pattern (fuzz
    // finding F33).
    let mut g = g0;
    g.normals.data = core::ptr::null();
    refused(
        name,
        refl_status::NullPointer,
        "`gbuffer.normals.data`",
        &before,
        || {
            run(
                Args {
                    g,
                    sub: refl_upsample_subsample {
                        pattern: 9,
                        frame: 0,
                    },
                    ..a0
                },
                &none,
            )
        },
    );
    let mut g = g0;
    g.depth.camera.fov_y = f32::NAN;
    refused(name, bad, "camera", &before, || {
        run(Args { g, ..a0 }, &none)
    });
    refused(name, bad, "`status` is 96x63", &before, || {
        run(a0, &|_, s| s.height = H - 1)
    });
    refused(name, bad, "`color`", &before, || {
        run(a0, &|c, _| c.width = W - 1)
    });
    let hp = h.color.as_ptr();
    refused(name, bad, "overlaps", &before, || {
        run(a0, &|c, _| c.data = hp as *mut _)
    });
    let hs = h.texels.as_ptr();
    refused(name, bad, "`status` overlaps `half`", &before, || {
        run(a0, &|_, s| s.data = hs as *mut u8)
    });

    // The trace's refusals.
    let tname = "refl_upsample_trace_rows";
    let o = refl_ssr_options_default();
    let hbefore = {
        let h = fresh_half();
        [bytes(&h.texels), bytes(&h.color), bytes(&h.host)].concat()
    };
    let trace = |g: &refl_gbuffer, sub: refl_upsample_subsample, rows: refl_row_range| {
        let mut h = fresh_half();
        let (s, allocs) = c_trace(g, &o, &[], &sub, rows, &mut h);
        (
            s,
            [bytes(&h.texels), bytes(&h.color), bytes(&h.host)].concat(),
            allocs,
        )
    };
    let s0 = sub_c(sub);
    refused(tname, bad, "`subsample.pattern`", &hbefore, || {
        trace(
            &g0,
            refl_upsample_subsample { pattern: 9, ..s0 },
            half_rows(),
        )
    });
    let mut g = g0;
    g.depth.depth.data = core::ptr::null();
    refused(
        tname,
        refl_status::NullPointer,
        "`gbuffer.depth.depth.data`",
        &hbefore,
        || {
            trace(
                &g,
                refl_upsample_subsample { pattern: 9, ..s0 },
                half_rows(),
            )
        },
    );
    refused(tname, bad, "`rows`", &hbefore, || {
        trace(
            &g0,
            s0,
            refl_row_range {
                begin: 0,
                end: HH + 1,
            },
        )
    });
    let mut g = g0;
    g.color.data = core::ptr::null();
    refused(
        tname,
        bad,
        "`color` needs a G-buffer color",
        &hbefore,
        || trace(&g, s0, half_rows()),
    );
    let mut h = fresh_half();
    // SAFETY: `subsample` NULL is refused.
    let s = unsafe {
        refl_upsample_trace_rows(
            &mut h.stats,
            h.texels.as_mut_ptr(),
            HN,
            common::no_color(),
            core::ptr::null_mut(),
            0,
            &g0,
            &o,
            core::ptr::null(),
            0,
            core::ptr::null(),
            half_rows(),
        )
    };
    assert_eq!(s, refl_status::NullPointer);
    assert!(message().contains("`subsample` is NULL"), "{}", message());
    // An output of too few half-resolution texels.
    let mut h = fresh_half();
    // SAFETY: valid buffers; `out_len` too small is refused.
    let s = unsafe {
        refl_upsample_trace_rows(
            &mut h.stats,
            h.texels.as_mut_ptr(),
            HN - 1,
            common::no_color(),
            core::ptr::null_mut(),
            0,
            &g0,
            &o,
            core::ptr::null(),
            0,
            &s0,
            half_rows(),
        )
    };
    assert_eq!(s, refl_status::InsufficientSize);
    assert!(message().contains("`out_len` is 1535"), "{}", message());
    assert!(bytes(&h.texels).iter().all(|&b| b == SENTINEL));
}
