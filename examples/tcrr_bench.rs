//! Profiles the TCRR passes (seed 000) alone on the room path, single
//! threaded: one key frame (frame 0, traced in full), then `--reuse` frames
//! reprojected from it with the offsets carried from frame to frame. Per
//! frame it prints the time of each pass (search, shift, warp, re-trace
//! list), of tracing the listed pixels and of tracing every mirror pixel,
//! the re-traced share and the mean absolute difference (0..255, final
//! image, mirror pixels) against the ray-traced frame; `--images DIR`
//! writes per-pixel error images (error x 16, re-traced pixels blue).
//! Per frame it also prints an FNV-1a digest of the passes' outputs
//! (offsets, intermediate image, warped color, mask) to compare kernel
//! versions bit for bit.
//!
//! ```text
//! cargo run --release --example tcrr_bench -- [--width 512] [--height 384]
//!     [--tris 150000] [--frames 60] [--span 0.25] [--reuse 4] [--reps 1]
//!     [--images DIR]
//! ```
//!
//! Set `TCRR_NO_SURFELS` to run the passes without the prepared surfels.
//! `--reps N` repeats every pass N times per frame (for `perf record`).
//! Times are the thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`).

use glam::Vec3;
use refl_app::gbuffer::GBuffer;
use refl_app::render::{compare, composite, direct_image, save_png, to_srgb8, ReflectionImage};
use refl_app::scene::Scene;
use refl_app::shade::Shader;
use refl_app::tcrr::{handled_mask, path_cameras, trace_mirror};
use refl_app::tracer::Tracer;
use refl_core::tcrr::{self, CurrentView, ReflectionBuffers, TcrrOptions, INVALID_OFFSET};
use refl_core::{DepthConvention, ImageView, ImageViewMut};
use std::path::PathBuf;
use std::time::Instant;

struct Args {
    width: u32,
    height: u32,
    tris: usize,
    frames: usize,
    span: f32,
    reuse: usize,
    reps: usize,
    images: Option<PathBuf>,
}

fn parse<T: std::str::FromStr>(k: &str, x: &str) -> T {
    x.parse()
        .unwrap_or_else(|_| panic!("bad value for {k}: {x}"))
}

fn args() -> Args {
    let mut a = Args {
        width: 512,
        height: 384,
        tris: 150_000,
        frames: 60,
        span: 0.25,
        reuse: 4,
        reps: 1,
        images: None,
    };
    let v: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i + 1 < v.len() {
        let (k, x) = (v[i].as_str(), v[i + 1].as_str());
        match k {
            "--width" => a.width = parse(k, x),
            "--height" => a.height = parse(k, x),
            "--tris" => a.tris = parse(k, x),
            "--frames" => a.frames = parse(k, x),
            "--span" => a.span = parse(k, x),
            "--reuse" => a.reuse = parse(k, x),
            "--reps" => a.reps = parse(k, x),
            "--images" => a.images = Some(PathBuf::from(x)),
            _ => panic!("unknown option {k}"),
        }
        i += 2;
    }
    a
}

/// On-CPU time of the calling thread in ns (the machine is shared, so
/// wall-clock time would count other processes' slices).
fn cpu_ns() -> Option<u64> {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid, writable timespec.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    (rc == 0).then(|| t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64)
}

/// A pass timer: on-CPU time where the system reports it, else wall time.
#[derive(Clone, Copy)]
struct Clock(Instant, Option<u64>);

impl Clock {
    fn now() -> Self {
        Clock(Instant::now(), cpu_ns())
    }
}

fn ms(t: Clock) -> f64 {
    match (t.1, cpu_ns()) {
        (Some(a), Some(b)) => (b - a) as f64 * 1e-6,
        _ => t.0.elapsed().as_secs_f64() * 1e3,
    }
}

fn main() {
    let a = args();
    let (w, h) = (a.width, a.height);
    let n = (w * h) as usize;
    let scene = Scene::room(a.tris);
    let tracer = Tracer::new(&scene);
    let shader = Shader::new(&scene, &tracer);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let cams = path_cameras(&scene, a.frames, (0.0, a.span), w, h).expect("cameras");
    let params = TcrrOptions::default();

    // Key frame 0: trace every mirror pixel.
    let g0 = GBuffer::render(&scene, &tracer, &cams[0], &pool);
    let handled0 = handled_mask(&g0);
    let mut kcolor = vec![[0.0f32; 3]; n];
    let mut kdist = vec![f32::INFINITY; n];
    for i in (0..n).filter(|&i| handled0[i]) {
        let (c, d) = trace_mirror(&shader, &g0, i);
        kcolor[i] = c.to_array();
        kdist[i] = d;
    }
    let knormal: Vec<[f32; 3]> = g0.normal.iter().map(|v| v.to_array()).collect();
    let kspec: Vec<f32> = (0..n)
        .map(|i| if handled0[i] { g0.specular[i] } else { 0.0 })
        .collect();
    let buffers = ReflectionBuffers::try_new(
        g0.camera,
        DepthConvention::Linear,
        ImageView::try_new(&g0.depth, w, h, w).unwrap(),
        ImageView::try_new(&knormal, w, h, w).unwrap(),
        ImageView::try_new(&kspec, w, h, w).unwrap(),
        ImageView::try_new(&kcolor, w, h, w).unwrap(),
        ImageView::try_new(&kdist, w, h, w).unwrap(),
    )
    .unwrap();
    let mut surfels = vec![tcrr::Surfel::default(); n];
    let t = Clock::now();
    tcrr::try_prepare(
        &mut ImageViewMut::try_new(&mut surfels, w, h, w).unwrap(),
        &buffers,
    )
    .unwrap();
    let t_prepare = ms(t);
    let buffers = if std::env::var_os("TCRR_NO_SURFELS").is_some() {
        buffers
    } else {
        buffers
            .try_with_surfels(ImageView::try_new(&surfels, w, h, w).unwrap())
            .unwrap()
    };

    let mut offsets = vec![INVALID_OFFSET; n];
    let mut inter = vec![[0.0f32; 3]; n];
    let mut idepth = vec![0.0f32; n];
    let mut coverage = vec![0u8; n];
    let mut color = vec![[0.0f32; 3]; n];
    let mut mask = vec![0u8; n];
    println!(
        "{w}x{h}, {} triangles, key frame 0, mirror pixels {}",
        a.tris,
        handled0.iter().filter(|&&b| b).count()
    );
    println!("prepare (once per key frame): {t_prepare:.2} ms");
    println!("frame  search  shift   warp   list  retrace  | trace_all  ratio | share   MAD    MAD(reused px)  iters/px");
    for (f, cam) in cams.iter().enumerate().skip(1).take(a.reuse) {
        let g = GBuffer::render(&scene, &tracer, cam, &pool);
        let handled = handled_mask(&g);
        let spec: Vec<f32> = (0..n)
            .map(|i| if handled[i] { g.specular[i] } else { 0.0 })
            .collect();
        let eye = g.camera.eye();
        let start_offsets = offsets.clone();
        let (mut t_search, mut t_shift, mut t_warp, mut t_list) = (0.0, 0.0, 0.0, 0.0);
        let mut sstats = tcrr::SearchStats::default();
        let mut list = Vec::new();
        for _ in 0..a.reps {
            offsets.copy_from_slice(&start_offsets);
            let t = Clock::now();
            let mut ov = ImageViewMut::try_new(&mut offsets, w, h, w).unwrap();
            sstats = tcrr::try_search(&mut ov, &buffers, eye, &params).unwrap();
            t_search += ms(t);

            let t = Clock::now();
            let ov = ImageView::try_new(&offsets, w, h, w).unwrap();
            let mut c = ImageViewMut::try_new(&mut inter, w, h, w).unwrap();
            let mut d = ImageViewMut::try_new(&mut idepth, w, h, w).unwrap();
            let mut v = ImageViewMut::try_new(&mut coverage, w, h, w).unwrap();
            tcrr::try_shift(&mut c, &mut d, &mut v, &buffers, &ov, &params).unwrap();
            t_shift += ms(t);

            let t = Clock::now();
            let current = CurrentView::try_new(
                g.camera,
                DepthConvention::Linear,
                ImageView::try_new(&g.depth, w, h, w).unwrap(),
                ImageView::try_new(&spec, w, h, w).unwrap(),
            )
            .unwrap();
            let mut c = ImageViewMut::try_new(&mut color, w, h, w).unwrap();
            let mut m = ImageViewMut::try_new(&mut mask, w, h, w).unwrap();
            tcrr::try_warp(
                &mut c,
                &mut m,
                &current,
                &buffers,
                &ImageView::try_new(&inter, w, h, w).unwrap(),
                &ImageView::try_new(&idepth, w, h, w).unwrap(),
                &ImageView::try_new(&coverage, w, h, w).unwrap(),
                &params,
            )
            .unwrap();
            t_warp += ms(t);

            let t = Clock::now();
            let mv = ImageView::try_new(&mask, w, h, w).unwrap();
            list = vec![0u32; tcrr::retrace_count(&mv)];
            tcrr::try_retrace_list(&mut list, &mv).unwrap();
            t_list += ms(t);
        }
        let reps = a.reps as f64;
        // FNV-1a over the bits of the passes' outputs: equal digests before
        // and after a kernel change mean bit-identical results.
        let mut digest = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |bits: u32| {
            digest = (digest ^ u64::from(bits)).wrapping_mul(0x0100_0000_01b3);
        };
        offsets.iter().flatten().for_each(|v| eat(v.to_bits()));
        inter.iter().flatten().for_each(|v| eat(v.to_bits()));
        idepth.iter().for_each(|v| eat(v.to_bits()));
        coverage.iter().for_each(|&v| eat(u32::from(v)));
        color.iter().flatten().for_each(|v| eat(v.to_bits()));
        mask.iter().for_each(|&v| eat(u32::from(v)));
        eprintln!(
            "      digest of offsets, intermediate image, warped color and mask: {digest:016x}"
        );
        let t = Clock::now();
        for &i in &list {
            color[i as usize] = trace_mirror(&shader, &g, i as usize).0.to_array();
        }
        let t_retrace = ms(t);
        let t = Clock::now();
        let mut truth = vec![Vec3::ZERO; n];
        for i in (0..n).filter(|&i| handled[i]) {
            truth[i] = trace_mirror(&shader, &g, i).0;
        }
        let t_all = ms(t);
        let direct = direct_image(&shader, &g, &pool);
        let img = |rgb: Vec<Vec3>| ReflectionImage {
            width: w,
            height: h,
            rgb,
            handled: handled.clone(),
        };
        let fin_t = composite(&g, &direct, &img(truth));
        let fin_m = composite(
            &g,
            &direct,
            &img(color.iter().map(|c| Vec3::from_array(*c)).collect()),
        );
        let e = compare(&fin_t, &fin_m, &handled);
        let reused: Vec<bool> = mask.iter().map(|&m| m == tcrr::MASK_REUSED).collect();
        let er = compare(&fin_t, &fin_m, &reused);
        // Where the error sits: reused pixels on a reflected edge (the
        // ray-traced frame's 4-neighbors differ by more than 16 levels)
        // versus smooth ones.
        let q: Vec<[u8; 3]> = fin_t.iter().map(|&c| to_srgb8(c)).collect();
        let edge_px: Vec<bool> = (0..n)
            .map(|i| {
                let (x, y) = (i % w as usize, i / w as usize);
                let mut nb = vec![];
                if x > 0 {
                    nb.push(i - 1);
                }
                if x + 1 < w as usize {
                    nb.push(i + 1);
                }
                if y > 0 {
                    nb.push(i - w as usize);
                }
                if y + 1 < h as usize {
                    nb.push(i + w as usize);
                }
                reused[i]
                    && nb
                        .iter()
                        .any(|&j| (0..3).any(|c| q[i][c].abs_diff(q[j][c]) > 16))
            })
            .collect();
        let smooth_px: Vec<bool> = (0..n).map(|i| reused[i] && !edge_px[i]).collect();
        let (ee, es) = (
            compare(&fin_t, &fin_m, &edge_px),
            compare(&fin_t, &fin_m, &smooth_px),
        );
        eprintln!(
            "      reused on reflected edges: {} px, MAD {:.2}; smooth: {} px, MAD {:.3}; share of the total error on edges {:.2}",
            ee.pixels,
            ee.mean_abs,
            es.pixels,
            es.mean_abs,
            ee.mean_abs * ee.pixels as f64
                / (ee.mean_abs * ee.pixels as f64 + es.mean_abs * es.pixels as f64).max(1e-9)
        );
        let n_handled = handled.iter().filter(|&&b| b).count();
        let tcrr_ms = (t_search + t_shift + t_warp + t_list) / reps + t_retrace;
        println!(
            "{f:5} {:7.2} {:6.2} {:6.2} {:6.2} {:7.2}  | {:8.2}  {:5.2} | {:.3}  {:.3}  {:.3} ({} px)  {:.2}",
            t_search / reps,
            t_shift / reps,
            t_warp / reps,
            t_list / reps,
            t_retrace,
            t_all,
            t_all / tcrr_ms,
            list.len() as f64 / n_handled.max(1) as f64,
            e.mean_abs,
            er.mean_abs,
            er.pixels,
            sstats.iterations as f64 / sstats.reflective.max(1) as f64,
        );
        if let Some(dir) = &a.images {
            std::fs::create_dir_all(dir).expect("image dir");
            let err: Vec<Vec3> = (0..n)
                .map(|i| {
                    if mask[i] == tcrr::MASK_RETRACE {
                        return Vec3::new(0.0, 0.0, 0.25);
                    }
                    if !handled[i] {
                        return Vec3::ZERO;
                    }
                    let (p, q) = (to_srgb8(fin_t[i]), to_srgb8(fin_m[i]));
                    let d = (0..3).map(|c| p[c].abs_diff(q[c])).max().unwrap_or(0);
                    Vec3::splat((f32::from(d) * 16.0 / 255.0).min(1.0))
                })
                .collect();
            let p = dir.join(format!("tcrr_error_{f}.png"));
            save_png(&p, w, h, &err).expect("png");
            save_png(&dir.join(format!("tcrr_frame_{f}.png")), w, h, &fin_m).expect("png");
            save_png(&dir.join(format!("tcrr_truth_{f}.png")), w, h, &fin_t).expect("png");
        }
    }
}
