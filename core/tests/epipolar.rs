//! Reprojected ray casting (seed 002) against brute-force oracles: an f64
//! box scene cast pixel by pixel stands in for the host's tracer; the
//! reprojection is checked against an O(n^2) re-implementation of Alg. 1
//! with the Sec. 4.2 occlusion check, and every "test object O only"
//! decision against the closest hit of the brute-force cast.
#![cfg(feature = "epipolar")]

use glam::{DVec3, Vec2, Vec3};
use refl_core::epipolar::{
    decide, frustum_contains, line_bin_count, line_bins, resample_slot, try_decide_rows,
    try_reproject, try_scratch_len, AipEntry, Decision, EpipolarOptions, Epipole, Epipoles,
    PosEntry, Quadrants, Reason, Reprojector, BACKGROUND_OBJECT, INVALID_OBJECT, OCCLUDER_GAP,
};
use refl_core::{Camera, Error, RowRange};

/// An axis-aligned box with an object id.
#[derive(Clone, Copy)]
struct Boxed {
    min: DVec3,
    max: DVec3,
}

fn bx(min: [f64; 3], max: [f64; 3]) -> Boxed {
    Boxed {
        min: DVec3::from(min),
        max: DVec3::from(max),
    }
}

/// Slab test in f64: the entry distance `t > 0` of the ray, if any.
fn hit_box(b: &Boxed, o: DVec3, d: DVec3) -> Option<f64> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        let inv = 1.0 / d[a];
        let (mut n, mut f) = ((b.min[a] - o[a]) * inv, (b.max[a] - o[a]) * inv);
        if n > f {
            std::mem::swap(&mut n, &mut f);
        }
        t0 = t0.max(n);
        t1 = t1.min(f);
    }
    (t0 <= t1 && t0 > 0.0).then_some(t0)
}

/// The brute-force closest hit: `(object, t)`.
fn cast(scene: &[Boxed], o: DVec3, d: DVec3) -> Option<(u32, f64)> {
    scene
        .iter()
        .enumerate()
        .filter_map(|(i, b)| hit_box(b, o, d).map(|t| (i as u32, t)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

const BACKGROUND_RADIUS: f32 = 500.0;

fn render_pos(scene: &[Boxed], cam: &Camera) -> Vec<PosEntry> {
    let (w, h) = (cam.width(), cam.height());
    let mut pos = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let ray = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            pos.push(
                match cast(scene, ray.origin.as_dvec3(), ray.dir.as_dvec3()) {
                    Some((obj, t)) => PosEntry::hit(ray.origin, ray.dir, t as f32, obj),
                    None => PosEntry::background(ray.origin, ray.dir, BACKGROUND_RADIUS),
                },
            );
        }
    }
    pos
}

/// A wall, a floor, a near occluder and a box hidden behind the occluder
/// from the first camera of the cases below.
fn occluder_scene() -> Vec<Boxed> {
    vec![
        bx([-30.0, -1.0, -13.0], [30.0, 12.0, -12.0]), // 0 far wall
        bx([-30.0, -1.0, -12.0], [30.0, 0.0, 3.0]),    // 1 floor
        bx([-1.2, 0.0, -5.0], [0.3, 3.2, -4.6]),       // 2 occluder
        bx([-0.6, 0.0, -8.5], [0.4, 2.4, -8.0]),       // 3 hidden box
        bx([2.0, 0.0, -7.0], [2.6, 1.0, -6.4]),        // 4 crate
        bx([-4.0, 0.0, -9.0], [-3.4, 3.0, -8.4]),      // 5 pillar
    ]
}

fn camera(eye: Vec3, target: Vec3, w: u32, h: u32) -> Camera {
    Camera::try_look_at(eye, target, Vec3::Y, 60f32.to_radians(), 0.05, 100.0, w, h).unwrap()
}

/// What one frame pair gives.
#[derive(Debug, Default)]
struct Outcome {
    /// "Test object O only" decisions whose ray hits O while the closest
    /// hit is another object (or whose background decision has a hit).
    errors: usize,
    /// Pixels resolved by one test.
    resolved: usize,
    /// Decisions that named an object.
    predicted: usize,
    pixels: usize,
    occlusion_rejected: u32,
}

fn run_pair(scene: &[Boxed], c0: &Camera, c1: &Camera, params: &EpipolarOptions) -> Outcome {
    let pos = render_pos(scene, c0);
    let (w, h) = (c1.width(), c1.height());
    let mut aip = vec![AipEntry::EMPTY; (w * h) as usize];
    let mut scratch = vec![0.0; try_scratch_len(w, h).unwrap()];
    let stats = try_reproject(&mut aip, &mut scratch, &pos, c0, c1, params).unwrap();
    let mut out = Outcome {
        pixels: (w * h) as usize,
        occlusion_rejected: stats.occlusion_rejected,
        ..Outcome::default()
    };
    for y in 0..h {
        for x in 0..w {
            let d = decide(&aip[(y * w + x) as usize], x, y, 1, params);
            if d.object == INVALID_OBJECT {
                continue;
            }
            out.predicted += 1;
            let ray = c1.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (o, dir) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
            let truth = cast(scene, o, dir);
            if d.object == BACKGROUND_OBJECT {
                out.resolved += 1;
                out.errors += usize::from(truth.is_some());
                continue;
            }
            if hit_box(&scene[d.object as usize], o, dir).is_some_and(|t| t < f64::from(d.tmax)) {
                out.resolved += 1;
                let wrong = truth.map(|t| t.0) != Some(d.object);
                if wrong && std::env::var("EPI_DEBUG").is_ok() {
                    let a = aip[(y * w + x) as usize];
                    eprintln!(
                        "error at ({x}, {y}): predicted {} (cnt {}), truth {truth:?}",
                        d.object, a.cnt
                    );
                }
                out.errors += usize::from(wrong);
            }
        }
    }
    out
}

/// Only the occlusion check under test: no resampling, no abrupt-motion
/// test, no frustum check (the backward and sideways cases leave the
/// previous pyramid).
fn check_only(occlusion_check: bool) -> EpipolarOptions {
    EpipolarOptions {
        // The depth guard's margin and ring catch some occlusion errors
        // too; here the occlusion check alone is under test.
        guard_margin: 0.0,
        guard_window: 0,
        resample_period: 0,
        abrupt_frames: 0,
        frustum_check: false,
        occlusion_check,
        ..EpipolarOptions::default()
    }
}

/// Asserts that without the occlusion check the hidden box is missed
/// somewhere (the case exercises the occlusion error) and that with it
/// there is no visibility error, and that most pixels are still resolved.
fn assert_case(name: &str, c0: &Camera, c1: &Camera, expect_errors_without: bool) {
    let scene = occluder_scene();
    let with = run_pair(&scene, c0, c1, &check_only(true));
    let without = run_pair(&scene, c0, c1, &check_only(false));
    println!("{name}: with check {with:?}; without {without:?}");
    if expect_errors_without {
        assert!(
            without.errors > 0,
            "{name}: the case must exercise the occlusion error"
        );
    }
    assert_eq!(with.errors, 0, "{name}: visibility errors with the check");
    assert!(with.occlusion_rejected > 0 || !expect_errors_without);
    assert!(
        with.resolved as f64 > 0.1 * with.pixels as f64,
        "{name}: only {} of {} pixels resolved",
        with.resolved,
        with.pixels
    );
}

const W: u32 = 160;
const H: u32 = 120;

#[test]
fn epipole_inside_image_forward_motion() {
    let c0 = camera(Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.0, 1.5, -10.0), W, H);
    let c1 = camera(Vec3::new(0.9, 1.5, -2.0), Vec3::new(0.9, 1.5, -12.0), W, H);
    let e = Epipoles::of(&c0, &c1).unwrap();
    assert!(e.previous.in_front && !e.previous.at_infinity);
    assert!((0.0..W as f32).contains(&e.previous.pixel.x));
    assert!((0.0..H as f32).contains(&e.previous.pixel.y));
    assert!(e.outward() && e.increasing());
    assert!(frustum_contains(&c0, c1.eye()));
    assert_case("inside", &c0, &c1, true);
}

#[test]
fn epipole_outside_image() {
    let c0 = camera(Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.0, 1.5, -10.0), W, H);
    let c1 = camera(Vec3::new(1.5, 1.5, -1.0), Vec3::new(1.5, 1.5, -11.0), W, H);
    let e = Epipoles::of(&c0, &c1).unwrap();
    assert!(e.previous.in_front && !e.previous.at_infinity);
    assert!(e.previous.pixel.x > W as f32, "{:?}", e.previous);
    assert!(!frustum_contains(&c0, c1.eye()));
    assert_case("outside", &c0, &c1, true);
}

#[test]
fn epipole_at_infinity_lateral_motion() {
    let c0 = camera(Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.0, 1.5, -10.0), W, H);
    let c1 = camera(Vec3::new(1.5, 1.5, 0.0), Vec3::new(1.5, 1.5, -10.0), W, H);
    let e = Epipoles::of(&c0, &c1).unwrap();
    assert!(e.previous.at_infinity && e.current.at_infinity);
    // The new eye lies to the right: the epipole is far out on the right.
    assert!(e.previous.pixel.x > 1e5 && (e.previous.pixel.y - H as f32 / 2.0).abs() < 1.0);
    // The new epipole is taken behind the new camera on the same side.
    assert!(e.current.pixel.x > 1e5 && !e.current.in_front);
    assert!(e.outward() && e.increasing());
    assert!(!frustum_contains(&c0, c1.eye()));
    assert_case("infinity", &c0, &c1, false);
}

#[test]
fn backward_motion_reverses_order() {
    let c0 = camera(Vec3::new(1.0, 1.5, -1.0), Vec3::new(1.0, 1.5, -11.0), W, H);
    let c1 = camera(Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.0, 1.5, -10.0), W, H);
    let e = Epipoles::of(&c0, &c1).unwrap();
    assert!(!e.previous.in_front && e.current.in_front);
    assert!(!e.outward() && !e.increasing());
    assert!(!frustum_contains(&c0, c1.eye()));
    assert_case("backward", &c0, &c1, false);
}

#[test]
fn pure_rotation_has_no_epipoles_and_no_occlusion_error() {
    let c0 = camera(Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.0, 1.5, -10.0), W, H);
    let c1 = camera(Vec3::new(0.0, 1.5, 0.0), Vec3::new(2.0, 1.4, -10.0), W, H);
    assert!(Epipoles::of(&c0, &c1).is_none());
    assert!(frustum_contains(&c0, c1.eye()));
    let scene = occluder_scene();
    let o = run_pair(&scene, &c0, &c1, &EpipolarOptions::default());
    assert_eq!(o.errors, 0);
    // 1/9 resampled; the guard window (3 px around every silhouette of a
    // nearer object) and the surround test take about 30% more.
    assert!(o.resolved as f64 > 0.55 * o.pixels as f64, "{o:?}");
}

// ---------------------------------------------------------------------------
// The reprojection against an O(n^2) f64 re-implementation.

/// f64 reprojection oracle: pixel position via the camera's own projection
/// formula (view matrix, tangent of the half angles) and Euclidean distance.
fn project64(cam: &Camera, p: DVec3) -> Option<(f64, f64, f64)> {
    let v = cam.view().as_dmat4().transform_point3(p);
    let z = -v.z;
    if z <= 0.0 {
        return None;
    }
    let ty = (f64::from(cam.fov_y()) * 0.5).tan();
    let tx = ty * f64::from(cam.width()) / f64::from(cam.height());
    let px = (v.x / (z * tx) + 1.0) * 0.5 * f64::from(cam.width());
    let py = (1.0 - v.y / (z * ty)) * 0.5 * f64::from(cam.height());
    Some((px, py, (p - cam.eye().as_dvec3()).length()))
}

#[test]
fn reprojector_matches_f64_oracle() {
    let cams = [
        camera(
            Vec3::new(1.0, 2.0, 5.0),
            Vec3::new(0.2, 0.5, -1.0),
            640,
            360,
        ),
        camera(
            Vec3::new(-3.0, 1.0, 2.0),
            Vec3::new(4.0, 0.0, -9.0),
            97,
            211,
        ),
    ];
    for cam in cams {
        let r = Reprojector::new(&cam);
        let mut checked = 0;
        for i in 0..2000u32 {
            let f = |k: u32| {
                ((i.wrapping_mul(2_654_435_761).rotate_left(k) >> 8) as f32) / 16_777_216.0
            };
            let p = Vec3::new(f(3) * 40.0 - 20.0, f(11) * 20.0 - 10.0, f(19) * 40.0 - 30.0);
            let oracle = project64(&cam, p.as_dvec3());
            let got = r.project(p);
            match (oracle, got) {
                (None, None) => {}
                (Some(o), Some((px, t))) => {
                    // f32 error relative to the pixel offsets involved.
                    let scale = (o.0.abs() + o.1.abs() + 1.0) * 2e-5;
                    assert!((f64::from(px.x) - o.0).abs() < scale, "{p} {px} {o:?}");
                    assert!((f64::from(px.y) - o.1).abs() < scale, "{p} {px} {o:?}");
                    assert!((f64::from(t) - o.2).abs() < o.2 * 1e-6);
                    // The camera's own f32 projection agrees.
                    let c = cam.project(p).unwrap();
                    let tol = (o.0.abs() + o.1.abs() + 1.0) as f32 * 1e-4;
                    assert!((c.truncate() - px).length() < tol, "{c} {px}");
                    checked += 1;
                }
                // Points within rounding of the eye plane may go either way.
                (o, g) => {
                    let z = cam.linear_depth(p);
                    assert!(z.abs() < 1e-4, "{p}: oracle {o:?} kernel {g:?}");
                }
            }
        }
        assert!(checked > 500);
    }
}

/// The epipolar traversal by explicit sorting: quadrant, then distance of
/// the row from the epipole's row, then of the column (reversed inward).
fn order_by_sort(w: u32, h: u32, e: Vec2, outward: bool) -> Vec<Vec<(u32, u32)>> {
    let q = Quadrants::new(w, h, e, outward);
    let mut quads = vec![Vec::new(); 4];
    for y in 0..h {
        for x in 0..w {
            let left = (x as f32 + 0.5) < e.x;
            let top = (y as f32 + 0.5) < e.y;
            quads[usize::from(!top) * 2 + usize::from(!left)].push((x, y));
        }
    }
    for (i, list) in quads.iter_mut().enumerate() {
        let quad = q.get(i);
        assert_eq!(quad.len(), list.len());
        let key = |&(x, y): &(u32, u32)| {
            let dy = ((y as f32 + 0.5) - e.y).abs();
            let dx = ((x as f32 + 0.5) - e.x).abs();
            let (ky, kx) = ((dy * 4.0) as i64, (dx * 4.0) as i64);
            if outward {
                (ky, kx)
            } else {
                (-ky, -kx)
            }
        };
        list.sort_by_key(key);
    }
    quads
}

#[test]
fn quadrant_traversal_is_the_sorted_epipolar_order() {
    for (e, outward) in [
        (Vec2::new(10.3, 7.8), true),
        (Vec2::new(10.3, 7.8), false),
        (Vec2::new(-40.0, 3.0), true),
        (Vec2::new(1e6, 5.0), false),
        (Vec2::new(0.0, 0.0), true),
        (Vec2::new(17.0, 12.0), true),
    ] {
        let (w, h) = (17, 12);
        let sorted = order_by_sort(w, h, e, outward);
        let q = Quadrants::new(w, h, e, outward);
        for (i, expected) in sorted.iter().enumerate() {
            let quad = q.get(i);
            let got: Vec<(u32, u32)> = (0..quad.len()).map(|k| quad.pixel(k)).collect();
            assert_eq!(&got, expected, "epipole {e} outward {outward} quadrant {i}");
        }
    }
}

/// Alg. 1 with the occlusion check, brute force: the checks compare with a
/// scan over every earlier kept point of the quadrant instead of records.
fn reproject_brute(
    pos: &[PosEntry],
    c0: &Camera,
    c1: &Camera,
    p: &EpipolarOptions,
) -> Vec<AipEntry> {
    let (w, h) = (c1.width(), c1.height());
    let mut aip = vec![AipEntry::EMPTY; (w * h) as usize];
    let e = Epipoles::of(c0, c1).unwrap();
    let moved = (c1.eye() - c0.eye()).length();
    let order = order_by_sort(w, h, e.previous.pixel, e.outward());
    let r = p.splat_radius as i64;
    let proj = Reprojector::new(c1);
    let bins = line_bin_count(w, h);
    let (axis, theta0, scale, full) = line_bins(w, h, e.current.pixel, bins);
    for quad in order {
        // Kept points of this quadrant, in order: (bin, distance^2, t).
        let mut kept: Vec<(i64, f32, f32)> = Vec::new();
        for (x, y) in quad {
            let entry = pos[(y * w + x) as usize];
            if entry.object == INVALID_OBJECT {
                continue;
            }
            let Some((px, t)) = proj.project(entry.point()) else {
                continue;
            };
            let (cx, cy) = (px.x.floor() as i64, px.y.floor() as i64);
            if cx < -r || cy < -r || cx >= w as i64 + r || cy >= h as i64 + r {
                continue;
            }
            let flag = |aip: &mut Vec<AipEntry>, bit| {
                for iy in (cy - r).max(0)..=(cy + r).min(h as i64 - 1) {
                    for ix in (cx - r).max(0)..=(cx + r).min(w as i64 - 1) {
                        aip[(iy * w as i64 + ix) as usize].flags |= bit;
                    }
                }
            };
            if p.abrupt_frames > 0 && moved > t * 0.5 / p.abrupt_frames as f32 {
                flag(&mut aip, AipEntry::ABRUPT_REJECTED);
                continue;
            }
            let d = px - e.current.pixel;
            let (a, b) = (axis.dot(d), axis.perp_dot(d));
            let bin = ((libm::atan2f(b, a) - theta0) * scale)
                .floor()
                .clamp(0.0, (bins - 1) as f32) as i64;
            let dist = a * a + b * b;
            // Every adjacent bin's last kept point, found by scanning.
            let ok = (bin - 1..=bin + 1).all(|k| {
                let k = if full { k.rem_euclid(bins as i64) } else { k };
                match kept.iter().rev().find(|p| p.0 == k) {
                    None => true,
                    Some(&(_, kd, kt)) => {
                        let in_order = if e.increasing() {
                            dist >= kd
                        } else {
                            dist <= kd
                        };
                        in_order || kt >= t * (1.0 - OCCLUDER_GAP)
                    }
                }
            });
            if !ok {
                // Flag, and the discarded point guards other objects.
                for iy in (cy - r).max(0)..=(cy + r).min(h as i64 - 1) {
                    for ix in (cx - r).max(0)..=(cx + r).min(w as i64 - 1) {
                        let a = &mut aip[(iy * w as i64 + ix) as usize];
                        a.flags |= AipEntry::OCCLUSION_REJECTED;
                        if a.object != entry.object {
                            a.t_other = a.t_other.min(t);
                        }
                    }
                }
                continue;
            }
            kept.push((bin, dist, t));
            for iy in (cy - r).max(0)..=(cy + r).min(h as i64 - 1) {
                for ix in (cx - r).max(0)..=(cx + r).min(w as i64 - 1) {
                    let a = &mut aip[(iy * w as i64 + ix) as usize];
                    // Surround bit: which side of the center (f64).
                    let (ox, oy) = (
                        f64::from(px.x) - (ix as f64 + 0.5),
                        f64::from(px.y) - (iy as f64 + 0.5),
                    );
                    let side = match (ox >= 0.0, oy >= 0.0) {
                        (false, false) => 16,
                        (true, false) => 32,
                        (false, true) => 64,
                        (true, true) => 128,
                    };
                    if a.object == INVALID_OBJECT {
                        *a = AipEntry {
                            object: entry.object,
                            t,
                            cnt: 1,
                            flags: a.flags | side,
                            ..*a
                        };
                    } else if a.t >= t {
                        if a.object == entry.object {
                            a.cnt += 1;
                            a.flags |= side;
                        } else {
                            a.t_other = a.t_other.min(a.t);
                            a.object = entry.object;
                            a.cnt = 1;
                            a.flags = (a.flags & 0xF) | side;
                        }
                        a.t = t;
                    } else if a.object == entry.object {
                        a.cnt += 1;
                        a.flags |= side;
                    } else {
                        a.t_other = a.t_other.min(t);
                    }
                }
            }
        }
    }
    if p.depth_guard && p.guard_window > 0 {
        // Guard window, from a copy (the kernel works in place).
        let g = p.guard_window as i64;
        let before = aip.clone();
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let e = before[(y * w as i64 + x) as usize];
                if e.object == INVALID_OBJECT {
                    continue;
                }
                for ny in (y - g).max(0)..=(y + g).min(h as i64 - 1) {
                    for nx in (x - g).max(0)..=(x + g).min(w as i64 - 1) {
                        let n = before[(ny * w as i64 + nx) as usize];
                        if n.object != e.object && n.object != INVALID_OBJECT {
                            let a = &mut aip[(y * w as i64 + x) as usize];
                            a.t_other = a.t_other.min(n.t);
                        }
                    }
                }
            }
        }
    }
    aip
}

#[test]
fn reprojection_matches_brute_force_alg1_with_occlusion_check() {
    let scene = occluder_scene();
    let (w, h) = (48, 36);
    let cases = [
        (Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.3, 1.5, -0.8), true),
        (Vec3::new(0.3, 1.5, -0.8), Vec3::new(0.0, 1.5, 0.0), false),
        (Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.4, 1.6, 0.0), false),
    ];
    for (e0, e1, abrupt) in cases {
        let c0 = camera(e0, e0 + Vec3::new(0.05, -0.1, -10.0), w, h);
        let c1 = camera(e1, e1 + Vec3::new(0.0, 0.0, -10.0), w, h);
        for radius in [0, 1, 2] {
            let params = EpipolarOptions {
                frustum_check: false,
                splat_radius: radius,
                abrupt_frames: if abrupt { 9 } else { 0 },
                ..EpipolarOptions::default()
            };
            let pos = render_pos(&scene, &c0);
            let mut aip = vec![AipEntry::EMPTY; (w * h) as usize];
            let mut scratch = vec![0.0; try_scratch_len(w, h).unwrap()];
            try_reproject(&mut aip, &mut scratch, &pos, &c0, &c1, &params).unwrap();
            let brute = reproject_brute(&pos, &c0, &c1, &params);
            assert_eq!(aip, brute, "{e0} -> {e1}, radius {radius}");
        }
    }
}

#[test]
fn splat_counts_and_closer_object_overwrite() {
    // Two points: object 7 at distance ~10 then object 3 at ~5 onto the
    // same pixel; then another point of 7 (farther) does not count, another
    // point of 3 does.
    let cam = camera(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 9, 9);
    let at = |t: f32, obj: u32| PosEntry::hit(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), t, obj);
    let mut pos = vec![PosEntry::INVALID; 81];
    pos[0] = at(10.0, 7);
    pos[1] = at(5.0, 3);
    pos[2] = at(12.0, 7);
    pos[3] = at(6.0, 3);
    let mut aip = vec![AipEntry::EMPTY; 81];
    let mut scratch = vec![0.0; try_scratch_len(9, 9).unwrap()];
    let params = EpipolarOptions {
        abrupt_frames: 0,
        guard_window: 0,
        ..EpipolarOptions::default()
    };
    // Pure rotation (same eye): no occlusion ordering, row order.
    let s = try_reproject(&mut aip, &mut scratch, &pos, &cam, &cam, &params).unwrap();
    assert!(s.no_baseline);
    assert_eq!((s.points, s.splatted), (4, 4));
    // All four land on the center pixel (4, 4); the 3x3 around it is hit.
    for y in 0..9 {
        for x in 0..9 {
            let a = aip[y * 9 + x];
            if (3..=5).contains(&x) && (3..=5).contains(&y) {
                assert_eq!(
                    (a.object, a.t, a.cnt, a.t_other),
                    (3, 5.0, 2, 10.0),
                    "({x}, {y})"
                );
            } else {
                assert_eq!(a, AipEntry::EMPTY);
            }
        }
    }
    // m_cnt decides: 2 points of object 3 (without the depth guard: all
    // points landed on one side of the center, which the guard refuses).
    let d = decide(
        &aip[4 * 9 + 4],
        4,
        4,
        1,
        &EpipolarOptions {
            m_cnt: 2,
            resample_period: 0,
            depth_guard: false,
            ..params
        },
    );
    assert_eq!((d.object, d.reason), (3, Reason::Reprojected));
    assert_ne!(
        aip[4 * 9 + 4].flags & AipEntry::SURROUNDED,
        AipEntry::SURROUNDED
    );
    let d = decide(
        &aip[4 * 9 + 4],
        4,
        4,
        1,
        &EpipolarOptions {
            m_cnt: 2,
            resample_period: 0,
            ..params
        },
    );
    assert_eq!((d.object, d.reason), (INVALID_OBJECT, Reason::Failed));
    let d = decide(
        &aip[4 * 9 + 4],
        4,
        4,
        1,
        &EpipolarOptions {
            m_cnt: 3,
            resample_period: 0,
            depth_guard: false,
            ..params
        },
    );
    assert_eq!((d.object, d.reason), (INVALID_OBJECT, Reason::Failed));
}

#[test]
fn points_behind_the_new_eye_are_dropped() {
    let c0 = camera(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 8, 8);
    let c1 = camera(Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.0, 0.0, -6.0), 8, 8);
    let mut pos = vec![PosEntry::INVALID; 64];
    pos[27] = PosEntry::hit(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 3.0, 1);
    pos[28] = PosEntry::hit(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 5.0, 1);
    pos[36] = PosEntry::hit(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 9.0, 2);
    let mut aip = vec![AipEntry::EMPTY; 64];
    let mut scratch = vec![0.0; try_scratch_len(8, 8).unwrap()];
    let params = EpipolarOptions {
        abrupt_frames: 0,
        ..EpipolarOptions::default()
    };
    let s = try_reproject(&mut aip, &mut scratch, &pos, &c0, &c1, &params).unwrap();
    assert_eq!((s.points, s.behind, s.splatted), (3, 2, 1));
    assert!(aip
        .iter()
        .all(|a| a.object == INVALID_OBJECT || a.object == 2));
}

#[test]
fn frustum_check_skips_reprojection() {
    let scene = occluder_scene();
    let c0 = camera(Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.0, 1.5, -10.0), 32, 24);
    let c1 = camera(Vec3::new(0.0, 1.5, 0.5), Vec3::new(0.0, 1.5, -10.0), 32, 24);
    assert!(!frustum_contains(&c0, c1.eye()));
    assert!(frustum_contains(&c1, c0.eye()));
    assert!(!frustum_contains(&c0, Vec3::NAN));
    let pos = render_pos(&scene, &c0);
    let mut aip = vec![AipEntry::EMPTY; 32 * 24];
    let mut scratch = vec![0.0; try_scratch_len(32, 24).unwrap()];
    let s = try_reproject(
        &mut aip,
        &mut scratch,
        &pos,
        &c0,
        &c1,
        &EpipolarOptions::default(),
    )
    .unwrap();
    assert!(s.frustum_failed);
    assert!(aip.iter().all(|a| *a == AipEntry::UNAVAILABLE));
    let d = decide(&aip[0], 0, 0, 3, &EpipolarOptions::default());
    assert_eq!(
        (d.object, d.tmin, d.reason),
        (INVALID_OBJECT, 0.0, Reason::Unavailable)
    );
}

#[test]
fn abrupt_motion_discards_near_points() {
    let c0 = camera(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 8, 8);
    let c1 = camera(Vec3::new(0.0, 0.0, -0.2), Vec3::new(0.0, 0.0, -1.2), 8, 8);
    let dir = Vec3::new(0.0, 0.0, -1.0);
    let mut pos = vec![PosEntry::INVALID; 64];
    // New distances 1.3 and 2.8 after a 0.2 move: delta = t / 2 / N is
    // 0.1625 and 0.35 for N = 4, 0.072 and 0.156 for N = 9.
    pos[27] = PosEntry::hit(Vec3::ZERO, dir, 1.5, 1);
    pos[36] = PosEntry::hit(Vec3::ZERO, dir, 3.0, 2);
    let mut aip = vec![AipEntry::EMPTY; 64];
    let mut scratch = vec![0.0; try_scratch_len(8, 8).unwrap()];
    for (n, rejected) in [(4, 1), (9, 2), (0, 0)] {
        let params = EpipolarOptions {
            abrupt_frames: n,
            ..EpipolarOptions::default()
        };
        let s = try_reproject(&mut aip, &mut scratch, &pos, &c0, &c1, &params).unwrap();
        assert_eq!(s.abrupt_rejected, rejected, "N = {n}");
        if rejected > 0 {
            let flagged = aip
                .iter()
                .filter(|a| a.flags & AipEntry::ABRUPT_REJECTED != 0)
                .count();
            assert_eq!(flagged, 9);
            let d = decide(
                &aip[4 * 8 + 4],
                4,
                4,
                1,
                &EpipolarOptions {
                    resample_period: 0,
                    ..params
                },
            );
            assert_eq!(d.reason, Reason::Abrupt);
        }
    }
}

#[test]
fn regular_resampling_slots_are_disjoint_and_cover_the_image() {
    for n in [1u32, 2, 4, 5, 9, 16] {
        let (w, h) = (36u32, 18u32);
        let mut counts = vec![0usize; n as usize];
        for y in 0..h {
            for x in 0..w {
                let s = resample_slot(x, y, n);
                assert!(s < n);
                counts[s as usize] += 1;
            }
        }
        // Every pixel exactly once in n frames; near-equal shares.
        let (lo, hi) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
        assert!(hi - lo <= (w as usize), "n = {n}: {counts:?}");
        if n == 9 {
            assert!(counts.iter().all(|&c| c == (w * h / 9) as usize));
            // Each 3x3 window holds every slot once.
            let mut seen = [false; 9];
            for y in 3..6 {
                for x in 6..9 {
                    seen[resample_slot(x, y, 9) as usize] = true;
                }
            }
            assert!(seen.iter().all(|&s| s));
        }
    }
    assert_eq!(resample_slot(3, 4, 0), u32::MAX);
    // Frame k resamples exactly the pixels of slot k mod N.
    let aip = AipEntry {
        object: 1,
        t: 2.0,
        cnt: 9,
        t_other: f32::INFINITY,
        flags: AipEntry::SURROUNDED,
    };
    let p = EpipolarOptions::default();
    let mut resampled = 0;
    for frame in 0..9 {
        let d = decide(&aip, 4, 7, frame, &p);
        if d.reason == Reason::Resampled {
            resampled += 1;
            assert_eq!(d.object, INVALID_OBJECT);
        } else {
            assert_eq!((d.object, d.reason), (1, Reason::Reprojected));
        }
    }
    assert_eq!(resampled, 1);
}

#[test]
fn shifted_origin_for_fallback_rays() {
    let aip = AipEntry {
        object: 4,
        t: 7.5,
        cnt: 2,
        t_other: 9.0,
        flags: 0,
    };
    let p = EpipolarOptions {
        shift_origin: true,
        shift_epsilon: 0.25,
        resample_period: 0,
        ..EpipolarOptions::default()
    };
    let d = decide(&aip, 0, 0, 0, &p);
    assert_eq!(
        (d.object, d.tmin, d.reason),
        (INVALID_OBJECT, 7.25, Reason::Failed)
    );
    // Off by default; never for the background sphere; never below 0.
    assert_eq!(
        decide(
            &aip,
            0,
            0,
            0,
            &EpipolarOptions {
                shift_origin: false,
                ..p
            }
        )
        .tmin,
        0.0
    );
    let bg = AipEntry {
        object: BACKGROUND_OBJECT,
        ..aip
    };
    assert_eq!(decide(&bg, 0, 0, 0, &p).tmin, 0.0);
    let near = AipEntry { t: 0.1, ..aip };
    assert_eq!(decide(&near, 0, 0, 0, &p).tmin, 0.0);
}

#[test]
fn background_sphere_is_reprojected_like_an_object() {
    // Nothing in the scene: every pixel stores a background point; after a
    // small forward move every pixel away from the border is predicted
    // background.
    let c0 = camera(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 40, 30);
    let c1 = camera(Vec3::new(0.0, 0.0, -0.1), Vec3::new(0.0, 0.0, -1.1), 40, 30);
    let pos = render_pos(&[], &c0);
    assert!(pos
        .iter()
        .all(|p| p.object == BACKGROUND_OBJECT && p.t == BACKGROUND_RADIUS));
    let mut aip = vec![AipEntry::EMPTY; 40 * 30];
    let mut scratch = vec![0.0; try_scratch_len(40, 30).unwrap()];
    let p = EpipolarOptions {
        resample_period: 0,
        ..EpipolarOptions::default()
    };
    try_reproject(&mut aip, &mut scratch, &pos, &c0, &c1, &p).unwrap();
    for y in 1..29 {
        for x in 1..39 {
            let d = decide(&aip[y * 40 + x], x as u32, y as u32, 1, &p);
            assert_eq!(d.object, BACKGROUND_OBJECT, "({x}, {y})");
        }
    }
}

#[test]
fn epipole_matches_projection_of_the_other_eye() {
    let c0 = camera(
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(-2.0, 1.0, -8.0),
        200,
        100,
    );
    for other in [
        Vec3::new(0.5, 1.9, 1.0),
        Vec3::new(1.2, 2.1, 5.0),
        Vec3::new(-9.0, 0.0, -30.0),
    ] {
        let e = Epipole::of(&c0, other).unwrap();
        let z = c0.linear_depth(other);
        assert_eq!(e.in_front, z > 0.0);
        // The projection of the eye through the other point: either the
        // camera's own projection (in front) or that of the point mirrored
        // through the eye (behind), which lands on the same pixel.
        let p = if z > 0.0 {
            other
        } else {
            2.0 * c0.eye() - other
        };
        let q = c0.project(p).unwrap();
        assert!(
            (q.truncate() - e.pixel).length() < 1e-2 * (1.0 + q.truncate().length() * 1e-3),
            "{q} {e:?}"
        );
    }
    assert!(Epipole::of(&c0, c0.eye()).is_none());
}

#[test]
fn bad_input_is_refused_and_outputs_untouched() {
    let c0 = camera(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 8, 8);
    let c_other = camera(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 8, 9);
    let pos = vec![PosEntry::INVALID; 64];
    let mut aip = vec![
        AipEntry {
            object: 42,
            t: 1.0,
            cnt: 3,
            t_other: 2.0,
            flags: 0
        };
        64
    ];
    let mut scratch = vec![0.0; try_scratch_len(8, 8).unwrap()];
    let p = EpipolarOptions::default();
    let before = aip.clone();
    assert_eq!(
        try_reproject(&mut aip, &mut scratch, &pos[..63], &c0, &c0, &p),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_reproject(&mut aip[..63], &mut scratch, &pos, &c0, &c0, &p),
        Err(Error::InsufficientSize)
    );
    let short = scratch.len() - 1;
    assert_eq!(
        try_reproject(&mut aip, &mut scratch[..short], &pos, &c0, &c0, &p),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_reproject(&mut aip, &mut scratch, &pos, &c0, &c_other, &p),
        Err(Error::InvalidArgument)
    );
    for bad in [
        EpipolarOptions { m_cnt: 0, ..p },
        EpipolarOptions {
            splat_radius: 4,
            ..p
        },
        EpipolarOptions {
            shift_epsilon: f32::NAN,
            ..p
        },
        EpipolarOptions {
            shift_epsilon: -1.0,
            ..p
        },
        EpipolarOptions {
            shift_epsilon: f32::INFINITY,
            ..p
        },
    ] {
        assert_eq!(
            try_reproject(&mut aip, &mut scratch, &pos, &c0, &c0, &bad),
            Err(Error::InvalidArgument)
        );
    }
    assert_eq!(aip, before);
    assert_eq!(try_scratch_len(0, 4), Err(Error::InvalidArgument));
    // Decisions for a row band.
    let empty = Decision {
        object: 9,
        tmin: 9.0,
        tmax: 9.0,
        reason: Reason::Failed,
    };
    let mut out = vec![empty; 64];
    let rows = RowRange::try_new(2, 5, 8).unwrap();
    assert_eq!(
        try_decide_rows(&mut out[..39], &aip, 8, rows, 0, &p),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        try_decide_rows(&mut out, &aip, 0, rows, 0, &p),
        Err(Error::InvalidArgument)
    );
    assert!(out.iter().all(|d| *d == empty));
    try_decide_rows(&mut out, &aip, 8, rows, 0, &p).unwrap();
    for (i, d) in out.iter().enumerate() {
        let y = i / 8;
        if (2..5).contains(&y) {
            assert_eq!(*d, decide(&aip[i], (i % 8) as u32, y as u32, 0, &p));
        } else {
            assert_eq!(*d, empty);
        }
    }
}

#[test]
fn depth_guard_margin_and_background_guard() {
    let p = EpipolarOptions {
        resample_period: 0,
        ..EpipolarOptions::default()
    };
    let entry = AipEntry {
        object: 3,
        t: 9.0,
        cnt: 9,
        t_other: 10.0,
        flags: AipEntry::SURROUNDED,
    };
    // The one-object interval ends a relative margin before the nearest
    // point of another object.
    let d = decide(&entry, 0, 0, 0, &p);
    assert_eq!(d.object, 3);
    assert_eq!(d.tmax, 10.0 * (1.0 - p.guard_margin));
    assert!(d.tmax < 10.0 && p.guard_margin > 0.0);
    let d0 = decide(
        &entry,
        0,
        0,
        0,
        &EpipolarOptions {
            guard_margin: 0.0,
            ..p
        },
    );
    assert_eq!(d0.tmax, 10.0);
    // A background prediction next to another object's point: traverse.
    let bg = AipEntry {
        object: BACKGROUND_OBJECT,
        t: 1000.0,
        ..entry
    };
    assert_eq!(decide(&bg, 0, 0, 0, &p).reason, Reason::Failed);
    let alone = AipEntry {
        t_other: f32::INFINITY,
        ..bg
    };
    let d = decide(&alone, 0, 0, 0, &p);
    assert_eq!(
        (d.object, d.reason),
        (BACKGROUND_OBJECT, Reason::Reprojected)
    );
    // Out-of-range margins are refused.
    for m in [f32::NAN, 1.0, -0.1, f32::INFINITY] {
        let bad = EpipolarOptions {
            guard_margin: m,
            ..p
        };
        assert!(bad.try_validate().is_err(), "{m}");
    }
}

#[test]
fn predictions_must_surround_the_pixel_center() {
    // Pure rotation (same camera): object 1 covers an L (x < 4 or y < 4)
    // of a 12 x 12 image, nothing elsewhere. Pixel (4, 4), in the concave
    // corner, gets 5 points (cnt = m_cnt) but all on its upper and left
    // sides, none below-right: its center is outside the object. Interior pixels are
    // surrounded.
    let (w, h) = (12u32, 12u32);
    let cam = camera(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), w, h);
    let mut pos = vec![PosEntry::INVALID; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            if x < 4 || y < 4 {
                let ray = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                pos[(y * w + x) as usize] = PosEntry::hit(ray.origin, ray.dir, 5.0, 1);
            }
        }
    }
    let params = EpipolarOptions {
        resample_period: 0,
        abrupt_frames: 0,
        ..EpipolarOptions::default()
    };
    let mut aip = vec![AipEntry::EMPTY; (w * h) as usize];
    let mut scratch = vec![0.0; try_scratch_len(w, h).unwrap()];
    try_reproject(&mut aip, &mut scratch, &pos, &cam, &cam, &params).unwrap();
    let corner = aip[(4 * w + 4) as usize];
    assert_eq!((corner.object, corner.cnt), (1, 5));
    // Below-left (64) and above-right (32) are reached, below-right not.
    assert_eq!(corner.flags & AipEntry::SURROUNDED, 16 | 32 | 64);
    let d = decide(&corner, 4, 4, 0, &params);
    assert_eq!((d.object, d.reason), (INVALID_OBJECT, Reason::Failed));
    let unguarded = EpipolarOptions {
        depth_guard: false,
        ..params
    };
    assert_eq!(
        decide(&corner, 4, 4, 0, &unguarded).reason,
        Reason::Reprojected
    );
    // Interior pixels: every side reached, one test of object 1.
    for (x, y) in [(1u32, 1u32), (2, 6), (6, 2), (10, 1), (1, 10)] {
        let a = aip[(y * w + x) as usize];
        assert_eq!(
            a.flags & AipEntry::SURROUNDED,
            AipEntry::SURROUNDED,
            "({x}, {y})"
        );
        let d = decide(&a, x, y, 0, &params);
        assert_eq!((d.object, d.reason), (1, Reason::Reprojected), "({x}, {y})");
    }
    // Every one-object decision is a pixel whose own ray sees object 1.
    for y in 0..h {
        for x in 0..w {
            let d = decide(&aip[(y * w + x) as usize], x, y, 0, &params);
            if d.reason == Reason::Reprojected {
                assert!(x < 4 || y < 4, "({x}, {y}) predicted outside the object");
            }
        }
    }
}
