//! Which passes a frame needs (issue 15: "leave out what a scene does not
//! need", at run time): from a frame's [`summary`](crate::summary) and what
//! the host states about its objects and itself, every pass of the frame
//! is run or skipped, each skip with its reason, and the bytes of the
//! buffers that are built (none for a skipped pass).
//!
//! [`try_plan_passes`]' rules use counts only, no cost model; choosing
//! between methods by time and error is [`try_choose_methods`]' job (a
//! budget, and a calibrated cost table the caller passes in: see its
//! docs), and [`try_chosen_passes`] then says which of the passes run. The
//! rules of [`try_plan_passes`]:
//!
//! * An object goes to the **planar pass** when the host can render extra
//!   views ([`HostCaps::planar_views`]), all its reflective pixels are
//!   mirror-class, and it is a plane: stated by the host
//!   ([`ObjectHints::planar_mirror`]) or found by the summary's plane test
//!   ([`ObjectSummary::is_planar`]).
//! * The **mirror pass** runs for the mirror-class pixels left (objects not
//!   on the planar pass, and pixels of unlisted objects); **Hi-Z** is built
//!   when the mirror pass traces with Hi-Z ([`PlanOptions::mirror_hiz`]) or
//!   the glossy pass runs (its cones walk the pyramid).
//! * The **glossy pass** and its **color** and **visibility** pyramids run
//!   for glossy-class pixels (the visibility pyramid only when the glossy
//!   options read it, [`PlanOptions::glossy_visibility`]).
//! * The **layered pass** runs when some object has layered maps
//!   ([`ObjectHints::layered_map`]) and some reflective pixel is traced in
//!   screen space (mirror or glossy pass).
//! * **Host rays** (the unresolved-ray lists for the host's tracer) are
//!   kept when the host has a ray tracer and a screen-space pass runs.
//! * The **probe** answers rough-class pixels, when the host has one.
//! * The **temporal pass** (seed 004 Sec. 4.6.5: the last frame's
//!   reflections re-projected, recovering the pixels whose ray failed)
//!   runs with the mirror pass when the host keeps a history
//!   ([`FrameMotion::history`]).
//! * **Nothing moved** ([`PlanOptions::motion`]: a history, the camera
//!   still, the scene still, no object stated moving): every pass is
//!   skipped as [`SkipReason::Unchanged`]; the host shows its last
//!   reflections again (seed 000 Sec. 3's stationary camera, for every
//!   method).
//! * An object stated **moving** ([`ObjectHints::moving`]) has stale
//!   layered maps: they were built before it moved. The layered pass runs
//!   for the maps of still objects only; if every mapped object moves it is
//!   skipped as [`SkipReason::MapsStale`], and [`try_choose_methods`]
//!   offers no layered option to a moving object.
//!
//! A pass whose family is not compiled in is skipped as
//! [`SkipReason::NotBuilt`] (Cargo features), whatever the frame needs.

use crate::summary::{FrameSummary, ObjectSummary, RoughnessClass, SummaryOptions};
use crate::Error;

/// What the host can do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct HostCaps {
    /// It can rasterize extra views (the planar pass's mirrored camera).
    pub planar_views: bool,
    /// It has a ray tracer for the rays the screen cannot answer.
    pub ray_tracer: bool,
    /// It has a prefiltered environment probe for rough reflections.
    pub probe: bool,
}

/// What the host states about one object (indexed as the summary's
/// objects). `repr(C)`: the C ABI's `refl_object_hints` is this struct.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(C)]
pub struct ObjectHints {
    /// A planar mirror (the host knows its plane).
    pub planar_mirror: bool,
    /// The object has layered depth maps (seed 001) the layered pass can
    /// trace.
    pub layered_map: bool,
    /// The object moved or changed shape since the last frame (the one
    /// whose results the host keeps): its layered maps, if any, are stale,
    /// and the frame is not unchanged (module docs).
    pub moving: bool,
}

/// What changed since the last frame, whose reflections the host may keep
/// ([`PlanOptions::motion`]). The default states nothing: no history, the
/// camera and the scene possibly moved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct FrameMotion {
    /// The host keeps the last frame's reflections (the temporal pass's
    /// history, `crate::temporal`) and can show them again.
    pub history: bool,
    /// The camera (view and projection) is the last frame's.
    pub camera_still: bool,
    /// Nothing else changed: no geometry moved (listed or not), no light or
    /// material changed. Objects stated [`ObjectHints::moving`] count as
    /// changes whatever this says.
    pub scene_still: bool,
}

/// How the passes that run are set up (what their sizes depend on).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PlanOptions {
    /// The mirror pass traces with Hi-Z (`MirrorMethod::HiZ`); else it
    /// steps and needs no pyramid. Default `true`.
    pub mirror_hiz: bool,
    /// The glossy options read a visibility pyramid
    /// (`GlossyOptions::uses_visibility`). Default `true`.
    pub glossy_visibility: bool,
    /// What changed since the last frame. Default: nothing stated (no
    /// history, everything may have moved).
    pub motion: FrameMotion,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            mirror_hiz: true,
            glossy_visibility: true,
            motion: FrameMotion::default(),
        }
    }
}

/// The passes of a frame, in the order they run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Pass {
    /// The Hi-Z pyramid of the depth image.
    HiZ = 0,
    /// The planar pass (extra views of planar mirrors).
    Planar = 1,
    /// The screen-space mirror pass.
    Mirror = 2,
    /// The color pyramid of the lit image (glossy cones).
    ColorPyramid = 3,
    /// The visibility pyramid (glossy cones).
    VisibilityPyramid = 4,
    /// The glossy pass.
    Glossy = 5,
    /// The layered-maps pass.
    Layered = 6,
    /// The lists of unresolved rays for the host's tracer.
    HostRays = 7,
    /// The environment probe lookups for rough pixels.
    Probe = 8,
    /// The temporal pass (seed 004 Sec. 4.6.5): the history re-projected
    /// into the frame, recovering pixels whose ray failed.
    Temporal = 9,
}

/// Number of [`Pass`]es.
pub const PASS_COUNT: usize = 10;

impl Pass {
    /// Every pass, in [`Pass`] order.
    pub const ALL: [Pass; PASS_COUNT] = [
        Pass::HiZ,
        Pass::Planar,
        Pass::Mirror,
        Pass::ColorPyramid,
        Pass::VisibilityPyramid,
        Pass::Glossy,
        Pass::Layered,
        Pass::HostRays,
        Pass::Probe,
        Pass::Temporal,
    ];
}

/// Why a pass runs or is skipped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum SkipReason {
    /// It runs.
    Runs = 0,
    /// Its family is not compiled in (Cargo feature off).
    NotBuilt = 1,
    /// No reflective pixel of its class is left for it.
    NoPixels = 2,
    /// Every mirror pixel is on the planar pass.
    AllMirrorsPlanar = 3,
    /// Nothing that would read it runs (a pyramid without its pass).
    NoReader = 4,
    /// The host cannot do what it needs (extra views, a tracer, a probe).
    NoHostSupport = 5,
    /// No object has layered maps.
    NoMaps = 6,
    /// The pass's own setting leaves it out (a visibility pyramid the
    /// glossy options do not read; stepping needs no Hi-Z).
    NotUsed = 7,
    /// Nothing moved since the last frame and the host keeps its
    /// reflections: they are this frame's.
    Unchanged = 8,
    /// Every object with layered maps moved: the maps are stale.
    MapsStale = 9,
}

/// One pass's decision.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PassDecision {
    /// The pass.
    pub pass: Pass,
    /// Why it runs or not ([`SkipReason::Runs`] when it runs).
    pub reason: SkipReason,
    /// Bytes of the buffer it builds (pyramids; 0 for the others and when
    /// skipped).
    pub bytes: usize,
}

impl PassDecision {
    /// Whether the pass runs.
    pub const fn runs(&self) -> bool {
        matches!(self.reason, SkipReason::Runs)
    }
}

/// The decisions of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PassPlan {
    /// One per [`Pass`], in [`Pass::ALL`] order.
    pub passes: [PassDecision; PASS_COUNT],
    /// Objects sent to the planar pass.
    pub planar_objects: u32,
    /// Mirror-class pixels left to the mirror pass.
    pub mirror_pixels: u64,
}

impl PassPlan {
    /// The decision of `pass`.
    pub fn decision(&self, pass: Pass) -> PassDecision {
        self.passes[pass as usize]
    }

    /// Bytes of every buffer the plan builds.
    pub fn bytes(&self) -> usize {
        self.passes.iter().map(|d| d.bytes).sum()
    }

    /// Passes run and skipped.
    pub fn counts(&self) -> (usize, usize) {
        let run = self.passes.iter().filter(|d| d.runs()).count();
        (run, PASS_COUNT - run)
    }
}

/// Bytes of a pyramid of `width x height` (`None`: the family is not
/// compiled in).
fn hiz_bytes(width: u32, height: u32) -> Result<Option<usize>, Error> {
    #[cfg(feature = "hiz")]
    {
        let n = crate::hiz::try_hiz_len(width, height)?;
        Ok(Some(n.saturating_mul(core::mem::size_of::<
            crate::hiz::HiZTexel,
        >())))
    }
    #[cfg(not(feature = "hiz"))]
    {
        let _ = (width, height);
        Ok(None)
    }
}

fn cone_bytes(width: u32, height: u32) -> Result<Option<(usize, usize)>, Error> {
    #[cfg(feature = "cone")]
    {
        let c = crate::cone::try_color_pyramid_len(width, height)?;
        let v = crate::cone::try_visibility_pyramid_len(width, height)?;
        Ok(Some((
            c.saturating_mul(core::mem::size_of::<crate::cone::ColorTexel>()),
            v.saturating_mul(4),
        )))
    }
    #[cfg(not(feature = "cone"))]
    {
        let _ = (width, height);
        Ok(None)
    }
}

/// Decides every pass of a frame of `width x height` from its summary
/// (`frame`, `objects`: [`crate::summary::try_summarize_rows`] over the
/// whole image), the host's `hints` per object (as many as `objects`, or
/// none: nothing stated) and `caps`, and writes into `planar[k]` whether
/// object `k` goes to the planar pass (`planar` as long as `objects`).
///
/// # Errors
/// * [`Error::InvalidArgument`]: `hints` neither empty nor as long as
///   `objects`, `summary_options` out of range, a zero size.
/// * [`Error::InsufficientSize`]: `planar` shorter than `objects`.
///
/// Nothing is written on error.
#[allow(clippy::too_many_arguments)]
pub fn try_plan_passes(
    planar: &mut [bool],
    frame: &FrameSummary,
    objects: &[ObjectSummary],
    hints: &[ObjectHints],
    caps: &HostCaps,
    summary_options: &SummaryOptions,
    options: &PlanOptions,
    (width, height): (u32, u32),
) -> Result<PassPlan, Error> {
    summary_options.try_validate()?;
    if !(hints.is_empty() || hints.len() == objects.len()) || width == 0 || height == 0 {
        return Err(Error::InvalidArgument);
    }
    if planar.len() < objects.len() {
        return Err(Error::InsufficientSize);
    }
    let hiz = hiz_bytes(width, height)?;
    let cone = cone_bytes(width, height)?;
    let (mirror, glossy, rough) = (
        RoughnessClass::Mirror as usize,
        RoughnessClass::Glossy as usize,
        RoughnessClass::Rough as usize,
    );
    // Objects on the planar pass, and the mirror pixels left.
    let (mut planar_objects, mut planar_pixels, mut listed_mirror) = (0u32, 0u64, 0u64);
    let (mut any_map, mut any_fresh_map, mut any_moving) = (false, false, false);
    for (k, o) in objects.iter().enumerate() {
        let h = hints.get(k).copied().unwrap_or_default();
        any_map |= h.layered_map;
        any_fresh_map |= h.layered_map && !h.moving;
        any_moving |= h.moving;
        listed_mirror += o.classes[mirror];
        let on_planar = caps.planar_views
            && o.pixels > 0
            && o.classes[mirror] == o.pixels
            && (h.planar_mirror || o.is_planar(summary_options));
        planar[k] = on_planar;
        if on_planar {
            planar_objects += 1;
            planar_pixels += o.pixels;
        }
    }
    // Mirror pixels of unlisted objects have no object to go planar.
    let unlisted_mirror = frame.classes[mirror].saturating_sub(listed_mirror);
    let mirror_pixels = (listed_mirror - planar_pixels) + unlisted_mirror;
    let glossy_pixels = frame.classes[glossy];

    let decide = |pass: Pass, reason: SkipReason, bytes: usize| PassDecision {
        pass,
        reason,
        bytes: if reason == SkipReason::Runs { bytes } else { 0 },
    };
    let screen_built = cfg!(any(feature = "depth-image", feature = "hiz"));
    let mirror_d = if !screen_built {
        decide(Pass::Mirror, SkipReason::NotBuilt, 0)
    } else if mirror_pixels > 0 {
        decide(Pass::Mirror, SkipReason::Runs, 0)
    } else if planar_objects > 0 && frame.classes[mirror] > 0 {
        decide(Pass::Mirror, SkipReason::AllMirrorsPlanar, 0)
    } else {
        decide(Pass::Mirror, SkipReason::NoPixels, 0)
    };
    let glossy_d = match cone {
        None => decide(Pass::Glossy, SkipReason::NotBuilt, 0),
        Some(_) if glossy_pixels > 0 => decide(Pass::Glossy, SkipReason::Runs, 0),
        Some(_) => decide(Pass::Glossy, SkipReason::NoPixels, 0),
    };
    let color_d = match cone {
        None => decide(Pass::ColorPyramid, SkipReason::NotBuilt, 0),
        Some((c, _)) if glossy_d.runs() => decide(Pass::ColorPyramid, SkipReason::Runs, c),
        Some(_) => decide(Pass::ColorPyramid, SkipReason::NoReader, 0),
    };
    let visibility_d = match cone {
        None => decide(Pass::VisibilityPyramid, SkipReason::NotBuilt, 0),
        Some((_, v)) if glossy_d.runs() && options.glossy_visibility => {
            decide(Pass::VisibilityPyramid, SkipReason::Runs, v)
        }
        Some(_) if glossy_d.runs() => decide(Pass::VisibilityPyramid, SkipReason::NotUsed, 0),
        Some(_) => decide(Pass::VisibilityPyramid, SkipReason::NoReader, 0),
    };
    let hiz_d = match hiz {
        None => decide(Pass::HiZ, SkipReason::NotBuilt, 0),
        Some(b) if glossy_d.runs() || (mirror_d.runs() && options.mirror_hiz) => {
            decide(Pass::HiZ, SkipReason::Runs, b)
        }
        Some(_) if mirror_d.runs() => decide(Pass::HiZ, SkipReason::NotUsed, 0),
        Some(_) => decide(Pass::HiZ, SkipReason::NoReader, 0),
    };
    let planar_d = if !cfg!(feature = "mirror") {
        decide(Pass::Planar, SkipReason::NotBuilt, 0)
    } else if planar_objects > 0 {
        decide(Pass::Planar, SkipReason::Runs, 0)
    } else if !caps.planar_views && frame.classes[mirror] > 0 {
        decide(Pass::Planar, SkipReason::NoHostSupport, 0)
    } else {
        decide(Pass::Planar, SkipReason::NoPixels, 0)
    };
    let screen = mirror_d.runs() || glossy_d.runs();
    let layered_built = cfg!(all(
        feature = "layered",
        any(feature = "depth-image", feature = "hiz")
    ));
    let layered_d = if !layered_built {
        decide(Pass::Layered, SkipReason::NotBuilt, 0)
    } else if !any_map {
        decide(Pass::Layered, SkipReason::NoMaps, 0)
    } else if !any_fresh_map {
        decide(Pass::Layered, SkipReason::MapsStale, 0)
    } else if screen {
        decide(Pass::Layered, SkipReason::Runs, 0)
    } else {
        decide(Pass::Layered, SkipReason::NoPixels, 0)
    };
    let host_d = if !screen_built {
        decide(Pass::HostRays, SkipReason::NotBuilt, 0)
    } else if !(screen || layered_d.runs()) {
        decide(Pass::HostRays, SkipReason::NoReader, 0)
    } else if caps.ray_tracer {
        decide(Pass::HostRays, SkipReason::Runs, 0)
    } else {
        decide(Pass::HostRays, SkipReason::NoHostSupport, 0)
    };
    let probe_d = if frame.classes[rough] == 0 {
        decide(Pass::Probe, SkipReason::NoPixels, 0)
    } else if caps.probe {
        decide(Pass::Probe, SkipReason::Runs, 0)
    } else {
        decide(Pass::Probe, SkipReason::NoHostSupport, 0)
    };
    let motion = &options.motion;
    let temporal_d = if !cfg!(feature = "hiz") {
        // The temporal filter re-projects the mirror pass's results.
        decide(Pass::Temporal, SkipReason::NotBuilt, 0)
    } else if !motion.history {
        decide(Pass::Temporal, SkipReason::NoHostSupport, 0)
    } else if mirror_d.runs() {
        decide(Pass::Temporal, SkipReason::Runs, 0)
    } else {
        decide(Pass::Temporal, SkipReason::NoReader, 0)
    };
    let mut passes = [
        hiz_d,
        planar_d,
        mirror_d,
        color_d,
        visibility_d,
        glossy_d,
        layered_d,
        host_d,
        probe_d,
        temporal_d,
    ];
    if motion.history && motion.camera_still && motion.scene_still && !any_moving {
        for d in passes.iter_mut() {
            if d.reason != SkipReason::NotBuilt {
                *d = decide(d.pass, SkipReason::Unchanged, 0);
            }
        }
    }
    Ok(PassPlan {
        passes,
        planar_objects,
        mirror_pixels,
    })
}

// ------------------------------------------------- method choice by budget

/// The bit of `pass` in a [`CostEntry::passes`] mask.
pub const fn pass_bit(pass: Pass) -> u32 {
    1 << pass as u32
}

/// Every valid bit of a [`CostEntry::passes`] mask.
const PASS_MASK: u32 = (1 << PASS_COUNT) - 1;

/// Which reflectors a calibrated option applies to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Surface {
    /// Any reflector.
    Any = 0,
    /// Planar reflectors only (the planar pass; errors measured there).
    Planar = 1,
    /// Curved (non-planar) reflectors only.
    Curved = 2,
}

impl Surface {
    /// Whether an option for this surface applies to a reflector that is
    /// (`planar`) or is not a plane.
    pub const fn admits(self, planar: bool) -> bool {
        match self {
            Surface::Any => true,
            Surface::Planar => planar,
            Surface::Curved => !planar,
        }
    }
}

/// One calibrated option: a method at one setting on the reflective pixels
/// of one [`RoughnessClass`] and [`Surface`], with its measured cost and
/// error. The table of these is the caller's (the root package measures it
/// with `refl calibrate` and passes it in as a slice). `repr(C)`: the C
/// ABI's `refl_plan_cost_entry` is this struct.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct CostEntry {
    /// The caller's name for the method and setting (opaque here).
    pub id: u32,
    /// The pixels it was measured on and applies to.
    pub class: RoughnessClass,
    /// The reflectors it applies to.
    pub surface: Surface,
    /// The passes it runs, as [`pass_bit`]s (at least one). What the host
    /// must offer follows from them: [`Pass::Planar`] extra views,
    /// [`Pass::HostRays`] a ray tracer, [`Pass::Probe`] a probe,
    /// [`Pass::Layered`] the object's layered maps. Never
    /// [`Pass::Temporal`].
    pub passes: u32,
    /// Time per reflective pixel over the reference tracer's time per ray
    /// (one closest-hit ray, shaded), measured in the same run. Finite, at
    /// least 0.
    pub time_ratio: f32,
    /// Mean absolute error on 0..255 over the pixels it handles. Finite,
    /// at least 0.
    pub error_255: f32,
}

impl CostEntry {
    /// Whether the option is plain ray tracing (it runs the host's tracer
    /// and nothing else).
    pub const fn is_ray_traced(&self) -> bool {
        self.passes == pass_bit(Pass::HostRays)
    }

    /// Whether it runs `pass`.
    pub const fn runs(&self, pass: Pass) -> bool {
        self.passes & pass_bit(pass) != 0
    }

    /// # Errors
    /// [`Error::InvalidArgument`] for a NaN, infinite or negative
    /// `time_ratio` or `error_255`, and for a `passes` mask that is empty,
    /// has a bit past the last [`Pass`] or names [`Pass::Temporal`] (no
    /// option runs it: it follows the mirror pass, [`try_chosen_passes`]).
    pub fn try_validate(&self) -> Result<(), Error> {
        let finite = |v: f32| v.is_finite() && v >= 0.0;
        if finite(self.time_ratio)
            && finite(self.error_255)
            && self.passes != 0
            && self.passes & !PASS_MASK == 0
            && self.passes & pass_bit(Pass::Temporal) == 0
        {
            Ok(())
        } else {
            Err(Error::InvalidArgument)
        }
    }

    /// Whether `self` is at least as fast and as accurate as `other` and
    /// better in one of the two.
    pub fn dominates(&self, other: &CostEntry) -> bool {
        self.time_ratio <= other.time_ratio
            && self.error_255 <= other.error_255
            && (self.time_ratio < other.time_ratio || self.error_255 < other.error_255)
    }
}

/// What a frame may spend.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// The frame's mean error, 0..255, at most this: the mean over the
    /// pixels the plan covers ([`BudgetPlan::covered`], the groups with an
    /// option), as [`BudgetPlan::error_255`] predicts it. Finite, at least
    /// 0.
    MaxError(f32),
    /// The frame's time at most this multiple of the reference tracer's
    /// time for one ray per reflective pixel. Finite, at least 0.
    MaxTime(f32),
}

impl Budget {
    /// # Errors
    /// [`Error::InvalidArgument`] for a NaN, infinite or negative limit.
    pub fn try_validate(&self) -> Result<(), Error> {
        let (Budget::MaxError(v) | Budget::MaxTime(v)) = *self;
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(Error::InvalidArgument)
        }
    }
}

/// The reflective pixels of one object (or of unlisted objects) in one
/// [`RoughnessClass`]: what one method is chosen for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PixelGroup {
    /// The object (its index in the summary's objects), or
    /// [`crate::summary::NO_OBJECT`] for pixels of unlisted objects.
    pub object: u32,
    /// Their class.
    pub class: RoughnessClass,
    /// The object is a plane (stated or found; unlisted pixels are not).
    pub planar: bool,
    /// Reflective pixels.
    pub pixels: u64,
}

/// Why a group got its option.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum ChoiceReason {
    /// The group's fastest option on the front, and the budget holds with
    /// it.
    Fastest = 0,
    /// The budget bought this group a more accurate option than its
    /// fastest (an error budget needed it, or a time budget left room for
    /// it), but not its most accurate.
    TradeOff = 1,
    /// The group's most accurate option on the front, within the budget.
    MostAccurate = 2,
    /// The error budget cannot be met: every group takes its most
    /// accurate option.
    ErrorBudgetUnreachable = 3,
    /// The time budget cannot be met: every group takes its fastest
    /// option.
    TimeBudgetUnreachable = 4,
    /// One option is on the group's front (any other is dominated).
    OnlyOption = 5,
    /// No calibrated option applies (class, surface, or what the host
    /// offers): its pixels are left out of the plan.
    NoOption = 6,
}

/// The option chosen for one [`PixelGroup`], and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Choice {
    /// The pixels.
    pub group: PixelGroup,
    /// The chosen entry's index in the table (`None`:
    /// [`ChoiceReason::NoOption`]).
    pub entry: Option<usize>,
    /// Why.
    pub reason: ChoiceReason,
    /// Options that apply to the group.
    pub applicable: u32,
    /// Of them, the ones on the group's Pareto front (not dominated by
    /// another applicable option).
    pub front: u32,
    /// The next faster option on the front, not taken (the budget ruled it
    /// out, or it is `None`: the choice is the fastest).
    pub faster: Option<usize>,
    /// The next more accurate option on the front, not taken.
    pub more_accurate: Option<usize>,
}

impl Default for Choice {
    fn default() -> Self {
        Self {
            group: PixelGroup {
                object: crate::summary::NO_OBJECT,
                class: RoughnessClass::Mirror,
                planar: false,
                pixels: 0,
            },
            entry: None,
            reason: ChoiceReason::NoOption,
            applicable: 0,
            front: 0,
            faster: None,
            more_accurate: None,
        }
    }
}

/// What [`try_choose_methods`] predicts for the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BudgetPlan {
    /// Groups written to the choices.
    pub groups: usize,
    /// Reflective pixels of the frame.
    pub reflective: u64,
    /// Of them, the ones some option handles (the others are in
    /// [`ChoiceReason::NoOption`] groups).
    pub covered: u64,
    /// Predicted time: the sum over groups of pixels times
    /// [`CostEntry::time_ratio`], over the reflective pixels (a multiple
    /// of the reference tracer's time for one ray per reflective pixel).
    pub time_ratio: f64,
    /// Predicted mean error (0..255) over the covered pixels.
    pub error_255: f64,
    /// Whether the prediction meets the budget.
    pub met: bool,
}

/// The most groups [`try_choose_methods`] can write for a summary of
/// `objects` objects: one per object and class, and one per class for
/// unlisted objects.
pub const fn choices_len(objects: usize) -> usize {
    objects.saturating_add(1).saturating_mul(3)
}

/// What the host offers a group: whether `pass` can run for it.
fn pass_available(pass: Pass, caps: &HostCaps, hint: &ObjectHints, planar: bool) -> bool {
    let screen = cfg!(any(feature = "depth-image", feature = "hiz"));
    match pass {
        Pass::HiZ => cfg!(feature = "hiz"),
        Pass::Planar => cfg!(feature = "mirror") && caps.planar_views && planar,
        Pass::Mirror => screen,
        Pass::ColorPyramid | Pass::VisibilityPyramid | Pass::Glossy => cfg!(feature = "cone"),
        Pass::Layered => cfg!(feature = "layered") && screen && hint.layered_map && !hint.moving,
        Pass::HostRays => caps.ray_tracer,
        Pass::Probe => caps.probe,
        // No calibrated option runs it (it follows the mirror pass in
        // `try_chosen_passes`).
        Pass::Temporal => false,
    }
}

/// Whether entry `e` applies to group `g` with `hint` and `caps`.
fn applies(e: &CostEntry, g: &PixelGroup, hint: &ObjectHints, caps: &HostCaps) -> bool {
    e.class == g.class
        && e.surface.admits(g.planar)
        && Pass::ALL
            .iter()
            .all(|&p| !e.runs(p) || pass_available(p, caps, hint, g.planar))
}

/// Whether entry `i` is on the front of the options that apply
/// (`ok(j)`): no applicable entry dominates it, and no earlier one equals
/// it in time and error.
fn on_front(table: &[CostEntry], i: usize, ok: &impl Fn(usize) -> bool) -> bool {
    let e = &table[i];
    ok(i)
        && !table.iter().enumerate().any(|(j, o)| {
            ok(j)
                && (o.dominates(e)
                    || (j < i && o.time_ratio == e.time_ratio && o.error_255 == e.error_255))
        })
}

/// Chooses, for every object and [`RoughnessClass`] of a frame's
/// reflective pixels, the calibrated option of `table` that the `budget`
/// asks for, with its reason.
///
/// The groups are the summary's objects per class (planar as `planar`
/// says: [`try_plan_passes`]' output, or the caller's own test) and, per
/// class, the pixels of unlisted objects. An option applies to a group
/// when its class and [`Surface`] match and the host offers every pass it
/// runs (`caps`, the object's layered maps in `hints`, and the planar
/// pass only for a planar group). Of those, only
/// the Pareto front counts (no other option at most as slow and at most
/// as wrong); where plain ray tracing is as fast and as accurate as a
/// screen-space option, that option is off the front and ray tracing is
/// chosen.
///
/// The choice across groups is a multiple-choice knapsack, solved
/// greedily along each group's front: every group starts at its fastest
/// option; for [`Budget::MaxError`], while the predicted mean error is
/// over the limit, the group whose next step buys the most error per unit
/// of time takes it, unless a single step that brings the mean within the
/// limit adds no more time (then the cheapest such step ends the search); once the limit holds, every group
/// in turn goes back to the fastest option that keeps it; for [`Budget::MaxTime`], the
/// best such step that still fits the time limit is taken while one
/// exists. The prediction is [`BudgetPlan`]: pixel-weighted sums of the
/// table's time ratios and errors.
///
/// Cost: with `g` groups and `t` table entries, finding the fronts takes
/// `O(g t^2)` and each of at most `g t` steps up to `O(g t (g + t^2))`
/// (the front test runs only for a step that would win); meant for tables
/// of tens of entries, as `refl calibrate` writes.
///
/// Returns the plan; the first [`BudgetPlan::groups`] entries of `choices`
/// hold the groups, in object order, then the unlisted ones. A frame
/// without reflective pixels gives no group, time 0 and error 0.
///
/// # Errors
/// * [`Error::InvalidArgument`]: an entry of `table` that fails
///   [`CostEntry::try_validate`], a `budget` that fails
///   [`Budget::try_validate`], `hints` neither empty nor as long as
///   `objects`, `planar` shorter than `objects`, objects whose reflective
///   pixels of some class add up to more than the frame's (each object may
///   hold at most what the frame holds, and together too), or class counts
///   (the frame's three, or the objects' of one class) that add up past
///   `u64::MAX`.
/// * [`Error::InsufficientSize`]: `choices` shorter than the groups of the
///   frame (at most [`choices_len`]`(objects.len())`).
///
/// Nothing is written on error.
#[allow(clippy::too_many_arguments)]
pub fn try_choose_methods(
    choices: &mut [Choice],
    frame: &FrameSummary,
    objects: &[ObjectSummary],
    planar: &[bool],
    hints: &[ObjectHints],
    caps: &HostCaps,
    table: &[CostEntry],
    budget: Budget,
) -> Result<BudgetPlan, Error> {
    budget.try_validate()?;
    for e in table {
        e.try_validate()?;
    }
    if !(hints.is_empty() || hints.len() == objects.len()) || planar.len() < objects.len() {
        return Err(Error::InvalidArgument);
    }
    const CLASSES: [RoughnessClass; 3] = [
        RoughnessClass::Mirror,
        RoughnessClass::Glossy,
        RoughnessClass::Rough,
    ];
    // Groups: count first (nothing written on error).
    // Counts that add up past `u64::MAX` are refused, so every sum below
    // (the groups' pixels, `covered`, `reflective`) fits.
    let mut listed = [0u64; 3];
    let mut needed = 0usize;
    for o in objects {
        for (l, &n) in listed.iter_mut().zip(&o.classes) {
            *l = l.checked_add(n).ok_or(Error::InvalidArgument)?;
            needed += usize::from(n > 0);
        }
    }
    let class_total = frame
        .classes
        .iter()
        .try_fold(0u64, |s, &n| s.checked_add(n))
        .ok_or(Error::InvalidArgument)?;
    for (&l, &n) in listed.iter().zip(&frame.classes) {
        if l > n {
            return Err(Error::InvalidArgument);
        }
        needed += usize::from(n > l);
    }
    if choices.len() < needed {
        return Err(Error::InsufficientSize);
    }
    let mut n = 0usize;
    for (k, o) in objects.iter().enumerate() {
        for (c, &class) in CLASSES.iter().enumerate() {
            if o.classes[c] > 0 {
                choices[n] = Choice {
                    group: PixelGroup {
                        object: k as u32,
                        class,
                        planar: planar[k],
                        pixels: o.classes[c],
                    },
                    ..Choice::default()
                };
                n += 1;
            }
        }
    }
    for (c, &class) in CLASSES.iter().enumerate() {
        if frame.classes[c] > listed[c] {
            choices[n] = Choice {
                group: PixelGroup {
                    object: crate::summary::NO_OBJECT,
                    class,
                    planar: false,
                    pixels: frame.classes[c] - listed[c],
                },
                ..Choice::default()
            };
            n += 1;
        }
    }
    let choices = &mut choices[..n];
    let hint_of = |g: &PixelGroup| -> ObjectHints {
        hints.get(g.object as usize).copied().unwrap_or_default()
    };
    // Each group's front, and its fastest option to start from.
    for ch in choices.iter_mut() {
        let g = ch.group;
        let h = hint_of(&g);
        let ok = |j: usize| applies(&table[j], &g, &h, caps);
        let mut best: Option<usize> = None;
        for i in 0..table.len() {
            ch.applicable += u32::from(ok(i));
            if on_front(table, i, &ok) {
                ch.front += 1;
                let faster = best.is_none_or(|b| {
                    let (e, b) = (&table[i], &table[b]);
                    e.time_ratio < b.time_ratio
                        || (e.time_ratio == b.time_ratio && e.error_255 < b.error_255)
                });
                if faster {
                    best = Some(i);
                }
            }
        }
        ch.entry = best;
    }
    let reflective = frame.reflective.max(class_total);
    let totals = |choices: &[Choice]| -> (f64, f64, u64) {
        let (mut t, mut e, mut covered) = (0.0f64, 0.0f64, 0u64);
        for ch in choices {
            if let Some(i) = ch.entry {
                let p = ch.group.pixels as f64;
                t += p * f64::from(table[i].time_ratio);
                e += p * f64::from(table[i].error_255);
                covered += ch.group.pixels;
            }
        }
        let r = reflective.max(1) as f64;
        (
            t / r,
            if covered > 0 { e / covered as f64 } else { 0.0 },
            covered,
        )
    };
    // The front options of group `g` more accurate than its current one,
    // with the slope (error saved per time spent) of moving there; the
    // best step of every group, over all groups.
    let best_step = |choices: &[Choice], time_left: Option<f64>| -> Option<(usize, usize)> {
        let r = reflective.max(1) as f64;
        let mut best: Option<(usize, usize, f64)> = None;
        for (k, ch) in choices.iter().enumerate() {
            let Some(cur) = ch.entry else { continue };
            let (g, h) = (ch.group, hint_of(&ch.group));
            let ok = |j: usize| applies(&table[j], &g, &h, caps);
            let c = &table[cur];
            for (j, o) in table.iter().enumerate() {
                if o.error_255 >= c.error_255 {
                    continue;
                }
                let dt = f64::from(o.time_ratio) - f64::from(c.time_ratio);
                if let Some(left) = time_left {
                    if dt * g.pixels as f64 / r > left {
                        continue;
                    }
                }
                let de = f64::from(c.error_255) - f64::from(o.error_255);
                let slope = if dt > 0.0 { de / dt } else { f64::INFINITY };
                // The front test (quadratic in the table) last, only for a
                // step that would win.
                if best.is_none_or(|(_, _, s)| slope > s) && on_front(table, j, &ok) {
                    best = Some((k, j, slope));
                }
            }
        }
        best.map(|(k, j, _)| (k, j))
    };
    let limit = |v: f32| f64::from(v);
    // For an error budget: the step that alone brings the mean within
    // `max` at the least added time, if one does.
    let closing_step = |choices: &mut [Choice], max: f64| -> Option<(usize, usize)> {
        let mut best: Option<(usize, usize, f64)> = None;
        for k in 0..choices.len() {
            let Some(cur) = choices[k].entry else {
                continue;
            };
            let (g, h) = (choices[k].group, hint_of(&choices[k].group));
            let ok = |j: usize| applies(&table[j], &g, &h, caps);
            for j in 0..table.len() {
                if table[j].error_255 >= table[cur].error_255 {
                    continue;
                }
                let added = (f64::from(table[j].time_ratio) - f64::from(table[cur].time_ratio))
                    * g.pixels as f64;
                if best.is_some_and(|(_, _, a)| added >= a) || !on_front(table, j, &ok) {
                    continue;
                }
                choices[k].entry = Some(j);
                if totals(choices).1 <= max {
                    best = Some((k, j, added));
                }
                choices[k].entry = Some(cur);
            }
        }
        best.map(|(k, j, _)| (k, j))
    };
    let mut unreachable = None;
    match budget {
        Budget::MaxError(max) => {
            while totals(choices).1 > limit(max) {
                let Some((k, j)) = best_step(choices, None) else {
                    unreachable = Some(ChoiceReason::ErrorBudgetUnreachable);
                    break;
                };
                // A single step that closes the gap for no more time than
                // the best error-per-time step adds ends the search.
                let added = |k: usize, j: usize, choices: &[Choice]| {
                    let cur = choices[k].entry.map_or(0.0, |c| table[c].time_ratio);
                    (f64::from(table[j].time_ratio) - f64::from(cur))
                        * choices[k].group.pixels as f64
                };
                let slope_added = added(k, j, choices);
                if let Some((kc, jc)) = closing_step(choices, limit(max)) {
                    if added(kc, jc, choices) <= slope_added {
                        choices[kc].entry = Some(jc);
                        break;
                    }
                }
                choices[k].entry = Some(j);
            }
            if unreachable.is_none() {
                // Give back what the last steps overshot: each group in
                // turn takes its fastest front option that keeps the limit.
                for k in 0..choices.len() {
                    let Some(cur) = choices[k].entry else {
                        continue;
                    };
                    let (g, h) = (choices[k].group, hint_of(&choices[k].group));
                    let ok = |j: usize| applies(&table[j], &g, &h, caps);
                    let mut pick = cur;
                    for j in 0..table.len() {
                        if table[j].time_ratio < table[pick].time_ratio && on_front(table, j, &ok) {
                            choices[k].entry = Some(j);
                            if totals(choices).1 <= limit(max) {
                                pick = j;
                            }
                        }
                    }
                    choices[k].entry = Some(pick);
                }
            }
        }
        Budget::MaxTime(max) => {
            if totals(choices).0 > limit(max) {
                unreachable = Some(ChoiceReason::TimeBudgetUnreachable);
            } else {
                while let Some((k, j)) = best_step(choices, Some(limit(max) - totals(choices).0)) {
                    choices[k].entry = Some(j);
                }
            }
        }
    }
    // Reasons, and the neighbors on each front.
    for ch in choices.iter_mut() {
        let Some(cur) = ch.entry else {
            ch.reason = ChoiceReason::NoOption;
            continue;
        };
        let (g, h) = (ch.group, hint_of(&ch.group));
        let ok = |j: usize| applies(&table[j], &g, &h, caps);
        let c = table[cur];
        let (mut faster, mut accurate): (Option<usize>, Option<usize>) = (None, None);
        for (j, o) in table.iter().enumerate() {
            if j == cur || !on_front(table, j, &ok) {
                continue;
            }
            if o.time_ratio < c.time_ratio
                && faster.is_none_or(|f| o.time_ratio > table[f].time_ratio)
            {
                faster = Some(j);
            }
            if o.error_255 < c.error_255
                && accurate.is_none_or(|a| o.error_255 > table[a].error_255)
            {
                accurate = Some(j);
            }
        }
        ch.faster = faster;
        ch.more_accurate = accurate;
        ch.reason = match (unreachable, ch.front) {
            (_, 1) => ChoiceReason::OnlyOption,
            (Some(r), _) => r,
            (None, _) if faster.is_none() => ChoiceReason::Fastest,
            (None, _) if accurate.is_none() => ChoiceReason::MostAccurate,
            (None, _) => ChoiceReason::TradeOff,
        };
    }
    let (time_ratio, error_255, covered) = totals(choices);
    let met = match budget {
        Budget::MaxError(max) => error_255 <= limit(max),
        Budget::MaxTime(max) => time_ratio <= limit(max),
    };
    Ok(BudgetPlan {
        groups: n,
        reflective,
        covered,
        time_ratio,
        error_255,
        met,
    })
}

/// The passes a frame runs with the options `choices` chose from `table`
/// (as [`try_choose_methods`] wrote them), from the frame's `base` plan
/// ([`try_plan_passes`], what the frame and host allow): a pass runs when
/// a chosen option runs it and the base plan does not rule it out as
/// [`SkipReason::NotBuilt`], [`SkipReason::NoHostSupport`],
/// [`SkipReason::Unchanged`] or [`SkipReason::MapsStale`] (the temporal
/// pass runs with the mirror pass when the base plan allows it); a pass the
/// base plan runs but no chosen option needs is skipped as
/// [`SkipReason::NotUsed`]; the others keep the base plan's reason. The
/// bytes are those of the buffers of `width x height` that run. Choices
/// whose entry is not in `table` run nothing.
///
/// # Errors
/// [`Error::InvalidArgument`] for a zero or overflowing size.
pub fn try_chosen_passes(
    base: &PassPlan,
    choices: &[Choice],
    table: &[CostEntry],
    (width, height): (u32, u32),
) -> Result<PassPlan, Error> {
    if width == 0 || height == 0 {
        return Err(Error::InvalidArgument);
    }
    let hiz = hiz_bytes(width, height)?.unwrap_or(0);
    let (color, visibility) = cone_bytes(width, height)?.unwrap_or((0, 0));
    let mut needed = 0u32;
    let (mut planar_objects, mut mirror_pixels) = (0u32, 0u64);
    for ch in choices {
        if let Some(e) = ch.entry.and_then(|i| table.get(i)) {
            needed |= e.passes;
            if e.runs(Pass::Planar) {
                planar_objects += 1;
            }
            if e.runs(Pass::Mirror) && ch.group.class == RoughnessClass::Mirror {
                mirror_pixels += ch.group.pixels;
            }
        }
    }
    // The temporal pass follows the mirror pass (no option names it).
    if needed & pass_bit(Pass::Mirror) != 0 {
        needed |= pass_bit(Pass::Temporal);
    }
    let mut passes = base.passes;
    for d in passes.iter_mut() {
        let want = needed & pass_bit(d.pass) != 0;
        let blocked = matches!(
            d.reason,
            SkipReason::NotBuilt
                | SkipReason::NoHostSupport
                | SkipReason::Unchanged
                | SkipReason::MapsStale
        );
        if want && !blocked {
            d.reason = SkipReason::Runs;
            d.bytes = match d.pass {
                Pass::HiZ => hiz,
                Pass::ColorPyramid => color,
                Pass::VisibilityPyramid => visibility,
                _ => 0,
            };
        } else if d.runs() {
            d.reason = SkipReason::NotUsed;
            d.bytes = 0;
        }
    }
    Ok(PassPlan {
        passes,
        planar_objects,
        mirror_pixels,
    })
}
