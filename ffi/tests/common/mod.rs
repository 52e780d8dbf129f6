//! Shared by the pass tests of refl-ffi (included with `mod common;`): a
//! counting global allocator (no export may allocate) and the scene they
//! run on, a floor `y = 0` and a unit sphere at `(0, 1, 0)` rendered
//! exactly.
#![allow(dead_code)]

use refl_core::glam::{DVec3, Vec2, Vec3};
use refl_core::{Camera, DepthConvention};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// Counts allocations made by the current thread while `COUNTING` is set.
struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator; the counters are thread-local
// cells that do not allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        let _ = COUNTING.try_with(|c| {
            if c.get() {
                let _ = ALLOCS.try_with(|a| a.set(a.get() + 1));
            }
        });
        // SAFETY: forwarded contract.
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        // SAFETY: forwarded contract.
        unsafe { System.dealloc(p, l) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Runs `f` and returns its result with the number of allocations it made.
pub fn counted<R>(f: impl FnOnce() -> R) -> (R, u64) {
    ALLOCS.with(|a| a.set(0));
    COUNTING.with(|c| c.set(true));
    let r = f();
    COUNTING.with(|c| c.set(false));
    (r, ALLOCS.with(|a| a.get()))
}

/// Image width of the scene.
pub const W: u32 = 96;
/// Image height of the scene.
pub const H: u32 = 64;

/// The scene's camera.
pub fn camera() -> Camera {
    Camera::try_look_at(
        Vec3::new(0.3, 2.0, 5.5),
        Vec3::new(0.0, 0.6, 0.0),
        Vec3::Y,
        1.0,
        0.1,
        50.0,
        W,
        H,
    )
    .unwrap()
}

/// The scene as a G-buffer would hold it.
pub struct Frame {
    pub cam: Camera,
    pub conv: DepthConvention,
    pub depth: Vec<f32>,
    /// The sphere's exit depth (a back-face pass); the far plane behind
    /// the one-sided floor.
    pub back: Vec<f32>,
    pub normals: Vec<[f32; 3]>,
    /// `(object id, x / W, y / H)`.
    pub color: Vec<[f32; 3]>,
    /// 0 the floor, 1 the sphere, `u32::MAX` nothing.
    pub ids: Vec<u32>,
}

/// The floor `y = 0` and a unit sphere at `(0, 1, 0)`, rendered exactly in
/// convention `conv`.
pub fn render(conv: DepthConvention) -> Frame {
    let cam = camera();
    let n = (W * H) as usize;
    let far = cam.encode_depth(cam.far(), conv);
    let mut f = Frame {
        cam,
        conv,
        depth: vec![far; n],
        back: vec![far; n],
        normals: vec![[0.0; 3]; n],
        color: vec![[0.0; 3]; n],
        ids: vec![u32::MAX; n],
    };
    let eye = cam.eye().as_dvec3();
    let fwd = -cam.inverse_view().z_axis.truncate().as_dvec3();
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let d = cam
                .primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
                .dir
                .as_dvec3()
                .normalize();
            let c = DVec3::new(0.0, 1.0, 0.0);
            let oc = eye - c;
            let b = oc.dot(d);
            let disc = b * b - (oc.dot(oc) - 1.0);
            let mut best: Option<(f64, f64, DVec3, u32)> = None;
            if disc > 0.0 {
                let s = disc.sqrt();
                let t = -b - s;
                best = Some((t, -b + s, (eye + d * t - c).normalize(), 1));
            }
            if d.y < 0.0 {
                let t = -eye.y / d.y;
                if best.is_none_or(|(bt, ..)| t < bt) {
                    best = Some((t, f64::INFINITY, DVec3::Y, 0));
                }
            }
            if let Some((t, te, nn, id)) = best {
                let z = (t * d.dot(fwd)) as f32;
                let zb = ((te * d.dot(fwd)) as f32).min(cam.far());
                f.depth[i] = cam.encode_depth(z, conv);
                f.back[i] = cam.encode_depth(zb, conv);
                f.normals[i] = nn.as_vec3().to_array();
                f.color[i] = [id as f32, x as f32 / W as f32, y as f32 / H as f32];
                f.ids[i] = id;
            }
        }
    }
    f
}

/// A convention as the C ABI's `uint32_t`.
pub fn conv_c(c: DepthConvention) -> u32 {
    match c {
        DepthConvention::Linear => 0,
        DepthConvention::ZeroToOne => 1,
        DepthConvention::ReversedZ => 2,
    }
}
