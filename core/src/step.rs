//! Ray / depth-image intersection by per-pixel stepping (seed 003 Sec. 3.4).
//!
//! Seed 003 Sec. 3.4: "the closest intersection between `r` and `DI` ... is
//! found by projecting `r` onto `DI`. ... `r'` is traversed from the near
//! endpoint to the far endpoint with one-pixel steps. ... A measure of depth
//! that is linear in screen space is used, i.e., proportional to `1/z`."
//!
//! # Example
//! ```rust
//! use core::f32::consts::FRAC_PI_2;
//! use refl_core::glam::Vec3;
//! use refl_core::{try_step, try_step_rays, Camera, DepthConvention, DepthImage, ImageView};
//! use refl_core::{Miss, Ray, StepOptions, Thickness, Trace};
//!
//! // 16 x 16 pixels of a wall at linear depth 10, 90 degrees field of view.
//! let cam = Camera::try_look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 0.1, 100.0, 16, 16)?;
//! let depth = vec![10.0f32; 256];
//! let image = DepthImage::try_new(ImageView::try_new(&depth, 16, 16, 16)?, cam, DepthConvention::Linear)?;
//!
//! // From (0, 0, -2) toward the wall point (8, 3, -10): NDC (0.8, 0.3),
//! // pixel (14.4, 5.6), at t = |(8, 3, -8)| = sqrt(137).
//! let origin = Vec3::new(0.0, 0.0, -2.0);
//! let ray = Ray { origin, dir: Vec3::new(8.0, 3.0, -8.0).normalize() };
//! let opts = StepOptions { stride: 4, max_steps: 256 };
//! let Trace::Hit(hit) = try_step(&image, Thickness::Constant(0.5), ray, f32::INFINITY, opts)? else {
//!     panic!("the ray reaches the wall");
//! };
//! assert_eq!(hit.pixel.floor().to_array(), [14.0, 5.0]);
//! assert!((hit.t - 137f32.sqrt()).abs() < 1e-3 && (hit.depth - 10.0).abs() < 1e-3);
//!
//! // A batch: the same ray, and one back toward the camera (it leaves the
//! // view through the near plane).
//! let rays = [ray, Ray { origin, dir: Vec3::Z }];
//! let mut out = [Trace::Miss { reason: Miss::EndOfRay, work: Default::default() }; 2];
//! try_step_rays(&mut out, &image, Thickness::Constant(0.5), &rays, &[f32::INFINITY], opts)?;
//! assert_eq!(out[0], Trace::Hit(hit));
//! assert!(matches!(out[1], Trace::Miss { reason: Miss::LeftImage, .. }));
//! # Ok::<(), refl_core::Error>(())
//! ```
//!
//! The kernel, [`try_step`], does this in four stages:
//!
//! 1. **Clip.** The ray `o + t d`, `t in [0, t_max]`, is clipped in 3D
//!    against the near plane, the far plane (when finite) and the four side
//!    planes of the camera's frustum (Liang-Barsky in `t`; the side planes
//!    are the image rectangle's edges). A ray starting behind the eye plane or
//!    in front of the near plane is thereby clipped to the near plane. If
//!    nothing is left the result is [`Miss::DegenerateProjection`].
//! 2. **Project.** The clipped endpoints are projected to pixel positions
//!    `p_a`, `p_b` with `1/z` values `iz_a`, `iz_b` (an infinite ray under an
//!    infinite far plane ends at its vanishing point, `iz_b = 0`). Along the
//!    2D segment `p(s) = p_a + s (p_b - p_a)` the ray's `1/z` is linear:
//!    `iz(s) = iz_a + s (iz_b - iz_a)` (the seed's screen-linear depth
//!    measure; perspective-correct interpolation).
//! 3. **Walk.** A grid walk (Amanatides-Woo DDA) visits, near endpoint
//!    first, every texel the segment touches, each with the sub-segment
//!    `[s_in, s_out]` inside it. Boundary crossings are computed directly
//!    from `p_a` (no accumulated increments), and the walk is bounded by the
//!    Manhattan distance between the end texels, so it always terminates.
//! 4. **Intersect.** Between consecutive steps the seed intersects the
//!    ray's depth segment with the image's in `1/z`. Here the image's segment
//!    at a texel is its thickness interval `[z_front, z_back]` (the shared
//!    contract of [`crate::trace`]): the texel is hit when the ray's depth
//!    interval `[1/iz(s_in), 1/iz(s_out)]` overlaps it, at the first point of
//!    the sub-segment inside it (the ray enters through `z_front` when moving
//!    away from the camera, through `z_back` when moving toward it). This is
//!    the seed's segment test with a thickness instead of an interpolated
//!    "rubber sheet" between neighboring texels, which would connect every
//!    silhouette to the background behind it.
//!
//! The hit's ray parameter is recovered from its screen parameter `s` by the
//! projective map `t = t_a + (t_b - t_a) s iz_b / iz(s)` (exact for the
//! clipped segment, well conditioned also for rays parallel to the image
//! plane), and from `1/z` for a ray ending at its vanishing point; so
//! `ray.at(t)` projects to the reported pixel up to rounding.
//!
//! **Passing behind geometry (thin-shell policy).** A ray that passes
//! behind a surface deeper than its thickness keeps marching: what lies
//! behind may be hit farther on (the surface is a shell of the given
//! thickness, not a solid). If the walk ends without a hit while the ray's
//! end point is behind the last texel's surface (deeper than `z_back`), the
//! miss reason is [`Miss::BehindGeometry`] (what the ray hits is hidden from
//! this image); otherwise it is [`Miss::EndOfRay`] when the ray ended at
//! `t_max` or the far plane (or its vanishing point) and [`Miss::LeftImage`]
//! when it left through a side of the image or through the near plane (a
//! ray coming toward the camera).
//!
//! **Planar case** (seed 003 Sec. 4.3: "intersections for planar reflectors
//! are immediate since the projection of the reflected ray is a single
//! point"). A ray whose line passes through the eye projects to one point:
//! the walk visits that one texel and compares the ray's depth range with
//! the texel's directly, one step and one fetch (two with a back-face
//! image). Projections shorter than a pixel are walked the same way and
//! touch at most the few texels they cross.
//!
//! **Empty texels.** A stored depth that decodes to NaN, to a depth
//! `<= 0`, or to the far plane or beyond (the cleared value of
//! [`DepthConvention::ZeroToOne`] and [`DepthConvention::ReversedZ`], `+inf`
//! under an infinite far plane) holds no surface. A back-face texel is used
//! as it decodes when it lies behind its front texel, the cleared value
//! included: a surface with nothing behind it in the back-face image (a
//! one-sided floor or wall) is solid to the far plane, as the Hi-Z kernel
//! reads it. A NaN back-face texel, or one at or in front of its front
//! texel, makes that texel a zero-thick shell.
//!
//! **Strides.** With [`StepOptions::stride`] `N > 1` the walk samples only
//! every `N`-th texel (and the last one); a coarse step fetches the front
//! depth only. When the ray reaches behind the front surface at a coarse
//! sample, the kernel walks that coarse interval again one texel at a time
//! with the full test, so on geometry the ray does not pass in and out of
//! within `N` pixels the result equals that of `N = 1`. If the refinement
//! finds no hit (the ray passed behind a surface), coarse stepping resumes.
//! The last interval, where the ray stops (at `t_max`, the far plane or the
//! image border), is always refined: a ray that enters a shell there and
//! stops at once need not be behind the stored depth at the coarse sample.
//!
//! **Threading.** [`try_step`] reads only its arguments; [`try_step_rays`]
//! traces a slice of rays. A host splits its rays (and outputs) into
//! chunks, e.g. rows of a reflection buffer, and calls either function on
//! its own threads; results do not depend on the split.
//!
//! Self-intersection: a ray whose origin lies on a surface of the image
//! hits that texel at `t = 0` when the origin is within the thickness.
//! Hosts tracing reflection rays from surfaces of the same image offset the
//! origin (e.g. along the normal) or start it one texel further.

use crate::trace::{try_validate_ray, RESOLVED_DEPTH};
use crate::{DepthConvention, DepthHit, DepthImage, Error, Miss, Ray, Thickness, Trace, Work};
use glam::{Vec2, Vec3};

/// Options of the stepping kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepOptions {
    /// Texels per coarse step, at least 1. `1` tests every texel the ray
    /// touches; larger strides sample every `stride`-th texel and refine the
    /// last coarse interval texel by texel once the ray reaches behind a
    /// surface (module docs).
    pub stride: u32,
    /// The most steps (coarse steps plus refinement steps) spent on one
    /// ray; reaching it gives [`Miss::OutOfSteps`]. `0` allows no step.
    pub max_steps: u32,
}

impl Default for StepOptions {
    /// `stride = 1` and no step cap (`max_steps = u32::MAX`): the walk is
    /// still bounded by the `width + height` texels a segment can touch.
    fn default() -> Self {
        Self {
            stride: 1,
            max_steps: u32::MAX,
        }
    }
}

/// Per-image constants of the projection, computed once per call.
#[derive(Clone, Copy, Debug)]
struct Projector {
    view: glam::Mat4,
    /// Pixels per unit of `x / z` and `y / z`.
    fx: f32,
    fy: f32,
    /// Principal point (image center) in pixels.
    cx: f32,
    cy: f32,
    w: f32,
    h: f32,
    near: f32,
    far: f32,
}

impl Projector {
    fn new(image: &DepthImage<'_>) -> Self {
        let cam = image.camera();
        // The same f64 tangents as `Camera::project`, so that pixel
        // positions agree with it to rounding.
        let (w, h) = (f64::from(cam.width()), f64::from(cam.height()));
        let tan_y = libm::tan(f64::from(cam.fov_y()) * 0.5);
        let tan_x = tan_y * w / h;
        Self {
            view: cam.view(),
            fx: (0.5 * w / tan_x) as f32,
            fy: (0.5 * h / tan_y) as f32,
            cx: (0.5 * w) as f32,
            cy: (0.5 * h) as f32,
            w: w as f32,
            h: h as f32,
            near: cam.near(),
            far: cam.far(),
        }
    }

    /// Homogeneous pixel coordinates `(px z, py z, z)` of a view-space point
    /// (linear in the point); `z` is the linear depth.
    #[inline]
    fn homogeneous(&self, v: Vec3, z: f32) -> Vec3 {
        Vec3::new(self.cx * z + self.fx * v.x, self.cy * z - self.fy * v.y, z)
    }
}

/// Why the clipped segment ends where it does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum End {
    /// `t_max`, the far plane, or the vanishing point of an infinite ray.
    Ray,
    /// A side of the image or the near plane.
    View,
}

/// The clipped, projected segment.
#[derive(Clone, Copy, Debug)]
struct Segment {
    p_a: Vec2,
    p_b: Vec2,
    iz_a: f32,
    iz_b: f32,
    t_a: f32,
    /// May be `+inf` (vanishing point).
    t_b: f32,
    /// `-(view dir).z`, the rate of linear depth along the ray.
    dz: f32,
    end: End,
}

impl Segment {
    #[inline]
    fn iz(&self, s: f32) -> f32 {
        self.iz_a + s * (self.iz_b - self.iz_a)
    }

    #[inline]
    fn pixel(&self, s: f32) -> Vec2 {
        self.p_a + s * (self.p_b - self.p_a)
    }

    /// Ray parameter of screen parameter `s` (module docs).
    #[inline]
    fn t(&self, s: f32) -> f32 {
        let iz = self.iz(s);
        if self.t_b.is_finite() {
            // u = s iz_b / iz(s) in [0, 1]: the fraction of [t_a, t_b].
            let u = if iz > 0.0 {
                (s * self.iz_b / iz).clamp(0.0, 1.0)
            } else {
                1.0
            };
            self.t_a + (self.t_b - self.t_a) * u
        } else {
            // Ends at the vanishing point: dz > 0, z(s) = 1 / iz(s).
            self.t_a + (1.0 / iz - 1.0 / self.iz_a) / self.dz
        }
    }
}

/// Clips the ray to the frustum and projects it (stages 1 and 2).
fn clip(pr: &Projector, ray: &Ray, t_max: f32) -> Option<Segment> {
    let o = pr.view.transform_point3(ray.origin);
    let d = pr.view.transform_vector3(ray.dir);
    let (z0, dz) = (-o.z, -d.z);
    let h0 = pr.homogeneous(o, z0);
    let hd = pr.homogeneous(d, dz);

    let mut lo = 0.0f32;
    let mut hi = f32::INFINITY;
    let mut end = End::Ray;
    // Each constraint is `alpha + beta t >= 0`.
    let mut cut = |alpha: f32, beta: f32, e: End| -> bool {
        if beta > 0.0 {
            lo = lo.max(-alpha / beta);
        } else if beta < 0.0 {
            let t = alpha / -beta;
            if t < hi {
                hi = t;
                end = e;
            }
        } else if alpha < 0.0 {
            return false;
        }
        true
    };
    let ok = (t_max.is_infinite() || cut(t_max, -1.0, End::Ray))
        && cut(z0 - pr.near, dz, End::View)
        && (pr.far.is_infinite() || cut(pr.far - z0, -dz, End::Ray))
        && cut(h0.x, hd.x, End::View)
        && cut(pr.w * z0 - h0.x, pr.w * dz - hd.x, End::View)
        && cut(h0.y, hd.y, End::View)
        && cut(pr.h * z0 - h0.y, pr.h * dz - hd.y, End::View);
    if !ok || !(lo <= hi) {
        return None;
    }
    let ha = h0 + hd * lo;
    // The far endpoint in homogeneous coordinates scaled by k = 1 / max(1, t)
    // (the same projective point; no overflow for huge t, the direction
    // itself for t = inf).
    let (k, hb) = if hi > 1.0 {
        (1.0 / hi, h0 * (1.0 / hi) + hd)
    } else {
        (1.0, h0 + hd * hi)
    };
    let seg = Segment {
        p_a: Vec2::new(ha.x / ha.z, ha.y / ha.z),
        p_b: Vec2::new(hb.x / hb.z, hb.y / hb.z),
        iz_a: 1.0 / ha.z,
        iz_b: k / hb.z,
        t_a: lo,
        t_b: hi,
        dz,
        end,
    };
    let finite = seg.p_a.is_finite()
        && seg.p_b.is_finite()
        && seg.iz_a.is_finite()
        && seg.iz_a > 0.0
        && seg.iz_b.is_finite()
        && seg.iz_b >= 0.0;
    finite.then_some(seg)
}

/// One texel of the walk with the part `[s_in, s_out]` of the segment
/// inside it.
#[derive(Clone, Copy, Debug)]
struct Span {
    x: u32,
    y: u32,
    s_in: f32,
    s_out: f32,
}

/// Amanatides-Woo grid walk over the texels a segment touches (stage 3).
#[derive(Clone, Copy, Debug)]
struct Walker {
    p_a: Vec2,
    dir: Vec2,
    x: u32,
    y: u32,
    end_x: u32,
    end_y: u32,
    s: f32,
    done: bool,
    /// The next boundary crossing along x and y ([`Walker::crossing`] of
    /// the current texel). Each depends only on the texel index along its
    /// own axis, so it is recomputed (from `p_a`, exactly as before) only
    /// when the walk steps along that axis: one division per step instead
    /// of two, same values.
    cx: Option<f32>,
    cy: Option<f32>,
}

/// The texel containing coordinate `c`, clamped to `[0, n - 1]`:
/// `floor(c)` clamped, without the out-of-line `libm::floorf` (no hardware
/// floor in `no_std` on baseline x86-64). Exact: `floor(c) <= 0` iff
/// `c < 1` (or NaN, which `floor(c) as u32` also maps to 0);
/// `floor(c) >= (n - 1) as f32` iff `c >= (n - 1) as f32` because that
/// bound is an integer-valued f32; otherwise `1 <= c < n - 1`, where the
/// truncating `c as u32` is `floor(c)`.
#[inline]
fn texel(c: f32, n: u32) -> u32 {
    if !(c >= 1.0) {
        0
    } else if c >= (n - 1) as f32 {
        n - 1
    } else {
        c as u32
    }
}

impl Walker {
    fn new(seg: &Segment, width: u32, height: u32) -> Self {
        let (p_a, dir) = (seg.p_a, seg.p_b - seg.p_a);
        let (x, y) = (texel(p_a.x, width), texel(p_a.y, height));
        let (end_x, end_y) = (texel(seg.p_b.x, width), texel(seg.p_b.y, height));
        Self {
            p_a,
            dir,
            x,
            y,
            end_x,
            end_y,
            s: 0.0,
            done: false,
            cx: Self::crossing(p_a.x, dir.x, x, end_x),
            cy: Self::crossing(p_a.y, dir.y, y, end_y),
        }
    }

    /// Screen parameter at which the segment crosses the next texel
    /// boundary along one axis, if the walk may still move along it.
    #[inline]
    fn crossing(p: f32, dir: f32, at: u32, end: u32) -> Option<f32> {
        if at == end || dir == 0.0 {
            return None;
        }
        let boundary = if end > at { (at + 1) as f32 } else { at as f32 };
        Some((boundary - p) / dir)
    }

    /// The next texel of the walk, or `None` after the last one.
    #[inline]
    fn next(&mut self) -> Option<Span> {
        if self.done {
            return None;
        }
        let (x, y, s_in) = (self.x, self.y, self.s);
        let (cx, cy) = (self.cx, self.cy);
        let step_x = match (cx, cy) {
            (None, None) => {
                self.done = true;
                return Some(Span {
                    x,
                    y,
                    s_in,
                    s_out: 1.0,
                });
            }
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (Some(a), Some(b)) => a <= b,
        };
        let s_cross = if step_x { cx } else { cy }.unwrap_or(1.0);
        // `s_cross.clamp(s_in, 1.0)` without its `s_in <= 1` assertion
        // (which holds: every `s` of the walk is at most 1).
        let s_out = if s_cross < s_in {
            s_in
        } else if s_cross > 1.0 {
            1.0
        } else {
            s_cross
        };
        if step_x {
            self.x = if self.end_x > self.x {
                self.x + 1
            } else {
                self.x - 1
            };
            self.cx = Self::crossing(self.p_a.x, self.dir.x, self.x, self.end_x);
        } else {
            self.y = if self.end_y > self.y {
                self.y + 1
            } else {
                self.y - 1
            };
            self.cy = Self::crossing(self.p_a.y, self.dir.y, self.y, self.end_y);
        }
        self.s = s_out;
        Some(Span { x, y, s_in, s_out })
    }
}

/// The stride-1 walk from `w` (every texel fully tested), specialized on
/// the direction class: `NX` / `NY` when the texel index decreases along
/// x / y (an axis the walk does not move along has `false`). It visits the
/// texels [`Walker::next`] visits, with the same parameters (the same
/// crossing expressions, the boundary side and the index step chosen at
/// compile time instead of per step, no `Option` per axis: an axis moves
/// while its index differs from its end index), and tests them as the
/// general loop does. `Ok(occluded)` after the last texel, `Err` with the
/// hit or the out-of-steps miss.
#[inline(never)]
fn stride1<const C: u8, const NX: bool, const NY: bool>(
    seg: &Segment,
    look: &mut Lookup<'_, '_, C>,
    w: &Walker,
    max_steps: u32,
) -> Result<bool, Trace> {
    // A local copy, so that the counters and the depth cache live in
    // registers (through `&mut` they are loads and stores every texel);
    // written back on the way out.
    let mut lk = *look;
    let r = stride1_local::<C, NX, NY>(seg, &mut lk, w, max_steps);
    *look = lk;
    r
}

/// [`stride1`] on its local copy of the lookup.
#[inline(always)]
fn stride1_local<const C: u8, const NX: bool, const NY: bool>(
    seg: &Segment,
    look: &mut Lookup<'_, '_, C>,
    w: &Walker,
    max_steps: u32,
) -> Result<bool, Trace> {
    let (p_a, dir) = (w.p_a, w.dir);
    let (mut x, mut y, mut s) = (w.x, w.y, w.s);
    let (end_x, end_y) = (w.end_x, w.end_y);
    // Unused while the index equals its end (where `crossing` is `None`).
    let mut cx = w.cx.unwrap_or(0.0);
    let mut cy = w.cy.unwrap_or(0.0);
    let mut occluded = false;
    if w.done {
        return Ok(occluded);
    }
    loop {
        let (mx, my) = (x != end_x, y != end_y);
        let last = !mx && !my;
        let span = if last {
            Span {
                x,
                y,
                s_in: s,
                s_out: 1.0,
            }
        } else {
            let step_x = mx && (!my || cx <= cy);
            let s_cross = if step_x { cx } else { cy };
            let s_out = if s_cross < s {
                s
            } else if s_cross > 1.0 {
                1.0
            } else {
                s_cross
            };
            let span = Span {
                x,
                y,
                s_in: s,
                s_out,
            };
            if step_x {
                x = if NX { x - 1 } else { x + 1 };
                let b = if NX { x as f32 } else { (x + 1) as f32 };
                cx = (b - p_a.x) / dir.x;
            } else {
                y = if NY { y - 1 } else { y + 1 };
                let b = if NY { y as f32 } else { (y + 1) as f32 };
                cy = (b - p_a.y) / dir.y;
            }
            s = s_out;
            span
        };
        if look.steps >= max_steps {
            return Err(Trace::Miss {
                reason: Miss::OutOfSteps,
                work: look.work(),
            });
        }
        look.steps += 1;
        match test_texel(seg, look, &span) {
            Test::Hit { s, front, z } => {
                return Err(make_hit(seg, &span, s, front, z, look.work()))
            }
            Test::Clear { occluded: o } => occluded = o,
        }
        if last {
            return Ok(occluded);
        }
    }
}

/// [`DepthConvention`]s as const generic parameters: the kernel is
/// instantiated per convention so that decoding a fetched depth
/// ([`Camera::decode_depth`](crate::Camera::decode_depth)) does not branch
/// on the convention per texel.
const LINEAR: u8 = 0;
/// See [`LINEAR`].
const ZERO_TO_ONE: u8 = 1;
/// See [`LINEAR`].
const REVERSED_Z: u8 = 2;

/// Depth lookups with the fetch counter, for images of the convention `C`
/// (see [`LINEAR`]).
#[derive(Clone, Copy)]
struct Lookup<'i, 'a, const C: u8> {
    image: &'i DepthImage<'a>,
    thickness: Thickness<'a>,
    far: f32,
    /// The depth image's texels and row stride, read directly (the walk's
    /// texels are inside the image: [`texel`] clamps).
    data: &'a [f32],
    stride: usize,
    dec: Decoder,
    /// [`Work::steps`].
    steps: u32,
    /// [`Work::fetches`], saturated to `u32` by [`Lookup::work`].
    fetches: u64,
    /// The last `(s, iz(s), 1 / iz(s))` computed: consecutive texels share
    /// their boundary parameter (`s_out` of one is `s_in` of the next), so
    /// the division is done once per boundary. Keyed by the bits of `s`;
    /// the values are a pure function of them, so reuse is exact.
    depth_cache: (u32, f32, f32),
}

impl<const C: u8> Lookup<'_, '_, C> {
    /// The work counters so far.
    fn work(&self) -> Work {
        Work {
            steps: self.steps,
            fetches: u32::try_from(self.fetches).unwrap_or(u32::MAX),
            iterations: 0,
        }
    }

    /// `true` if a decoded linear depth is a surface (module docs).
    #[inline]
    fn is_surface(&self, z: f32) -> bool {
        z > 0.0 && z < self.far
    }

    /// `(iz(s), 1 / iz(s))` of the segment at screen parameter `s`.
    #[inline]
    fn ray_depth(&mut self, seg: &Segment, s: f32) -> (f32, f32) {
        let (bits, iz, z) = self.depth_cache;
        if bits == s.to_bits() {
            return (iz, z);
        }
        let iz = seg.iz(s);
        let z = 1.0 / iz;
        self.depth_cache = (s.to_bits(), iz, z);
        (iz, z)
    }

    /// The front depth of texel `(x, y)`, `None` for an empty texel.
    #[inline]
    fn front(&mut self, x: u32, y: u32) -> Option<f32> {
        self.fetches += 1;
        debug_assert!(x < self.image.width() && y < self.image.height());
        let d = *self.data.get(y as usize * self.stride + x as usize)?;
        let z = self.dec.decode::<C>(d);
        self.is_surface(z).then_some(z)
    }

    /// The back depth of the texel whose front depth is `front`.
    #[inline]
    fn back(&mut self, x: u32, y: u32, front: f32) -> f32 {
        match self.thickness {
            Thickness::Constant(c) => front + c,
            Thickness::BackFaces(view) => {
                self.fetches += 1;
                match view.get(x, y) {
                    Some(d) => {
                        // The rule of the Hi-Z kernel (`hiz.rs`, `bounds`):
                        // a back depth behind the front one is used as it
                        // is, the cleared value (far plane, `+inf`)
                        // included; NaN, `<= 0` or in front: zero-thick.
                        let z = self.dec.decode::<C>(d);
                        if z > front {
                            z
                        } else {
                            front
                        }
                    }
                    None => front,
                }
            }
        }
    }
}

/// [`Camera::decode_depth`](crate::Camera::decode_depth) with the camera's
/// planes and their products read once per ray batch: the same
/// expressions in the same order (`n f` and `f - n` are the products it
/// computes per call), so the same bits.
#[derive(Clone, Copy, Debug)]
struct Decoder {
    n: f32,
    f: f32,
    nf: f32,
    fmn: f32,
}

impl Decoder {
    fn new(cam: &crate::Camera) -> Self {
        let (n, f) = (cam.near(), cam.far());
        Self {
            n,
            f,
            nf: n * f,
            fmn: f - n,
        }
    }

    /// The linear depth of stored depth `d` of convention
    /// the convention `C` (see [`LINEAR`]).
    #[inline(always)]
    fn decode<const C: u8>(&self, d: f32) -> f32 {
        let (n, f) = (self.n, self.f);
        match C {
            LINEAR => d,
            ZERO_TO_ONE if f.is_infinite() => n / (1.0 - d),
            ZERO_TO_ONE if d == 1.0 => f,
            ZERO_TO_ONE => self.nf / (f - d * self.fmn),
            _ if f.is_infinite() => n / d,
            _ if d == 0.0 => f,
            _ => self.nf / (n + d * self.fmn),
        }
    }
}

/// Outcome of the full test of one texel.
enum Test {
    /// Hit at screen parameter `s`, with the texel's front depth and the
    /// ray's depth at the hit (the boundary it entered through, or its
    /// depth at the texel's entry when it starts inside).
    Hit { s: f32, front: f32, z: f32 },
    /// No hit; `occluded` if the ray leaves the texel behind its surface.
    Clear { occluded: bool },
}

/// The full test of one texel (stage 4).
#[inline(always)]
fn test_texel<const C: u8>(seg: &Segment, look: &mut Lookup<'_, '_, C>, span: &Span) -> Test {
    let Some(front) = look.front(span.x, span.y) else {
        return Test::Clear { occluded: false };
    };
    let (iz_in, z_in) = look.ray_depth(seg, span.s_in);
    let (iz_out, z_out) = look.ray_depth(seg, span.s_out);
    if z_in.max(z_out) < front {
        // Entirely in front: no back-face fetch needed.
        return Test::Clear { occluded: false };
    }
    let back = look.back(span.x, span.y, front);
    if z_in.min(z_out) > back {
        return Test::Clear {
            occluded: z_out > back,
        };
    }
    // The ray's depth interval overlaps [front, back]: first point inside.
    let (s, z) = if z_in >= front && z_in <= back {
        (span.s_in, z_in)
    } else {
        // Enters through the front face (moving away) or through the back
        // face (moving toward the camera): solve iz(s) = 1 / boundary on the
        // sub-segment, in the screen-linear measure 1/z (seed 003 Sec. 3.4).
        let boundary = if z_in < front { front } else { back };
        let iz_hit = 1.0 / boundary;
        let denom = iz_in - iz_out;
        let f = if denom != 0.0 {
            ((iz_in - iz_hit) / denom).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (span.s_in + (span.s_out - span.s_in) * f, boundary)
    };
    Test::Hit { s, front, z }
}

/// The largest `f32` below `v` (for `v > 0`), so that a coordinate clamped
/// to `[i, next_below(i + 1)]` floors to `i`.
#[inline]
fn next_below(v: f32) -> f32 {
    f32::from_bits(v.to_bits() - 1)
}

fn make_hit(seg: &Segment, span: &Span, s: f32, front: f32, z: f32, work: Work) -> Trace {
    let p = seg.pixel(s);
    let (x0, y0) = (span.x as f32, span.y as f32);
    let pixel = Vec2::new(
        p.x.clamp(x0, next_below(x0 + 1.0)),
        p.y.clamp(y0, next_below(y0 + 1.0)),
    );
    let (mut t, mut depth) = (seg.t(s), 1.0 / seg.iz(s));
    // The screen parameter also fails to resolve depth on a finite segment
    // that nearly reaches its vanishing point: a ray from depth 1 ending
    // past 1e7 puts a surface at 6.7e6 at `s = 1 - 2^-23`, whose depth
    // reads 2^23 (fuzz finding F31 of the step target). The known depth
    // `z` tells: where `s` resolves depth, `1/iz(s)` equals it up to
    // rounding.
    let off = z.is_finite() && !((depth - z).abs() <= RESOLVED_DEPTH * z);
    let unresolved = off || seg.t_b.is_infinite() || !(t.is_finite() && depth.is_finite());
    if unresolved && seg.dz > 0.0 {
        let z = if z.is_finite() { z } else { front };
        // A ray ending at its vanishing point (iz_b = 0): near that end the
        // screen parameter cannot resolve depth (a surface 2^23 times
        // deeper than the start rounds the entry fraction to the end,
        // where 1/iz is infinite; at 1e8 times, depth came out 40% short:
        // fuzz findings of the step target, the second F16). The depth of
        // the hit is known, the boundary the ray crossed (or its depth at
        // the texel's entry), and t follows from the linear depth z(t) =
        // 1/iz_a + dz (t - t_a); where s resolves depth this is the value
        // `seg.t(s)` computes, up to rounding.
        depth = z;
        t = seg.t_a + (z - 1.0 / seg.iz_a) / seg.dz;
        // The hit lies on the segment: rounding of that expression (a
        // 1x1 image, an infinite far plane and a surface at 3.6e12 gave
        // t 3% past t_max, fuzz finding F11) must not leave it.
        t = t.clamp(seg.t_a, seg.t_b);
    }
    Trace::Hit(DepthHit {
        pixel,
        t,
        depth,
        surface_depth: front,
        work,
    })
}

/// Validates a thickness against the image.
fn validate_thickness(image: &DepthImage<'_>, thickness: &Thickness<'_>) -> Result<(), Error> {
    match thickness {
        Thickness::Constant(c) => {
            if !(*c >= 0.0) {
                return Err(Error::InvalidArgument);
            }
        }
        Thickness::BackFaces(v) => {
            if v.width() != image.width() || v.height() != image.height() {
                return Err(Error::InvalidArgument);
            }
        }
    }
    Ok(())
}

fn validate_options(opts: &StepOptions) -> Result<(), Error> {
    if opts.stride == 0 {
        return Err(Error::InvalidArgument);
    }
    Ok(())
}

/// Traces one ray against a depth image by per-pixel stepping along its
/// projection (seed 003 Sec. 3.4; planar rays as in Sec. 4.3). The module
/// docs describe clipping, the walk, the hit test, the thin-shell policy
/// and the miss reasons.
///
/// `ray` must have a unit direction; `t_max` bounds the ray parameter
/// (`+inf`: up to the far plane, or the vanishing point under an infinite
/// far plane). A hit's `pixel` lies in the texel hit (`pixel.floor()`),
/// `ray.at(t)` projects to `pixel` up to rounding, `depth` is the ray's
/// linear depth there and `surface_depth` the texel's front depth.
///
/// # Errors
/// [`Error::InvalidArgument`] for a ray or `t_max` rejected by
/// [`try_validate_ray`], a `stride` of 0, a
/// constant thickness that is NaN or negative, or a back-face image whose
/// size differs from the depth image's.
///
/// # Panics
/// Never.
pub fn try_step(
    image: &DepthImage<'_>,
    thickness: Thickness<'_>,
    ray: Ray,
    t_max: f32,
    opts: StepOptions,
) -> Result<Trace, Error> {
    try_validate_ray(&ray, t_max)?;
    validate_thickness(image, &thickness)?;
    validate_options(&opts)?;
    let pr = Projector::new(image);
    Ok(match image.convention() {
        DepthConvention::Linear => {
            step_unchecked::<LINEAR>(&pr, image, thickness, &ray, t_max, opts)
        }
        DepthConvention::ZeroToOne => {
            step_unchecked::<ZERO_TO_ONE>(&pr, image, thickness, &ray, t_max, opts)
        }
        DepthConvention::ReversedZ => {
            step_unchecked::<REVERSED_Z>(&pr, image, thickness, &ray, t_max, opts)
        }
    })
}

/// Traces `rays[i]` with maximum distance `t_max[i]` (or `t_max[0]` for
/// every ray when `t_max.len() == 1`) into `out[i]`, as [`try_step`] would
/// (the same arguments in the same order, the ray and `t_max` replaced by
/// slices and the result by `out`).
///
/// `out` holds [`Trace`]s or any type made from one (`From<Trace>`), and
/// `rays` [`Ray`]s or any type that converts into one: a host's (or the C
/// ABI's) own ray and result records are traced in place, without a copy.
///
/// Every input is validated before anything is written, so on `Err` `out`
/// is untouched. Elements of `out` past `rays.len()` are not written, nor
/// are elements of `t_max` past `rays.len()` read. For threads, split
/// `rays`, `out` (and `t_max`) into matching chunks and call this on each.
///
/// # Errors
/// * [`Error::InsufficientSize`]: `out.len() < rays.len()`, or `t_max` is
///   neither of length 1 nor at least `rays.len()` long.
/// * [`Error::InvalidArgument`]: `t_max` is empty, or any ray, `t_max`,
///   the thickness or the options are rejected as by [`try_step`].
///
/// # Panics
/// Never.
pub fn try_step_rays<O: From<Trace>, R: Copy + Into<Ray>>(
    out: &mut [O],
    image: &DepthImage<'_>,
    thickness: Thickness<'_>,
    rays: &[R],
    t_max: &[f32],
    opts: StepOptions,
) -> Result<(), Error> {
    if t_max.is_empty() {
        return Err(Error::InvalidArgument);
    }
    if out.len() < rays.len() || (t_max.len() != 1 && t_max.len() < rays.len()) {
        return Err(Error::InsufficientSize);
    }
    validate_thickness(image, &thickness)?;
    validate_options(&opts)?;
    let tm = |i: usize| if t_max.len() == 1 { t_max[0] } else { t_max[i] };
    for (i, ray) in rays.iter().enumerate() {
        try_validate_ray(&(*ray).into(), tm(i))?;
    }
    let pr = Projector::new(image);
    let args = (&pr, image, thickness, rays, t_max, opts);
    match image.convention() {
        DepthConvention::Linear => step_all::<LINEAR, O, R>(out, args),
        DepthConvention::ZeroToOne => step_all::<ZERO_TO_ONE, O, R>(out, args),
        DepthConvention::ReversedZ => step_all::<REVERSED_Z, O, R>(out, args),
    }
    Ok(())
}

/// [`try_step_rays`] after validation, for an image of convention
/// the convention `C` (see [`LINEAR`]).
fn step_all<const C: u8, O: From<Trace>, R: Copy + Into<Ray>>(
    out: &mut [O],
    (pr, image, thickness, rays, t_max, opts): (
        &Projector,
        &DepthImage<'_>,
        Thickness<'_>,
        &[R],
        &[f32],
        StepOptions,
    ),
) {
    let tm = |i: usize| if t_max.len() == 1 { t_max[0] } else { t_max[i] };
    for (i, (o, ray)) in out.iter_mut().zip(rays).enumerate() {
        *o = step_unchecked::<C>(pr, image, thickness, &(*ray).into(), tm(i), opts).into();
    }
}

/// The kernel on validated input, for an image of convention
/// the convention `C` (see [`LINEAR`]).
fn step_unchecked<const C: u8>(
    pr: &Projector,
    image: &DepthImage<'_>,
    thickness: Thickness<'_>,
    ray: &Ray,
    t_max: f32,
    opts: StepOptions,
) -> Trace {
    let mut look = Lookup::<C> {
        image,
        thickness,
        far: pr.far,
        data: image.depth().data(),
        stride: image.depth().stride() as usize,
        dec: Decoder::new(image.camera()),
        steps: 0,
        fetches: 0,
        depth_cache: (0, 0.0, 0.0),
    };
    let Some(seg) = clip(pr, ray, t_max) else {
        return Trace::Miss {
            reason: Miss::DegenerateProjection,
            work: look.work(),
        };
    };
    // The walk starts at s = 0.
    look.depth_cache = (0.0f32.to_bits(), seg.iz(0.0), 1.0 / seg.iz(0.0));
    let mut walker = Walker::new(&seg, image.width(), image.height());
    let stride = opts.stride;
    let mut occluded = false;
    let out_of_steps = |work: Work| Trace::Miss {
        reason: Miss::OutOfSteps,
        work,
    };
    // Stride 1: every interval is one texel, fully tested (the general
    // loop below does the same with its grouping bookkeeping).
    if stride == 1 {
        let walk = match (walker.end_x < walker.x, walker.end_y < walker.y) {
            (false, false) => stride1::<C, false, false>,
            (false, true) => stride1::<C, false, true>,
            (true, false) => stride1::<C, true, false>,
            (true, true) => stride1::<C, true, true>,
        };
        match walk(&seg, &mut look, &walker, opts.max_steps) {
            Ok(o) => occluded = o,
            Err(t) => return t,
        }
    } else {
        loop {
            // One coarse interval: up to `stride` texels, the last one sampled.
            let group_start = walker;
            let mut sample = None;
            let mut group_len = 0;
            while group_len < stride {
                match walker.next() {
                    Some(span) => sample = Some(span),
                    None => break,
                }
                group_len += 1;
            }
            let Some(span) = sample else { break };
            // The walk's last interval: where the ray stops (t_max, the far
            // plane, the image border), not where it went behind geometry.
            let last = walker.done;
            if look.steps >= opts.max_steps {
                return out_of_steps(look.work());
            }
            look.steps += 1;
            if group_len == 1 {
                // A one-texel interval (stride 1, or the planar case and other
                // one-texel walks at any stride): the full test at once.
                match test_texel(&seg, &mut look, &span) {
                    Test::Hit { s, front, z } => {
                        return make_hit(&seg, &span, s, front, z, look.work())
                    }
                    Test::Clear { occluded: o } => occluded = o,
                }
                continue;
            }
            // Coarse sample: does the ray reach behind the front surface here?
            let trigger = match look.front(span.x, span.y) {
                Some(front) => {
                    let (_, z_in) = look.ray_depth(&seg, span.s_in);
                    let (_, z_out) = look.ray_depth(&seg, span.s_out);
                    let z = z_in.max(z_out);
                    z >= front
                }
                None => false,
            };
            // A ray that enters a surface's shell inside the last interval
            // and stops there can be in front of the stored depth at the
            // coarse sample (the depth varies within a texel): refine the
            // last interval whatever the sample says (at most `stride`
            // steps once per ray; found by scripts/explore.sh).
            if !trigger && !last {
                occluded = false;
                continue;
            }
            // Refine the interval texel by texel.
            // The replay visits the same `group_len` texels (the walk is
            // deterministic), the coarse sample last.
            let mut fine = group_start;
            for _ in 0..group_len {
                let Some(f) = fine.next() else { break };
                if look.steps >= opts.max_steps {
                    return out_of_steps(look.work());
                }
                look.steps += 1;
                match test_texel(&seg, &mut look, &f) {
                    Test::Hit { s, front, z } => {
                        return make_hit(&seg, &f, s, front, z, look.work())
                    }
                    Test::Clear { occluded: o } => occluded = o,
                }
            }
        }
    }
    let reason = if occluded {
        Miss::BehindGeometry
    } else {
        match seg.end {
            End::Ray => Miss::EndOfRay,
            End::View => Miss::LeftImage,
        }
    };
    Trace::Miss {
        reason,
        work: look.work(),
    }
}
