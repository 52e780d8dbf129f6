//! refl_summary_* / refl_summary_rows / refl_*_summary_merge /
//! refl_summary_object_plane: the C calls equal refl-core's
//! `summary` functions bit for bit (every convention, whole image and tile
//! bands merged), errors return their documented status and leave every
//! output untouched, and no export allocates.
#![cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]

use refl::*;
use refl_core::summary::{try_summarize_rows, FrameSummary, ObjectSummary, SummaryOptions};
use refl_core::{DepthConvention, ImageView, RowRange};
#[path = "common/gbuffer.rs"]
mod common;
use common::{counted, render, Frame, H, W};

fn ids_c(f: &Frame) -> refl_image_u32 {
    refl_image_u32 {
        data: f.ids.as_ptr(),
        len: f.ids.len(),
        width: W,
        height: H,
        stride: W,
    }
}

fn no_ids() -> refl_image_u32 {
    refl_image_u32 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

fn last_error() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: valid buffer.
    let k = unsafe { refl_last_error_message(buf.as_mut_ptr().cast(), buf.len()) };
    String::from_utf8_lossy(&buf[..k.min(255)]).to_string()
}

fn c_summary(
    f: &Frame,
    ids: refl_image_u32,
    rows: refl_row_range,
    o: &refl_summary_options,
) -> (
    refl_status,
    refl_summary_frame,
    [refl_summary_object; 2],
    u64,
) {
    let g = f.gbuffer_c(false);
    let mut frame = refl_summary_frame::default();
    let mut objects = [refl_summary_object::default(); 2];
    let (s, allocs) = counted(|| {
        // SAFETY: valid pointers and images.
        unsafe { refl_summary_rows(&mut frame, objects.as_mut_ptr(), 2, &g, ids, o, rows) }
    });
    (s, frame, objects, allocs)
}

#[test]
fn options_default_is_the_rust_default() {
    let c = refl_summary_options_default();
    assert_eq!(SummaryOptions::from(c), SummaryOptions::default());
}

#[test]
fn c_summary_equals_the_rust_summary_bit_for_bit_without_allocating() {
    for conv in [
        DepthConvention::Linear,
        DepthConvention::ZeroToOne,
        DepthConvention::ReversedZ,
    ] {
        let f = render(conv);
        let o = refl_summary_options_default();
        let (s, frame, objects, allocs) =
            c_summary(&f, ids_c(&f), refl_row_range { begin: 0, end: H }, &o);
        assert_eq!(s, refl_status::Ok, "{}", last_error());
        assert_eq!(allocs, 0);
        let g = f.gbuffer(false);
        let (mut rf, mut ro) = (FrameSummary::default(), [ObjectSummary::default(); 2]);
        let v = ImageView::try_new(&f.ids, W, H, W).unwrap();
        try_summarize_rows(
            &mut rf,
            &mut ro,
            &g,
            Some(&v),
            RowRange::try_all(H).unwrap(),
            &o.into(),
        )
        .unwrap();
        assert_eq!(FrameSummary::from(frame), rf);
        for k in 0..2 {
            assert_eq!(ObjectSummary::from(objects[k]), ro[k], "object {k}");
        }
        assert!(frame.reflective > 1000 && objects[0].pixels > 500 && objects[1].pixels > 100);
        // The floor is a plane, the sphere is not.
        let mut fit = refl_summary_plane_fit::default();
        // SAFETY: valid pointers.
        let s = unsafe { refl_summary_object_plane(&mut fit, &objects[0], &o) };
        assert_eq!(s, refl_status::Ok);
        assert!(fit.planar, "{fit:?}");
        assert!((fit.normal[1] - 1.0).abs() < 1e-9, "{fit:?}");
        // SAFETY: valid pointers.
        let s = unsafe { refl_summary_object_plane(&mut fit, &objects[1], &o) };
        assert_eq!(s, refl_status::Ok);
        assert!(!fit.planar, "{fit:?}");
        // Without ids every pixel is object 0.
        let (s, all, objs, _) = c_summary(&f, no_ids(), refl_row_range { begin: 0, end: H }, &o);
        assert_eq!(s, refl_status::Ok);
        assert_eq!(all.reflective, frame.reflective);
        assert_eq!(objs[0].pixels, frame.reflective);
        assert_eq!(objs[1].pixels, 0);
    }
}

#[test]
fn tile_bands_merged_equal_one_call() {
    let f = render(DepthConvention::ReversedZ);
    let o = refl_summary_options_default();
    let (_, whole, whole_o, _) = c_summary(&f, ids_c(&f), refl_row_range { begin: 0, end: H }, &o);
    let mut frame = refl_summary_frame::default();
    let mut objects = [refl_summary_object::default(); 2];
    let mut y = 0;
    while y < H {
        let rows = refl_row_range {
            begin: y,
            end: (y + 2 * REFL_SUMMARY_TILE).min(H),
        };
        let (s, bf, bo, _) = c_summary(&f, ids_c(&f), rows, &o);
        assert_eq!(s, refl_status::Ok, "{}", last_error());
        // SAFETY: valid pointers.
        unsafe {
            assert_eq!(refl_summary_merge_frame(&mut frame, &bf), refl_status::Ok);
            for k in 0..2 {
                assert_eq!(
                    refl_summary_merge_object(&mut objects[k], &bo[k]),
                    refl_status::Ok
                );
            }
        }
        y += 2 * REFL_SUMMARY_TILE;
    }
    assert_eq!(frame, whole);
    for k in 0..2 {
        let (a, b) = (objects[k], whole_o[k]);
        assert_eq!(
            (a.pixels, a.classes, a.border_pixels, a.rect),
            (b.pixels, b.classes, b.border_pixels, b.rect)
        );
        let (mut fa, mut fb) = (
            refl_summary_plane_fit::default(),
            refl_summary_plane_fit::default(),
        );
        // SAFETY: valid pointers.
        unsafe {
            refl_summary_object_plane(&mut fa, &a, &o);
            refl_summary_object_plane(&mut fb, &b, &o);
        }
        assert_eq!(fa.planar, fb.planar);
        assert!((fa.rms_distance - fb.rms_distance).abs() < 1e-9);
    }
}

use refl_status::{
    DegenerateGeometry as Degenerate, InsufficientSize as Short, InvalidArgument as Bad,
    NullPointer as Null,
};

/// A frame summary no export writes.
fn frame_sentinel() -> refl_summary_frame {
    refl_summary_frame {
        pixels: 77,
        ..Default::default()
    }
}

/// Runs `refl_summary_rows` on sentinel outputs (`k` objects, or a NULL
/// object list), expects status `want`, no allocation, both outputs
/// untouched and a last error naming the call.
fn run(
    want: refl_status,
    gb: *const refl_gbuffer,
    ids: refl_image_u32,
    o: *const refl_summary_options,
    rows: refl_row_range,
    k: usize,
    null_objects: bool,
) {
    let sentinel_f = frame_sentinel();
    let sentinel_o = object_sentinel();
    let mut frame = sentinel_f;
    let mut objects = [sentinel_o; 2];
    let p = if null_objects {
        core::ptr::null_mut()
    } else {
        objects.as_mut_ptr()
    };
    let (s, allocs) = counted(|| {
        // SAFETY: valid or NULL pointers.
        unsafe { refl_summary_rows(&mut frame, p, k, gb, ids, o, rows) }
    });
    assert_eq!(s, want, "{}", last_error());
    assert_eq!(allocs, 0);
    assert_eq!(frame, sentinel_f);
    assert!(objects.iter().all(|x| *x == sentinel_o));
    assert!(
        last_error().starts_with("refl_summary_rows: "),
        "{}",
        last_error()
    );
}

/// An object summary no export writes.
fn object_sentinel() -> refl_summary_object {
    refl_summary_object {
        pixels: 99,
        depth_sum: -1.0,
        ..Default::default()
    }
}

#[test]
fn summary_rows_refuses_nulls_and_bad_options_untouched() {
    let f = render(DepthConvention::Linear);
    let g = f.gbuffer_c(false);
    let d = refl_summary_options_default();
    let all = refl_row_range { begin: 0, end: H };
    // NULLs.
    run(Null, core::ptr::null(), ids_c(&f), &d, all, 2, false);
    run(Null, &g, ids_c(&f), core::ptr::null(), all, 2, false);
    run(Null, &g, ids_c(&f), &d, all, 2, true);
    // Options out of range.
    for bad in [
        refl_summary_options {
            mirror_roughness: f32::NAN,
            ..d
        },
        refl_summary_options {
            glossy_roughness: 0.0,
            mirror_roughness: 0.5,
            ..d
        },
        refl_summary_options {
            normal_cos: 2.0,
            ..d
        },
    ] {
        run(Bad, &g, ids_c(&f), &bad, all, 2, false);
        assert!(last_error().contains("`options`"), "{}", last_error());
    }
}

#[test]
fn summary_rows_refuses_bad_rows_ids_and_object_counts_untouched() {
    let f = render(DepthConvention::Linear);
    let g = f.gbuffer_c(false);
    let d = refl_summary_options_default();
    let all = refl_row_range { begin: 0, end: H };
    // Rows: beyond the height, off a tile row.
    run(
        Bad,
        &g,
        ids_c(&f),
        &d,
        refl_row_range {
            begin: 0,
            end: H + 1,
        },
        2,
        false,
    );
    run(
        Bad,
        &g,
        ids_c(&f),
        &d,
        refl_row_range { begin: 3, end: 16 },
        2,
        false,
    );
    // Ids of another size; no objects.
    let short = refl_image_u32 {
        width: W - 1,
        ..ids_c(&f)
    };
    run(Bad, &g, short, &d, all, 2, false);
    run(Short, &g, ids_c(&f), &d, all, 0, false);
}

/// Objects over the ids (an output overlapping an input).
#[test]
fn summary_rows_refuses_objects_over_the_ids() {
    let f = render(DepthConvention::Linear);
    let g = f.gbuffer_c(false);
    let d = refl_summary_options_default();
    let all = refl_row_range { begin: 0, end: H };
    let sentinel_f = frame_sentinel();
    let mut frame = sentinel_f;
    let mut ids_copy = f.ids.clone();
    let ids_alias = refl_image_u32 {
        data: ids_copy.as_ptr(),
        ..ids_c(&f)
    };
    // SAFETY: the objects alias the ids on purpose (refused before use).
    let s = unsafe {
        refl_summary_rows(
            &mut frame,
            ids_copy.as_mut_ptr().cast(),
            1,
            &g,
            ids_alias,
            &d,
            all,
        )
    };
    assert_eq!(s, Bad, "{}", last_error());
    assert_eq!(frame, sentinel_f);
    assert_eq!(ids_copy, f.ids);
}

#[test]
fn plane_of_nothing_is_degenerate_and_nulls_are_refused_untouched() {
    let d = refl_summary_options_default();
    let (sentinel_f, sentinel_o) = (frame_sentinel(), object_sentinel());
    // A plane of nothing.
    let mut fit = refl_summary_plane_fit {
        planar: true,
        ..Default::default()
    };
    let empty = refl_summary_object::default();
    // SAFETY: valid pointers.
    let s = unsafe { refl_summary_object_plane(&mut fit, &empty, &d) };
    assert_eq!(s, Degenerate);
    assert!(fit.planar);
    // SAFETY: NULL pointers.
    unsafe {
        assert_eq!(
            refl_summary_object_plane(core::ptr::null_mut(), &empty, &d),
            Null
        );
        assert_eq!(
            refl_summary_merge_frame(core::ptr::null_mut(), &sentinel_f),
            Null
        );
        let mut dst = sentinel_o;
        assert_eq!(refl_summary_merge_object(&mut dst, core::ptr::null()), Null);
        assert_eq!(dst, sentinel_o);
    }
}

/// `refl_plan_passes` equals `refl_core::plan::try_plan_passes` on the
/// summary of the shared scene, and refuses bad input without writing.
/// The ZeroToOne scene's summary through the C ABI (checked to succeed)
/// with the default options.
fn scene_summary() -> (
    refl_summary_frame,
    [refl_summary_object; 2],
    refl_summary_options,
) {
    let f = render(DepthConvention::ZeroToOne);
    let o = refl_summary_options_default();
    let (s, frame, objects, _) = c_summary(&f, ids_c(&f), refl_row_range { begin: 0, end: H }, &o);
    assert_eq!(s, refl_status::Ok);
    (frame, objects, o)
}

#[test]
fn plan_passes_equals_the_rust_plan() {
    use refl_core::plan::{try_plan_passes, FrameMotion, HostCaps, ObjectHints, PlanOptions};
    let (frame, objects, o) = scene_summary();
    let po0 = refl_plan_options_default();
    assert!(po0.mirror_hiz && po0.glossy_visibility);
    assert!(!(po0.history || po0.camera_still || po0.scene_still));
    // (extra views, planar hint, object 1 moving, history, camera still,
    // scene still).
    for (planar_views, hint, moving, history, camera_still, scene_still) in [
        (true, false, false, false, false, false),
        (false, false, false, false, false, false),
        (true, true, false, false, false, false),
        (false, false, false, true, false, false),
        (false, false, false, true, true, true),
        (false, false, true, true, true, true),
        (false, false, true, true, false, false),
    ] {
        let po = refl_plan_options {
            history,
            camera_still,
            scene_still,
            ..po0
        };
        let caps = refl_plan_host_caps {
            planar_views,
            ray_tracer: true,
            probe: false,
        };
        let hints = [
            refl_plan_object_hints::default(),
            refl_plan_object_hints {
                planar_mirror: hint,
                layered_map: true,
                moving,
            },
        ];
        let mut out = refl_plan::default();
        let mut planar = [false; 2];
        let (st, allocs) = counted(|| {
            // SAFETY: valid pointers and lengths.
            unsafe {
                refl_plan_passes(
                    &mut out,
                    planar.as_mut_ptr(),
                    2,
                    &frame,
                    objects.as_ptr(),
                    2,
                    hints.as_ptr(),
                    2,
                    &caps,
                    &o,
                    &po,
                    W,
                    H,
                )
            }
        });
        assert_eq!(st, refl_status::Ok, "{}", last_error());
        assert_eq!(allocs, 0);
        let rh = [
            ObjectHints::default(),
            ObjectHints {
                planar_mirror: hint,
                layered_map: true,
                moving,
            },
        ];
        let ro = [
            ObjectSummary::from(objects[0]),
            ObjectSummary::from(objects[1]),
        ];
        let mut rp = [false; 2];
        let want = try_plan_passes(
            &mut rp,
            &frame.into(),
            &ro,
            &rh,
            &HostCaps {
                planar_views,
                ray_tracer: true,
                probe: false,
            },
            &o.into(),
            &PlanOptions {
                motion: FrameMotion {
                    history,
                    camera_still,
                    scene_still,
                },
                ..PlanOptions::default()
            },
            (W, H),
        )
        .unwrap();
        assert_eq!(planar, rp);
        assert_eq!(out, refl_plan::from(want));
        // The floor is planar: with extra views it goes to the planar pass.
        assert_eq!(planar[0], planar_views);
        let unchanged = history && camera_still && scene_still && !moving;
        for (k, d) in out.passes.iter().enumerate() {
            assert_eq!(d.pass as usize, k);
            assert!(d.reason <= refl_plan_reason::MapsStale as u32);
            assert!(d.reason == refl_plan_reason::Runs as u32 || d.bytes == 0);
            assert_eq!(
                unchanged,
                d.reason == refl_plan_reason::Unchanged as u32,
                "pass {k}"
            );
        }
        let temporal = out.passes[refl_plan_pass::Temporal as usize];
        let mirror = out.passes[refl_plan_pass::Mirror as usize];
        if !unchanged {
            assert_eq!(
                temporal.reason == refl_plan_reason::Runs as u32,
                history && mirror.reason == refl_plan_reason::Runs as u32
            );
        }
    }
}

/// Hints of another length, planar too short, NULL frame.
#[test]
fn plan_passes_refuses_bad_lengths_and_a_null_frame_untouched() {
    let (frame, objects, o) = scene_summary();
    let po = refl_plan_options_default();
    let caps = refl_plan_host_caps::default();
    let sentinel = refl_plan {
        planar_objects: 77,
        ..Default::default()
    };
    let one_hint = [refl_plan_object_hints::default()];
    for (want, planar_len, hints_len, null_frame) in [
        (refl_status::InvalidArgument, 2usize, 1usize, false),
        (refl_status::InsufficientSize, 1, 0, false),
        (refl_status::NullPointer, 2, 0, true),
    ] {
        let mut out = sentinel;
        let mut planar = [true, true];
        // SAFETY: valid pointers for the stated lengths, or NULL.
        let st = unsafe {
            refl_plan_passes(
                &mut out,
                planar.as_mut_ptr(),
                planar_len,
                if null_frame {
                    core::ptr::null()
                } else {
                    &frame
                },
                objects.as_ptr(),
                2,
                if hints_len > 0 {
                    one_hint.as_ptr()
                } else {
                    core::ptr::null()
                },
                hints_len,
                &caps,
                &o,
                &po,
                W,
                H,
            )
        };
        assert_eq!(st, want, "{}", last_error());
        assert_eq!(out, sentinel);
        assert_eq!(planar, [true, true]);
    }
}
