//! refl_bounce_*: the C pass equals refl-core's `BouncePass` bit for bit
//! (every depth convention, a moved camera, several attenuations, with and
//! without a status image), two row bands equal one call and leave the
//! other rows untouched, every refusal returns its documented status,
//! names the argument in the last-error message and leaves every output
//! byte as it was, and no call allocates (`tests/alloc.rs` covers the
//! export too).

#[path = "common/gbuffer.rs"]
mod common;
#[path = "common/passes.rs"]
mod passes;

use common::{color_mut, counted, img_vec3, moved_camera, render, render_with, Frame, H, W};
use passes::*;
use refl::*;
use refl_core::bounce::{BounceOptions, BouncePass, BounceStats, BounceStatus, PreviousFrame};
use refl_core::{DepthConvention, DepthImage, ImageView, ImageViewMut};

/// The previous frame's final image: its lit color with a reflection-like
/// tint, a NaN texel now and then.
fn final_color(f: &Frame) -> Vec<[f32; 3]> {
    f.color
        .iter()
        .enumerate()
        .map(|(i, c)| {
            if i % 89 == 7 {
                [f32::NAN, 0.0, 0.0]
            } else {
                [c[0] * 0.5 + 0.25, c[1] + 0.125, 1.0 - c[2]]
            }
        })
        .collect()
}

/// The two frames of a test.
struct Frames {
    prev: Frame,
    cur: Frame,
    last: Vec<[f32; 3]>,
}

fn frames(conv: DepthConvention) -> Frames {
    let prev = render(conv);
    let last = final_color(&prev);
    Frames {
        cur: render_with(moved_camera(), conv),
        prev,
        last,
    }
}

fn previous_c(fr: &Frames) -> refl_bounce_previous {
    refl_bounce_previous {
        depth: fr.prev.gbuffer_c(false).depth,
        color: img_vec3(&fr.last),
    }
}

struct CRun {
    out: Vec<[f32; 3]>,
    status: Vec<u8>,
    stats: refl_bounce_stats,
}

fn sentinel_stats() -> refl_bounce_stats {
    sentinel()
}

fn fresh() -> CRun {
    let v = sentinel_f32();
    CRun {
        out: vec![[v; 3]; N],
        status: vec![SENTINEL; N],
        stats: sentinel_stats(),
    }
}

/// One C call over `rows` into `r`.
fn c_call(
    r: &mut CRun,
    g: &refl_gbuffer,
    p: &refl_bounce_previous,
    o: &refl_bounce_options,
    with_status: bool,
    rows: refl_row_range,
) -> (refl_status, u64) {
    let out = color_mut(&mut r.out);
    let status = if with_status {
        u8_mut(&mut r.status)
    } else {
        no_u8_mut()
    };
    let stats = &mut r.stats;
    // SAFETY: valid buffers of the stated lengths, outputs disjoint from
    // the inputs.
    counted(|| unsafe { refl_bounce_source_rows(stats, out, status, g, p, o, rows) })
}

fn all_rows() -> refl_row_range {
    refl_row_range { begin: 0, end: H }
}

fn rust_run(fr: &Frames, o: BounceOptions) -> (Vec<[f32; 3]>, Vec<u8>, BounceStats) {
    let p = &fr.prev;
    let depth = DepthImage::try_new(
        ImageView::try_new(&p.depth, W, H, W).unwrap(),
        p.cam,
        p.conv,
    )
    .unwrap();
    let previous =
        PreviousFrame::try_new(depth, ImageView::try_new(&fr.last, W, H, W).unwrap()).unwrap();
    let pass = BouncePass::try_new(fr.cur.gbuffer(false), previous, o).unwrap();
    let mut out = vec![[0.0f32; 3]; N];
    let mut status = vec![0u8; N];
    let stats = pass
        .try_run(
            &mut ImageViewMut::try_new(&mut out, W, H, W).unwrap(),
            Some(&mut ImageViewMut::try_new(&mut status, W, H, W).unwrap()),
        )
        .unwrap();
    (out, status, stats)
}

fn stats_of(s: &BounceStats) -> refl_bounce_stats {
    refl_bounce_stats {
        reprojected: s.reprojected,
        rejected: s.rejected,
        off_screen: s.off_screen,
        no_surface: s.no_surface,
    }
}

#[test]
fn the_defaults_and_statuses_are_refl_cores() {
    let d = refl_bounce_options_default();
    assert_eq!(BounceOptions::from(d), BounceOptions::default());
    assert_eq!((d.attenuation, d.depth_tolerance), (1.0, 0.02));
    for (s, c) in [
        (BounceStatus::NoSurface, refl_bounce_status::NoSurface),
        (BounceStatus::Reprojected, refl_bounce_status::Reprojected),
        (BounceStatus::OffScreen, refl_bounce_status::OffScreen),
        (BounceStatus::Rejected, refl_bounce_status::Rejected),
    ] {
        assert_eq!(refl_bounce_status::from(s), c);
        assert_eq!(s as u32, c as u32);
    }
}

#[test]
fn c_pass_equals_the_rust_pass_bit_for_bit_without_allocating() {
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let fr = frames(conv);
        let g = fr.cur.gbuffer_c(false);
        let p = previous_c(&fr);
        let d = refl_bounce_options_default();
        for o in [
            d,
            refl_bounce_options {
                attenuation: 0.5,
                ..d
            },
            refl_bounce_options {
                attenuation: 0.0,
                depth_tolerance: 0.0,
            },
        ] {
            let want = rust_run(&fr, o.into());
            for with_status in [true, false] {
                let mut r = fresh();
                let (s, allocs) = c_call(&mut r, &g, &p, &o, with_status, all_rows());
                assert_eq!((s, allocs), (refl_status::Ok, 0), "{conv:?} {o:?}");
                assert_eq!(r.stats, stats_of(&want.2), "{conv:?} {o:?}");
                for i in 0..N {
                    assert_eq!(color_bits(&r.out[i]), color_bits(&want.0[i]), "pixel {i}");
                }
                if with_status {
                    assert_eq!(r.status, want.1);
                } else {
                    assert!(r.status.iter().all(|&b| b == SENTINEL));
                }
            }
            // The frame exercises every status (tolerance 0 rejects
            // nearly everything).
            let st = stats_of(&want.2);
            assert!(
                o.depth_tolerance == 0.0
                    || (st.reprojected > 4000
                        && st.off_screen > 0
                        && st.no_surface > 0
                        && st.rejected > 0),
                "{conv:?}: {st:?}"
            );
            if o.attenuation == 0.0 {
                // One bounce: the source is the lit color.
                assert!(want
                    .0
                    .iter()
                    .zip(&fr.cur.color)
                    .all(|(a, b)| color_bits(a) == color_bits(b)));
            }
        }
    }
}

#[test]
fn bands_equal_one_call_and_leave_other_rows_untouched() {
    let fr = frames(DepthConvention::ReversedZ);
    let (g, p, o) = (
        fr.cur.gbuffer_c(false),
        previous_c(&fr),
        refl_bounce_options {
            attenuation: 0.75,
            ..refl_bounce_options_default()
        },
    );
    let mut whole = fresh();
    assert_eq!(
        c_call(&mut whole, &g, &p, &o, true, all_rows()).0,
        refl_status::Ok
    );
    for k in [1, 17, H / 2, H - 1] {
        let mut r = fresh();
        let mut sum = refl_bounce_stats::default();
        for band in [
            refl_row_range { begin: 0, end: k },
            refl_row_range { begin: k, end: H },
        ] {
            assert_eq!(c_call(&mut r, &g, &p, &o, true, band).0, refl_status::Ok);
            sum.reprojected += r.stats.reprojected;
            sum.rejected += r.stats.rejected;
            sum.off_screen += r.stats.off_screen;
            sum.no_surface += r.stats.no_surface;
            if band.begin == 0 {
                let split = (k * W) as usize;
                assert!(bytes(&r.out[split..]).iter().all(|&b| b == SENTINEL));
                assert!(r.status[split..].iter().all(|&b| b == SENTINEL));
            }
        }
        assert_eq!(sum, whole.stats, "band at {k}");
        assert_eq!(bytes(&r.out), bytes(&whole.out), "band at {k}");
        assert_eq!(r.status, whole.status, "band at {k}");
    }
}

#[test]
fn refusals_name_the_argument_and_write_nothing() {
    let fr = frames(DepthConvention::Linear);
    let g0 = fr.cur.gbuffer_c(false);
    let p0 = previous_c(&fr);
    let o0 = refl_bounce_options_default();
    let before = {
        let r = fresh();
        [bytes(&r.out), r.status.clone(), bytes(&[r.stats])].concat()
    };
    let run = |g: refl_gbuffer,
               p: refl_bounce_previous,
               o: refl_bounce_options,
               rows: refl_row_range,
               edit: &dyn Fn(&mut refl_image_vec3_mut, &mut refl_image_u8_mut)| {
        let mut r = fresh();
        let mut out = color_mut(&mut r.out);
        let mut status = u8_mut(&mut r.status);
        edit(&mut out, &mut status);
        // SAFETY: valid buffers (or the defect under test, which the call
        // refuses before reading or writing).
        let stats = &mut r.stats;
        let (s, allocs) =
            counted(|| unsafe { refl_bounce_source_rows(stats, out, status, &g, &p, &o, rows) });
        (
            s,
            [bytes(&r.out), r.status.clone(), bytes(&[r.stats])].concat(),
            allocs,
        )
    };
    let name = "refl_bounce_source_rows";
    let none = |_: &mut refl_image_vec3_mut, _: &mut refl_image_u8_mut| {};
    let bad = refl_status::InvalidArgument;
    // Options.
    for (o, says) in [
        (
            refl_bounce_options {
                attenuation: f32::NAN,
                ..o0
            },
            "`options.attenuation`",
        ),
        (
            refl_bounce_options {
                attenuation: 1.5,
                ..o0
            },
            "`options.attenuation`",
        ),
        (
            refl_bounce_options {
                depth_tolerance: -1.0,
                ..o0
            },
            "`options.depth_tolerance`",
        ),
        (
            refl_bounce_options {
                depth_tolerance: f32::INFINITY,
                ..o0
            },
            "`options.depth_tolerance`",
        ),
    ] {
        refused(name, bad, says, &before, || {
            run(g0, p0, o, all_rows(), &none)
        });
    }
    // Rows.
    for rows in [
        refl_row_range { begin: 3, end: 2 },
        refl_row_range {
            begin: 0,
            end: H + 1,
        },
    ] {
        refused(name, bad, "`rows`", &before, || {
            run(g0, p0, o0, rows, &none)
        });
    }
    // The G-buffer without its lit color, NULL images.
    let mut g = g0;
    g.color.data = core::ptr::null();
    refused(
        name,
        refl_status::NullPointer,
        "`gbuffer.color.data`",
        &before,
        || run(g, p0, o0, all_rows(), &none),
    );
    let mut p = p0;
    p.color.data = core::ptr::null();
    refused(
        name,
        refl_status::NullPointer,
        "`previous.color.data`",
        &before,
        || run(g0, p, o0, all_rows(), &none),
    );
    let mut p = p0;
    p.depth.depth.data = core::ptr::null();
    refused(
        name,
        refl_status::NullPointer,
        "`previous.depth.depth.data`",
        &before,
        || run(g0, p, o0, all_rows(), &none),
    );
    // The previous color not of its camera's size, short, a bad camera.
    let mut p = p0;
    p.color.width = W - 1;
    refused(name, bad, "`previous.color` is 95x64", &before, || {
        run(g0, p, o0, all_rows(), &none)
    });
    let mut p = p0;
    p.color.len -= 1;
    refused(
        name,
        refl_status::InsufficientSize,
        "`previous.color.len`",
        &before,
        || run(g0, p, o0, all_rows(), &none),
    );
    let mut p = p0;
    p.depth.camera.fov_y = f32::NAN;
    refused(name, bad, "`previous.depth.camera", &before, || {
        run(g0, p, o0, all_rows(), &none)
    });
    let mut p = p0;
    p.depth.convention = 7;
    refused(name, bad, "convention", &before, || {
        run(g0, p, o0, all_rows(), &none)
    });
    // Outputs of another size, NULL, short, aliasing an input.
    refused(name, bad, "`out` is 95x64", &before, || {
        run(g0, p0, o0, all_rows(), &|o, _| o.width = W - 1)
    });
    refused(name, bad, "`status` is 96x63", &before, || {
        run(g0, p0, o0, all_rows(), &|_, s| s.height = H - 1)
    });
    refused(
        name,
        refl_status::InsufficientSize,
        "`out.len`",
        &before,
        || run(g0, p0, o0, all_rows(), &|o, _| o.len -= 1),
    );
    refused(
        name,
        refl_status::NullPointer,
        "`out.data`",
        &before,
        || {
            run(g0, p0, o0, all_rows(), &|o, _| {
                o.data = core::ptr::null_mut()
            })
        },
    );
    let lit = fr.cur.color.as_ptr();
    // `out` over the G-buffer's lit color: refused before anything is
    // written (the lit color is then compared unchanged too).
    let lit_before = bytes(&fr.cur.color);
    refused(name, bad, "`out` overlaps `gbuffer.color`", &before, || {
        run(g0, p0, o0, all_rows(), &|o, _| o.data = lit as *mut _)
    });
    assert_eq!(bytes(&fr.cur.color), lit_before);
    let last = fr.last.as_ptr();
    refused(
        name,
        bad,
        "`out` overlaps `previous.color`",
        &before,
        || run(g0, p0, o0, all_rows(), &|o, _| o.data = last as *mut _),
    );
    // NULL arguments.
    let mut r = fresh();
    // SAFETY: NULL pointers are refused.
    let s = unsafe {
        refl_bounce_source_rows(
            &mut r.stats,
            color_mut(&mut r.out),
            no_u8_mut(),
            &g0,
            core::ptr::null(),
            &o0,
            all_rows(),
        )
    };
    assert_eq!(s, refl_status::NullPointer);
    assert!(message().contains("`previous` is NULL"), "{}", message());
    assert_eq!(r.stats, sentinel_stats());
}
