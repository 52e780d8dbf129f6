//! The screen-space mirror reflection pass: G-buffer in, one mirror ray per
//! reflective pixel traced against the frame's own depth buffer by per-pixel
//! stepping (seed 003 Sec. 3.4, `crate::step`) or Hi-Z traversal (seed
//! 004 Sec. 4.4.1, `crate::hiz`), hits validated and shaded, and the
//! pixels the screen cannot answer handed back as world rays for the host's
//! own tracer (design.md, "Passes"; issue 13).
//!
//! Described once ([`MirrorPass::try_new`]: the G-buffer, the options and,
//! for Hi-Z, the pyramid, validated together), executed over row bands
//! ([`MirrorPass::try_run`] on an output band; bands are independent, so
//! the host's threads split the image).
//!
//! # Example
//! ```rust
//! # #[cfg(feature = "depth-image")] {
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::{Camera, DepthConvention, DepthImage, GBuffer, ImageView, ImageViewMut};
//! use refl_core::{MirrorOptions, MirrorPass, MirrorStatus, MirrorTexel, NormalSpace};
//!
//! // 16 x 16 pixels: the eye 1 above the floor y = 0, looking down -Z at a wall at z = -4.
//! let cam = Camera::try_look_at(Vec3::Y, Vec3::new(0.0, 1.0, -1.0), Vec3::Y, FRAC_PI_2, 0.1, 100.0, 16, 16)?;
//! let (mut depth, mut normals) = (vec![4.0f32; 256], vec![[0.0, 0.0, 1.0f32]; 256]);
//! for (i, (d, n)) in depth.iter_mut().zip(&mut normals).enumerate() {
//!     // Row y looks along NDC y = 1 - (2 y + 1) / 16 and meets the floor at depth -1 / NDC y.
//!     let floor = -1.0 / (1.0 - (2 * (i / 16) + 1) as f32 / 16.0);
//!     if (0.0..4.0).contains(&floor) {
//!         (*d, *n) = (floor, [0.0, 1.0, 0.0]);
//!     }
//! }
//! let depth = DepthImage::try_new(ImageView::try_new(&depth, 16, 16, 16)?, cam, DepthConvention::Linear)?;
//! let gbuffer = GBuffer::try_new(depth, ImageView::try_new(&normals, 16, 16, 16)?, NormalSpace::World)?;
//!
//! // Stepping (the default method) needs no Hi-Z pyramid: `None` (without the
//! // `hiz` feature, `try_new` takes no pyramid argument).
//! # #[cfg(feature = "hiz")]
//! let pass = MirrorPass::try_new(gbuffer, MirrorOptions::default(), None)?;
//! # #[cfg(not(feature = "hiz"))]
//! # let pass = MirrorPass::try_new(gbuffer, MirrorOptions::default())?;
//! let mut texels = vec![MirrorTexel::default(); 256];
//! let stats = pass.try_run(&mut ImageViewMut::try_new(&mut texels, 16, 16, 16)?, None, &mut [])?;
//! assert_eq!(stats.traced, 256);
//! // Pixel (8, 13) sees the floor at P (NDC (1/16, -11/16), depth 16/11). Its ray
//! // comes from the mirrored eye (0, -1, 0) and meets the wall at Q, at height
//! // -1 + 4 (11/16) = 1.75: NDC (1/16, 3/16), pixel (8.5, 6.5).
//! let (p, q) = (Vec3::new(1.0 / 11.0, 0.0, -16.0 / 11.0), Vec3::new(0.25, 1.75, -4.0));
//! let floor = texels[13 * 16 + 8];
//! assert_eq!(floor.status, MirrorStatus::Hit);
//! assert!((floor.pixel - Vec2::new(8.5, 6.5)).length() < 0.05);
//! assert!((floor.t - (q - p).length()).abs() < 1e-3);
//! // The wall reflects toward the camera, out of the screen: the host traces those.
//! assert!(texels[2 * 16 + 8].status.needs_host());
//! # }
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! # Per pixel
//! 1. **Reflective?** A pixel is traced when its mask (if any) is non-zero
//!    and its roughness (if any) is at most [`MirrorOptions::max_roughness`];
//!    otherwise [`MirrorStatus::Skipped`].
//! 2. **Surface.** The world point `P` at the pixel center and stored depth,
//!    the unit world normal `n` ([`GBuffer::surface`]); sky, NaN or a zero
//!    normal give [`MirrorStatus::NoSurface`]. A normal facing away from
//!    the eye is flipped toward it (a two-sided surface seen from behind).
//! 3. **Ray.** `r = v - 2 (v . n) n` with `v` the unit view direction from
//!    the eye to `P` (the mirror reflection of seed 001 appendix).
//! 4. **Start.** A depth texel stores one depth over its footprint, so a
//!    ray leaving a surface that recedes from the camera runs behind its own
//!    surface's next texels for about half a texel, and any kernel started
//!    at `P` reports its own reflector (self-intersection). The ray starts
//!    where its projection has moved [`MirrorOptions::start_pixels`] pixels
//!    from `P`'s ([`crate::trace::ray_start_t`], closed form in f64), or at
//!    [`MirrorOptions::t_min`] if that is later. This is independent of the
//!    thickness and of the viewing angle: with a constant thickness of 1x
//!    the scene depth a depth-slope start (the root package's old rule) left
//!    3,797 self-hits where this rule left none (issue 13). A ray whose
//!    projection never moves that far (toward its own vanishing point) goes
//!    to the host ([`MirrorStatus::NoProjection`]).
//! 5. **Thickness.** With a back-face image in the G-buffer, a hit needs the
//!    ray between the front and the back depth ([`Thickness::BackFaces`]);
//!    otherwise every surface is [`MirrorOptions::thickness`] times the
//!    reflecting pixel's linear depth thick ([`Thickness::Constant`]; a
//!    scale-free default).
//! 6. **Trace** from `P + t0 r` with `t_max - t0`; the hit is refined to
//!    sub-pixel precision ([`crate::trace::refine_hit`]) when
//!    [`MirrorOptions::refine`] is set. `t` is reported from `P`.
//! 7. **Validate.** A ray that passes behind an object, within its
//!    thickness, is reported by the kernels as a hit, though what it really
//!    meets (if anything) is hidden: the hit is accepted only where the ray
//!    meets the visible surface, i.e. the hit was refined onto the plane of
//!    the surface around it, or the ray's depth at the hit is at most
//!    [`HIDDEN_SLOPES`] of a texel's depth change (the largest to a
//!    continuous neighbor) plus the ray's own depth change over one pixel
//!    of its projection behind the texel's front depth (a plane spreads
//!    half a change around the stored depth over the texel, and the ray may
//!    have crossed it anywhere on its last pixel); otherwise the ray
//!    resumes where its projection has left that texel (it may come out
//!    from behind the object and meet a visible surface), at most
//!    [`hidden_resumes`] times, and then goes to the host as
//!    [`MirrorStatus::Hidden`] ([`MirrorOptions::reject_hidden_hits`];
//!    on the test scene of `core/tests/ssr.rs` this removes most false
//!    hits). A hit where every texel of its bilinear footprint has a normal
//!    facing along the ray (`n . r >` [`BACK_FACE_COS`]) reached the surface from behind:
//!    what the ray really hits is hidden, so the hit is refused
//!    ([`MirrorStatus::BackFace`]) when [`MirrorOptions::reject_back_faces`]
//!    is set, and goes to the host. (One texel is not enough: at an edge the
//!    texel under the hit may show the neighboring surface.)
//! 8. **Confidence.** `1` in the image, fading linearly to `0` within
//!    [`MirrorOptions::border_fade`] (a fraction of the smaller image side)
//!    of the border, as production SSR fades hits near the screen edge so
//!    that a fallback (the host's probe) takes over without a seam.
//! 9. **Shade.** With a lit color in the G-buffer and a color output, the
//!    hit texel's color is written (black for every other status); blend
//!    `probe + confidence (color - probe)`.
//!
//! # What goes to the host
//! A ray that left the image ([`MirrorStatus::LeftImage`]), went behind
//! geometry ([`MirrorStatus::BehindGeometry`]), ran out of steps, has no
//! usable projection, or hit a back face is appended to the host-ray list as
//! a [`HostRay`] from `P` (the list is the caller's slice; rays past its end
//! are counted, and [`MirrorPass::host_ray`] gives any pixel's ray again). A
//! ray that reached `t_max` or the far plane in front of every surface
//! ([`MirrorStatus::Sky`]) is answered: within the view frustum, everything
//! in front of the depth buffer is empty.

use crate::trace::{refine_hit, RayStart, REFINE_CONTINUITY};
use crate::{
    Camera, DepthHit, Error, GBuffer, ImageViewMut, Miss, Ray, RowRange, Thickness, Trace,
};

/// How many texel depth changes (to the steepest continuous neighbor) an
/// unrefined kernel hit may lie behind its texel's front depth, besides
/// the ray's own depth change over one pixel, and still be on the visible
/// surface (module docs, step 7). A texel stores its center's depth; over
/// its footprint a plane lies within half a depth change of it (a curved
/// surface, as at a sphere's base, a little more), and the ray met the
/// surface somewhere on its last pixel before the kernel's sample (issue
/// 13; before, one whole change and no ray term, which refused true hits
/// of rays whose depth changes fast along their projection).
///
/// Measured (found within a pixel of the visible reflections / false
/// hits; 32 resumes), one change without the ray term (before), 0.75 with
/// it (now), 1 and 0.5 with it:
/// * `cpp_tests/ssr_example.cpp`, constant thickness: 99.07% / 319,
///   99.31% / 309, 99.32% / 403, 98.63% / 257 (now with
///   [`hidden_resumes`], 40 at 320x240: 99.31% / 312).
/// * The root package's `tests/ssr_scenes.rs` evaluation (stepping,
///   256x192, reversed-Z; false hits per ray whose reflection is not
///   visible): `stage`, all 12 poses: 98.83% / 2.81%, 98.82% / 2.85%,
///   98.82% / 3.13%, 98.83% / 2.60%; `room`, poses 0, 4, 8: 98.31% /
///   5.62%, 98.40% / 5.45%, 98.32% / 6.34%, 98.51% / 4.52%.
/// * The scene of `core/tests/ssr.rs` (linear depth), before and now:
///   default camera 98.37% / 74, 98.88% / 71; grazing 98.04% / 37,
///   99.15% / 42; near 95.71% / 103, 95.12% / 99.
///
/// (On `cpp_tests/ssr_example.cpp` 2, 3 and 5 changes without the ray term
/// had raised the found share by 0.15, 0.22 and 0.27 points and the false
/// hits by 42%, 55% and 83% over 1.)
pub const HIDDEN_SLOPES: f32 = 0.75;

/// A hit is on a back face when every texel around it has `n . r` above
/// this (module docs, step 7). At a curved object's base (a torus, a sphere
/// on a floor) the texels around a true hit face slightly along the ray;
/// measured on `cpp_tests/ssr_example.cpp`: 0 finds 98.54% of the visible
/// reflections with 277 false hits, 0.2 98.56% / 292, 0.4 99.07% / 319
/// (before issue 13 changed [`HIDDEN_SLOPES`]).
pub const BACK_FACE_COS: f32 = 0.4;

/// How often a ray resumes past a hidden hit before it goes to the host as
/// [`MirrorStatus::Hidden`] (module docs, step 7): this many times, or an
/// eighth of the image's larger side if that is more ([`hidden_resumes`]),
/// so that a ray may pass behind objects over the same share of the image
/// at every resolution (issue 13: with 32 at 512x384 the room's pose 0
/// handed 1,433 visible reflections to the host, 4% of them, against 0.6%
/// at 256x192).
pub const HIDDEN_RESUMES: u32 = 32;

/// The resume budget of a `width x height` image: [`HIDDEN_RESUMES`] or
/// `max(width, height) / 8`, whichever is larger.
pub const fn hidden_resumes(width: u32, height: u32) -> u32 {
    let side = if width > height { width } else { height };
    if side / 8 > HIDDEN_RESUMES {
        side / 8
    } else {
        HIDDEN_RESUMES
    }
}

/// Relative depth slack of the visible-surface test (module docs, step 7):
/// f32 rounding of the decoded depths.
pub const HIDDEN_EPSILON: f32 = 1e-4;
use glam::{Vec2, Vec3};

#[cfg(feature = "hiz")]
use crate::hiz::{try_trace_hiz, try_trace_hiz_rays_thick, HiZ, HiZOptions};

/// Pixels whose rays [`MirrorPass`] traces as one batch in a Hi-Z run
/// (at most 256: a chunk's pending list holds `u8` indices).
#[cfg(feature = "hiz")]
const BATCH: usize = 128;
#[cfg(feature = "depth-image")]
use crate::step::{try_step, StepOptions};

/// The kernel a [`MirrorPass`] traces with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MirrorMethod {
    /// Per-pixel stepping (`crate::step::try_step`, feature
    /// `depth-image`).
    Step,
    /// Hi-Z traversal (`crate::hiz::try_trace_hiz`, feature `hiz`): needs
    /// a pyramid built from the G-buffer's depth.
    HiZ,
}

/// Settings of the mirror pass. [`MirrorOptions::default`] is what the pass
/// was measured with (tests/ssr_scenes.rs of the root package).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MirrorOptions {
    /// The kernel.
    pub method: MirrorMethod,
    /// Stepping settings (used when `method` is [`MirrorMethod::Step`]).
    #[cfg(feature = "depth-image")]
    pub step: StepOptions,
    /// Hi-Z settings (used when `method` is [`MirrorMethod::HiZ`]).
    #[cfg(feature = "hiz")]
    pub hiz: HiZOptions,
    /// Surface thickness without a back-face image, relative to the
    /// reflecting pixel's linear depth (finite, `>= 0`).
    pub thickness: f32,
    /// Where a ray starts: once its projection has moved this many pixels
    /// (finite, `>= 0`; module docs, step 4).
    pub start_pixels: f32,
    /// The ray starts no earlier than this distance from the surface point
    /// (finite, `>= 0`).
    pub t_min: f32,
    /// The longest ray, world units (`> t_min`; `+inf` allowed).
    pub t_max: f32,
    /// Pixels with a roughness above this are not traced (used only with a
    /// roughness image; NaN roughness is never traced). Not NaN.
    pub max_roughness: f32,
    /// Width of the confidence fade at the image border, as a fraction of
    /// the smaller image side (`[0, 0.5]`; `0`: no fade).
    pub border_fade: f32,
    /// Refine hits to sub-pixel precision ([`crate::trace::refine_hit`]).
    pub refine: bool,
    /// Refuse hits on surfaces that face along the ray (module docs, step 7).
    pub reject_back_faces: bool,
    /// Refuse hits inside the thickness that do not lie on the visible
    /// surface (module docs, step 7).
    pub reject_hidden_hits: bool,
}

impl Default for MirrorOptions {
    /// Stepping (Hi-Z when only the `hiz` feature is on) with its defaults,
    /// thickness 0.5 of the pixel's depth, start after 1 pixel, `t_min = 0`,
    /// `t_max = +inf`, roughness up to 0.1, a 5% border fade, refined hits,
    /// back faces refused.
    fn default() -> Self {
        Self {
            #[cfg(feature = "depth-image")]
            method: MirrorMethod::Step,
            #[cfg(not(feature = "depth-image"))]
            method: MirrorMethod::HiZ,
            #[cfg(feature = "depth-image")]
            step: StepOptions::default(),
            #[cfg(feature = "hiz")]
            hiz: HiZOptions::default(),
            thickness: 0.5,
            start_pixels: 1.0,
            t_min: 0.0,
            t_max: f32::INFINITY,
            max_roughness: 0.1,
            border_fade: 0.05,
            refine: true,
            reject_back_faces: true,
            reject_hidden_hits: true,
        }
    }
}

/// What the pass did at one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum MirrorStatus {
    /// Not reflective (mask 0, roughness above the limit or NaN), or not in
    /// the rows a run wrote.
    #[default]
    Skipped = 0,
    /// No usable surface: sky, NaN depth, zero or non-finite normal.
    NoSurface = 1,
    /// A validated hit.
    Hit = 2,
    /// The ray reached `t_max` or the far plane in front of every surface:
    /// it hits nothing (answered).
    Sky = 3,
    /// Host: the projected ray left the image.
    LeftImage = 4,
    /// Host: the ray passed behind geometry.
    BehindGeometry = 5,
    /// Host: the kernel's step or iteration cap was reached.
    OutOfSteps = 6,
    /// Host: the ray has no usable projection (it never moves
    /// `start_pixels` from its origin, or leaves through the near plane at
    /// once), or its hit lies so far away that the distance overflows f32.
    NoProjection = 7,
    /// Host: the hit surface faces along the ray.
    BackFace = 8,
    /// Host: the kernel's hit lies inside the thickness, not on the
    /// visible surface (module docs, step 7).
    Hidden = 9,
}

impl MirrorStatus {
    /// `true` for the statuses whose pixels are handed to the host.
    pub const fn needs_host(self) -> bool {
        matches!(
            self,
            Self::LeftImage
                | Self::BehindGeometry
                | Self::OutOfSteps
                | Self::NoProjection
                | Self::BackFace
                | Self::Hidden
        )
    }
}

/// One pixel of the pass's output.
///
/// `#[repr(C)]` (a status byte, three bytes of padding, then the floats:
/// 20 bytes), so that the C ABI can read an array of its own texels
/// (`refl_ssr_texel`, whose `uint32_t` status starts with the same byte on
/// little-endian targets) in place once it has checked every status.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct MirrorTexel {
    /// What happened.
    pub status: MirrorStatus,
    /// Sub-pixel position of the hit in the image (pixels; the texel hit is
    /// its floor). `[0, 0]` without a hit.
    pub pixel: Vec2,
    /// Distance along the ray from the surface point to the hit (world
    /// units). `0` without a hit.
    pub t: f32,
    /// Confidence of the hit in `[0, 1]` (module docs, step 8). `0` without
    /// a hit.
    pub confidence: f32,
}

/// A pixel's reflection ray for the host's tracer.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HostRay {
    /// Pixel column.
    pub x: u32,
    /// Pixel row.
    pub y: u32,
    /// The surface point (the ray's origin; add the host's own offset).
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// Trace from this distance ([`MirrorOptions::t_min`]).
    pub t_min: f32,
    /// Trace up to this distance ([`MirrorOptions::t_max`]).
    pub t_max: f32,
    /// Why the screen did not answer.
    pub status: MirrorStatus,
}

/// Counts of one run over a band.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MirrorStats {
    /// Pixels traced (reflective with a surface).
    pub traced: u32,
    /// Validated hits.
    pub hits: u32,
    /// Rays answered as sky.
    pub sky: u32,
    /// Pixels that need the host's tracer.
    pub host_rays: u32,
    /// Of those, the ones written to the host list (the rest did not fit).
    pub host_rays_written: u32,
}

/// The trace of one pixel as the pass sets it up (what [`MirrorPass`]
/// hands its kernel): for tests and hosts that want the rays themselves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MirrorRay {
    /// The surface point.
    pub origin: Vec3,
    /// Unit reflection direction.
    pub dir: Vec3,
    /// Unit normal the ray was reflected about (facing the eye).
    pub normal: Vec3,
    /// Where the kernel starts, from `origin` (module docs, step 4).
    pub t_start: f32,
    /// The thickness the kernel is given when there is no back-face image
    /// (linear depth units).
    pub thickness: f32,
}

impl MirrorRay {
    /// The ray the kernel traces, starting at `t_start`.
    pub fn kernel_ray(&self) -> Ray {
        Ray {
            origin: self.origin + self.dir * self.t_start,
            dir: self.dir,
        }
    }
}

/// Steps 2 and 3 of the module docs for the surface point `p` with unit
/// normal `n` seen from `eye`: the normal turned toward the eye (flipped
/// when it faces away: a two-sided surface seen from behind) and the unit
/// mirror direction `r = v - 2 (v . n) n` (seed 001 appendix) with `v` the
/// unit view direction from `eye` to `p`; `None` when `p` is at the eye or
/// the direction degenerates. The one ray generation of the passes
/// ([`MirrorPass`], the glossy pass's axis, the cluster kernels and pass).
pub(crate) fn reflect_view(eye: Vec3, p: Vec3, n: Vec3) -> Option<(Vec3, Vec3)> {
    let v = p - eye;
    // A surface farther than about 1.8e19 from the eye (an infinite far
    // plane), or nearer than about 1e-19 (a tiny near plane), has a view
    // vector whose square overflows or underflows f32: scaled by its
    // largest component first (finding F26b; others keep their bits).
    let m = v.abs().max_element();
    let v = if !(1e-18..=1e18).contains(&m) && m > 0.0 && m.is_finite() {
        v / m
    } else {
        v
    };
    let v = v.normalize_or_zero();
    let n = if n.dot(v) > 0.0 { -n } else { n };
    let dir = (v - 2.0 * v.dot(n) * n).normalize_or_zero();
    if v == Vec3::ZERO || dir == Vec3::ZERO {
        return None;
    }
    Some((n, dir))
}

/// A pixel's surface and mirror direction ([`MirrorPass`] steps 1 to 3).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Reflection {
    /// The surface point.
    pub origin: Vec3,
    /// Unit normal, facing the eye.
    pub normal: Vec3,
    /// Unit mirror direction.
    pub dir: Vec3,
    /// Linear depth of the pixel.
    pub depth: f32,
}

/// The four texels whose centers surround `p` (the bilinear footprint),
/// shifted inside at the top and left border (those past the bottom or
/// right border are outside the image and read as no surface).
fn footprint(p: Vec2) -> [(u32, u32); 4] {
    let x0 = libm::floorf(p.x - 0.5).max(0.0) as u32;
    let y0 = libm::floorf(p.y - 0.5).max(0.0) as u32;
    [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)]
}

/// Whether a kernel hit lies on the visible surface (module docs, step 7).
#[derive(Clone, Copy)]
enum Front {
    /// On it: the hit stands.
    Visible,
    /// Behind it: the ray may resume `resume` past the hit point (`None`:
    /// its projection never moves a pixel from there).
    Hidden { resume: Option<f32> },
}

/// A pixel's setup, or the status that ends it early (also what the
/// layered pass, `crate::layered_pass`, builds on: one ray generation and
/// start rule for every pass).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Setup {
    Done(MirrorStatus),
    /// The ray starts at or beyond `t_max`: answered as sky untraced.
    Sky(MirrorRay),
    Trace(MirrorRay),
    Host(MirrorRay, MirrorStatus),
}

/// One pixel's mirror ray as [`MirrorPass`] traced it: what the glossy
/// pass (`crate::glossy`) builds on, so that both passes share one ray
/// generation, start rule and hit validation.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(feature = "cone"), allow(dead_code))]
pub(crate) struct AxisTrace {
    /// The pixel's texel, as [`MirrorPass::pixel`] gives it.
    pub texel: MirrorTexel,
    /// Its host ray, as [`MirrorPass::pixel`] gives it.
    pub host: Option<HostRay>,
    /// The reflection ray, for every pixel with one (`None` for
    /// [`MirrorStatus::Skipped`] and [`MirrorStatus::NoSurface`]).
    pub ray: Option<MirrorRay>,
    /// Whether the ray was traced from `ray.t_start` (not handed over or
    /// answered before tracing).
    pub traced: bool,
}

/// The mirror pass over one frame (module docs).
#[derive(Clone, Copy, Debug)]
pub struct MirrorPass<'a> {
    gbuffer: GBuffer<'a>,
    options: MirrorOptions,
    #[cfg(feature = "hiz")]
    hiz: Option<HiZ<'a>>,
    /// [`ray_start_t`]'s per-camera constants, once per pass.
    start: RayStart,
}

pub(crate) fn validate_options(o: &MirrorOptions) -> Result<(), Error> {
    let finite_nonneg = |x: f32| x >= 0.0 && x.is_finite();
    let ok = finite_nonneg(o.thickness)
        && finite_nonneg(o.start_pixels)
        && finite_nonneg(o.t_min)
        && o.t_max > o.t_min
        && !o.max_roughness.is_nan()
        && (0.0..=0.5).contains(&o.border_fade);
    if !ok {
        return Err(Error::InvalidArgument);
    }
    #[cfg(feature = "depth-image")]
    if o.method == MirrorMethod::Step && o.step.stride == 0 {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

impl<'a> MirrorPass<'a> {
    /// Describes the pass over `gbuffer` with `options`; `hiz` is the
    /// pyramid of the G-buffer's depth for [`MirrorMethod::HiZ`] (built
    /// with `crate::try_build_hiz` from [`GBuffer::depth`]; ignored for
    /// stepping).
    ///
    /// # Errors
    /// * [`Error::InvalidArgument`]: an option out of its range (see
    ///   [`MirrorOptions`]); a method whose feature is not compiled in;
    ///   Hi-Z without a pyramid, or with a pyramid of another camera or
    ///   depth convention than the G-buffer's.
    #[cfg(feature = "hiz")]
    pub fn try_new(
        gbuffer: GBuffer<'a>,
        options: MirrorOptions,
        hiz: Option<HiZ<'a>>,
    ) -> Result<Self, Error> {
        validate_options(&options)?;
        match options.method {
            MirrorMethod::HiZ => {
                let h = hiz.as_ref().ok_or(Error::InvalidArgument)?;
                if h.camera() != gbuffer.camera() || h.convention() != gbuffer.convention() {
                    return Err(Error::InvalidArgument);
                }
            }
            MirrorMethod::Step => {
                if cfg!(not(feature = "depth-image")) {
                    return Err(Error::InvalidArgument);
                }
            }
        }
        Ok(Self {
            start: RayStart::new(gbuffer.camera()),
            gbuffer,
            options,
            hiz,
        })
    }

    /// Describes the stepping pass over `gbuffer` with `options` (built
    /// without the `hiz` feature).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`]: an option out of its range (see
    /// [`MirrorOptions`]).
    #[cfg(not(feature = "hiz"))]
    pub fn try_new(gbuffer: GBuffer<'a>, options: MirrorOptions) -> Result<Self, Error> {
        validate_options(&options)?;
        Ok(Self {
            start: RayStart::new(gbuffer.camera()),
            gbuffer,
            options,
        })
    }

    /// A pass that only generates rays ([`MirrorPass::ray`],
    /// [`MirrorPass::host_ray`]): `options` validated as by
    /// [`MirrorPass::try_new`], no kernel checked and no pyramid (its traces
    /// are errors). For passes that trace the same rays against something
    /// else (the layered pass).
    #[cfg_attr(not(feature = "layered"), allow(dead_code))]
    pub(crate) fn try_rays_only(
        gbuffer: GBuffer<'a>,
        options: MirrorOptions,
    ) -> Result<Self, Error> {
        validate_options(&options)?;
        Ok(Self {
            start: RayStart::new(gbuffer.camera()),
            gbuffer,
            options,
            #[cfg(feature = "hiz")]
            hiz: None,
        })
    }

    /// The G-buffer.
    pub const fn gbuffer(&self) -> &GBuffer<'a> {
        &self.gbuffer
    }

    /// The options.
    pub const fn options(&self) -> &MirrorOptions {
        &self.options
    }

    fn camera(&self) -> &Camera {
        self.gbuffer.camera()
    }

    pub(crate) fn reflective(&self, x: u32, y: u32) -> bool {
        if let Some(m) = self.gbuffer.mask() {
            if m.get(x, y) == Some(0) {
                return false;
            }
        }
        if let Some(r) = self.gbuffer.roughness() {
            match r.get(x, y) {
                Some(r) if r <= self.options.max_roughness => {}
                _ => return false,
            }
        }
        true
    }

    /// Steps 1 to 3 of the module docs at pixel `(x, y)`: the surface
    /// point, the normal turned toward the eye, the reflection direction
    /// and the pixel's linear depth; or the status that ends the pixel
    /// there ([`MirrorStatus::Skipped`], [`MirrorStatus::NoSurface`]). The
    /// ray generation every G-buffer pass shares (the mirror, glossy and
    /// cluster passes).
    pub(crate) fn reflection(&self, x: u32, y: u32) -> Result<Reflection, MirrorStatus> {
        if !self.reflective(x, y) {
            return Err(MirrorStatus::Skipped);
        }
        let s = self.gbuffer.surface(x, y).ok_or(MirrorStatus::NoSurface)?;
        let (normal, dir) = reflect_view(self.camera().eye(), s.position, s.normal)
            .ok_or(MirrorStatus::NoSurface)?;
        Ok(Reflection {
            origin: s.position,
            normal,
            dir,
            depth: s.depth,
        })
    }

    pub(crate) fn setup(&self, x: u32, y: u32) -> Setup {
        let s = match self.reflection(x, y) {
            Ok(s) => s,
            Err(status) => return Setup::Done(status),
        };
        let ray = Ray {
            origin: s.origin,
            dir: s.dir,
        };
        let thickness = self.options.thickness * s.depth;
        let mut mr = MirrorRay {
            origin: s.origin,
            dir: s.dir,
            normal: s.normal,
            t_start: self.options.t_min,
            thickness,
        };
        match self.start.t(&ray, self.options.start_pixels) {
            Some(t0) if thickness.is_finite() => {
                mr.t_start = t0.max(self.options.t_min);
                if !(mr.t_start < self.options.t_max) {
                    return Setup::Sky(mr);
                }
                Setup::Trace(mr)
            }
            _ => Setup::Host(mr, MirrorStatus::NoProjection),
        }
    }

    /// The ray the pass traces for pixel `(x, y)`, or `None` where it
    /// traces none (not reflective, no surface, or a ray it hands to the
    /// host without tracing).
    pub fn ray(&self, x: u32, y: u32) -> Option<MirrorRay> {
        match self.setup(x, y) {
            Setup::Trace(r) => Some(r),
            _ => None,
        }
    }

    /// The host ray of pixel `(x, y)` as the pass would hand it over with
    /// `status` (for pixels whose list entry did not fit), or `None` for a
    /// pixel without a reflection ray.
    pub fn host_ray(&self, x: u32, y: u32, status: MirrorStatus) -> Option<HostRay> {
        match self.setup(x, y) {
            Setup::Trace(r) | Setup::Host(r, _) => Some(self.host_entry(x, y, &r, status)),
            Setup::Done(_) | Setup::Sky(_) => None,
        }
    }

    fn host_entry(&self, x: u32, y: u32, r: &MirrorRay, status: MirrorStatus) -> HostRay {
        self.host_ray_from(x, y, r.origin, r.dir, status)
    }

    /// The host ray of pixel `(x, y)` from `origin` along `dir` (a
    /// [`Reflection`]'s) with `status`: the list entry of every pass.
    pub(crate) fn host_ray_from(
        &self,
        x: u32,
        y: u32,
        origin: Vec3,
        dir: Vec3,
        status: MirrorStatus,
    ) -> HostRay {
        HostRay {
            x,
            y,
            origin,
            dir,
            t_min: self.options.t_min,
            t_max: self.options.t_max,
            status,
        }
    }

    fn thickness(&self, r: &MirrorRay) -> Thickness<'a> {
        match self.gbuffer.back_depth() {
            Some(b) => Thickness::BackFaces(*b),
            None => Thickness::Constant(r.thickness),
        }
    }

    /// The kernel's trace of a pixel's ray, unrefined: exactly what
    /// `crate::step::try_step` or `crate::hiz::try_trace_hiz` returns
    /// for [`MirrorRay::kernel_ray`], `t_max - t_start`, the thickness
    /// above and the options' kernel settings.
    ///
    /// # Errors
    /// As the kernel (never for a ray from [`MirrorPass::ray`]).
    pub fn try_trace_kernel(&self, r: &MirrorRay) -> Result<Trace, Error> {
        let ray = r.kernel_ray();
        let t_max = self.options.t_max - r.t_start;
        let th = self.thickness(r);
        match self.options.method {
            #[cfg(feature = "depth-image")]
            MirrorMethod::Step => try_step(self.gbuffer.depth(), th, ray, t_max, self.options.step),
            #[cfg(feature = "hiz")]
            MirrorMethod::HiZ => match &self.hiz {
                Some(h) => try_trace_hiz(h, th, ray, t_max, &self.options.hiz),
                None => Err(Error::InvalidArgument),
            },
            #[allow(unreachable_patterns)]
            _ => Err(Error::InvalidArgument),
        }
    }

    /// The first visible surface of the output view that `ray` (from a
    /// surface point of it) meets within `t_max`, by stepping through the
    /// G-buffer's depth (whatever [`MirrorOptions::method`]): the pass's
    /// start rule, thickness (relative to the depth of `ray.origin`, or the
    /// back faces), step options, refinement and hidden-hit test (a hidden
    /// hit ends the search). The hit's `t` is from `ray.origin`. For rays
    /// that are not a pixel's mirror ray: the cluster pass's second
    /// intersections (seed 003 Sec. 4.4).
    #[cfg(feature = "cluster")]
    pub(crate) fn trace_visible(&self, ray: &Ray, t_max: f32) -> Option<DepthHit> {
        let t0 = self
            .start
            .t(ray, self.options.start_pixels)?
            .max(self.options.t_min);
        if !(t0 < t_max) {
            return None;
        }
        let from = Ray {
            origin: ray.at(t0),
            dir: ray.dir,
        };
        let th = match self.gbuffer.back_depth() {
            Some(b) => Thickness::BackFaces(*b),
            None => {
                Thickness::Constant(self.options.thickness * self.camera().linear_depth(ray.origin))
            }
        };
        let depth = self.gbuffer.depth();
        let Ok(Trace::Hit(h)) = try_step(depth, th, from, t_max - t0, self.options.step) else {
            return None;
        };
        let (h, refined) = if self.options.refine {
            let f = refine_hit(depth, &from, t_max - t0, &h);
            let moved = f.t.to_bits() != h.t.to_bits() || f.pixel != h.pixel;
            (f, moved)
        } else {
            (h, false)
        };
        if self.options.reject_hidden_hits {
            if let Front::Hidden { .. } = self.front(&h, refined, &from) {
                return None;
            }
        }
        Some(DepthHit { t: t0 + h.t, ..h })
    }

    /// Whether a kernel hit of `ray` lies on the visible surface (module
    /// docs, step 7): refined onto the surface's plane, or at most
    /// [`HIDDEN_SLOPES`] texel depth changes plus the ray's depth change
    /// over one pixel behind the texel's front depth. Hidden, it also
    /// gives what resuming needs: the parameter past the hit point where the
    /// ray's projection has moved one pixel (its [`RayStart::t`], computed
    /// once for both).
    fn front(&self, h: &DepthHit, refined: bool, ray: &Ray) -> Front {
        if refined {
            return Front::Visible;
        }
        // The ray's own depth change over one pixel of its projection at
        // the hit: it may have crossed the surface anywhere on its last
        // pixel before the kernel's sample.
        let at = Ray {
            origin: ray.at(h.t),
            dir: ray.dir,
        };
        let cam = self.camera();
        let resume = self.start.t(&at, 1.0);
        let ray_dz = resume
            .map(|dt| (cam.linear_depth(at.at(dt)) - cam.linear_depth(at.origin)).abs())
            .filter(|dz| dz.is_finite())
            .unwrap_or(0.0);
        let (x, y) = (h.pixel.x as u32, h.pixel.y as u32);
        let d = self.gbuffer.depth();
        let Some(z0) = d.linear_at(x, y) else {
            return Front::Visible;
        };
        // The largest depth change to a continuous neighbor (the plate
        // error of a texel on a sloped surface is up to half of it).
        let mut slope = 0.0f32;
        for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
            let (nx, ny) = (i64::from(x) + dx, i64::from(y) + dy);
            if nx < 0 || ny < 0 {
                continue;
            }
            if let Some(z) = d.linear_at(nx as u32, ny as u32) {
                let dz = (z - z0).abs();
                if dz <= REFINE_CONTINUITY * z0 {
                    slope = slope.max(dz);
                }
            }
        }
        if h.depth <= z0 + HIDDEN_SLOPES * slope + ray_dz + HIDDEN_EPSILON * z0 {
            Front::Visible
        } else {
            Front::Hidden { resume }
        }
    }

    /// Whether every texel of the bilinear footprint of `p` (the up to 4
    /// texel centers around it) with a usable normal faces along `dir`, and
    /// there is one: the ray meets the surface from behind. One texel is
    /// not enough at an edge, where the texel under the hit may show the
    /// neighboring surface (a floor under a box's base).
    fn faces_away(&self, p: Vec2, dir: Vec3) -> bool {
        let mut any = false;
        for (x, y) in footprint(p) {
            if let Some(n) = self.gbuffer.world_normal(x, y) {
                if !(n.dot(dir) > BACK_FACE_COS) {
                    return false;
                }
                any = true;
            }
        }
        any
    }

    fn confidence(&self, p: Vec2) -> f32 {
        let (w, h) = (self.gbuffer.width() as f32, self.gbuffer.height() as f32);
        let band = self.options.border_fade * w.min(h);
        if !(band > 0.0) {
            return 1.0;
        }
        let d = p.x.min(w - p.x).min(p.y).min(h - p.y);
        (d / band).clamp(0.0, 1.0)
    }

    /// Traces and validates one pixel: its output texel and, for the
    /// statuses of [`MirrorStatus::needs_host`], its host ray.
    pub fn pixel(&self, x: u32, y: u32) -> (MirrorTexel, Option<HostRay>) {
        let a = self.trace_axis(x, y);
        (a.texel, a.host)
    }

    /// [`MirrorPass::pixel`] with the ray it traced.
    pub(crate) fn trace_axis(&self, x: u32, y: u32) -> AxisTrace {
        self.axis_from_setup(x, y, self.setup(x, y))
    }

    /// [`MirrorPass::trace_axis`] from the pixel's [`Setup`].
    fn axis_from_setup(&self, x: u32, y: u32, setup: Setup) -> AxisTrace {
        let mut out = MirrorTexel::default();
        let done = |texel, host, ray| AxisTrace {
            texel,
            host,
            ray,
            traced: false,
        };
        let r = match setup {
            Setup::Done(s) => {
                out.status = s;
                return done(out, None, None);
            }
            Setup::Sky(r) => {
                out.status = MirrorStatus::Sky;
                return done(out, None, Some(r));
            }
            Setup::Host(r, s) => {
                out.status = s;
                return done(out, Some(self.host_entry(x, y, &r, s)), Some(r));
            }
            Setup::Trace(r) => r,
        };
        // A hidden hit (the ray passed behind an object within its
        // thickness) does not end the ray: it resumes one pixel past it, at
        // most `hidden_resumes` times (module docs, step 7).
        let mut seg = r;
        let mut resumes = 0;
        let budget = hidden_resumes(self.gbuffer.width(), self.gbuffer.height());
        let status = loop {
            let trace = self.try_trace_kernel(&seg);
            if let Some(s) = self.outcome(&mut seg, &mut resumes, budget, trace, &mut out) {
                break s;
            }
        };
        self.traced_axis(x, y, r, out, status)
    }

    /// The traced pixel `(x, y)` with ray `r`, texel `out` and `status`.
    fn traced_axis(
        &self,
        x: u32,
        y: u32,
        r: MirrorRay,
        mut out: MirrorTexel,
        status: MirrorStatus,
    ) -> AxisTrace {
        out.status = status;
        let host = status
            .needs_host()
            .then(|| self.host_entry(x, y, &r, status));
        AxisTrace {
            texel: out,
            host,
            ray: Some(r),
            traced: true,
        }
    }

    /// One kernel trace of a pixel's ray `seg` judged (module docs, steps
    /// 6 and 7): the pixel's status, with the hit written to `out`, or
    /// `None` when the hit is hidden and the ray resumes past it (`seg`'s
    /// start moved, `resumes` counted, at most `budget` times).
    fn outcome(
        &self,
        seg: &mut MirrorRay,
        resumes: &mut u32,
        budget: u32,
        trace: Result<Trace, Error>,
        out: &mut MirrorTexel,
    ) -> Option<MirrorStatus> {
        let Ok(Trace::Hit(h)) = trace else {
            return Some(match trace {
                Ok(Trace::Miss { reason, .. }) => match reason {
                    Miss::EndOfRay => MirrorStatus::Sky,
                    Miss::LeftImage => MirrorStatus::LeftImage,
                    Miss::BehindGeometry => MirrorStatus::BehindGeometry,
                    Miss::OutOfSteps => MirrorStatus::OutOfSteps,
                    Miss::DegenerateProjection => MirrorStatus::NoProjection,
                },
                // Not reached for a ray from `setup` (validated options,
                // unit direction, finite origin); handed over rather
                // than lost.
                _ => MirrorStatus::NoProjection,
            });
        };
        let (h, refined) = if self.options.refine {
            let f = refine_hit(
                self.gbuffer.depth(),
                &seg.kernel_ray(),
                self.options.t_max - seg.t_start,
                &h,
            );
            let moved = f.t.to_bits() != h.t.to_bits() || f.pixel != h.pixel;
            (f, moved)
        } else {
            (h, false)
        };
        let front = if self.options.reject_hidden_hits {
            self.front(&h, refined, &seg.kernel_ray())
        } else {
            Front::Visible
        };
        if let Front::Hidden { resume } = front {
            // Resume where the projection has left the hit's texel.
            match resume.map(|dt| seg.t_start + h.t + dt) {
                Some(t) if *resumes < budget && t < self.options.t_max => {
                    *resumes += 1;
                    seg.t_start = t;
                    return None;
                }
                _ => return Some(MirrorStatus::Hidden),
            }
        }
        if self.options.reject_back_faces && self.faces_away(h.pixel, seg.dir) {
            return Some(MirrorStatus::BackFace);
        }
        // A surface so far away (a depth near f32::MAX) that the
        // distance to it overflows f32 is no hit the pass can state:
        // the host traces it (found by the `ssr` fuzz target).
        // The kernel's `t` is at most `t_max - t_start`, which rounds:
        // the sum may pass `t_max` by an ulp (as the layered pass's did,
        // F32); the hit lies at the end.
        let t = seg.t_start + h.t;
        let t = if t > self.options.t_max {
            self.options.t_max
        } else {
            t
        };
        if !t.is_finite() {
            return Some(MirrorStatus::NoProjection);
        }
        out.pixel = h.pixel;
        out.t = t;
        out.confidence = self.confidence(h.pixel);
        Some(MirrorStatus::Hit)
    }

    /// Runs the pass over the rows `out` owns (a whole image or a band from
    /// [`ImageViewMut::try_band`]): writes every pixel's [`MirrorTexel`],
    /// the lit color at each hit into `color` (black elsewhere; needs a
    /// G-buffer color), and appends the pixels that need the host's tracer
    /// to `host` in row-major order, as far as `host` holds them.
    ///
    /// Contract: `out` (and `color`) are the G-buffer's size; `host` may be
    /// empty (the statuses still say which pixels need the host, and
    /// [`MirrorPass::host_ray`] gives their rays).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `out` or `color` is not the G-buffer's
    /// size, or their bands differ, or `color` is given without a G-buffer
    /// color. Nothing is written then.
    pub fn try_run(
        &self,
        out: &mut ImageViewMut<'_, MirrorTexel>,
        color: Option<&mut ImageViewMut<'_, [f32; 3]>>,
        host: &mut [HostRay],
    ) -> Result<MirrorStats, Error> {
        if color.is_some() && self.gbuffer.color().is_none() {
            return Err(Error::InvalidArgument);
        }
        let (w, h) = (self.gbuffer.width(), self.gbuffer.height());
        match ImageSink::try_new(out, color, host, w, h)? {
            Some((rows, mut sink)) => Ok(self.run_rows(rows, &mut sink)),
            None => Ok(MirrorStats::default()),
        }
    }

    /// Runs the pass over `rows` (checked against the G-buffer's height)
    /// and hands every pixel's texel and color, and every host ray in
    /// row-major order, to `sink`: the loop of [`MirrorPass::try_run`] for
    /// hosts whose buffers are not [`ImageViewMut`]s (refl-ffi writes C
    /// structs through it).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `rows` ends beyond the G-buffer's
    /// height. Nothing is handed to `sink` then.
    pub fn try_run_rows(
        &self,
        rows: RowRange,
        sink: &mut impl MirrorSink,
    ) -> Result<MirrorStats, Error> {
        if rows.end() > self.gbuffer.height() {
            return Err(Error::InvalidArgument);
        }
        Ok(self.run_rows(rows, sink))
    }

    fn run_rows(&self, rows: RowRange, sink: &mut impl MirrorSink) -> MirrorStats {
        let mut stats = MirrorStats::default();
        #[cfg(feature = "hiz")]
        if let Some(hiz) = self.batch_hiz() {
            for y in rows.rows() {
                self.axes_batched(
                    hiz,
                    y,
                    |_| true,
                    |x, a| {
                        if let Some(a) = a {
                            let (t, rgb) = self.count_and_shade(a.texel, a.host, &mut stats, sink);
                            sink.texel(x, y, &t, rgb);
                        }
                    },
                );
            }
            return stats;
        }
        for y in rows.rows() {
            for x in 0..self.gbuffer.width() {
                let (t, rgb) = self.run_pixel(x, y, &mut stats, sink);
                sink.texel(x, y, &t, rgb);
            }
        }
        stats
    }

    /// The pyramid a run traces its rays over in batches
    /// ([`MirrorPass::axes_batched`]): a Hi-Z pass with constant thickness.
    #[cfg(feature = "hiz")]
    pub(crate) fn batch_hiz(&self) -> Option<&HiZ<'a>> {
        match (self.options.method, &self.hiz, self.gbuffer.back_depth()) {
            (MirrorMethod::HiZ, Some(h), None) => Some(h),
            _ => None,
        }
    }

    /// Row `y` of a Hi-Z run with constant thickness ([`Self::batch_hiz`]),
    /// chunk by chunk of [`BATCH`] pixels: the rays of a chunk's pixels
    /// with `want(x)` are traced as one batch
    /// (`crate::hiz::try_trace_hiz_rays_thick`: the AVX2 ray stream where
    /// the CPU has it) and judged; the rays whose hit was hidden resume in
    /// the next batch, until every ray has its status; then `f` gets every
    /// pixel of the chunk in row order, with its [`AxisTrace`] (`None`
    /// where not `want(x)`). The same traces as
    /// [`MirrorPass::trace_axis`] pixel by pixel: each pixel's ray sees the
    /// same kernel results (the batch returns the single-ray kernel's) and
    /// the same judgment ([`MirrorPass::outcome`]). About 20 KB of stack
    /// for the chunk. The loop of the mirror pass's runs and of the glossy
    /// pass's (`crate::glossy`).
    #[cfg(feature = "hiz")]
    pub(crate) fn axes_batched(
        &self,
        hiz: &HiZ<'_>,
        y: u32,
        want: impl Fn(u32) -> bool,
        mut f: impl FnMut(u32, Option<AxisTrace>),
    ) {
        let w = self.gbuffer.width();
        let budget = hidden_resumes(w, self.gbuffer.height());
        let none = Trace::Miss {
            reason: Miss::DegenerateProjection,
            work: crate::trace::Work::default(),
        };
        // Each pixel's setup (`None`: not wanted).
        let mut setups = [None::<Setup>; BATCH];
        // Per traced pixel of the chunk, in pixel order: its ray as it
        // resumes, its resumptions, texel and status (`None`: pending).
        let mut segs = [MirrorRay {
            origin: Vec3::ZERO,
            dir: Vec3::Z,
            normal: Vec3::Z,
            t_start: 0.0,
            thickness: 0.0,
        }; BATCH];
        let mut resumes = [0u32; BATCH];
        let mut texels = [MirrorTexel::default(); BATCH];
        let mut status = [None::<MirrorStatus>; BATCH];
        // The pending pixels of a round (indices into the above) and their
        // batch.
        let mut pending = [0u8; BATCH];
        let mut rays = [Ray {
            origin: Vec3::ZERO,
            dir: Vec3::Z,
        }; BATCH];
        let (mut th, mut t_max) = ([0.0f32; BATCH], [0.0f32; BATCH]);
        let mut traces = [none; BATCH];
        let mut x0 = 0;
        while x0 < w {
            let n = (w - x0).min(BATCH as u32) as usize;
            let mut count = 0;
            for (i, s) in setups[..n].iter_mut().enumerate() {
                let x = x0 + i as u32;
                *s = want(x).then(|| self.setup(x, y));
                if let Some(Setup::Trace(r)) = s {
                    segs[count] = *r;
                    resumes[count] = 0;
                    texels[count] = MirrorTexel::default();
                    status[count] = None;
                    pending[count] = count as u8;
                    count += 1;
                }
            }
            let mut left = count;
            while left > 0 {
                for (j, &k) in pending[..left].iter().enumerate() {
                    let r = &segs[usize::from(k)];
                    rays[j] = r.kernel_ray();
                    t_max[j] = self.options.t_max - r.t_start;
                    th[j] = r.thickness;
                }
                // Never `Err` for the rays of `setup` (validated options,
                // unit directions, finite origins); each ray is traced on
                // its own if it were.
                let batched = try_trace_hiz_rays_thick(
                    &mut traces[..left],
                    hiz,
                    &th[..left],
                    &rays[..left],
                    &t_max[..left],
                    &self.options.hiz,
                )
                .is_ok();
                let mut still = 0;
                for j in 0..left {
                    let k = usize::from(pending[j]);
                    let trace = if batched {
                        Ok(traces[j])
                    } else {
                        self.try_trace_kernel(&segs[k])
                    };
                    match self.outcome(&mut segs[k], &mut resumes[k], budget, trace, &mut texels[k])
                    {
                        Some(st) => status[k] = Some(st),
                        None => {
                            pending[still] = k as u8;
                            still += 1;
                        }
                    }
                }
                left = still;
            }
            let mut k = 0;
            for (i, s) in setups[..n].iter().enumerate() {
                let x = x0 + i as u32;
                let Some(s) = s else {
                    f(x, None);
                    continue;
                };
                let a = match s {
                    Setup::Trace(r) => {
                        k += 1;
                        match status[k - 1] {
                            Some(st) => self.traced_axis(x, y, *r, texels[k - 1], st),
                            // Not reached: every ray ends with a status.
                            None => self.axis_from_setup(x, y, *s),
                        }
                    }
                    _ => self.axis_from_setup(x, y, *s),
                };
                f(x, Some(a));
            }
            x0 += n as u32;
        }
    }

    /// One pixel of a run: traces `(x, y)` ([`MirrorPass::pixel`]), counts
    /// it into `stats`, hands its host ray (if any) to `sink` and returns
    /// its texel and color ([`MirrorPass::shade`]). The loop body of
    /// [`MirrorPass::try_run_rows`] and of the half-resolution pass
    /// (`crate::upsample::HalfPass`), which writes the texel elsewhere.
    pub(crate) fn run_pixel(
        &self,
        x: u32,
        y: u32,
        stats: &mut MirrorStats,
        sink: &mut impl MirrorSink,
    ) -> (MirrorTexel, [f32; 3]) {
        let (t, hr) = self.pixel(x, y);
        self.count_and_shade(t, hr, stats, sink)
    }

    /// The accounting and shading of [`MirrorPass::run_pixel`] for a
    /// pixel's traced texel `t` and host ray `hr`.
    fn count_and_shade(
        &self,
        t: MirrorTexel,
        hr: Option<HostRay>,
        stats: &mut MirrorStats,
        sink: &mut impl MirrorSink,
    ) -> (MirrorTexel, [f32; 3]) {
        if !matches!(t.status, MirrorStatus::Skipped | MirrorStatus::NoSurface) {
            stats.traced += 1;
        }
        match t.status {
            MirrorStatus::Hit => stats.hits += 1,
            MirrorStatus::Sky => stats.sky += 1,
            _ => {}
        }
        if let Some(hr) = hr {
            if sink.host(stats.host_rays_written, &hr) {
                stats.host_rays_written += 1;
            }
            stats.host_rays += 1;
        }
        (t, self.shade(&t))
    }

    /// The reflection color of a pixel's texel as [`MirrorPass::try_run`]
    /// writes it: the G-buffer's lit color at the hit texel for a
    /// [`MirrorStatus::Hit`], black for every other status or without a
    /// lit color.
    pub fn shade(&self, t: &MirrorTexel) -> [f32; 3] {
        match (t.status, self.gbuffer.color()) {
            (MirrorStatus::Hit, Some(l)) => l
                .get(t.pixel.x as u32, t.pixel.y as u32)
                .unwrap_or([0.0; 3]),
            _ => [0.0; 3],
        }
    }
}

/// Where [`MirrorPass::try_run_rows`] puts its results.
pub trait MirrorSink {
    /// Pixel `(x, y)`'s texel and reflection color (the lit color at a
    /// hit, black otherwise or without a G-buffer color).
    fn texel(&mut self, x: u32, y: u32, texel: &MirrorTexel, color: [f32; 3]);
    /// Host ray number `index` of this run (0, 1, ... in row-major order,
    /// counting only those stored); returns `false` if it was not stored
    /// (the list is full).
    fn host(&mut self, index: u32, ray: &HostRay) -> bool;
}

/// The image outputs of a pass's `try_run` (the mirror and the glossy
/// pass): texels of type `T`, an optional color image of the same rows,
/// and the host-ray list.
pub(crate) struct ImageSink<'o, 'c, 'h, 'x, 'y, T> {
    out: &'o mut ImageViewMut<'x, T>,
    color: Option<&'c mut ImageViewMut<'y, [f32; 3]>>,
    host: &'h mut [HostRay],
}

impl<'o, 'c, 'h, 'x, 'y, T: Copy> ImageSink<'o, 'c, 'h, 'x, 'y, T> {
    /// Checks the outputs against a `width x height` G-buffer: the sink
    /// and the rows `out` owns (`None` if it owns none).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] if `out` or `color` is not `width x
    /// height`, or their bands differ.
    #[allow(clippy::type_complexity)]
    pub(crate) fn try_new(
        out: &'o mut ImageViewMut<'x, T>,
        color: Option<&'c mut ImageViewMut<'y, [f32; 3]>>,
        host: &'h mut [HostRay],
        width: u32,
        height: u32,
    ) -> Result<Option<(RowRange, Self)>, Error> {
        if out.width() != width || out.height() != height {
            return Err(Error::InvalidArgument);
        }
        if let Some(c) = color.as_deref() {
            if c.width() != width || c.height() != height || c.owned_rows() != out.owned_rows() {
                return Err(Error::InvalidArgument);
            }
        }
        Ok(out
            .owned_rows()
            .map(|rows| (rows, Self { out, color, host })))
    }

    /// Writes pixel `(x, y)`'s texel and color.
    pub(crate) fn put(&mut self, x: u32, y: u32, texel: &T, color: [f32; 3]) {
        if let Some(p) = self.out.get_mut(x, y) {
            *p = *texel;
        }
        if let Some(c) = self.color.as_deref_mut().and_then(|c| c.get_mut(x, y)) {
            *c = color;
        }
    }

    /// Stores host ray number `index` if the list holds it.
    pub(crate) fn put_host(&mut self, index: u32, ray: &HostRay) -> bool {
        match self.host.get_mut(index as usize) {
            Some(slot) => {
                *slot = *ray;
                true
            }
            None => false,
        }
    }
}

impl MirrorSink for ImageSink<'_, '_, '_, '_, '_, MirrorTexel> {
    fn texel(&mut self, x: u32, y: u32, texel: &MirrorTexel, color: [f32; 3]) {
        self.put(x, y, texel, color);
    }
    fn host(&mut self, index: u32, ray: &HostRay) -> bool {
        self.put_host(index, ray)
    }
}
