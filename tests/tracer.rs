//! The obvhs reference tracer against an f64 brute-force oracle.

use glam::{DVec3, Vec3};
use refl_app::scene::Scene;
use refl_app::tracer::{ray_triangle_plane, TraceCount, Tracer};

/// xorshift64*: deterministic test randomness.
struct Rng(u64);

impl Rng {
    fn next_f32(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn unit_vector(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.next_f32(), self.next_f32(), self.next_f32()) * 2.0 - 1.0;
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

/// Möller–Trumbore in f64 on the f32 vertices: `t` if the ray hits.
fn brute_t(tri: &[Vec3; 3], o: DVec3, d: DVec3) -> Option<f64> {
    let [a, b, c] = tri.map(|p| p.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
}

fn brute_closest(scene: &Scene, o: Vec3, d: Vec3) -> Option<(u32, f64)> {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    scene
        .tris
        .iter()
        .enumerate()
        .filter_map(|(i, t)| brute_t(t, o, d).map(|t| (i as u32, t)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// Rays from random points inside the scene bounds in random directions,
/// plus rays from the path's eyes toward random points.
fn rays(scene: &Scene, n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = Rng(seed);
    let b = scene.bounds();
    let point = |rng: &mut Rng| {
        b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())
    };
    (0..n)
        .map(|k| {
            if k % 2 == 0 {
                (point(&mut rng), rng.unit_vector())
            } else {
                let eye = scene.camera_path[k % scene.camera_path.len()].eye;
                let target = point(&mut rng);
                (eye, (target - eye).normalize())
            }
        })
        .collect()
}

fn check_against_brute_force(scene: &Scene, n: usize, seed: u64) {
    let tracer = Tracer::new(scene);
    let mut hits = 0;
    for (o, d) in rays(scene, n, seed) {
        let got = tracer.trace(o, d, 0.0, f32::INFINITY);
        let want = brute_closest(scene, o, d);
        match (got, want) {
            (None, None) => {}
            (Some(h), Some((prim, t))) => {
                hits += 1;
                let rel = (f64::from(h.t) - t).abs() / t.max(1e-3);
                assert!(rel < 1e-4, "t {} vs {t} (prim {} vs {prim})", h.t, h.prim);
                if h.prim != prim {
                    // A tie: the tracer's primitive is hit at the same distance.
                    let tie = brute_t(&scene.tris[h.prim as usize], o.as_dvec3(), d.as_dvec3())
                        .is_some_and(|t2| (t2 - t).abs() / t.max(1e-3) < 1e-4);
                    assert!(tie, "prim {} vs {prim} at t {t}", h.prim);
                }
                // Barycentrics reproduce the hit point.
                let [a, b, c] = scene.tris[h.prim as usize];
                let p = a * (1.0 - h.u - h.v) + b * h.u + c * h.v;
                assert!(p.distance(o + d * h.t) < 1e-4 * scene.diameter());
            }
            (got, want) => panic!("tracer {got:?} vs brute force {want:?} for ray {o} {d}"),
        }
    }
    assert!(
        hits > n / 4,
        "too few hits ({hits}) to be a meaningful test"
    );
}

#[test]
fn closest_hits_match_brute_force_room() {
    check_against_brute_force(&Scene::room(3_000), 2_000, 1);
}

#[test]
fn closest_hits_match_brute_force_concave() {
    check_against_brute_force(&Scene::concave(3_000), 2_000, 2);
}

#[test]
fn closest_hits_match_brute_force_walkthrough() {
    check_against_brute_force(&Scene::walkthrough(6_000), 2_000, 3);
}

#[test]
fn ray_interval_and_occlusion() {
    let scene = Scene::room(5_000);
    let tracer = Tracer::new(&scene);
    for (o, d) in rays(&scene, 2_000, 4) {
        let hit = tracer.trace(o, d, 0.0, f32::INFINITY);
        assert_eq!(tracer.occluded(o, d, 0.0, f32::INFINITY), hit.is_some());
        let Some(h) = hit else { continue };
        // Nothing closer than the closest hit; the hit itself within a
        // slightly longer interval.
        assert!(!tracer.occluded(o, d, 0.0, h.t * (1.0 - 1e-4)));
        assert!(tracer.occluded(o, d, 0.0, h.t * (1.0 + 1e-4)));
        assert!(tracer.trace(o, d, 0.0, h.t * (1.0 - 1e-4)).is_none());
        // Starting past the hit finds a farther one, or nothing.
        if let Some(far) = tracer.trace(o, d, h.t * (1.0 + 1e-4), f32::INFINITY) {
            assert!(far.t > h.t);
        }
        // Plane reconstruction of the same primitive agrees.
        let r = ray_triangle_plane(&scene.tris[h.prim as usize], h.prim, o, d).unwrap();
        assert!((r.t - h.t).abs() <= 1e-5 * h.t.max(1.0));
        assert!((r.u - h.u).abs() < 1e-4 && (r.v - h.v).abs() < 1e-4);
    }
}

#[test]
fn empty_scene_traces_nothing() {
    let mut scene = Scene::room(2_000);
    scene.tris.clear();
    let tracer = Tracer::new(&scene);
    assert!(tracer
        .trace(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY)
        .is_none());
    assert!(!tracer.occluded(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY));
}

/// `trace_counted` returns `trace`'s hits bit for bit and counts what the
/// traversal did: at least one node (the root) per ray, at least one
/// triangle test per hit, never more tests than triangles; a ray that
/// starts with a shorter interval visits no more nodes and tests no more
/// triangles (every box and triangle test is at least as strict, in the
/// same order); one triangle is tested exactly once when hit.
#[test]
fn counted_traces_equal_traces_and_count_the_work() {
    let scene = Scene::room(5_000);
    let tracer = Tracer::new(&scene);
    let mut total = TraceCount::default();
    for (o, d) in rays(&scene, 2_000, 5) {
        let mut c = TraceCount::default();
        let got = tracer.trace_counted(o, d, 0.0, f32::INFINITY, &mut c);
        let want = tracer.trace(o, d, 0.0, f32::INFINITY);
        assert_eq!(
            got.map(|h| (h.prim, h.t.to_bits(), h.u.to_bits(), h.v.to_bits())),
            want.map(|h| (h.prim, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()))
        );
        assert_eq!(c.rays, 1);
        assert!(c.steps >= 1, "the root node is visited");
        assert!(c.tests <= scene.tris.len() as u64);
        if let Some(h) = got {
            assert!(c.tests >= 1);
            let mut short = TraceCount::default();
            let tmax = h.t * (1.0 - 1e-4);
            assert!(tracer.trace_counted(o, d, 0.0, tmax, &mut short).is_none());
            assert!(
                short.steps <= c.steps && short.tests <= c.tests,
                "{short:?} vs {c:?}"
            );
        }
        total = total + c;
    }
    assert_eq!(total.rays, 2_000);
    assert!(total.tests_per_ray(total.rays) > 1.0);
    assert_eq!(TraceCount::default().tests_per_ray(0), 0.0);

    // One triangle: tested exactly once by a ray through it.
    let mut one = Scene::room(2_000);
    one.tris = vec![[
        Vec3::new(-1.0, -1.0, -5.0),
        Vec3::new(1.0, -1.0, -5.0),
        Vec3::new(0.0, 1.0, -5.0),
    ]];
    one.normals = vec![one.normals[0]];
    one.tri_object = vec![0];
    let t1 = Tracer::new(&one);
    let mut c = TraceCount::default();
    let h = t1.trace_counted(Vec3::ZERO, Vec3::NEG_Z, 0.0, f32::INFINITY, &mut c);
    assert!(h.is_some_and(|h| (h.t - 5.0).abs() < 1e-5));
    assert_eq!((c.rays, c.tests), (1, 1));
    let mut c = TraceCount::default();
    assert!(t1
        .trace_counted(Vec3::ZERO, Vec3::Z, 0.0, f32::INFINITY, &mut c)
        .is_none());
    assert_eq!(c.tests, 0, "a ray away from the only box tests no triangle");
}
