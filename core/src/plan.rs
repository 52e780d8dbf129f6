//! Which passes a frame needs (issue 15: "leave out what a scene does not
//! need", at run time): from a frame's [`summary`](crate::summary) and what
//! the host states about its objects and itself, every pass of the frame
//! is run or skipped, each skip with its reason, and the bytes of the
//! buffers that are built (none for a skipped pass).
//!
//! The rules use counts only, no cost model (choosing between methods by
//! time and error is the calibrated planner's job, not built yet):
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
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            mirror_hiz: true,
            glossy_visibility: true,
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
}

/// Number of [`Pass`]es.
pub const PASS_COUNT: usize = 9;

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
    let mut any_map = false;
    for (k, o) in objects.iter().enumerate() {
        let h = hints.get(k).copied().unwrap_or_default();
        any_map |= h.layered_map;
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
    Ok(PassPlan {
        passes: [
            hiz_d,
            planar_d,
            mirror_d,
            color_d,
            visibility_d,
            glossy_d,
            layered_d,
            host_d,
            probe_d,
        ],
        planar_objects,
        mirror_pixels,
    })
}
