//! Profiles the reprojection phase of reprojected ray casting (seed 002)
//! alone on the walkthrough path, single threaded, against ORSA (full
//! traversal of every pixel with obvhs) on the same frames. Per frame pair
//! it runs `refl_core::epipolar::try_reproject` with the default
//! parameters and with the guard window off, and prints the thread CPU time
//! of each next to ORSA's, so the cost of the serial phase can be read as a
//! share of a frame without the noise of other processes' threads.
//!
//! ```text
//! cargo run --release --example epipolar_bench -- [--frames 12] [--reps 5]
//! ```
//!
//! Times are the thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`), median of
//! `--reps` repetitions.

use refl_app::epipolar::{background_radius, path_cameras, PathSizes};
use refl_app::scene::Scene;
use refl_app::tracer::Tracer;
use refl_core::epipolar::{try_reproject, try_scratch_len, AipEntry, EpipolarOptions, PosEntry};

fn cpu_ms() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes the timespec it is given.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    assert_eq!(rc, 0, "clock_gettime");
    t.tv_sec as f64 * 1e3 + t.tv_nsec as f64 * 1e-6
}

fn median_ms(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut v: Vec<f64> = (0..reps.max(1))
        .map(|_| {
            let t0 = cpu_ms();
            f();
            cpu_ms() - t0
        })
        .collect();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let mut frames = 12usize;
    let mut reps = 5usize;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut val = |name: &str| {
            args.next()
                .and_then(|v| v.parse::<usize>().ok())
                .unwrap_or_else(|| panic!("{name} needs a number"))
        };
        match a.as_str() {
            "--frames" => frames = val("--frames"),
            "--reps" => reps = val("--reps"),
            other => panic!("unknown argument {other}"),
        }
    }
    let scene = Scene::walkthrough(150_000);
    let tracer = Tracer::new(&scene);
    let sizes = PathSizes {
        frames,
        ..PathSizes::new(false)
    };
    let cams = path_cameras(&scene, &sizes).expect("path cameras");
    let (w, h) = (sizes.width, sizes.height);
    let n = (w * h) as usize;
    let radius = background_radius(&scene);
    let mut scratch = vec![0.0f32; try_scratch_len(w, h).expect("try_scratch_len")];
    let mut aip = vec![AipEntry::EMPTY; n];
    let guard_off = EpipolarOptions {
        guard_window: 0,
        ..EpipolarOptions::default()
    };
    println!("frame | ORSA ms | reproject ms | reproject (guard_window=0) ms | reproject / ORSA");
    let (mut sum_orsa, mut sum_rep, mut sum_off) = (0.0, 0.0, 0.0);
    let mut previous: Option<Vec<PosEntry>> = None;
    for (f, cam) in cams.iter().enumerate() {
        // ORSA on one thread: the POS buffer of this frame.
        let mut pos = vec![PosEntry::INVALID; n];
        let orsa = median_ms(reps.min(2), || {
            for (i, p) in pos.iter_mut().enumerate() {
                let px = refl_app::gbuffer::pixel_center(
                    (i % w as usize) as u32,
                    (i / w as usize) as u32,
                );
                let r = cam.primary_ray(px);
                *p = match tracer.trace(r.origin, r.dir, 0.0, f32::INFINITY) {
                    Some(hit) => {
                        PosEntry::hit(r.origin, r.dir, hit.t, scene.tri_object[hit.prim as usize])
                    }
                    None => PosEntry::background(r.origin, r.dir, radius),
                };
            }
        });
        if let Some(prev_pos) = &previous {
            let prev = &cams[f - 1];
            let rep = median_ms(reps, || {
                try_reproject(
                    &mut aip,
                    &mut scratch,
                    prev_pos,
                    prev,
                    cam,
                    &EpipolarOptions::default(),
                )
                .expect("reproject");
            });
            let off = median_ms(reps, || {
                try_reproject(&mut aip, &mut scratch, prev_pos, prev, cam, &guard_off)
                    .expect("reproject");
            });
            println!("{f} | {orsa:.2} | {rep:.2} | {off:.2} | {:.3}", rep / orsa);
            sum_orsa += orsa;
            sum_rep += rep;
            sum_off += off;
        }
        previous = Some(pos);
    }
    let k = frames.saturating_sub(1).max(1) as f64;
    println!(
        "mean over {} frame pairs ({w}x{h}, 1 thread): ORSA {:.2} ms, reproject {:.2} ms ({:.3} of ORSA), guard window {:.2} ms",
        frames.saturating_sub(1),
        sum_orsa / k,
        sum_rep / k,
        sum_rep / sum_orsa,
        (sum_rep - sum_off) / k
    );
}
