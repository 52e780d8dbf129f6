//! Single-thread micro-benchmark of refl-core's depth-image kernels (Hi-Z
//! traversal and per-pixel stepping) on the room scene's reflection rays as
//! the mirror pass starts them (`screen::kernel_rays`), with a
//! bit-exactness check of their results.
//!
//! ```text
//! cargo run --release --example depth_kernels_bench -- [options]
//!   --tris N        room triangles (30000)
//!   --size WxH      image size (512x384)
//!   --time KERNEL   hiz | hiz-scalar | step | both | pass | build | none
//!                   (both): kernel(s) to time; hiz is the batch call (the
//!                   AVX2 stream where the CPU has it), hiz-scalar the
//!                   scalar walk; pass: the whole Hi-Z mirror pass
//!                   (`MirrorPass::try_run`); build: the Hi-Z pyramid against
//!                   a memcpy of its bytes, every convention (with the
//!                   pyramid's hash)
//!   --reps N        timed repetitions per kernel (20; 0 for a setup-only
//!                   run, to subtract from `perf stat` counts)
//!   --save FILE     write every checked trace to FILE
//!   --check FILE    compare every checked trace with FILE, bit for bit
//!   --compare FILE  compare every checked trace with FILE by result: count
//!                   the traces whose hit texel or miss reason differ (and
//!                   hit/miss flips), and for the others the bit
//!                   differences (max |t| and depth difference, relative)
//!                   and the work-counter changes; exit status 1 if any
//!                   texel or miss reason differs
//! ```
//!
//! Checked traces: both kernels in every depth convention (reversed-Z with
//! an infinite far plane), with constant thickness and with a synthetic
//! back-face image, under several option sets; the Hi-Z diagnostic
//! counters too. The printed hash covers all of them, so two builds that
//! print the same hash returned identical results.
//!
//! Timings are on the calling thread only: reversed-Z, infinite far plane,
//! constant thickness, default options. Wall-clock numbers are noisy on a
//! shared machine; `perf stat -e instructions` on `--reps N` minus
//! `--reps 0` (which traces once, untimed, for the report) gives
//! instructions per ray independently of load, or, without `perf`,
//! `valgrind --tool=callgrind --toggle-collect='refl_core::hiz::try_trace_hiz_rays*'`
//! on `--time hiz --reps 1` counts one batch of Hi-Z traces alone. Each
//! kernel's line `totals` gives the rays, iterations, fetches and steps of
//! one batch to divide by.

use refl_app::gbuffer::GBuffer;
use refl_app::scene::Scene;
use refl_app::screen::{self, DepthBuffer};
use refl_app::shade::Shader;
use refl_app::tracer::Tracer;
use refl_core::hiz::{self, HiZOptions};
use refl_core::{DepthConvention, ImageView, Ray, StepOptions, Thickness, Trace};
use std::time::Instant;

struct Args {
    tris: usize,
    width: u32,
    height: u32,
    time: String,
    reps: usize,
    save: Option<String>,
    check: Option<String>,
    compare: Option<String>,
}

fn parse_args() -> Args {
    let mut a = Args {
        tris: 30_000,
        width: 512,
        height: 384,
        time: "both".into(),
        reps: 20,
        save: None,
        check: None,
        compare: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(k) = it.next() {
        let mut v = || it.next().unwrap_or_else(|| panic!("{k} needs a value"));
        match k.as_str() {
            "--tris" => a.tris = v().parse().expect("--tris"),
            "--size" => {
                let s = v();
                let (w, h) = s.split_once('x').expect("--size WxH");
                a.width = w.parse().expect("width");
                a.height = h.parse().expect("height");
            }
            "--time" => a.time = v(),
            "--reps" => a.reps = v().parse().expect("--reps"),
            "--save" => a.save = Some(v()),
            "--check" => a.check = Some(v()),
            "--compare" => a.compare = Some(v()),
            _ => panic!("unknown argument {k}"),
        }
    }
    a
}

/// Appends the bits of one trace (and optional Hi-Z stats) to `out`.
fn encode(out: &mut Vec<u32>, t: &Trace) {
    let w = t.work();
    match t {
        Trace::Hit(h) => out.extend([
            0,
            h.pixel.x.to_bits(),
            h.pixel.y.to_bits(),
            h.t.to_bits(),
            h.depth.to_bits(),
            h.surface_depth.to_bits(),
        ]),
        Trace::Miss { reason, .. } => out.extend([1, *reason as u32, 0, 0, 0, 0]),
    }
    out.extend([w.steps, w.fetches, w.iterations]);
}

/// Words of one [`encode`]d trace (without the Hi-Z stats).
const RECORD: usize = 9;

/// Differences between two runs' traces ([`encode`]d records, stats words
/// included), by result rather than by bit.
#[derive(Default)]
struct Diff {
    traces: usize,
    identical: usize,
    /// Hit in one run, miss in the other.
    flip: usize,
    /// Both hits, different texel (`floor` of the pixel).
    texel: usize,
    /// Both misses, different reason.
    reason: usize,
    /// Same texel or reason, other bits differ (position, t, depth, work).
    bits: usize,
    /// Same texel, different `t` / `depth` bits: the largest relative
    /// differences.
    max_dt: f64,
    max_ddepth: f64,
    /// Same result, different work counters (steps, fetches, iterations)
    /// or Hi-Z stats; and the summed change of iterations.
    work: usize,
    iterations: i64,
}

impl Diff {
    fn add(&mut self, b: &[u32], w: &[u32]) {
        self.traces += 1;
        if b == w {
            self.identical += 1;
            return;
        }
        let f = |x: u32| f64::from(f32::from_bits(x));
        let rel = |x: u32, y: u32| (f(x) - f(y)).abs() / f(x).abs().max(f(y).abs()).max(1e-30);
        self.iterations += i64::from(w[8]) - i64::from(b[8]);
        if b[0] != w[0] {
            self.flip += 1;
        } else if b[0] == 0 {
            let texel = |v: &[u32]| (f(v[1]).floor(), f(v[2]).floor());
            if texel(b) != texel(w) {
                self.texel += 1;
            } else {
                self.bits += 1;
                if b[1..6] == w[1..6] {
                    self.work += 1;
                }
                self.max_dt = self.max_dt.max(rel(b[3], w[3]));
                self.max_ddepth = self.max_ddepth.max(rel(b[4], w[4]));
            }
        } else if b[1] != w[1] {
            self.reason += 1;
        } else {
            self.bits += 1;
            self.work += 1;
        }
    }

    fn merge(&mut self, o: &Self) {
        self.traces += o.traces;
        self.identical += o.identical;
        self.flip += o.flip;
        self.texel += o.texel;
        self.reason += o.reason;
        self.bits += o.bits;
        self.max_dt = self.max_dt.max(o.max_dt);
        self.max_ddepth = self.max_ddepth.max(o.max_ddepth);
        self.work += o.work;
        self.iterations += o.iterations;
    }

    fn line(&self) -> String {
        format!(
            "{} traces, {} identical; texel differs {}, miss reason differs {}, \
             hit/miss flips {}; same result with other bits {} (work counters only {}), \
             max relative |dt| {:.3e}, |d depth| {:.3e}; iterations {:+}",
            self.traces,
            self.identical,
            self.texel,
            self.reason,
            self.flip,
            self.bits,
            self.work,
            self.max_dt,
            self.max_ddepth,
            self.iterations
        )
    }
}

/// FNV-1a over the words.
fn fnv(words: &[u32]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for w in words {
        for b in w.to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

fn miss() -> Trace {
    Trace::Miss {
        reason: refl_core::Miss::EndOfRay,
        work: refl_core::Work::default(),
    }
}

fn main() {
    let a = parse_args();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let scene = Scene::room(a.tris);
    let tracer = Tracer::new(&scene);
    let shader = Shader::new(&scene, &tracer);
    let cam = scene.camera(0, a.width, a.height).expect("camera");
    let g = GBuffer::render(&scene, &tracer, &cam, &pool);
    let rays = screen::reflection_rays(&scene, &tracer, &shader, &g, &pool);
    // The kernels' rays as the mirror pass starts them.
    let rays = screen::kernel_rays(&g, &rays);
    let rays: &[Ray] = &rays;
    let n = rays.len();
    let thick = scene.diameter() * screen::THICKNESS_OF_DIAMETER;
    println!(
        "room({}) {}x{}: {} reflection rays, thickness {}",
        a.tris, a.width, a.height, n, thick
    );

    let mut out = vec![miss(); n];
    if a.save.is_some() || a.check.is_some() || a.compare.is_some() {
        let mut words: Vec<u32> = Vec::new();
        let mut labels: Vec<(String, usize)> = Vec::new();
        // Per label: the record length of each of its traces, in order
        // (`encode`'s 9 words, 11 with the Hi-Z stats).
        let mut records: Vec<Vec<usize>> = Vec::new();
        for c in DepthConvention::ALL {
            let far = if c == DepthConvention::ReversedZ {
                f32::INFINITY
            } else {
                cam.far()
            };
            let depth = DepthBuffer::new(&g, c, far).expect("depth");
            let image = depth.image().expect("image");
            // Synthetic back faces: each surface is between 0 and 3
            // thicknesses deep (varying per pixel), some pixels empty.
            let back: Vec<f32> = g
                .depth
                .iter()
                .enumerate()
                .map(|(i, &z)| {
                    let k = (i.wrapping_mul(2_654_435_761) >> 7) % 7;
                    if k == 6 {
                        f32::NAN
                    } else {
                        depth
                            .camera
                            .encode_depth(z + thick * 0.5 * k as f32, depth.convention)
                    }
                })
                .collect();
            let back = ImageView::try_new(&back, a.width, a.height, a.width).expect("back");
            let mut pyr = vec![[0.0f32; 2]; hiz::try_hiz_len(a.width, a.height).expect("len")];
            hiz::try_build_hiz(&mut pyr, &image).expect("build");
            let hz = hiz::HiZ::try_new(&pyr, depth.camera, c).expect("hiz");
            let thicknesses = [
                ("const", Thickness::Constant(thick)),
                ("zero", Thickness::Constant(0.0)),
                ("back", Thickness::BackFaces(back)),
            ];
            let hiz_opts = [
                HiZOptions::default(),
                HiZOptions {
                    stop_level: 2,
                    start_level: 4,
                    ..HiZOptions::default()
                },
                HiZOptions {
                    start_level: 0,
                    prologue_steps: 0,
                    max_iterations: 40,
                    ..HiZOptions::default()
                },
            ];
            let step_opts = [
                StepOptions::default(),
                StepOptions {
                    stride: 4,
                    max_steps: 300,
                },
            ];
            for (tn, th) in thicknesses {
                for (k, o) in hiz_opts.iter().enumerate() {
                    let start = words.len();
                    for r in rays {
                        let (t, s) =
                            hiz::try_trace_hiz_stats(&hz, th, *r, f32::INFINITY, o).expect("hiz");
                        encode(&mut words, &t);
                        words.extend([s.boundary_ties, s.max_level]);
                    }
                    // The batch entry point agrees with the single-ray one.
                    hiz::try_trace_hiz_rays(&mut out, &hz, th, rays, &[f32::INFINITY], o)
                        .expect("hiz rays");
                    for t in &out {
                        encode(&mut words, t);
                    }
                    labels.push((format!("{c:?} hiz {tn} opts{k}"), start));
                    records.push([vec![RECORD + 2; n], vec![RECORD; n]].concat());
                }
                for (k, o) in step_opts.iter().enumerate() {
                    let start = words.len();
                    refl_core::try_step_rays(&mut out, &image, th, rays, &[f32::INFINITY], *o)
                        .expect("step");
                    for t in &out {
                        encode(&mut words, t);
                    }
                    labels.push((format!("{c:?} step {tn} opts{k}"), start));
                    records.push(vec![RECORD; n]);
                }
            }
        }
        println!(
            "checked traces: {} words, hash {:016x}",
            words.len(),
            fnv(&words)
        );
        if let Some(p) = &a.save {
            let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
            std::fs::write(p, bytes).expect("save");
            println!("saved to {p}");
        }
        let read_base = |p: &str| -> Vec<u32> {
            let bytes = std::fs::read(p).expect("read baseline");
            bytes
                .chunks_exact(4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect()
        };
        if let Some(p) = &a.compare {
            let base = read_base(p);
            if base.len() != words.len() {
                println!(
                    "compare: {p} holds {} words, this run {}: not the same traces",
                    base.len(),
                    words.len()
                );
                std::process::exit(1);
            }
            let mut total = Diff::default();
            for ((label, start), recs) in labels.iter().zip(&records) {
                let mut d = Diff::default();
                let mut at = *start;
                for &len in recs {
                    d.add(&base[at..at + len], &words[at..at + len]);
                    at += len;
                }
                if d.traces != d.identical {
                    println!("compare {label}: {}", d.line());
                }
                total.merge(&d);
            }
            println!("compare total: {}", total.line());
            if total.texel + total.reason + total.flip > 0 {
                std::process::exit(1);
            }
        }
        if let Some(p) = &a.check {
            let base = read_base(p);
            if base == words {
                println!("check: identical to {p}");
            } else {
                let first = base
                    .iter()
                    .zip(&words)
                    .position(|(x, y)| x != y)
                    .unwrap_or(base.len().min(words.len()));
                let label = labels
                    .iter()
                    .rev()
                    .find(|(_, s)| *s <= first)
                    .map_or("?", |(l, _)| l.as_str());
                println!(
                    "check: DIFFERS from {p} ({} vs {} words), first at word {first} in {label}",
                    base.len(),
                    words.len()
                );
                std::process::exit(1);
            }
        }
    }

    // Timing: reversed-Z, infinite far, constant thickness, defaults.
    let depth = DepthBuffer::new(&g, DepthConvention::ReversedZ, f32::INFINITY).expect("depth");
    let image = depth.image().expect("image");
    let mut pyr = vec![[0.0f32; 2]; hiz::try_hiz_len(a.width, a.height).expect("len")];
    hiz::try_build_hiz(&mut pyr, &image).expect("build");
    let hz = hiz::HiZ::try_new(&pyr, depth.camera, depth.convention).expect("hiz");
    let th = Thickness::Constant(thick);
    let report = |name: &str, out: &[Trace], ns: &mut [f64]| {
        let (mut fetches, mut iters, mut steps, mut hits) = (0u64, 0u64, 0u64, 0usize);
        for t in out {
            fetches += u64::from(t.work().fetches);
            steps += u64::from(t.work().steps);
            iters += u64::from(t.work().iterations);
            hits += usize::from(t.hit().is_some());
        }
        let words: Vec<u32> = out
            .iter()
            .flat_map(|t| {
                let mut w = Vec::new();
                encode(&mut w, t);
                w
            })
            .collect();
        ns.sort_by(f64::total_cmp);
        let (min, med) = ns
            .first()
            .map_or((f64::NAN, f64::NAN), |&m| (m, ns[ns.len() / 2]));
        println!(
            "{name:5}: {min:8.1} ns/ray min, {med:8.1} median over {} reps; {:.2} fetches/ray, \
             {:.2} iterations/ray, {hits} hits, hash {:016x}",
            ns.len(),
            fetches as f64 / n as f64,
            iters as f64 / n as f64,
            fnv(&words)
        );
        // Totals per traced batch, to divide instruction counts by.
        println!("{name:5}: totals {n} rays, {iters} iterations, {fetches} fetches, {steps} steps");
    };
    let time_it = |f: &mut dyn FnMut()| -> Vec<f64> {
        (0..a.reps)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64() * 1e9 / n as f64
            })
            .collect()
    };
    if a.time == "hiz" || a.time == "both" {
        let opts = HiZOptions::default();
        let mut ns = time_it(&mut || {
            hiz::try_trace_hiz_rays(&mut out, &hz, th, rays, &[f32::INFINITY], &opts).expect("hiz");
        });
        if a.reps == 0 {
            hiz::try_trace_hiz_rays(&mut out, &hz, th, rays, &[f32::INFINITY], &opts).expect("hiz");
        }
        report("hiz", &out, &mut ns);
    }
    if a.time == "hiz-scalar" {
        // The scalar walk alone (`try_trace_hiz_rays_scalar`), the AVX2
        // stream's reference.
        let opts = HiZOptions::default();
        let mut ns = time_it(&mut || {
            hiz::try_trace_hiz_rays_scalar(&mut out, &hz, th, rays, &[f32::INFINITY], &opts)
                .expect("hiz");
        });
        if a.reps == 0 {
            hiz::try_trace_hiz_rays_scalar(&mut out, &hz, th, rays, &[f32::INFINITY], &opts)
                .expect("hiz");
        }
        report("hizs", &out, &mut ns);
    }
    if a.time == "pass" {
        // The whole Hi-Z mirror pass (`MirrorPass::try_run`, default
        // options, no back faces) over the frame, per pixel with a ray.
        let images = screen::PassImages::new(&g, None);
        let pass = refl_core::MirrorPass::try_new(
            images.gbuffer(image).expect("gbuffer"),
            refl_core::MirrorOptions {
                method: refl_core::MirrorMethod::HiZ,
                ..refl_core::MirrorOptions::default()
            },
            Some(hz),
        )
        .expect("pass");
        let (w, h) = (a.width, a.height);
        let mut texels = vec![refl_core::MirrorTexel::default(); (w * h) as usize];
        let mut stats = refl_core::MirrorStats::default();
        let mut run = || {
            let mut o = refl_core::ImageViewMut::try_new(&mut texels, w, h, w).expect("out");
            stats = pass.try_run(&mut o, None, &mut []).expect("run");
        };
        let mut ns: Vec<f64> = (0..a.reps.max(1))
            .map(|_| {
                let t = Instant::now();
                run();
                t.elapsed().as_secs_f64() * 1e9
            })
            .collect();
        ns.sort_by(f64::total_cmp);
        let traced = f64::from(stats.traced.max(1));
        println!(
            "pass : {:8.1} ns/traced pixel min, {:8.1} median over {} reps; {} traced, {} hits, \
             stream lanes {}",
            ns[0] / traced,
            ns[ns.len() / 2] / traced,
            ns.len(),
            stats.traced,
            stats.hits,
            hiz::hiz_stream_lanes()
        );
    }
    if a.time == "step" || a.time == "both" {
        let opts = StepOptions::default();
        let mut ns = time_it(&mut || {
            refl_core::try_step_rays(&mut out, &image, th, rays, &[f32::INFINITY], opts)
                .expect("step");
        });
        if a.reps == 0 {
            refl_core::try_step_rays(&mut out, &image, th, rays, &[f32::INFINITY], opts)
                .expect("step");
        }
        report("step", &out, &mut ns);
    }
    if a.time == "build" {
        // The whole pyramid (`hiz::try_build_hiz`) against a copy of the
        // same bytes, alternating, in every convention (issue 14 part 4:
        // at least half a memcpy's speed).
        let mut copy = vec![[0.0f32; 2]; pyr.len()];
        let mb = (pyr.len() * 8) as f64 / 1e6;
        println!(
            "build: pyramid of {}x{}, {} texels ({mb:.2} MB); ms per build and per copy (median of {} reps)",
            a.width,
            a.height,
            pyr.len(),
            a.reps
        );
        for c in DepthConvention::ALL {
            let far = if c == DepthConvention::ReversedZ {
                f32::INFINITY
            } else {
                cam.far()
            };
            let depth = DepthBuffer::new(&g, c, far).expect("depth");
            let image = depth.image().expect("image");
            let (mut tb, mut tc) = (Vec::new(), Vec::new());
            for _ in 0..a.reps.max(1) {
                let t = Instant::now();
                hiz::try_build_hiz(&mut pyr, &image).expect("build");
                tb.push(t.elapsed().as_secs_f64() * 1e3);
                let t = Instant::now();
                copy.copy_from_slice(std::hint::black_box(&pyr));
                std::hint::black_box(&mut copy);
                tc.push(t.elapsed().as_secs_f64() * 1e3);
            }
            tb.sort_by(f64::total_cmp);
            tc.sort_by(f64::total_cmp);
            let (b, m) = (tb[tb.len() / 2], tc[tc.len() / 2]);
            let words: Vec<u32> = pyr
                .iter()
                .flat_map(|t| [t[0].to_bits(), t[1].to_bits()])
                .collect();
            println!(
                "build {c:?}: {b:.3} ms build, {m:.3} ms copy; build speed / copy speed {:.3}; pyramid hash {:016x}",
                m / b,
                fnv(&words)
            );
        }
    }
}
