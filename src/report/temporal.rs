//! The temporal-filtering path's rows and notes (seed 004 Sec. 4.6.5):
//! the report side of [`crate::temporal::run_path`].

use super::Level;
use crate::report_out::Row;
use crate::shade::Shader;
use crate::tcrr::path_cameras;
use crate::temporal::{run_path, Setting};
use refl_core::temporal::TemporalOptions;
use std::fmt::Write as _;
use std::path::Path;

/// The settings the report runs at `level`: the pass alone (`off`),
/// recovery alone (`max_frames` 1), the filter at the default options
/// re-projecting through the reflection's
/// virtual point and, as the seed does, through the surface point; at the
/// default and long levels also a shorter and a longer history and
/// depth-only rejection (the seed's demo); long only, blending without
/// recovery.
pub fn report_settings(level: Level) -> Vec<Setting> {
    let base = TemporalOptions::default();
    let on = |filter: TemporalOptions, distances: bool| Setting {
        filter: Some(filter),
        distances,
    };
    let mut v = vec![
        Setting {
            filter: None,
            distances: false,
        },
        // Recovery only: a mirror pass's answers are exact and the same
        // every frame, so blending them only blurs (bilinear history).
        on(
            TemporalOptions {
                max_frames: 1.0,
                ..base
            },
            true,
        ),
        on(base, true),
        on(base, false),
    ];
    if level != Level::Quick {
        for max_frames in [4.0, 16.0] {
            v.push(on(TemporalOptions { max_frames, ..base }, true));
        }
        v.push(on(
            TemporalOptions {
                normal_cos: -1.0,
                ..base
            },
            true,
        ));
    }
    if level == Level::Long {
        v.push(on(
            TemporalOptions {
                recover: false,
                ..base
            },
            true,
        ));
    }
    v
}

/// Runs the report's temporal rows for one scene over the TCRR study's
/// frames (quick: 5 frames over the first 2% of the path; default: 16,
/// long: 60 frames over the first quarter, about 2.5 cm of travel a frame
/// on the room path). Returns the rows and a Markdown note.
///
/// # Errors
/// As [`run_path`].
#[allow(clippy::too_many_arguments)]
pub fn report_rows(
    shader: &Shader,
    label: &str,
    level: Level,
    width: u32,
    height: u32,
    threads: usize,
    pool: &rayon::ThreadPool,
    images: &Path,
) -> Result<(Vec<Row>, String), String> {
    if shader.scene.camera_path.is_empty() {
        return Ok((Vec::new(), String::new()));
    }
    let (frames, span) = match level {
        Level::Quick => (5, (0.0, 0.02)),
        Level::Default => (16, (0.0, 0.25 * 16.0 / 60.0)),
        Level::Long => (60, (0.0, 0.25)),
    };
    let cameras = path_cameras(shader.scene, frames, span, width, height)
        .map_err(|e| format!("{label}: camera: {e}"))?;
    let settings = report_settings(level);
    let out = run_path(
        shader,
        label,
        &cameras,
        &settings,
        threads,
        pool,
        Some(images),
    )?;
    let mut note = String::new();
    let _ = writeln!(
        note,
        "  - Temporal path (`hiz-temporal`, seed 004 Sec. 4.6.5): the Hi-Z mirror pass over {frames} frames along \
         path parameters {span:?}, failed pixels showing the environment (`temporal=off`) or filtered with a history \
         re-projected from the last frame; the reference's own frame-to-frame change is {:.3}/255; \
         `{label}_temporal.png` and `{label}_temporal_off.png` show the last frame",
        out.reference_flicker
    );
    for (name, pf) in &out.per_frame {
        let v: Vec<String> = pf.iter().map(|e| format!("{e:.2}")).collect();
        let _ = writeln!(note, "  - `{name}`: error per frame [{}]", v.join(", "));
    }
    Ok((out.rows, note))
}
