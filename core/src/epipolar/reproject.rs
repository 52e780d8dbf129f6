//! The reprojection phase (seed 002 Alg. 1, Sec. 5.1 reprojection, Sec. 4.1
//! view-frustum check, Sec. 4.3.1 abrupt motion): the per-frame
//! [`Reprojector`], the scratch size, the splat of the POS points into
//! the AIP buffer ([`try_reproject`]) and the guard window.

use super::order::LineRecords;
use super::{
    AipEntry, EpipolarOptions, Epipole, Epipoles, PosEntry, Quadrants, INVALID_OBJECT,
    MAX_SPLAT_RADIUS,
};
use crate::{Camera, Error};
use glam::{DVec3, Vec2, Vec3};

/// Per-frame coefficients of the reprojection (seed 002 Sec. 5.1): for a
/// world point `P` and `d = P - C` (`C` the eye), the pixel position is
/// `(A.d / N.d, B.d / N.d)` and the signed distance `|d|`, with `N` the unit
/// forward vector and `A`, `B` the image-plane rows with the principal point
/// folded in (composed in f64, rounded once). One point costs 3 subtractions,
/// 8 additions, 14 multiplications, 1 division, 1 square root and 1 branch
/// (the paper counts 12 multiplications and 2 branches with its
/// principal-component variant).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reprojector {
    eye: Vec3,
    a: Vec3,
    b: Vec3,
    n: Vec3,
}

impl Reprojector {
    /// The coefficients of `camera`.
    pub fn new(camera: &Camera) -> Reprojector {
        let view = camera.view().as_dmat4();
        let row = |i: usize| DVec3::new(view.x_axis[i], view.y_axis[i], view.z_axis[i]);
        let (r0, r1, r2) = (row(0), row(1), row(2));
        let w = f64::from(camera.width());
        let h = f64::from(camera.height());
        let tan_y = libm::tan(f64::from(camera.fov_y()) * 0.5);
        let tan_x = tan_y * w / h;
        let n = -r2;
        // px = (x_v / (z tan_x) + 1) w / 2, py = (1 - y_v / (z tan_y)) h / 2
        // with x_v = r0.d, y_v = r1.d, z = n.d.
        let a = r0 * (w / (2.0 * tan_x)) + n * (w * 0.5);
        let b = -r1 * (h / (2.0 * tan_y)) + n * (h * 0.5);
        Reprojector {
            eye: camera.inverse_view().w_axis.truncate(),
            a: a.as_vec3(),
            b: b.as_vec3(),
            n: n.as_vec3(),
        }
    }

    /// `(pixel x, pixel y, signed distance)` of `p`, or `None` when `p` is
    /// at or behind the eye plane (design.md erratum: points with `t <= 0`
    /// are dropped) or the result is not finite.
    #[inline]
    pub fn project(&self, p: Vec3) -> Option<(Vec2, f32)> {
        let d = p - self.eye;
        let z = self.n.dot(d);
        if !(z > 0.0) {
            return None;
        }
        let inv = 1.0 / z;
        let px = Vec2::new(self.a.dot(d) * inv, self.b.dot(d) * inv);
        let t = libm::sqrtf(d.dot(d));
        (px.is_finite() && t.is_finite()).then_some((px, t))
    }

    /// The eye the coefficients were made for.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }
}

/// Floats of reprojection scratch for a `width x height` new image, the
/// larger of two uses (one after the other):
/// * the occlusion check's `(distance, t)` records of
///   `w + h + 4 MAX_SPLAT_RADIUS` angular bins of the epipolar lines
///   ([`line_bins`](super::line_bins)), about one bin per border pixel;
/// * the guard window's ring of `2 MAX_SPLAT_RADIUS + 1` rows of
///   row-window summaries, 3 floats per pixel ([`EpipolarOptions::guard_window`]).
///
/// # Errors
/// [`Error::InvalidArgument`] for a zero size or an overflowing count.
pub fn try_scratch_len(width: u32, height: u32) -> Result<usize, Error> {
    if width == 0 || height == 0 {
        return Err(Error::InvalidArgument);
    }
    let pad = 2 * u64::from(MAX_SPLAT_RADIUS);
    let lines = 2 * (u64::from(width) + pad) + 2 * (u64::from(height) + pad);
    let ring = GUARD_RING_ROWS * GUARD_SUMMARY_FLOATS * u64::from(width);
    usize::try_from(lines.max(ring)).map_err(|_| Error::InvalidArgument)
}

/// Angular bins of the occlusion check's epipolar-line records for a
/// `width x height` image: `w + h + 4 MAX_SPLAT_RADIUS`, about one per
/// border pixel of the padded image (each bin takes 2 floats of
/// [`try_scratch_len`]).
pub fn line_bin_count(width: u32, height: u32) -> usize {
    let pad = 2 * MAX_SPLAT_RADIUS as usize;
    width as usize + pad + height as usize + pad
}

/// Rows of row-window summaries the guard window keeps at once.
const GUARD_RING_ROWS: u64 = 2 * MAX_SPLAT_RADIUS as u64 + 1;

/// Floats per guard summary: nearest `t`, its object (bits), nearest `t`
/// of any other object.
const GUARD_SUMMARY_FLOATS: u64 = 3;

/// Counts of one reprojection phase.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReprojectStats {
    /// POS entries holding a point (object not [`INVALID_OBJECT`]).
    pub points: u32,
    /// Points splatted into the AIP.
    pub splatted: u32,
    /// Points at or behind the new eye plane (dropped).
    pub behind: u32,
    /// Points whose splat misses the new image entirely.
    pub outside: u32,
    /// Points discarded by the occlusion check (Sec. 4.2).
    pub occlusion_rejected: u32,
    /// Points discarded by the abrupt-motion test (Sec. 4.3.1).
    pub abrupt_rejected: u32,
    /// `true` if the view-frustum check (Sec. 4.1) failed and nothing was
    /// reprojected.
    pub frustum_failed: bool,
    /// `true` if the eyes coincide (pure rotation): no parallax, the
    /// occlusion check has nothing to order and is skipped.
    pub no_baseline: bool,
}

/// The view-frustum check of seed 002 Sec. 4.1: `true` if `eye` lies inside
/// the (infinite) view pyramid of `previous`, or coincides with its eye
/// (pure rotation cannot cause the view-frustum error). Outside, objects the
/// previous frame never saw can appear anywhere and reprojection must be
/// skipped. A NaN eye is outside.
pub fn frustum_contains(previous: &Camera, eye: Vec3) -> bool {
    if !eye.is_finite() {
        return false;
    }
    let Some(e) = Epipole::of(previous, eye) else {
        return true;
    };
    if e.at_infinity || !e.in_front {
        return false;
    }
    let (w, h) = (previous.width() as f32, previous.height() as f32);
    (0.0..=w).contains(&e.pixel.x) && (0.0..=h).contains(&e.pixel.y)
}

/// Reprojection phase (seed 002 Alg. 1 with Secs. 4.1, 4.2, 4.3.1): fills
/// `aip` (the `current` camera's `width x height` pixels, row-major) from
/// `pos` (the `previous` camera's pixels, row-major).
///
/// * With [`EpipolarOptions::frustum_check`], if `current`'s eye is outside
///   `previous`'s view pyramid ([`frustum_contains`]), every AIP entry becomes
///   [`AipEntry::UNAVAILABLE`].
/// * Otherwise every stored point is reprojected with the per-frame
///   [`Reprojector`]; points behind the new eye are dropped; with
///   [`EpipolarOptions::abrupt_frames`] `= N > 0` a point at signed distance `t` is
///   discarded if the eye moved more than `t / 2 / N`; with
///   [`EpipolarOptions::occlusion_check`] the points are visited in the epipolar
///   order of [`Quadrants`]; each angular bin of the epipolar lines through
///   the new epipole ([`line_bins`](super::line_bins)) records the distance from the epipole
///   and the signed distance `t` of the last point kept on it, and a point
///   is discarded when its distance from the epipole is below (moving
///   forward; above when the order reverses) the record of its bin or an
///   adjacent one while that record is nearer the camera by more than
///   [`OCCLUDER_GAP`](super::OCCLUDER_GAP) `* t` (it fell behind a nearer point on its line: it
///   is occluded). Without the depth test, points of neighboring lines of
///   one surface, visited row by row rather than strictly by distance,
///   would discard each other. Records restart with each quadrant (an
///   epipolar line never leaves its quadrant).
/// * Surviving points splat into the `(2r+1)^2` neighborhood exactly as
///   Alg. 1: an empty entry takes the point; a point not farther than the
///   entry's `t` lowers `t` and increments `cnt` for the same object or
///   overwrites the object with `cnt = 1`; a farther point of the same
///   object increments `cnt`. In addition [`AipEntry::t_other`] keeps the
///   nearest distance of the points that lost (the overwritten object's
///   nearest point, farther points of other objects).
///
/// `scratch` holds [`try_scratch_len`] floats (contents ignored and
/// overwritten).
///
/// # Errors
/// * [`Error::InvalidArgument`]: the cameras differ in size, or `options`
///   fails [`EpipolarOptions::try_validate`].
/// * [`Error::InsufficientSize`]: `pos` or `aip` shorter than
///   `width * height`, `scratch` shorter than [`try_scratch_len`].
///
/// Nothing is written on error.
pub fn try_reproject(
    aip: &mut [AipEntry],
    scratch: &mut [f32],
    pos: &[PosEntry],
    previous: &Camera,
    current: &Camera,
    options: &EpipolarOptions,
) -> Result<ReprojectStats, Error> {
    options.try_validate()?;
    let (w, h) = (current.width(), current.height());
    if previous.width() != w || previous.height() != h {
        return Err(Error::InvalidArgument);
    }
    let n = w as usize * h as usize;
    if pos.len() < n || aip.len() < n || scratch.len() < try_scratch_len(w, h)? {
        return Err(Error::InsufficientSize);
    }
    let aip = &mut aip[..n];
    let mut stats = ReprojectStats::default();
    if options.frustum_check && !frustum_contains(previous, current.eye()) {
        aip.fill(AipEntry::UNAVAILABLE);
        stats.frustum_failed = true;
        stats.points = pos[..n]
            .iter()
            .filter(|p| p.object != INVALID_OBJECT)
            .count() as u32;
        return Ok(stats);
    }
    aip.fill(AipEntry::EMPTY);
    let proj = Reprojector::new(current);
    let moved = (current.eye() - previous.eye()).length();
    let epipoles = Epipoles::of(previous, current);
    stats.no_baseline = epipoles.is_none();
    let mut ctx = Splat {
        aip,
        width: w,
        height: h,
        radius: options.splat_radius as i64,
        proj,
        moved,
        abrupt_frames: options.abrupt_frames,
    };
    match (options.occlusion_check, epipoles) {
        (true, Some(e)) => {
            let mut records = LineRecords::new(scratch, w, h, e.current.pixel, e.increasing());
            let quads = Quadrants::new(w, h, e.previous.pixel, e.outward());
            for qi in 0..4 {
                let q = quads.get(qi);
                if q.is_empty() {
                    continue;
                }
                records.reset();
                // `Quadrant::pixel` order, without a division per point.
                let (c0, c1) = q.columns;
                for r in 0..q.rows.1 - q.rows.0 {
                    let y = if q.rows_descending {
                        q.rows.1 - 1 - r
                    } else {
                        q.rows.0 + r
                    };
                    let row = &pos[y as usize * w as usize..][..w as usize];
                    if q.columns_descending {
                        for entry in row[c0 as usize..c1 as usize].iter().rev() {
                            ctx.point(entry, Some(&mut records), &mut stats);
                        }
                    } else {
                        for entry in &row[c0 as usize..c1 as usize] {
                            ctx.point(entry, Some(&mut records), &mut stats);
                        }
                    }
                }
            }
        }
        _ => {
            for entry in &pos[..n] {
                ctx.point(entry, None, &mut stats);
            }
        }
    }
    if options.depth_guard && options.guard_window > 0 {
        guard_window(ctx.aip, scratch, w, h, options.guard_window);
    }
    Ok(stats)
}

/// Nearest entries of a set of AIP entries, for the guard window: the
/// nearest `t` (`t1`) and its object (`o1`), and the nearest `t` of any
/// entry holding another object than `o1` (`t2`). The minimum over "another
/// object than mine" of a set is then `t1` if `o1` is not mine, else `t2`;
/// and summaries merge associatively, so a `(2g+1)^2` window is a vertical
/// merge of `2g+1` horizontal ones (`2 (2g+1)` merges per pixel instead of
/// `(2g+1)^2` reads). `min` is exact, so the result is bit-identical to the
/// direct scan.
#[derive(Clone, Copy)]
struct Nearest2 {
    t1: f32,
    o1: u32,
    t2: f32,
}

impl Nearest2 {
    /// The summary of the empty set.
    const EMPTY: Nearest2 = Nearest2 {
        t1: f32::INFINITY,
        o1: INVALID_OBJECT,
        t2: f32::INFINITY,
    };

    #[inline]
    fn of(a: &AipEntry) -> Nearest2 {
        if a.object == INVALID_OBJECT {
            Nearest2::EMPTY
        } else {
            Nearest2 {
                t1: a.t,
                o1: a.object,
                t2: f32::INFINITY,
            }
        }
    }

    #[inline]
    fn merge(self, o: Nearest2) -> Nearest2 {
        let (a, b) = if self.t1 <= o.t1 {
            (self, o)
        } else {
            (o, self)
        };
        // b's nearest of an object other than a.o1.
        let other = if b.o1 != a.o1 { b.t1 } else { b.t2 };
        Nearest2 {
            t1: a.t1,
            o1: a.o1,
            t2: a.t2.min(other),
        }
    }

    /// Nearest `t` of the set's entries holding another object than
    /// `object`.
    #[inline]
    fn other_than(&self, object: u32) -> f32 {
        if self.o1 != object {
            self.t1
        } else {
            self.t2
        }
    }

    #[inline]
    fn store(&self, out: &mut [f32]) {
        // The object id travels bit for bit through the f32 scratch
        // (`from_bits`/`to_bits` are transmutes; no arithmetic touches it).
        out[0] = self.t1;
        out[1] = f32::from_bits(self.o1);
        out[2] = self.t2;
    }

    #[inline]
    fn load(s: &[f32]) -> Nearest2 {
        Nearest2 {
            t1: s[0],
            o1: s[1].to_bits(),
            t2: s[2],
        }
    }
}

/// The guard window of [`EpipolarOptions::guard_window`]: lowers `t_other` of every
/// entry to the `t` of the entries within `g` pixels holding another
/// object. Reads only `object` and `t`, which it does not change, so it
/// works in place. Separable ([`Nearest2`]): `scratch` holds a ring of
/// `2g + 1` rows of horizontal window summaries (at least
/// `(2g + 1) * 3 * w` floats, which [`try_scratch_len`] covers).
fn guard_window(aip: &mut [AipEntry], scratch: &mut [f32], w: u32, h: u32, g: u32) {
    let (w, h, g) = (w as usize, h as usize, g as usize);
    let ring_rows = 2 * g + 1;
    let stride = GUARD_SUMMARY_FLOATS as usize * w;
    let ring = &mut scratch[..ring_rows * stride];
    // Horizontal summaries of row `y` into ring slot `y % ring_rows`.
    let summarize = |aip: &[AipEntry], ring: &mut [f32], y: usize| {
        let row = &aip[y * w..][..w];
        let out = &mut ring[(y % ring_rows) * stride..][..stride];
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(g), (x + g).min(w - 1));
            let mut s = Nearest2::EMPTY;
            for a in &row[x0..=x1] {
                s = s.merge(Nearest2::of(a));
            }
            s.store(&mut out[3 * x..3 * x + 3]);
        }
    };
    for y in 0..g.min(h) {
        summarize(aip, ring, y);
    }
    for y in 0..h {
        if y + g < h {
            summarize(aip, ring, y + g);
        }
        let (y0, y1) = (y.saturating_sub(g), (y + g).min(h - 1));
        for x in 0..w {
            let object = aip[y * w + x].object;
            if object == INVALID_OBJECT {
                continue;
            }
            let mut s = Nearest2::EMPTY;
            for ny in y0..=y1 {
                let at = (ny % ring_rows) * stride + 3 * x;
                s = s.merge(Nearest2::load(&ring[at..at + 3]));
            }
            let a = &mut aip[y * w + x];
            a.t_other = a.t_other.min(s.other_than(object));
        }
    }
}

struct Splat<'a> {
    aip: &'a mut [AipEntry],
    width: u32,
    height: u32,
    radius: i64,
    proj: Reprojector,
    moved: f32,
    abrupt_frames: u32,
}

impl Splat<'_> {
    #[inline]
    fn point(
        &mut self,
        entry: &PosEntry,
        records: Option<&mut LineRecords<'_>>,
        stats: &mut ReprojectStats,
    ) {
        if entry.object == INVALID_OBJECT {
            return;
        }
        stats.points += 1;
        let p = entry.point();
        let Some((px, t)) = self.proj.project(p) else {
            stats.behind += 1;
            return;
        };
        let (x, y) = (libm::floorf(px.x), libm::floorf(px.y));
        let r = self.radius as f32;
        if !(x >= -r && y >= -r && x < self.width as f32 + r && y < self.height as f32 + r) {
            stats.outside += 1;
            return;
        }
        let (x, y) = (x as i64, y as i64);
        // Sec. 4.3.1: delta = t / 2 / N.
        if self.abrupt_frames > 0 && self.moved > t * 0.5 / self.abrupt_frames as f32 {
            stats.abrupt_rejected += 1;
            self.flag(x, y, AipEntry::ABRUPT_REJECTED);
            return;
        }
        if let Some(rec) = records {
            if !rec.check(px, t) {
                stats.occlusion_rejected += 1;
                // The discarded point still bounds the one-object test of
                // another object (the depth guard): something is there at
                // distance t.
                let object = entry.object;
                self.for_each(x, y, |a, _, _| {
                    a.flags |= AipEntry::OCCLUSION_REJECTED;
                    if a.object != object {
                        a.t_other = a.t_other.min(t);
                    }
                });
                return;
            }
        }
        stats.splatted += 1;
        let object = entry.object;
        self.for_each(x, y, |a, ix, iy| {
            // Side of the pixel center the point landed on.
            let side = AipEntry::SURROUND_UP_LEFT
                << (u32::from(px.x >= ix as f32 + 0.5) + 2 * u32::from(px.y >= iy as f32 + 0.5));
            if a.object == INVALID_OBJECT {
                // First assignment.
                a.object = object;
                a.t = t;
                a.cnt = 1;
                a.flags |= side;
            } else if a.t >= t {
                if a.object == object {
                    a.cnt += 1;
                    a.flags |= side;
                } else {
                    // Rewrite by the closer object; the old one's nearest
                    // point becomes the guard.
                    a.t_other = a.t_other.min(a.t);
                    a.object = object;
                    a.cnt = 1;
                    a.flags = (a.flags & !AipEntry::SURROUNDED) | side;
                }
                a.t = t;
            } else if a.object == object {
                a.cnt += 1;
                a.flags |= side;
            } else {
                a.t_other = a.t_other.min(t);
            }
        });
    }

    fn flag(&mut self, x: i64, y: i64, bit: u32) {
        self.for_each(x, y, |a, _, _| a.flags |= bit);
    }

    #[inline]
    fn for_each(&mut self, x: i64, y: i64, mut f: impl FnMut(&mut AipEntry, i64, i64)) {
        let r = self.radius;
        let (w, h) = (self.width as i64, self.height as i64);
        for iy in (y - r).max(0)..=(y + r).min(h - 1) {
            let row = iy as usize * w as usize;
            for ix in (x - r).max(0)..=(x + r).min(w - 1) {
                f(&mut self.aip[row + ix as usize], ix, iy);
            }
        }
    }
}
