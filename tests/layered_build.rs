//! Layered depth cube maps built from scene meshes with obvhs (seed 001
//! Sec. 3.3-3.4) against obvhs itself: rays traced through the map agree
//! with closest hits on the object alone.

use glam::Vec3;
use refl_app::layered::{build, object_tracer, trace_rays};
use refl_app::scene::Scene;
use refl_core::layered::LayeredOptions;
use refl_core::Ray;

fn pool() -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
}

/// SplitMix64 in [0, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

struct Agreement {
    rays: usize,
    agree: usize,
    both: usize,
    /// Hit-point distances of rays that hit in both, in texels, sorted.
    err: Vec<f32>,
    fetches: f64,
}

impl Agreement {
    fn rate(&self) -> f64 {
        self.agree as f64 / self.rays as f64
    }
    fn q(&self, q: f64) -> f32 {
        self.err[((self.err.len() - 1) as f64 * q) as usize]
    }
}

/// Builds the map of the object named `name` and compares `n` rays aimed at
/// its box with obvhs hits on the object alone.
fn compare(scene: &Scene, name: &str, res: u32, layers: u32, n: usize) -> Agreement {
    let id = scene.objects.iter().position(|o| o.name == name).unwrap() as u32;
    let pool = pool();
    let obj = build(scene, id, res, layers, &pool).unwrap();
    println!(
        "{name}: res {res} L {layers}: {} columns, {} crossings, {} approximate, {:.1} ms",
        obj.columns, obj.crossings, obj.approx_columns, obj.build_ms
    );
    let (tracer, o) = object_tracer(scene, id).unwrap();
    let b = o.bounds;
    let (c, ext) = (b.center(), b.max - b.min);
    let mut rng = Rng(17);
    let rays: Vec<Ray> = (0..n)
        .map(|_| {
            let dir = loop {
                let v = Vec3::new(rng.next(), rng.next(), rng.next()) * 2.0 - 1.0;
                if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                    break v.normalize();
                }
            };
            let origin = c + dir * 2.0 * b.diagonal();
            let target = b.min + Vec3::new(rng.next(), rng.next(), rng.next()) * ext;
            Ray {
                origin,
                dir: (target - origin).normalize(),
            }
        })
        .collect();
    let params = LayeredOptions::default();
    let got = trace_rays(&obj, &rays, f32::INFINITY, &params, &pool).unwrap();
    let tex = ((obj.grid.max() - obj.grid.min()).max_element() / res as f32).max(1e-30);
    let mut a = Agreement {
        rays: n,
        agree: 0,
        both: 0,
        err: Vec::new(),
        fetches: 0.0,
    };
    for (r, g) in rays.iter().zip(&got) {
        a.fetches += g.work().fetches as f64 / n as f64;
        let truth = tracer.trace(r.origin, r.dir, 0.0, f32::INFINITY);
        match (truth, g.hit()) {
            (Some(t), Some(h)) => {
                a.agree += 1;
                a.both += 1;
                a.err.push((h.position - r.at(t.t)).length() / tex);
            }
            (None, None) => a.agree += 1,
            _ => {}
        }
    }
    a.err.sort_by(f32::total_cmp);
    println!(
        "{name}: agreement {:.4} over {} rays ({} hits), error texels p50 {:.3} p95 {:.3} p99 {:.3} max {:.3}, fetches/ray {:.1}",
        a.rate(),
        a.rays,
        a.both,
        a.q(0.5),
        a.q(0.95),
        a.q(0.99),
        a.q(1.0),
        a.fetches
    );
    a
}

#[test]
fn convex_sphere_map_agrees_with_obvhs() {
    let scene = Scene::room(20_000);
    let a = compare(&scene, "green_sphere", 96, 1, 4000);
    assert!(a.rate() >= 0.99, "agreement {}", a.rate());
    assert!(a.both > 1000);
    assert!(a.q(0.95) <= 0.25);
    assert!(a.q(0.99) <= 1.0);
    // Empty space is skipped (half-texel steps alone read ~10x more).
    assert!(a.fetches <= 200.0, "{}", a.fetches);
}

#[test]
fn concave_arch_map_agrees_with_obvhs() {
    let scene = Scene::concave(20_000);
    let many = compare(&scene, "arch", 96, 4, 4000);
    assert!(many.rate() >= 0.99, "agreement {}", many.rate());
    assert!(many.both > 1000);
    assert!(many.q(0.95) <= 0.25);
    assert!(many.q(0.99) <= 1.0);
    // One layer fills the arch's opening along some axes: approximate.
    let one = compare(&scene, "arch", 96, 1, 4000);
    assert!(
        one.rate() < many.rate(),
        "{} vs {}",
        one.rate(),
        many.rate()
    );
}

#[test]
fn unknown_objects_and_zero_sizes_are_rejected() {
    let scene = Scene::room(20_000);
    let pool = pool();
    assert!(build(&scene, scene.objects.len() as u32, 8, 1, &pool).is_err());
    assert!(build(&scene, 0, 0, 1, &pool).is_err());
}

/// `layers = 0` follows the object's depth complexity (seed 001 Table 1):
/// a convex sphere gets one layer, the arch (two solid intervals along
/// some columns) more, and no column of either is approximated; the auto
/// map agrees with obvhs as well as the hand-picked four layers do.
#[test]
fn auto_layers_follow_the_depth_complexity() {
    let pool = pool();
    let room = Scene::room(20_000);
    let sphere = room
        .objects
        .iter()
        .position(|o| o.name == "green_sphere")
        .unwrap() as u32;
    let s = build(&room, sphere, 64, 0, &pool).unwrap();
    assert_eq!((s.grid.layers(), s.approx_columns), (1, 0));
    let concave = Scene::concave(20_000);
    let arch = concave
        .objects
        .iter()
        .position(|o| o.name == "arch")
        .unwrap() as u32;
    let a = build(&concave, arch, 96, 0, &pool).unwrap();
    assert!(a.grid.layers() >= 2 && a.grid.layers() <= refl_app::layered::MAX_AUTO_LAYERS);
    assert_eq!(a.approx_columns, 0, "{} layers", a.grid.layers());
    // One layer fewer would approximate some column.
    let fewer = build(&concave, arch, 96, a.grid.layers() - 1, &pool).unwrap();
    assert!(fewer.approx_columns > 0);
    let auto = compare(&concave, "arch", 96, 0, 4000);
    let four = compare(&concave, "arch", 96, 4, 4000);
    assert!(
        auto.rate() >= four.rate() - 1e-9,
        "{} vs {}",
        auto.rate(),
        four.rate()
    );
}
