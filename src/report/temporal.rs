//! The temporal-filtering path's rows and notes (seed 004 Sec. 4.6.5):
//! the report side of [`crate::temporal::run_path`].

use super::studies::SceneRun;
use super::Level;
use crate::report_out::Row;
use crate::temporal::{run_path, Setting};
use refl_core::temporal::TemporalOptions;
use std::fmt::Write as _;

/// The settings the report runs at `level`: the pass alone (`off`),
/// recovery alone (`max_frames` 1), the filter at the default options
/// re-projecting through the reflection's
/// virtual point and, as the seed does, through the surface point; at the
/// default and long levels also depth-only rejection (the seed's demo)
/// and both re-projections without the history clamp;
/// long only, a shorter and a longer history and blending without
/// recovery.
pub fn report_settings(level: Level) -> Vec<Setting> {
    let base = TemporalOptions::default();
    let on = |filter: TemporalOptions, distances: bool| Setting {
        filter: Some(filter),
        distances,
        tss: false,
    };
    let mut v = vec![
        Setting {
            filter: None,
            distances: false,
            tss: false,
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
    if level == Level::Long {
        for max_frames in [4.0, 16.0] {
            v.push(on(TemporalOptions { max_frames, ..base }, true));
        }
    }
    // Temporal super-sampling (Sec. 4.7.4): a quarter of the rays per
    // frame, the history recovering the rest; the most recent trace kept.
    v.push(Setting {
        tss: true,
        ..on(
            TemporalOptions {
                max_frames: 1.0,
                ..base
            },
            true,
        )
    });
    if level != Level::Quick {
        v.push(on(
            TemporalOptions {
                normal_cos: -1.0,
                ..base
            },
            true,
        ));
        // Without the neighborhood clamp (the seed's blend as it is), both
        // re-projections: what the clamp removes.
        let unclamped = TemporalOptions {
            clamp_history: false,
            ..base
        };
        v.push(on(unclamped, true));
        v.push(on(unclamped, false));
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
/// frames ([`super::tcrr::study_cameras`]). Returns the rows and a
/// Markdown note.
///
/// # Errors
/// As [`run_path`].
pub fn report_rows(s: &SceneRun<'_>) -> Result<(Vec<Row>, String), String> {
    let (shader, label) = (s.shader, s.label);
    if shader.scene.camera_path.is_empty() {
        return Ok((Vec::new(), String::new()));
    }
    let (cameras, frames, span) = super::tcrr::study_cameras(s)?;
    let settings = report_settings(s.sizes.level);
    let out = run_path(
        &super::tcrr::path_run(s, &cameras),
        &settings,
        Some(s.images),
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
