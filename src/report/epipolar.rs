//! The epipolar walk's rows, notes and mismatch list (seed 002): the report
//! side of [`crate::epipolar::measure`].

use crate::epipolar::{PathMeasure, PathSizes};
use crate::report_out::Row;
use crate::scene::Scene;
use crate::tracer::TraceCount;
use std::fmt::Write as _;
use std::path::Path;

/// Mean over frames 1.. (frame 0 has no reprojection: the steady state).
fn steady(v: &[f64]) -> f64 {
    if v.len() > 1 {
        v[1..].iter().sum::<f64>() / (v.len() - 1) as f64
    } else {
        v.iter().sum::<f64>()
    }
}

/// The rows (`orsa`, `irsa`, one `epipolar` row per setting) and the notes
/// of walk `m` on `scene`; with `images`, every visibility error and tie is
/// written to `images/{scene}_epipolar_mismatches.csv`.
///
/// Time and shares are over frames 1.. (the steady state), mismatches over
/// every frame. A setting's error is its share of mismatched pixels
/// (`mean_abs_255` = 255 x that share, `psnr_db` infinite without
/// mismatches and 0 with: visibility is right or wrong, not graded).
///
/// # Errors
/// An I/O failure writing the mismatch list.
pub fn rows(
    scene: &Scene,
    sizes: &PathSizes,
    m: &PathMeasure,
    threads: usize,
    images: Option<&Path>,
) -> Result<(Vec<Row>, String), String> {
    let frames = m.frames;
    let n = sizes.width as usize * sizes.height as usize;
    let (o_ms, i_ms) = (steady(&m.orsa_ms), steady(&m.irsa_ms));
    // Seed 002's hardware-independent work per pixel over frames 1..
    // (Tables 1-3: `Ñ_IT` ray/object intersection tests, `Ñ_TS` traversal
    // steps; here CWBVH node visits, see `Tracer::trace_counted`).
    let steady_pixels = (n * frames.saturating_sub(1)) as u64;
    let work = |c: &TraceCount, pixels: u64| -> Vec<(String, String)> {
        vec![
            ("n_it".into(), format!("{:.3}", c.tests_per_ray(pixels))),
            ("n_ts".into(), format!("{:.3}", c.steps_per_ray(pixels))),
        ]
    };
    let base = |method: &str, setting: &str, ms: f64, extra: Vec<(String, String)>| Row {
        scene: scene.name.clone(),
        method: method.into(),
        setting: setting.into(),
        threads,
        time_ms: ms,
        reference_ms: o_ms,
        speedup: if ms > 0.0 { o_ms / ms } else { f64::INFINITY },
        coverage: 1.0,
        mean_abs_255: 0.0,
        psnr_db: f64::INFINITY,
        share_over_8: 0.0,
        extra,
    };
    let mut rows = vec![
        base(
            "orsa",
            "full_traversal",
            o_ms,
            vec![
                ("frames".into(), frames.to_string()),
                ("irsa_ms".into(), format!("{i_ms:.4}")),
            ]
            .into_iter()
            .chain(work(&m.orsa_count, steady_pixels))
            .collect(),
        ),
        base(
            "irsa",
            "known_object",
            i_ms,
            vec![
                ("frames".into(), frames.to_string()),
                ("visibility_errors".into(), m.irsa_errors.len().to_string()),
                ("ties".into(), m.irsa_ties.to_string()),
                ("irsa_ms".into(), format!("{i_ms:.4}")),
            ]
            .into_iter()
            .chain(work(&m.irsa_count, steady_pixels))
            .collect(),
        ),
    ];
    // Shadow rays (seed 002 Sec. 7.4, `crate::epipolar_shadow`): the same
    // visible points, full any-hit traversal against reprojected occluders.
    let sh = &m.shadows;
    let (so_ms, sm_ms) = (steady(&sh.orsa_ms), steady(&sh.method_ms));
    let per_frame = sh.rays as f64 / frames.saturating_sub(1).max(1) as f64;
    let shadow_share = |c: u64| c as f64 / sh.rays.max(1) as f64;
    let mut shadow_rows = vec![
        Row {
            reference_ms: so_ms,
            speedup: 1.0,
            ..base(
                "orsa",
                "shadow_rays=any_hit",
                so_ms,
                vec![
                    ("frames".into(), frames.to_string()),
                    ("shadow_rays".into(), format!("{per_frame:.0}")),
                    (
                        "shadowed".into(),
                        format!("{:.4}", shadow_share(sh.shadowed)),
                    ),
                ],
            )
        },
        Row {
            reference_ms: so_ms,
            speedup: if sm_ms > 0.0 {
                so_ms / sm_ms
            } else {
                f64::INFINITY
            },
            ..base(
                "epipolar",
                "shadow_rays=reprojected_occluder",
                sm_ms,
                vec![
                    ("frames".into(), frames.to_string()),
                    ("shadow_rays".into(), format!("{per_frame:.0}")),
                    (
                        "shadowed".into(),
                        format!("{:.4}", shadow_share(sh.shadowed)),
                    ),
                    ("c_R".into(), format!("{:.4}", shadow_share(sh.reprojected))),
                    ("visibility_errors".into(), sh.errors.to_string()),
                ],
            )
        },
    ];
    let shadow_err = sh.errors as f64 / (sh.rays.max(1)) as f64;
    shadow_rows[1].mean_abs_255 = 255.0 * shadow_err;
    shadow_rows[1].share_over_8 = shadow_err;
    shadow_rows[1].psnr_db = if sh.errors == 0 { f64::INFINITY } else { 0.0 };
    let mut notes = String::new();
    let _ = writeln!(
        notes,
        "- `{}` walkthrough (seed 002): {frames} frames at {}x{}, eye step {} per frame from path position {}; \
         per-object BVHs built in {:.1} ms; ORSA {o_ms:.2} ms/frame, IRSA {i_ms:.2} ms/frame (frames 1..); \
         IRSA visibility errors against ORSA: {}, ties (same point, another object): {}; camera gaze {:?}: {} of {} frame \
         pairs fail the view-frustum check (Sec. 4.1), with gaze {:?} {} would",
        scene.name,
        sizes.width,
        sizes.height,
        sizes.step,
        sizes.start,
        m.objects_build_ms,
        m.irsa_errors.len(),
        m.irsa_ties,
        sizes.gaze,
        m.frustum_fails,
        frames.saturating_sub(1),
        m.other_gaze.0,
        m.other_gaze.1,
    );
    let _ = writeln!(
        notes,
        "  - shadow rays (Sec. 7.4, our construction: reprojected occluders tested first, then full any-hit): \
         {per_frame:.0} rays/frame, {:.1}% shadowed, {:.1}% answered by one object test (c_R), {} answers differing \
         from full traversal; {sm_ms:.2} ms/frame against {so_ms:.2} ms/frame for any-hit traversal of every ray",
        100.0 * shadow_share(sh.shadowed),
        100.0 * shadow_share(sh.reprojected),
        sh.errors,
    );
    for e in m.irsa_errors.iter().take(20) {
        let _ = writeln!(
            notes,
            "  - IRSA frame {} pixel {:?}: ORSA {:?}, IRSA {:?}",
            e.frame, e.pixel, e.orsa, e.method
        );
    }
    if let Some(dir) = images {
        let file = dir.join(format!("{}_epipolar_mismatches.csv", scene.name));
        std::fs::write(&file, mismatch_csv(m)).map_err(|e| format!("{}: {e}", file.display()))?;
        let _ = writeln!(
            notes,
            "  - every visibility error and tie: `images/{}`",
            file.file_name()
                .map_or(String::new(), |f| f.to_string_lossy().into_owned())
        );
    }
    for (setting, t) in &m.totals {
        // Shares over the frames that had a reprojection (frame 0 and
        // frames failing the view-frustum check are all ORSA).
        let steady_px = (t.pixels - t.unavailable).max(1) as f64;
        let share = |c: usize| c as f64 / steady_px;
        let ms = steady(&t.times);
        let err_share = t.mismatches.len() as f64 / t.pixels.max(1) as f64;
        let mut row = base(
            "epipolar",
            setting,
            ms,
            vec![
                ("frames".into(), frames.to_string()),
                ("c_R".into(), format!("{:.4}", share(t.resolved))),
                ("c_E".into(), format!("{:.4}", share(t.failed))),
                ("c_O".into(), format!("{:.4}", share(t.resampled))),
                ("c_abrupt".into(), format!("{:.4}", share(t.abrupt))),
                (
                    "c_unavailable".into(),
                    format!(
                        "{:.4}",
                        t.unavailable.saturating_sub(n) as f64 / (t.pixels - n).max(1) as f64
                    ),
                ),
                ("visibility_errors".into(), t.mismatches.len().to_string()),
                ("ties".into(), t.ties.len().to_string()),
                ("irsa_ms".into(), format!("{i_ms:.4}")),
                (
                    "vs_irsa".into(),
                    format!("{:.4}", if ms > 0.0 { i_ms / ms } else { 0.0 }),
                ),
            ]
            .into_iter()
            .chain(work(&t.count, t.steady_pixels))
            .collect(),
        );
        row.mean_abs_255 = 255.0 * err_share;
        row.share_over_8 = err_share;
        row.psnr_db = if t.mismatches.is_empty() {
            f64::INFINITY
        } else {
            0.0
        };
        rows.push(row);
        let _ = writeln!(
            notes,
            "  - `epipolar` {setting}: c_R {:.1}%, c_E {:.1}%, c_O {:.1}% (of frames with reprojection; \
             {} of {} frames without), {:.2} ms/frame ({:.2}x ORSA, {:.2}x IRSA time), \
             {} visibility errors, {} ties; per pixel Ñ_IT {:.2} and Ñ_TS {:.2} (ORSA {:.2} and {:.2}, IRSA {:.2} and {:.2})",
            100.0 * share(t.resolved),
            100.0 * share(t.failed),
            100.0 * share(t.resampled),
            t.unavailable / n,
            frames,
            ms,
            if ms > 0.0 { o_ms / ms } else { 0.0 },
            if i_ms > 0.0 { ms / i_ms } else { 0.0 },
            t.mismatches.len(),
            t.ties.len(),
            t.count.tests_per_ray(t.steady_pixels),
            t.count.steps_per_ray(t.steady_pixels),
            m.orsa_count.tests_per_ray(steady_pixels),
            m.orsa_count.steps_per_ray(steady_pixels),
            m.irsa_count.tests_per_ray(steady_pixels),
            m.irsa_count.steps_per_ray(steady_pixels),
        );
        for e in t.mismatches.iter().take(20) {
            let _ = writeln!(
                notes,
                "    - frame {} pixel {:?}: ORSA {:?}, method {:?} ({:?})",
                e.frame, e.pixel, e.orsa, e.method, e.path
            );
        }
        if t.mismatches.len() > 20 {
            let _ = writeln!(notes, "    - ... {} more", t.mismatches.len() - 20);
        }
    }
    rows.append(&mut shadow_rows);
    Ok((rows, notes))
}

/// Every mismatch and tie of IRSA and of every setting, one CSV line each.
fn mismatch_csv(m: &PathMeasure) -> String {
    let mut csv =
        String::from("setting,kind,frame,x,y,path,orsa_prim,orsa_t,method_prim,method_t\n");
    let fmt_hit = |h: Option<(u32, f32)>| match h {
        Some((p, t)) => format!("{p},{t}"),
        None => ",".to_string(),
    };
    let irsa_list = m.irsa_errors.iter().map(|e| ("irsa", "error", e));
    let method_lists = m.totals.iter().flat_map(|(setting, t)| {
        t.mismatches
            .iter()
            .map(move |e| (setting.as_str(), "error", e))
            .chain(t.ties.iter().map(move |e| (setting.as_str(), "tie", e)))
    });
    for (setting, kind, e) in irsa_list.chain(method_lists) {
        let _ = writeln!(
            csv,
            "{setting},{kind},{},{},{},{:?},{},{}",
            e.frame,
            e.pixel.0,
            e.pixel.1,
            e.path,
            fmt_hit(e.orsa),
            fmt_hit(e.method)
        );
    }
    csv
}
