//! The layered-maps pass (`refl_core::layered_pass`) against the kernels it
//! wraps, bit for bit: the rays taken from the mirror pass (which
//! `tests/ssr.rs` holds against its own derivation), every map traced with
//! `LayeredMap::try_trace` here in the documented order, the results
//! combined by the documented rules; over the analytic scene of
//! `tests/ssr.rs` (a floor, a sphere and a box) with layered maps of the
//! sphere and of the box (placed by a transform) built from the exact
//! column crossings, in every depth convention, with and without object
//! ids, over the whole image, row bands and ray lists. Against the f64
//! scene: the floor's reflections of the sphere and the box are found
//! where they are. And every refusal: bad options, maps, bounds, ids,
//! outputs and rays, nothing written.
#![cfg(all(feature = "layered", feature = "depth-image", feature = "hiz"))]

#[path = "common/scene.rs"]
mod scene;

use refl_core::glam::{Affine3A, DVec3, Vec2, Vec3};
use refl_core::layered::{Face, LayerHit, LayeredGrid, LayeredMap, LayeredMapMut, LayeredTrace};
use refl_core::{
    layered_pass_scratch_len, prr_mask_words, prr_radii, try_prepare_layered_pass,
    try_prr_classify, try_prr_masks, try_prr_masks_len, Error, HostRay, ImageView, ImageViewMut,
    LayeredBound, LayeredHostRay, LayeredMiss, LayeredOptions, LayeredPass, LayeredPassOptions,
    LayeredPassStats, LayeredPassStatus, LayeredPassTexel, MirrorOptions, MirrorPass, MirrorStatus,
    PrrStats, PrrTriangle, Ray, RowRange, PRR_NO_REGION,
};
use scene::{default_camera, grazing_camera, render, Frame, Scene, BOX_HI, BOX_LO, CONVENTIONS};

/// The sphere's payload: a packed color (r 0x40, g 0x80, b 0xff).
const SPHERE_PAYLOAD: u32 = 0x00ff_8040;
/// The box's payloads: a packed color plus the layer's entry index.
const BOX_PAYLOAD: u32 = 0x0010_2030;

/// Owned buffers of one map.
struct Owned {
    grid: LayeredGrid,
    depth: Vec<f32>,
    payload: Vec<u32>,
    counts: Vec<u32>,
    bounds: Vec<f32>,
}

impl Owned {
    fn map(&self) -> LayeredMap<'_> {
        LayeredMap::try_new(
            self.grid,
            &self.depth,
            &self.payload,
            &self.counts,
            &self.bounds,
        )
        .unwrap()
    }
}

/// Exact crossings of the world ray `o + t d` (`0..=t_max`) with the unit
/// sphere at `(0, 1, 0)` (`sphere`) or the box (not `sphere`).
fn crossings(sphere: bool, o: DVec3, d: DVec3, t_max: f64) -> Vec<(f64, bool)> {
    let (t0, t1) = if sphere {
        let oc = o - DVec3::new(0.0, 1.0, 0.0);
        let b = oc.dot(d);
        let disc = b * b - (oc.dot(oc) - 1.0);
        if disc <= 0.0 {
            return Vec::new();
        }
        (-b - disc.sqrt(), -b + disc.sqrt())
    } else {
        let mut t = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < BOX_LO[a] || o[a] > BOX_HI[a] {
                    return Vec::new();
                }
                continue;
            }
            let (p, q) = ((BOX_LO[a] - o[a]) / d[a], (BOX_HI[a] - o[a]) / d[a]);
            t = (t.0.max(p.min(q)), t.1.min(p.max(q)));
        }
        if t.0 > t.1 {
            return Vec::new();
        }
        t
    };
    [(t0, true), (t1, false)]
        .into_iter()
        .filter(|&(t, _)| (0.0..=t_max).contains(&t))
        .collect()
}

/// The map of the sphere (`sphere`) or of the box, built from the exact
/// crossings of the `-X`, `-Y`, `-Z` columns. The box's map is built in a
/// local frame (the box shifted to the origin) and placed by a translation.
fn build(sphere: bool, res: u32, layers: u32) -> Owned {
    let grid = if sphere {
        LayeredGrid::try_new(
            Vec3::new(-1.02, -0.02, -1.02),
            Vec3::new(1.02, 2.02, 1.02),
            res,
            layers,
        )
        .unwrap()
    } else {
        let pad = Vec3::splat(0.02);
        let ext = (BOX_HI - BOX_LO).as_vec3();
        LayeredGrid::try_new(-pad, ext + pad, res, layers)
            .unwrap()
            .try_with_transform(Affine3A::from_translation(BOX_LO.as_vec3()))
            .unwrap()
    };
    let len = grid.len();
    let mut o = Owned {
        grid,
        depth: vec![0.0; len.depth],
        payload: vec![0; len.payload],
        counts: vec![0; len.counts],
        bounds: vec![0.0; len.bounds],
    };
    {
        let mut m = LayeredMapMut::try_new(
            grid,
            &mut o.depth,
            &mut o.payload,
            &mut o.counts,
            &mut o.bounds,
        )
        .unwrap();
        m.clear();
        for face in [Face::NegX, Face::NegY, Face::NegZ] {
            for j in 0..res {
                for i in 0..res {
                    let r = grid.try_face_ray(face, i, j).unwrap();
                    let mut hits: Vec<LayerHit> = crossings(
                        sphere,
                        r.origin.as_dvec3(),
                        r.dir.as_dvec3(),
                        r.t_max as f64,
                    )
                    .into_iter()
                    .enumerate()
                    .map(|(k, (t, front))| LayerHit {
                        t: t as f32,
                        id: if sphere {
                            SPHERE_PAYLOAD
                        } else {
                            BOX_PAYLOAD + k as u32
                        },
                        front,
                    })
                    .collect();
                    m.try_fill_column(face, i, j, &mut hits).unwrap();
                }
            }
        }
        m.build_bounds();
    }
    o
}

/// The two maps (sphere, then box) and their object ids.
struct Maps {
    owned: [Owned; 2],
}

const MAP_IDS: [u32; 2] = [1, 2];

fn maps() -> Maps {
    Maps {
        owned: [build(true, 48, 1), build(false, 32, 2)],
    }
}

impl Maps {
    fn views(&self) -> [LayeredMap<'_>; 2] {
        [self.owned[0].map(), self.owned[1].map()]
    }
}

fn prepared(f: &Frame, maps: &[LayeredMap<'_>], o: &LayeredPassOptions) -> Vec<LayeredBound> {
    let mut b = vec![LayeredBound::default(); layered_pass_scratch_len(maps)];
    try_prepare_layered_pass(&mut b, &f.gbuffer(false), maps, o).unwrap();
    b
}

/// The frame with every object reflective (no mask): the sphere's and the
/// box's own pixels trace too, so the id rule matters.
fn frame(cam: refl_core::Camera, conv: refl_core::DepthConvention) -> Frame {
    render(cam, conv)
}

fn ids_view(f: &Frame) -> ImageView<'_, u32> {
    let (w, h) = (f.camera.width(), f.camera.height());
    ImageView::try_new(&f.id, w, h, w).unwrap()
}

fn option_sets() -> Vec<LayeredPassOptions> {
    let d = LayeredPassOptions::default();
    vec![
        d,
        LayeredPassOptions {
            start_pixels: 2.5,
            t_min: 0.05,
            t_max: 4.0,
            payload_color: true,
            trace: LayeredOptions {
                early_stop_texels: 0.25,
                smooth_texels: 0.0,
                ..d.trace
            },
            ..d
        },
        // A step cap that runs out on long crossings.
        LayeredPassOptions {
            trace: LayeredOptions {
                max_steps: 6,
                step_texels: 0.25,
                ..d.trace
            },
            ..d
        },
    ]
}

/// What the documentation says the pass does for one segment, with the
/// kernel called here on every map (no sphere test): `(texel, color,
/// kernel calls, calls that did not miss the box)`.
#[allow(clippy::too_many_arguments)]
fn by_hand_segment(
    maps: &[LayeredMap<'_>],
    map_ids: Option<&[u32]>,
    own: Option<u32>,
    ray: &Ray,
    t_seg: f32,
    t_start: f32,
    t_end: f32,
    o: &LayeredPassOptions,
) -> (LayeredPassTexel, [f32; 3], u32, u32) {
    let mut best: Option<(usize, refl_core::LayeredHit)> = None;
    let (mut inside, mut steps, mut calls, mut boxed, mut fetches) = (false, false, 0, 0, 0u32);
    for (k, m) in maps.iter().enumerate() {
        if let (Some(id), Some(ids)) = (own, map_ids) {
            if ids[k] == id {
                continue;
            }
        }
        let t_max = best.map_or(t_seg, |(_, h)| h.t);
        if !(t_max > 0.0) {
            break;
        }
        let tr = m.try_trace(ray, t_max, &o.trace).unwrap();
        calls += 1;
        fetches += tr.work().fetches;
        match tr {
            LayeredTrace::Hit(h) => {
                boxed += 1;
                if best.is_none_or(|(_, b)| h.t < b.t) {
                    best = Some((k, h));
                }
            }
            LayeredTrace::Miss { reason, work } => {
                if reason != LayeredMiss::MissedBox {
                    boxed += 1;
                } else {
                    assert_eq!(work.fetches, 0);
                }
                inside |= reason == LayeredMiss::StartedInside;
                steps |= reason == LayeredMiss::OutOfSteps;
            }
        }
    }
    let mut t = LayeredPassTexel {
        dir: ray.dir,
        fetches,
        ..LayeredPassTexel::default()
    };
    let Some((k, h)) = best else {
        t.status = if inside {
            LayeredPassStatus::StartedInside
        } else if steps {
            LayeredPassStatus::OutOfSteps
        } else {
            LayeredPassStatus::LeftMaps
        };
        return (t, [0.0; 3], calls, boxed);
    };
    let g = maps[k].grid();
    let q = g.box_coords(h.position);
    let (u, v) = h.face.uv_axes();
    let res = g.face_res() as f32;
    let e = o.trace.early_stop_texels;
    t.status = LayeredPassStatus::Hit;
    t.map = k as u32;
    t.face = h.face;
    t.texel = h.texel;
    // The sub-texel position, kept within the hit texel's cell (F28).
    let (ti, tj) = (h.texel[0] as f32, h.texel[1] as f32);
    t.uv = Vec2::new(
        (q[u] * res).max(ti).min(ti + 1.0),
        (q[v] * res).max(tj).min(tj + 1.0),
    );
    t.layer = h.layer;
    t.payload = h.payload;
    let sum = t_start + h.t;
    t.t = if sum > t_end { t_end } else { sum };
    t.position = h.position;
    t.confidence = if h.mismatch <= e {
        1.0
    } else {
        (e / h.mismatch).min(1.0)
    };
    let c = h.payload.to_le_bytes();
    let color = if o.payload_color {
        [
            c[0] as f32 / 255.0,
            c[1] as f32 / 255.0,
            c[2] as f32 / 255.0,
        ]
    } else {
        [0.0; 3]
    };
    (t, color, calls, boxed)
}

/// The whole image by hand: texels, colors, host rays (row-major), the
/// kernel-call bounds.
struct ByHand {
    texels: Vec<LayeredPassTexel>,
    colors: Vec<[f32; 3]>,
    host: Vec<LayeredHostRay>,
    calls: u64,
    boxed: u64,
}

fn by_hand(f: &Frame, maps: &[LayeredMap<'_>], ids: bool, o: &LayeredPassOptions) -> ByHand {
    let (w, h) = (f.camera.width(), f.camera.height());
    let mp = MirrorPass::try_new(f.gbuffer(false), o.mirror_options(), None).unwrap();
    let mut out = ByHand {
        texels: Vec::new(),
        colors: Vec::new(),
        host: Vec::new(),
        calls: 0,
        boxed: 0,
    };
    let host = |x, y, origin, dir, status| LayeredHostRay {
        x,
        y,
        origin,
        dir,
        t_min: o.t_min,
        t_max: o.t_max,
        status,
    };
    for y in 0..h {
        for x in 0..w {
            let (t, c) = match mp.ray(x, y) {
                Some(r) => {
                    let own = ids.then(|| f.id[(y * w + x) as usize]);
                    let (t, c, calls, boxed) = by_hand_segment(
                        maps,
                        ids.then_some(&MAP_IDS[..]),
                        own,
                        &r.kernel_ray(),
                        o.t_max - r.t_start,
                        r.t_start,
                        o.t_max,
                        o,
                    );
                    out.calls += u64::from(calls);
                    out.boxed += u64::from(boxed);
                    if t.status.needs_host() {
                        out.host.push(host(x, y, r.origin, r.dir, t.status));
                    }
                    (t, c)
                }
                None => {
                    // Not traced: the mirror pass's own status.
                    let status = match mp.pixel(x, y).0.status {
                        MirrorStatus::Skipped => LayeredPassStatus::Skipped,
                        MirrorStatus::NoSurface => LayeredPassStatus::NoSurface,
                        MirrorStatus::Sky => LayeredPassStatus::Sky,
                        MirrorStatus::NoProjection => LayeredPassStatus::NoProjection,
                        s => panic!("untraced pixel with status {s:?}"),
                    };
                    let hr = mp.host_ray(x, y, MirrorStatus::NoProjection);
                    let dir = match status {
                        LayeredPassStatus::Skipped | LayeredPassStatus::NoSurface => Vec3::ZERO,
                        _ => hr.map(|r| r.dir).unwrap_or_else(|| {
                            // Sky: the ray exists, the mirror pass hands
                            // none over; its direction is the setup's.
                            sky_dir(&mp, x, y)
                        }),
                    };
                    if status == LayeredPassStatus::NoProjection {
                        let r = hr.unwrap();
                        out.host.push(host(x, y, r.origin, r.dir, status));
                    }
                    (
                        LayeredPassTexel {
                            status,
                            dir,
                            ..LayeredPassTexel::default()
                        },
                        [0.0; 3],
                    )
                }
            };
            out.texels.push(t);
            out.colors.push(c);
        }
    }
    out
}

/// The direction of a pixel whose ray starts beyond `t_max` (the mirror
/// pass with an unbounded `t_max` traces it).
fn sky_dir(mp: &MirrorPass<'_>, x: u32, y: u32) -> Vec3 {
    let o = MirrorOptions {
        t_max: f32::INFINITY,
        ..*mp.options()
    };
    MirrorPass::try_new(*mp.gbuffer(), o, None)
        .unwrap()
        .ray(x, y)
        .unwrap()
        .dir
}

fn bits(t: &LayeredPassTexel) -> (LayeredPassStatus, Face, [u32; 16]) {
    (
        t.status,
        t.face,
        [
            t.map,
            t.texel[0],
            t.texel[1],
            t.uv.x.to_bits(),
            t.uv.y.to_bits(),
            t.layer,
            t.payload,
            t.t.to_bits(),
            t.position.x.to_bits(),
            t.position.y.to_bits(),
            t.position.z.to_bits(),
            t.confidence.to_bits(),
            t.dir.x.to_bits(),
            t.dir.y.to_bits(),
            t.dir.z.to_bits(),
            t.fetches,
        ],
    )
}

fn host_bits(r: &LayeredHostRay) -> (u32, u32, [u32; 8], LayeredPassStatus) {
    (
        r.x,
        r.y,
        [
            r.origin.x.to_bits(),
            r.origin.y.to_bits(),
            r.origin.z.to_bits(),
            r.dir.x.to_bits(),
            r.dir.y.to_bits(),
            r.dir.z.to_bits(),
            r.t_min.to_bits(),
            r.t_max.to_bits(),
        ],
        r.status,
    )
}

/// The pass over the whole image (`try_run`), host list large enough.
fn run(
    pass: &LayeredPass<'_>,
    color: bool,
) -> (
    Vec<LayeredPassTexel>,
    Vec<[f32; 3]>,
    Vec<LayeredHostRay>,
    LayeredPassStats,
) {
    let (w, h) = (pass.gbuffer().width(), pass.gbuffer().height());
    let n = (w * h) as usize;
    let mut out = vec![LayeredPassTexel::default(); n];
    let mut colors = vec![[0.0; 3]; n];
    let mut host = vec![LayeredHostRay::default(); n];
    let stats = {
        let mut o = ImageViewMut::try_new(&mut out, w, h, w).unwrap();
        let mut c = ImageViewMut::try_new(&mut colors, w, h, w).unwrap();
        pass.try_run(&mut o, color.then_some(&mut c), &mut host)
            .unwrap()
    };
    assert_eq!(stats.host_rays, stats.host_rays_written);
    host.truncate(stats.host_rays as usize);
    (out, colors, host, stats)
}

#[test]
fn pass_equals_the_kernels_it_wraps() {
    let m = maps();
    let views = m.views();
    let mut hits = [0u32; 2];
    let mut statuses = std::collections::BTreeSet::new();
    for cam in [default_camera(), grazing_camera()] {
        for conv in CONVENTIONS {
            let f = frame(cam, conv);
            for o in option_sets() {
                let bounds = prepared(&f, &views, &o);
                for ids in [false, true] {
                    let mut pass =
                        LayeredPass::try_new(f.gbuffer(false), &views[..], o, &bounds).unwrap();
                    if ids {
                        pass = pass.try_with_ids(ids_view(&f), &MAP_IDS).unwrap();
                    }
                    let want = by_hand(&f, &views, ids, &o);
                    let (got, colors, host, stats) = run(&pass, o.payload_color);
                    for (i, (g, e)) in got.iter().zip(&want.texels).enumerate() {
                        assert_eq!(bits(g), bits(e), "pixel {i} ({conv:?}, ids {ids}, {o:?})");
                        statuses.insert(g.status as u8);
                        if g.status == LayeredPassStatus::Hit {
                            hits[g.map as usize] += 1;
                        }
                    }
                    if o.payload_color {
                        assert_eq!(colors, want.colors);
                    }
                    assert_eq!(host.len(), want.host.len());
                    for (a, b) in host.iter().zip(&want.host) {
                        assert_eq!(host_bits(a), host_bits(b));
                    }
                    // The sphere test skips only maps the kernel misses.
                    assert!(
                        (want.boxed..=want.calls).contains(&stats.kernel_traces),
                        "{} kernel traces, by hand {}..={}",
                        stats.kernel_traces,
                        want.boxed,
                        want.calls
                    );
                    let count = |s| got.iter().filter(|t| t.status == s).count() as u32;
                    assert_eq!(stats.hits, count(LayeredPassStatus::Hit));
                    assert_eq!(stats.sky, count(LayeredPassStatus::Sky));
                    assert_eq!(
                        stats.traced,
                        got.iter()
                            .filter(|t| !matches!(
                                t.status,
                                LayeredPassStatus::Skipped | LayeredPassStatus::NoSurface
                            ))
                            .count() as u32
                    );
                    assert_eq!(
                        stats.fetches,
                        got.iter().map(|t| u64::from(t.fetches)).sum::<u64>()
                    );
                    // Every host ray is the pixel's, as `host_ray` gives it.
                    for r in &host {
                        assert_eq!(pass.host_ray(r.x, r.y, r.status), Some(*r));
                    }
                }
            }
        }
    }
    // Both maps are hit, and every status but NoProjection occurs.
    assert!(hits[0] > 100 && hits[1] > 100, "{hits:?}");
    for s in [
        LayeredPassStatus::NoSurface,
        LayeredPassStatus::Hit,
        LayeredPassStatus::Sky,
        LayeredPassStatus::LeftMaps,
        LayeredPassStatus::OutOfSteps,
    ] {
        assert!(statuses.contains(&(s as u8)), "{s:?} never occurred");
    }
}

#[test]
fn row_bands_equal_the_whole_image() {
    let m = maps();
    let views = m.views();
    let f = frame(default_camera(), refl_core::DepthConvention::ReversedZ);
    let o = LayeredPassOptions {
        payload_color: true,
        ..LayeredPassOptions::default()
    };
    let bounds = prepared(&f, &views, &o);
    let pass = LayeredPass::try_new(f.gbuffer(false), &views[..], o, &bounds)
        .unwrap()
        .try_with_ids(ids_view(&f), &MAP_IDS)
        .unwrap();
    let (whole, whole_c, whole_host, _) = run(&pass, true);
    let (w, h) = (f.camera.width(), f.camera.height());
    let n = (w * h) as usize;
    let mut out = vec![LayeredPassTexel::default(); n];
    let mut colors = vec![[0.0; 3]; n];
    for y0 in (0..h).step_by(7) {
        let rows = RowRange::try_new(y0, (y0 + 7).min(h), h).unwrap();
        let a = rows.start() as usize * w as usize;
        let b = rows.end() as usize * w as usize;
        let mut band_host = vec![LayeredHostRay::default(); 5];
        let st = {
            let mut ov = ImageViewMut::try_band(&mut out[a..b], w, h, w, rows).unwrap();
            let mut cv = ImageViewMut::try_band(&mut colors[a..b], w, h, w, rows).unwrap();
            pass.try_run(&mut ov, Some(&mut cv), &mut band_host)
                .unwrap()
        };
        // A short list holds the band's first rays; the rest are counted.
        let want: Vec<_> = whole_host
            .iter()
            .filter(|r| rows.rows().contains(&r.y))
            .copied()
            .collect();
        assert_eq!(st.host_rays as usize, want.len());
        assert_eq!(st.host_rays_written, st.host_rays.min(5));
        let k = st.host_rays_written as usize;
        assert_eq!(&band_host[..k], &want[..k]);
    }
    assert_eq!(out, whole);
    assert_eq!(colors, whole_c);
    let _ = n;
}

/// A SplitMix64 generator.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0;
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

/// Listed rays from everywhere (near and far from the maps, grazing their
/// boxes, starting inside them) traced by the pass equal the kernels, and
/// the sphere test never changes a result.
#[test]
fn ray_lists_equal_the_kernels_and_the_sphere_test_changes_nothing() {
    let m = maps();
    let views = m.views();
    let f = frame(default_camera(), refl_core::DepthConvention::Linear);
    let mut rng = Rng(0x6c61_7965_7265_6470);
    let targets = [DVec3::new(0.0, 1.0, 0.0), (BOX_LO + BOX_HI) * 0.5];
    let mut rays = Vec::new();
    for k in 0..6000 {
        let c = targets[k % 2];
        // Origins from inside the objects to 300 units away; targets
        // spread to twice the objects' size (many rays graze or miss).
        let dist = [0.3, 1.5, 4.0, 30.0, 300.0][k % 5];
        let origin = c + rng.unit() * dist;
        let target = c + rng.unit() * (2.0 * rng.next());
        let dir = (target - origin).normalize();
        rays.push(HostRay {
            x: (k as u32 * 7) % f.camera.width(),
            y: (k as u32 * 3) % f.camera.height(),
            origin: origin.as_vec3(),
            dir: dir.as_vec3(),
            t_min: [0.0, 0.01, 0.5][k % 3],
            t_max: [f32::INFINITY, 5.0, 400.0, 2.0][k % 4],
            status: MirrorStatus::LeftImage,
        });
    }
    for o in option_sets() {
        let bounds = prepared(&f, &views, &o);
        for ids in [false, true] {
            let mut pass = LayeredPass::try_new(f.gbuffer(false), &views[..], o, &bounds).unwrap();
            if ids {
                pass = pass.try_with_ids(ids_view(&f), &MAP_IDS).unwrap();
            }
            let mut out = vec![LayeredPassTexel::default(); rays.len()];
            let mut colors = vec![[7.0; 3]; rays.len()];
            let mut host = vec![LayeredHostRay::default(); rays.len()];
            let st = pass
                .try_trace_rays(
                    &mut out,
                    o.payload_color.then_some(&mut colors[..]),
                    &mut host,
                    &rays,
                )
                .unwrap();
            let (mut calls, mut boxed, mut want_host) = (0u64, 0u64, Vec::new());
            for (k, r) in rays.iter().enumerate() {
                let own = ids.then(|| f.id[(r.y * f.camera.width() + r.x) as usize]);
                let seg = Ray {
                    origin: r.origin + r.dir * r.t_min,
                    dir: r.dir,
                };
                let (t, c, cl, bx) = by_hand_segment(
                    &views,
                    ids.then_some(&MAP_IDS[..]),
                    own,
                    &seg,
                    r.t_max - r.t_min,
                    r.t_min,
                    r.t_max,
                    &o,
                );
                calls += u64::from(cl);
                boxed += u64::from(bx);
                assert_eq!(bits(&out[k]), bits(&t), "ray {k}: {r:?}");
                if o.payload_color {
                    assert_eq!(colors[k], c);
                }
                if t.status.needs_host() {
                    want_host.push(LayeredHostRay {
                        x: r.x,
                        y: r.y,
                        origin: r.origin,
                        dir: r.dir,
                        t_min: r.t_min,
                        t_max: r.t_max,
                        status: t.status,
                    });
                }
            }
            assert!((boxed..=calls).contains(&st.kernel_traces));
            assert!(st.kernel_traces < calls, "the sphere test skipped nothing");
            assert_eq!(st.host_rays as usize, want_host.len());
            assert_eq!(&host[..want_host.len()], &want_host[..]);
            assert_eq!(st.traced as usize, rays.len());
        }
    }
}

/// The mirror pass's host rays (what the screen could not answer) go on
/// to the maps unchanged: the ray list takes `HostRay`s.
#[test]
fn mirror_pass_host_rays_chain_into_the_maps() {
    let m = maps();
    let views = m.views();
    let f = frame(default_camera(), refl_core::DepthConvention::ZeroToOne);
    let (w, h) = (f.camera.width(), f.camera.height());
    let mp = MirrorPass::try_new(f.gbuffer(false), MirrorOptions::default(), None).unwrap();
    let n = (w * h) as usize;
    let mut texels = vec![refl_core::MirrorTexel::default(); n];
    let mut screen_host = vec![HostRay::default(); n];
    let st = mp
        .try_run(
            &mut ImageViewMut::try_new(&mut texels, w, h, w).unwrap(),
            None,
            &mut screen_host,
        )
        .unwrap();
    screen_host.truncate(st.host_rays_written as usize);
    assert!(screen_host.len() > 50);
    let o = LayeredPassOptions::default();
    let bounds = prepared(&f, &views, &o);
    let pass = LayeredPass::try_new(f.gbuffer(false), &views[..], o, &bounds)
        .unwrap()
        .try_with_ids(ids_view(&f), &MAP_IDS)
        .unwrap();
    let mut out = vec![LayeredPassTexel::default(); screen_host.len()];
    let mut host = vec![LayeredHostRay::default(); screen_host.len()];
    let ls = pass
        .try_trace_rays(&mut out, None, &mut host, &screen_host)
        .unwrap();
    assert!(ls.hits > 0, "{ls:?}");
    for (k, r) in screen_host.iter().enumerate() {
        let own = f.id[(r.y * w + r.x) as usize];
        let seg = Ray {
            origin: r.origin + r.dir * r.t_min,
            dir: r.dir,
        };
        let (t, ..) = by_hand_segment(
            &views,
            Some(&MAP_IDS),
            Some(own),
            &seg,
            r.t_max - r.t_min,
            r.t_min,
            r.t_max,
            &o,
        );
        assert_eq!(bits(&out[k]), bits(&t));
    }
}

/// Signed distance of `p` to the nearest mapped object (sphere, box).
fn object_distance(p: DVec3) -> f64 {
    let sphere = (p - DVec3::new(0.0, 1.0, 0.0)).length() - 1.0;
    let c = (BOX_LO + BOX_HI) * 0.5;
    let q = (p - c).abs() - (BOX_HI - BOX_LO) * 0.5;
    let boxd = q.max(DVec3::ZERO).length() + q.max_element().min(0.0);
    sphere.min(boxd)
}

/// Against the f64 scene, with and without the start rule (0 and 1
/// pixel): the floor pixels whose reflection ray (as the pass generates
/// it) starts clear of the objects (at least 2 texel
/// diagonals from their surfaces: closer, a map cannot resolve the gap)
/// and first meets the sphere or the box are hits on that object's map
/// within a texel diagonal of the exact point (99%); those whose ray meets
/// neither go to the host as `LeftMaps` (99%); those whose ray starts
/// inside an object, a quarter texel diagonal deep or more (the start rule's pixel
/// lies past a surface the floor touches), go to the host as
/// `StartedInside` (99%).
#[test]
fn floor_reflections_are_found_where_the_scene_has_them() {
    let m = maps();
    let views = m.views();
    let diag = |k: usize| {
        let g = views[k].grid();
        f64::from((g.max() - g.min()).max_element() / g.face_res() as f32) * 3f64.sqrt()
    };
    let clear = 2.0 * diag(0).max(diag(1));
    for (conv, start) in CONVENTIONS.into_iter().flat_map(|c| [(c, 0.0), (c, 1.0)]) {
        let f = frame(default_camera(), conv);
        let (w, h) = (f.camera.width(), f.camera.height());
        let o = LayeredPassOptions {
            start_pixels: start,
            ..LayeredPassOptions::default()
        };
        let bounds = prepared(&f, &views, &o);
        let pass = LayeredPass::try_new(f.gbuffer(false), &views[..], o, &bounds)
            .unwrap()
            .try_with_ids(ids_view(&f), &MAP_IDS)
            .unwrap();
        let (out, ..) = run(&pass, false);
        let (mut objects, mut agree, mut empty, mut left) = (0, 0, 0, 0);
        let (mut inside, mut started_inside) = (0, 0);
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                if f.id[i] != 0 {
                    continue;
                }
                let Some(r) = pass.ray(x, y) else { continue };
                let t = &out[i];
                let o64 = r.origin.as_dvec3();
                let d64 = r.dir.as_dvec3().normalize();
                let start = object_distance(o64 + d64 * f64::from(r.t_start));
                if start < -clear / 8.0 {
                    inside += 1;
                    started_inside += u32::from(t.status == LayeredPassStatus::StartedInside);
                    continue;
                }
                if start.abs() < clear {
                    continue;
                }
                match Scene.trace(o64, d64, f64::from(r.t_start), 0) {
                    Some(e) if e.id == 1 || e.id == 2 => {
                        objects += 1;
                        let tol = diag(e.id as usize - 1);
                        let err = (t.position.as_dvec3() - (o64 + d64 * e.t)).length();
                        agree += u32::from(
                            t.status == LayeredPassStatus::Hit
                                && t.map == e.id - 1
                                && err <= tol
                                && (f64::from(t.t) - e.t).abs() <= tol,
                        );
                    }
                    _ => {
                        empty += 1;
                        left += u32::from(t.status == LayeredPassStatus::LeftMaps);
                    }
                }
            }
        }
        assert!(
            objects > 300 && empty > 300,
            "{objects} / {empty} floor rays"
        );
        assert!(
            agree as f64 >= 0.99 * objects as f64,
            "{conv:?}: {agree} of {objects} found"
        );
        assert!(
            left as f64 >= 0.99 * empty as f64,
            "{left} of {empty} left the maps"
        );
        // Only the start rule moves a floor ray's start into an object.
        assert!(
            if start > 0.0 { inside > 5 } else { inside == 0 },
            "{inside} rays start inside"
        );
        assert!(
            started_inside as f64 >= 0.99 * inside as f64,
            "{started_inside} of {inside} started inside"
        );
    }
}

/// Rays that start beyond `t_max` are sky (answered, not traced); a
/// payload color is decoded little-endian.
#[test]
fn sky_and_payload_colors() {
    let m = maps();
    let views = m.views();
    let f = frame(default_camera(), refl_core::DepthConvention::Linear);
    // (The start rule on: with no offset every ray starts at 0 < t_max.)
    let o = LayeredPassOptions {
        t_max: 1e-4,
        start_pixels: 1.0,
        ..LayeredPassOptions::default()
    };
    let bounds = prepared(&f, &views, &o);
    let pass = LayeredPass::try_new(f.gbuffer(false), &views[..], o, &bounds).unwrap();
    let (out, _, host, st) = run(&pass, false);
    assert!(
        st.sky > 1000 && st.kernel_traces < u64::from(st.traced) / 10,
        "{st:?}"
    );
    for t in out.iter().filter(|t| t.status == LayeredPassStatus::Sky) {
        assert_eq!((t.fetches, t.t), (0, 0.0));
        assert!((t.dir.length() - 1.0).abs() < 1e-5);
    }
    assert!(host.iter().all(|r| r.status.needs_host()));
    // Colors.
    let o = LayeredPassOptions {
        payload_color: true,
        ..LayeredPassOptions::default()
    };
    let bounds = prepared(&f, &views, &o);
    let pass = LayeredPass::try_new(f.gbuffer(false), &views[..], o, &bounds)
        .unwrap()
        .try_with_ids(ids_view(&f), &MAP_IDS)
        .unwrap();
    let (out, colors, ..) = run(&pass, true);
    let mut seen = [false; 2];
    for (t, c) in out.iter().zip(&colors) {
        match (t.status, t.map) {
            (LayeredPassStatus::Hit, 0) => {
                seen[0] = true;
                assert_eq!(*c, [64.0 / 255.0, 128.0 / 255.0, 1.0]);
            }
            (LayeredPassStatus::Hit, _) => {
                seen[1] = true;
                assert_eq!(c[1..], [32.0 / 255.0, 16.0 / 255.0]);
            }
            _ => assert_eq!(*c, [0.0; 3]),
        }
    }
    assert_eq!(seen, [true; 2]);
}

/// Bad options, maps, bounds, ids and outputs are refused, and nothing
/// is written.
#[test]
fn refusals_leave_every_output_untouched() {
    let m = maps();
    let views = m.views();
    let f = frame(default_camera(), refl_core::DepthConvention::Linear);
    let g = f.gbuffer(false);
    let d = LayeredPassOptions::default();
    let bad_options = [
        LayeredPassOptions {
            t_max: f32::NAN,
            ..d
        },
        LayeredPassOptions { t_max: 0.0, ..d },
        LayeredPassOptions { t_min: -1.0, ..d },
        LayeredPassOptions {
            start_pixels: f32::INFINITY,
            ..d
        },
        LayeredPassOptions {
            max_roughness: f32::NAN,
            ..d
        },
        LayeredPassOptions {
            trace: LayeredOptions {
                step_texels: 0.0,
                ..d.trace
            },
            ..d
        },
        LayeredPassOptions {
            trace: LayeredOptions {
                binary_steps: 65,
                ..d.trace
            },
            ..d
        },
    ];
    let sentinel = LayeredBound {
        key: 77,
        ..LayeredBound::default()
    };
    for o in bad_options {
        let mut b = vec![sentinel; 2];
        assert_eq!(
            try_prepare_layered_pass(&mut b, &g, &views[..], &o),
            Err(Error::InvalidArgument)
        );
        assert!(b.iter().all(|x| *x == sentinel));
        assert!(matches!(o.try_validate(), Err(Error::InvalidArgument)));
    }
    // Short bounds.
    let mut b = vec![sentinel; 1];
    assert_eq!(
        try_prepare_layered_pass(&mut b, &g, &views[..], &d),
        Err(Error::InsufficientSize)
    );
    assert_eq!(b[0], sentinel);
    let bounds = prepared(&f, &views, &d);
    for o in bad_options {
        assert!(matches!(
            LayeredPass::try_new(g, &views[..], o, &bounds),
            Err(Error::InvalidArgument)
        ));
    }
    assert!(matches!(
        LayeredPass::try_new(g, &views[..], d, &bounds[..1]),
        Err(Error::InsufficientSize)
    ));
    // Bounds of other maps: swapped order, a moved map, another grid.
    let swapped = [views[1], views[0]];
    assert!(matches!(
        LayeredPass::try_new(g, &swapped[..], d, &bounds),
        Err(Error::InvalidArgument)
    ));
    let moved_grid = views[0]
        .grid()
        .try_with_transform(Affine3A::from_translation(Vec3::new(0.0, 0.5, 0.0)))
        .unwrap();
    let o0 = &m.owned[0];
    let moved = [
        LayeredMap::try_new(moved_grid, &o0.depth, &o0.payload, &o0.counts, &o0.bounds).unwrap(),
        views[1],
    ];
    assert!(matches!(
        LayeredPass::try_new(g, &moved[..], d, &bounds),
        Err(Error::InvalidArgument)
    ));
    // Ids of another size, too few map ids.
    let pass = LayeredPass::try_new(g, &views[..], d, &bounds).unwrap();
    let (w, h) = (f.camera.width(), f.camera.height());
    let small = ImageView::try_new(&f.id[..((w - 1) * h) as usize], w - 1, h, w - 1).unwrap();
    assert!(matches!(
        pass.try_with_ids(small, &MAP_IDS),
        Err(Error::InvalidArgument)
    ));
    assert!(matches!(
        pass.try_with_ids(ids_view(&f), &MAP_IDS[..1]),
        Err(Error::InsufficientSize)
    ));
    // Outputs: wrong size, color without payload colors, bands that differ,
    // rows beyond the image.
    let n = (w * h) as usize;
    let texel = LayeredPassTexel {
        map: 99,
        ..LayeredPassTexel::default()
    };
    let mut out = vec![texel; n];
    let mut colors = vec![[5.0f32; 3]; n];
    let mut host = vec![
        LayeredHostRay {
            x: 77,
            ..LayeredHostRay::default()
        };
        4
    ];
    {
        let mut o = ImageViewMut::try_new(&mut out[..n - w as usize], w, h - 1, w).unwrap();
        assert_eq!(
            pass.try_run(&mut o, None, &mut host),
            Err(Error::InvalidArgument)
        );
        let mut o = ImageViewMut::try_new(&mut out, w, h, w).unwrap();
        let mut c = ImageViewMut::try_new(&mut colors, w, h, w).unwrap();
        assert_eq!(
            pass.try_run(&mut o, Some(&mut c), &mut host),
            Err(Error::InvalidArgument)
        );
    }
    {
        let colored = LayeredPass::try_new(
            g,
            &views[..],
            LayeredPassOptions {
                payload_color: true,
                ..d
            },
            &bounds,
        )
        .unwrap();
        let rows = RowRange::try_new(0, 3, h).unwrap();
        let (oa, ca) = (
            &mut out[..3 * w as usize],
            &mut colors[w as usize..4 * w as usize],
        );
        let mut o = ImageViewMut::try_band(oa, w, h, w, rows).unwrap();
        let mut c =
            ImageViewMut::try_band(ca, w, h, w, RowRange::try_new(1, 4, h).unwrap()).unwrap();
        assert_eq!(
            colored.try_run(&mut o, Some(&mut c), &mut host),
            Err(Error::InvalidArgument)
        );
    }
    struct Sink(u32);
    impl refl_core::LayeredPassSink for Sink {
        fn texel(&mut self, _: u32, _: u32, _: &LayeredPassTexel, _: [f32; 3]) {
            self.0 += 1;
        }
        fn host(&mut self, _: u32, _: &LayeredHostRay) -> bool {
            self.0 += 1;
            true
        }
    }
    let mut sink = Sink(0);
    // Rows past the height cannot be built against the G-buffer's height;
    // a range built for a taller image is refused.
    let tall = RowRange::try_new(h - 1, h + 1, h + 1).unwrap();
    assert_eq!(
        pass.try_run_rows(tall, &mut sink),
        Err(Error::InvalidArgument)
    );
    assert_eq!(sink.0, 0);
    assert!(out.iter().all(|t| *t == texel));
    assert!(colors.iter().all(|c| *c == [5.0; 3]));
    assert!(host.iter().all(|r| r.x == 77));
    // Listed rays: bad rays, short outputs, color without payload colors.
    let good = HostRay {
        origin: Vec3::new(0.0, 1.0, 5.0),
        dir: Vec3::new(0.0, 0.0, -1.0),
        t_max: f32::INFINITY,
        ..HostRay::default()
    };
    let bad_rays = [
        HostRay {
            origin: Vec3::new(f32::NAN, 0.0, 0.0),
            ..good
        },
        HostRay {
            dir: Vec3::new(0.0, 0.0, -1.1),
            ..good
        },
        HostRay {
            dir: Vec3::ZERO,
            ..good
        },
        HostRay {
            t_min: -0.5,
            ..good
        },
        HostRay {
            t_min: f32::INFINITY,
            ..good
        },
        HostRay {
            t_max: f32::NAN,
            ..good
        },
        HostRay {
            t_min: 2.0,
            t_max: 2.0,
            ..good
        },
        HostRay {
            origin: Vec3::new(0.0, 0.0, 3e38),
            t_min: 1e38,
            dir: Vec3::Z,
            ..good
        },
    ];
    for bad in bad_rays {
        let rays = [good, bad];
        assert_eq!(
            pass.try_trace_rays(&mut out[..2], None, &mut host, &rays),
            Err(Error::InvalidArgument),
            "{bad:?}"
        );
    }
    assert_eq!(
        pass.try_trace_rays(&mut out[..1], None, &mut host, &[good, good]),
        Err(Error::InsufficientSize)
    );
    assert_eq!(
        pass.try_trace_rays(
            &mut out[..2],
            Some(&mut colors[..2]),
            &mut host,
            &[good, good]
        ),
        Err(Error::InvalidArgument)
    );
    assert!(out.iter().all(|t| *t == texel));
    assert!(colors.iter().all(|c| *c == [5.0; 3]));
    assert!(host.iter().all(|r| r.x == 77));
    // A map that is not usable is refused by prepare and the pass.
    struct Broken<'m>(LayeredMap<'m>);
    impl refl_core::LayeredMapSet for Broken<'_> {
        fn len(&self) -> usize {
            2
        }
        fn map(&self, k: usize) -> Option<LayeredMap<'_>> {
            (k == 0).then_some(self.0)
        }
    }
    let broken = Broken(views[0]);
    let mut b = vec![sentinel; 2];
    assert_eq!(
        try_prepare_layered_pass(&mut b, &g, &broken, &d),
        Err(Error::InvalidArgument)
    );
    assert!(b.iter().all(|x| *x == sentinel));
    assert!(matches!(
        LayeredPass::try_new(g, &broken, d, &bounds),
        Err(Error::InvalidArgument)
    ));
}

/// Fuzz finding F32: a hit's `t` is the ray's start plus the kernel's `t`,
/// which is at most `t_max - t_start`; that difference rounds, and the sum
/// passed `t_max` by an ulp. With `t_max` set to each hit's own distance
/// (and the float below it), every hit stays within `[t_min, t_max]`.
#[test]
fn hits_never_pass_t_max() {
    let m = maps();
    let views = m.views();
    let f = frame(default_camera(), CONVENTIONS[0]);
    let d = LayeredPassOptions::default();
    let all = {
        let bounds = prepared(&f, &views, &d);
        let pass = LayeredPass::try_new(f.gbuffer(false), &views[..], d, &bounds).unwrap();
        run(&pass, false).0
    };
    let ts: Vec<f32> = all
        .iter()
        .filter(|t| t.status == LayeredPassStatus::Hit)
        .map(|t| t.t)
        .collect();
    assert!(ts.len() > 100, "{} hits", ts.len());
    let mut checked = 0;
    for &t_hit in ts.iter().step_by(ts.len() / 24) {
        for t_max in [t_hit, f32::from_bits(t_hit.to_bits() - 1)] {
            let o = LayeredPassOptions { t_max, ..d };
            let bounds = prepared(&f, &views, &o);
            let pass = LayeredPass::try_new(f.gbuffer(false), &views[..], o, &bounds).unwrap();
            for t in run(&pass, false).0 {
                if t.status == LayeredPassStatus::Hit {
                    checked += 1;
                    assert!(
                        t.t >= o.t_min && t.t <= t_max,
                        "hit t {} outside [{}, {t_max}]",
                        t.t,
                        o.t_min
                    );
                }
            }
        }
    }
    assert!(checked > 1000, "{checked} hits checked");
}

/// Cells per side of the floor's triangulation in the region tests: the
/// floor `[-8, 8]^2` in `FLOOR_CELLS^2` squares of two triangles each.
const FLOOR_CELLS: u32 = 16;

/// The floor's triangles (cell `(i, j)` gives triangles `2 (j n + i)`,
/// below its diagonal `x - x0 >= z - z0`, and `+ 1`), their vertex
/// normals tilted by up to `tilt` (x and z components) from the floor's
/// `+Y`, in both orientations of the corners.
fn floor_triangles(tilt: f32) -> Vec<PrrTriangle> {
    let n = FLOOR_CELLS;
    let size = 16.0 / n as f32;
    let mut out = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (x0, z0) = (-8.0 + i as f32 * size, -8.0 + j as f32 * size);
            let p = |dx: f32, dz: f32| Vec3::new(x0 + dx * size, 0.0, z0 + dz * size);
            let tilted = |k: u32| {
                let a = (i * 7 + j * 3 + k) as f32;
                Vec3::new(tilt * (a * 0.7).sin(), 1.0, tilt * (a * 1.3).cos()).to_array()
            };
            for corners in [
                [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
                [p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
            ] {
                let mut t = PrrTriangle::flat(corners);
                if tilt > 0.0 {
                    t.normals = [tilted(0), tilted(1), tilted(2)];
                }
                out.push(t);
            }
        }
    }
    out
}

/// Per pixel, the floor triangle its surface point lies on (from the
/// f64 scene's hit), `PRR_NO_REGION` off the floor.
fn floor_regions(f: &Frame) -> Vec<u32> {
    let (w, h) = (f.camera.width(), f.camera.height());
    let eye = f.camera.eye().as_dvec3();
    let size = 16.0 / f64::from(FLOOR_CELLS);
    let mut out = vec![PRR_NO_REGION; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            if f.id[i] != 0 {
                continue;
            }
            let d = f
                .camera
                .primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
                .dir
                .as_dvec3()
                .normalize();
            let p = eye + d * (-eye.y / d.y);
            let (u, v) = ((p.x + 8.0) / size, (p.z + 8.0) / size);
            let (ci, cj) = (u.floor().clamp(0.0, 15.0), v.floor().clamp(0.0, 15.0));
            let lower = u - ci >= v - cj;
            out[i] = 2 * (cj as u32 * FLOOR_CELLS + ci as u32) + u32::from(!lower);
        }
    }
    out
}

/// The masks of `tris` for `f`'s camera and `bounds`.
fn masks_of(f: &Frame, tris: &[PrrTriangle], bounds: &[LayeredBound]) -> (Vec<u64>, PrrStats) {
    let mut masks = vec![0u64; tris.len()];
    let st = try_prr_masks(&mut masks, tris, f.camera.eye(), bounds).unwrap();
    (masks, st)
}

#[test]
fn regions_change_no_texel_and_count_the_lookups_they_save() {
    let m = maps();
    let views = m.views();
    let mut skipped = 0u64;
    for (cam, tilt) in [
        (default_camera(), 0.0),
        (grazing_camera(), 0.0),
        (default_camera(), 0.15),
    ] {
        for conv in CONVENTIONS {
            let f = frame(cam, conv);
            let tris = floor_triangles(tilt);
            let regions = floor_regions(&f);
            let (w, h) = (f.camera.width(), f.camera.height());
            let region_view = ImageView::try_new(&regions, w, h, w).unwrap();
            for o in option_sets() {
                let bounds = prepared(&f, &views, &o);
                let (masks, st) = masks_of(&f, &tris, &bounds);
                assert_eq!(
                    (st.regions, st.pairs),
                    (tris.len() as u64, 2 * tris.len() as u64)
                );
                assert_eq!(
                    st.may_reflect,
                    masks.iter().map(|m| u64::from(m.count_ones())).sum::<u64>()
                );
                // The floor's far corners cannot show the objects.
                assert!(st.may_reflect < st.pairs, "{st:?}");
                for ids in [false, true] {
                    let mut plain =
                        LayeredPass::try_new(f.gbuffer(false), &views[..], o, &bounds).unwrap();
                    if ids {
                        plain = plain.try_with_ids(ids_view(&f), &MAP_IDS).unwrap();
                    }
                    let with = plain.try_with_regions(region_view, &masks).unwrap();
                    let (a, ca, ha, sa) = run(&plain, o.payload_color);
                    let (b, cb, hb, sb) = run(&with, o.payload_color);
                    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
                        assert_eq!(
                            bits(x),
                            bits(y),
                            "pixel {i} ({conv:?}, tilt {tilt}, ids {ids}, {o:?})"
                        );
                    }
                    assert_eq!(ca, cb);
                    assert_eq!(ha.len(), hb.len());
                    for (x, y) in ha.iter().zip(&hb) {
                        assert_eq!(host_bits(x), host_bits(y));
                    }
                    assert_eq!(sa.prr_skipped, 0);
                    assert_eq!(
                        sa.sphere_culled,
                        sb.sphere_culled + sb.prr_skipped,
                        "every pair the regions skip is one the sphere test rejects"
                    );
                    assert_eq!(
                        LayeredPassStats {
                            sphere_culled: sa.sphere_culled,
                            prr_skipped: 0,
                            ..sb
                        },
                        sa
                    );
                    skipped += sb.prr_skipped;
                }
            }
        }
    }
    assert!(skipped > 10_000, "the regions skip only {skipped} lookups");
}

/// Deterministic pseudo-random numbers in `[0, 1)`.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * (hi - lo) + Vec3::splat(lo)
    }
}

/// Random reflector triangles near the origin (small and large, some
/// degenerate, some with tilted vertex normals) and random spheres.
fn random_case(rng: &mut Lcg, maps: usize) -> (Vec<PrrTriangle>, Vec<LayeredBound>) {
    let tris = (0..200)
        .map(|k| {
            let c = rng.vec(-4.0, 4.0);
            let s = if k % 3 == 0 { 0.2 } else { 1.5 };
            let mut corners = [c + rng.vec(-s, s), c + rng.vec(-s, s), c + rng.vec(-s, s)];
            if k % 50 == 7 {
                corners[2] = corners[1];
            }
            let mut t = PrrTriangle::flat(corners);
            if k % 2 == 1 {
                let f = Vec3::from_array(t.normals[0]).normalize_or_zero();
                let tilt = if k % 10 == 9 { 2.0 } else { 0.2 };
                t.normals = [0, 1, 2].map(|_| (f + rng.vec(-tilt, tilt) * f.length()).to_array());
            }
            t
        })
        .collect();
    let bounds = (0..maps)
        .map(|_| LayeredBound {
            center: rng.vec(-5.0, 5.0).to_array(),
            radius: 0.1 + 0.8 * rng.next(),
            key: 0,
        })
        .collect();
    (tris, bounds)
}

#[test]
fn prr_masks_equal_the_classify_loop() {
    let mut rng = Lcg(19);
    let (mut set, mut unset, mut untested) = (0, 0, 0);
    for case in 0..8 {
        let n = [1, 5, 17, 63, 64, 0, 65, 130][case];
        let (tris, bounds) = random_case(&mut rng, n);
        let eye = rng.vec(-6.0, 6.0);
        let words = prr_mask_words(n);
        assert_eq!(words, n.div_ceil(64).max(1));
        let len = try_prr_masks_len(tris.len(), n).unwrap();
        assert_eq!(len, tris.len() * words);
        let mut masks = vec![u64::MAX; len + 1];
        let st = try_prr_masks(&mut masks, &tris, eye, &bounds).unwrap();
        assert_eq!(
            masks[len],
            u64::MAX,
            "past the triangles nothing is written"
        );
        let mut want = PrrStats {
            regions: tris.len() as u64,
            pairs: (tris.len() * n) as u64,
            ..PrrStats::default()
        };
        for (t, tri) in tris.iter().enumerate() {
            let mut mask = vec![0u64; words];
            for (k, b) in bounds.iter().enumerate() {
                let center = Vec3::from_array(b.center);
                let corners = tri.corners.map(Vec3::from_array);
                let bit = match prr_radii(tri, eye, b) {
                    None => {
                        want.untested += 1;
                        true
                    }
                    Some(r) => {
                        // The near rule: box and plane within `near`.
                        let v = corners.map(|c| c.as_dvec3());
                        let o = center.as_dvec3();
                        let lo = v[0].min(v[1]).min(v[2]);
                        let hi = v[0].max(v[1]).max(v[2]);
                        let nrm = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                        let near = f64::from(r.near);
                        ((o - o.clamp(lo, hi)).length() <= near && nrm.dot(o - v[0]).abs() <= near)
                            || match try_prr_classify(eye, center, r.cone, corners) {
                                Ok(c) => c.may_reflect(),
                                Err(e) => {
                                    assert_eq!(e, Error::DegenerateGeometry);
                                    true
                                }
                            }
                    }
                };
                if bit {
                    mask[k / 64] |= 1 << (k % 64);
                    want.may_reflect += 1;
                    set += 1;
                } else {
                    unset += 1;
                }
            }
            assert_eq!(
                masks[t * words..(t + 1) * words],
                mask[..],
                "triangle {t} of case {case}"
            );
        }
        untested += want.untested;
        assert_eq!(st, want);
    }
    assert!(
        set > 500 && unset > 500 && untested > 50,
        "{set} set, {unset} unset, {untested} untested"
    );
}

/// Seed 001 Sec. 3.2 for flat triangles: with the radii of `prr_radii`
/// the masks keep every map whose padded sphere a mirror ray from a point
/// of the triangle meets, and with the seed's own radius (the sphere's)
/// they are the seed's test exactly; tilted normals only add maps.
#[test]
fn prr_masks_keep_every_map_a_mirror_ray_meets() {
    let mut rng = Lcg(7);
    let (mut checked, mut meets) = (0u64, 0u64);
    for _ in 0..4 {
        let (tris, bounds) = random_case(&mut rng, 24);
        let eye = rng.vec(-6.0, 6.0);
        let mut masks = vec![0u64; tris.len()];
        try_prr_masks(&mut masks, &tris, eye, &bounds).unwrap();
        for (t, tri) in tris.iter().enumerate() {
            let Some(sin_delta) = tri.normal_spread_sin() else {
                assert_eq!(masks[t], (1 << bounds.len()) - 1);
                continue;
            };
            let v = tri.corners.map(|c| Vec3::from_array(c).as_dvec3());
            let nv = tri.normals.map(|c| Vec3::from_array(c).as_dvec3());
            let f = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            for _ in 0..40 {
                let (a, b) = (f64::from(rng.next()), f64::from(rng.next()));
                let (a, b) = if a + b > 1.0 {
                    (1.0 - a, 1.0 - b)
                } else {
                    (a, b)
                };
                let w = [1.0 - a - b, a, b];
                let p = v[0] * w[0] + v[1] * w[1] + v[2] * w[2];
                let n = (nv[0] * w[0] + nv[1] * w[1] + nv[2] * w[2]).normalize();
                assert!(n.dot(f).abs() >= (1.0 - sin_delta * sin_delta).sqrt() - 1e-9);
                let view = (p - eye.as_dvec3()).normalize();
                let r = view - 2.0 * view.dot(n) * n;
                for (k, bd) in bounds.iter().enumerate() {
                    let o = DVec3::from_array(bd.center.map(f64::from));
                    // The ray from p meets the sphere (radius widened by the
                    // pass's pad at the surface point).
                    let pad = f64::from(bd.radius) * (1.0 + 1e-4);
                    let oc = o - p;
                    let tc = oc.dot(r);
                    let perp2 = (oc - r * tc).length_squared();
                    let hit = perp2 <= pad * pad && (tc >= 0.0 || oc.length() <= pad);
                    checked += 1;
                    if hit {
                        meets += 1;
                        assert!(
                            masks[t] >> k & 1 == 1,
                            "triangle {t}, map {k}: a ray meets it"
                        );
                    }
                }
            }
        }
    }
    assert!(meets > 1000 && checked > 10 * meets, "{meets} of {checked}");
}

#[test]
fn prr_refusals_leave_every_output_untouched() {
    let mut rng = Lcg(3);
    let (tris, bounds) = random_case(&mut rng, 4);
    let eye = Vec3::new(0.0, 1.0, 9.0);
    let mut dst = vec![7u64; 2 * tris.len()];
    let mut bad_tri = tris.clone();
    bad_tri[3].corners[1][2] = f32::NAN;
    let mut bad_normal = tris.clone();
    bad_normal[5].normals[0][0] = f32::INFINITY;
    let many = vec![bounds[0]; 65];
    let bad_radius = [LayeredBound {
        radius: -1.0,
        ..bounds[0]
    }];
    let bad_center = [LayeredBound {
        center: [0.0, f32::NAN, 0.0],
        ..bounds[0]
    }];
    // (triangles, eye, bounds, dst length, error)
    type Case<'a> = (&'a [PrrTriangle], Vec3, &'a [LayeredBound], usize, Error);
    let cases: [Case<'_>; 8] = [
        (
            &tris,
            Vec3::new(f32::NAN, 0.0, 0.0),
            &bounds,
            tris.len(),
            Error::InvalidArgument,
        ),
        (
            &tris,
            Vec3::splat(f32::INFINITY),
            &bounds,
            tris.len(),
            Error::InvalidArgument,
        ),
        (&bad_tri, eye, &bounds, tris.len(), Error::InvalidArgument),
        (
            &bad_normal,
            eye,
            &bounds,
            tris.len(),
            Error::InvalidArgument,
        ),
        (
            &tris,
            eye,
            &many,
            2 * tris.len() - 1,
            Error::InsufficientSize,
        ),
        (&tris, eye, &bad_radius, tris.len(), Error::InvalidArgument),
        (&tris, eye, &bad_center, tris.len(), Error::InvalidArgument),
        (&tris, eye, &bounds, tris.len() - 1, Error::InsufficientSize),
    ];
    for (t, e, b, len, err) in cases {
        assert_eq!(try_prr_masks(&mut dst[..len], t, e, b), Err(err));
        assert!(dst.iter().all(|&m| m == 7));
    }
    // No triangles are fine; a count that overflows is refused.
    assert!(try_prr_masks(&mut [], &[], eye, &many).is_ok());
    assert_eq!(
        try_prr_masks_len(usize::MAX, 65),
        Err(Error::InvalidArgument)
    );
    assert_eq!(try_prr_masks_len(usize::MAX, 64), Ok(usize::MAX));

    // The pass: regions of the wrong size, an id out of range (one word
    // per region; two for 65 maps).
    let m = maps();
    let views = m.views();
    let f = frame(default_camera(), refl_core::DepthConvention::Linear);
    let (w, h) = (f.camera.width(), f.camera.height());
    let o = LayeredPassOptions::default();
    let b = prepared(&f, &views, &o);
    let pass = LayeredPass::try_new(f.gbuffer(false), &views[..], o, &b).unwrap();
    let masks = [3u64; 4];
    let mut regions = vec![PRR_NO_REGION; (w * h) as usize];
    regions[5] = 3;
    let small = ImageView::try_new(&regions[..(w * (h - 1)) as usize], w, h - 1, w).unwrap();
    assert_eq!(
        pass.try_with_regions(small, &masks).err(),
        Some(Error::InvalidArgument)
    );
    assert!(pass
        .try_with_regions(ImageView::try_new(&regions, w, h, w).unwrap(), &masks)
        .is_ok());
    regions[(w * h - 1) as usize] = 4;
    let out_of_range = ImageView::try_new(&regions, w, h, w).unwrap();
    assert_eq!(
        pass.try_with_regions(out_of_range, &masks).err(),
        Some(Error::InvalidArgument)
    );
    let many_views = vec![views[0]; 65];
    let many_bounds = prepared(&f, &many_views, &o);
    let big = LayeredPass::try_new(f.gbuffer(false), &many_views[..], o, &many_bounds).unwrap();
    let mut two = vec![PRR_NO_REGION; (w * h) as usize];
    two[7] = 1;
    let two = ImageView::try_new(&two, w, h, w).unwrap();
    assert_eq!(
        big.try_with_regions(two, &masks[..3]).err(),
        Some(Error::InvalidArgument)
    );
    assert!(big.try_with_regions(two, &masks).is_ok());
}
