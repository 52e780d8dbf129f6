//! The pass plan (`refl_core::plan`) on summaries of the analytic scene (a
//! floor, a sphere and a box): a frame of planar mirrors builds no Hi-Z
//! and runs no mirror pass when the host renders extra views; a frame
//! without glossy pixels builds no color or visibility pyramid; the bytes
//! are those of the pyramids that are built; every skip says why.
#![cfg(all(
    feature = "depth-image",
    feature = "hiz",
    feature = "cone",
    feature = "mirror",
    feature = "layered"
))]

#[path = "common/scene.rs"]
mod scene;

use refl_core::plan::{
    try_plan_passes, HostCaps, ObjectHints, Pass, PassPlan, PlanOptions, SkipReason,
};
use refl_core::summary::{try_summarize_rows, FrameSummary, ObjectSummary, SummaryOptions};
use refl_core::{
    try_color_pyramid_len, try_hiz_len, try_visibility_pyramid_len, DepthConvention, Error,
    ImageView, RowRange,
};
use scene::{default_camera, render, Frame};

/// The summary of the default view with `reflective` objects reflective
/// (mask) at roughness `rough[object]`.
fn summary(
    f: &Frame,
    reflective: [bool; 3],
    rough: [f32; 3],
) -> (FrameSummary, [ObjectSummary; 3]) {
    let (w, h) = (f.camera.width(), f.camera.height());
    let mask: Vec<u8> =
        f.id.iter()
            .map(|&id| u8::from(id < 3 && reflective[id as usize]))
            .collect();
    let r: Vec<f32> =
        f.id.iter()
            .map(|&id| if id < 3 { rough[id as usize] } else { 0.0 })
            .collect();
    let g = f
        .gbuffer(false)
        .try_with_mask(ImageView::try_new(&mask, w, h, w).unwrap())
        .unwrap()
        .try_with_roughness(ImageView::try_new(&r, w, h, w).unwrap())
        .unwrap();
    let ids = ImageView::try_new(&f.id, w, h, w).unwrap();
    let (mut fr, mut ob) = (FrameSummary::default(), [ObjectSummary::default(); 3]);
    try_summarize_rows(
        &mut fr,
        &mut ob,
        &g,
        Some(&ids),
        RowRange::try_all(h).unwrap(),
        &SummaryOptions::default(),
    )
    .unwrap();
    (fr, ob)
}

fn plan(
    f: &Frame,
    s: &(FrameSummary, [ObjectSummary; 3]),
    hints: &[ObjectHints],
    caps: HostCaps,
    o: PlanOptions,
) -> (PassPlan, [bool; 3]) {
    let mut planar = [false; 3];
    let p = try_plan_passes(
        &mut planar,
        &s.0,
        &s.1,
        hints,
        &caps,
        &SummaryOptions::default(),
        &o,
        (f.camera.width(), f.camera.height()),
    )
    .unwrap();
    (p, planar)
}

fn reason(p: &PassPlan, pass: Pass) -> SkipReason {
    p.decision(pass).reason
}

const ALL_CAPS: HostCaps = HostCaps {
    planar_views: true,
    ray_tracer: true,
    probe: true,
};

#[test]
fn a_frame_of_planar_mirrors_builds_no_hiz_and_runs_no_mirror_pass() {
    let f = render(default_camera(), DepthConvention::ReversedZ);
    // Only the floor reflects, as a mirror.
    let s = summary(&f, [true, false, false], [0.0; 3]);
    let (p, planar) = plan(&f, &s, &[], ALL_CAPS, PlanOptions::default());
    assert_eq!(planar, [true, false, false]);
    assert_eq!(p.planar_objects, 1);
    assert_eq!(p.mirror_pixels, 0);
    assert_eq!(reason(&p, Pass::Planar), SkipReason::Runs);
    assert_eq!(reason(&p, Pass::Mirror), SkipReason::AllMirrorsPlanar);
    assert_eq!(reason(&p, Pass::HiZ), SkipReason::NoReader);
    assert_eq!(reason(&p, Pass::Glossy), SkipReason::NoPixels);
    assert_eq!(reason(&p, Pass::ColorPyramid), SkipReason::NoReader);
    assert_eq!(reason(&p, Pass::VisibilityPyramid), SkipReason::NoReader);
    assert_eq!(reason(&p, Pass::HostRays), SkipReason::NoReader);
    assert_eq!(reason(&p, Pass::Probe), SkipReason::NoPixels);
    assert_eq!(p.bytes(), 0);
    assert_eq!(p.counts(), (1, 9));
    // Without extra views the floor goes through the mirror pass, on Hi-Z.
    let caps = HostCaps {
        planar_views: false,
        ..ALL_CAPS
    };
    let (p, planar) = plan(&f, &s, &[], caps, PlanOptions::default());
    assert_eq!(planar, [false; 3]);
    assert_eq!(p.mirror_pixels, s.1[0].pixels);
    assert_eq!(reason(&p, Pass::Planar), SkipReason::NoHostSupport);
    assert_eq!(reason(&p, Pass::Mirror), SkipReason::Runs);
    assert_eq!(reason(&p, Pass::HiZ), SkipReason::Runs);
    assert_eq!(reason(&p, Pass::HostRays), SkipReason::Runs);
    let (w, h) = (f.camera.width(), f.camera.height());
    assert_eq!(p.bytes(), try_hiz_len(w, h).unwrap() * 8);
    // Stepping needs no pyramid.
    let stepping = PlanOptions {
        mirror_hiz: false,
        ..PlanOptions::default()
    };
    let (p, _) = plan(&f, &s, &[], caps, stepping);
    assert_eq!(reason(&p, Pass::HiZ), SkipReason::NotUsed);
    assert_eq!(p.bytes(), 0);
}

#[test]
fn curved_mirrors_and_glossy_pixels_run_the_screen_space_passes() {
    let f = render(default_camera(), DepthConvention::Linear);
    let (w, h) = (f.camera.width(), f.camera.height());
    // Every object reflects; the sphere is glossy.
    let s = summary(&f, [true; 3], [0.0, 0.4, 0.0]);
    let (p, planar) = plan(&f, &s, &[], ALL_CAPS, PlanOptions::default());
    // The floor is a plane; the box is not (several faces); the sphere is
    // glossy.
    assert_eq!(planar, [true, false, false]);
    assert_eq!(p.mirror_pixels, s.1[2].pixels);
    for pass in [
        Pass::HiZ,
        Pass::Planar,
        Pass::Mirror,
        Pass::ColorPyramid,
        Pass::VisibilityPyramid,
        Pass::Glossy,
        Pass::HostRays,
    ] {
        assert_eq!(reason(&p, pass), SkipReason::Runs, "{pass:?}");
    }
    let hiz = try_hiz_len(w, h).unwrap() * 8;
    let color = try_color_pyramid_len(w, h).unwrap() * 12;
    let vis = try_visibility_pyramid_len(w, h).unwrap() * 4;
    assert_eq!(p.bytes(), hiz + color + vis);
    // Options that read no visibility pyramid build none.
    let o = PlanOptions {
        glossy_visibility: false,
        ..PlanOptions::default()
    };
    let (p2, _) = plan(&f, &s, &[], ALL_CAPS, o);
    assert_eq!(reason(&p2, Pass::VisibilityPyramid), SkipReason::NotUsed);
    assert_eq!(p2.bytes(), hiz + color);
    // A host that states the box is a planar mirror sends it to the
    // planar pass too; then only the glossy sphere is screen space.
    let hints = [
        ObjectHints::default(),
        ObjectHints::default(),
        ObjectHints {
            planar_mirror: true,
            ..ObjectHints::default()
        },
    ];
    let (p3, planar) = plan(&f, &s, &hints, ALL_CAPS, PlanOptions::default());
    assert_eq!(planar, [true, false, true]);
    assert_eq!(reason(&p3, Pass::Mirror), SkipReason::AllMirrorsPlanar);
    assert_eq!(reason(&p3, Pass::Glossy), SkipReason::Runs);
    assert_eq!(reason(&p3, Pass::HiZ), SkipReason::Runs);
}

#[test]
fn rough_pixels_go_to_the_probe_and_maps_to_the_layered_pass() {
    let f = render(default_camera(), DepthConvention::ZeroToOne);
    let s = summary(&f, [false, true, false], [0.0, 1.5, 0.0]);
    let (p, _) = plan(&f, &s, &[], ALL_CAPS, PlanOptions::default());
    assert_eq!(reason(&p, Pass::Probe), SkipReason::Runs);
    assert_eq!(reason(&p, Pass::Mirror), SkipReason::NoPixels);
    assert_eq!(reason(&p, Pass::Glossy), SkipReason::NoPixels);
    assert_eq!(p.bytes(), 0);
    let no_probe = HostCaps {
        probe: false,
        ..ALL_CAPS
    };
    let (p, _) = plan(&f, &s, &[], no_probe, PlanOptions::default());
    assert_eq!(reason(&p, Pass::Probe), SkipReason::NoHostSupport);
    // Maps: traced when a screen-space pass runs.
    let maps = [
        ObjectHints::default(),
        ObjectHints {
            layered_map: true,
            ..ObjectHints::default()
        },
        ObjectHints::default(),
    ];
    let (p, _) = plan(&f, &s, &maps, ALL_CAPS, PlanOptions::default());
    assert_eq!(reason(&p, Pass::Layered), SkipReason::NoPixels);
    let curved = summary(&f, [false, true, true], [0.0; 3]);
    let (p, _) = plan(&f, &curved, &maps, ALL_CAPS, PlanOptions::default());
    assert_eq!(reason(&p, Pass::Layered), SkipReason::Runs);
    let (p, _) = plan(&f, &curved, &[], ALL_CAPS, PlanOptions::default());
    assert_eq!(reason(&p, Pass::Layered), SkipReason::NoMaps);
    // No reflective pixel at all: nothing runs.
    let none = summary(&f, [false; 3], [0.0; 3]);
    let (p, _) = plan(&f, &none, &maps, ALL_CAPS, PlanOptions::default());
    assert_eq!(p.counts(), (0, 10));
    assert_eq!(p.bytes(), 0);
}

#[test]
fn refusals_write_nothing() {
    let f = render(default_camera(), DepthConvention::Linear);
    let s = summary(&f, [true; 3], [0.0; 3]);
    let size = (f.camera.width(), f.camera.height());
    let caps = ALL_CAPS;
    let o = PlanOptions::default();
    let so = SummaryOptions::default();
    let mut planar = [true, false, true];
    let two = [ObjectHints::default(); 2];
    assert_eq!(
        try_plan_passes(&mut planar, &s.0, &s.1, &two, &caps, &so, &o, size).unwrap_err(),
        Error::InvalidArgument
    );
    assert_eq!(
        try_plan_passes(&mut planar[..2], &s.0, &s.1, &[], &caps, &so, &o, size).unwrap_err(),
        Error::InsufficientSize
    );
    assert_eq!(
        try_plan_passes(&mut planar, &s.0, &s.1, &[], &caps, &so, &o, (0, 4)).unwrap_err(),
        Error::InvalidArgument
    );
    let bad = SummaryOptions {
        normal_cos: f32::NAN,
        ..so
    };
    assert_eq!(
        try_plan_passes(&mut planar, &s.0, &s.1, &[], &caps, &bad, &o, size).unwrap_err(),
        Error::InvalidArgument
    );
    assert_eq!(planar, [true, false, true]);
}

/// What moved (issue 15: "static or moving", "camera motion since the last
/// frame"): with a history and nothing moved every pass is skipped as
/// unchanged; the temporal pass runs with the mirror pass when the host
/// keeps a history; a moving object's layered maps are stale.
#[test]
fn motion_decides_reuse_the_temporal_pass_and_stale_maps() {
    use refl_core::plan::FrameMotion;
    let f = render(default_camera(), DepthConvention::ReversedZ);
    // The sphere and the box curved mirrors: the mirror pass runs.
    let s = summary(&f, [false, true, true], [0.0; 3]);
    let with = |motion: FrameMotion| PlanOptions {
        motion,
        ..PlanOptions::default()
    };
    let maps = |moving: [bool; 3]| {
        [0, 1, 2].map(|k| ObjectHints {
            layered_map: k > 0,
            moving: moving[k],
            ..ObjectHints::default()
        })
    };
    let still = maps([false; 3]);
    // Nothing stated (the default): no history, no temporal pass.
    let (p, _) = plan(&f, &s, &still, ALL_CAPS, PlanOptions::default());
    assert_eq!(reason(&p, Pass::Mirror), SkipReason::Runs);
    assert_eq!(reason(&p, Pass::Temporal), SkipReason::NoHostSupport);
    assert_eq!(reason(&p, Pass::Layered), SkipReason::Runs);
    let base_bytes = p.bytes();
    assert!(base_bytes > 0);
    // A history and a moving camera: the temporal pass joins the mirror
    // pass; nothing else changes.
    let history = FrameMotion {
        history: true,
        ..FrameMotion::default()
    };
    let (pt, _) = plan(&f, &s, &still, ALL_CAPS, with(history));
    assert_eq!(reason(&pt, Pass::Temporal), SkipReason::Runs);
    for pass in Pass::ALL {
        if pass != Pass::Temporal {
            assert_eq!(pt.decision(pass), p.decision(pass), "{pass:?}");
        }
    }
    // Nothing moved: every pass skipped, no buffer.
    let unchanged = FrameMotion {
        history: true,
        camera_still: true,
        scene_still: true,
    };
    let (pu, _) = plan(&f, &s, &still, ALL_CAPS, with(unchanged));
    assert_eq!(pu.counts(), (0, 10));
    assert_eq!(pu.bytes(), 0);
    for pass in Pass::ALL {
        assert_eq!(reason(&pu, pass), SkipReason::Unchanged, "{pass:?}");
    }
    // ... but not without a history, nor with the camera or the scene
    // moved, nor with an object stated moving.
    for m in [
        FrameMotion {
            history: false,
            ..unchanged
        },
        FrameMotion {
            camera_still: false,
            ..unchanged
        },
        FrameMotion {
            scene_still: false,
            ..unchanged
        },
    ] {
        let (pm, _) = plan(&f, &s, &still, ALL_CAPS, with(m));
        assert_eq!(pm.bytes(), base_bytes, "{m:?}");
        assert!(Pass::ALL
            .iter()
            .all(|&q| reason(&pm, q) != SkipReason::Unchanged));
    }
    // The box moves: its maps are stale, the sphere's still serve.
    let (pb, _) = plan(
        &f,
        &s,
        &maps([false, false, true]),
        ALL_CAPS,
        with(unchanged),
    );
    assert_eq!(reason(&pb, Pass::Layered), SkipReason::Runs);
    assert_eq!(reason(&pb, Pass::Mirror), SkipReason::Runs);
    assert_eq!(reason(&pb, Pass::Temporal), SkipReason::Runs);
    // Both mapped objects move: no map serves.
    let (ps, _) = plan(&f, &s, &maps([false, true, true]), ALL_CAPS, with(history));
    assert_eq!(reason(&ps, Pass::Layered), SkipReason::MapsStale);
    // A moving object without maps leaves the layered pass alone.
    let (pn, _) = plan(&f, &s, &maps([true, false, false]), ALL_CAPS, with(history));
    assert_eq!(reason(&pn, Pass::Layered), SkipReason::Runs);
    // Without the mirror pass there is nothing to re-project.
    let planar_only = summary(&f, [true, false, false], [0.0; 3]);
    let (pp, _) = plan(&f, &planar_only, &[], ALL_CAPS, with(history));
    assert_eq!(reason(&pp, Pass::Mirror), SkipReason::AllMirrorsPlanar);
    assert_eq!(reason(&pp, Pass::Temporal), SkipReason::NoReader);
}
