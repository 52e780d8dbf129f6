//! The cluster pass (`refl_core::cluster::pass`) against the seed 003
//! kernels it wraps: its plan equals `try_count_objects`, `try_bin_layout`,
//! `try_assign_clusters`, `try_cluster_ranges` and `try_cluster_camera` on
//! the G-buffer's surfaces (derived here from `GBuffer::surface` and the
//! mirror pass's normal rule), its finalize equals `try_finalize_cluster`
//! bit for bit over any split into row bands, its host rays are the mirror
//! pass's; hostile input is refused with every output untouched; the
//! frustum planes against projection.
#![cfg(feature = "cluster")]

use refl_core::cluster::*;
use refl_core::glam::{DVec3, Vec2, Vec3};
use refl_core::{
    Camera, DepthConvention, DepthImage, Error, GBuffer, HostRay, ImageView, ImageViewMut,
    MirrorStatus, NormalSpace, RowRange, Thickness,
};

const W: u32 = 96;
const H: u32 = 64;
const N: usize = (W * H) as usize;

fn camera() -> Camera {
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

const SPHERE_C: DVec3 = DVec3::new(0.0, 1.0, 0.0);

/// The first hit after `t_min` of the scene (floor `y = 0` within 8 of the
/// origin, object 0; unit sphere at (0, 1, 0), object 1; wall `z = -4`,
/// object 2), leaving out `skip`: `(t, point, normal, object)`.
fn cast(o: DVec3, d: DVec3, t_min: f64, skip: Option<u32>) -> Option<(f64, DVec3, DVec3, u32)> {
    let mut best: Option<(f64, DVec3, DVec3, u32)> = None;
    let mut take = |t: f64, n: DVec3, id: u32, ok: &dyn Fn(DVec3) -> bool| {
        let p = o + d * t;
        if t > t_min && skip != Some(id) && ok(p) && best.is_none_or(|b| t < b.0) {
            best = Some((t, p, n, id));
        }
    };
    if d.y != 0.0 {
        take(-o.y / d.y, DVec3::Y, 0, &|p| {
            p.x.abs() < 8.0 && p.z.abs() < 8.0
        });
    }
    let oc = o - SPHERE_C;
    let b = oc.dot(d);
    let disc = b * b - (oc.dot(oc) - 1.0);
    if disc > 0.0 {
        for t in [-b - disc.sqrt(), -b + disc.sqrt()] {
            let n = (o + d * t - SPHERE_C).normalize();
            take(t, n, 1, &|_| true);
        }
    }
    if d.z != 0.0 {
        take((-4.0 - o.z) / d.z, DVec3::Z, 2, &|p| {
            p.x.abs() < 8.0 && p.y > 0.0 && p.y < 5.0
        });
    }
    best
}

fn shade_of(p: DVec3) -> [f32; 3] {
    [
        (0.5 + 0.4 * (p.x * 0.9).sin()) as f32,
        (0.5 + 0.4 * (p.y * 1.3).cos()) as f32,
        (0.5 + 0.3 * (p.z * 0.7).sin()) as f32,
    ]
}

/// A G-buffer of the scene (per pixel center in f64).
struct Frame {
    cam: Camera,
    conv: DepthConvention,
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    ids: Vec<u32>,
}

fn frame(conv: DepthConvention, flip_sphere: bool) -> Frame {
    let cam = camera();
    let far = cam.encode_depth(cam.far(), conv);
    let mut f = Frame {
        cam,
        conv,
        depth: vec![far; N],
        normals: vec![[0.0; 3]; N],
        ids: vec![u32::MAX; N],
    };
    for y in 0..H {
        for x in 0..W {
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let Some((_, p, n, id)) = cast(r.origin.as_dvec3(), r.dir.as_dvec3(), 0.0, None) else {
                continue;
            };
            let i = (y * W + x) as usize;
            f.depth[i] = cam.encode_depth(cam.linear_depth(p.as_vec3()), conv);
            // A two-sided surface's normal may face away (the pass turns it).
            let n = if flip_sphere && id == 1 { -n } else { n };
            f.normals[i] = n.as_vec3().to_array();
            f.ids[i] = id;
        }
    }
    f
}

impl Frame {
    fn gbuffer(&self) -> GBuffer<'_> {
        let d = DepthImage::try_new(
            ImageView::try_new(&self.depth, W, H, W).unwrap(),
            self.cam,
            self.conv,
        )
        .unwrap();
        GBuffer::try_new(
            d,
            ImageView::try_new(&self.normals, W, H, W).unwrap(),
            NormalSpace::World,
        )
        .unwrap()
    }

    fn objects<'a>(&'a self, lobes: &'a [Lobe]) -> ClusterObjects<'a> {
        ClusterObjects {
            ids: ImageView::try_new(&self.ids, W, H, W).unwrap(),
            lobes,
        }
    }
}

fn glossy() -> Lobe {
    Lobe {
        rays: 8,
        exponent: 40.0,
        max_angle: try_lobe_angle(40.0, 0.95).unwrap(),
    }
}

/// The kernels' inputs derived independently from the G-buffer: the
/// surface point of `GBuffer::surface`, its normal turned toward the eye
/// when it faces away (the mirror pass's rule), the object where the pass
/// counts one (an id below `lobes`, a surface).
struct Derived {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    objects: Vec<u32>,
}

fn derive(g: &GBuffer<'_>, ids: &[u32], objects: usize) -> Derived {
    let eye = g.camera().eye();
    let mut d = Derived {
        positions: vec![[0.0; 3]; N],
        normals: vec![[0.0, 1.0, 0.0]; N],
        objects: vec![NO_OBJECT; N],
    };
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let Some(s) = g.surface(x, y) else { continue };
            let v = (s.position - eye).normalize_or_zero();
            let n = if s.normal.dot(v) > 0.0 {
                -s.normal
            } else {
                s.normal
            };
            d.positions[i] = s.position.to_array();
            d.normals[i] = n.to_array();
            if (ids[i] as usize) < objects {
                d.objects[i] = ids[i];
            }
        }
    }
    d
}

impl Derived {
    fn input(&self) -> ClusterInput<'_> {
        ClusterInput {
            positions: ImageView::try_new(&self.positions, W, H, W).unwrap(),
            normals: ImageView::try_new(&self.normals, W, H, W).unwrap(),
        }
    }
}

/// A plan's memory.
struct Plan {
    ids: Vec<u32>,
    order: Vec<u32>,
    offsets: Vec<u32>,
    counts: Vec<u32>,
    layout: Vec<ObjectBins>,
    entries: Vec<Option<ClusterPlanEntry>>,
}

impl Plan {
    fn new(len: &ClusterPlanLen) -> Self {
        Plan {
            ids: vec![7; len.ids],
            order: vec![7; len.order],
            offsets: vec![7; len.offsets],
            counts: vec![7; len.counts],
            layout: vec![
                ObjectBins {
                    theta_bins: 7,
                    phi_bins: 7,
                    first: 7
                };
                len.layout
            ],
            entries: vec![None; len.clusters],
        }
    }

    fn scratch(&mut self) -> ClusterScratchMut<'_> {
        ClusterScratchMut {
            ids: &mut self.ids,
            order: &mut self.order,
            offsets: &mut self.offsets,
            counts: &mut self.counts,
            layout: &mut self.layout,
        }
    }

    fn snapshot(&self) -> String {
        format!(
            "{:?}{:?}{:?}{:?}{:?}{:?}",
            self.ids, self.order, self.offsets, self.counts, self.layout, self.entries
        )
    }
}

fn plan(
    pass: &ClusterPass<'_>,
    objects: &ClusterObjects<'_>,
) -> (Plan, ClusterPlanStats, Vec<ClusterPlanEntry>) {
    let len = try_cluster_plan_len(W, H, objects.lobes.len(), pass.options()).unwrap();
    let mut p = Plan::new(&len);
    let mut entries = std::mem::take(&mut p.entries);
    let st = pass.try_plan(&mut entries, p.scratch(), objects).unwrap();
    let list: Vec<ClusterPlanEntry> = entries[..st.clusters as usize]
        .iter()
        .map(|e| e.unwrap())
        .collect();
    assert!(entries[st.clusters as usize..].iter().all(Option::is_none));
    p.entries = entries;
    (p, st, list)
}

fn options() -> ClusterPassOptions {
    let mut o = ClusterPassOptions::default();
    o.camera.far_distance = 20.0;
    o.cluster.gain = 16.0;
    o
}

#[test]
fn plan_equals_the_kernels_bit_for_bit() {
    for (conv, flip, lobes) in [
        (
            DepthConvention::Linear,
            false,
            vec![Lobe::MIRROR, Lobe::MIRROR],
        ),
        (
            DepthConvention::ZeroToOne,
            true,
            vec![Lobe::MIRROR, glossy()],
        ),
        (DepthConvention::ReversedZ, false, vec![glossy()]),
    ] {
        let f = frame(conv, flip);
        let g = f.gbuffer();
        let o = options();
        let pass = ClusterPass::try_new(g, o).unwrap();
        let objects = f.objects(&lobes);
        let (p, st, entries) = plan(&pass, &objects);
        // The kernels on the derived inputs.
        let d = derive(&g, &f.ids, lobes.len());
        let ov = ImageView::try_new(&d.objects, W, H, W).unwrap();
        let mut counts = vec![0u32; lobes.len()];
        try_count_objects(&mut counts, &ov, RowRange::try_all(H).unwrap()).unwrap();
        let mut layout = vec![ObjectBins::default(); lobes.len()];
        let bins = try_bin_layout(&mut layout, &counts, N as u64, &o.cluster).unwrap();
        let mut ids = vec![0u32; N];
        try_assign_clusters(
            &mut ImageViewMut::try_new(&mut ids, W, H, W).unwrap(),
            &ImageView::try_new(&d.normals, W, H, W).unwrap(),
            &ov,
            &layout,
        )
        .unwrap();
        let mut offsets = vec![0u32; bins as usize + 1];
        let mut order = vec![0u32; N];
        let total = try_cluster_ranges(
            &mut offsets,
            &mut order,
            &ImageView::try_new(&ids, W, H, W).unwrap(),
            bins,
        )
        .unwrap();
        assert_eq!(st.bins, bins);
        assert_eq!(st.pixels, total);
        assert!(total > 1000, "{total}");
        assert_eq!(p.counts, counts);
        assert_eq!(p.layout, layout);
        assert_eq!(p.ids, ids);
        assert_eq!(p.order[..total as usize], order[..total as usize]);
        assert_eq!(&p.offsets[..offsets.len()], &offsets[..]);
        // One entry per non-empty cluster, in id order, with the kernel's
        // camera.
        let input = d.input();
        let eye = g.camera().eye();
        let mut k = 0;
        for c in 0..bins {
            let (a, b) = (offsets[c as usize], offsets[c as usize + 1]);
            if b == a {
                continue;
            }
            let e = &entries[k];
            k += 1;
            let px = &order[a as usize..b as usize];
            let object = d.objects[px[0] as usize];
            let lobe = lobes[object as usize];
            let mut co = o.camera;
            if lobe.rays > 1 {
                co.cone_half_angle = co.cone_half_angle.max(lobe.max_angle);
            }
            let view = try_cluster_camera(&input, px, eye, &co).unwrap();
            assert_eq!(
                (e.id, e.object, e.first, e.len, e.lobe),
                (c, object, a, b - a, lobe)
            );
            assert_eq!(
                e.rows,
                RowRange::try_new(px[0] / W, px[px.len() - 1] / W + 1, H).unwrap()
            );
            assert_eq!(e.view, view, "cluster {c}");
            match view {
                ClusterView::Camera(cc) => assert_eq!(e.frustum, cc.camera.frustum_planes()),
                ClusterView::Fallback(_) => assert_eq!(e.frustum, [Default::default(); 6]),
            }
        }
        assert_eq!(k, entries.len());
        assert_eq!(st.clusters as usize, entries.len());
        let cams = entries.iter().filter(|e| e.camera().is_some()).count();
        assert_eq!(st.cameras as usize, cams);
        assert!(cams >= lobes.len(), "{cams}");
        assert_eq!(
            st.planar as usize,
            entries
                .iter()
                .filter(|e| e.camera().is_some_and(|c| c.planar))
                .count()
        );
    }
}

/// Seed 003 Sec. 3.5 item 2: with a glossy blur radius `r`, each glossy
/// cluster's camera has its far plane at `min(D, r / tan(max_angle))`
/// (f64 closed form) and is otherwise the kernel's camera for those
/// options, bit for bit; mirror clusters keep `D`; `r = +inf` (the
/// default) changes nothing; `r <= 0` or NaN is refused.
#[test]
fn glossy_clusters_bring_their_far_plane_in() {
    let f = frame(DepthConvention::ReversedZ, true);
    let g = f.gbuffer();
    let lobes = vec![Lobe::MIRROR, glossy()];
    let objects = f.objects(&lobes);
    let (_, _, before) = plan(&ClusterPass::try_new(g, options()).unwrap(), &objects);
    let d = derive(&g, &f.ids, lobes.len());
    let input = d.input();
    let eye = g.camera().eye();
    for r in [0.5f32, 3.0, 1e6, f32::INFINITY] {
        let mut o = options();
        o.camera.glossy_blur_radius = r;
        let pass = ClusterPass::try_new(g, o).unwrap();
        let (p, _, entries) = plan(&pass, &objects);
        let (mut glossy_cams, mut nearer) = (0, 0);
        for (e, b) in entries.iter().zip(&before) {
            let px = &p.order[e.first as usize..(e.first + e.len) as usize];
            let mut co = o.camera;
            let want = if e.lobe.rays > 1 {
                co.cone_half_angle = co.cone_half_angle.max(e.lobe.max_angle);
                (f64::from(r) / f64::from(e.lobe.max_angle).tan()).min(20.0)
            } else {
                20.0
            };
            let Some(cc) = e.camera() else {
                continue;
            };
            let rel = (f64::from(cc.far_distance) - want).abs() / want;
            assert!(rel < 1e-6, "r {r}: far {} vs {want}", cc.far_distance);
            co.far_distance = cc.far_distance;
            assert_eq!(e.view, try_cluster_camera(&input, px, eye, &co).unwrap());
            if e.lobe.rays > 1 {
                glossy_cams += 1;
                nearer += usize::from(cc.far_distance < 20.0);
            }
            if r >= 1e6 {
                assert_eq!(e, b, "r {r}: the plan changed");
            }
        }
        assert!(glossy_cams > 0, "r {r}");
        assert_eq!(
            nearer > 0,
            r < 10.0,
            "r {r}: {nearer} of {glossy_cams} nearer"
        );
    }
    for bad in [0.0, -1.0, f32::NAN] {
        let mut o = options();
        o.camera.glossy_blur_radius = bad;
        assert!(
            matches!(ClusterPass::try_new(g, o), Err(Error::InvalidArgument)),
            "{bad}"
        );
    }
}

/// The host's render of an entry: the scene through its camera, only what
/// lies strictly in front of its clip plane, a planar cluster without its
/// own object.
fn render(e: &ClusterPlanEntry, conv: DepthConvention) -> (Vec<f32>, Vec<[f32; 3]>) {
    let cc = e.camera().unwrap();
    let cam = &cc.camera;
    let (w, h) = (cam.width(), cam.height());
    let empty = if conv == DepthConvention::Linear {
        f32::INFINITY
    } else {
        cam.encode_depth(cam.far(), conv)
    };
    let mut depth = vec![empty; (w * h) as usize];
    let mut color = vec![[0.0f32; 3]; (w * h) as usize];
    let (cn, cp) = (cc.clip.normal.as_dvec3(), cc.clip.point.as_dvec3());
    for y in 0..h {
        for x in 0..w {
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (o, d) = (r.origin.as_dvec3(), r.dir.as_dvec3());
            let (so, dn) = ((o - cp).dot(cn), d.dot(cn));
            let t_clip = if so > 0.0 {
                0.0
            } else if dn > 0.0 {
                -so / dn
            } else {
                continue;
            };
            let skip = cc.planar.then_some(e.object);
            if let Some((_, p, _, _)) = cast(o, d, t_clip, skip) {
                let z = cam.linear_depth(p.as_vec3());
                if z < cam.far() {
                    depth[(y * w + x) as usize] = cam.encode_depth(z, conv);
                    color[(y * w + x) as usize] = shade_of(p);
                }
            }
        }
    }
    (depth, color)
}

/// Collects a finalize call's results.
#[derive(Default)]
struct Collect {
    texels: Vec<(u32, u32, ClusterTexel)>,
    host: Vec<HostRay>,
    cap: usize,
}

impl ClusterSink for Collect {
    fn texel(&mut self, x: u32, y: u32, texel: &ClusterTexel) {
        self.texels.push((x, y, *texel));
    }
    fn host(&mut self, index: u32, ray: &HostRay) -> bool {
        assert_eq!(index as usize, self.host.len());
        if self.host.len() < self.cap {
            self.host.push(*ray);
            true
        } else {
            false
        }
    }
}

fn bits(s: &ClusterShade) -> [u32; 15] {
    let v = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    let [a, b, c] = v(s.rgb);
    let [d, e, f] = v(s.env_dir);
    let [g, h, i] = v(s.mirror_dir);
    [
        a,
        b,
        c,
        s.hit_weight.to_bits(),
        s.env_weight.to_bits(),
        d,
        e,
        f,
        g,
        h,
        i,
        s.rays,
        s.hits,
        s.fetches,
        s.steps,
    ]
}

#[test]
fn finalize_equals_the_kernel_bit_for_bit_over_any_bands() {
    let mut statuses = std::collections::BTreeMap::<u8, usize>::new();
    for (conv, flip, lobes, fade, back) in [
        (
            DepthConvention::Linear,
            false,
            vec![Lobe::MIRROR, Lobe::MIRROR],
            false,
            false,
        ),
        (
            DepthConvention::ReversedZ,
            true,
            vec![Lobe::MIRROR, glossy()],
            true,
            false,
        ),
        (
            DepthConvention::ZeroToOne,
            false,
            vec![glossy(), Lobe::MIRROR],
            false,
            true,
        ),
    ] {
        let f = frame(conv, flip);
        let g = f.gbuffer();
        let o = ClusterPassOptions {
            fade,
            seed: 5,
            refine: !fade,
            ..options()
        };
        let pass = ClusterPass::try_new(g, o).unwrap();
        let objects = f.objects(&lobes);
        let (p, _, entries) = plan(&pass, &objects);
        let d = derive(&g, &f.ids, lobes.len());
        let input = d.input();
        let eye = g.camera().eye();
        for e in &entries {
            let px = &p.order[e.first as usize..(e.first + e.len) as usize];
            let Some(cc) = e.camera() else {
                continue;
            };
            let (depth, color) = render(e, conv);
            let (dw, dh) = (cc.camera.width(), cc.camera.height());
            let di = DepthImage::try_new(
                ImageView::try_new(&depth, dw, dh, dw).unwrap(),
                cc.camera,
                conv,
            )
            .unwrap();
            let cv = ImageView::try_new(&color, dw, dh, dw).unwrap();
            // A back-face image: every surface 0.2 deep (linear).
            let backs: Vec<f32> = depth
                .iter()
                .map(|&z| {
                    let l = cc.camera.decode_depth(z, conv);
                    if l.is_finite() && l < cc.camera.far() {
                        cc.camera.encode_depth((l + 0.2).min(cc.camera.far()), conv)
                    } else {
                        z
                    }
                })
                .collect();
            let bv = ImageView::try_new(&backs, dw, dh, dw).unwrap();
            let mut rv = ClusterRender::try_new(di, cv).unwrap();
            if back {
                rv = rv.try_with_back_depth(bv).unwrap();
            }
            // The kernel.
            let fin = FinalizeInput {
                thickness: if back {
                    Thickness::BackFaces(bv)
                } else {
                    Thickness::Constant(o.thickness * o.camera.far_distance)
                },
                step: o.step,
                refine: o.refine,
                lobe: e.lobe,
                // Glossy clusters only (seed 003 Sec. 3.5 item 2).
                fade: o.fade && e.lobe.rays > 1,
                seed: o.seed,
                single_ray: o.glossy_single_ray,
            };
            let mut want = vec![ClusterShade::default(); px.len()];
            try_finalize_cluster(&mut want, &input, px, eye, cc, &di, &cv, &fin).unwrap();
            // The pass, over the entry's rows in three bands and whole.
            for count in [1u32, 3] {
                let mut got = Vec::new();
                let mut hosts = Vec::new();
                for b in 0..count {
                    let Some(rows) = e.rows.band(b, count) else {
                        continue;
                    };
                    let mut sink = Collect {
                        cap: usize::MAX,
                        ..Collect::default()
                    };
                    let st = pass
                        .try_finalize_rows(e, &p.order, Some(&rv), rows, &mut sink)
                        .unwrap();
                    assert_eq!(st.pixels as usize, sink.texels.len());
                    assert_eq!(st.host_rays as usize, sink.host.len());
                    assert_eq!(st.host_rays_written, st.host_rays);
                    got.extend(sink.texels);
                    hosts.extend(sink.host);
                }
                assert_eq!(got.len(), px.len());
                let mut want_hosts = Vec::new();
                for ((x, y, t), (&pp, w)) in got.iter().zip(px.iter().zip(&want)) {
                    assert_eq!((*x, *y), (pp % W, pp / W));
                    assert_eq!(bits(&t.shade), bits(w), "pixel {pp}");
                    *statuses.entry(t.status as u8).or_default() += 1;
                    match t.status {
                        MirrorStatus::Hit => assert_eq!(w.hits, w.rays),
                        MirrorStatus::Sky => assert!(w.env_weight > 0.0),
                        s => {
                            assert!(s.needs_host() && w.env_weight > 0.0, "{s:?}");
                            want_hosts.push(pass.mirror_pass().host_ray(*x, *y, s).unwrap());
                        }
                    }
                }
                assert_eq!(hosts, want_hosts);
            }
            // The image variant writes the same texels and leaves the rest.
            let sentinel = ClusterTexel {
                status: MirrorStatus::Hidden,
                ..ClusterTexel::default()
            };
            let mut img = vec![sentinel; N];
            let mut host = vec![HostRay::default(); 4];
            let st = pass
                .try_finalize(
                    &mut ImageViewMut::try_new(&mut img, W, H, W).unwrap(),
                    &mut host,
                    e,
                    &p.order,
                    Some(&rv),
                )
                .unwrap();
            assert_eq!(st.host_rays_written, st.host_rays.min(4));
            for (i, t) in img.iter().enumerate() {
                match px.iter().position(|&q| q as usize == i) {
                    Some(k) => assert_eq!(bits(&t.shade), bits(&want[k])),
                    None => assert_eq!(*t, sentinel),
                }
            }
        }
    }
    // Every status occurs: hits, environment, and host rays.
    let has = |s: MirrorStatus| statuses.get(&(s as u8)).copied().unwrap_or(0) > 0;
    assert!(has(MirrorStatus::Hit), "{statuses:?}");
    assert!(has(MirrorStatus::Sky), "{statuses:?}");
    assert!(
        has(MirrorStatus::LeftImage) || has(MirrorStatus::BehindGeometry),
        "{statuses:?}"
    );
}

#[test]
fn clusters_without_a_camera_go_to_the_host() {
    let f = frame(DepthConvention::Linear, false);
    let g = f.gbuffer();
    let mut o = options();
    o.camera.min_pixels = u32::MAX;
    let pass = ClusterPass::try_new(g, o).unwrap();
    let lobes = [Lobe::MIRROR, Lobe::MIRROR];
    let (p, st, entries) = plan(&pass, &f.objects(&lobes));
    assert_eq!(st.cameras, 0);
    let mut n = 0;
    for e in &entries {
        assert_eq!(e.view, ClusterView::Fallback(ClusterFallback::TooFewPixels));
        let mut sink = Collect {
            cap: 3,
            ..Collect::default()
        };
        let st = pass
            .try_finalize_rows(e, &p.order, None, e.rows, &mut sink)
            .unwrap();
        assert_eq!(st.host_rays, e.len);
        assert_eq!(st.host_rays_written, e.len.min(3));
        for (x, y, t) in &sink.texels {
            assert_eq!(t.status, MirrorStatus::NoProjection);
            let hr = pass
                .mirror_pass()
                .host_ray(*x, *y, MirrorStatus::NoProjection)
                .unwrap();
            assert_eq!(t.shade.env_weight, 1.0);
            assert_eq!((t.shade.env_dir, t.shade.mirror_dir), (hr.dir, hr.dir));
            assert_eq!(t.shade.rays, 0);
            n += 1;
        }
        for (k, h) in sink.host.iter().enumerate() {
            let (x, y, _) = sink.texels[k];
            assert_eq!(
                *h,
                pass.mirror_pass()
                    .host_ray(x, y, MirrorStatus::NoProjection)
                    .unwrap()
            );
        }
    }
    assert_eq!(n, st.pixels);
}

#[test]
fn hostile_input_is_refused_and_nothing_is_written() {
    let f = frame(DepthConvention::Linear, false);
    let g = f.gbuffer();
    let o = options();
    // Options.
    for bad in [
        ClusterPassOptions {
            thickness: f32::NAN,
            ..o
        },
        ClusterPassOptions {
            thickness: -1.0,
            ..o
        },
        ClusterPassOptions { t_max: 0.0, ..o },
        ClusterPassOptions {
            t_min: f32::NAN,
            ..o
        },
        ClusterPassOptions {
            step: refl_core::StepOptions {
                stride: 0,
                max_steps: 9,
            },
            ..o
        },
        ClusterPassOptions {
            cluster: ClusterOptions {
                gain: f32::NAN,
                ..o.cluster
            },
            ..o
        },
        ClusterPassOptions {
            camera: ClusterCameraOptions {
                far_distance: f32::NAN,
                ..o.camera
            },
            ..o
        },
    ] {
        assert_eq!(
            ClusterPass::try_new(g, bad).err(),
            Some(Error::InvalidArgument)
        );
    }
    let pass = ClusterPass::try_new(g, o).unwrap();
    let lobes = [Lobe::MIRROR, Lobe::MIRROR];
    let len = try_cluster_plan_len(W, H, 2, &o).unwrap();
    assert_eq!(
        try_cluster_plan_len(0, H, 2, &o),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        try_cluster_plan_len(W, H, usize::MAX, &o),
        Err(Error::InvalidArgument)
    );
    // Plan: short parts, a short list, bad lobes, ids of another size.
    let small_ids = vec![0u32; N - W as usize];
    let bad_lobe = [
        Lobe::MIRROR,
        Lobe {
            rays: 8,
            exponent: f32::NAN,
            max_angle: 0.3,
        },
    ];
    type Cut = Box<dyn Fn(&mut Plan)>;
    let cases: Vec<(Cut, ClusterObjects<'_>, Error)> = vec![
        (
            Box::new(|p: &mut Plan| p.ids.pop().map(drop).unwrap()),
            f.objects(&lobes),
            Error::InsufficientSize,
        ),
        (
            Box::new(|p: &mut Plan| p.order.pop().map(drop).unwrap()),
            f.objects(&lobes),
            Error::InsufficientSize,
        ),
        (
            Box::new(|p: &mut Plan| p.offsets.pop().map(drop).unwrap()),
            f.objects(&lobes),
            Error::InsufficientSize,
        ),
        (
            Box::new(|p: &mut Plan| p.counts.pop().map(drop).unwrap()),
            f.objects(&lobes),
            Error::InsufficientSize,
        ),
        (
            Box::new(|p: &mut Plan| p.layout.pop().map(drop).unwrap()),
            f.objects(&lobes),
            Error::InsufficientSize,
        ),
        (
            Box::new(|p: &mut Plan| p.entries.pop().map(drop).unwrap()),
            f.objects(&lobes),
            Error::InsufficientSize,
        ),
        (
            Box::new(|_: &mut Plan| {}),
            f.objects(&bad_lobe),
            Error::InvalidArgument,
        ),
        (
            Box::new(|_: &mut Plan| {}),
            ClusterObjects {
                ids: ImageView::try_new(&small_ids, W, H - 1, W).unwrap(),
                lobes: &lobes,
            },
            Error::InvalidArgument,
        ),
    ];
    for (k, (cut, objects, want)) in cases.iter().enumerate() {
        let mut p = Plan::new(&len);
        cut(&mut p);
        let before = p.snapshot();
        let mut entries = std::mem::take(&mut p.entries);
        let r = pass.try_plan(&mut entries, p.scratch(), objects);
        p.entries = entries;
        assert_eq!(r, Err(*want), "case {k}");
        assert_eq!(p.snapshot(), before, "case {k} wrote");
    }
    // Finalize: a valid plan and render, then one bad argument at a time.
    let (p, _, entries) = plan(&pass, &f.objects(&lobes));
    let e = *entries.iter().find(|e| e.camera().is_some()).unwrap();
    let cc = *e.camera().unwrap();
    let (depth, color) = render(&e, DepthConvention::Linear);
    let (dw, dh) = (cc.camera.width(), cc.camera.height());
    let dv = ImageView::try_new(&depth, dw, dh, dw).unwrap();
    let cv = ImageView::try_new(&color, dw, dh, dw).unwrap();
    let di = DepthImage::try_new(dv, cc.camera, DepthConvention::Linear).unwrap();
    let rv = ClusterRender::try_new(di, cv).unwrap();
    // Sizes: color or back faces of another size than the depth.
    let tiny = vec![[0.0f32; 3]; 4];
    assert_eq!(
        ClusterRender::try_new(di, ImageView::try_new(&tiny, 2, 2, 2).unwrap()).err(),
        Some(Error::InvalidArgument)
    );
    let tiny_f = vec![0.0f32; 4];
    assert_eq!(
        rv.try_with_back_depth(ImageView::try_new(&tiny_f, 2, 2, 2).unwrap())
            .err(),
        Some(Error::InvalidArgument)
    );
    // A render of another camera (mismatched cameras).
    let other = Camera::try_look_at(
        Vec3::new(0.0, -3.0, 0.0),
        Vec3::ZERO,
        Vec3::Z,
        1.0,
        0.1,
        50.0,
        dw,
        dh,
    )
    .unwrap();
    let rv_other = ClusterRender::try_new(
        DepthImage::try_new(dv, other, DepthConvention::Linear).unwrap(),
        cv,
    )
    .unwrap();
    let mut nan_cam = e;
    if let ClusterView::Camera(c) = &mut nan_cam.view {
        c.centroid.x = f32::NAN;
    }
    let mut bad_lobe_e = e;
    bad_lobe_e.lobe.rays = 0;
    let past = ClusterPlanEntry {
        first: p.order.len() as u32 - 1,
        ..e
    };
    let mut bad_order = p.order.clone();
    bad_order[e.first as usize] = u32::MAX;
    let all = RowRange::try_all(H).unwrap();
    let calls: Vec<(
        ClusterPlanEntry,
        &[u32],
        Option<&ClusterRender<'_>>,
        RowRange,
    )> = vec![
        (e, &p.order, None, e.rows),
        (e, &p.order, Some(&rv_other), e.rows),
        (nan_cam, &p.order, Some(&rv), e.rows),
        (bad_lobe_e, &p.order, Some(&rv), e.rows),
        (past, &p.order, Some(&rv), all),
        (e, &bad_order, Some(&rv), all),
        (e, &p.order[..e.first as usize], Some(&rv), all),
    ];
    for (k, (entry, order, r, rows)) in calls.into_iter().enumerate() {
        let mut sink = Collect {
            cap: usize::MAX,
            ..Collect::default()
        };
        assert_eq!(
            pass.try_finalize_rows(&entry, order, r, rows, &mut sink),
            Err(Error::InvalidArgument),
            "call {k}"
        );
        assert!(sink.texels.is_empty() && sink.host.is_empty(), "call {k}");
    }
    // Rows beyond the G-buffer (a range of a taller image).
    let mut sink = Collect::default();
    assert_eq!(
        pass.try_finalize_rows(
            &e,
            &p.order,
            Some(&rv),
            RowRange::try_new(0, H + 1, H + 1).unwrap(),
            &mut sink
        ),
        Err(Error::InvalidArgument)
    );
    // A G-buffer that lost a cluster pixel's surface (NaN normal) since
    // the plan: not this G-buffer's plan.
    let mut nan_normals = f.normals.clone();
    nan_normals[p.order[e.first as usize] as usize] = [f32::NAN, 0.0, 0.0];
    let g2 = GBuffer::try_new(
        *g.depth(),
        ImageView::try_new(&nan_normals, W, H, W).unwrap(),
        NormalSpace::World,
    )
    .unwrap();
    let pass2 = ClusterPass::try_new(g2, o).unwrap();
    let mut sink = Collect::default();
    assert_eq!(
        pass2.try_finalize_rows(&e, &p.order, Some(&rv), e.rows, &mut sink),
        Err(Error::InvalidArgument)
    );
    assert!(sink.texels.is_empty());
    // The image variant: an output of another size, untouched.
    let mut img = vec![ClusterTexel::default(); N - 1];
    assert_eq!(
        pass.try_finalize(
            &mut ImageViewMut::try_new(&mut img, W - 1, H, W - 1).unwrap(),
            &mut [],
            &e,
            &p.order,
            Some(&rv)
        ),
        Err(Error::InvalidArgument)
    );
    assert!(img.iter().all(|t| *t == ClusterTexel::default()));
}

/// f64 oracle: a point is inside the frustum when it projects into the
/// image rectangle with a linear depth in `[near, far]`.
#[test]
fn frustum_planes_agree_with_projection() {
    let cams = [
        camera(),
        Camera::try_look_at(
            Vec3::new(-3.0, 7.0, 2.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::Y,
            0.4,
            0.5,
            30.0,
            40,
            90,
        )
        .unwrap(),
        Camera::try_look_at(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::ZERO,
            Vec3::Y,
            2.5,
            0.01,
            f32::INFINITY,
            200,
            50,
        )
        .unwrap(),
    ];
    let mut inside = 0;
    let mut seed = 0x1234_5678u32;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        f64::from(seed) / f64::from(u32::MAX) * 2.0 - 1.0
    };
    for cam in &cams {
        let planes = cam.frustum_planes();
        for p in &planes {
            assert!((p.truncate().length() - 1.0).abs() < 1e-6 || p.truncate().length() == 0.0);
        }
        let v = cam.view().as_dmat4();
        let inv = v.inverse();
        let (ty, tx) = (
            (f64::from(cam.fov_y()) / 2.0).tan(),
            (f64::from(cam.fov_y()) / 2.0).tan() * f64::from(cam.width()) / f64::from(cam.height()),
        );
        let far = f64::from(cam.far()).min(60.0);
        for _ in 0..20_000 {
            // View-space samples around the frustum, then world.
            let z = f64::from(cam.near()) * 0.5 + (rnd() * 0.5 + 0.5) * far * 1.2;
            let q = DVec3::new(rnd() * 1.3 * tx * z, rnd() * 1.3 * ty * z, -z);
            let pw = inv.transform_point3(q);
            // Margins: skip points within 1e-4 relative of a boundary.
            let (nx, ny) = (q.x / (z * tx), q.y / (z * ty));
            let near_edge = (nx.abs() - 1.0).abs() < 1e-4
                || (ny.abs() - 1.0).abs() < 1e-4
                || (z - f64::from(cam.near())).abs() < 1e-4 * z
                || (z - f64::from(cam.far())).abs() < 1e-4 * z;
            if near_edge {
                continue;
            }
            let want = nx.abs() <= 1.0
                && ny.abs() <= 1.0
                && z >= f64::from(cam.near())
                && z <= f64::from(cam.far());
            let got = planes
                .iter()
                .all(|p| p.truncate().as_dvec3().dot(pw) + f64::from(p.w) >= 0.0);
            assert_eq!(got, want, "{q:?}");
            inside += usize::from(want);
        }
    }
    assert!(inside > 10_000, "{inside}");
}
