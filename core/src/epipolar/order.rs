//! The occlusion-compatible epipolar order (seed 002 Sec. 4.2, Fig. 4): the
//! epipoles of a frame pair, the four quadrants and their traversal, and
//! the per-line records of the occlusion check.

use super::{line_bin_count, MAX_SPLAT_RADIUS};
use crate::Camera;
use glam::{Vec2, Vec3};

/// Where one camera's eye appears in the other camera's image (seed 002
/// Sec. 4.2): the projection of the other center of projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epipole {
    /// Pixel position. An epipole at (or numerically near) infinity is
    /// represented by a point [`Epipole::FAR`] pixels from the image center
    /// in its direction, which gives the same traversal order.
    pub pixel: Vec2,
    /// `true` if the other eye lies in front of the camera's eye plane (or
    /// on it: an epipole at infinity); `false` if behind (moving backward).
    /// The occlusion-compatible order reverses with it.
    pub in_front: bool,
    /// `true` if the other eye lies on the eye plane (the camera moved
    /// parallel to its image plane): the epipole is at infinity.
    pub at_infinity: bool,
}

impl Epipole {
    /// Distance from the image center at which an epipole at infinity is
    /// placed (pixels); f32 still resolves 1/16 pixel there.
    pub const FAR: f32 = 1.0e6;

    /// The epipole of `other_eye` in `camera`'s image, or `None` when the
    /// eyes coincide (within `1e-6` of the distance from the origin, at
    /// least `1e-12`): no baseline, no epipolar geometry (pure rotation).
    pub fn of(camera: &Camera, other_eye: Vec3) -> Option<Epipole> {
        let eye = camera.inverse_view().w_axis.truncate().as_dvec3();
        let other = other_eye.as_dvec3();
        let base = other - eye;
        let len = base.length();
        if !(len > 1e-6 * eye.length().max(other.length()).max(1e-6)) {
            return None;
        }
        let view = camera.view().as_dmat4();
        let v = view.transform_vector3(base);
        let w = f64::from(camera.width());
        let h = f64::from(camera.height());
        let tan_y = libm::tan(f64::from(camera.fov_y()) * 0.5);
        let tan_x = tan_y * w / h;
        // Homogeneous pixel offset from the image center: (x_v w/(2 tan_x),
        // -y_v h/(2 tan_y)) over z = -z_v.
        let dir = glam::DVec2::new(v.x * w / (2.0 * tan_x), -v.y * h / (2.0 * tan_y));
        let z = -v.z;
        let center = glam::DVec2::new(w * 0.5, h * 0.5);
        let far = f64::from(Epipole::FAR);
        let at_infinity = libm::fabs(z) * far <= dir.length();
        let offset = if at_infinity {
            dir.normalize() * far
        } else {
            let o = dir / z;
            if o.length() > far {
                o.normalize() * far
            } else {
                o
            }
        };
        Some(Epipole {
            pixel: (center + offset).as_vec2(),
            in_front: at_infinity || z > 0.0,
            at_infinity,
        })
    }
}

/// The two epipoles of a frame pair (seed 002 Sec. 4.2): `previous` is the
/// new eye `C_i` projected into the previous image `VP_{i-1}` (it orders the
/// reprojection), `current` the previous eye `C_{i-1}` projected into the
/// new image `VP_i` (distances from it are checked).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epipoles {
    /// `E_{i-1}`: the new eye in the previous image.
    pub previous: Epipole,
    /// `E_i`: the previous eye in the new image.
    pub current: Epipole,
}

impl Epipoles {
    /// Both epipoles, or `None` for coincident eyes.
    ///
    /// An epipole at infinity is the limit of a far epipole in front on one
    /// side and behind on the other; both give the same order along the
    /// epipolar lines. `previous` is kept in front (on the side the eye
    /// moved to), `current` is taken behind, on the same side (the mirror
    /// of [`Epipole::of`]'s point), so that a sideways move is ordered like
    /// the forward moves it is the limit of (outward, increasing).
    pub fn of(previous: &Camera, current: &Camera) -> Option<Epipoles> {
        let mut cur = Epipole::of(current, previous.eye())?;
        if cur.at_infinity {
            let center = Vec2::new(current.width() as f32, current.height() as f32) * 0.5;
            cur.pixel = 2.0 * center - cur.pixel;
            cur.in_front = false;
        }
        Some(Epipoles {
            previous: Epipole::of(previous, current.eye())?,
            current: cur,
        })
    }

    /// Whether the previous image is traversed away from its epipole
    /// (`true`: the new eye is in front of the previous camera, e.g. moving
    /// forward) or toward it (`false`: moving backward, the order reverses).
    pub fn outward(&self) -> bool {
        self.previous.in_front
    }

    /// Whether distances from the new epipole must grow along the traversal
    /// (`true`: the previous eye is behind the new camera) or shrink
    /// (`false`: it is in front, as when moving backward).
    pub fn increasing(&self) -> bool {
        !self.current.in_front
    }
}

/// The four quadrants of an image around an epipole and their traversal
/// orders (seed 002 Sec. 4.2, Fig. 4, after Mark 1999 p. 62).
///
/// Column `c` is left of the epipole when `c + 0.5 < e.x`, row `r` above it
/// when `r + 0.5 < e.y`. Within a quadrant the rows are visited in order of
/// their distance from the epipole's row and, inside each row, the columns
/// in order of their distance from its column (outward), or both reversed
/// (inward). Every pixel is then visited after every pixel of its quadrant
/// that is nearer the epipole in both coordinates, in particular after the
/// pixels between it and the epipole on its epipolar line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quadrants {
    width: u32,
    height: u32,
    split_x: u32,
    split_y: u32,
    outward: bool,
}

/// One quadrant: a column range and a row range with their directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quadrant {
    /// Columns `[start, end)`.
    pub columns: (u32, u32),
    /// Rows `[start, end)`.
    pub rows: (u32, u32),
    /// `true`: columns are visited from `end - 1` down to `start`.
    pub columns_descending: bool,
    /// `true`: rows are visited from `end - 1` down to `start`.
    pub rows_descending: bool,
}

impl Quadrant {
    /// Number of pixels.
    pub fn len(&self) -> usize {
        (self.columns.1 - self.columns.0) as usize * (self.rows.1 - self.rows.0) as usize
    }

    /// `true` for an empty quadrant (epipole outside the image).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The `k`-th pixel of the traversal (`k < len`).
    #[inline]
    pub fn pixel(&self, k: usize) -> (u32, u32) {
        let w = (self.columns.1 - self.columns.0) as usize;
        let (r, c) = ((k / w) as u32, (k % w) as u32);
        let x = if self.columns_descending {
            self.columns.1 - 1 - c
        } else {
            self.columns.0 + c
        };
        let y = if self.rows_descending {
            self.rows.1 - 1 - r
        } else {
            self.rows.0 + r
        };
        (x, y)
    }
}

impl Quadrants {
    /// The quadrants of a `width x height` image around `epipole`,
    /// traversed outward (away from it) or inward.
    pub fn new(width: u32, height: u32, epipole: Vec2, outward: bool) -> Quadrants {
        // Number of columns c with c + 0.5 < e.x, clamped to [0, width].
        let split = |e: f32, n: u32| {
            let s = libm::ceilf(e - 0.5);
            if !(s > 0.0) {
                0
            } else if s >= n as f32 {
                n
            } else {
                s as u32
            }
        };
        Quadrants {
            width,
            height,
            split_x: split(epipole.x, width),
            split_y: split(epipole.y, height),
            outward,
        }
    }

    /// Quadrant `i` of 4: top-left, top-right, bottom-left, bottom-right.
    pub fn get(&self, i: usize) -> Quadrant {
        let left = i % 2 == 0;
        let top = i < 2;
        // Outward: left columns descend toward 0, right ones ascend.
        Quadrant {
            columns: if left {
                (0, self.split_x)
            } else {
                (self.split_x, self.width)
            },
            rows: if top {
                (0, self.split_y)
            } else {
                (self.split_y, self.height)
            },
            columns_descending: left == self.outward,
            rows_descending: top == self.outward,
        }
    }
}

/// Relative depth gap of the occlusion check: a point that breaks the
/// epipolar order is discarded only when the recorded point it fell behind
/// is nearer the camera by more than this fraction of the point's distance.
pub const OCCLUDER_GAP: f32 = 0.02;

/// Angular bins of the epipolar lines through the new epipole (seed 002
/// Sec. 4.2): `(axis, theta0, bins per radian, full circle)` for `len`
/// bins over a `width x height` image padded by [`MAX_SPLAT_RADIUS`] + 1.
/// An epipole inside the padded image takes the full circle from the +x
/// axis; one outside it takes the angular range the padded image covers
/// around the bisector of that range (an epipole at infinity gives a tiny
/// range of almost parallel lines, resolved in f32 because the angle is
/// measured from the bisector).
pub fn line_bins(width: u32, height: u32, epipole: Vec2, len: usize) -> (Vec2, f32, f32, bool) {
    let p = f64::from(MAX_SPLAT_RADIUS) + 1.0;
    let (w, h) = (f64::from(width), f64::from(height));
    let e = epipole.as_dvec2();
    let inside = e.x > -p && e.x < w + p && e.y > -p && e.y < h + p;
    let (axis, theta0, theta1) = if inside {
        (
            glam::DVec2::X,
            -core::f64::consts::PI,
            core::f64::consts::PI,
        )
    } else {
        let u0 = (glam::DVec2::new(w * 0.5, h * 0.5) - e).normalize();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for c in [
            glam::DVec2::new(-p, -p),
            glam::DVec2::new(w + p, -p),
            glam::DVec2::new(-p, h + p),
            glam::DVec2::new(w + p, h + p),
        ] {
            let d = c - e;
            let a = libm::atan2(u0.perp_dot(d), u0.dot(d));
            lo = lo.min(a);
            hi = hi.max(a);
        }
        let mid = 0.5 * (lo + hi);
        let r = glam::DVec2::new(libm::cos(mid), libm::sin(mid));
        let axis = glam::DVec2::new(u0.x * r.x - u0.y * r.y, u0.x * r.y + u0.y * r.x);
        let half = 0.5 * (hi - lo) * 1.001 + 1e-9;
        (axis, -half, half)
    };
    (
        axis.as_vec2(),
        theta0 as f32,
        (len as f64 / (theta1 - theta0)) as f32,
        inside,
    )
}

/// Per-epipolar-line records of the occlusion check: for each angular bin
/// ([`line_bins`]) the distance from the new epipole and the signed
/// distance `t` of the last point kept there.
pub(super) struct LineRecords<'a> {
    data: &'a mut [f32],
    epipole: Vec2,
    /// Unit axis angles are measured from.
    axis: Vec2,
    /// Angle of the first bin and bins per radian.
    theta0: f32,
    scale: f32,
    /// The bins cover the full circle (epipole inside the padded image).
    full: bool,
    increasing: bool,
}

impl<'a> LineRecords<'a> {
    pub(super) fn new(
        scratch: &'a mut [f32],
        width: u32,
        height: u32,
        epipole: Vec2,
        increasing: bool,
    ) -> Self {
        let len = 2 * line_bin_count(width, height);
        let (axis, theta0, scale, full) = line_bins(width, height, epipole, len / 2);
        LineRecords {
            data: &mut scratch[..len],
            epipole,
            axis,
            theta0,
            scale,
            full,
            increasing,
        }
    }

    pub(super) fn reset(&mut self) {
        let init = if self.increasing {
            f32::NEG_INFINITY
        } else {
            f32::INFINITY
        };
        self.data.fill(init);
    }

    /// Checks the point at pixel position `p` and signed distance `t`
    /// against the records of its bin and the two adjacent ones (the lines
    /// its splat can reach): it fails when it breaks the distance order of
    /// a record nearer the camera by more than [`OCCLUDER_GAP`]; on success
    /// it becomes its bin's record.
    #[inline]
    pub(super) fn check(&mut self, p: Vec2, t: f32) -> bool {
        let d = p - self.epipole;
        let a = self.axis.dot(d);
        let b = self.axis.perp_dot(d);
        let theta = libm::atan2f(b, a);
        let n = (self.data.len() / 2) as i64;
        let bin = libm::floorf((theta - self.theta0) * self.scale);
        let bin = if bin > 0.0 {
            (bin as i64).min(n - 1)
        } else {
            0
        };
        let dist = a * a + b * b;
        let mut ok = true;
        for k in bin - 1..=bin + 1 {
            let k = if self.full {
                k.rem_euclid(n)
            } else if k < 0 || k >= n {
                continue;
            } else {
                k
            };
            let r = self.data[2 * k as usize];
            let order = if self.increasing {
                dist >= r
            } else {
                dist <= r
            };
            ok &= order || !(self.data[2 * k as usize + 1] < t * (1.0 - OCCLUDER_GAP));
        }
        if ok {
            self.data[2 * bin as usize] = dist;
            self.data[2 * bin as usize + 1] = t;
        }
        ok
    }
}
