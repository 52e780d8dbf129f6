//! The cluster pass through the C ABI (`refl_cluster_plan_len`,
//! `refl_cluster_plan`, `refl_cluster_finalize_rows`) equals the seed 003
//! kernel exports it wraps bit for bit: the plan equals
//! `refl_cluster_count_objects`, `_bin_layout`, `_assign`, `_ranges` and
//! `_build_camera` on the G-buffer's surfaces, the finalize equals
//! `refl_cluster_finalize` (clusters finalized from threads into one
//! image, in row bands), and its host rays are the mirror pass's; hostile
//! input gets its status with every output untouched and no allocation.

use refl::*;
use refl_core::cluster::ClusterView;
use refl_core::glam::{DVec3, Vec2};
use refl_core::{DepthConvention, GBuffer, MirrorStatus};
#[path = "common/gbuffer.rs"]
mod common;
use common::{conv_c, counted, none_f32, none_u32, none_vec3, render, Frame, Shared, H, W};

const N: usize = (W * H) as usize;

fn lobes() -> [refl_cluster_lobe; 2] {
    let mut angle = 0.0f32;
    assert_eq!(
        unsafe { refl_cluster_lobe_angle(&mut angle, 40.0, 0.95) },
        refl_status::Ok
    );
    [
        refl_cluster_lobe {
            rays: 1,
            exponent: 0.0,
            max_angle: 0.0,
        },
        refl_cluster_lobe {
            rays: 8,
            exponent: 40.0,
            max_angle: angle,
        },
    ]
}

fn options() -> refl_cluster_pass_options {
    let mut o = refl_cluster_pass_options_default();
    o.camera.far_distance = 20.0;
    o.cluster.gain = 16.0;
    o.seed = 9;
    o
}

fn u32_img(d: &[u32], w: u32, h: u32) -> refl_image_u32 {
    refl_image_u32 {
        data: d.as_ptr(),
        len: d.len(),
        width: w,
        height: h,
        stride: w,
    }
}

fn vec3_img(d: &[[f32; 3]], w: u32, h: u32) -> refl_image_vec3 {
    refl_image_vec3 {
        data: d.as_ptr().cast(),
        len: d.len(),
        width: w,
        height: h,
        stride: w,
    }
}

fn f32_img(d: &[f32], w: u32, h: u32) -> refl_image_f32 {
    refl_image_f32 {
        data: d.as_ptr(),
        len: d.len(),
        width: w,
        height: h,
        stride: w,
    }
}

/// A plan through the C ABI: sizes, scratch, the written entries, stats.
struct Plan {
    sizes: refl_cluster_plan_sizes,
    scratch: Vec<u32>,
    entries: Vec<refl_cluster_plan_entry>,
    stats: refl_cluster_plan_stats,
}

fn zero_entry() -> refl_cluster_plan_entry {
    refl_cluster_plan_entry {
        id: 7,
        object: 7,
        first: 7,
        len: 7,
        rows: refl_row_range { begin: 7, end: 7 },
        lobe: refl_cluster_lobe {
            rays: 7,
            exponent: 7.0,
            max_angle: 7.0,
        },
        camera: refl_cluster_camera::from_view(&ClusterView::Fallback(
            refl_core::cluster::ClusterFallback::NoRays,
        )),
        frustum: [refl_vec4 {
            x: 7.0,
            y: 7.0,
            z: 7.0,
            w: 7.0,
        }; 6],
    }
}

fn plan(g: &refl_gbuffer, objects: &refl_cluster_objects, o: &refl_cluster_pass_options) -> Plan {
    let mut sizes = refl_cluster_plan_sizes::default();
    assert_eq!(
        unsafe { refl_cluster_plan_len(&mut sizes, g, objects, o) },
        refl_status::Ok
    );
    let mut p = Plan {
        sizes,
        scratch: vec![7; sizes.scratch_len],
        entries: vec![zero_entry(); sizes.clusters_len],
        stats: refl_cluster_plan_stats::default(),
    };
    let (s, allocs) = counted(|| unsafe {
        refl_cluster_plan(
            &mut p.stats,
            p.entries.as_mut_ptr(),
            p.entries.len(),
            p.scratch.as_mut_ptr(),
            p.scratch.len(),
            g,
            objects,
            o,
        )
    });
    assert_eq!((s, allocs), (refl_status::Ok, 0));
    assert!(p.entries[p.stats.clusters as usize..]
        .iter()
        .all(|e| *e == zero_entry()));
    p.entries.truncate(p.stats.clusters as usize);
    p
}

/// The kernels' inputs from the G-buffer: `GBuffer::surface`'s point, its
/// normal turned toward the eye where it faces away, the object where the
/// pass counts one.
fn derive(g: &GBuffer<'_>, ids: &[u32], objects: u32) -> (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<u32>) {
    let eye = g.camera().eye();
    let (mut pos, mut nor, mut obj) = (
        vec![[0.0; 3]; N],
        vec![[0.0, 1.0, 0.0]; N],
        vec![u32::MAX; N],
    );
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
            pos[i] = s.position.to_array();
            nor[i] = n.to_array();
            if ids[i] < objects {
                obj[i] = ids[i];
            }
        }
    }
    (pos, nor, obj)
}

/// The floor `y = 0` and the unit sphere at (0, 1, 0) (objects 0 and 1)
/// through a cluster camera, what lies in front of its clip plane only
/// (a planar cluster without its own object), in `conv`.
fn render_cluster(e: &refl_cluster_plan_entry, conv: DepthConvention) -> (Vec<f32>, Vec<[f32; 3]>) {
    let cc = refl_core::cluster::ClusterCamera::try_from(&e.camera).unwrap();
    let cam = cc.camera;
    let (w, h) = (cam.width(), cam.height());
    let empty = cam.encode_depth(cam.far(), conv);
    let mut depth = vec![empty; (w * h) as usize];
    let mut color = vec![[0.0f32; 3]; (w * h) as usize];
    let (cn, cp) = (cc.clip.normal.as_dvec3(), cc.clip.point.as_dvec3());
    for y in 0..h {
        for x in 0..w {
            let r = cam.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (o, d) = (r.origin.as_dvec3(), r.dir.as_dvec3());
            let (so, dn) = ((o - cp).dot(cn), d.dot(cn));
            let t0 = if so > 0.0 {
                0.0
            } else if dn > 0.0 {
                -so / dn
            } else {
                continue;
            };
            let mut best: Option<f64> = None;
            let mut take = |t: f64, id: u32| {
                if t > t0 && !(cc.planar && id == e.object) && best.is_none_or(|b| t < b) {
                    best = Some(t);
                }
            };
            if d.y != 0.0 {
                take(-o.y / d.y, 0);
            }
            let oc = o - DVec3::new(0.0, 1.0, 0.0);
            let b = oc.dot(d);
            let disc = b * b - (oc.dot(oc) - 1.0);
            if disc > 0.0 {
                take(-b - disc.sqrt(), 1);
                take(-b + disc.sqrt(), 1);
            }
            if let Some(t) = best {
                let p = o + d * t;
                let z = cam.linear_depth(p.as_vec3());
                if z < cam.far() {
                    let i = (y * w + x) as usize;
                    depth[i] = cam.encode_depth(z, conv);
                    color[i] = [
                        (0.5 + 0.4 * (p.x * 1.7).sin()) as f32,
                        (0.5 + 0.4 * (p.y * 2.1).cos()) as f32,
                        (0.5 + 0.3 * (p.z * 1.3).sin()) as f32,
                    ];
                }
            }
        }
    }
    (depth, color)
}

fn shade_bits(s: &refl_cluster_shade) -> [u32; 15] {
    let v = |v: refl_vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
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

/// The pass's inputs on the scene in one convention: the frame, the
/// options and the lobes.
struct Setup {
    f: Frame,
    o: refl_cluster_pass_options,
    lobes: [refl_cluster_lobe; 2],
}

impl Setup {
    fn new(conv: DepthConvention) -> Setup {
        Setup {
            f: render(conv),
            o: options(),
            lobes: lobes(),
        }
    }

    fn g(&self) -> refl_gbuffer {
        self.f.gbuffer_c(false)
    }

    /// The frame's ids (objects 0 and 1) with the two lobes.
    fn objects(&self) -> refl_cluster_objects {
        refl_cluster_objects {
            ids: u32_img(&self.f.ids, W, H),
            lobes: self.lobes.as_ptr(),
            lobes_len: self.lobes.len(),
        }
    }

    /// The pass's plan through the C ABI.
    fn plan(&self) -> Plan {
        plan(&self.g(), &self.objects(), &self.o)
    }
}

/// The seed 003 clustering exports on the frame's surfaces (each checked
/// to succeed): what the plan wraps.
struct Kernels {
    pos: Vec<[f32; 3]>,
    nor: Vec<[f32; 3]>,
    obj: Vec<u32>,
    counts: [u32; 2],
    layout: [refl_cluster_object_bins; 2],
    bins: u32,
    ids: Vec<u32>,
    offsets: Vec<u32>,
    order: Vec<u32>,
    total: u32,
}

impl Kernels {
    fn pv(&self) -> refl_image_vec3 {
        vec3_img(&self.pos, W, H)
    }

    fn nv(&self) -> refl_image_vec3 {
        vec3_img(&self.nor, W, H)
    }
}

fn kernels(f: &Frame, o: &refl_cluster_pass_options) -> Kernels {
    let (pos, nor, obj) = derive(&f.gbuffer(false), &f.ids, 2);
    let (nv, ov) = (vec3_img(&nor, W, H), u32_img(&obj, W, H));
    let mut counts = [0u32; 2];
    let all = refl_row_range { begin: 0, end: H };
    assert_eq!(
        unsafe { refl_cluster_count_objects(counts.as_mut_ptr(), 2, ov, all) },
        refl_status::Ok
    );
    let mut layout = [refl_cluster_object_bins::default(); 2];
    let mut bins = 0u32;
    assert_eq!(
        unsafe {
            refl_cluster_bin_layout(
                &mut bins,
                layout.as_mut_ptr(),
                2,
                counts.as_ptr(),
                2,
                N as u64,
                &o.cluster,
            )
        },
        refl_status::Ok
    );
    let mut ids = vec![0u32; N];
    assert_eq!(
        unsafe {
            refl_cluster_assign(
                refl_image_u32_mut {
                    data: ids.as_mut_ptr(),
                    len: N,
                    width: W,
                    height: H,
                    stride: W,
                },
                all,
                nv,
                ov,
                layout.as_ptr(),
                2,
            )
        },
        refl_status::Ok
    );
    let mut offsets = vec![0u32; bins as usize + 1];
    let mut order = vec![0u32; N];
    let mut total = 0u32;
    assert_eq!(
        unsafe {
            refl_cluster_ranges(
                &mut total,
                offsets.as_mut_ptr(),
                offsets.len(),
                order.as_mut_ptr(),
                N,
                u32_img(&ids, W, H),
                bins,
            )
        },
        refl_status::Ok
    );
    Kernels {
        pos,
        nor,
        obj,
        counts,
        layout,
        bins,
        ids,
        offsets,
        order,
        total,
    }
}

/// The scene's conventions and the conventions of its clusters' renders.
const CONVENTIONS: [(DepthConvention, DepthConvention); 2] = [
    (DepthConvention::Linear, DepthConvention::Linear),
    (DepthConvention::ReversedZ, DepthConvention::ZeroToOne),
];

#[test]
fn plan_scratch_and_stats_equal_the_clustering_exports() {
    for (conv, _) in CONVENTIONS {
        let setup = Setup::new(conv);
        let p = setup.plan();
        let k = kernels(&setup.f, &setup.o);
        // The scratch: ids, order, offsets, counts, layout.
        let s = &p.scratch;
        assert_eq!(&s[..N], &k.ids[..]);
        assert_eq!(&s[N..N + k.total as usize], &k.order[..k.total as usize]);
        let off = 2 * N;
        let n_off = p.sizes.scratch_len - 2 * N - 2 * 4;
        assert_eq!(&s[off..off + k.offsets.len()], &k.offsets[..]);
        assert_eq!(&s[off + n_off..off + n_off + 2], &k.counts[..]);
        let lay: Vec<u32> = k
            .layout
            .iter()
            .flat_map(|b| [b.theta_bins, b.phi_bins, b.first])
            .collect();
        assert_eq!(&s[off + n_off + 2..], &lay[..]);
        assert_eq!((p.stats.bins, p.stats.pixels), (k.bins, k.total));
    }
}

#[test]
fn plan_entries_equal_build_camera_per_cluster() {
    for (conv, _) in CONVENTIONS {
        let setup = Setup::new(conv);
        let (o, lobes) = (setup.o, setup.lobes);
        let p = setup.plan();
        let k = kernels(&setup.f, &o);
        let (pv, nv) = (k.pv(), k.nv());
        let eye: refl_vec3 = setup.f.cam.eye().into();
        let mut n = 0;
        for c in 0..k.bins as usize {
            let (a, b) = (k.offsets[c], k.offsets[c + 1]);
            if b == a {
                continue;
            }
            let e = &p.entries[n];
            n += 1;
            let px = &k.order[a as usize..b as usize];
            let object = k.obj[px[0] as usize];
            let lobe = lobes[object as usize];
            let mut co = o.camera;
            if lobe.rays > 1 {
                co.cone_half_angle = co.cone_half_angle.max(lobe.max_angle);
            }
            let mut cam = zero_entry().camera;
            assert_eq!(
                unsafe {
                    refl_cluster_build_camera(&mut cam, pv, nv, px.as_ptr(), px.len(), eye, &co)
                },
                refl_status::Ok
            );
            assert_eq!(
                (e.id, e.object, e.first, e.len, e.lobe),
                (c as u32, object, a, b - a, lobe)
            );
            assert_eq!(
                (e.rows.begin, e.rows.end),
                (px[0] / W, px[px.len() - 1] / W + 1)
            );
            assert_eq!(e.camera, cam, "cluster {c}");
            if cam.fallback == 0 {
                let cc = refl_core::cluster::ClusterCamera::try_from(&cam).unwrap();
                let planes = cc.camera.frustum_planes();
                for (q, w) in e.frustum.iter().zip(planes) {
                    assert_eq!([q.x, q.y, q.z, q.w], w.to_array());
                }
            }
        }
        assert_eq!(n, p.entries.len());
    }
}

/// A cluster's render (depth, color), or none for a cluster without a
/// camera.
type Render = Option<(Vec<f32>, Vec<[f32; 3]>)>;

/// Finalizes every cluster of the plan `p` from its own thread into
/// `texels` (the whole image), in two row bands, with its render in
/// `rconv` (or none, for clusters without a camera); returns each
/// cluster's host rays, bands in order.
fn finalize_in_threads(
    g: refl_gbuffer,
    o: &refl_cluster_pass_options,
    p: &Plan,
    renders: &[Render],
    rconv: DepthConvention,
    texels: &mut [refl_cluster_texel],
) -> Vec<Vec<refl_host_ray>> {
    let tp = Shared(texels.as_mut_ptr());
    let gs = Shared(g);
    std::thread::scope(|sc| {
        let hs: Vec<_> = p
            .entries
            .iter()
            .zip(renders)
            .map(|(e, r)| {
                let (g, s, tp) = (&gs, &p.scratch, &tp);
                sc.spawn(move || {
                    let rv = r.as_ref().map(|(d, c)| {
                        let (w, h) = (e.camera.camera.width, e.camera.camera.height);
                        refl_cluster_render {
                            depth: refl_depth_image {
                                depth: f32_img(d, w, h),
                                camera: e.camera.camera,
                                convention: conv_c(rconv),
                            },
                            color: vec3_img(c, w, h),
                            back_depth: none_f32(),
                            reflector_diffuse: none_vec3(),
                            reflector_ids: none_u32(),
                        }
                    });
                    let rp = rv.as_ref().map_or(core::ptr::null(), |r| r as *const _);
                    let rows = e.rows;
                    let mid = rows.begin + (rows.end - rows.begin) / 2;
                    let mut out = Vec::new();
                    for band in [(rows.begin, mid), (mid, rows.end)] {
                        if band.0 == band.1 {
                            continue;
                        }
                        let mut host = vec![refl_host_ray::default(); N];
                        let mut st = refl_cluster_stats::default();
                        let r = unsafe {
                            refl_cluster_finalize_rows(
                                &mut st,
                                *tp.get(),
                                N,
                                host.as_mut_ptr(),
                                N,
                                g.get(),
                                o,
                                s.as_ptr(),
                                s.len(),
                                e,
                                rp,
                                refl_row_range {
                                    begin: band.0,
                                    end: band.1,
                                },
                            )
                        };
                        assert_eq!(r, refl_status::Ok);
                        assert_eq!(st.host_rays_written, st.host_rays);
                        host.truncate(st.host_rays as usize);
                        out.extend(host);
                    }
                    out
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

/// Finalize: every cluster with a camera from its own thread into one
/// image, in two row bands, equals the kernel export per cluster; its host
/// rays are the mirror pass's; pixels of no cluster are untouched.
#[test]
fn finalize_rows_from_threads_equals_finalize_and_the_mirror_pass_host_rays() {
    let mut statuses = [0usize; 10];
    for (conv, rconv) in CONVENTIONS {
        let setup = Setup::new(conv);
        let (f, o) = (&setup.f, setup.o);
        let g = setup.g();
        let p = setup.plan();
        let k = kernels(f, &o);
        let (pv, nv) = (k.pv(), k.nv());
        let (ids, order) = (&k.ids, &k.order);
        let eye: refl_vec3 = f.cam.eye().into();
        let renders: Vec<_> = p
            .entries
            .iter()
            .map(|e| (e.camera.fallback == 0).then(|| render_cluster(e, rconv)))
            .collect();
        let mut texels = vec![refl_cluster_texel::default(); N];
        let hosts = finalize_in_threads(g, &o, &p, &renders, rconv, &mut texels);
        let gb = f.gbuffer(false);
        let mirror = refl_core::MirrorPass::try_new(
            gb,
            refl_core::cluster::ClusterPassOptions::from(o).mirror_options(),
            None,
        )
        .unwrap();
        for ((e, r), host) in p.entries.iter().zip(&renders).zip(&hosts) {
            let px = &order[e.first as usize..(e.first + e.len) as usize];
            let mut want_host = Vec::new();
            let mut want = vec![refl_cluster_shade::default(); px.len()];
            if let Some((d, c)) = r {
                let (w, h) = (e.camera.camera.width, e.camera.camera.height);
                let di = refl_depth_image {
                    depth: f32_img(d, w, h),
                    camera: e.camera.camera,
                    convention: conv_c(rconv),
                };
                let input = refl_cluster_finalize_input {
                    thickness: refl_trace_thickness {
                        constant: o.thickness * e.camera.far_distance,
                        back_faces: none_f32(),
                    },
                    step: o.step,
                    refine: o.refine,
                    lobe: e.lobe,
                    fade: o.fade,
                    seed: o.seed,
                    single_ray: o.glossy_single_ray,
                };
                let mut fell = 0u32;
                assert_eq!(
                    unsafe {
                        refl_cluster_finalize(
                            &mut fell,
                            want.as_mut_ptr(),
                            want.len(),
                            pv,
                            nv,
                            px.as_ptr(),
                            px.len(),
                            eye,
                            &e.camera,
                            &di,
                            vec3_img(c, w, h),
                            &input,
                        )
                    },
                    refl_status::Ok
                );
            }
            for (&q, w) in px.iter().zip(&want) {
                let t = &texels[q as usize];
                statuses[t.status as usize] += 1;
                if r.is_some() {
                    assert_eq!(shade_bits(&t.shade), shade_bits(w), "pixel {q}");
                } else {
                    assert_eq!(t.status, refl_ssr_status::NoProjection as u32);
                    assert_eq!((t.shade.env_weight, t.shade.rays), (1.0, 0));
                }
                let hit = t.status == refl_ssr_status::Hit as u32;
                let sky = t.status == refl_ssr_status::Sky as u32;
                assert_eq!(hit, t.shade.hits == t.shade.rays && t.shade.rays > 0);
                if !hit && !sky {
                    let st = [
                        MirrorStatus::LeftImage,
                        MirrorStatus::BehindGeometry,
                        MirrorStatus::OutOfSteps,
                        MirrorStatus::NoProjection,
                    ]
                    .into_iter()
                    .find(|s| refl_ssr_status::from(*s) as u32 == t.status)
                    .unwrap();
                    want_host.push(refl_host_ray::from(
                        mirror.host_ray(q % W, q / W, st).unwrap(),
                    ));
                }
            }
            assert_eq!(host, &want_host);
        }
        // Pixels of no cluster are untouched.
        for (i, t) in texels.iter().enumerate() {
            if ids[i] == u32::MAX {
                assert_eq!(*t, refl_cluster_texel::default());
            }
        }
    }
    for s in [refl_ssr_status::Hit, refl_ssr_status::Sky] {
        assert!(statuses[s as usize] > 0, "{statuses:?}");
    }
    assert!(statuses[4..].iter().sum::<usize>() > 0, "{statuses:?}");
}

/// The last error message.
fn msg() -> String {
    with_last_error_message(|m| m.to_owned())
}

#[test]
fn plan_len_refuses_null_and_nan_input_untouched() {
    let setup = Setup::new(DepthConvention::Linear);
    let (g, objects, o) = (setup.g(), setup.objects(), setup.o);
    let mut sz = refl_cluster_plan_sizes {
        scratch_len: 5,
        clusters_len: 5,
    };
    let keep = sz;
    let nan = refl_cluster_pass_options {
        cluster: refl_cluster_options {
            gain: f32::NAN,
            ..o.cluster
        },
        ..o
    };
    for (want, gp, op, opts) in [
        (
            refl_status::NullPointer,
            core::ptr::null(),
            &raw const objects,
            &raw const o,
        ),
        (
            refl_status::NullPointer,
            &raw const g,
            core::ptr::null(),
            &raw const o,
        ),
        (
            refl_status::NullPointer,
            &raw const g,
            &raw const objects,
            core::ptr::null(),
        ),
        (
            refl_status::InvalidArgument,
            &raw const g,
            &raw const objects,
            &raw const nan,
        ),
    ] {
        let (s, a) = counted(|| unsafe { refl_cluster_plan_len(&mut sz, gp, op, opts) });
        assert_eq!((s, a), (want, 0));
        assert_eq!(sz, keep);
    }
}

#[test]
fn plan_refuses_hostile_input_writing_nothing() {
    let setup = Setup::new(DepthConvention::Linear);
    let (f, lobes) = (&setup.f, setup.lobes);
    let (g, objects, o) = (setup.g(), setup.objects(), setup.o);
    let p = setup.plan();
    // Each case on fresh sentinel outputs.
    let bad_lobes = [
        lobes[0],
        refl_cluster_lobe {
            rays: 8,
            exponent: f32::NAN,
            max_angle: 0.3,
        },
    ];
    let small_ids = vec![0u32; N - W as usize];
    let with = |ids: refl_image_u32, l: *const refl_cluster_lobe, n: usize| refl_cluster_objects {
        ids,
        lobes: l,
        lobes_len: n,
    };
    let thick_nan = refl_cluster_pass_options {
        thickness: f32::NAN,
        ..o
    };
    struct Case {
        want: refl_status,
        scratch_cut: usize,
        clusters_cut: usize,
        objects: refl_cluster_objects,
        options: refl_cluster_pass_options,
        alias: bool,
        name: &'static str,
    }
    let base = Case {
        want: refl_status::Ok,
        scratch_cut: 0,
        clusters_cut: 0,
        objects,
        options: o,
        alias: false,
        name: "",
    };
    let cases = [
        Case {
            want: refl_status::InsufficientSize,
            scratch_cut: 1,
            name: "scratch_len",
            ..base
        },
        Case {
            want: refl_status::InsufficientSize,
            clusters_cut: 1,
            name: "clusters_len",
            ..base
        },
        Case {
            want: refl_status::NullPointer,
            objects: with(u32_img(&f.ids, W, H), core::ptr::null(), 2),
            name: "objects.lobes",
            ..base
        },
        Case {
            want: refl_status::InvalidArgument,
            objects: with(u32_img(&f.ids, W, H), bad_lobes.as_ptr(), 2),
            name: "",
            ..base
        },
        Case {
            want: refl_status::InvalidArgument,
            objects: with(u32_img(&small_ids, W, H - 1), lobes.as_ptr(), 2),
            name: "",
            ..base
        },
        Case {
            want: refl_status::InvalidArgument,
            options: thick_nan,
            name: "options",
            ..base
        },
        Case {
            want: refl_status::InvalidArgument,
            alias: true,
            name: "overlap",
            ..base
        },
    ];
    for c in &cases {
        let mut scratch = vec![7u32; p.sizes.scratch_len];
        let mut list = vec![zero_entry(); p.sizes.clusters_len];
        let mut st = refl_cluster_plan_stats {
            bins: 77,
            ..Default::default()
        };
        let sp = scratch.as_mut_ptr();
        // Aliasing: the list written over the G-buffer's normals.
        let (lp, ll) = if c.alias {
            (f.normals.as_ptr() as *mut refl_cluster_plan_entry, 1)
        } else {
            (list.as_mut_ptr(), list.len() - c.clusters_cut)
        };
        let ll = if c.alias { list.len() } else { ll };
        let (s, a) = counted(|| unsafe {
            refl_cluster_plan(
                &mut st,
                lp,
                ll,
                sp,
                scratch.len() - c.scratch_cut,
                &g,
                &c.objects,
                &c.options,
            )
        });
        assert_eq!((s, a), (c.want, 0), "{}", c.name);
        assert!(msg().contains(c.name), "{}: {}", c.name, msg());
        assert!(scratch.iter().all(|&v| v == 7));
        assert!(list.iter().all(|e| *e == zero_entry()));
        assert_eq!(st.bins, 77);
    }
}

#[test]
fn finalize_rows_refuses_hostile_input_writing_nothing() {
    let setup = Setup::new(DepthConvention::Linear);
    let (g, o) = (setup.g(), setup.o);
    let p = setup.plan();
    let e = *p.entries.iter().find(|e| e.camera.fallback == 0).unwrap();
    let (d, c) = render_cluster(&e, DepthConvention::Linear);
    let (w, h) = (e.camera.camera.width, e.camera.camera.height);
    let render = refl_cluster_render {
        depth: refl_depth_image {
            depth: f32_img(&d, w, h),
            camera: e.camera.camera,
            convention: conv_c(DepthConvention::Linear),
        },
        color: vec3_img(&c, w, h),
        back_depth: none_f32(),
        reflector_diffuse: none_vec3(),
        reflector_ids: none_u32(),
    };
    let mut other = render;
    other.depth.camera.view.m[12] += 0.5;
    let mut small_color = render;
    small_color.color.width -= 1;
    let tiny = [1.0f32; 4];
    let mut small_back = render;
    small_back.back_depth = f32_img(&tiny, 2, 2);
    let mut nan_entry = e;
    nan_entry.camera.centroid.x = f32::NAN;
    let mut unknown = e;
    unknown.camera.fallback = 99;
    let mut past = e;
    past.first = N as u32 - 1;
    let mut rows_past = e;
    rows_past.rows.end = H + 1;
    let mut sentinel_scratch = p.scratch.clone();
    let ok_rows = e.rows;
    type Call<'a> = (
        refl_status,
        &'static str,
        refl_cluster_plan_entry,
        *const refl_cluster_render,
        refl_row_range,
        usize,
        usize,
        bool,
    );
    let calls: [Call<'_>; 11] = [
        (
            refl_status::NullPointer,
            "render",
            e,
            core::ptr::null(),
            ok_rows,
            N,
            0,
            false,
        ),
        (
            refl_status::InvalidArgument,
            "",
            e,
            &other,
            ok_rows,
            N,
            0,
            false,
        ),
        (
            refl_status::InvalidArgument,
            "render",
            e,
            &small_color,
            ok_rows,
            N,
            0,
            false,
        ),
        (
            refl_status::InvalidArgument,
            "render",
            e,
            &small_back,
            ok_rows,
            N,
            0,
            false,
        ),
        (
            refl_status::InvalidArgument,
            "cluster",
            nan_entry,
            &render,
            ok_rows,
            N,
            0,
            false,
        ),
        (
            refl_status::InvalidArgument,
            "cluster",
            unknown,
            &render,
            ok_rows,
            N,
            0,
            false,
        ),
        (
            refl_status::InvalidArgument,
            "",
            past,
            &render,
            refl_row_range { begin: 0, end: H },
            N,
            0,
            false,
        ),
        (
            refl_status::InvalidArgument,
            "cluster",
            rows_past,
            &render,
            ok_rows,
            N,
            0,
            false,
        ),
        (
            refl_status::InvalidArgument,
            "rows",
            e,
            &render,
            refl_row_range { begin: 2, end: 1 },
            N,
            0,
            false,
        ),
        (
            refl_status::InsufficientSize,
            "out_len",
            e,
            &render,
            ok_rows,
            N - 1,
            0,
            false,
        ),
        (
            refl_status::InsufficientSize,
            "scratch_len",
            e,
            &render,
            ok_rows,
            N,
            N + 1,
            false,
        ),
    ];
    let mut run = |(want, name, entry, rp, rows, out_len, cut, alias): Call<'_>| {
        let sentinel = refl_cluster_texel {
            status: 77,
            ..Default::default()
        };
        let mut texels = vec![sentinel; N];
        let mut host = vec![
            refl_host_ray {
                x: 77,
                ..Default::default()
            };
            8
        ];
        let mut st = refl_cluster_stats {
            pixels: 77,
            ..Default::default()
        };
        // Aliasing: the output over the scratch the call reads.
        let (tp, sp) = if alias {
            let sp = sentinel_scratch.as_mut_ptr();
            (sp as *mut refl_cluster_texel, sp.cast_const())
        } else {
            (texels.as_mut_ptr(), p.scratch.as_ptr())
        };
        let (s, a) = counted(|| unsafe {
            refl_cluster_finalize_rows(
                &mut st,
                tp,
                out_len,
                host.as_mut_ptr(),
                host.len(),
                &g,
                &o,
                sp,
                p.scratch.len() - cut,
                &entry,
                rp,
                rows,
            )
        });
        assert_eq!((s, a), (want, 0), "{name}: {}", msg());
        assert!(msg().contains(name), "{name}: {}", msg());
        assert!(texels.iter().all(|t| *t == sentinel));
        assert!(host.iter().all(|h| h.x == 77));
        assert_eq!(st.pixels, 77);
    };
    for c in calls {
        run(c);
    }
    // The output over the scratch (the pixel lists it reads).
    let scratch_copy = p.scratch.clone();
    run((
        refl_status::InvalidArgument,
        "overlap",
        e,
        &render,
        ok_rows,
        N,
        0,
        true,
    ));
    assert_eq!(sentinel_scratch, scratch_copy);
}

#[test]
fn finalize_rows_of_an_entry_without_a_camera_needs_no_render() {
    let setup = Setup::new(DepthConvention::Linear);
    let (g, o) = (setup.g(), setup.o);
    let p = setup.plan();
    let e = *p.entries.iter().find(|e| e.camera.fallback == 0).unwrap();
    let mut fb = e;
    fb.camera = refl_cluster_camera::from_view(&ClusterView::Fallback(
        refl_core::cluster::ClusterFallback::TooFewPixels,
    ));
    let mut texels = vec![refl_cluster_texel::default(); N];
    let mut st = refl_cluster_stats::default();
    let s = unsafe {
        refl_cluster_finalize_rows(
            &mut st,
            texels.as_mut_ptr(),
            N,
            core::ptr::null_mut(),
            0,
            &g,
            &o,
            p.scratch.as_ptr(),
            p.scratch.len(),
            &fb,
            core::ptr::null(),
            fb.rows,
        )
    };
    assert_eq!(s, refl_status::Ok);
    assert_eq!(
        (st.pixels, st.host_rays, st.host_rays_written),
        (e.len, e.len, 0)
    );
}
