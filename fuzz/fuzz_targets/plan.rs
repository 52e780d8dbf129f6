//! Fuzz target: the method choice by budget (issue 15) in the C ABI,
//! `refl_plan_choices_len` and `refl_plan_choose_methods`, over fuzzed
//! summaries: 0 to 12 object records (fuzzed class counts, sometimes huge
//! or more than the frame's; sometimes a huge `objects_len` over a short
//! buffer), a frame record (its counts mostly the objects' plus unlisted
//! pixels), `planar` flags and hints (valid bools, any length), host caps,
//! a cost table of 0 to 10 entries (classes, surfaces and pass masks as
//! the raw integers a C caller can pass, unknown ones included; NaN, Inf,
//! negative, -0 and huge times and errors; a `table_len` of
//! `REFL_PLAN_NO_ENTRY` or more), budgets of both kinds and unknown ones
//! (NaN, Inf, negative, 0, huge limits), a `choices` buffer of exactly the
//! groups, short, empty, longer, `refl_plan_choices_len`'s length or a huge
//! length, and pointers NULL, misaligned or `choices` over an input.
//!
//! Checked: the NULL and error rules (nothing written on error, inputs
//! never written, the last-error message), valid input accepted and every
//! refusal one the header lists for the input; on OK the groups (count,
//! order, object, class, pixels, `planar`), records past `out->groups`
//! untouched, `out->groups <= refl_plan_choices_len(objects_len)`, each
//! choice against the header's rules (applicable options and the Pareto
//! front counted from the table, the entry on the front or
//! `REFL_PLAN_NO_ENTRY` exactly for `NO_OPTION`, indices below
//! `table_len`, the entry's copied fields, the next faster and next more
//! accurate front options, the reason against them and the budget), the
//! plan's totals (covered pixels, time and error as the pixel-weighted
//! sums, `met` against the budget, the shares adding up to the totals),
//! the end state of the greedy search the header refers to (the core's
//! docs: under a met time budget no more accurate step fits, under a met
//! error budget no group's faster option keeps it), two calls with the
//! same input alike field for field, and `refl_plan_choices_len`'s length
//! always enough (the same groups).
//!
//! Its first runs found two refl bugs, both fixed (`fuzz/README.md`, F37
//! and F38; reproducers in `fuzz/artifacts-found/plan/`, also in the
//! corpus): a NULL `choices` of length 0 for a frame without groups was
//! undefined behaviour (F37), and class counts whose sum passes
//! `u64::MAX` overflowed in the core (F38); the target checks both
//! strictly: the first call succeeds, the second is refused.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const NO_ENTRY: u32 = REFL_PLAN_NO_ENTRY;
const NO_OBJECT: u32 = REFL_SUMMARY_NO_OBJECT;
/// Every known bit of a pass mask.
const PASS_MASK: u32 = (1 << REFL_PLAN_PASS_COUNT) - 1;
const PASSES: [refl_plan_pass; REFL_PLAN_PASS_COUNT] = [
    refl_plan_pass::Hiz,
    refl_plan_pass::Planar,
    refl_plan_pass::Mirror,
    refl_plan_pass::ColorPyramid,
    refl_plan_pass::VisibilityPyramid,
    refl_plan_pass::Glossy,
    refl_plan_pass::Layered,
    refl_plan_pass::HostRays,
    refl_plan_pass::Probe,
    refl_plan_pass::Temporal,
];

const fn bit(p: refl_plan_pass) -> u32 {
    1 << p as u32
}

const RAY: u32 = bit(refl_plan_pass::HostRays);
const PLANAR: u32 = bit(refl_plan_pass::Planar);
const PROBE: u32 = bit(refl_plan_pass::Probe);
const SCREEN: u32 = bit(refl_plan_pass::Hiz) | bit(refl_plan_pass::Mirror);
const LAYERED: u32 = bit(refl_plan_pass::Hiz) | bit(refl_plan_pass::Layered);
const GLOSSY: u32 = bit(refl_plan_pass::Hiz)
    | bit(refl_plan_pass::ColorPyramid)
    | bit(refl_plan_pass::VisibilityPyramid)
    | bit(refl_plan_pass::Glossy);
const MASKS: [u32; 10] = [
    RAY,
    PLANAR,
    PROBE,
    SCREEN,
    LAYERED,
    GLOSSY,
    SCREEN | RAY,
    LAYERED | RAY,
    GLOSSY | RAY,
    PLANAR | SCREEN,
];

/// Reasons (`refl_plan_choice_reason`) as the raw values of the records.
const FASTEST: u32 = refl_plan_choice_reason::Fastest as u32;
const TRADE_OFF: u32 = refl_plan_choice_reason::TradeOff as u32;
const MOST_ACCURATE: u32 = refl_plan_choice_reason::MostAccurate as u32;
const ERROR_UNREACHABLE: u32 = refl_plan_choice_reason::ErrorBudgetUnreachable as u32;
const TIME_UNREACHABLE: u32 = refl_plan_choice_reason::TimeBudgetUnreachable as u32;
const ONLY_OPTION: u32 = refl_plan_choice_reason::OnlyOption as u32;
const NO_OPTION: u32 = refl_plan_choice_reason::NoOption as u32;

/// A huge length (passed over a short buffer).
fn huge(b: &mut Bytes) -> usize {
    b.pick(&[
        usize::MAX,
        isize::MAX as usize,
        1 << 40,
        u32::MAX as usize,
        u32::MAX as usize + 1,
    ])
}

/// A pixel count: mostly 0 or small, sometimes large or extreme.
fn count(b: &mut Bytes) -> u64 {
    match b.u8() {
        0..=89 => 0,
        90..=209 => u64::from(b.u16() % 2000),
        210..=229 => u64::from(b.u32()),
        230..=243 => b.pick(&[
            1 << 53,
            (1 << 53) + 1,
            1 << 62,
            1 << 63,
            u64::MAX / 3,
            u64::MAX / 2,
        ]),
        244..=249 => u64::MAX,
        _ => b.u64(),
    }
}

/// A double for the fields the choice does not read (the plane sums).
fn f64_any(b: &mut Bytes) -> f64 {
    match b.u8() {
        0..=7 => f64::from_bits(b.u64()),
        _ => f64::from(b.f32_any()),
    }
}

fn object(b: &mut Bytes) -> refl_summary_object {
    let classes = [count(b), count(b), count(b)];
    let mut o = refl_summary_object {
        pixels: classes.iter().fold(0u64, |a, &c| a.saturating_add(c)),
        classes,
        ..Default::default()
    };
    if b.chance(16) {
        // The fields the choice does not read, fuzzed.
        o.pixels = b.u64();
        o.border_pixels = b.u64();
        o.rect = [b.u32(), b.u32(), b.u32(), b.u32()];
        o.origin = [f64_any(b), f64_any(b), f64_any(b)];
        o.normal_sum = [f64_any(b), f64_any(b), f64_any(b)];
        o.point_sum = [f64_any(b), f64_any(b), f64_any(b)];
        o.point_products = [
            f64_any(b),
            f64_any(b),
            f64_any(b),
            f64_any(b),
            f64_any(b),
            f64_any(b),
        ];
        o.depth_sum = f64_any(b);
    }
    o
}

/// The frame: mostly the objects' counts plus unlisted pixels per class,
/// sometimes fuzzed counts (fewer than the objects' included).
fn frame(b: &mut Bytes, objs: &[refl_summary_object]) -> refl_summary_frame {
    let listed = listed(objs);
    let mut f = refl_summary_frame::default();
    let fuzzed = b.chance(24);
    for c in 0..3 {
        f.classes[c] = if fuzzed {
            count(b)
        } else {
            listed[c].saturating_add(if b.chance(100) { count(b) } else { 0 })
        };
    }
    f.reflective = match b.u8() {
        0..=15 => count(b),
        _ => f.classes.iter().fold(0u64, |a, &c| a.saturating_add(c)),
    };
    if b.chance(16) {
        f.pixels = b.u64();
        f.surfaces = b.u64();
        f.border = b.u64();
        f.unlisted = b.u64();
        f.tiles = [b.u64(), b.u64(), b.u64(), b.u64()];
    }
    f
}

/// A time or error: from a grid (ties and dominance), in `[0, hi]`, or
/// (`bad`) sometimes hostile.
fn cost(b: &mut Bytes, grid: &[f32], hi: f32, bad: bool) -> f32 {
    match b.u8() {
        0..=23 if bad => b.f32_special(),
        0..=7 => b.pick(&[-0.0, 0.0, 1e-45, f32::MAX, 1e30]),
        8..=149 => b.pick(grid),
        _ => b.f32_fine(0.0, hi),
    }
}

fn entry(b: &mut Bytes, bad: bool) -> refl_plan_cost_entry {
    let roughness_class = match b.u8() {
        0..=15 if bad => b.pick(&[3u8, 4, 0x80, 0xFF]),
        k => k % 3,
    };
    let surface = match b.u8() {
        0..=15 if bad => b.pick(&[3u32, 7, 1 << 31, u32::MAX]),
        k => u32::from(k) % 3,
    };
    let passes = match b.u8() {
        0..=7 if bad => b.pick(&[0, 1 << REFL_PLAN_PASS_COUNT, u32::MAX, RAY | 1 << 31]),
        0..=47 => match b.u32() & PASS_MASK {
            0 => RAY,
            m => m,
        },
        _ => b.pick(&MASKS),
    };
    refl_plan_cost_entry {
        id: if b.chance(32) {
            b.u32()
        } else {
            u32::from(b.u8())
        },
        roughness_class,
        surface,
        passes,
        time_ratio: cost(
            b,
            &[0.0, 0.05, 0.3, 0.4, 0.6, 0.7, 1.0, 4.0, 16.0],
            32.0,
            bad,
        ),
        error_255: cost(b, &[0.0, 1.0, 2.0, 3.0, 6.0, 8.0, 20.0, 30.0], 255.0, bad),
    }
}

fn entry_ok(e: &refl_plan_cost_entry) -> bool {
    let fine = |v: f32| v.is_finite() && v >= 0.0;
    e.roughness_class <= 2
        && e.surface <= 2
        && e.passes != 0
        && e.passes & !PASS_MASK == 0
        // No option runs the temporal pass (it follows the mirror pass).
        && e.passes & bit(refl_plan_pass::Temporal) == 0
        && fine(e.time_ratio)
        && fine(e.error_255)
}

fn budget(b: &mut Bytes) -> refl_plan_budget {
    let kind = match b.u8() {
        0..=5 => b.pick(&[2, 3, 0x100, u32::MAX]),
        k => u32::from(k & 1),
    };
    let value = match b.u8() {
        0..=11 => b.f32_special(),
        12..=111 => b.pick(&[0.0, -0.0, 0.5, 1.0, 2.0, 5.0, 40.0, 100.0, 1e30, f32::MAX]),
        _ => b.f32_fine(0.0, if kind == 0 { 40.0 } else { 8.0 }),
    };
    refl_plan_budget { kind, value }
}

fn budget_ok(bu: &refl_plan_budget) -> bool {
    bu.kind <= 1 && bu.value.is_finite() && bu.value >= 0.0
}

/// The objects' pixels per class (saturating, as a C caller's sum would
/// not wrap past the frame's).
fn listed(objs: &[refl_summary_object]) -> [u64; 3] {
    let mut l = [0u64; 3];
    for o in objs {
        for c in 0..3 {
            l[c] = l[c].saturating_add(o.classes[c]);
        }
    }
    l
}

/// The groups of the frame: one per object and class with pixels, one per
/// class with unlisted pixels.
fn needed(f: &refl_summary_frame, objs: &[refl_summary_object]) -> usize {
    let l = listed(objs);
    objs.iter()
        .map(|o| o.classes.iter().filter(|&&c| c > 0).count())
        .sum::<usize>()
        + (0..3).filter(|&c| f.classes[c] > l[c]).count()
}

/// One group of the model: an object's pixels of one class, or the
/// unlisted ones.
#[derive(Clone, Copy, Debug)]
struct Group {
    object: u32,
    class: u32,
    pixels: u64,
    planar: bool,
    layered: bool,
}

/// The groups the header describes (one per object and class with pixels,
/// then one per class with unlisted pixels), in that order.
fn groups(
    f: &refl_summary_frame,
    objs: &[refl_summary_object],
    planar: &[bool],
    hints: &[refl_plan_object_hints],
) -> Vec<Group> {
    let mut gs = Vec::new();
    for (k, o) in objs.iter().enumerate() {
        for c in 0..3 {
            if o.classes[c] > 0 {
                gs.push(Group {
                    object: k as u32,
                    class: c as u32,
                    pixels: o.classes[c],
                    planar: planar[k],
                    // A moving object's maps are stale.
                    layered: hints.get(k).is_some_and(|h| h.layered_map && !h.moving),
                });
            }
        }
    }
    let l = listed(objs);
    for c in 0..3 {
        if f.classes[c] > l[c] {
            gs.push(Group {
                object: NO_OBJECT,
                class: c as u32,
                pixels: f.classes[c] - l[c],
                planar: false,
                layered: false,
            });
        }
    }
    gs
}

/// Whether entry `e` applies to `g`: its class and surface match, and the
/// host offers every pass it runs (extra views for a plane, a tracer, a
/// probe, the object's layered maps; the screen-space passes are built in
/// this library: every family is).
fn applies(e: &refl_plan_cost_entry, g: &Group, caps: &refl_plan_host_caps) -> bool {
    let surface = match e.surface {
        0 => true,
        1 => g.planar,
        _ => !g.planar,
    };
    let offered = |p: refl_plan_pass| match p {
        refl_plan_pass::Planar => caps.planar_views && g.planar,
        refl_plan_pass::Layered => g.layered,
        refl_plan_pass::HostRays => caps.ray_tracer,
        refl_plan_pass::Probe => caps.probe,
        _ => true,
    };
    u32::from(e.roughness_class) == g.class
        && surface
        && PASSES.iter().all(|&p| e.passes & bit(p) == 0 || offered(p))
}

/// `(time, error)` of an entry.
fn point(e: &refl_plan_cost_entry) -> (f32, f32) {
    (e.time_ratio, e.error_255)
}

fn dominates(a: (f32, f32), b: (f32, f32)) -> bool {
    a.0 <= b.0 && a.1 <= b.1 && (a.0 < b.0 || a.1 < b.1)
}

/// The Pareto front of the options that apply: its distinct points
/// (entries of equal time and error are one point).
fn front(table: &[refl_plan_cost_entry], ok: &[usize]) -> Vec<(f32, f32)> {
    let mut pts: Vec<(f32, f32)> = Vec::new();
    for &i in ok {
        let p = point(&table[i]);
        if !ok.iter().any(|&j| dominates(point(&table[j]), p))
            && !pts.iter().any(|q| q.0 == p.0 && q.1 == p.1)
        {
            pts.push(p);
        }
    }
    pts
}

/// `|a - b|` within `1e-9` of the larger (sums in another order).
fn near(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

/// The end state of the greedy search the header refers to (the core's
/// `try_choose_methods` docs), for a budget that is met: under
/// `MAX_TIME` no step to a more accurate front option still fits the time
/// left; under `MAX_ERROR` (after "every group in turn goes back to the
/// fastest option that keeps" the limit) no group's faster front option
/// keeps it. Both recomputed as the core's docs state them: pixel-weighted
/// sums in the groups' order.
fn check_greedy(
    p: &refl_plan_budget_plan,
    cs: &[refl_plan_choice],
    fronts: &[Vec<usize>],
    table: &[refl_plan_cost_entry],
    bu: &refl_plan_budget,
) {
    let what = "refl_plan_choose_methods";
    let limit = f64::from(bu.value);
    let r = p.reflective.max(1) as f64;
    for (k, c) in cs.iter().enumerate() {
        if c.entry == NO_ENTRY {
            continue;
        }
        let cur = &table[c.entry as usize];
        for &j in &fronts[k] {
            let o = &table[j];
            if bu.kind == 1 && o.error_255 < cur.error_255 {
                let dt = f64::from(o.time_ratio) - f64::from(cur.time_ratio);
                let left = limit - p.time_ratio;
                assert!(dt * c.pixels as f64 / r > left, "{what}: group {k} could still step to entry {j} {o:?} within {bu:?}: {p:?} {c:?}");
            }
            if bu.kind == 0 && o.time_ratio < cur.time_ratio {
                let e: f64 = cs
                    .iter()
                    .enumerate()
                    .filter(|(_, x)| x.entry != NO_ENTRY)
                    .fold(0.0, |a, (i, x)| {
                        a + x.pixels as f64
                            * f64::from(if i == k { o.error_255 } else { x.error_255 })
                    });
                let err = e / p.covered as f64;
                assert!(err > limit, "{what}: group {k} could go back to the faster entry {j} {o:?} (error {err}) within {bu:?}: {p:?} {c:?}");
            }
        }
    }
}

/// The caller's arguments (inputs), as passed.
struct Input {
    frame: Buf<refl_summary_frame>,
    objects: Buf<refl_summary_object>,
    objects_len: usize,
    planar: Buf<bool>,
    planar_len: usize,
    hints: Buf<refl_plan_object_hints>,
    hints_len: usize,
    caps: Buf<refl_plan_host_caps>,
    table: Buf<refl_plan_cost_entry>,
    table_len: usize,
    budget: Buf<refl_plan_budget>,
}

impl Input {
    /// `refl_plan_choose_methods` into `out` and `choices[0 .. choices_len]`.
    ///
    /// # Safety
    /// The pointers as the buffers say (valid for their lengths, NULL or
    /// misaligned); a length past its buffer only where refl refuses it
    /// before reading or writes no further than the buffer.
    unsafe fn choose(
        &self,
        out: *mut refl_plan_budget_plan,
        choices: *mut refl_plan_choice,
        choices_len: usize,
    ) -> refl_status {
        // SAFETY: as the caller says.
        unsafe {
            refl_plan_choose_methods(
                out,
                choices,
                choices_len,
                self.frame.cptr(),
                self.objects.cptr(),
                self.objects_len,
                self.planar.cptr(),
                self.planar_len,
                self.hints.cptr(),
                self.hints_len,
                self.caps.cptr(),
                self.table.cptr(),
                self.table_len,
                self.budget.cptr(),
            )
        }
    }

    fn snapshot(&self) -> [Vec<u8>; 7] {
        [
            self.frame.snapshot(),
            self.objects.snapshot(),
            self.planar.snapshot(),
            self.hints.snapshot(),
            self.caps.snapshot(),
            self.table.snapshot(),
            self.budget.snapshot(),
        ]
    }

    #[track_caller]
    fn assert_unchanged(&self, s: &[Vec<u8>; 7], what: &str) {
        self.frame
            .assert_unchanged(&s[0], &format!("{what}: frame"));
        self.objects
            .assert_unchanged(&s[1], &format!("{what}: objects"));
        self.planar
            .assert_unchanged(&s[2], &format!("{what}: planar"));
        self.hints
            .assert_unchanged(&s[3], &format!("{what}: hints"));
        self.caps.assert_unchanged(&s[4], &format!("{what}: caps"));
        self.table
            .assert_unchanged(&s[5], &format!("{what}: table"));
        self.budget
            .assert_unchanged(&s[6], &format!("{what}: budget"));
    }
}

/// A second call with fresh outputs of `choices_len` records: its status,
/// plan and choices.
fn call_again(
    inp: &Input,
    choices_len: usize,
) -> (
    refl_status,
    refl_plan_budget_plan,
    Vec<refl_plan_choice>,
    Buf<refl_plan_choice>,
) {
    let mut out = out1::<refl_plan_budget_plan>(PtrKind::Valid);
    let mut ch = Buf::<refl_plan_choice>::sentinel(choices_len, PtrKind::Valid);
    // SAFETY: valid outputs of their lengths; the inputs as in the first call.
    let s = unsafe { inp.choose(out.ptr(), ch.ptr(), choices_len) };
    let what = "refl_plan_choose_methods";
    null_rules_m(s, false, false, false, what);
    if s != refl_status::Ok {
        assert!(
            out.is_sentinel(0) && (0..choices_len).all(|i| ch.is_sentinel(i)),
            "{what}: wrote on error (second call)"
        );
        return (s, refl_plan_budget_plan::default(), Vec::new(), ch);
    }
    let p = out.get(0);
    // (Records refl wrote: `p.groups` of them.)
    let cs = (0..p.groups.min(choices_len)).map(|i| ch.get(i)).collect();
    (s, p, cs, ch)
}

/// The fields of a choice, floats as bits (padding not compared).
fn choice_bits(c: &refl_plan_choice) -> [u64; 16] {
    [
        c.object.into(),
        c.roughness_class.into(),
        c.pixels,
        c.entry.into(),
        c.reason.into(),
        c.applicable.into(),
        c.front.into(),
        c.faster.into(),
        c.more_accurate.into(),
        c.id.into(),
        c.passes.into(),
        c.time_ratio.to_bits().into(),
        c.error_255.to_bits().into(),
        c.time_share.to_bits(),
        c.error_share.to_bits(),
        c.planar.into(),
    ]
}

fn plan_bits(p: &refl_plan_budget_plan) -> [u64; 6] {
    [
        p.groups as u64,
        p.reflective,
        p.covered,
        p.time_ratio.to_bits(),
        p.error_255.to_bits(),
        p.met.into(),
    ]
}

/// The header's promises of an accepted call: `p` and its `cs` (the first
/// `p.groups` records) for the model's input.
#[allow(clippy::too_many_arguments)]
fn check_ok(
    p: &refl_plan_budget_plan,
    cs: &[refl_plan_choice],
    f: &refl_summary_frame,
    objs: &[refl_summary_object],
    planar: &[bool],
    hints: &[refl_plan_object_hints],
    caps: &refl_plan_host_caps,
    table: &[refl_plan_cost_entry],
    bu: &refl_plan_budget,
) {
    let what = "refl_plan_choose_methods";
    let gs = groups(f, objs, planar, hints);
    assert_eq!(p.groups, gs.len(), "{what}: groups {p:?} for {f:?}");
    assert_eq!(cs.len(), gs.len());
    let mut full = 0usize;
    // SAFETY: a valid output.
    let s = unsafe { refl_plan_choices_len(&mut full, objs.len() as u32) };
    assert_eq!(s, refl_status::Ok);
    assert!(
        p.groups <= full,
        "{what}: {} groups, refl_plan_choices_len {full}",
        p.groups
    );
    let sum_classes = f.classes.iter().fold(0u64, |a, &c| a.saturating_add(c));
    // The reflective pixels: the frame's count, or its classes' (the header
    // does not say which when they differ).
    assert!(
        p.reflective == f.reflective || p.reflective == sum_classes,
        "{what}: reflective {} of {f:?}",
        p.reflective
    );
    assert!(
        p.covered <= p.reflective,
        "{what}: covered {} of {} reflective",
        p.covered,
        p.reflective
    );

    // The groups: in object order, the unlisted last, one per class.
    for w in cs.windows(2) {
        assert!(
            w[0].object <= w[1].object,
            "{what}: object {} before {}",
            w[0].object,
            w[1].object
        );
    }
    let mut keys: Vec<(u32, u32)> = cs.iter().map(|c| (c.object, c.roughness_class)).collect();
    keys.sort_unstable();
    keys.dedup();
    assert_eq!(keys.len(), cs.len(), "{what}: a group twice");
    let (mut covered, mut t_sum, mut e_sum) = (0u64, 0f64, 0f64);
    let mut unreach = None;
    // Per record: the applicable entries on the front (by index).
    let mut on_front: Vec<Vec<usize>> = Vec::with_capacity(cs.len());
    for c in cs {
        let g = gs
            .iter()
            .find(|g| g.object == c.object && g.class == c.roughness_class)
            .unwrap_or_else(|| {
                panic!(
                    "{what}: a group of object {} class {} not in the frame",
                    c.object, c.roughness_class
                )
            });
        assert_eq!(
            (c.pixels, c.planar),
            (g.pixels, g.planar),
            "{what}: group {g:?} as {c:?}"
        );
        assert!(c.reason <= NO_OPTION, "{what}: reason {}", c.reason);
        let ok: Vec<usize> = (0..table.len())
            .filter(|&i| applies(&table[i], g, caps))
            .collect();
        let fr = front(table, &ok);
        on_front.push(
            ok.iter()
                .copied()
                .filter(|&i| fr.contains(&point(&table[i])))
                .collect(),
        );
        assert_eq!(
            c.applicable as usize,
            ok.len(),
            "{what}: applicable of {g:?}: {c:?}"
        );
        assert_eq!(
            c.front as usize,
            fr.len(),
            "{what}: front of {g:?}: {c:?} ({fr:?})"
        );
        for i in [c.entry, c.faster, c.more_accurate] {
            assert!(
                i == NO_ENTRY || (i as usize) < table.len(),
                "{what}: index {i} of {} entries",
                table.len()
            );
        }
        if ok.is_empty() {
            assert!(
                c.entry == NO_ENTRY && c.reason == NO_OPTION,
                "{what}: no option applies to {g:?}: {c:?}"
            );
            assert!(
                c.faster == NO_ENTRY && c.more_accurate == NO_ENTRY,
                "{what}: neighbors without an entry: {c:?}"
            );
            assert!(
                c.id == 0 && c.passes == 0 && c.time_ratio == 0.0 && c.error_255 == 0.0,
                "{what}: fields without an entry: {c:?}"
            );
            assert!(
                c.time_share == 0.0 && c.error_share == 0.0,
                "{what}: shares without an entry: {c:?}"
            );
            continue;
        }
        assert!(
            c.entry != NO_ENTRY && c.reason != NO_OPTION,
            "{what}: {} options apply to {g:?}: {c:?}",
            ok.len()
        );
        let e = &table[c.entry as usize];
        let cur = point(e);
        assert!(
            ok.contains(&(c.entry as usize)) && fr.contains(&cur),
            "{what}: entry {} {e:?} not on the front {fr:?}",
            c.entry
        );
        assert!(
            c.id == e.id
                && c.passes == e.passes
                && same_f32(c.time_ratio, e.time_ratio)
                && same_f32(c.error_255, e.error_255),
            "{what}: fields {c:?} of entry {e:?}"
        );
        // The next faster / more accurate front points, not taken.
        let faster = fr
            .iter()
            .filter(|q| q.0 < cur.0)
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .copied();
        let accurate = fr
            .iter()
            .filter(|q| q.1 < cur.1)
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .copied();
        for (idx, want, name) in [
            (c.faster, faster, "faster"),
            (c.more_accurate, accurate, "more accurate"),
        ] {
            match want {
                None => assert_eq!(idx, NO_ENTRY, "{what}: {name} of {c:?} with front {fr:?}"),
                Some(q) => {
                    assert!(
                        idx != NO_ENTRY,
                        "{what}: no {name} for {c:?} with front {fr:?}"
                    );
                    let pq = point(&table[idx as usize]);
                    assert!(
                        ok.contains(&(idx as usize)) && pq.0 == q.0 && pq.1 == q.1,
                        "{what}: {name} {idx} {pq:?}, want {q:?} ({c:?}, front {fr:?})"
                    );
                }
            }
        }
        match c.reason {
            ONLY_OPTION => assert_eq!(fr.len(), 1, "{what}: only option with front {fr:?}"),
            r => {
                assert!(fr.len() > 1, "{what}: reason {r} with a front of one");
                match r {
                    FASTEST => assert!(c.faster == NO_ENTRY, "{what}: fastest {c:?}"),
                    TRADE_OFF => assert!(
                        c.faster != NO_ENTRY && c.more_accurate != NO_ENTRY,
                        "{what}: trade-off {c:?}"
                    ),
                    MOST_ACCURATE => assert!(
                        c.more_accurate == NO_ENTRY && c.faster != NO_ENTRY,
                        "{what}: most accurate {c:?}"
                    ),
                    ERROR_UNREACHABLE | TIME_UNREACHABLE => {
                        assert!(
                            unreach.is_none_or(|u| u == r),
                            "{what}: both unreachable reasons"
                        );
                        unreach = Some(r);
                    }
                    _ => unreachable!(),
                }
                if matches!(r, FASTEST | TRADE_OFF | MOST_ACCURATE) {
                    // "and the budget holds with it" / "within the budget".
                    assert!(
                        p.met,
                        "{what}: reason {r} but the budget is not met: {p:?} {bu:?}"
                    );
                }
            }
        }
        let px = c.pixels as f64;
        covered += c.pixels;
        t_sum += px * f64::from(e.time_ratio);
        e_sum += px * f64::from(e.error_255);
    }
    if let Some(r) = unreach {
        let kind = if r == ERROR_UNREACHABLE { 0 } else { 1 };
        assert_eq!(bu.kind, kind, "{what}: reason {r} under budget {bu:?}");
        assert!(!p.met, "{what}: unreachable but met: {p:?}");
        for c in cs.iter().filter(|c| c.entry != NO_ENTRY) {
            // Every group takes its most accurate (error) or fastest (time)
            // option; those with more than one say why.
            let n = if r == ERROR_UNREACHABLE {
                c.more_accurate
            } else {
                c.faster
            };
            assert_eq!(n, NO_ENTRY, "{what}: reason {r} but {c:?}");
            assert!(
                c.reason == r || c.reason == ONLY_OPTION,
                "{what}: reason {} beside {r}",
                c.reason
            );
        }
    }
    assert_eq!(p.covered, covered, "{what}: covered {p:?}");
    let want_t = if p.reflective > 0 {
        t_sum / p.reflective as f64
    } else {
        t_sum
    };
    let want_e = if covered > 0 {
        e_sum / covered as f64
    } else {
        0.0
    };
    assert!(
        near(p.time_ratio, want_t),
        "{what}: time {} want {want_t}",
        p.time_ratio
    );
    assert!(
        near(p.error_255, want_e),
        "{what}: error {} want {want_e}",
        p.error_255
    );
    let limit = f64::from(bu.value);
    let met = if bu.kind == 0 {
        p.error_255 <= limit
    } else {
        p.time_ratio <= limit
    };
    assert_eq!(p.met, met, "{what}: met of {p:?} under {bu:?}");
    if p.met {
        check_greedy(p, cs, &on_front, table, bu);
    }
    // The shares: each group's part, adding up to the totals.
    let (mut ts, mut es) = (0f64, 0f64);
    for c in cs.iter().filter(|c| c.entry != NO_ENTRY) {
        let px = c.pixels as f64;
        let t = px * f64::from(c.time_ratio) / p.reflective.max(1) as f64;
        let e = px * f64::from(c.error_255) / covered.max(1) as f64;
        assert!(
            near(c.time_share, t) && near(c.error_share, e),
            "{what}: shares {c:?} want {t} {e}"
        );
        ts += c.time_share;
        es += c.error_share;
    }
    assert!(
        near(ts, p.time_ratio) || (ts - p.time_ratio).abs() <= 1e-9 * p.time_ratio.abs().max(1.0),
        "{what}: time shares {ts} of {}",
        p.time_ratio
    );
    assert!(
        near(es, p.error_255) || (es - p.error_255).abs() <= 1e-9 * p.error_255.abs().max(1.0),
        "{what}: error shares {es} of {}",
        p.error_255
    );
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);

    // refl_plan_choices_len: (objects + 1) * 3, the NULL and error rules.
    {
        let objects = match b.u8() % 4 {
            0 => b.pick(&[0, 1, 12, u32::MAX, u32::MAX - 1, 1 << 31]),
            _ => u32::from(b.u8() % 16),
        };
        let mut out = out1::<usize>(b.ptr_kind());
        // SAFETY: NULL, misaligned or valid for one usize.
        let s = unsafe { refl_plan_choices_len(out.ptr(), objects) };
        let what = "refl_plan_choices_len";
        null_rules_m(
            s,
            out.is_null(),
            out.is_null(),
            out.kind() == PtrKind::Misaligned,
            what,
        );
        on_error_untouched(s, &[("out_len", out.is_sentinel(0))], what);
        assert_eq!(
            s == refl_status::Ok,
            out.usable(),
            "{what}: status {s:?} for a {:?} pointer",
            out.kind()
        );
        if s == refl_status::Ok {
            let n = out.get(0);
            assert_eq!(n, (objects as usize + 1) * 3, "{what}: {objects} objects");
        }
    }

    // The summary.
    let n = match b.u8() {
        0..=15 => 0,
        k => usize::from(k % 13),
    };
    let objs: Vec<refl_summary_object> = (0..n).map(|_| object(&mut b)).collect();
    let f = frame(&mut b, &objs);
    // F38: counts whose sum passes u64::MAX (the frame's classes, or the
    // objects' of one class) are refused (INVALID_ARGUMENT).
    let wide =
        |xs: &mut dyn Iterator<Item = u64>| xs.map(u128::from).sum::<u128>() > u128::from(u64::MAX);
    let frame_overflow = wide(&mut f.classes.iter().copied());
    let objects_overflow = (0..3).any(|c| wide(&mut objs.iter().map(|o| o.classes[c])));
    let mut planar_v: Vec<bool> = {
        let len = match b.u8() {
            0..=9 => n.saturating_sub(1 + usize::from(b.u8() % 3)),
            10..=29 => n + usize::from(b.u8() % 4),
            _ => n,
        };
        (0..len).map(|_| b.bool()).collect()
    };
    let hints_v: Vec<refl_plan_object_hints> = {
        let len = match b.u8() {
            0..=79 => 0,
            80..=87 => n + 1,
            88..=95 => n.saturating_sub(1),
            _ => n,
        };
        (0..len)
            .map(|_| refl_plan_object_hints {
                planar_mirror: b.bool(),
                layered_map: b.bool(),
                moving: b.chance(4),
            })
            .collect()
    };
    let caps_v = refl_plan_host_caps {
        planar_views: b.bool(),
        ray_tracer: b.bool(),
        probe: b.bool(),
    };
    let bad = b.chance(40);
    let tn = match b.u8() {
        0..=15 => 0,
        k => usize::from(k % 11),
    };
    let table_v: Vec<refl_plan_cost_entry> = (0..tn).map(|_| entry(&mut b, bad)).collect();
    let bu = budget(&mut b);

    // Lengths (one sometimes huge over its short buffer) and pointers.
    let huge_of = if b.chance(12) { b.below(5) } else { 5 };
    let huge_len = huge(&mut b);
    if huge_of == 1 && planar_v.len() < n {
        // A huge `planar_len` over a buffer of the objects' flags at least
        // (what refl reads).
        planar_v.resize(n, false);
    }
    let all_valid = b.chance(216);
    let kind = |b: &mut Bytes| {
        if all_valid {
            PtrKind::Valid
        } else {
            b.ptr_kind()
        }
    };
    let inp = Input {
        frame: Buf::from_slice(&[f], kind(&mut b)),
        objects: Buf::from_slice(&objs, kind(&mut b)),
        objects_len: if huge_of == 0 { huge_len } else { n },
        planar: Buf::from_slice(&planar_v, kind(&mut b)),
        planar_len: if huge_of == 1 {
            huge_len
        } else {
            planar_v.len()
        },
        hints: Buf::from_slice(&hints_v, kind(&mut b)),
        hints_len: if huge_of == 2 {
            huge_len
        } else {
            hints_v.len()
        },
        caps: Buf::from_slice(&[caps_v], kind(&mut b)),
        table: Buf::from_slice(&table_v, kind(&mut b)),
        table_len: if huge_of == 3 {
            huge_len.max(NO_ENTRY as usize)
        } else {
            tn
        },
        budget: Buf::from_slice(&[bu], kind(&mut b)),
    };
    let okind = kind(&mut b);
    let ckind = kind(&mut b);

    // What the header asks of the input.
    let listed_v = listed(&objs);
    let over_frame = (0..3).any(|c| listed_v[c] > f.classes[c]);
    let needed = needed(&f, &objs);
    let full = (n + 1) * 3;
    let cbuf = match b.u8() % 16 {
        0 => 0,
        1 => needed.saturating_sub(1 + usize::from(b.u8() % 4)),
        2 => full,
        3 => needed + 1 + usize::from(b.u8() % 8),
        _ => needed,
    };
    // A huge `choices_len` over a buffer of exactly the groups (refl
    // writes no further).
    let (cbuf, clen) = if huge_of == 4 {
        (needed, huge_len)
    } else {
        (cbuf, cbuf)
    };
    let ckind = if cbuf == 0 && b.chance(128) {
        PtrKind::Null
    } else {
        ckind
    };
    let mut choices = Buf::<refl_plan_choice>::sentinel(cbuf, ckind);
    let mut out = out1::<refl_plan_budget_plan>(okind);
    // Sometimes `choices` over an input (refused when both are not empty).
    let alias = match b.u8() {
        0..=3 if inp.objects.usable() && n > 0 => {
            Some(("objects", inp.objects.cptr() as *mut refl_plan_choice))
        }
        4..=5 if inp.table.usable() && tn > 0 => {
            Some(("table", inp.table.cptr() as *mut refl_plan_choice))
        }
        6 if inp.frame.usable() => Some(("frame", inp.frame.cptr() as *mut refl_plan_choice)),
        7 if inp.budget.usable() => Some(("budget", inp.budget.cptr() as *mut refl_plan_choice)),
        _ => None,
    };
    let cptr = alias.map_or_else(|| choices.ptr(), |a| a.1);
    let before = inp.snapshot();

    // SAFETY: pointers NULL, misaligned or valid for their buffers; a
    // length past its buffer is either refused by a rule the header states
    // before anything is read (objects, hints, table) or reaches no further
    // than refl reads (planar: `objects_len` flags) or writes (choices: the
    // groups, the buffer's length); an aliased `choices` is refused.
    let s = unsafe { inp.choose(out.ptr(), cptr, clen) };
    let what = "refl_plan_choose_methods";
    let required_null = out.is_null()
        || inp.frame.is_null()
        || inp.caps.is_null()
        || inp.budget.is_null()
        || (clen > 0 && cptr.is_null())
        || (inp.objects_len > 0 && inp.objects.is_null())
        || (inp.planar_len > 0 && inp.planar.is_null())
        || (inp.hints_len > 0 && inp.hints.is_null())
        || (inp.table_len > 0 && inp.table.is_null());
    let mis = |p: usize, align: usize| p % align != 0;
    // A misaligned pointer with a length of 0 is read nowhere: refusing it
    // or not are both read into "a misaligned pointer" (not required).
    let mis_required = out.kind() == PtrKind::Misaligned
        || inp.frame.kind() == PtrKind::Misaligned
        || inp.budget.kind() == PtrKind::Misaligned
        || (clen > 0 && mis(cptr as usize, core::mem::align_of::<refl_plan_choice>()))
        || (inp.objects_len > 0 && inp.objects.kind() == PtrKind::Misaligned)
        || (inp.table_len > 0 && inp.table.kind() == PtrKind::Misaligned);
    let mis_any = mis_required
        || [choices.kind(), inp.objects.kind(), inp.table.kind()].contains(&PtrKind::Misaligned);
    // Whether refl can count the groups (the objects are readable).
    let objects_read = huge_of != 0 && (n == 0 || inp.objects.usable());
    let table_read = huge_of != 3;
    let invalid = !budget_ok(&bu)
        || (table_read && !table_v.iter().all(entry_ok))
        || inp.table_len >= NO_ENTRY as usize
        || !(inp.hints_len == 0 || inp.hints_len == inp.objects_len)
        || inp.planar_len < inp.objects_len
        || (objects_read && (over_frame || objects_overflow))
        || frame_overflow
        || mis_required
        || alias.is_some_and(|_| clen > 0);
    let insufficient = objects_read && clen < needed;
    // A huge planar or choices length is the caller's breach: refl may
    // refuse it as impossibly long or overlapping (an INVALID_ARGUMENT).
    let huge_breach = huge_of == 1 || huge_of == 4;
    null_rules_m(s, required_null, required_null, mis_any, what);
    on_error_untouched(
        s,
        &[
            ("out", out.is_sentinel(0)),
            ("choices", (0..cbuf).all(|i| choices.is_sentinel(i))),
        ],
        what,
    );
    inp.assert_unchanged(&before, what);
    match s {
        refl_status::Ok => assert!(!required_null && !invalid && !insufficient, "{what}: accepted bad input (null {required_null}, invalid {invalid}, insufficient {insufficient}): {bu:?} {table_v:?}"),
        refl_status::NullPointer => {}
        refl_status::InvalidArgument => assert!(invalid || huge_breach || mis_any, "{what}: refused valid arguments: {}", last_error()),
        refl_status::InsufficientSize => assert!(insufficient, "{what}: INSUFFICIENT_SIZE with {clen} records for {needed} groups"),
        _ => panic!("{what}: undocumented status {s:?}: {}", last_error()),
    }
    if !required_null && !invalid && !insufficient && !huge_breach && !mis_any {
        assert_eq!(
            s,
            refl_status::Ok,
            "{what}: refused valid input: {}",
            last_error()
        );
    }

    // `refl_plan_choices_len`'s length always suffices.
    let only_short = s == refl_status::InsufficientSize
        && !required_null
        && !invalid
        && !huge_breach
        && !mis_any;
    if only_short {
        let (s2, p2, c2, _) = call_again(&inp, full);
        assert_eq!(
            s2,
            refl_status::Ok,
            "{what}: refused refl_plan_choices_len's {full} records: {}",
            last_error()
        );
        check_ok(
            &p2, &c2, &f, &objs, &planar_v, &hints_v, &caps_v, &table_v, &bu,
        );
    }
    if s != refl_status::Ok {
        return;
    }

    let p = out.get(0);
    let cs: Vec<refl_plan_choice> = (0..p.groups.min(cbuf)).map(|i| choices.get(i)).collect();
    assert!(
        p.groups <= cbuf,
        "{what}: {} groups in {cbuf} records",
        p.groups
    );
    for i in p.groups..cbuf {
        assert!(
            choices.is_sentinel(i),
            "{what}: record {i} past the {} groups written",
            p.groups
        );
    }
    check_ok(
        &p, &cs, &f, &objs, &planar_v, &hints_v, &caps_v, &table_v, &bu,
    );

    // The same input again: the same output, byte for byte (the fields;
    // the padding is no output), and nothing past the groups; and with
    // refl_plan_choices_len's length the same groups.
    if huge_of == 5 {
        let (s2, p2, c2, ch2) = call_again(&inp, cbuf);
        assert_eq!(
            s2,
            refl_status::Ok,
            "{what}: second call refused: {}",
            last_error()
        );
        assert_eq!(
            plan_bits(&p2),
            plan_bits(&p),
            "{what}: second call's plan {p2:?} vs {p:?}"
        );
        for (a, c) in c2.iter().zip(&cs) {
            assert_eq!(
                choice_bits(a),
                choice_bits(c),
                "{what}: second call's choice {a:?} vs {c:?}"
            );
        }
        assert!(
            (p.groups..cbuf).all(|i| ch2.is_sentinel(i)),
            "{what}: second call wrote past the groups"
        );
        let (s3, p3, c3, _) = call_again(&inp, full);
        assert_eq!(
            s3,
            refl_status::Ok,
            "{what}: refused refl_plan_choices_len's {full} records: {}",
            last_error()
        );
        assert_eq!(
            plan_bits(&p3),
            plan_bits(&p),
            "{what}: plan with {full} records {p3:?} vs {p:?}"
        );
        for (a, c) in c3.iter().zip(&cs) {
            assert_eq!(
                choice_bits(a),
                choice_bits(c),
                "{what}: choice with {full} records {a:?} vs {c:?}"
            );
        }
    }
});
