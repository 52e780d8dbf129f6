//! Reflection shifting (seed 000 Sec. 3.2.2): the grid mesh of the
//! reflection buffer, moved by the offsets and rasterized into the
//! intermediate reflection image, with the small triangle rasterizer it
//! needs.
//!
//! # Example
//! ```rust
//! use refl_core::tcrr::{try_shift, COVERAGE_NONE, COVERAGE_REUSE, INVALID_OFFSET};
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
//! // Offsets one pixel to the right (what the search finds when the eye moves to
//! // (0.375, 2, 0)); the last column has no match.
//! let offsets: Vec<[f32; 2]> = (0..64).map(|i| if i % 8 < 7 { [1.0, 0.0] } else { INVALID_OFFSET }).collect();
//! let (mut shifted, mut path, mut coverage) = ([[0.0f32; 3]; 64], [0.0f32; 64], [0u8; 64]);
//! try_shift(
//!     &mut ImageViewMut::try_new(&mut shifted, 8, 8, 8)?,
//!     &mut ImageViewMut::try_new(&mut path, 8, 8, 8)?,
//!     &mut ImageViewMut::try_new(&mut coverage, 8, 8, 8)?,
//!     &buffers,
//!     &view(&offsets)?,
//!     &TcrrOptions::default(),
//! )?;
//! // The mesh moved one pixel right: pixel (x + 1, y) holds key pixel (x, y)'s
//! // reflection and its path length s.d + s.r; nothing lands in column 0.
//! for i in (0..64).filter(|i| i % 8 < 7) {
//!     assert_eq!((shifted[i + 1], coverage[i + 1]), (color[i], COVERAGE_REUSE));
//!     assert!((path[i + 1] - (2.0 + distance[i])).abs() < 1e-5);
//! }
//! assert!((0..8).all(|y| coverage[y * 8] == COVERAGE_NONE));
//! # Ok::<(), refl_core::Error>(())
//! ```

use super::{offset_is_valid, ReflectionBuffers, Sample, TcrrOptions, SNAP_PX};
use crate::{Error, ImageView, ImageViewMut};
use glam::{Vec2, Vec3};

/// Counts of one shifting pass (triangles are counted once per band they
/// reach, so bands of one image may count a triangle more than once).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShiftStats {
    /// Grid triangles rasterized.
    pub drawn: u32,
    /// Grid triangles discarded for exceeding the magnification threshold.
    pub magnified: u32,
    /// Pixels of the band written (covered) at least once.
    pub covered: u32,
}

/// Intermediate coverage value: no reflection (re-trace).
pub const COVERAGE_NONE: u8 = 0;
/// Intermediate coverage value: a shifted reflection, reusable.
pub const COVERAGE_REUSE: u8 = 1;
/// Intermediate coverage value: a shifted reflection next to a reflection
/// edge that moved differently from its other side (parallax): where the
/// edge lies between the samples is unknown, so warping re-traces it.
pub const COVERAGE_EDGE: u8 = 2;

/// A grid vertex: shifted position, color, the depth `s.d + s.r` and
/// whether it borders a reflection edge that moved.
#[derive(Clone, Copy, Debug)]
struct Vertex {
    p: Vec2,
    color: Vec3,
    depth: f32,
    sample: Sample,
    edge: bool,
}

/// Projects the reflection buffer's grid mesh by its offsets into the
/// intermediate reflection image (seed 000 Sec. 3.2.2), over the rows the
/// three output views own (they must own the same band).
///
/// The outputs are cleared over the band first (`coverage` 0, `depth`
/// `+inf`, `color` 0). The grid has a vertex at each pixel center `s` of the
/// reflection buffer, moved to `s + o(s)`; a vertex exists where `s` is a
/// reflective sample with a valid offset. Each grid cell `a=(x,y)`,
/// `b=(x+1,y)`, `c=(x,y+1)`, `d=(x+1,y+1)` gives the triangles `a b c` and
/// `b d c`, each drawn only if its three vertices exist and every edge
/// joins samples on one surface ([`TcrrOptions::discontinuity`]) with
/// continuous reflected path lengths
/// ([`TcrrOptions::reflected_discontinuity`]); a triangle whose shifted area
/// exceeds [`TcrrOptions::magnification`] times its original area (half a
/// pixel) is discarded. Uncovered pixels keep [`COVERAGE_NONE`]: they must
/// be re-traced. A covered pixel gets [`COVERAGE_REUSE`], or
/// [`COVERAGE_EDGE`] if its triangle has a vertex next to a reflection edge
/// (a 4-neighbor across a discontinuity of `s.d + s.r`) whose two sides
/// moved differently: the seed's gaps at depth discontinuities
/// (Sec. 3.2.2) widened by the samples whose neighborhood is uncertain.
///
/// Rasterization: pixel centers inside the triangle or on its edges (either
/// winding) take the barycentric interpolation of color and depth
/// (`s.d + s.r` linear; `+inf` over a triangle with a vertex whose
/// reflected ray left the scene), a center that coincides with a vertex
/// takes that vertex's values exactly; the depth test keeps the smallest
/// depth, the first triangle in row-major grid order on ties, so the result
/// does not depend on the banding.
///
/// # Errors
/// [`Error::InvalidArgument`] (nothing written) if a view's size differs
/// from the buffers', the three outputs own different bands, or `options` is
/// out of range.
pub fn try_shift(
    color: &mut ImageViewMut<'_, [f32; 3]>,
    depth: &mut ImageViewMut<'_, f32>,
    coverage: &mut ImageViewMut<'_, u8>,
    buffers: &ReflectionBuffers<'_>,
    offsets: &ImageView<'_, [f32; 2]>,
    options: &TcrrOptions,
) -> Result<ShiftStats, Error> {
    options.try_validate()?;
    let (w, h) = (buffers.width(), buffers.height());
    let sized = |vw: u32, vh: u32| vw == w && vh == h;
    if !(sized(color.width(), color.height())
        && sized(depth.width(), depth.height())
        && sized(coverage.width(), coverage.height())
        && sized(offsets.width(), offsets.height()))
        || color.owned_rows() != depth.owned_rows()
        || color.owned_rows() != coverage.owned_rows()
    {
        return Err(Error::InvalidArgument);
    }
    let mut stats = ShiftStats::default();
    let Some(rows) = color.owned_rows() else {
        return Ok(stats);
    };
    color.fill([0.0; 3]);
    depth.fill(f32::INFINITY);
    coverage.fill(0);
    let mut out = Target {
        color,
        depth,
        coverage,
        y0: rows.start(),
        y1: rows.end(),
        width: w,
    };
    let (band_lo, band_hi) = (rows.start() as f32 + 0.5, rows.end() as f32 - 0.5);
    let pos = |x: u32, y: u32| -> Option<Vec2> {
        let o = offsets.get(x, y)?;
        if !offset_is_valid(o) || !buffers.is_specular(x, y) {
            return None;
        }
        Some(Vec2::new(x as f32 + 0.5 + o[0], y as f32 + 0.5 + o[1]))
    };
    // Reflected path length s.d + s.r of a specular texel (cheap: no
    // back-projection).
    let path = |x: u32, y: u32| -> Option<f32> { buffers.path_length(x, y) };
    let tol = options.reflected_discontinuity;
    let continuous = |a: f32, b: f32| match (a.is_finite(), b.is_finite()) {
        (true, true) => (a - b).abs() <= tol * a.min(b),
        (false, false) => true,
        _ => false,
    };
    // A vertex borders a moving reflection edge if a 4-neighbor across a
    // path discontinuity has a different (or no) offset.
    let edge = |x: u32, y: u32, o: [f32; 2], d: f32| -> bool {
        let n = [
            (x.wrapping_sub(1), y),
            (x + 1, y),
            (x, y.wrapping_sub(1)),
            (x, y + 1),
        ];
        n.iter().any(|&(u, v)| match path(u, v) {
            Some(dn) if !continuous(d, dn) => offsets.get(u, v).is_none_or(|on| {
                !offset_is_valid(on)
                    || (on[0] - o[0]).abs() > SNAP_PX
                    || (on[1] - o[1]).abs() > SNAP_PX
            }),
            _ => false,
        })
    };
    let vertex = |x: u32, y: u32, p: Vec2| -> Option<Vertex> {
        let s = buffers.sample(x, y)?;
        let c = buffers.color.get(x, y)?;
        let depth = s.surf.z + s.r;
        let o = offsets.get(x, y)?;
        Some(Vertex {
            p,
            color: Vec3::from_array(c),
            depth,
            sample: s,
            edge: edge(x, y, o, depth),
        })
    };
    for y in 0..h.saturating_sub(1) {
        // The right-hand vertices of one cell are the left-hand ones of the
        // next: computed once.
        let mut memo_top: Option<(u32, Option<Vertex>)> = None;
        let mut memo_bottom: Option<(u32, Option<Vertex>)> = None;
        // Shifted positions of the cell's left corners, carried over from
        // the right corners of the previous cell.
        let (mut left_top, mut left_bottom) = (pos(0, y), pos(0, y + 1));
        for x in 0..w.saturating_sub(1) {
            let (pb, pd) = (pos(x + 1, y), pos(x + 1, y + 1));
            let (pa, pc) = (left_top, left_bottom);
            (left_top, left_bottom) = (pb, pd);
            let (Some(pa), Some(pb), Some(pc)) = (pa, pb, pc) else {
                continue;
            };
            // Quick reject: the cell's shifted vertices all above or below
            // the band.
            let (mut lo, mut hi) = (pa.y.min(pb.y).min(pc.y), pa.y.max(pb.y).max(pc.y));
            if let Some(pd) = pd {
                lo = lo.min(pd.y);
                hi = hi.max(pd.y);
            }
            if hi < band_lo || lo > band_hi {
                continue;
            }
            let a = match memo_top {
                Some((k, v)) if k == x => v,
                _ => vertex(x, y, pa),
            };
            let b = vertex(x + 1, y, pb);
            memo_top = Some((x + 1, b));
            let c = match memo_bottom {
                Some((k, v)) if k == x => v,
                _ => vertex(x, y + 1, pc),
            };
            let d = pd.and_then(|pd| vertex(x + 1, y + 1, pd));
            memo_bottom = Some((x + 1, d));
            let (Some(a), Some(b), Some(c)) = (a, b, c) else {
                continue;
            };
            let joined = |u: &Vertex, v: &Vertex| edge_joined(u, v, options);
            let (ab, ac, bc) = (joined(&a, &b), joined(&a, &c), joined(&b, &c));
            if ab && ac && bc {
                draw(&mut out, &a, &b, &c, options, &mut stats);
            }
            if let Some(d) = d {
                if bc && joined(&b, &d) && joined(&c, &d) {
                    draw(&mut out, &b, &d, &c, options, &mut stats);
                }
            }
        }
    }
    Ok(stats)
}

/// Grid edge test: one reflector surface and continuous reflected paths.
fn edge_joined(u: &Vertex, v: &Vertex, p: &TcrrOptions) -> bool {
    if !u.sample.surf.connected(&v.sample.surf, p.discontinuity) {
        return false;
    }
    match (u.depth.is_finite(), v.depth.is_finite()) {
        (true, true) => {
            (u.depth - v.depth).abs() <= p.reflected_discontinuity * u.depth.min(v.depth)
        }
        (false, false) => true,
        _ => false,
    }
}

/// The intermediate image band being written.
struct Target<'o, 'a, 'b, 'c> {
    color: &'o mut ImageViewMut<'a, [f32; 3]>,
    depth: &'o mut ImageViewMut<'b, f32>,
    coverage: &'o mut ImageViewMut<'c, u8>,
    y0: u32,
    y1: u32,
    width: u32,
}

/// Twice the signed area of `a b p`: `(b - a) x (p - a)`.
#[inline]
fn edge(a: Vec2, b: Vec2, p: Vec2) -> f32 {
    (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)
}

/// First and last pixel index whose center `i + 0.5` lies in `[lo, hi]`,
/// clamped to `[first, end)`; `None` if empty.
///
/// The bounds are clamped to `[first - 1, end]` before rounding, which
/// changes no result (the clamp to `[first, end)` follows) and keeps them
/// in the range where [`floor_small`] is exact.
#[inline]
fn span(lo: f32, hi: f32, first: u32, end: u32) -> Option<(u32, u32)> {
    let (f, e) = (first as f32, end as f32);
    let a = ceil_small((lo - 0.5).max(f - 1.0).min(e)).max(f);
    let b = floor_small((hi - 0.5).max(f - 1.0).min(e)).min(e - 1.0);
    (a <= b).then_some((a as u32, b as u32))
}

/// The smallest of three finite values (no NaN handling).
#[inline(always)]
fn min3(a: f32, b: f32, c: f32) -> f32 {
    let m = if b < a { b } else { a };
    if c < m {
        c
    } else {
        m
    }
}

/// The largest of three finite values (no NaN handling).
#[inline(always)]
fn max3(a: f32, b: f32, c: f32) -> f32 {
    let m = if b > a { b } else { a };
    if c > m {
        c
    } else {
        m
    }
}

/// `floor(v)` for finite `|v| < 2^31` (exact there: a float of magnitude
/// `>= 2^23` is already an integer), without a libm call; the inner loops
/// of shifting and warping round every triangle and tap.
#[inline(always)]
pub(crate) fn floor_small(v: f32) -> f32 {
    let t = v as i32 as f32;
    if t > v {
        t - 1.0
    } else {
        t
    }
}

/// `ceil(v)` for finite `|v| < 2^31`, as [`floor_small`].
#[inline(always)]
fn ceil_small(v: f32) -> f32 {
    let t = v as i32 as f32;
    if t < v {
        t + 1.0
    } else {
        t
    }
}

fn draw(
    t: &mut Target<'_, '_, '_, '_>,
    a: &Vertex,
    b: &Vertex,
    c: &Vertex,
    options: &TcrrOptions,
    stats: &mut ShiftStats,
) {
    let area2 = edge(a.p, b.p, c.p);
    if !(area2.abs() > 0.0) {
        return;
    }
    // Original grid triangles have area 1/2, twice that is 1.
    if area2.abs() > options.magnification {
        stats.magnified += 1;
        return;
    }
    // The vertices are finite here (a non-finite one gives a NaN or
    // infinite area above), so plain comparisons order them.
    let Some((y_first, y_last)) = span(
        min3(a.p.y, b.p.y, c.p.y),
        max3(a.p.y, b.p.y, c.p.y),
        t.y0,
        t.y1,
    ) else {
        return;
    };
    let Some((x_first, x_last)) = span(
        min3(a.p.x, b.p.x, c.p.x),
        max3(a.p.x, b.p.x, c.p.x),
        0,
        t.width,
    ) else {
        return;
    };
    stats.drawn += 1;
    let sign = area2.signum();
    let inv = 1.0 / area2;
    let finite = a.depth.is_finite() && b.depth.is_finite() && c.depth.is_finite();
    let cover = if a.edge || b.edge || c.edge {
        COVERAGE_EDGE
    } else {
        COVERAGE_REUSE
    };
    for y in y_first..y_last + 1 {
        for x in x_first..x_last + 1 {
            let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let (wa, wb, wc) = (edge(b.p, c.p, p), edge(c.p, a.p, p), edge(a.p, b.p, p));
            if wa * sign < 0.0 || wb * sign < 0.0 || wc * sign < 0.0 {
                continue;
            }
            let (col, z) = if wb == 0.0 && wc == 0.0 {
                (a.color, a.depth)
            } else if wa == 0.0 && wc == 0.0 {
                (b.color, b.depth)
            } else if wa == 0.0 && wb == 0.0 {
                (c.color, c.depth)
            } else {
                let (ba, bb, bc) = (wa * inv, wb * inv, wc * inv);
                let col = a.color * ba + b.color * bb + c.color * bc;
                let z = if finite {
                    a.depth * ba + b.depth * bb + c.depth * bc
                } else {
                    f32::INFINITY
                };
                (col, z)
            };
            let Some(cov) = t.coverage.get(x, y) else {
                continue;
            };
            let old = t.depth.get(x, y).unwrap_or(f32::INFINITY);
            if cov == 0 || z < old {
                if cov == 0 {
                    stats.covered += 1;
                }
                if let Some(v) = t.coverage.get_mut(x, y) {
                    *v = cover;
                }
                if let Some(v) = t.depth.get_mut(x, y) {
                    *v = z;
                }
                if let Some(v) = t.color.get_mut(x, y) {
                    *v = col.to_array();
                }
            }
        }
    }
}
