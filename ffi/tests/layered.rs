//! The layered-depth-map exports against refl-core: same buffers, same
//! traces, same PRR classes; every error path returns its status and
//! leaves outputs untouched.

use core::mem::MaybeUninit;
use refl::*;
use refl_core::glam::{Affine3A, Mat4, Vec3};
use refl_core::layered::{LayerHit, LayeredGrid, LayeredMap, LayeredMapMut, LayeredOptions};
use refl_core::{try_prr_classify, Face, Ray};

fn v3(v: Vec3) -> refl_vec3 {
    v.into()
}

fn ok<T>(f: impl FnOnce(*mut T) -> refl_status) -> T {
    let mut v = MaybeUninit::<T>::uninit();
    assert_eq!(f(v.as_mut_ptr()), refl_status::Ok);
    // SAFETY: the function returned OK, so it wrote the output.
    unsafe { v.assume_init() }
}

fn grid_c(res: u32, layers: u32) -> refl_layered_grid {
    refl_layered_grid {
        min: v3(Vec3::splat(-1.05)),
        max: v3(Vec3::splat(1.05)),
        face_res: res,
        layers,
        world_from_local: Mat4::IDENTITY.into(),
    }
}

/// Unit-sphere crossings of a column ray, in f64.
fn sphere_hits(o: Vec3, d: Vec3, t_max: f32) -> Vec<(f32, bool)> {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let b = o.dot(d);
    let c = o.dot(o) - 1.0;
    let disc = b * b - c;
    if disc <= 0.0 {
        return vec![];
    }
    let s = disc.sqrt();
    [(-b - s, true), (-b + s, false)]
        .into_iter()
        .filter(|(t, _)| *t >= 0.0 && *t <= t_max as f64)
        .map(|(t, f)| (t as f32, f))
        .collect()
}

struct Bufs {
    depth: Vec<f32>,
    payload: Vec<u32>,
    counts: Vec<u32>,
    bounds: Vec<f32>,
}

impl Bufs {
    fn new(g: &refl_layered_grid) -> Self {
        let l: refl_layered_sizes = ok(|o| unsafe { refl_layered_len(o, g.face_res, g.layers) });
        Bufs {
            depth: vec![7.0; l.depth_len],
            payload: vec![7; l.payload_len],
            counts: vec![7; l.counts_len],
            bounds: vec![7.0; l.bounds_len],
        }
    }
    fn map_mut(&mut self, g: refl_layered_grid) -> refl_layered_map_mut {
        refl_layered_map_mut {
            grid: g,
            depth: self.depth.as_mut_ptr(),
            depth_len: self.depth.len(),
            payload: self.payload.as_mut_ptr(),
            payload_len: self.payload.len(),
            counts: self.counts.as_mut_ptr(),
            counts_len: self.counts.len(),
            bounds: self.bounds.as_mut_ptr(),
            bounds_len: self.bounds.len(),
        }
    }
    fn map(&self, g: refl_layered_grid) -> refl_layered_map {
        refl_layered_map {
            grid: g,
            depth: self.depth.as_ptr(),
            depth_len: self.depth.len(),
            payload: self.payload.as_ptr(),
            payload_len: self.payload.len(),
            counts: self.counts.as_ptr(),
            counts_len: self.counts.len(),
            bounds: self.bounds.as_ptr(),
            bounds_len: self.bounds.len(),
        }
    }
}

/// Fills a sphere map through `refl_layered_fill_face` (CSR hits).
fn build_c(g: refl_layered_grid) -> Bufs {
    let mut b = Bufs::new(&g);
    let m = b.map_mut(g);
    assert_eq!(unsafe { refl_layered_clear(&m) }, refl_status::Ok);
    let res = g.face_res;
    for face in [1u32, 3, 5] {
        let (mut hits, mut offs) = (Vec::new(), vec![0usize]);
        for j in 0..res {
            for i in 0..res {
                let r: refl_layered_column_ray =
                    ok(|o| unsafe { refl_layered_face_ray(o, &g, face, i, j) });
                for (k, (t, f)) in sphere_hits(r.origin.into(), r.dir.into(), r.t_max)
                    .into_iter()
                    .enumerate()
                {
                    hits.push(refl_layered_layer_hit {
                        t,
                        id: (j * res + i) * 4 + k as u32,
                        front: f,
                    });
                }
                offs.push(hits.len());
            }
        }
        let approx: u32 = ok(|o| unsafe {
            refl_layered_fill_face(
                o,
                &m,
                face,
                hits.as_mut_ptr(),
                hits.len(),
                offs.as_ptr(),
                offs.len(),
            )
        });
        assert_eq!(approx, 0);
    }
    b
}

/// The same map through refl-core directly (bounds built at the end).
fn build_rust(g: LayeredGrid) -> (Vec<f32>, Vec<u32>, Vec<u32>, Vec<f32>) {
    let l = g.len();
    let (mut d, mut p, mut c, mut b) = (
        vec![0.0; l.depth],
        vec![0; l.payload],
        vec![0; l.counts],
        vec![0.0; l.bounds],
    );
    let mut m = LayeredMapMut::try_new(g, &mut d, &mut p, &mut c, &mut b).unwrap();
    m.clear();
    let res = g.face_res();
    for face in [Face::NegX, Face::NegY, Face::NegZ] {
        for j in 0..res {
            for i in 0..res {
                let r = g.try_face_ray(face, i, j).unwrap();
                let mut hits: Vec<_> = sphere_hits(r.origin, r.dir, r.t_max)
                    .into_iter()
                    .enumerate()
                    .map(|(k, (t, front))| LayerHit {
                        t,
                        id: (j * res + i) * 4 + k as u32,
                        front,
                    })
                    .collect();
                m.try_fill_column(face, i, j, &mut hits).unwrap();
            }
        }
    }
    m.build_bounds();
    (d, p, c, b)
}

#[test]
fn sizes_params_and_face_rays_match_the_core() {
    let l: refl_layered_sizes = ok(|o| unsafe { refl_layered_len(o, 5, 3) });
    let core = refl_core::try_layered_len(5, 3).unwrap();
    assert_eq!(
        (l.depth_len, l.payload_len, l.counts_len, l.bounds_len),
        (core.depth, core.payload, core.counts, core.bounds)
    );
    let mut sentinel = refl_layered_sizes {
        depth_len: 1,
        payload_len: 2,
        counts_len: 3,
        bounds_len: 4,
    };
    let before = sentinel;
    assert_eq!(
        unsafe { refl_layered_len(&mut sentinel, 0, 3) },
        refl_status::InvalidArgument
    );
    assert_eq!(
        unsafe { refl_layered_len(&mut sentinel, 3, 0) },
        refl_status::InvalidArgument
    );
    assert_eq!(sentinel, before);
    assert_eq!(
        unsafe { refl_layered_len(core::ptr::null_mut(), 3, 3) },
        refl_status::NullPointer
    );

    let p = refl_layered_options_default();
    assert_eq!(LayeredOptions::from(p), LayeredOptions::default());

    let xf = Affine3A::from_rotation_z(0.4) * Affine3A::from_translation(Vec3::new(1.0, 2.0, 3.0));
    let mut g = grid_c(8, 2);
    g.world_from_local = Mat4::from(xf).into();
    let core = LayeredGrid::try_from(&g).unwrap();
    for face in 0..6 {
        let r: refl_layered_column_ray =
            ok(|o| unsafe { refl_layered_face_ray(o, &g, face, 3, 5) });
        let c = core
            .try_face_ray(Face::from_index(face).unwrap(), 3, 5)
            .unwrap();
        assert_eq!(Vec3::from(r.origin), c.origin);
        assert_eq!(Vec3::from(r.dir), c.dir);
        assert_eq!(r.t_max, c.t_max);
    }
    let mut out = refl_layered_column_ray::default();
    let s = |g: &refl_layered_grid, f: u32, i: u32, out: &mut refl_layered_column_ray| unsafe {
        refl_layered_face_ray(out, g, f, i, 0)
    };
    assert_eq!(s(&g, 6, 0, &mut out), refl_status::InvalidArgument);
    assert_eq!(s(&g, 0, 8, &mut out), refl_status::InvalidArgument);
    let mut bad = g;
    bad.world_from_local.m[3] = 0.5; // not affine
    assert_eq!(s(&bad, 0, 0, &mut out), refl_status::InvalidArgument);
    let mut bad = g;
    bad.world_from_local.m[0] = f32::NAN;
    assert_eq!(s(&bad, 0, 0, &mut out), refl_status::InvalidArgument);
    let mut bad = g;
    bad.world_from_local = Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)).into();
    assert_eq!(s(&bad, 0, 0, &mut out), refl_status::DegenerateGeometry);
    let mut bad = g;
    bad.max.y = bad.min.y;
    assert_eq!(s(&bad, 0, 0, &mut out), refl_status::DegenerateGeometry);
    assert_eq!(out, refl_layered_column_ray::default());
    assert_eq!(
        unsafe { refl_layered_face_ray(&mut out, core::ptr::null(), 0, 0, 0) },
        refl_status::NullPointer
    );
}

#[test]
fn filling_through_the_abi_equals_filling_in_rust() {
    let g = grid_c(24, 2);
    let c = build_c(g);
    let (d, p, n, bounds) = build_rust(LayeredGrid::try_from(&g).unwrap());
    assert_eq!(c.counts, n);
    assert_eq!(c.payload, p);
    // refl_layered_fill_face rebuilt the bounds of the faces it filled.
    assert_eq!(c.bounds, bounds);
    assert_eq!(c.depth.len(), d.len());
    for (a, b) in c.depth.iter().zip(&d) {
        assert!(a == b || (a.is_infinite() && b.is_infinite()));
    }
    // One column through refl_layered_fill_column.
    let mut b = Bufs::new(&g);
    let m = b.map_mut(g);
    assert_eq!(unsafe { refl_layered_clear(&m) }, refl_status::Ok);
    let mut hits = [
        refl_layered_layer_hit {
            t: 1.5,
            id: 9,
            front: false,
        },
        refl_layered_layer_hit {
            t: 0.5,
            id: 8,
            front: true,
        },
    ];
    let f: refl_layered_column_fill =
        ok(|o| unsafe { refl_layered_fill_column(o, &m, 1, 2, 3, hits.as_mut_ptr(), hits.len()) });
    assert_eq!((f.intervals, f.stored), (1, 1));
    let base = (24 + 3) * 24 + 2; // face 1, j 3, i 2
    assert_eq!(b.counts[base], 1);
    assert_eq!(b.payload[base * 2], 8);
    // The column's bound cells are "never skip" until rebuilt, then exact
    // as refl-core builds them.
    let never_skip = |b: &[f32]| {
        b.chunks(2)
            .any(|h| h[0] == f32::NEG_INFINITY && h[1] == f32::INFINITY)
    };
    assert!(never_skip(&b.bounds));
    assert_eq!(unsafe { refl_layered_build_bounds(&m) }, refl_status::Ok);
    assert!(!never_skip(&b.bounds));
    let (mut d2, mut p2, mut c2, mut b2) = (
        b.depth.clone(),
        b.payload.clone(),
        b.counts.clone(),
        vec![0.0; b.bounds.len()],
    );
    LayeredMapMut::try_new(
        LayeredGrid::try_from(&g).unwrap(),
        &mut d2,
        &mut p2,
        &mut c2,
        &mut b2,
    )
    .unwrap()
    .build_bounds();
    assert_eq!(b.bounds, b2);
    // Errors leave the bounds untouched.
    let snapshot = b.bounds.clone();
    let mut short = b.map_mut(g);
    short.bounds_len -= 1;
    assert_eq!(
        unsafe { refl_layered_build_bounds(&short) },
        refl_status::InsufficientSize
    );
    let mut alias = b.map_mut(g);
    alias.bounds = alias.depth;
    assert_eq!(
        unsafe { refl_layered_build_bounds(&alias) },
        refl_status::InvalidArgument
    );
    let mut null = b.map_mut(g);
    null.bounds = core::ptr::null_mut();
    assert_eq!(
        unsafe { refl_layered_build_bounds(&null) },
        refl_status::NullPointer
    );
    assert_eq!(
        unsafe { refl_layered_build_bounds(core::ptr::null()) },
        refl_status::NullPointer
    );
    assert_eq!(b.bounds, snapshot);
}

impl Bufs {
    /// Copies of the four buffers.
    fn snapshot(&self) -> (Vec<f32>, Vec<u32>, Vec<u32>, Vec<f32>) {
        (
            self.depth.clone(),
            self.payload.clone(),
            self.counts.clone(),
            self.bounds.clone(),
        )
    }
}

/// A hit the fill accepts.
const GOOD_HIT: refl_layered_layer_hit = refl_layered_layer_hit {
    t: 0.5,
    id: 1,
    front: true,
};

#[test]
fn fill_column_errors_leave_the_map_untouched() {
    let g = grid_c(4, 2);
    let mut b = Bufs::new(&g);
    let snapshot = b.snapshot();
    let m = b.map_mut(g);
    let mut good = [GOOD_HIT];
    let mut fill = refl_layered_column_fill {
        intervals: 77,
        stored: 77,
    };
    let call = |m: &refl_layered_map_mut,
                hits: &mut [refl_layered_layer_hit],
                face: u32,
                fill: &mut refl_layered_column_fill| unsafe {
        refl_layered_fill_column(fill, m, face, 0, 0, hits.as_mut_ptr(), hits.len())
    };
    let mut nan = [refl_layered_layer_hit {
        t: f32::NAN,
        id: 1,
        front: true,
    }];
    assert_eq!(
        call(&m, &mut nan, 0, &mut fill),
        refl_status::InvalidArgument
    );
    assert_eq!(
        call(&m, &mut good, 6, &mut fill),
        refl_status::InvalidArgument
    );
    let mut short = m;
    short.counts_len -= 1;
    assert_eq!(
        call(&short, &mut good, 0, &mut fill),
        refl_status::InsufficientSize
    );
    let mut short = m;
    short.bounds_len -= 1;
    assert_eq!(
        call(&short, &mut good, 0, &mut fill),
        refl_status::InsufficientSize
    );
    let mut null = m;
    null.payload = core::ptr::null_mut();
    assert_eq!(
        call(&null, &mut good, 0, &mut fill),
        refl_status::NullPointer
    );
    let mut alias = m;
    alias.payload = alias.counts; // overlapping buffers
    assert_eq!(
        call(&alias, &mut good, 0, &mut fill),
        refl_status::InvalidArgument
    );
    assert_eq!(
        unsafe { refl_layered_fill_column(&mut fill, &m, 0, 0, 0, core::ptr::null_mut(), 1) },
        refl_status::NullPointer
    );
    assert_eq!(fill.intervals, 77);
    assert_eq!(b.snapshot(), snapshot);
}

#[test]
fn fill_face_errors_leave_the_map_untouched() {
    let g = grid_c(4, 2);
    let mut b = Bufs::new(&g);
    let snapshot = b.snapshot();
    let m = b.map_mut(g);
    let mut good = [GOOD_HIT];
    // Bad offsets.
    let offs_bad = vec![0usize, 1, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1];
    let mut approx = 55u32;
    assert_eq!(
        unsafe {
            refl_layered_fill_face(
                &mut approx,
                &m,
                0,
                good.as_mut_ptr(),
                1,
                offs_bad.as_ptr(),
                offs_bad.len(),
            )
        },
        refl_status::InvalidArgument
    );
    let offs_far = vec![0usize, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2];
    assert_eq!(
        unsafe {
            refl_layered_fill_face(
                &mut approx,
                &m,
                0,
                good.as_mut_ptr(),
                1,
                offs_far.as_ptr(),
                offs_far.len(),
            )
        },
        refl_status::InvalidArgument
    );
    let offs_ok = [0usize; 17];
    assert_eq!(
        unsafe {
            refl_layered_fill_face(
                &mut approx,
                &m,
                0,
                good.as_mut_ptr(),
                1,
                offs_ok.as_ptr(),
                16,
            )
        },
        refl_status::InsufficientSize
    );
    assert_eq!(approx, 55);
    assert_eq!(b.snapshot(), snapshot);
}

#[test]
fn traces_through_the_abi_equal_the_core() {
    let g = grid_c(32, 1);
    let b = build_c(g);
    let map = b.map(g);
    let core = LayeredMap::try_new(
        LayeredGrid::try_from(&g).unwrap(),
        &b.depth,
        &b.payload,
        &b.counts,
        &b.bounds,
    )
    .unwrap();
    let params = refl_layered_options_default();
    let mut rays = Vec::new();
    for k in 0..200 {
        let a = k as f32 * 0.37;
        let o = Vec3::new(a.cos() * 3.0, (a * 0.7).sin() * 2.0, a.sin() * 3.0);
        let target = Vec3::new((a * 1.3).sin(), (a * 2.1).cos(), (a * 0.3).sin()) * 1.1;
        rays.push(refl_ray {
            origin: o.into(),
            dir: (target - o).normalize().into(),
        });
    }
    let mut all = vec![refl_layered_result::default(); rays.len()];
    assert_eq!(
        unsafe {
            refl_layered_trace_rays(
                all.as_mut_ptr(),
                all.len(),
                &map,
                rays.as_ptr(),
                rays.len(),
                f32::INFINITY,
                &params,
            )
        },
        refl_status::Ok
    );
    let mut hits = 0;
    for (r, batch) in rays.iter().zip(&all) {
        let one: refl_layered_result =
            ok(|o| unsafe { refl_layered_trace_ray(o, &map, *r, f32::INFINITY, &params) });
        assert_eq!(&one, batch);
        let ray = Ray {
            origin: r.origin.into(),
            dir: r.dir.into(),
        };
        let c = core
            .try_trace(&ray, f32::INFINITY, &LayeredOptions::default())
            .unwrap();
        assert_eq!(refl_layered_result::from(c), one);
        if let Some(h) = c.hit() {
            hits += 1;
            assert!(one.hit);
            assert_eq!(one.payload, h.payload);
            // On the unit sphere to within a texel (2.1 / 32).
            assert!((h.position.length() - 1.0).abs() < 0.07);
        } else {
            assert!(!one.hit);
            assert_ne!(one.miss, 0);
        }
    }
    assert!(hits > 50, "{hits}");
}

/// A ray at the sphere from +z.
fn good_ray() -> refl_ray {
    refl_ray {
        origin: v3(Vec3::new(0.0, 0.0, 3.0)),
        dir: v3(-Vec3::Z),
    }
}

/// [`good_ray`] from a NaN origin.
fn nan_ray() -> refl_ray {
    refl_ray {
        origin: v3(Vec3::new(f32::NAN, 0.0, 3.0)),
        dir: v3(-Vec3::Z),
    }
}

/// A trace result no export writes.
fn result_sentinel() -> refl_layered_result {
    refl_layered_result {
        hit: true,
        miss: 99,
        ..Default::default()
    }
}

#[test]
fn trace_ray_errors_leave_the_output_untouched() {
    let g = grid_c(8, 1);
    let b = build_c(g);
    let map = b.map(g);
    let params = refl_layered_options_default();
    let good = good_ray();
    let sentinel = result_sentinel();
    let mut out = sentinel;
    let bad_ray = nan_ray();
    let unnormalized = refl_ray {
        origin: good.origin,
        dir: v3(Vec3::new(0.0, 0.0, -2.0)),
    };
    unsafe {
        assert_eq!(
            refl_layered_trace_ray(&mut out, &map, bad_ray, 1.0, &params),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_layered_trace_ray(&mut out, &map, unnormalized, 1.0, &params),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_layered_trace_ray(&mut out, &map, good, f32::NAN, &params),
            refl_status::InvalidArgument
        );
        let bad_params = refl_layered_options {
            step_texels: 0.0,
            ..params
        };
        assert_eq!(
            refl_layered_trace_ray(&mut out, &map, good, 1.0, &bad_params),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_layered_trace_ray(&mut out, core::ptr::null(), good, 1.0, &params),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_layered_trace_ray(&mut out, &map, good, 1.0, core::ptr::null()),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_layered_trace_ray(core::ptr::null_mut(), &map, good, 1.0, &params),
            refl_status::NullPointer
        );
        let bad_params = refl_layered_options {
            smooth_texels: f32::NAN,
            ..params
        };
        assert_eq!(
            refl_layered_trace_ray(&mut out, &map, good, 1.0, &bad_params),
            refl_status::InvalidArgument
        );
        let mut short = map;
        short.depth_len -= 1;
        assert_eq!(
            refl_layered_trace_ray(&mut out, &short, good, 1.0, &params),
            refl_status::InsufficientSize
        );
        let mut short = map;
        short.bounds_len -= 1;
        assert_eq!(
            refl_layered_trace_ray(&mut out, &short, good, 1.0, &params),
            refl_status::InsufficientSize
        );
        let mut null = map;
        null.bounds = core::ptr::null();
        assert_eq!(
            refl_layered_trace_ray(&mut out, &null, good, 1.0, &params),
            refl_status::NullPointer
        );
    }
    assert_eq!(out, sentinel);
}

/// One bad ray spoils the batch call, nothing written; zero rays need no
/// arrays.
#[test]
fn trace_rays_errors_leave_the_outputs_untouched() {
    let g = grid_c(8, 1);
    let b = build_c(g);
    let map = b.map(g);
    let params = refl_layered_options_default();
    let (good, bad_ray, sentinel) = (good_ray(), nan_ray(), result_sentinel());
    let rays = [good, bad_ray, good];
    let mut outs = [sentinel; 3];
    unsafe {
        assert_eq!(
            refl_layered_trace_rays(
                outs.as_mut_ptr(),
                3,
                &map,
                rays.as_ptr(),
                3,
                f32::INFINITY,
                &params
            ),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_layered_trace_rays(
                outs.as_mut_ptr(),
                2,
                &map,
                rays.as_ptr(),
                3,
                f32::INFINITY,
                &params
            ),
            refl_status::InsufficientSize
        );
        assert_eq!(
            refl_layered_trace_rays(
                core::ptr::null_mut(),
                3,
                &map,
                rays.as_ptr(),
                3,
                f32::INFINITY,
                &params
            ),
            refl_status::NullPointer
        );
        assert_eq!(
            refl_layered_trace_rays(
                outs.as_mut_ptr(),
                3,
                &map,
                core::ptr::null(),
                3,
                f32::INFINITY,
                &params
            ),
            refl_status::NullPointer
        );
        // Zero rays: nothing to do, even with NULL arrays.
        assert_eq!(
            refl_layered_trace_rays(
                core::ptr::null_mut(),
                0,
                &map,
                core::ptr::null(),
                0,
                f32::INFINITY,
                &params
            ),
            refl_status::Ok
        );
    }
    assert!(outs.iter().all(|o| *o == sentinel));
}

#[test]
fn prr_classes_match_the_core() {
    let floor = [
        Vec3::new(-10.0, 0.0, -10.0),
        Vec3::new(10.0, 0.0, -10.0),
        Vec3::new(0.0, 0.0, 10.0),
    ];
    let cases = [
        (Vec3::new(0.0, 3.0, 5.0), Vec3::new(0.0, 1.0, 0.0), 0.3),
        (Vec3::new(0.0, 3.0, 5.0), Vec3::new(0.0, -1.0, 0.0), 0.3),
        (Vec3::new(0.0, 3.0, 5.0), Vec3::new(40.0, 1.0, 0.0), 0.3),
        (Vec3::new(0.0, -0.9, 0.0), Vec3::new(0.0, 0.5, 0.0), 0.6),
    ];
    for (eye, c, r) in cases {
        let got: u32 = ok(|o| unsafe {
            refl_layered_prr_classify(
                o,
                v3(eye),
                v3(c),
                r,
                v3(floor[0]),
                v3(floor[1]),
                v3(floor[2]),
            )
        });
        let want = refl_layered_prr_class::from(try_prr_classify(eye, c, r, floor).unwrap()) as u32;
        assert_eq!(got, want);
    }
    let mut out = 77u32;
    unsafe {
        let (e, c) = (v3(Vec3::Y), v3(Vec3::Y * 2.0));
        let t = floor.map(v3);
        assert_eq!(
            refl_layered_prr_classify(&mut out, e, c, f32::NAN, t[0], t[1], t[2]),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_layered_prr_classify(&mut out, e, c, -1.0, t[0], t[1], t[2]),
            refl_status::InvalidArgument
        );
        assert_eq!(
            refl_layered_prr_classify(&mut out, e, c, 1.0, t[0], t[0], t[2]),
            refl_status::DegenerateGeometry
        );
        assert_eq!(
            refl_layered_prr_classify(core::ptr::null_mut(), e, c, 1.0, t[0], t[1], t[2]),
            refl_status::NullPointer
        );
    }
    assert_eq!(out, 77);
}
