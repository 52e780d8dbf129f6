//! Reflection pixel matching by neighborhood search (seed 000 Sec. 3.2.1,
//! Alg. 2).

use super::{offset_is_valid, reflection_distance, ReflectionBuffers, TcrrParams, INVALID_OFFSET};
use super::{Reflected, Surf, SNAP_PX};
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
/// [`reflection_distance`] than `s_c`, the search moves to the best one,
/// unless that neighbor lies outside the reflector's silhouette (not a
/// reflective sample, or across a depth discontinuity from `s_c`, see
/// [`TcrrParams::discontinuity`]), which records INVALID. A search that
/// evaluates [`TcrrParams::max_iterations`] neighborhoods without
/// converging, or whose start has no defined distance and no improving
/// neighbor, records INVALID. Otherwise it records `s_c - s`, refined
/// between pixel centers when [`TcrrParams::subpixel`] is on (see the
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
/// differs from the buffers', `eye` is not finite or `params` is out of
/// range.
pub fn search(
    offsets: &mut ImageViewMut<'_, [f32; 2]>,
    buffers: &ReflectionBuffers<'_>,
    eye: Vec3,
    params: &TcrrParams,
) -> Result<SearchStats, Error> {
    params.validate()?;
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
                    let (o, iters) = match_pixel(buffers, x, y, s, prev, eye, params);
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

/// The candidate at `(x, y)`: its surface, whether it is a reflective
/// sample, and its distance for target `r` seen from `eye`.
#[inline]
fn candidate(
    b: &ReflectionBuffers<'_>,
    x: i64,
    y: i64,
    target: Reflected,
    eye: Vec3,
) -> Option<(Surf, bool, Option<f32>)> {
    if x < 0 || y < 0 {
        return None;
    }
    let (x, y) = (u32::try_from(x).ok()?, u32::try_from(y).ok()?);
    let surf = b.surface(x, y)?;
    // A reflective sample (see `ReflectionBuffers::sample`) without
    // back-projecting the texel a second time.
    let reflective = b.is_specular(x, y) && b.distance.get(x, y).is_some_and(|r| r >= 0.0);
    let d = reflection_distance(eye, surf.pos, surf.normal, target);
    Some((surf, reflective, d))
}

/// Alg. 2 for one sample; returns the offset and the neighborhoods
/// evaluated.
#[allow(clippy::too_many_arguments)]
fn match_pixel(
    b: &ReflectionBuffers<'_>,
    x: u32,
    y: u32,
    s: super::Sample,
    prev: [f32; 2],
    eye: Vec3,
    p: &TcrrParams,
) -> ([f32; 2], u32) {
    let Some(target) = b.target(&s) else {
        return (INVALID_OFFSET, 0);
    };
    let (w, h) = (i64::from(b.width()), i64::from(b.height()));
    let (sx, sy) = (i64::from(x), i64::from(y));
    // Alg. 2 lines 5-6: warm start from the previous offset.
    let mut c = (sx, sy);
    let mut c_surf = s.surf;
    if offset_is_valid(prev) {
        let (ox, oy) = (libm::roundf(prev[0]), libm::roundf(prev[1]));
        if ox.abs() < w as f32 && oy.abs() < h as f32 {
            let start = (sx + ox as i64, sy + oy as i64);
            if let Some((su, true, _)) = candidate(b, start.0, start.1, target, eye) {
                c = start;
                c_surf = su;
            }
        }
    }
    let mut former = reflection_distance(eye, c_surf.pos, c_surf.normal, target);
    let mut iters = 0u32;
    while iters < p.max_iterations {
        iters += 1;
        // Line 10: the best neighbor.
        let mut inside = [false; 8];
        let mut best: Option<(usize, f32)> = None;
        for (k, (dx, dy)) in RING.iter().enumerate() {
            let Some((su, refl, d)) = candidate(b, c.0 + *dx as i64, c.1 + *dy as i64, target, eye)
            else {
                continue;
            };
            inside[k] = refl && c_surf.connected(&su, p.discontinuity);
            if let Some(d) = d {
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
        if !improves {
            // Lines 11-16: a local minimum, inside the silhouette by
            // construction (every step stayed inside).
            if former.is_none() {
                return (INVALID_OFFSET, iters);
            }
            let mut o = [(c.0 - sx) as f32, (c.1 - sy) as f32];
            let on_border = c.0 == 0 || c.1 == 0 || c.0 == w - 1 || c.1 == h - 1;
            if on_border {
                // The minimum may lie beyond the image, where the search
                // cannot follow: keep the match only if the tangent-plane
                // zero projects inside the image.
                let inside_image = refine(b, c, &c_surf, target, eye).is_some_and(|d| {
                    let (qx, qy) = (c.0 as f32 + 0.5 + d[0], c.1 as f32 + 0.5 + d[1]);
                    qx >= 0.0 && qy >= 0.0 && qx < w as f32 && qy < h as f32
                });
                if !inside_image {
                    return (INVALID_OFFSET, iters);
                }
            }
            if p.subpixel && inside.iter().all(|&i| i) {
                if let Some(d) = refine(b, c, &c_surf, target, eye) {
                    let snap = |v: f32| {
                        let v = v.clamp(-1.0, 1.0);
                        if v.abs() < SNAP_PX {
                            0.0
                        } else {
                            v
                        }
                    };
                    o[0] += snap(d[0]);
                    o[1] += snap(d[1]);
                }
            }
            return (o, iters);
        }
        let (k, bd) = best.expect("improves implies a best neighbor");
        if !inside[k] {
            // Line 15: the match lies outside the reflector's silhouette.
            return (INVALID_OFFSET, iters);
        }
        let (dx, dy) = RING[k];
        c = (c.0 + i64::from(dx), c.1 + i64::from(dy));
        c_surf = match candidate(b, c.0, c.1, target, eye) {
            Some((su, _, _)) => su,
            None => return (INVALID_OFFSET, iters),
        };
        former = Some(bd);
    }
    // Line 21: cap reached.
    (INVALID_OFFSET, iters)
}

/// Sub-pixel refinement of a match at pixel `c` with surface `cs`: the
/// point `W*` of `c`'s tangent plane whose [`reflection_distance`] is zero
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
