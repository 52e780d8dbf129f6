//! Reflection pixel matching by neighborhood search (seed 000 Sec. 3.2.1,
//! Alg. 2).
//!
//! # Example
//! ```rust
//! use refl_core::tcrr::{offset_is_valid, try_search, INVALID_OFFSET};
//! use refl_core::glam::{Vec2, Vec3};
//! use refl_core::{Camera, DepthConvention, ImageView, ImageViewMut, ReflectionBuffers, TcrrOptions};
//!
//! // The key frame: 8 x 8 pixels looking straight down from (0, 2, 0) at the mirror
//! // floor y = 0, 1/4 unit per pixel (x right, z down the image). The reflected rays
//! // end on a ceiling at y = 4: at twice the distance from the eye to the floor point.
//! let look = |x: f32| {
//!     let eye = Vec3::new(x, 2.0, 0.0);
//!     Camera::try_look_at(eye, eye - Vec3::Y, Vec3::NEG_Z, 2.0 * 0.5f32.atan(), 0.1, 100.0, 8, 8)
//! };
//! let key = look(0.0)?;
//! let center = |i: usize| Vec2::new((i % 8) as f32 + 0.5, (i / 8) as f32 + 0.5);
//! let floor = |i: usize| key.unproject(center(i), 2.0, DepthConvention::Linear);
//! let distance: Vec<f32> = (0..64).map(|i| 2.0 * (floor(i) - key.eye()).length()).collect();
//! let color: Vec<[f32; 3]> = (0..64).map(|i| [(i % 8) as f32 / 8.0, (i / 8) as f32 / 8.0, 0.5]).collect();
//! let (depth, normal, specular) = ([2.0f32; 64], [[0.0f32, 1.0, 0.0]; 64], [1.0f32; 64]);
//! fn view<T: Copy>(data: &[T]) -> Result<ImageView<'_, T>, refl_core::Error> {
//!     ImageView::try_new(data, 8, 8, 8)
//! }
//! let (depth, normal, specular) = (view(&depth)?, view(&normal)?, view(&specular)?);
//! let buffers = ReflectionBuffers::try_new(
//!     key, DepthConvention::Linear, depth, normal, specular, view(&color)?, view(&distance)?,
//! )?;
//!
//! // The eye moves to (0.375, 2, 0). A floor point P reflects the ceiling point
//! // R = (3 P_x, 4, 3 P_z); from the new eye, R is seen in the floor where the line to
//! // R's mirror image (3 P_x, -4, 3 P_z) crosses it, a third of the way: at
//! // P + 2/3 (0.375, 0, 0), one pixel right of P.
//! let mut offsets = [INVALID_OFFSET; 64]; // after a key frame
//! let (mut out, eye) = (ImageViewMut::try_new(&mut offsets, 8, 8, 8)?, Vec3::new(0.375, 2.0, 0.0));
//! let stats = try_search(&mut out, &buffers, eye, &TcrrOptions::default())?;
//! assert_eq!((stats.matched, stats.invalid), (56, 8));
//! for y in 0..8 {
//!     for x in 0..7 {
//!         let o = offsets[y * 8 + x];
//!         assert!((o[0] - 1.0).abs() < 1e-3 && o[1].abs() < 1e-3);
//!     }
//!     // The last column's match lies beyond the key frame.
//!     assert!(!offset_is_valid(offsets[y * 8 + 7]));
//! }
//! # Ok::<(), refl_core::Error>(())
//! ```

use super::{distance_squared, Reflected, Surf, Target, SNAP_PX};
use super::{offset_is_valid, ReflectionBuffers, TcrrOptions, INVALID_OFFSET};
use crate::{Error, ImageViewMut};
use glam::Vec3;

/// Counts of one search pass over the band it ran on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SearchStats {
    /// Reflective samples visited.
    pub reflective: u32,
    /// Samples that found a match (a valid offset).
    pub matched: u32,
    /// Samples that recorded [`INVALID_OFFSET`]: the search left the
    /// reflector's silhouette, hit the iteration cap, or no candidate had a
    /// defined distance.
    pub invalid: u32,
    /// 3x3 neighborhoods evaluated, summed over the samples.
    pub iterations: u64,
}

impl SearchStats {
    /// Sums two bands' counts.
    pub fn merged(self, other: SearchStats) -> SearchStats {
        SearchStats {
            reflective: self.reflective + other.reflective,
            matched: self.matched + other.matched,
            invalid: self.invalid + other.invalid,
            iterations: self.iterations + other.iterations,
        }
    }
}

/// The 3x3 hollow neighborhood, in a fixed order (ties go to the first).
const RING: [(i32, i32); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// Updates the offset buffer of a key frame for the current eye `eye`
/// (seed 000 Alg. 2), over the rows `offsets` owns.
///
/// On entry `offsets` holds the previous frame's offsets `O_p` (fill it
/// with [`INVALID_OFFSET`] after a key frame: the search then starts at the
/// pixel itself); on return it holds `O_c`. Each pixel reads and writes only
/// its own texel, so one buffer serves as both.
///
/// Per reflective sample `s` at `(u, v)`: `R` from B.1, B.4 and the key eye
/// (Alg. 2 lines 2-4, with the surface position back-projected from the
/// depth `s.d`); the start `s_c = s + round(o)` if the previous offset is
/// valid and lands on a reflective sample, else `s`; then, while a
/// neighbor of the 3x3 hollow neighborhood has a strictly smaller
/// [`reflection_distance`](super::reflection_distance) than `s_c`, the search moves to the best one,
/// unless that neighbor lies outside the reflector's silhouette (not a
/// reflective sample, or across a depth discontinuity from `s_c`, see
/// [`TcrrOptions::discontinuity`]), which records INVALID. A search that
/// evaluates [`TcrrOptions::max_iterations`] neighborhoods without
/// converging, or whose start has no defined distance and no improving
/// neighbor, records INVALID. Otherwise it records `s_c - s`, refined
/// between pixel centers when [`TcrrOptions::subpixel`] is on (see the
/// module docs of [`crate::tcrr`]). Pixels that are not reflective
/// samples get INVALID.
///
/// Neighbors outside the image are not candidates; a minimum on the image
/// border is kept only if the zero of the distance on its tangent plane
/// projects inside the image (else the match lies beyond the key frame:
/// INVALID).
///
/// # Errors
/// [`Error::InvalidArgument`] (nothing written) if the offset buffer's size
/// differs from the buffers', `eye` is not finite or `options` is out of
/// range.
pub fn try_search(
    offsets: &mut ImageViewMut<'_, [f32; 2]>,
    buffers: &ReflectionBuffers<'_>,
    eye: Vec3,
    options: &TcrrOptions,
) -> Result<SearchStats, Error> {
    options.try_validate()?;
    if offsets.width() != buffers.width()
        || offsets.height() != buffers.height()
        || !eye.is_finite()
    {
        return Err(Error::InvalidArgument);
    }
    let mut stats = SearchStats::default();
    let Some(rows) = offsets.owned_rows() else {
        return Ok(stats);
    };
    for y in rows.rows() {
        for x in 0..buffers.width() {
            let Some(prev) = offsets.get(x, y) else {
                continue;
            };
            let result = match buffers.sample(x, y) {
                Some(s) => {
                    stats.reflective += 1;
                    let (o, iters) = match_pixel(buffers, x, y, s, prev, eye, options);
                    stats.iterations += u64::from(iters);
                    if offset_is_valid(o) {
                        stats.matched += 1;
                    } else {
                        stats.invalid += 1;
                    }
                    o
                }
                None => INVALID_OFFSET,
            };
            if let Some(t) = offsets.get_mut(x, y) {
                *t = result;
            }
        }
    }
    Ok(stats)
}

/// A candidate texel of the search: its surface, whether it is a
/// reflective sample's texel, and its squared distance for the pixel's
/// target (`None` where [`reflection_distance`](super::reflection_distance) is undefined).
#[derive(Clone, Copy, Debug)]
struct Cand {
    surf: Surf,
    reflective: bool,
    d2: Option<f32>,
}

/// A slot of the 3x3 window around the search's current pixel.
#[derive(Clone, Copy, Debug)]
enum Slot {
    /// Not evaluated yet.
    Unknown,
    /// Outside the image or no surface.
    Empty,
    /// An evaluated candidate.
    Cand(Cand),
}

/// Window index of offset `(dx, dy)` in `-1..=1`.
#[inline]
fn slot_index(dx: i32, dy: i32) -> usize {
    ((dy + 1) * 3 + dx + 1) as usize
}

/// The candidate at `(x, y)` for target `t` seen from `eye`.
#[inline(always)]
fn candidate(b: &ReflectionBuffers<'_>, x: i64, y: i64, t: Target, eye: Vec3) -> Slot {
    let Some((surf, reflective)) = texel(b, x, y) else {
        return Slot::Empty;
    };
    Slot::Cand(Cand {
        surf,
        reflective,
        d2: distance_squared(eye, surf.pos, surf.normal, t),
    })
}

/// The surface at `(x, y)` and whether it is a reflective sample's texel.
#[inline(always)]
fn texel(b: &ReflectionBuffers<'_>, x: i64, y: i64) -> Option<(Surf, bool)> {
    let (x, y) = (u32::try_from(x).ok()?, u32::try_from(y).ok()?);
    b.surface_reflective(x, y)
}

/// Snaps a sub-pixel correction: clamped to one pixel, 0 within
/// [`SNAP_PX`].
#[inline]
fn snap(v: f32) -> f32 {
    let v = v.clamp(-1.0, 1.0);
    if v.abs() < SNAP_PX {
        0.0
    } else {
        v
    }
}

/// Steps of [`newton_path`] before it hands over to the descent.
const MAX_NEWTON_STEPS: u32 = 8;

/// The sub-pixel fast path of the search (with [`TcrrOptions::subpixel`]):
/// from the start texel `c`, step one texel at a time toward the zero of
/// the distance on the current texel's tangent plane ([`refine`], a Newton
/// step), each step to a reflective texel on the same surface (the
/// silhouette rule of Alg. 2), until the zero lies within half a texel of
/// the current one; there the distance must be defined and the 3x3
/// neighborhood must lie inside the silhouette, and the match is that
/// texel plus its correction. On a planar reflector the corrected match is
/// the one the descent reaches (the zero is the same point from every
/// texel of the plane), on a curved one the same up to the curvature
/// within a texel; it costs one back-projection per step instead of a
/// 3x3 neighborhood of distances. `None` (the caller runs the descent)
/// where a step would leave the silhouette or the image border is
/// reached, the zero does not project, the steps oscillate between two
/// texels, or [`MAX_NEWTON_STEPS`] or the iteration cap would be hit.
#[allow(clippy::too_many_arguments)]
fn newton_path(
    b: &ReflectionBuffers<'_>,
    mut c: (i64, i64),
    mut cs: Surf,
    s: (i64, i64),
    target: Reflected,
    t: Target,
    eye: Vec3,
    p: &TcrrOptions,
) -> Option<([f32; 2], u32)> {
    let (w, h) = (i64::from(b.width()), i64::from(b.height()));
    let mut steps = 0u32;
    let mut prev = c;
    loop {
        if c.0 <= 0 || c.1 <= 0 || c.0 >= w - 1 || c.1 >= h - 1 {
            return None;
        }
        let d = refine(b, c, &cs, target, eye)?;
        if d[0].abs() <= 0.5 && d[1].abs() <= 0.5 {
            distance_squared(eye, cs.pos, cs.normal, t)?;
            for &(dx, dy) in RING.iter() {
                let (ns, refl) = texel(b, c.0 + i64::from(dx), c.1 + i64::from(dy))?;
                if !(refl && cs.connected(&ns, p.discontinuity)) {
                    return None;
                }
            }
            let o = [
                (c.0 - s.0) as f32 + snap(d[0]),
                (c.1 - s.1) as f32 + snap(d[1]),
            ];
            return Some((o, steps + 1));
        }
        steps += 1;
        if steps >= p.max_iterations.min(MAX_NEWTON_STEPS) {
            return None;
        }
        let step = |v: f32| {
            if v > 0.5 {
                1
            } else if v < -0.5 {
                -1
            } else {
                0
            }
        };
        let next = (c.0 + step(d[0]), c.1 + step(d[1]));
        if next == prev {
            // Oscillation between two texels (a curved reflector whose
            // tangent planes place the zero on either side): the descent
            // decides.
            return None;
        }
        prev = c;
        let (ns, refl) = texel(b, next.0, next.1)?;
        if !(refl && cs.connected(&ns, p.discontinuity)) {
            return None;
        }
        c = next;
        cs = ns;
    }
}

/// Alg. 2 for one sample; returns the offset and the neighborhoods
/// evaluated. The distances are compared squared (the same order as
/// [`reflection_distance`](super::reflection_distance)); each texel is evaluated once per pixel: a 3x3
/// window of candidates moves with the search.
#[allow(clippy::too_many_arguments)]
fn match_pixel(
    b: &ReflectionBuffers<'_>,
    x: u32,
    y: u32,
    s: super::Sample,
    prev: [f32; 2],
    eye: Vec3,
    p: &TcrrOptions,
) -> ([f32; 2], u32) {
    let Some(target) = b.target(&s) else {
        return (INVALID_OFFSET, 0);
    };
    let Some(t) = Target::new(target) else {
        return (INVALID_OFFSET, 0);
    };
    let (w, h) = (i64::from(b.width()), i64::from(b.height()));
    let (sx, sy) = (i64::from(x), i64::from(y));
    // Alg. 2 lines 5-6: warm start from the previous offset.
    let mut c = (sx, sy);
    let mut center_surf = s.surf;
    if offset_is_valid(prev) {
        let (ox, oy) = (libm::roundf(prev[0]), libm::roundf(prev[1]));
        if ox.abs() < w as f32 && oy.abs() < h as f32 && (ox, oy) != (0.0, 0.0) {
            let start = (sx + ox as i64, sy + oy as i64);
            if let Some((surf, true)) = texel(b, start.0, start.1) {
                c = start;
                center_surf = surf;
            }
        }
    }
    if p.subpixel {
        if let Some(r) = newton_path(b, c, center_surf, (sx, sy), target, t, eye, p) {
            return r;
        }
    }
    // The start's distance is needed by the descent only (the fast path
    // checks its own texel's).
    let mut center = Cand {
        surf: center_surf,
        reflective: true,
        d2: distance_squared(eye, center_surf.pos, center_surf.normal, t),
    };
    let mut win = [Slot::Unknown; 9];
    win[slot_index(0, 0)] = Slot::Cand(center);
    let mut former = center.d2;
    let mut iters = 0u32;
    while iters < p.max_iterations {
        iters += 1;
        // Line 10: the best neighbor.
        let mut best: Option<(usize, f32)> = None;
        for (k, &(dx, dy)) in RING.iter().enumerate() {
            let i = slot_index(dx, dy);
            if let Slot::Unknown = win[i] {
                win[i] = candidate(b, c.0 + i64::from(dx), c.1 + i64::from(dy), t, eye);
            }
            if let Slot::Cand(Cand { d2: Some(d), .. }) = win[i] {
                if best.is_none_or(|(_, bd)| d < bd) {
                    best = Some((k, d));
                }
            }
        }
        let improves = match (best, former) {
            (Some((_, bd)), Some(f)) => bd < f,
            (Some(_), None) => true,
            (None, _) => false,
        };
        let inside = |slot: &Slot| match slot {
            Slot::Cand(cd) => cd.reflective && center.surf.connected(&cd.surf, p.discontinuity),
            _ => false,
        };
        if !improves {
            // Lines 11-16: a local minimum, inside the silhouette by
            // construction (every step stayed inside).
            if former.is_none() {
                return (INVALID_OFFSET, iters);
            }
            let mut o = [(c.0 - sx) as f32, (c.1 - sy) as f32];
            let on_border = c.0 == 0 || c.1 == 0 || c.0 == w - 1 || c.1 == h - 1;
            let mut refined = None;
            if on_border {
                // The minimum may lie beyond the image, where the search
                // cannot follow: keep the match only if the tangent-plane
                // zero projects inside the image.
                refined = refine(b, c, &center.surf, target, eye);
                let inside_image = refined.is_some_and(|d| {
                    let (qx, qy) = (c.0 as f32 + 0.5 + d[0], c.1 as f32 + 0.5 + d[1]);
                    qx >= 0.0 && qy >= 0.0 && qx < w as f32 && qy < h as f32
                });
                if !inside_image {
                    return (INVALID_OFFSET, iters);
                }
            }
            if p.subpixel
                && RING
                    .iter()
                    .all(|&(dx, dy)| inside(&win[slot_index(dx, dy)]))
            {
                if refined.is_none() {
                    refined = refine(b, c, &center.surf, target, eye);
                }
                if let Some(d) = refined {
                    o[0] += snap(d[0]);
                    o[1] += snap(d[1]);
                }
            }
            return (o, iters);
        }
        let (k, bd) = best.expect("improves implies a best neighbor");
        let (dx, dy) = RING[k];
        let next = win[slot_index(dx, dy)];
        if !inside(&next) {
            // Line 15: the match lies outside the reflector's silhouette.
            return (INVALID_OFFSET, iters);
        }
        let Slot::Cand(next) = next else {
            return (INVALID_OFFSET, iters);
        };
        // Move the window by (dx, dy): what stays inside keeps its value.
        let mut moved = [Slot::Unknown; 9];
        for ny in -1..=1i32 {
            for nx in -1..=1i32 {
                let (ox, oy) = (nx + dx, ny + dy);
                if (-1..=1).contains(&ox) && (-1..=1).contains(&oy) {
                    moved[slot_index(nx, ny)] = win[slot_index(ox, oy)];
                }
            }
        }
        win = moved;
        c = (c.0 + i64::from(dx), c.1 + i64::from(dy));
        center = next;
        former = Some(bd);
    }
    // Line 21: cap reached.
    (INVALID_OFFSET, iters)
}

/// Sub-pixel refinement of a match at pixel `c` with surface `cs`: the
/// point `W*` of `c`'s tangent plane whose [`reflection_distance`](super::reflection_distance) is zero
/// (where the line from the eye to `M`, the target mirrored about that
/// plane, crosses it; for a target at infinity, the line from the eye
/// against the mirrored direction), projected into the key camera. On a
/// planar reflector this is the exact minimum; on a curved one a Newton
/// step on the tangent plane. Returns the correction in pixels (the caller
/// clamps it to one pixel and snaps it to 0 within [`SNAP_PX`]); `None` if
/// the line is parallel to the plane or the point does not project.
fn refine(
    b: &ReflectionBuffers<'_>,
    c: (i64, i64),
    cs: &Surf,
    target: Reflected,
    eye: Vec3,
) -> Option<[f32; 2]> {
    let n = cs.normal;
    let he = n.dot(eye - cs.pos);
    // Direction of the line from the eye through W* (toward the surface).
    let u = match target {
        Reflected::Point(r) => {
            let m = r - 2.0 * n.dot(r - cs.pos) * n;
            m - eye
        }
        Reflected::Direction(d) => -(2.0 * n.dot(d) * n - d),
    };
    let denom = n.dot(u);
    if !(denom < 0.0) {
        return None;
    }
    let w_star = eye + u * (-he / denom);
    let q = b.camera.project(w_star)?;
    let (dx, dy) = (q.x - (c.0 as f32 + 0.5), q.y - (c.1 as f32 + 0.5));
    (dx.is_finite() && dy.is_finite()).then_some([dx, dy])
}
