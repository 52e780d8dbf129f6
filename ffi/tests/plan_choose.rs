//! refl_plan_choose_methods / refl_plan_choices_len: the C call equals
//! `refl_core::plan::try_choose_methods` on the same inputs (several
//! frames, both budget kinds, budgets met and unreachable), allocates
//! nothing, and every refusal returns its documented status, names the
//! argument in the last-error message and leaves `choices` and `out`
//! byte-identical.
#![cfg(all(
    feature = "depth-image",
    feature = "hiz",
    feature = "cone",
    feature = "mirror",
    feature = "layered"
))]
#![allow(clippy::undocumented_unsafe_blocks)]

#[path = "common/counting.rs"]
mod counting;

use counting::counted;
use refl::*;
use refl_core::plan::{
    choices_len, try_choose_methods, Budget, BudgetPlan, Choice, ChoiceReason, CostEntry, HostCaps,
    ObjectHints, Pass, Surface,
};
use refl_core::summary::{FrameSummary, ObjectSummary, RoughnessClass};

#[global_allocator]
static GLOBAL: counting::Counting = counting::Counting;

const RAY: u32 = 1 << Pass::HostRays as u32;
const PLANAR: u32 = 1 << Pass::Planar as u32;
const PROBE: u32 = 1 << Pass::Probe as u32;
const SCREEN: u32 = (1 << Pass::HiZ as u32) | (1 << Pass::Mirror as u32);
const LAYERED: u32 = (1 << Pass::HiZ as u32) | (1 << Pass::Layered as u32);

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

fn table() -> Vec<CostEntry> {
    use RoughnessClass::{Glossy, Mirror, Rough};
    vec![
        entry(10, Mirror, Surface::Any, RAY, 1.0, 0.0),
        entry(11, Mirror, Surface::Planar, PLANAR, 0.6, 0.0),
        entry(12, Mirror, Surface::Planar, PLANAR, 0.3, 1.0),
        entry(13, Mirror, Surface::Any, PROBE, 0.05, 30.0),
        entry(14, Mirror, Surface::Any, SCREEN, 0.4, 6.0),
        entry(15, Mirror, Surface::Curved, LAYERED, 0.7, 2.0),
        entry(16, Glossy, Surface::Any, RAY, 4.0, 3.0),
        entry(17, Glossy, Surface::Any, RAY, 16.0, 1.0),
        entry(18, Glossy, Surface::Any, PROBE, 0.05, 20.0),
        entry(19, Rough, Surface::Any, PROBE, 0.05, 8.0),
    ]
}

fn object(mirror: u64, glossy: u64, rough: u64) -> ObjectSummary {
    ObjectSummary {
        pixels: mirror + glossy + rough,
        classes: [mirror, glossy, rough],
        ..ObjectSummary::default()
    }
}

/// A frame: summary, objects, planar flags, hints.
struct Scene {
    frame: FrameSummary,
    objects: Vec<ObjectSummary>,
    planar: Vec<bool>,
    hints: Vec<ObjectHints>,
}

fn scenes() -> Vec<Scene> {
    let frame = |classes: [u64; 3]| FrameSummary {
        pixels: 10_000,
        surfaces: 8_000,
        reflective: classes.iter().sum(),
        classes,
        ..FrameSummary::default()
    };
    vec![
        // Planar and curved mirrors, a glossy object.
        Scene {
            frame: frame([2000, 500, 0]),
            objects: vec![object(1000, 0, 0), object(1000, 0, 0), object(0, 500, 0)],
            planar: vec![true, false, false],
            hints: vec![],
        },
        // Unlisted pixels in every class, layered maps on one object, a
        // mixed object.
        Scene {
            frame: frame([2600, 900, 300]),
            objects: vec![object(800, 200, 100), object(1200, 0, 0)],
            planar: vec![false, false],
            hints: vec![
                ObjectHints {
                    planar_mirror: false,
                    layered_map: true,
                    moving: false,
                },
                // Maps, but moving: stale (no layered option).
                ObjectHints {
                    planar_mirror: false,
                    layered_map: true,
                    moving: true,
                },
            ],
        },
        // No objects listed: every pixel unlisted.
        Scene {
            frame: frame([400, 400, 400]),
            objects: vec![],
            planar: vec![],
            hints: vec![],
        },
        // No reflective pixels.
        Scene {
            frame: frame([0, 0, 0]),
            objects: vec![object(0, 0, 0)],
            planar: vec![false],
            hints: vec![],
        },
    ]
}

const HOSTS: [HostCaps; 3] = [
    HostCaps {
        planar_views: true,
        ray_tracer: true,
        probe: true,
    },
    HostCaps {
        planar_views: false,
        ray_tracer: false,
        probe: true,
    },
    HostCaps {
        planar_views: true,
        ray_tracer: true,
        probe: false,
    },
];

const BUDGETS: [Budget; 6] = [
    Budget::MaxError(5.0),
    Budget::MaxError(0.0),
    Budget::MaxError(40.0),
    Budget::MaxTime(0.5),
    Budget::MaxTime(0.0),
    Budget::MaxTime(100.0),
];

fn caps_c(c: &HostCaps) -> refl_plan_host_caps {
    refl_plan_host_caps {
        planar_views: c.planar_views,
        ray_tracer: c.ray_tracer,
        probe: c.probe,
    }
}

fn objects_c(o: &[ObjectSummary]) -> Vec<refl_summary_object> {
    o.iter().map(|&o| o.into()).collect()
}

fn hints_c(h: &[ObjectHints]) -> Vec<refl_plan_object_hints> {
    h.iter()
        .map(|h| refl_plan_object_hints {
            planar_mirror: h.planar_mirror,
            layered_map: h.layered_map,
            moving: h.moving,
        })
        .collect()
}

fn budget_c(b: Budget) -> refl_plan_budget {
    match b {
        Budget::MaxError(v) => refl_plan_budget {
            kind: refl_plan_budget_kind::MaxError as u32,
            value: v,
        },
        Budget::MaxTime(v) => refl_plan_budget {
            kind: refl_plan_budget_kind::MaxTime as u32,
            value: v,
        },
    }
}

fn table_c(t: &[CostEntry]) -> Vec<refl_plan_cost_entry> {
    t.iter()
        .map(|e| refl_plan_cost_entry {
            id: e.id,
            roughness_class: e.class as u8,
            surface: match e.surface {
                Surface::Any => refl_plan_surface::Any,
                Surface::Planar => refl_plan_surface::Planar,
                Surface::Curved => refl_plan_surface::Curved,
            } as u32,
            passes: e.passes,
            time_ratio: e.time_ratio,
            error_255: e.error_255,
        })
        .collect()
}

fn reason_c(r: ChoiceReason) -> u32 {
    (match r {
        ChoiceReason::Fastest => refl_plan_choice_reason::Fastest,
        ChoiceReason::TradeOff => refl_plan_choice_reason::TradeOff,
        ChoiceReason::MostAccurate => refl_plan_choice_reason::MostAccurate,
        ChoiceReason::ErrorBudgetUnreachable => refl_plan_choice_reason::ErrorBudgetUnreachable,
        ChoiceReason::TimeBudgetUnreachable => refl_plan_choice_reason::TimeBudgetUnreachable,
        ChoiceReason::OnlyOption => refl_plan_choice_reason::OnlyOption,
        ChoiceReason::NoOption => refl_plan_choice_reason::NoOption,
    }) as u32
}

fn index_c(i: Option<usize>) -> u32 {
    i.map_or(REFL_PLAN_NO_ENTRY, |i| u32::try_from(i).unwrap())
}

/// What the C record of a core choice must hold.
fn expected_choice(c: &Choice, table: &[CostEntry], p: &BudgetPlan) -> refl_plan_choice {
    let e = c.entry.map(|i| table[i]);
    let px = c.group.pixels as f64;
    refl_plan_choice {
        object: c.group.object,
        roughness_class: c.group.class as u32,
        pixels: c.group.pixels,
        entry: index_c(c.entry),
        reason: reason_c(c.reason),
        applicable: c.applicable,
        front: c.front,
        faster: index_c(c.faster),
        more_accurate: index_c(c.more_accurate),
        id: e.map_or(0, |e| e.id),
        passes: e.map_or(0, |e| e.passes),
        time_ratio: e.map_or(0.0, |e| e.time_ratio),
        error_255: e.map_or(0.0, |e| e.error_255),
        time_share: e.map_or(0.0, |e| {
            px * f64::from(e.time_ratio) / p.reflective.max(1) as f64
        }),
        error_share: e.map_or(0.0, |e| {
            if p.covered > 0 {
                px * f64::from(e.error_255) / p.covered as f64
            } else {
                0.0
            }
        }),
        planar: c.group.planar,
    }
}

fn blank_choice() -> refl_plan_choice {
    refl_plan_choice {
        object: 7,
        roughness_class: 7,
        pixels: 7,
        entry: 7,
        reason: 7,
        applicable: 7,
        front: 7,
        faster: 7,
        more_accurate: 7,
        id: 7,
        passes: 7,
        time_ratio: 7.0,
        error_255: 7.0,
        time_share: 7.0,
        error_share: 7.0,
        planar: true,
    }
}

fn c_choices_len(objects: usize) -> usize {
    let mut n = usize::MAX;
    let st = unsafe { refl_plan_choices_len(&mut n, u32::try_from(objects).unwrap()) };
    assert_eq!(st, refl_status::Ok);
    n
}

#[test]
fn choices_len_is_the_cores() {
    for n in [0u32, 1, 2, 17, u32::MAX] {
        assert_eq!(c_choices_len(n as usize), choices_len(n as usize));
    }
    let st = unsafe { refl_plan_choices_len(core::ptr::null_mut(), 2) };
    assert_eq!(st, refl_status::NullPointer);
    assert!(last_error().contains("`out_len`"), "{}", last_error());
}

#[test]
fn c_call_equals_the_core_on_frames_hosts_and_budgets() {
    let t = table();
    let tc = table_c(&t);
    let mut checked = 0;
    for s in scenes() {
        let (oc, hc) = (objects_c(&s.objects), hints_c(&s.hints));
        let fc = refl_summary_frame::from(s.frame);
        for caps in &HOSTS {
            let cc = caps_c(caps);
            for &b in &BUDGETS {
                let n = choices_len(s.objects.len());
                let mut core = vec![Choice::default(); n];
                let want = try_choose_methods(
                    &mut core, &s.frame, &s.objects, &s.planar, &s.hints, caps, &t, b,
                )
                .unwrap();
                let mut choices = vec![blank_choice(); c_choices_len(s.objects.len())];
                let mut out = refl_plan_budget_plan::default();
                let bc = budget_c(b);
                let (st, allocs) = counted(|| unsafe {
                    refl_plan_choose_methods(
                        &mut out,
                        choices.as_mut_ptr(),
                        choices.len(),
                        &fc,
                        oc.as_ptr(),
                        oc.len(),
                        s.planar.as_ptr(),
                        s.planar.len(),
                        if hc.is_empty() {
                            core::ptr::null()
                        } else {
                            hc.as_ptr()
                        },
                        hc.len(),
                        &cc,
                        tc.as_ptr(),
                        tc.len(),
                        &bc,
                    )
                });
                assert_eq!(st, refl_status::Ok, "{b:?} {caps:?}");
                assert_eq!(allocs, 0);
                assert_eq!(
                    out,
                    refl_plan_budget_plan {
                        groups: want.groups,
                        reflective: want.reflective,
                        covered: want.covered,
                        time_ratio: want.time_ratio,
                        error_255: want.error_255,
                        met: want.met,
                    },
                    "{b:?} {caps:?}"
                );
                for k in 0..want.groups {
                    assert_eq!(
                        choices[k],
                        expected_choice(&core[k], &t, &want),
                        "group {k}, {b:?} {caps:?}"
                    );
                }
                // Records past the groups are untouched.
                for c in &choices[want.groups..] {
                    assert_eq!(*c, blank_choice());
                }
                if want.groups > 0 {
                    let ts: f64 = choices[..want.groups].iter().map(|c| c.time_share).sum();
                    assert!((ts - want.time_ratio).abs() <= 1e-9 * want.time_ratio.max(1.0));
                }
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 4 * HOSTS.len() * BUDGETS.len());
}

/// The inputs of one call, as raw parts a case can break.
struct Args {
    frame: *const refl_summary_frame,
    objects: *const refl_summary_object,
    objects_len: usize,
    planar: *const bool,
    planar_len: usize,
    hints: *const refl_plan_object_hints,
    hints_len: usize,
    caps: *const refl_plan_host_caps,
    table: *const refl_plan_cost_entry,
    table_len: usize,
    budget: *const refl_plan_budget,
    choices_len: usize,
    choices_null: bool,
    out_null: bool,
}

fn last_error() -> String {
    let mut buf = [0u8; 512];
    let k = unsafe { refl_last_error_message(buf.as_mut_ptr().cast(), buf.len()) };
    String::from_utf8_lossy(&buf[..k.min(511)]).to_string()
}

#[test]
fn refusals_name_the_argument_and_leave_outputs_untouched() {
    let s = &scenes()[1];
    let (oc, hc) = (objects_c(&s.objects), hints_c(&s.hints));
    let fc = refl_summary_frame::from(s.frame);
    let cc = caps_c(&HOSTS[0]);
    let tc = table_c(&table());
    let good_budget = budget_c(Budget::MaxError(5.0));
    let nan_budget = budget_c(Budget::MaxError(f32::NAN));
    let neg_budget = budget_c(Budget::MaxTime(-1.0));
    let inf_budget = budget_c(Budget::MaxTime(f32::INFINITY));
    let kind_budget = refl_plan_budget {
        kind: 2,
        value: 1.0,
    };
    let mut bad_time = tc.clone();
    bad_time[3].time_ratio = f32::NAN;
    let mut bad_class = tc.clone();
    bad_class[1].roughness_class = 3;
    let mut bad_surface = tc.clone();
    bad_surface[2].surface = 3;
    let mut no_pass = tc.clone();
    no_pass[4].passes = 0;
    let mut far_pass = tc.clone();
    far_pass[5].passes = 1 << REFL_PLAN_PASS_COUNT;
    let mut neg_error = tc.clone();
    neg_error[0].error_255 = -1.0;
    let big_objects = objects_c(&[object(5000, 0, 0), object(0, 0, 0)]);
    // Class counts that add up past UINT64_MAX (the fuzz target `plan`'s
    // `class-counts-sum-past-u64-max-overflow`).
    let mut huge_frame = fc;
    huge_frame.classes = [1 << 63; 3];
    let mut max_frame = fc;
    max_frame.classes = [u64::MAX, 0, 0];
    let half_objects = objects_c(&[object(1 << 63, 0, 0), object(1 << 63, 0, 0)]);
    // Scene 1: 3 + 1 object groups, 3 unlisted classes.
    let groups = 7;
    let good = || Args {
        frame: &fc,
        objects: oc.as_ptr(),
        objects_len: oc.len(),
        planar: s.planar.as_ptr(),
        planar_len: s.planar.len(),
        hints: hc.as_ptr(),
        hints_len: hc.len(),
        caps: &cc,
        table: tc.as_ptr(),
        table_len: tc.len(),
        budget: &good_budget,
        choices_len: choices_len(2),
        choices_null: false,
        out_null: false,
    };
    type Case<'a> = (&'a str, refl_status, &'a str, Box<dyn Fn(&mut Args) + 'a>);
    let null = refl_status::NullPointer;
    let inv = refl_status::InvalidArgument;
    let cases: Vec<Case> = vec![
        ("ok", refl_status::Ok, "", Box::new(|_| {})),
        ("out NULL", null, "`out`", Box::new(|a| a.out_null = true)),
        (
            "choices NULL",
            null,
            "`choices`",
            Box::new(|a| a.choices_null = true),
        ),
        (
            "frame NULL",
            null,
            "`frame`",
            Box::new(|a| a.frame = core::ptr::null()),
        ),
        (
            "objects NULL",
            null,
            "`objects`",
            Box::new(|a| a.objects = core::ptr::null()),
        ),
        (
            "planar NULL",
            null,
            "`planar`",
            Box::new(|a| a.planar = core::ptr::null()),
        ),
        (
            "hints NULL",
            null,
            "`hints`",
            Box::new(|a| a.hints = core::ptr::null()),
        ),
        (
            "caps NULL",
            null,
            "`caps`",
            Box::new(|a| a.caps = core::ptr::null()),
        ),
        (
            "table NULL",
            null,
            "`table`",
            Box::new(|a| a.table = core::ptr::null()),
        ),
        (
            "budget NULL",
            null,
            "`budget`",
            Box::new(|a| a.budget = core::ptr::null()),
        ),
        (
            "NaN budget",
            inv,
            "`budget`",
            Box::new(|a| a.budget = &nan_budget),
        ),
        (
            "negative budget",
            inv,
            "`budget`",
            Box::new(|a| a.budget = &neg_budget),
        ),
        (
            "infinite budget",
            inv,
            "`budget`",
            Box::new(|a| a.budget = &inf_budget),
        ),
        (
            "unknown budget kind",
            inv,
            "`budget`",
            Box::new(|a| a.budget = &kind_budget),
        ),
        (
            "NaN time",
            inv,
            "`table[3]`",
            Box::new(|a| a.table = bad_time.as_ptr()),
        ),
        (
            "unknown class",
            inv,
            "`table[1]`",
            Box::new(|a| a.table = bad_class.as_ptr()),
        ),
        (
            "unknown surface",
            inv,
            "`table[2]`",
            Box::new(|a| a.table = bad_surface.as_ptr()),
        ),
        (
            "empty pass mask",
            inv,
            "`table[4]`",
            Box::new(|a| a.table = no_pass.as_ptr()),
        ),
        (
            "pass past the last",
            inv,
            "`table[5]`",
            Box::new(|a| a.table = far_pass.as_ptr()),
        ),
        (
            "negative error",
            inv,
            "`table[0]`",
            Box::new(|a| a.table = neg_error.as_ptr()),
        ),
        (
            "hints of another count",
            inv,
            "`hints_len`",
            Box::new(|a| a.hints_len = 1),
        ),
        (
            "planar too short",
            inv,
            "`planar_len`",
            Box::new(|a| a.planar_len = 1),
        ),
        (
            "objects over the frame",
            inv,
            "`objects`",
            Box::new(|a| a.objects = big_objects.as_ptr()),
        ),
        (
            "frame classes past UINT64_MAX",
            inv,
            "`frame`",
            Box::new(|a| a.frame = &huge_frame),
        ),
        (
            "objects' classes past UINT64_MAX",
            inv,
            "`objects`",
            Box::new(|a| {
                a.frame = &max_frame;
                a.objects = half_objects.as_ptr();
            }),
        ),
        (
            "choices too short",
            refl_status::InsufficientSize,
            "`choices_len`",
            Box::new(|a| a.choices_len = groups - 1),
        ),
    ];
    for (what, want, name, f) in &cases {
        let mut a = good();
        f(&mut a);
        // The outputs as raw words, so the comparison covers every byte.
        let words = choices_len(2) * core::mem::size_of::<refl_plan_choice>() / 8;
        let mut choices = vec![0xA5A5_5A5A_0FF0_F00Fu64; words];
        let mut out = [0x1234_5678_9ABC_DEF0u64; 6];
        const _: () = assert!(core::mem::size_of::<refl_plan_budget_plan>() <= 48);
        let (before_c, before_o) = (choices.clone(), out);
        let st = unsafe {
            refl_plan_choose_methods(
                if a.out_null {
                    core::ptr::null_mut()
                } else {
                    out.as_mut_ptr().cast()
                },
                if a.choices_null {
                    core::ptr::null_mut()
                } else {
                    choices.as_mut_ptr().cast()
                },
                a.choices_len,
                a.frame,
                a.objects,
                a.objects_len,
                a.planar,
                a.planar_len,
                a.hints,
                a.hints_len,
                a.caps,
                a.table,
                a.table_len,
                a.budget,
            )
        };
        assert_eq!(st, *want, "{what}: {}", last_error());
        if *want == refl_status::Ok {
            let p: refl_plan_budget_plan = unsafe { core::ptr::read(out.as_ptr().cast()) };
            assert_eq!(p.groups, groups, "{what}");
            continue;
        }
        let msg = last_error();
        assert!(
            msg.starts_with("refl_plan_choose_methods: "),
            "{what}: {msg}"
        );
        assert!(msg.contains(name), "{what}: {msg} does not name {name}");
        assert_eq!(choices, before_c, "{what}: choices written");
        assert_eq!(out, before_o, "{what}: out written");
    }
}

#[test]
fn overlapping_choices_are_refused() {
    let s = &scenes()[0];
    let fc = refl_summary_frame::from(s.frame);
    let oc = objects_c(&s.objects);
    let cc = caps_c(&HOSTS[0]);
    let b = budget_c(Budget::MaxTime(1.0));
    // The table stored inside the choices buffer.
    let words = choices_len(3) * core::mem::size_of::<refl_plan_choice>() / 8;
    let mut buf = vec![0u64; words];
    let tc = table_c(&table());
    unsafe {
        core::ptr::copy_nonoverlapping(tc.as_ptr(), buf.as_mut_ptr().cast(), tc.len());
    }
    let before = buf.clone();
    let mut out = refl_plan_budget_plan::default();
    let st = unsafe {
        refl_plan_choose_methods(
            &mut out,
            buf.as_mut_ptr().cast(),
            choices_len(3),
            &fc,
            oc.as_ptr(),
            oc.len(),
            s.planar.as_ptr(),
            s.planar.len(),
            core::ptr::null(),
            0,
            &cc,
            buf.as_ptr().cast(),
            tc.len(),
            &b,
        )
    };
    assert_eq!(st, refl_status::InvalidArgument);
    assert_eq!(buf, before);
    assert_eq!(out, refl_plan_budget_plan::default());
}

/// A frame without reflective pixels has no group, so `choices` may be
/// NULL with `choices_len` 0 (the fuzz target `plan`'s
/// `null-choices-without-groups-slice-from-null`: the export formed a
/// slice from the NULL pointer, undefined behaviour that a build with
/// debug assertions aborts on).
#[test]
fn empty_frame_takes_null_choices() {
    let fc = refl_summary_frame::from(FrameSummary::default());
    let cc = caps_c(&HOSTS[0]);
    let tc = table_c(&table());
    let b = budget_c(Budget::MaxError(1.0));
    for choices in [
        core::ptr::null_mut(),
        core::ptr::NonNull::<refl_plan_choice>::dangling().as_ptr(),
    ] {
        let mut out = refl_plan_budget_plan {
            groups: 77,
            ..Default::default()
        };
        let st = unsafe {
            refl_plan_choose_methods(
                &mut out,
                choices,
                0,
                &fc,
                core::ptr::null(),
                0,
                core::ptr::null(),
                0,
                core::ptr::null(),
                0,
                &cc,
                tc.as_ptr(),
                tc.len(),
                &b,
            )
        };
        assert_eq!(st, refl_status::Ok, "{}", last_error());
        assert_eq!(out.groups, 0);
        assert_eq!(out.covered, 0);
    }
}
