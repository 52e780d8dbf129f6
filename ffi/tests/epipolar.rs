//! The seed 002 exports called from Rust: the reprojection and the
//! decisions equal refl-core's on the same buffers, and every error path
//! returns its status and leaves the outputs byte-identical.

use refl::*;
use refl_core::epipolar::{
    decide, try_reproject, try_scratch_len, AipEntry, EpipolarOptions, PosEntry, Reason,
    BACKGROUND_OBJECT,
};
use refl_core::glam::{Vec2, Vec3};
use refl_core::Camera;

const W: u32 = 48;
const UNAVAILABLE: refl_epipolar_aip_entry = refl_epipolar_aip_entry {
    object: REFL_EPIPOLAR_INVALID_OBJECT,
    t: f32::INFINITY,
    cnt: 0,
    t_other: f32::INFINITY,
    flags: REFL_EPIPOLAR_FLAG_NO_REPROJECTION,
};
const H: u32 = 32;

fn cam(eye: Vec3, target: Vec3) -> Camera {
    Camera::try_look_at(eye, target, Vec3::Y, 1.0, 0.1, 100.0, W, H).unwrap()
}

/// POS of a floor (object 0, y = 0) with a box-like wall (object 1,
/// z = -6, |x| < 1) and background (the sphere at distance 50).
fn pos_of(c: &Camera) -> Vec<refl_epipolar_pos_entry> {
    let mut v = Vec::new();
    for y in 0..H {
        for x in 0..W {
            let r = c.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let mut best: Option<(f32, u32)> = None;
            if r.dir.y < 0.0 {
                best = Some((-r.origin.y / r.dir.y, 0));
            }
            if r.dir.z < 0.0 {
                let t = (-6.0 - r.origin.z) / r.dir.z;
                let p = r.origin + r.dir * t;
                if p.x.abs() < 1.0 && p.y > 0.0 && p.y < 2.0 && best.is_none_or(|b| t < b.0) {
                    best = Some((t, 1));
                }
            }
            let e = match best {
                Some((t, o)) => PosEntry::hit(r.origin, r.dir, t, o),
                None => PosEntry::background(r.origin, r.dir, 50.0),
            };
            v.push(refl_epipolar_pos_entry {
                point: e.point,
                object: e.object,
                t: e.t,
            });
        }
    }
    v
}

fn params() -> refl_epipolar_options {
    refl_epipolar_options_default()
}

#[test]
fn defaults_and_scratch_len_match_core() {
    let p = params();
    assert_eq!(
        EpipolarOptions::try_from(&p).unwrap(),
        EpipolarOptions::default()
    );
    let mut n = 0usize;
    assert_eq!(
        unsafe { refl_epipolar_scratch_len(&mut n, W, H) },
        refl_status::Ok
    );
    assert_eq!(n, try_scratch_len(W, H).unwrap());
    let mut n2 = 7usize;
    assert_eq!(
        unsafe { refl_epipolar_scratch_len(&mut n2, 0, H) },
        refl_status::InvalidArgument
    );
    assert_eq!(n2, 7);
    assert_eq!(
        unsafe { refl_epipolar_scratch_len(std::ptr::null_mut(), W, H) },
        refl_status::NullPointer
    );
}

/// The reprojection of the first camera's POS into a second camera
/// slightly moved and turned, through the C ABI (checked to succeed) and
/// refl-core: the AIP and stats of each.
struct Reprojected {
    aip: Vec<refl_epipolar_aip_entry>,
    stats: refl_epipolar_stats,
    core_aip: Vec<AipEntry>,
    core_stats: refl_core::epipolar::ReprojectStats,
}

fn reprojected() -> Reprojected {
    let c0 = cam(Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.0, 1.3, -10.0));
    let c1 = cam(Vec3::new(0.05, 1.5, -0.2), Vec3::new(0.3, 1.3, -10.0));
    let pos = pos_of(&c0);
    let n = (W * H) as usize;
    let p = params();
    let (rc0, rc1): (refl_camera, refl_camera) = ((&c0).into(), (&c1).into());
    let mut aip = vec![UNAVAILABLE; n];
    let mut scratch = vec![0.0f32; try_scratch_len(W, H).unwrap()];
    let mut stats = refl_epipolar_stats::default();
    let s = unsafe {
        refl_epipolar_reproject(
            aip.as_mut_ptr(),
            aip.len(),
            scratch.as_mut_ptr(),
            scratch.len(),
            &mut stats,
            pos.as_ptr(),
            pos.len(),
            &rc0,
            &rc1,
            &p,
        )
    };
    assert_eq!(s, refl_status::Ok);
    // The same call through the core.
    let core_pos: Vec<PosEntry> = pos
        .iter()
        .map(|e| PosEntry {
            point: e.point,
            object: e.object,
            t: e.t,
        })
        .collect();
    let mut core_aip = vec![AipEntry::UNAVAILABLE; n];
    let mut core_scratch = vec![0.0f32; scratch.len()];
    let st = try_reproject(
        &mut core_aip,
        &mut core_scratch,
        &core_pos,
        &c0,
        &c1,
        &EpipolarOptions::default(),
    )
    .unwrap();
    Reprojected {
        aip,
        stats,
        core_aip,
        core_stats: st,
    }
}

#[test]
fn reprojection_equals_core() {
    let n = (W * H) as usize;
    let r = reprojected();
    let (stats, st) = (r.stats, r.core_stats);
    let (aip, core_aip) = (&r.aip, &r.core_aip);
    assert_eq!(stats.points, st.points);
    assert_eq!(stats.splatted, st.splatted);
    assert_eq!(stats.occlusion_rejected, st.occlusion_rejected);
    assert_eq!(stats.frustum_failed, st.frustum_failed);
    assert!(st.splatted > n as u32 / 2, "{st:?}");
    for (a, b) in aip.iter().zip(core_aip) {
        assert_eq!(
            (a.object, a.t.to_bits(), a.cnt, a.t_other.to_bits(), a.flags),
            (b.object, b.t.to_bits(), b.cnt, b.t_other.to_bits(), b.flags)
        );
    }
}

/// A decision no export writes.
const DECISION_SENTINEL: refl_epipolar_decision = refl_epipolar_decision {
    object: 12345,
    tmax: -1.0,
    tmin: -1.0,
    reason: 99,
};

#[test]
fn decisions_of_two_row_bands_equal_core_background_included() {
    let n = (W * H) as usize;
    let p = params();
    let r = reprojected();
    let (aip, core_aip) = (&r.aip, &r.core_aip);
    let sentinel = DECISION_SENTINEL;
    let mut out = vec![sentinel; n];
    for (b, e) in [(0, H / 2), (H / 2, H)] {
        let s = unsafe {
            refl_epipolar_decide_rows(
                out.as_mut_ptr(),
                n,
                aip.as_ptr(),
                n,
                W,
                refl_row_range { begin: b, end: e },
                3,
                &p,
            )
        };
        assert_eq!(s, refl_status::Ok);
    }
    let mut background = 0;
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let d = decide(&core_aip[i], x, y, 3, &EpipolarOptions::default());
            let o = out[i];
            assert_eq!(o.object, d.object);
            assert_eq!(o.tmax.to_bits(), d.tmax.to_bits());
            assert_eq!(o.tmin.to_bits(), d.tmin.to_bits());
            assert_eq!(o.reason, d.reason as u32);
            background += usize::from(d.object == BACKGROUND_OBJECT);
            if d.reason == Reason::Reprojected {
                assert_eq!(o.reason, refl_epipolar_reason::Reprojected as u32);
            }
        }
    }
    assert!(background > 0);
}

#[test]
fn one_row_band_touches_only_its_rows() {
    let n = (W * H) as usize;
    let p = params();
    let aip = reprojected().aip;
    let sentinel = DECISION_SENTINEL;
    let mut out2 = vec![sentinel; n];
    let s = unsafe {
        refl_epipolar_decide_rows(
            out2.as_mut_ptr(),
            n,
            aip.as_ptr(),
            n,
            W,
            refl_row_range { begin: 2, end: 5 },
            3,
            &p,
        )
    };
    assert_eq!(s, refl_status::Ok);
    for (i, d) in out2.iter().enumerate() {
        let y = i as u32 / W;
        assert_eq!(*d == sentinel, !(2..5).contains(&y), "pixel {i}");
    }
}

/// The inputs of the reprojection error tests: the first camera's POS,
/// and the first and a second camera moved back.
fn error_inputs() -> (Vec<refl_epipolar_pos_entry>, refl_camera, refl_camera) {
    let c0 = cam(Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.0, 1.3, -10.0));
    let c1 = cam(Vec3::new(0.0, 1.5, -0.2), Vec3::new(0.0, 1.3, -10.0));
    (pos_of(&c0), (&c0).into(), (&c1).into())
}

/// An AIP entry no export writes.
const AIP_SENTINEL: refl_epipolar_aip_entry = refl_epipolar_aip_entry {
    object: 7,
    t: 3.0,
    cnt: 9,
    t_other: 4.0,
    flags: 0,
};

#[test]
fn reproject_refuses_bad_sizes_options_and_cameras_untouched() {
    let (pos, rc0, rc1) = error_inputs();
    let n = (W * H) as usize;
    let sentinel = AIP_SENTINEL;
    let sl = try_scratch_len(W, H).unwrap();
    let run = |aip_len: usize,
               scratch_len: usize,
               pos_len: usize,
               prev: &refl_camera,
               p: &refl_epipolar_options,
               expected: refl_status| {
        let mut aip = vec![sentinel; n];
        let mut scratch = vec![0.0f32; sl];
        let mut stats = refl_epipolar_stats {
            points: 77,
            ..Default::default()
        };
        let s = unsafe {
            refl_epipolar_reproject(
                aip.as_mut_ptr(),
                aip_len,
                scratch.as_mut_ptr(),
                scratch_len,
                &mut stats,
                pos.as_ptr(),
                pos_len,
                prev,
                &rc1,
                p,
            )
        };
        assert_eq!(s, expected);
        assert!(aip.iter().all(|a| *a == sentinel));
        assert_eq!(stats.points, 77);
    };
    let p = params();
    run(n - 1, sl, n, &rc0, &p, refl_status::InsufficientSize);
    run(n, sl - 1, n, &rc0, &p, refl_status::InsufficientSize);
    run(n, sl, n - 1, &rc0, &p, refl_status::InsufficientSize);
    for bad in [
        refl_epipolar_options { m_cnt: 0, ..p },
        refl_epipolar_options {
            splat_radius: REFL_EPIPOLAR_MAX_SPLAT_RADIUS + 1,
            ..p
        },
        refl_epipolar_options {
            shift_epsilon: f32::NAN,
            ..p
        },
        refl_epipolar_options {
            guard_margin: 1.0,
            ..p
        },
    ] {
        run(n, sl, n, &rc0, &bad, refl_status::InvalidArgument);
    }
    // A camera of another size.
    let other: refl_camera =
        (&Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 0.1, 100.0, W + 1, H)
            .unwrap())
            .into();
    run(n, sl, n, &other, &p, refl_status::InvalidArgument);
    // A NaN camera.
    let mut nan = rc0;
    nan.fov_y = f32::NAN;
    run(n, sl, n, &nan, &p, refl_status::InvalidArgument);
}

#[test]
fn reproject_refuses_null_pointers_and_a_scratch_over_the_aip() {
    let (pos, rc0, rc1) = error_inputs();
    let n = (W * H) as usize;
    let sentinel = AIP_SENTINEL;
    let sl = try_scratch_len(W, H).unwrap();
    let p = params();
    let mut aip = vec![sentinel; n];
    let mut scratch = vec![0.0f32; sl];
    let mut stats = refl_epipolar_stats::default();
    let s = unsafe {
        refl_epipolar_reproject(
            aip.as_mut_ptr(),
            n,
            scratch.as_mut_ptr(),
            sl,
            &mut stats,
            std::ptr::null(),
            n,
            &rc0,
            &rc1,
            &p,
        )
    };
    assert_eq!(s, refl_status::NullPointer);
    let s = unsafe {
        refl_epipolar_reproject(
            aip.as_mut_ptr(),
            n,
            scratch.as_mut_ptr(),
            sl,
            std::ptr::null_mut(),
            pos.as_ptr(),
            n,
            &rc0,
            &rc1,
            &p,
        )
    };
    assert_eq!(s, refl_status::NullPointer);
    // Overlapping AIP and scratch.
    let s = unsafe {
        refl_epipolar_reproject(
            aip.as_mut_ptr(),
            n,
            aip.as_mut_ptr().cast(),
            sl,
            &mut stats,
            pos.as_ptr(),
            n,
            &rc0,
            &rc1,
            &p,
        )
    };
    assert_eq!(s, refl_status::InvalidArgument);
    assert!(aip.iter().all(|a| *a == sentinel));
}

#[test]
fn decide_rows_refuses_bad_input_untouched() {
    let n = (W * H) as usize;
    let p = params();
    let dsent = refl_epipolar_decision {
        object: 1,
        tmax: 2.0,
        tmin: 3.0,
        reason: 4,
    };
    let aip = vec![UNAVAILABLE; n];
    let decide_with = |out_len: usize,
                       aip_len: usize,
                       w: u32,
                       b: u32,
                       e: u32,
                       p: &refl_epipolar_options,
                       expected: refl_status| {
        let mut out = vec![dsent; n];
        let s = unsafe {
            refl_epipolar_decide_rows(
                out.as_mut_ptr(),
                out_len,
                aip.as_ptr(),
                aip_len,
                w,
                refl_row_range { begin: b, end: e },
                0,
                p,
            )
        };
        assert_eq!(s, expected);
        assert!(out.iter().all(|d| *d == dsent));
    };
    decide_with(n - 1, n, W, 0, H, &p, refl_status::InsufficientSize);
    decide_with(n, n - 1, W, 0, H, &p, refl_status::InsufficientSize);
    decide_with(n, n, 0, 0, H, &p, refl_status::InvalidArgument);
    decide_with(n, n, W, 3, 3, &p, refl_status::InvalidArgument);
    decide_with(n, n, W, 4, 3, &p, refl_status::InvalidArgument);
    decide_with(n, n, W, 0, H + 1, &p, refl_status::InsufficientSize);
    decide_with(
        n,
        n,
        W,
        0,
        H,
        &refl_epipolar_options { m_cnt: 0, ..p },
        refl_status::InvalidArgument,
    );
    let s = unsafe {
        refl_epipolar_decide_rows(
            std::ptr::null_mut(),
            n,
            aip.as_ptr(),
            n,
            W,
            refl_row_range { begin: 0, end: H },
            0,
            &p,
        )
    };
    assert_eq!(s, refl_status::NullPointer);
    let mut out = vec![dsent; n];
    let s = unsafe {
        refl_epipolar_decide_rows(
            out.as_mut_ptr(),
            n,
            aip.as_ptr(),
            n,
            W,
            refl_row_range { begin: 0, end: H },
            0,
            std::ptr::null(),
        )
    };
    assert_eq!(s, refl_status::NullPointer);
}

#[test]
fn decisions_of_unavailable_entries_are_full_traversals() {
    let n = (W * H) as usize;
    let p = params();
    let aip = vec![UNAVAILABLE; n];
    let mut out = vec![
        refl_epipolar_decision {
            object: 1,
            tmax: 2.0,
            tmin: 3.0,
            reason: 4,
        };
        n
    ];
    let s = unsafe {
        refl_epipolar_decide_rows(
            out.as_mut_ptr(),
            n,
            aip.as_ptr(),
            n,
            W,
            refl_row_range { begin: 0, end: H },
            0,
            &p,
        )
    };
    assert_eq!(s, refl_status::Ok);
    assert!(out.iter().all(|d| d.object == REFL_EPIPOLAR_INVALID_OBJECT
        && d.reason == refl_epipolar_reason::Unavailable as u32));
}
