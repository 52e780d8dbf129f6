//! The screen-space mirror pass (`refl_core::ssr`) against the kernels it
//! wraps (bit for bit, with the glue re-derived here) and against an f64
//! analytic oracle: a mirror floor with a sphere and a box standing on it,
//! depth and normals rendered exactly, reflection hits found exactly.
#![cfg(all(feature = "depth-image", feature = "hiz"))]

#[path = "common/scene.rs"]
mod scene;

use refl_core::glam::{Vec2, Vec3};
use refl_core::trace::{ray_start_t, refine_hit};
use refl_core::{
    try_step, try_trace_hiz, Camera, DepthConvention, DepthImage, Error, GBuffer, HiZ, HostRay,
    ImageView, ImageViewMut, MirrorMethod, MirrorOptions, MirrorPass, MirrorStatus, MirrorTexel,
    NormalSpace, Ray, RowRange, Thickness, Trace,
};
use scene::{camera, default_camera, grazing_camera, render, Frame, Scene, CONVENTIONS};

fn run(pass: &MirrorPass<'_>) -> (Vec<MirrorTexel>, Vec<[f32; 3]>, Vec<HostRay>) {
    let (w, h) = (pass.gbuffer().width(), pass.gbuffer().height());
    let n = (w * h) as usize;
    let mut out = vec![MirrorTexel::default(); n];
    let mut color = vec![[9.0; 3]; n];
    let mut host = vec![HostRay::default(); n];
    let stats = {
        let mut o = ImageViewMut::try_new(&mut out, w, h, w).unwrap();
        let mut c = ImageViewMut::try_new(&mut color, w, h, w).unwrap();
        pass.try_run(&mut o, Some(&mut c), &mut host).unwrap()
    };
    assert_eq!(stats.host_rays, stats.host_rays_written);
    host.truncate(stats.host_rays as usize);
    let count = |s: MirrorStatus| out.iter().filter(|t| t.status == s).count() as u32;
    assert_eq!(stats.hits, count(MirrorStatus::Hit));
    assert_eq!(stats.sky, count(MirrorStatus::Sky));
    assert_eq!(
        stats.host_rays,
        out.iter().filter(|t| t.status.needs_host()).count() as u32
    );
    (out, color, host)
}

fn bits(t: &MirrorTexel) -> (MirrorStatus, [u32; 4]) {
    (
        t.status,
        [
            t.pixel.x.to_bits(),
            t.pixel.y.to_bits(),
            t.t.to_bits(),
            t.confidence.to_bits(),
        ],
    )
}

/// The pass's glue re-derived from its documentation, calling the kernels
/// directly.
fn by_hand(
    f: &Frame,
    opts: &MirrorOptions,
    hiz: Option<&HiZ<'_>>,
    back: bool,
    x: u32,
    y: u32,
) -> MirrorTexel {
    let cam = f.camera;
    let (w, h) = (cam.width(), cam.height());
    let i = (y * w + x) as usize;
    let mut out = MirrorTexel::default();
    let z = cam.decode_depth(f.depth[i], f.conv);
    let n = Vec3::from_array(f.normals[i]);
    if !(z >= cam.near() && z < cam.far()) || n.length_squared() == 0.0 {
        out.status = MirrorStatus::NoSurface;
        return out;
    }
    let n = n * (1.0 / n.length_squared().sqrt());
    let p = cam.unproject(
        Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
        f.depth[i],
        f.conv,
    );
    let v = (p - cam.eye()).normalize();
    let n = if n.dot(v) > 0.0 { -n } else { n };
    let dir = (v - 2.0 * v.dot(n) * n).normalize();
    let mut t0 = ray_start_t(&cam, &Ray { origin: p, dir }, opts.start_pixels)
        .expect("a ray that moves")
        .max(opts.t_min);
    let bv = ImageView::try_new(&f.back, w, h, w).unwrap();
    let g = f.gbuffer(back);
    // Hidden hits resume one pixel past their texel, up to 32 times.
    let mut resumes = 0;
    out.status = loop {
        let ray = Ray {
            origin: p + dir * t0,
            dir,
        };
        let t_max = opts.t_max - t0;
        let th = if back {
            Thickness::BackFaces(bv)
        } else {
            Thickness::Constant(opts.thickness * z)
        };
        let trace = match opts.method {
            MirrorMethod::Step => try_step(g.depth(), th, ray, t_max, opts.step).unwrap(),
            MirrorMethod::HiZ => try_trace_hiz(hiz.unwrap(), th, ray, t_max, &opts.hiz).unwrap(),
        };
        let hit = match trace {
            Trace::Hit(hit) => hit,
            Trace::Miss { reason, .. } => {
                break match reason {
                    refl_core::Miss::EndOfRay => MirrorStatus::Sky,
                    refl_core::Miss::LeftImage => MirrorStatus::LeftImage,
                    refl_core::Miss::BehindGeometry => MirrorStatus::BehindGeometry,
                    refl_core::Miss::OutOfSteps => MirrorStatus::OutOfSteps,
                    refl_core::Miss::DegenerateProjection => MirrorStatus::NoProjection,
                }
            }
        };
        let r = refine_hit(g.depth(), &ray, t_max, &hit);
        let refined = r.t != hit.t || r.pixel != hit.pixel;
        let hit = r;
        let (tx, ty) = (hit.pixel.x.floor() as u32, hit.pixel.y.floor() as u32);
        let lin = |x: i64, y: i64| {
            (x >= 0 && y >= 0 && x < w as i64 && y < h as i64)
                .then(|| cam.decode_depth(f.depth[(y * w as i64 + x) as usize], f.conv))
        };
        let z0 = lin(tx as i64, ty as i64).unwrap();
        let slope = [(-1, 0), (1, 0), (0, -1), (0, 1)]
            .into_iter()
            .filter_map(|(dx, dy)| lin(tx as i64 + dx, ty as i64 + dy))
            .map(|z| (z - z0).abs())
            .filter(|&dz| dz <= 0.1 * z0)
            .fold(0.0f32, f32::max);
        // The ray's own depth change over its next pixel at the hit.
        let at = Ray {
            origin: ray.at(hit.t),
            dir,
        };
        let ray_dz = ray_start_t(&cam, &at, 1.0)
            .map(|dt| (cam.linear_depth(at.at(dt)) - cam.linear_depth(at.origin)).abs())
            .filter(|dz| dz.is_finite())
            .unwrap_or(0.0);
        let on_front = refined || hit.depth <= z0 + 0.75 * slope + ray_dz + 1e-4 * z0;
        if !on_front {
            let at = Ray {
                origin: ray.at(hit.t),
                dir,
            };
            match ray_start_t(&cam, &at, 1.0).map(|dt| t0 + hit.t + dt) {
                Some(t) if resumes < (w.max(h) / 8).max(32) && t < opts.t_max => {
                    resumes += 1;
                    t0 = t;
                    continue;
                }
                _ => break MirrorStatus::Hidden,
            }
        }
        if facing_away(f, hit.pixel, dir) {
            break MirrorStatus::BackFace;
        }
        out.pixel = hit.pixel;
        let t = t0 + hit.t;
        out.t = if t > opts.t_max { opts.t_max } else { t };
        let band = opts.border_fade * (w.min(h) as f32);
        let d = hit
            .pixel
            .x
            .min(w as f32 - hit.pixel.x)
            .min(hit.pixel.y)
            .min(h as f32 - hit.pixel.y);
        out.confidence = (d / band).clamp(0.0, 1.0);
        break MirrorStatus::Hit;
    };
    out
}

/// The texels whose centers surround `p`, inside the image.
fn around(f: &Frame, p: Vec2) -> Vec<usize> {
    let (w, h) = (f.camera.width() as i64, f.camera.height() as i64);
    let x0 = ((p.x - 0.5).floor() as i64).max(0);
    let y0 = ((p.y - 0.5).floor() as i64).max(0);
    [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)]
        .into_iter()
        .filter(|&(x, y)| x < w && y < h)
        .map(|(x, y)| (y * w + x) as usize)
        .collect()
}

fn unit(n: [f32; 3]) -> Option<Vec3> {
    let n = Vec3::from_array(n);
    (n.length_squared() > 0.0).then(|| n * (1.0 / n.length_squared().sqrt()))
}

/// Every texel center around `p` with a normal faces along `dir` (`n . dir
/// > 0.4`).
fn facing_away(f: &Frame, p: Vec2, dir: Vec3) -> bool {
    let normals: Vec<Vec3> = around(f, p)
        .into_iter()
        .filter_map(|j| unit(f.normals[j]))
        .collect();
    !normals.is_empty() && normals.iter().all(|n| n.dot(dir) > 0.4)
}

#[test]
fn pass_equals_the_kernels_it_wraps_bit_for_bit() {
    for conv in CONVENTIONS {
        let f = render(default_camera(), conv);
        let pyr = f.pyramid();
        let hiz = HiZ::try_new(&pyr, f.camera, conv).unwrap();
        for method in [MirrorMethod::Step, MirrorMethod::HiZ] {
            for back in [false, true] {
                let opts = MirrorOptions {
                    method,
                    ..MirrorOptions::default()
                };
                let g = f.gbuffer(back);
                let pass = MirrorPass::try_new(g, opts, Some(hiz)).unwrap();
                let (out, color, host) = run(&pass);
                let mut k = 0;
                for y in 0..120 {
                    for x in 0..160 {
                        let i = (y * 160 + x) as usize;
                        let want = by_hand(&f, &opts, Some(&hiz), back, x, y);
                        assert_eq!(
                            bits(&out[i]),
                            bits(&want),
                            "{conv:?} {method:?} back {back} pixel ({x}, {y})"
                        );
                        let rgb = if want.status == MirrorStatus::Hit {
                            let (tx, ty) = (want.pixel.x as u32, want.pixel.y as u32);
                            f.color[(ty * 160 + tx) as usize]
                        } else {
                            [0.0; 3]
                        };
                        assert_eq!(color[i], rgb, "color ({x}, {y})");
                        if want.status.needs_host() {
                            let hr = host[k];
                            assert_eq!((hr.x, hr.y, hr.status), (x, y, want.status));
                            assert_eq!(Some(hr), pass.host_ray(x, y, want.status));
                            k += 1;
                        }
                    }
                }
                assert_eq!(k, host.len());
            }
        }
    }
}

/// Found and false-hit rates against the exact reflections: a hit is found
/// when it lies within one pixel of the projection of the exact hit and
/// that hit is visible (the pixel it projects to sees the same object at
/// its depth within 2%).
#[derive(Debug, Default)]
struct Rates {
    visible: u32,
    found: u32,
    hits: u32,
    false_hits: u32,
    self_hits: u32,
}

fn rates(f: &Frame, out: &[MirrorTexel], pass: &MirrorPass<'_>) -> Rates {
    let cam = f.camera;
    let (w, h) = (cam.width(), cam.height());
    let mut r = Rates::default();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let Some(mr) = pass.ray(x, y).or_else(|| {
                pass.host_ray(x, y, MirrorStatus::LeftImage)
                    .map(|hr| refl_core::MirrorRay {
                        origin: hr.origin,
                        dir: hr.dir,
                        normal: Vec3::ZERO,
                        t_start: 0.0,
                        thickness: 0.0,
                    })
            }) else {
                continue;
            };
            let (o, d) = (mr.origin.as_dvec3(), mr.dir.as_dvec3().normalize());
            let exact = Scene.trace(o, d, 0.0, f.id[i]);
            let mut visible_px = None;
            if let Some(e) = exact {
                let p = o + d * e.t;
                // Exactly visible: in the image, and the eye sees it
                // (nothing closer on the segment from the eye).
                if let Some(q) = cam.project(p.as_vec3()) {
                    let inside = q.x >= 0.0 && q.y >= 0.0 && q.x < w as f32 && q.y < h as f32;
                    let eye = cam.eye().as_dvec3();
                    let dist = (p - eye).length();
                    let first = Scene.trace(eye, (p - eye) / dist, 0.0, u32::MAX);
                    if inside && first.is_some_and(|s| s.t >= dist * (1.0 - 1e-6)) {
                        visible_px = Some(q.truncate());
                    }
                }
            }
            if visible_px.is_some() {
                r.visible += 1;
                if std::env::var("SSR_VIS").is_ok() {
                    eprintln!("vis {:?} {x} {y}", f.conv);
                }
            }
            let t = &out[i];
            if std::env::var("SSR_DEBUG").is_ok() && t.status != MirrorStatus::Hit {
                if let Some(q) = visible_px {
                    eprintln!(
                        "missed {x},{y} id {} {:?} exact at {q:?} t {:?}",
                        f.id[i],
                        t.status,
                        exact.map(|e| (e.t, e.id))
                    );
                }
            }
            if t.status == MirrorStatus::Hit {
                r.hits += 1;
                let (hx, hy) = (t.pixel.x as u32, t.pixel.y as u32);
                let hit_id = f.id[(hy * w + hx) as usize];
                let found = visible_px.is_some_and(|q| (q - t.pixel).length() <= 1.0);
                if !found && hit_id == f.id[i] && f.id[i] == 0 {
                    r.self_hits += 1;
                }
                match visible_px {
                    Some(q) if (q - t.pixel).length() <= 1.0 => r.found += 1,
                    Some(q) => {
                        r.false_hits += 1;
                        if std::env::var("SSR_DEBUG").is_ok() {
                            eprintln!("far {x},{y} id {} -> hit id {hit_id} at {:?} exact {:?} d {:.2} t {} exact t {:?}", f.id[i], t.pixel, q, (q - t.pixel).length(), t.t, exact.map(|e| e.t));
                        }
                    }
                    None => {
                        r.false_hits += 1;
                        if std::env::var("SSR_DEBUG").is_ok() {
                            eprintln!(
                                "hidden {x},{y} id {} -> hit id {hit_id} at {:?} t {} exact {:?}",
                                f.id[i],
                                t.pixel,
                                t.t,
                                exact.map(|e| (e.t, e.id))
                            );
                        }
                    }
                }
            }
        }
    }
    r
}

#[test]
fn defaults_find_the_visible_reflections_in_every_convention() {
    let cams = [
        ("default", default_camera()),
        ("grazing", grazing_camera()),
        // Close, looking down.
        (
            "near",
            camera(
                Vec3::new(0.2, 3.0, 2.8),
                Vec3::new(0.4, 0.3, -0.2),
                128,
                128,
            ),
        ),
    ];
    let mut bad = Vec::new();
    for (name, cam) in cams {
        for conv in CONVENTIONS {
            let f = render(cam, conv);
            let pyr = f.pyramid();
            let hiz = HiZ::try_new(&pyr, cam, conv).unwrap();
            for method in [MirrorMethod::Step, MirrorMethod::HiZ] {
                for back in [false, true] {
                    let opts = MirrorOptions {
                        method,
                        ..MirrorOptions::default()
                    };
                    let pass = MirrorPass::try_new(f.gbuffer(back), opts, Some(hiz)).unwrap();
                    let (out, _, _) = run(&pass);
                    if std::env::var("SSR_DEBUG").is_ok() {
                        eprintln!("CASE {name} {conv:?} {method:?} {back}");
                    }
                    let r = rates(&f, &out, &pass);
                    let found = r.found as f64 / r.visible.max(1) as f64;
                    let false_rate = r.false_hits as f64 / r.hits.max(1) as f64;
                    eprintln!(
                        "{name} {conv:?} {method:?} back {back}: {r:?} found {:.2}% false {:.2}%",
                        100.0 * found,
                        100.0 * false_rate
                    );
                    // Measured: found 98.9% / 98.6% (default camera,
                    // without / with back faces), 99.2% / 98.9%
                    // (grazing), 95.1% / 96.0% (near); false 1.7-4.2%;
                    // false hits on the reflector's own texels (beside
                    // the sphere's base, whose true reflection is its
                    // hidden underside) <= 1.7% of the hits. Before the
                    // ray term of issue 13's visible-surface bound
                    // (`refl_core::ssr::HIDDEN_SLOPES`) the default and
                    // grazing cameras found 98.4% and 98.0%.
                    let want = if name == "near" { 0.95 } else { 0.985 };
                    if !(r.visible > 200
                        && r.self_hits as f64 <= 0.02 * r.hits as f64
                        && found >= want
                        && false_rate <= 0.05)
                    {
                        bad.push(format!("{name} {conv:?} {method:?} back {back}: {r:?}"));
                    }
                }
            }
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

/// The start rule and the hit validation over constant thicknesses from
/// 0.05 to 1 of the reflecting pixel's depth: few false hits on the
/// reflector's own texels at any, and the found and false-hit rates stay
/// within bounds (printed with
/// `--nocapture`).
#[test]
fn every_thickness_from_five_percent_to_one_depth() {
    let mut bad = Vec::new();
    for (name, cam) in [("default", default_camera()), ("grazing", grazing_camera())] {
        let f = render(cam, DepthConvention::ReversedZ);
        let pyr = f.pyramid();
        let hiz = HiZ::try_new(&pyr, cam, f.conv).unwrap();
        for thickness in [0.05, 0.1, 0.2, 0.5, 1.0] {
            let opts = MirrorOptions {
                thickness,
                ..MirrorOptions::default()
            };
            let pass = MirrorPass::try_new(f.gbuffer(false), opts, Some(hiz)).unwrap();
            let (out, _, _) = run(&pass);
            let r = rates(&f, &out, &pass);
            let found = r.found as f64 / r.visible.max(1) as f64;
            let false_rate = r.false_hits as f64 / r.hits.max(1) as f64;
            eprintln!(
                "{name} thickness {thickness}: {r:?} found {:.2}% false {:.2}%",
                100.0 * found,
                100.0 * false_rate
            );
            // Thin shells lose hits on the grazing floor (86% at 0.05);
            // from 0.2 on, found >= 98.8%; false <= 3.9% at every one.
            let want = if thickness >= 0.2 { 0.97 } else { 0.85 };
            if !(r.self_hits as f64 <= 0.02 * r.hits as f64 && found >= want && false_rate <= 0.05)
            {
                bad.push(format!("{name} thickness {thickness}: {r:?}"));
            }
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

#[test]
fn bands_equal_the_whole_image_and_a_short_host_list_is_counted() {
    let f = render(default_camera(), DepthConvention::ReversedZ);
    let pass = MirrorPass::try_new(f.gbuffer(false), MirrorOptions::default(), None).unwrap();
    let (whole, whole_color, whole_host) = run(&pass);
    let n = whole.len();
    let mut out = vec![MirrorTexel::default(); n];
    let mut color = vec![[0.0; 3]; n];
    let mut host = Vec::new();
    for band in 0..7 {
        let rows = RowRange::try_all(120).unwrap().band(band, 7).unwrap();
        let at = (rows.start() * 160) as usize;
        let mut o = ImageViewMut::try_band(&mut out[at..], 160, 120, 160, rows).unwrap();
        let mut c = ImageViewMut::try_band(&mut color[at..], 160, 120, 160, rows).unwrap();
        let mut h = vec![HostRay::default(); 160 * rows.len() as usize];
        let st = pass.try_run(&mut o, Some(&mut c), &mut h).unwrap();
        host.extend_from_slice(&h[..st.host_rays_written as usize]);
    }
    assert!(out.iter().zip(&whole).all(|(a, b)| bits(a) == bits(b)));
    assert_eq!(color, whole_color);
    assert_eq!(host, whole_host);
    // A host list of 10: the first 10 in row-major order, all counted.
    let mut o = vec![MirrorTexel::default(); n];
    let mut h = vec![HostRay::default(); 10];
    let st = pass
        .try_run(
            &mut ImageViewMut::try_new(&mut o, 160, 120, 160).unwrap(),
            None,
            &mut h,
        )
        .unwrap();
    assert!(whole_host.len() > 10);
    assert_eq!(st.host_rays as usize, whole_host.len());
    assert_eq!(st.host_rays_written, 10);
    assert_eq!(&h[..], &whole_host[..10]);
    for hr in &whole_host[10..] {
        assert_eq!(pass.host_ray(hr.x, hr.y, hr.status), Some(*hr));
    }
}

#[test]
fn bad_options_and_mismatched_buffers_are_refused_and_nothing_is_written() {
    let f = render(default_camera(), DepthConvention::ZeroToOne);
    let g = f.gbuffer(false);
    let pyr = f.pyramid();
    let hiz = HiZ::try_new(&pyr, f.camera, f.conv).unwrap();
    let d = MirrorOptions::default();
    let bad = [
        MirrorOptions {
            thickness: -1.0,
            ..d
        },
        MirrorOptions {
            thickness: f32::NAN,
            ..d
        },
        MirrorOptions {
            thickness: f32::INFINITY,
            ..d
        },
        MirrorOptions {
            start_pixels: -0.5,
            ..d
        },
        MirrorOptions {
            start_pixels: f32::NAN,
            ..d
        },
        MirrorOptions { t_min: -1.0, ..d },
        MirrorOptions {
            t_min: f32::INFINITY,
            ..d
        },
        MirrorOptions {
            t_min: 2.0,
            t_max: 2.0,
            ..d
        },
        MirrorOptions {
            t_max: f32::NAN,
            ..d
        },
        MirrorOptions {
            max_roughness: f32::NAN,
            ..d
        },
        MirrorOptions {
            border_fade: 0.6,
            ..d
        },
        MirrorOptions {
            border_fade: -0.1,
            ..d
        },
        MirrorOptions {
            step: refl_core::StepOptions {
                stride: 0,
                ..d.step
            },
            ..d
        },
    ];
    for o in bad {
        assert_eq!(
            MirrorPass::try_new(g, o, Some(hiz)).err(),
            Some(Error::InvalidArgument),
            "{o:?}"
        );
    }
    let hiz_opts = MirrorOptions {
        method: MirrorMethod::HiZ,
        ..d
    };
    // Hi-Z without a pyramid, or with one of another camera or convention.
    assert_eq!(
        MirrorPass::try_new(g, hiz_opts, None).err(),
        Some(Error::InvalidArgument)
    );
    let other = camera(Vec3::new(0.4, 2.2, 6.0), Vec3::new(0.3, 0.7, 0.0), 160, 120);
    let f2 = render(other, f.conv);
    let pyr2 = f2.pyramid();
    let hiz2 = HiZ::try_new(&pyr2, other, f.conv).unwrap();
    assert_eq!(
        MirrorPass::try_new(g, hiz_opts, Some(hiz2)).err(),
        Some(Error::InvalidArgument)
    );
    let hiz3 = HiZ::try_new(&pyr, f.camera, DepthConvention::ReversedZ).unwrap();
    assert_eq!(
        MirrorPass::try_new(g, hiz_opts, Some(hiz3)).err(),
        Some(Error::InvalidArgument)
    );
    // Outputs of the wrong size, colors without a G-buffer color, or
    // color and texel bands that differ: refused, nothing written.
    let pass = MirrorPass::try_new(g, d, None).unwrap();
    let sentinel = MirrorTexel {
        t: 7.0,
        ..MirrorTexel::default()
    };
    let mut small = vec![sentinel; 159 * 120];
    let mut host = vec![HostRay::default(); 4];
    assert_eq!(
        pass.try_run(
            &mut ImageViewMut::try_new(&mut small, 159, 120, 159).unwrap(),
            None,
            &mut host
        )
        .err(),
        Some(Error::InvalidArgument)
    );
    assert!(small.iter().all(|t| *t == sentinel));
    let mut out = vec![sentinel; 160 * 120];
    let mut col = vec![[5.0; 3]; 160 * 120];
    let plain = GBuffer::try_new(*g.depth(), *g.normals(), NormalSpace::World).unwrap();
    let no_color = MirrorPass::try_new(plain, d, None).unwrap();
    assert_eq!(
        no_color
            .try_run(
                &mut ImageViewMut::try_new(&mut out, 160, 120, 160).unwrap(),
                Some(&mut ImageViewMut::try_new(&mut col, 160, 120, 160).unwrap()),
                &mut host
            )
            .err(),
        Some(Error::InvalidArgument)
    );
    let rows = RowRange::try_new(0, 60, 120).unwrap();
    assert_eq!(
        pass.try_run(
            &mut ImageViewMut::try_new(&mut out, 160, 120, 160).unwrap(),
            Some(&mut ImageViewMut::try_band(&mut col, 160, 120, 160, rows).unwrap()),
            &mut host
        )
        .err(),
        Some(Error::InvalidArgument)
    );
    assert!(out.iter().all(|t| *t == sentinel));
    assert!(col.iter().all(|c| *c == [5.0; 3]));
    assert!(host.iter().all(|h| *h == HostRay::default()));
    // G-buffer images of another size.
    let n2 = vec![[0.0f32; 3]; 100];
    assert_eq!(
        GBuffer::try_new(
            *g.depth(),
            ImageView::try_new(&n2, 10, 10, 10).unwrap(),
            NormalSpace::World
        )
        .err(),
        Some(Error::InvalidArgument)
    );
    let m2 = vec![1u8; 100];
    assert_eq!(
        g.try_with_mask(ImageView::try_new(&m2, 10, 10, 10).unwrap())
            .err(),
        Some(Error::InvalidArgument)
    );
}

#[test]
fn masks_roughness_view_normals_and_hostile_pixels() {
    let mut f = render(default_camera(), DepthConvention::Linear);
    let (w, h) = (160u32, 120u32);
    // NaN and infinite depths, zero, NaN and huge normals in a few pixels.
    let spots = [
        (10usize, 100usize),
        (80, 90),
        (100, 70),
        (30, 60),
        (120, 100),
    ];
    f.depth[spots[0].1 * 160 + spots[0].0] = f32::NAN;
    f.depth[spots[1].1 * 160 + spots[1].0] = f32::INFINITY;
    f.normals[spots[2].1 * 160 + spots[2].0] = [0.0; 3];
    f.normals[spots[3].1 * 160 + spots[3].0] = [f32::NAN, 1.0, 0.0];
    // Huge and tiny normals (their squares overflow or underflow f32) are
    // as usable as unit ones (finding F24b: 1e30 was refused).
    let unit = f.normals[spots[4].1 * 160 + spots[4].0];
    let unit = Vec3::from_array(unit).normalize();
    let plain = MirrorPass::try_new(f.gbuffer(false), MirrorOptions::default(), None).unwrap();
    let want = plain.pixel(spots[4].0 as u32, spots[4].1 as u32);
    assert_ne!(want.0.status, MirrorStatus::NoSurface);
    for scale in [1e30f32, 1e-30, f32::MAX, 1e-44] {
        let mut g = f.clone();
        g.normals[spots[4].1 * 160 + spots[4].0] = (unit * scale).to_array();
        let p = MirrorPass::try_new(g.gbuffer(false), MirrorOptions::default(), None).unwrap();
        let got = p.pixel(spots[4].0 as u32, spots[4].1 as u32);
        assert_eq!(got.0.status, want.0.status, "normal scaled by {scale:e}");
        assert!(
            (got.0.pixel - want.0.pixel).length() < 0.05
                && (got.0.t - want.0.t).abs() <= 1e-4 * want.0.t.abs(),
            "normal scaled by {scale:e}: {got:?} vs {want:?}"
        );
    }
    let base = plain;
    for (k, &(x, y)) in spots.iter().enumerate().take(4) {
        let (t, hr) = base.pixel(x as u32, y as u32);
        assert_eq!((t.status, hr), (MirrorStatus::NoSurface, None), "spot {k}");
    }
    let (whole, _, _) = run(&base);
    // View-space normals give the same rays up to rounding.
    let view = f.camera.view();
    let vn: Vec<[f32; 3]> = f
        .normals
        .iter()
        .map(|n| view.transform_vector3(Vec3::from_array(*n)).to_array())
        .collect();
    let g = f.gbuffer(false);
    let gv = GBuffer::try_new(
        *g.depth(),
        ImageView::try_new(&vn, w, h, w).unwrap(),
        NormalSpace::View,
    )
    .unwrap();
    let pv = MirrorPass::try_new(gv, MirrorOptions::default(), None).unwrap();
    let mut same = 0;
    let mut hits = 0;
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (pv.pixel(x, y).0, whole[(y * w + x) as usize]);
            if b.status == MirrorStatus::Hit {
                hits += 1;
                if a.status == b.status && (a.pixel - b.pixel).length() < 0.05 {
                    same += 1;
                }
            }
        }
    }
    assert!(same as f64 >= 0.99 * hits as f64, "{same} of {hits}");
    // A mask and a roughness image skip pixels.
    let mask: Vec<u8> = (0..w * h).map(|i| (i % 2) as u8).collect();
    let rough: Vec<f32> = (0..w * h)
        .map(|i| {
            if i % 3 == 0 {
                0.5
            } else if i % 3 == 1 {
                f32::NAN
            } else {
                0.0
            }
        })
        .collect();
    let gm = g
        .try_with_mask(ImageView::try_new(&mask, w, h, w).unwrap())
        .unwrap()
        .try_with_roughness(ImageView::try_new(&rough, w, h, w).unwrap())
        .unwrap();
    let pm = MirrorPass::try_new(gm, MirrorOptions::default(), None).unwrap();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let t = pm.pixel(x, y).0;
            if mask[i] == 0 || !(rough[i] <= 0.1) {
                assert_eq!(t.status, MirrorStatus::Skipped, "({x}, {y})");
            } else {
                assert_eq!(bits(&t), bits(&whole[i]), "({x}, {y})");
            }
        }
    }
}

/// A surface at a linear depth near `f32::MAX` (an infinite far plane):
/// the distance to it overflows f32, so it is handed to the host, never a
/// hit at `t = inf` (the `ssr` fuzz target's case, both methods; before
/// the fix Hi-Z returned a hit with `t = inf` at pixel (2, 4)).
#[test]
fn a_hit_whose_distance_overflows_goes_to_the_host() {
    let view = refl_core::glam::Mat4::from_cols_array(&[
        -0.70710677,
        -0.2949813,
        0.6426399,
        0.0,
        0.0,
        0.90883005,
        0.41716653,
        0.0,
        -0.70710677,
        0.2949813,
        -0.6426399,
        0.0,
        -0.0,
        -1.4361503,
        -8.909497,
        1.0,
    ]);
    let cam =
        refl_core::Camera::try_new(view, 2.1887386, 0.83305883, f32::INFINITY, 21, 5).unwrap();
    let depth: [f32; 105] = [
        824468.56,
        f32::INFINITY,
        f32::MAX,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::NAN,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::NAN,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::NAN,
        10.839704,
        10.839707,
        10.839704,
        10.839705,
        10.839704,
        10.839702,
        10.839703,
        f32::NAN,
        10.839703,
        10.839703,
        10.839703,
        10.839703,
        10.839703,
        10.839704,
        10.839702,
        10.839702,
        10.839704,
        10.839705,
        f32::NAN,
        10.839704,
        10.839704,
        4.031782,
        4.031783,
        4.031782,
        4.03178,
        4.031779,
        f32::NAN,
        4.0317793,
        4.031779,
        4.0317793,
        4.0317793,
        f32::NAN,
        4.0317793,
        4.0317793,
        4.031779,
        4.0317783,
        4.0317793,
        f32::NAN,
        4.0317793,
        4.0317793,
        4.031781,
        4.031781,
        2.476441,
        2.4764395,
        2.4764404,
        f32::NAN,
        2.4764404,
        2.47644,
        2.4764395,
        2.47644,
        2.4764395,
        2.4764404,
        2.4764404,
        2.47644,
        2.47644,
        2.47644,
        f32::NAN,
        2.47644,
        2.47644,
        2.4764404,
        2.4764404,
        2.4764404,
        2.47644,
    ];
    let normals = [[0.0f32, 1.0, 0.0]; 105];
    let conv = DepthConvention::Linear;
    let dv = ImageView::try_new(&depth, 21, 5, 21).unwrap();
    let di = refl_core::DepthImage::try_new(dv, cam, conv).unwrap();
    let nv = ImageView::try_new(&normals, 21, 5, 21).unwrap();
    let mut pyr = vec![refl_core::HiZTexel::default(); refl_core::try_hiz_len(21, 5).unwrap()];
    refl_core::try_build_hiz(&mut pyr, &di).unwrap();
    for method in [MirrorMethod::Step, MirrorMethod::HiZ] {
        let g = GBuffer::try_new(di, nv, NormalSpace::View).unwrap();
        let o = MirrorOptions {
            method,
            ..MirrorOptions::default()
        };
        let hiz = (method == MirrorMethod::HiZ).then(|| HiZ::try_new(&pyr, cam, conv).unwrap());
        let pass = MirrorPass::try_new(g, o, hiz).unwrap();
        for y in 0..5 {
            for x in 0..21 {
                let (t, _) = pass.pixel(x, y);
                if t.status == MirrorStatus::Hit {
                    assert!(
                        t.t.is_finite(),
                        "{method:?} ({x}, {y}): a hit at t = {}",
                        t.t
                    );
                }
            }
        }
        if method == MirrorMethod::HiZ {
            let (t, hr) = pass.pixel(2, 4);
            assert_eq!(t.status, MirrorStatus::NoProjection);
            assert_eq!(
                hr.map(|r| (r.x, r.y, r.status)),
                Some((2, 4, MirrorStatus::NoProjection))
            );
        }
    }
}

/// The resume budget past hidden hits covers the same share of the image
/// at every resolution: 32 up to 256 pixels on the larger side, an eighth
/// of it beyond.
#[test]
fn hidden_resume_budget_scales_with_the_image() {
    use refl_core::ssr::{hidden_resumes, HIDDEN_RESUMES};
    assert_eq!(HIDDEN_RESUMES, 32);
    for (w, h, want) in [
        (0, 0, 32),
        (1, 1, 32),
        (160, 120, 32),
        (256, 192, 32),
        (192, 256, 32),
        (264, 100, 33),
        (512, 384, 64),
        (384, 512, 64),
        (1920, 1080, 240),
        (u32::MAX, 1, u32::MAX / 8),
    ] {
        assert_eq!(hidden_resumes(w, h), want, "{w}x{h}");
    }
}

/// Finding F26b (fuzz target `cluster_pass`): with an infinite far plane a
/// surface 1e21 from the eye is a surface, but its view vector's square
/// overflowed f32 and the pixel read as "no surface" in every pass. The
/// mirror direction of a far wall facing the camera is the view direction
/// turned back, as it is for a near one.
#[test]
fn far_surfaces_beyond_the_f32_square_still_reflect() {
    let (w, h) = (8u32, 6u32);
    let cam = Camera::try_look_at(
        Vec3::new(0.3, 1.0, 2.0),
        Vec3::new(0.3, 1.0, -5.0),
        Vec3::Y,
        1.0,
        0.1,
        f32::INFINITY,
        w,
        h,
    )
    .unwrap();
    for z in [10.0f32, 1e18, 1e21, 1e30] {
        let depth = vec![z; (w * h) as usize];
        let normals = vec![[0.0f32, 0.0, 1.0]; (w * h) as usize];
        let d = DepthImage::try_new(
            ImageView::try_new(&depth, w, h, w).unwrap(),
            cam,
            DepthConvention::Linear,
        )
        .unwrap();
        let g = GBuffer::try_new(
            d,
            ImageView::try_new(&normals, w, h, w).unwrap(),
            NormalSpace::World,
        )
        .unwrap();
        let pass = MirrorPass::try_new(g, MirrorOptions::default(), None).unwrap();
        for (x, y) in [(0, 0), (4, 3), (7, 5)] {
            let (t, host) = pass.pixel(x, y);
            assert_ne!(t.status, MirrorStatus::NoSurface, "depth {z:e} ({x}, {y})");
            if let Some(r) = host {
                let v = cam
                    .primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
                    .dir;
                let want = Vec3::new(v.x, v.y, -v.z);
                assert!(
                    (r.dir - want).length() < 1e-4,
                    "depth {z:e}: {:?} vs {want:?}",
                    r.dir
                );
            }
        }
    }
}

/// As the layered pass's F32: a hit's `t` (start plus the kernel's `t`,
/// itself at most the rounded `t_max - t_start`) never passes `t_max`,
/// with `t_max` set to each hit's own distance and the float below it.
#[test]
fn hits_never_pass_t_max() {
    let f = render(default_camera(), CONVENTIONS[0]);
    let pyr = f.pyramid();
    let hiz = HiZ::try_new(&pyr, f.camera, CONVENTIONS[0]).unwrap();
    for method in [MirrorMethod::Step, MirrorMethod::HiZ] {
        let d = MirrorOptions {
            method,
            ..MirrorOptions::default()
        };
        let pass = MirrorPass::try_new(f.gbuffer(false), d, Some(hiz)).unwrap();
        let ts: Vec<f32> = run(&pass)
            .0
            .iter()
            .filter(|t| t.status == MirrorStatus::Hit)
            .map(|t| t.t)
            .collect();
        assert!(ts.len() > 100, "{} hits", ts.len());
        let mut checked = 0;
        for &t_hit in ts.iter().step_by(ts.len() / 16) {
            for t_max in [t_hit, f32::from_bits(t_hit.to_bits() - 1)] {
                let o = MirrorOptions { t_max, ..d };
                let pass = MirrorPass::try_new(f.gbuffer(false), o, Some(hiz)).unwrap();
                for t in run(&pass).0 {
                    if t.status == MirrorStatus::Hit {
                        checked += 1;
                        assert!(
                            t.t >= o.t_min && t.t <= t_max,
                            "{method:?}: hit t {} outside [{}, {t_max}]",
                            t.t,
                            o.t_min
                        );
                    }
                }
            }
        }
        assert!(checked > 1000, "{checked} hits checked");
    }
}
