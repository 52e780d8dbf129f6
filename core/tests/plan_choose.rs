//! Method choice by budget (`refl_core::plan::try_choose_methods`) on a
//! hand-made calibration table where the right choice is known (worked
//! out by hand in the comments), its edge cases (budgets that cannot be
//! met, exact limits, empty frames, hosts without a tracer or extra views,
//! pixels no option handles) and its refusals (NaN, infinite and negative
//! numbers, short buffers), and the passes the choice runs.
#![cfg(all(
    feature = "depth-image",
    feature = "hiz",
    feature = "cone",
    feature = "mirror",
    feature = "layered"
))]

use refl_core::plan::{
    choices_len, pass_bit, try_choose_methods, try_chosen_passes, try_plan_passes, Budget,
    BudgetPlan, Choice, ChoiceReason, CostEntry, HostCaps, ObjectHints, Pass, PlanOptions,
    SkipReason, Surface,
};
use refl_core::summary::{FrameSummary, ObjectSummary, RoughnessClass, SummaryOptions, NO_OBJECT};
use refl_core::Error;

const RAY: u32 = 1 << Pass::HostRays as u32;
const PLANAR: u32 = 1 << Pass::Planar as u32;
const PROBE: u32 = 1 << Pass::Probe as u32;
const SCREEN: u32 = (1 << Pass::HiZ as u32) | (1 << Pass::Mirror as u32);

fn entry(
    id: u32,
    class: RoughnessClass,
    surface: Surface,
    passes: u32,
    t: f32,
    e: f32,
) -> CostEntry {
    CostEntry {
        id,
        class,
        surface,
        passes,
        time_ratio: t,
        error_255: e,
    }
}

/// The table: indices are ids.
fn table() -> Vec<CostEntry> {
    use RoughnessClass::{Glossy, Mirror};
    vec![
        entry(0, Mirror, Surface::Any, RAY, 1.0, 0.0), // ray tracing
        entry(1, Mirror, Surface::Planar, PLANAR, 0.6, 0.0), // planar, full res
        entry(2, Mirror, Surface::Planar, PLANAR, 0.3, 1.0), // planar, half res
        entry(3, Mirror, Surface::Any, PROBE, 0.05, 30.0), // environment
        entry(4, Mirror, Surface::Any, SCREEN, 1.2, 0.5), // screen space, slower than rays
        entry(5, Glossy, Surface::Any, RAY, 4.0, 3.0), // 4 samples
        entry(6, Glossy, Surface::Any, RAY, 16.0, 1.0), // 16 samples
        entry(7, Glossy, Surface::Any, PROBE, 0.05, 20.0), // environment
    ]
}

fn object(mirror: u64, glossy: u64) -> ObjectSummary {
    ObjectSummary {
        pixels: mirror + glossy,
        classes: [mirror, glossy, 0],
        ..ObjectSummary::default()
    }
}

/// A planar mirror (1000 px), a curved mirror (1000 px) and a curved
/// glossy object (500 px).
fn frame() -> (FrameSummary, [ObjectSummary; 3], [bool; 3]) {
    let objects = [object(1000, 0), object(1000, 0), object(0, 500)];
    let f = FrameSummary {
        pixels: 10_000,
        surfaces: 8_000,
        reflective: 2500,
        classes: [2000, 500, 0],
        ..FrameSummary::default()
    };
    (f, objects, [true, false, false])
}

const HOST: HostCaps = HostCaps {
    planar_views: true,
    ray_tracer: true,
    probe: true,
};

fn choose(budget: Budget, caps: &HostCaps) -> (BudgetPlan, Vec<Choice>) {
    let (f, objects, planar) = frame();
    let mut out = vec![Choice::default(); choices_len(objects.len())];
    let p =
        try_choose_methods(&mut out, &f, &objects, &planar, &[], caps, &table(), budget).unwrap();
    out.truncate(p.groups);
    (p, out)
}

fn ids(c: &[Choice]) -> Vec<Option<usize>> {
    c.iter().map(|c| c.entry).collect()
}

#[test]
fn error_budget_picks_the_known_choice() {
    // Start: every group at its environment lookup, mean error
    // (1000*30 + 1000*30 + 500*20) / 2500 = 28. Steps by error saved per
    // time: planar env -> half res (29 / 0.25 = 116), curved env -> rays
    // (30 / 0.95 = 31.6), then the mean is (1000*1 + 0 + 500*20) / 2500 =
    // 4.4 <= 5. Going back to a faster option breaks the limit in every
    // group. Screen space (1.2x, 0.5) is dominated by rays (1.0x, 0).
    let (p, c) = choose(Budget::MaxError(5.0), &HOST);
    assert_eq!(ids(&c), [Some(2), Some(0), Some(7)]);
    assert!(p.met);
    assert!((p.error_255 - 4.4).abs() < 1e-9, "{}", p.error_255);
    assert!((p.time_ratio - (300.0 + 1000.0 + 25.0) / 2500.0).abs() < 1e-6);
    assert_eq!(p.covered, 2500);
    assert_eq!(c[0].reason, ChoiceReason::TradeOff);
    assert_eq!((c[0].faster, c[0].more_accurate), (Some(3), Some(1)));
    assert_eq!(c[1].reason, ChoiceReason::MostAccurate);
    // Rays, env and screen space apply to the curved mirror; screen space
    // is off the front.
    assert_eq!((c[1].applicable, c[1].front), (3, 2));
    // Rays are dominated on the planar mirror by the full-res planar pass.
    assert_eq!((c[0].applicable, c[0].front), (5, 3));
    assert_eq!(c[2].reason, ChoiceReason::Fastest);
    assert_eq!(c[2].group.object, 2);
    assert_eq!(c[2].group.class, RoughnessClass::Glossy);
}

#[test]
fn error_budget_exactly_met_and_just_missed() {
    // 4.4 is reachable exactly as above.
    let (p, c) = choose(Budget::MaxError(4.4), &HOST);
    assert!(p.met);
    assert_eq!(ids(&c), [Some(2), Some(0), Some(7)]);
    // At 4.39 one more step is needed. The best error per time would be
    // the glossy object's 4 samples (17 / 3.95 = 4.3 against the planar
    // mirror's half -> full res, 1 / 0.3 = 3.3), but the planar step alone
    // closes the gap (mean (0 + 0 + 500 * 20) / 2500 = 4.0) at 300 pixel
    // units of time against 1975: it is taken.
    let (p, c) = choose(Budget::MaxError(4.39), &HOST);
    assert!(p.met);
    assert_eq!(ids(&c), [Some(1), Some(0), Some(7)]);
    assert!((p.error_255 - 4.0).abs() < 1e-9);
    assert!((p.time_ratio - (600.0 + 1000.0 + 25.0) / 2500.0).abs() < 1e-6);
    // At 3.9 no single step closes the gap from 4.4 but the glossy
    // object's 4 samples (mean 1.0); then nothing faster keeps 3.9.
    let (p, c) = choose(Budget::MaxError(3.9), &HOST);
    assert!(p.met);
    assert_eq!(ids(&c), [Some(2), Some(0), Some(5)]);
    assert!((p.error_255 - 1.0).abs() < 1e-9);
    // At 0.9 from 4.4: 16 glossy samples alone would close the gap (mean
    // 0.6) but add 7975 pixel units of time against the best step's 1975
    // (4 samples, mean 1.0), so the search goes on: then the planar full
    // res step (300) closes it. 1.44x against 3.72x for the 16 samples.
    let (p, c) = choose(Budget::MaxError(0.9), &HOST);
    assert!(p.met);
    assert_eq!(ids(&c), [Some(1), Some(0), Some(5)]);
    assert!((p.error_255 - 0.6).abs() < 1e-9);
    assert!((p.time_ratio - (600.0 + 1000.0 + 2000.0) / 2500.0).abs() < 1e-6);
}

#[test]
fn zero_error_is_unreachable_with_noisy_glossy_options() {
    let (p, c) = choose(Budget::MaxError(0.0), &HOST);
    assert!(!p.met);
    // Every group at its most accurate option.
    assert_eq!(ids(&c), [Some(1), Some(0), Some(6)]);
    assert!(c
        .iter()
        .all(|c| c.reason == ChoiceReason::ErrorBudgetUnreachable));
    assert!((p.error_255 - 500.0 / 2500.0).abs() < 1e-9);
}

#[test]
fn time_budget_picks_the_known_choice() {
    // From the fastest (0.05x): planar env -> half (+0.1x), curved env ->
    // rays (+0.38x), glossy 4 spp would add 0.79x (> 1.0 in all), planar
    // half -> full adds 0.12x: 0.65x in all; nothing else fits.
    let (p, c) = choose(Budget::MaxTime(1.0), &HOST);
    assert_eq!(ids(&c), [Some(1), Some(0), Some(7)]);
    assert!(p.met);
    assert!((p.time_ratio - (600.0 + 1000.0 + 25.0) / 2500.0).abs() < 1e-6);
    assert!((p.error_255 - 4.0).abs() < 1e-9);
    assert_eq!(c[0].reason, ChoiceReason::MostAccurate);
    assert_eq!(c[2].reason, ChoiceReason::Fastest);
    // A time budget below the fastest plan: all fastest, not met.
    let (p, c) = choose(Budget::MaxTime(0.01), &HOST);
    assert!(!p.met);
    assert_eq!(ids(&c), [Some(3), Some(3), Some(7)]);
    assert!(c
        .iter()
        .all(|c| c.reason == ChoiceReason::TimeBudgetUnreachable));
    // Exactly the fastest plan's time: met, all fastest.
    let (p, _) = choose(Budget::MaxTime(0.05), &HOST);
    assert!(p.met);
}

#[test]
fn host_without_tracer_or_views_gets_what_it_can_run() {
    let caps = HostCaps {
        ray_tracer: false,
        ..HOST
    };
    // No rays: the curved mirror keeps screen space (now on its front).
    let (p, c) = choose(Budget::MaxError(0.0), &caps);
    assert_eq!(ids(&c), [Some(1), Some(4), Some(7)]);
    assert_eq!(c[2].reason, ChoiceReason::OnlyOption);
    assert!(!p.met);
    let caps = HostCaps {
        planar_views: false,
        ..HOST
    };
    let (_, c) = choose(Budget::MaxError(0.0), &caps);
    assert_eq!(ids(&c), [Some(0), Some(0), Some(6)]);
    // Nothing at all: no option anywhere.
    let (p, c) = choose(Budget::MaxError(10.0), &HostCaps::default());
    // (Screen space needs nothing of the host.)
    assert_eq!(ids(&c), [Some(4), Some(4), None]);
    assert_eq!(c[2].reason, ChoiceReason::NoOption);
    assert_eq!(p.covered, 2000);
    // The error is over the covered pixels, the time over all of them.
    assert!((p.error_255 - 0.5).abs() < 1e-9);
    assert!((p.time_ratio - 2400.0 / 2500.0).abs() < 1e-6);
}

#[test]
fn unlisted_and_rough_pixels_form_their_own_groups() {
    let (mut f, objects, planar) = frame();
    f.classes = [2100, 500, 40];
    f.reflective = 2640;
    let mut out = vec![Choice::default(); choices_len(objects.len())];
    let p = try_choose_methods(
        &mut out,
        &f,
        &objects,
        &planar,
        &[],
        &HOST,
        &table(),
        Budget::MaxError(1.0),
    )
    .unwrap();
    assert_eq!(p.groups, 5);
    let g: Vec<_> = out[3..5].iter().map(|c| c.group).collect();
    assert_eq!(
        (g[0].object, g[0].class, g[0].pixels),
        (NO_OBJECT, RoughnessClass::Mirror, 100)
    );
    assert!(!g[0].planar);
    assert_eq!(
        (g[1].object, g[1].class, g[1].pixels),
        (NO_OBJECT, RoughnessClass::Rough, 40)
    );
    assert_eq!(out[4].reason, ChoiceReason::NoOption);
    assert_eq!(p.covered, 2600);
}

#[test]
fn empty_frame_has_no_groups() {
    let mut out = [Choice::default(); 3];
    for budget in [Budget::MaxError(0.0), Budget::MaxTime(0.0)] {
        let p = try_choose_methods(
            &mut out,
            &FrameSummary::default(),
            &[],
            &[],
            &[],
            &HOST,
            &table(),
            budget,
        )
        .unwrap();
        assert_eq!(
            p,
            BudgetPlan {
                groups: 0,
                reflective: 0,
                covered: 0,
                time_ratio: 0.0,
                error_255: 0.0,
                met: true
            }
        );
    }
    // An empty table: every group has no option.
    let (f, objects, planar) = frame();
    let mut out = vec![Choice::default(); 3];
    let p = try_choose_methods(
        &mut out,
        &f,
        &objects,
        &planar,
        &[],
        &HOST,
        &[],
        Budget::MaxTime(1.0),
    )
    .unwrap();
    assert_eq!(p.covered, 0);
    assert!(out.iter().all(|c| c.reason == ChoiceReason::NoOption));
}

#[test]
fn bad_inputs_are_refused_and_nothing_is_written() {
    let (f, objects, planar) = frame();
    let sentinel = Choice {
        applicable: 99,
        ..Choice::default()
    };
    let run = |t: &[CostEntry],
               budget: Budget,
               out: &mut [Choice],
               hints: &[ObjectHints],
               planar: &[bool]| {
        try_choose_methods(out, &f, &objects, planar, hints, &HOST, t, budget)
    };
    let mut out = vec![sentinel; 9];
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0] {
        for b in [Budget::MaxError(bad), Budget::MaxTime(bad)] {
            assert_eq!(
                run(&table(), b, &mut out, &[], &planar),
                Err(Error::InvalidArgument)
            );
        }
        let mut t = table();
        t[3].time_ratio = bad;
        assert_eq!(t[3].try_validate(), Err(Error::InvalidArgument));
        assert_eq!(
            run(&t, Budget::MaxError(1.0), &mut out, &[], &planar),
            Err(Error::InvalidArgument)
        );
        let mut t = table();
        t[6].error_255 = bad;
        assert_eq!(
            run(&t, Budget::MaxError(1.0), &mut out, &[], &planar),
            Err(Error::InvalidArgument)
        );
    }
    let mut t = table();
    t[0].passes = 0;
    assert_eq!(
        run(&t, Budget::MaxError(1.0), &mut out, &[], &planar),
        Err(Error::InvalidArgument)
    );
    // Past the last pass, and the temporal pass (no option runs it).
    for bad in [1 << 10, pass_bit(Pass::Temporal)] {
        t[0].passes = bad;
        assert_eq!(
            run(&t, Budget::MaxError(1.0), &mut out, &[], &planar),
            Err(Error::InvalidArgument)
        );
    }
    // Hints of the wrong length, planar flags too short.
    let hints = [ObjectHints::default(); 2];
    assert_eq!(
        run(&table(), Budget::MaxError(1.0), &mut out, &hints, &planar),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        run(&table(), Budget::MaxError(1.0), &mut out, &[], &planar[..2]),
        Err(Error::InvalidArgument)
    );
    // Three groups do not fit in two.
    assert_eq!(
        run(&table(), Budget::MaxError(1.0), &mut out[..2], &[], &planar),
        Err(Error::InsufficientSize)
    );
    // An object with more pixels of a class than the frame.
    let mut f2 = f;
    f2.classes[1] = 10;
    let mut o = vec![sentinel; 9];
    assert_eq!(
        try_choose_methods(
            &mut o,
            &f2,
            &objects,
            &planar,
            &[],
            &HOST,
            &table(),
            Budget::MaxTime(1.0)
        ),
        Err(Error::InvalidArgument)
    );
    // Counts that add up past u64::MAX (the fuzz target `plan`'s
    // `class-counts-sum-past-u64-max-overflow`: the sum panicked with
    // overflow checks and wrapped without): the frame's three classes,
    // and two objects' mirror pixels under a frame of u64::MAX.
    let mut f3 = f;
    f3.classes = [1 << 63; 3];
    f3.reflective = u64::MAX;
    assert_eq!(
        try_choose_methods(
            &mut o,
            &f3,
            &[],
            &[],
            &[],
            &HOST,
            &table(),
            Budget::MaxTime(1.0)
        ),
        Err(Error::InvalidArgument)
    );
    let mut f4 = f;
    f4.classes = [u64::MAX, 0, 0];
    f4.reflective = u64::MAX;
    let two = |o: &mut [Choice], mirror: [u64; 2]| {
        let objects = mirror.map(|m| object(m, 0));
        try_choose_methods(
            o,
            &f4,
            &objects,
            &[true, false],
            &[],
            &HOST,
            &table(),
            Budget::MaxTime(1.0),
        )
    };
    assert_eq!(two(&mut o, [1 << 63; 2]), Err(Error::InvalidArgument));
    // Just below: the two objects' mirror pixels add up to exactly
    // u64::MAX, the frame's; accepted (no unlisted group), the sums fit.
    let p = two(&mut o, [(1 << 63) - 1, 1 << 63]).unwrap();
    assert_eq!(p.groups, 2);
    assert_eq!(o[0].group.pixels + o[1].group.pixels, u64::MAX);
    assert!(out.iter().all(|c| *c == sentinel));
    assert_eq!(Budget::MaxTime(0.0).try_validate(), Ok(()));
}

#[test]
fn chosen_passes_follow_the_choice() {
    let (f, objects, planar) = frame();
    let o = SummaryOptions::default();
    let hints = [
        ObjectHints {
            planar_mirror: true,
            ..ObjectHints::default()
        },
        ObjectHints::default(),
        ObjectHints::default(),
    ];
    let mut p = [false; 3];
    let base = try_plan_passes(
        &mut p,
        &f,
        &objects,
        &hints,
        &HOST,
        &o,
        &PlanOptions::default(),
        (100, 100),
    )
    .unwrap();
    assert_eq!(p, planar);
    assert!(base.decision(Pass::HiZ).runs() && base.decision(Pass::Glossy).runs());
    // Planar full res, rays, glossy env: no screen-space pass, no pyramid.
    let (_, c) = choose(Budget::MaxTime(1.0), &HOST);
    let chosen = try_chosen_passes(&base, &c, &table(), (100, 100)).unwrap();
    for pass in [Pass::Planar, Pass::HostRays, Pass::Probe] {
        assert!(chosen.decision(pass).runs(), "{pass:?}");
    }
    for pass in [
        Pass::HiZ,
        Pass::Mirror,
        Pass::Glossy,
        Pass::ColorPyramid,
        Pass::VisibilityPyramid,
    ] {
        assert_eq!(
            chosen.decision(pass).reason,
            SkipReason::NotUsed,
            "{pass:?}"
        );
    }
    assert_eq!(chosen.bytes(), 0);
    assert_eq!(chosen.planar_objects, 1);
    assert_eq!(chosen.decision(Pass::Layered).reason, SkipReason::NoMaps);
    // Screen space on the curved mirror (no tracer): Hi-Z runs with its
    // bytes.
    let caps = HostCaps {
        ray_tracer: false,
        ..HOST
    };
    let (_, c) = choose(Budget::MaxError(0.0), &caps);
    let chosen = try_chosen_passes(&base, &c, &table(), (100, 100)).unwrap();
    assert!(chosen.decision(Pass::HiZ).runs());
    assert_eq!(
        chosen.decision(Pass::HiZ).bytes,
        base.decision(Pass::HiZ).bytes
    );
    assert_eq!(chosen.mirror_pixels, 1000);
    assert_eq!(
        try_chosen_passes(&base, &c, &table(), (0, 100)),
        Err(Error::InvalidArgument)
    );
    assert_eq!(pass_bit(Pass::Probe), PROBE);
}

/// A layered option is offered to an object with maps only while it
/// stands still (stale maps after it moved); the chosen passes keep the
/// base plan's "unchanged" skips and run the temporal pass exactly when a
/// chosen option runs the mirror pass and the host keeps a history.
#[test]
fn moving_maps_and_the_temporal_pass_in_the_choice() {
    use refl_core::plan::FrameMotion;
    let layered = 1 << Pass::Layered as u32 | 1 << Pass::Mirror as u32;
    let mut t = table();
    // A cheap, exact layered option for mirrors (the curved mirror has
    // maps).
    t.push(entry(
        8,
        RoughnessClass::Mirror,
        Surface::Any,
        layered,
        0.1,
        0.0,
    ));
    let (f, objects, planar) = frame();
    let hints = |moving: bool| {
        [
            ObjectHints::default(),
            ObjectHints {
                layered_map: true,
                moving,
                ..ObjectHints::default()
            },
            ObjectHints::default(),
        ]
    };
    let pick = |h: &[ObjectHints]| {
        let mut out = vec![Choice::default(); choices_len(objects.len())];
        let p = try_choose_methods(
            &mut out,
            &f,
            &objects,
            &planar,
            h,
            &HOST,
            &t,
            Budget::MaxError(0.0),
        )
        .unwrap();
        out.truncate(p.groups);
        out
    };
    assert_eq!(pick(&hints(false))[1].entry, Some(8));
    assert_ne!(pick(&hints(true))[1].entry, Some(8));
    // The temporal pass follows a chosen mirror pass when there is a
    // history (here the layered option runs the mirror pass).
    let c = pick(&hints(false));
    let so = SummaryOptions::default();
    let base_of = |motion: FrameMotion| {
        let mut p = [false; 3];
        try_plan_passes(
            &mut p,
            &f,
            &objects,
            &hints(false),
            &HOST,
            &so,
            &PlanOptions {
                motion,
                ..PlanOptions::default()
            },
            (100, 100),
        )
        .unwrap()
    };
    let history = FrameMotion {
        history: true,
        ..FrameMotion::default()
    };
    let chosen = try_chosen_passes(&base_of(history), &c, &t, (100, 100)).unwrap();
    assert!(chosen.decision(Pass::Mirror).runs());
    assert!(chosen.decision(Pass::Temporal).runs());
    let chosen = try_chosen_passes(&base_of(FrameMotion::default()), &c, &t, (100, 100)).unwrap();
    assert!(chosen.decision(Pass::Mirror).runs());
    assert_eq!(
        chosen.decision(Pass::Temporal).reason,
        SkipReason::NoHostSupport
    );
    // Nothing moved: the choice changes nothing, every pass stays skipped.
    let still = FrameMotion {
        history: true,
        camera_still: true,
        scene_still: true,
    };
    let chosen = try_chosen_passes(&base_of(still), &c, &t, (100, 100)).unwrap();
    assert_eq!(chosen.counts(), (0, 10));
    assert!(Pass::ALL
        .iter()
        .all(|&p| chosen.decision(p).reason == SkipReason::Unchanged));
}
