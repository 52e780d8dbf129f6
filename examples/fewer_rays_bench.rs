//! Single-thread timings of the parts of the fewer-rays mirror pass
//! (seed 004 Sec. 4.7.3-4.7.4, `refl_core::upsample`) on the room at pose
//! 0: the Hi-Z pyramid build, the full-resolution pass, the half pass (one
//! ray per 2x2 block) and the reconstruction, each alone, with the
//! reconstruction's counts.
//!
//! ```text
//! cargo run --release --example fewer_rays_bench -- [--tris N] [--size WxH] [--reps N]
//! ```
//!
//! Wall-clock numbers on a shared machine are noisy: compare the parts
//! within one run (the median of `--reps` is printed).

use refl_app::gbuffer::GBuffer;
use refl_app::scene::Scene;
use refl_app::screen::{self, DepthBuffer, PassImages, ScreenMethod};
use refl_app::tracer::Tracer;
use refl_core::hiz::{HiZOptions, HiZTexel};
use refl_core::upsample::{try_half_size, HalfPass, Subsample, UpsampleOptions, UpsamplePass};
use refl_core::{DepthConvention, ImageView, ImageViewMut, MirrorPass, MirrorTexel};
use std::time::Instant;

fn median_ms(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut v: Vec<f64> = (0..reps.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let (mut tris, mut w, mut h, mut reps) = (30_000usize, 512u32, 384u32, 5usize);
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let v = args.get(i + 1).cloned().unwrap_or_default();
        match args[i].as_str() {
            "--tris" => tris = v.parse().expect("--tris N"),
            "--reps" => reps = v.parse().expect("--reps N"),
            "--size" => {
                let (a, b) = v.split_once('x').expect("--size WxH");
                (w, h) = (a.parse().expect("width"), b.parse().expect("height"));
            }
            other => panic!("unknown argument {other}"),
        }
        i += 2;
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let scene = Scene::room(tris);
    let tracer = Tracer::new(&scene);
    let cam = scene.camera(0, w, h).expect("camera");
    let g = GBuffer::render(&scene, &tracer, &cam, &pool);
    let lit = vec![glam::Vec3::splat(0.5); g.len()];
    let images = PassImages::new(&g, Some(&lit));
    let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY).expect("depth");
    let image = depth.image().expect("image");
    let method = ScreenMethod::HiZ(HiZOptions::default());
    let mut pyramid: Vec<HiZTexel> = vec![[0.0; 2]; refl_core::try_hiz_len(w, h).expect("hiz len")];

    let build = median_ms(reps, || {
        screen::build_hiz(&mut pyramid, &image, &pool).expect("build");
    });
    let full = median_ms(reps, || {
        screen::run(method, true, &image, &images, &pool).expect("full pass");
    });
    let hiz = refl_core::HiZ::try_new(&pyramid, *image.camera(), image.convention()).expect("hiz");
    let pass = MirrorPass::try_new(
        images.gbuffer(image).expect("gbuffer"),
        method.options(true),
        Some(hiz),
    )
    .expect("pass");
    let (hw, hh) = try_half_size(w, h).expect("half size");
    let mut half = vec![MirrorTexel::default(); (hw * hh) as usize];
    let mut half_color = vec![[0.0f32; 3]; (hw * hh) as usize];
    println!("room({tris}) {w}x{h}, one thread, median of {reps}:");
    println!("  hi-z build          {build:8.2} ms");
    println!("  full pass (+build)  {full:8.2} ms");
    for (name, sub) in [
        ("uniform", Subsample::uniform(0)),
        ("staggered", Subsample::staggered(0)),
    ] {
        let hp = HalfPass::new(pass, sub);
        let trace = median_ms(reps, || {
            let mut o = ImageViewMut::try_new(&mut half, hw, hh, hw).expect("half");
            let mut c = ImageViewMut::try_new(&mut half_color, hw, hh, hw).expect("color");
            hp.try_run(&mut o, Some(&mut c), &mut [])
                .expect("half pass");
        });
        println!("  {name}: half pass {trace:8.2} ms");
        for (label, options) in [
            ("bilateral", UpsampleOptions::default()),
            (
                "bilateral+retrace",
                UpsampleOptions {
                    retrace: true,
                    ..UpsampleOptions::default()
                },
            ),
            (
                "bilinear",
                UpsampleOptions {
                    depth_threshold: f32::INFINITY,
                    depth_sigma: f32::INFINITY,
                    normal_power: 0.0,
                    ..UpsampleOptions::default()
                },
            ),
        ] {
            let up = UpsamplePass::try_new(
                pass,
                sub,
                ImageView::try_new(&half, hw, hh, hw).expect("half"),
                Some(ImageView::try_new(&half_color, hw, hh, hw).expect("color")),
                options,
            )
            .expect("upsample");
            let mut out = vec![MirrorTexel::default(); (w * h) as usize];
            let mut color = vec![[0.0f32; 3]; (w * h) as usize];
            let mut stats = Default::default();
            let ms = median_ms(reps, || {
                let mut o = ImageViewMut::try_new(&mut out, w, h, w).expect("out");
                let mut c = ImageViewMut::try_new(&mut color, w, h, w).expect("color");
                stats = up
                    .try_run(&mut o, Some(&mut c), None, &mut [])
                    .expect("upsample");
            });
            println!("    {label:18} {ms:8.2} ms  {stats:?}");
        }
    }
}
