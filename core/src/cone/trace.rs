//! Screen-space cone tracing (seed 004 Sec. 4.4.5 / 4.5.5, Listing 4.7,
//! Eq. 4.2; anisotropic stretching of Sec. 4.6.8): the isosceles-triangle
//! helpers and the sample circles, the sampling of the three pyramids
//! ([`ConePyramids`]), and [`try_cone_trace`].

use super::pyramid::{finite3, foreground};
use super::{try_color_pyramid_len, try_visibility_pyramid_len, ColorTexel};
use crate::hiz::{HiZ, HiZLayout, HiZTexel, PyramidStamp};
use crate::Error;
use glam::Vec2;

/// Largest screen-triangle half-angle the view-space cone size
/// ([`Cone::travel`]) produces (89 degrees).
pub const MAX_VIEW_THETA: f32 = 1.553_343;

/// Most circles [`try_cone_trace`] takes, whatever the options say.
pub const MAX_CIRCLES: u32 = 64;

/// Most samples one anisotropic (stretched) circle takes.
pub const MAX_STRETCH_SAMPLES: u32 = 8;

// ------------------------------------------------ isosceles triangle

/// The base (opposite side) of the isosceles triangle of half-angle `theta`
/// at the apex and height `adjacent`: `2 tan(theta) adjacent` (seed 004
/// Eq. 4.2).
#[inline]
pub fn isosceles_opposite(adjacent: f32, theta: f32) -> f32 {
    2.0 * libm::tanf(theta) * adjacent
}

/// The in-radius of the isosceles triangle with base `a` and height `h`, in
/// the cancellation-free form `a h / (sqrt(a^2 + 4 h^2) + a)` (design.md
/// erratum). The seed's `a (sqrt(a^2 + 4 h^2) - a) / (4 h)` subtracts two
/// nearly equal numbers when `a >> h`, i.e. for *wide* cones (design.md
/// says narrow; for `a << h` the seed's form is merely slower): at 89.9
/// degrees it loses about half of the f32 digits (tested). 0 when `a` or
/// `h` is 0; the sum under the root is formed scaled so that it does not
/// overflow.
#[inline]
pub fn isosceles_inradius(a: f32, h: f32) -> f32 {
    if !(a > 0.0 && h > 0.0) {
        return 0.0;
    }
    // a h / (sqrt(a^2 + 4h^2) + a) = h x / (sqrt(x^2 + y^2) + x) with
    // x = a / m, y = 2 h / m, m = max(a, h): no overflow, ratio in (0, 1/2].
    let m = a.max(h);
    let (x, y) = (a / m, 2.0 * (h / m));
    (x / (libm::sqrtf(x * x + y * y) + x)) * h
}

/// One sample circle of a cone (all lengths in level-0 pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeCircle {
    /// Distance of the circle's center from the apex along the axis.
    pub center: f32,
    /// The in-radius.
    pub radius: f32,
}

/// The sample circles of a screen-space cone (seed 004 Sec. 4.4.5, Listing
/// 4.7): starting with `adj = length`, each circle is the in-radius `r` of
/// the triangle of height `adj`, centered at `adj - r`; the next triangle
/// has height `adj - 2 r`. Yields at most `max` circles and stops when the
/// height reaches 0.
#[derive(Clone, Copy, Debug)]
pub struct ConeCircles {
    adjacent: f32,
    two_tan: f32,
    left: u32,
}

impl ConeCircles {
    /// The circles of a cone of half-angle `theta` whose axis is `length`
    /// pixels long, at most `max` of them.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a NaN/Inf or negative length, or
    /// `theta` outside `[0, pi/2)`.
    pub fn try_new(length: f32, theta: f32, max: u32) -> Result<Self, Error> {
        if !(length >= 0.0 && length.is_finite() && valid_theta(theta)) {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            adjacent: length,
            two_tan: 2.0 * libm::tanf(theta),
            left: max,
        })
    }
}

impl Iterator for ConeCircles {
    type Item = ConeCircle;

    fn next(&mut self) -> Option<ConeCircle> {
        if self.left == 0 || !(self.adjacent > 0.0) {
            return None;
        }
        self.left -= 1;
        let h = self.adjacent;
        let r = isosceles_inradius(self.two_tan * h, h);
        self.adjacent = h - 2.0 * r;
        Some(ConeCircle {
            center: h - r,
            radius: r,
        })
    }
}

pub(super) fn valid_theta(theta: f32) -> bool {
    (0.0..core::f32::consts::FRAC_PI_2).contains(&theta) && libm::tanf(theta).is_finite()
}

/// The mip level a circle of radius `radius` pixels samples:
/// `max(0, log2(2 radius) + bias)` (module docs; Listing 4.7 is `bias =
/// -1`). 0 for a zero or NaN radius.
#[inline]
pub fn cone_mip_level(radius: f32, bias: f32) -> f32 {
    if !(radius > 0.0) {
        return 0.0;
    }
    let l = libm::log2f(2.0 * radius) + bias;
    if l > 0.0 {
        l
    } else {
        0.0
    }
}

// ------------------------------------------------------------ cone trace

/// The three pyramids a cone trace reads, bound together.
#[derive(Clone, Copy, Debug)]
pub struct ConePyramids<'a> {
    hiz: HiZ<'a>,
    pub(super) color: &'a [ColorTexel],
    visibility: &'a [f32],
    focal: f32,
}

impl<'a> ConePyramids<'a> {
    /// Binds a Hi-Z, a color pyramid ([`try_build_color_pyramid`](super::try_build_color_pyramid)) and a
    /// visibility pyramid ([`try_build_visibility_pyramid`](super::try_build_visibility_pyramid)) of one frame.
    /// An empty `visibility` binds none: enough for [`try_multiray`](super::try_multiray) and
    /// for [`try_cone_trace`] with [`ConeOptions::use_visibility`] off
    /// (with it on, the trace is refused).
    ///
    /// # Errors
    /// * [`Error::InsufficientSize`] if `color` is shorter than
    ///   [`try_color_pyramid_len`] or a non-empty `visibility` than
    ///   [`try_visibility_pyramid_len`] for the Hi-Z's size.
    /// * [`Error::InvalidArgument`] if a pyramid's [`PyramidStamp`] is not
    ///   this frame's: the color pyramid built for another size, the
    ///   visibility pyramid from another Hi-Z camera, or either not built.
    pub fn try_new(
        hiz: HiZ<'a>,
        color: &'a [ColorTexel],
        visibility: &'a [f32],
    ) -> Result<Self, Error> {
        let cam = hiz.camera();
        let (w, h) = (cam.width(), cam.height());
        let with_vis = !visibility.is_empty();
        if color.len() < try_color_pyramid_len(w, h)?
            || (with_vis && visibility.len() < try_visibility_pyramid_len(w, h)?)
        {
            return Err(Error::InsufficientSize);
        }
        if PyramidStamp::read(color, w, h) != Some(PyramidStamp::of_size(w, h))
            || (with_vis && PyramidStamp::read(visibility, w, h) != Some(PyramidStamp::of(cam)))
        {
            return Err(Error::InvalidArgument);
        }
        let focal = cam.height() as f32 / (2.0 * libm::tanf(cam.fov_y() * 0.5));
        Ok(Self {
            hiz,
            color,
            visibility,
            focal,
        })
    }

    /// The Hi-Z.
    pub const fn hiz(&self) -> &HiZ<'a> {
        &self.hiz
    }

    /// Focal length in pixels, `height / (2 tan(fov_y / 2))`.
    pub const fn focal(&self) -> f32 {
        self.focal
    }

    /// Bilinear sample of level `level` of a pyramid at level-0 pixel
    /// position `p` (texel centers at `(i + 0.5) w_L / W`, edges clamped).
    fn bilinear<T: Copy, const N: usize>(
        data: &[T],
        layout: &HiZLayout,
        level: u32,
        p: Vec2,
        get: impl Fn(T) -> [f32; N],
        fetches: &mut u32,
    ) -> [f32; N] {
        let l = match layout.level(level) {
            Some(l) => l,
            None => return [0.0; N],
        };
        let sx = l.width as f32 / layout.width() as f32;
        let sy = l.height as f32 / layout.height() as f32;
        let u = p.x * sx - 0.5;
        let v = p.y * sy - 0.5;
        let (x0, y0) = (libm::floorf(u), libm::floorf(v));
        let (fx, fy) = (u - x0, v - y0);
        let (wm, hm) = (i64::from(l.width) - 1, i64::from(l.height) - 1);
        // Clamped first: a position far outside the image (or +-inf)
        // saturates the cast at i64::MAX, where `xi + 1` overflowed (fuzz
        // finding F13); every index is clamped into the level anyway.
        let (xi, yi) = ((x0 as i64).clamp(-1, wm), (y0 as i64).clamp(-1, hm));
        let fetch = |x: i64, y: i64| -> [f32; N] {
            let x = x.clamp(0, wm) as usize;
            let y = y.clamp(0, hm) as usize;
            data.get(l.offset + y * l.width as usize + x)
                .map(|&t| get(t))
                .unwrap_or([0.0; N])
        };
        *fetches += 4;
        let (a, b, c, d) = (
            fetch(xi, yi),
            fetch(xi + 1, yi),
            fetch(xi, yi + 1),
            fetch(xi + 1, yi + 1),
        );
        let mut out = [0.0; N];
        for k in 0..N {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bot = c[k] + (d[k] - c[k]) * fx;
            out[k] = top + (bot - top) * fy;
        }
        out
    }

    /// Trilinear sample of a pyramid: bilinear in levels `floor(level)` and
    /// the next, linear across.
    fn trilinear<T: Copy, const N: usize>(
        &self,
        data: &[T],
        level: f32,
        p: Vec2,
        get: impl Fn(T) -> [f32; N] + Copy,
        fetches: &mut u32,
    ) -> [f32; N] {
        let layout = self.hiz.layout();
        let last = layout.level_count() - 1;
        let l0 = (libm::floorf(level) as u32).min(last);
        let t = if l0 >= last { 0.0 } else { level - l0 as f32 };
        let a = Self::bilinear(data, layout, l0, p, get, fetches);
        if t <= 0.0 {
            return a;
        }
        let b = Self::bilinear(data, layout, l0 + 1, p, get, fetches);
        let mut out = a;
        for k in 0..N {
            out[k] = a[k] + (b[k] - a[k]) * t;
        }
        out
    }

    /// The sphere weight (module docs) at level `level` (integer) for a
    /// sphere of depth center `z` and depth radius `rz` at pixel `p`.
    #[allow(clippy::too_many_arguments)]
    fn sphere_weight_at(
        &self,
        level: u32,
        p: Vec2,
        z: f32,
        rz: f32,
        tolerance: f32,
        fetches: &mut u32,
    ) -> f32 {
        let layout = self.hiz.layout();
        let l = match layout.level(level) {
            Some(l) => l,
            None => return 0.0,
        };
        // Cell under p, as the Hi-Z footprints define it (the last cell
        // reaches the edge).
        let cx = ((p.x.max(0.0) as u64) >> level).min(u64::from(l.width) - 1) as u32;
        let cy = ((p.y.max(0.0) as u64) >> level).min(u64::from(l.height) - 1) as u32;
        *fetches += 1;
        let t: HiZTexel = self.hiz.texel(level, cx, cy).unwrap_or([f32::NAN; 2]);
        let closest = t[0];
        if !foreground(closest, self.hiz.camera().far()) {
            return 0.0;
        }
        let reach = rz + tolerance * z;
        if reach > 0.0 {
            ((z + reach - closest) / reach).clamp(0.0, 1.0)
        } else if z >= closest {
            1.0
        } else {
            0.0
        }
    }

    fn sphere_weight(
        &self,
        level: f32,
        p: Vec2,
        z: f32,
        rz: f32,
        tolerance: f32,
        fetches: &mut u32,
    ) -> f32 {
        let last = self.hiz.layout().level_count() - 1;
        let l0 = (libm::floorf(level) as u32).min(last);
        let t = if l0 >= last { 0.0 } else { level - l0 as f32 };
        let a = self.sphere_weight_at(l0, p, z, rz, tolerance, fetches);
        if t <= 0.0 {
            return a;
        }
        let b = self.sphere_weight_at(l0 + 1, p, z, rz, tolerance, fetches);
        a + (b - a) * t
    }

    /// Trilinear color at level-0 pixel `p`, mip `level`.
    pub fn sample_color(&self, p: Vec2, level: f32) -> ColorTexel {
        let mut f = 0;
        self.trilinear(self.color, level, p, |c| c, &mut f)
    }

    /// Trilinear visibility at level-0 pixel `p`, mip `level`.
    pub fn sample_visibility(&self, p: Vec2, level: f32) -> f32 {
        let mut f = 0;
        self.trilinear(self.visibility, level, p, |v| [v], &mut f)[0]
    }
}

/// Settings of [`try_cone_trace`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeOptions {
    /// Most circles (clamped to [`MAX_CIRCLES`]); Listing 4.7 takes 7.
    pub max_circles: u32,
    /// Added to the circle's mip level `log2(2 r)`; `-1` is Listing 4.7's
    /// `log2(r)`.
    pub level_bias: f32,
    /// Weight samples by the pre-integrated visibility (Sec. 4.4.2);
    /// without it only the sphere weight counts.
    pub use_visibility: bool,
    /// Largest anisotropic stretch (Sec. 4.6.8): a circle becomes an
    /// ellipse elongated along the cone axis by `min(1 / n_dot_v,
    /// max_stretch)`, sampled by up to [`MAX_STRETCH_SAMPLES`] points along
    /// the axis at the mip level of the minor radius. `1` is isotropic.
    pub max_stretch: f32,
    /// Relative depth tolerance of the sphere weight: the sphere reaches
    /// `rz + depth_tolerance * z` in depth (the hit lies on the surface,
    /// and f32 rounding or a neighboring texel must not put a narrow
    /// cone's sphere just in front of it).
    pub depth_tolerance: f32,
    /// Divide the accumulated color by the accumulated coverage when it is
    /// positive (a weighted mean of the samples), so the fallback only
    /// takes cones no sample covered. Off (the seed's rule): the uncovered
    /// rest `1 - A` blends the fallback.
    pub normalize: bool,
}

impl Default for ConeOptions {
    /// 8 circles, bias 0, visibility on, isotropic, 1% depth tolerance, no
    /// normalization.
    fn default() -> Self {
        Self {
            max_circles: 8,
            level_bias: 0.0,
            use_visibility: true,
            max_stretch: 1.0,
            depth_tolerance: 0.01,
            normalize: false,
        }
    }
}

/// A screen-space cone: apex at the reflection ray's start, axis to its
/// Hi-Z hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// Apex (the ray's start projected), level-0 pixels.
    pub apex: Vec2,
    /// Linear depth of the apex.
    pub apex_depth: f32,
    /// The hit pixel (e.g. [`crate::DepthHit::pixel`]).
    pub hit: Vec2,
    /// Linear depth of the hit (e.g. [`crate::DepthHit::depth`]).
    pub hit_depth: f32,
    /// Half-angle, radians, in `[0, pi/2)`.
    pub theta: f32,
    /// `dot(n, v)` of the reflector (normal and direction toward the eye),
    /// for the anisotropic stretch; use 1 when it is off.
    pub n_dot_v: f32,
    /// World distance from the apex to the hit (e.g. [`crate::DepthHit::t`])
    /// for the view-space cone size, or 0 for the seed's screen-space
    /// triangle (module docs, "Cone size").
    pub travel: f32,
}

/// What [`try_cone_trace`] returns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeResult {
    /// The integrated color, the uncovered rest blended with the fallback.
    pub color: ColorTexel,
    /// Accumulated coverage `A` in `[0, 1]` (1 - weight of the fallback).
    pub coverage: f32,
    /// Circles taken.
    pub circles: u32,
    /// Pyramid texels read.
    pub fetches: u32,
}

/// Integrates the cone `cone` over the pyramids (seed 004 Sec. 4.4.5,
/// Listing 4.7; module docs, "Cone trace").
///
/// # Errors
/// [`Error::InvalidArgument`] for non-finite or non-positive depths,
/// non-finite pixels, `theta` outside `[0, pi/2)`, a non-finite fallback,
/// `n_dot_v` NaN, options with a non-finite bias or a `max_stretch`
/// below 1 or not finite, or `use_visibility` on with pyramids bound
/// without a visibility pyramid.
///
/// # Panics
/// Never.
pub fn try_cone_trace(
    pyramids: &ConePyramids<'_>,
    cone: &Cone,
    fallback: ColorTexel,
    options: &ConeOptions,
) -> Result<ConeResult, Error> {
    let depths_ok = cone.apex_depth > 0.0
        && cone.apex_depth.is_finite()
        && cone.hit_depth > 0.0
        && cone.hit_depth.is_finite();
    let ok = cone.apex.is_finite()
        && cone.hit.is_finite()
        && depths_ok
        && valid_theta(cone.theta)
        && !cone.n_dot_v.is_nan()
        && cone.travel >= 0.0
        && cone.travel.is_finite()
        && finite3(fallback)
        && options.level_bias.is_finite()
        && options.max_stretch >= 1.0
        && options.max_stretch.is_finite()
        && options.depth_tolerance >= 0.0
        && options.depth_tolerance.is_finite();
    if !ok || (options.use_visibility && pyramids.visibility.is_empty()) {
        return Err(Error::InvalidArgument);
    }
    let axis = cone.hit - cone.apex;
    let length = axis.length();
    if !length.is_finite() {
        return Err(Error::InvalidArgument);
    }
    let unit = if length > 0.0 { axis / length } else { Vec2::X };
    // View-space cone size (module docs): the triangle's angle that makes
    // the cone's width at the hit, `2 travel tan(theta)` projected at the
    // hit's depth, the base of the screen triangle.
    let theta = if cone.travel > 0.0 && length > 0.0 && cone.theta > 0.0 {
        let r_px = pyramids.focal * cone.travel * libm::tanf(cone.theta) / cone.hit_depth;
        libm::atanf(r_px / length).min(MAX_VIEW_THETA)
    } else {
        cone.theta
    };
    let max = options.max_circles.min(MAX_CIRCLES);
    let stretch = if cone.n_dot_v > 0.0 {
        (1.0 / cone.n_dot_v).clamp(1.0, options.max_stretch)
    } else {
        options.max_stretch
    };
    let (q1, q2) = (1.0 / cone.apex_depth, 1.0 / cone.hit_depth);
    // Color differences and their weighted sum in f64: a color near
    // f32::MAX against a fallback of the other sign overflows f32 (fuzz
    // finding F19), though the result, a convex combination of the
    // fallback and the pyramid's colors, is finite.
    let mut acc = [0.0f64; 3];
    let mut coverage = 0.0f32;
    let mut fetches = 0u32;
    let mut circles = 0u32;
    // A zero-length axis (the hit at the apex) is one sample at the hit.
    let single = ConeCircle {
        center: 0.0,
        radius: 0.0,
    };
    let mut iter = ConeCircles::try_new(length, theta, max)?;
    let mut first = true;
    loop {
        let circle = match iter.next() {
            Some(c) => c,
            None if first && max > 0 => single,
            None => break,
        };
        first = false;
        circles += 1;
        let level = cone_mip_level(circle.radius, options.level_bias);
        let s = if length > 0.0 {
            (circle.center / length).clamp(0.0, 1.0)
        } else {
            1.0
        };
        // The axis depth over the circle's extent along the axis: the
        // sphere is placed at the deeper of its two edges (the first
        // circle's front edge is the hit itself).
        let axis_depth = |s: f32| 1.0 / (q1 + (q2 - q1) * s.clamp(0.0, 1.0));
        let ds = if length > 0.0 {
            circle.radius / length
        } else {
            0.0
        };
        let z = axis_depth(s - ds).max(axis_depth(s + ds));
        let rz = circle.radius * z / pyramids.focal;
        let n = if stretch > 1.0 {
            (libm::ceilf(stretch) as u32).clamp(1, MAX_STRETCH_SAMPLES)
        } else {
            1
        };
        let (mut c, mut a) = ([0.0f64; 3], 0.0f32);
        for j in 0..n {
            let off = if n > 1 {
                (j as f32 / (n - 1) as f32 * 2.0 - 1.0) * circle.radius * (stretch - 1.0)
            } else {
                0.0
            };
            let p = cone.apex + unit * (circle.center + off);
            let col = pyramids.trilinear(pyramids.color, level, p, |t| t, &mut fetches);
            let vis = if options.use_visibility {
                pyramids.trilinear(pyramids.visibility, level, p, |v| [v], &mut fetches)[0]
            } else {
                1.0
            };
            let w = pyramids.sphere_weight(level, p, z, rz, options.depth_tolerance, &mut fetches);
            let aj = (vis * w).clamp(0.0, 1.0);
            for k in 0..3 {
                c[k] += f64::from(aj) * (f64::from(col[k]) - f64::from(fallback[k]));
            }
            a += aj;
        }
        let inv = 1.0 / n as f32;
        let a = a * inv;
        if a > 0.0 {
            let take = a.min(1.0 - coverage);
            // c / n is the weighted color difference of this circle; its
            // share is scaled down to the weight actually taken.
            let scale = f64::from(take / a * inv);
            for k in 0..3 {
                acc[k] += c[k] * scale;
            }
            coverage += take;
        }
        if coverage >= 1.0 {
            coverage = 1.0;
            break;
        }
    }
    if options.normalize && coverage > 0.0 {
        for a in &mut acc {
            *a /= f64::from(coverage);
        }
    }
    Ok(ConeResult {
        color: [
            (f64::from(fallback[0]) + acc[0]) as f32,
            (f64::from(fallback[1]) + acc[1]) as f32,
            (f64::from(fallback[2]) + acc[2]) as f32,
        ],
        coverage,
        circles,
        fetches,
    })
}
