//! The TCRR path's rows and notes (seed 000): the report side of
//! [`crate::tcrr::run_path`].

use super::studies::SceneRun;
use super::Level;
use crate::report_out::Row;
use crate::tcrr::{path_cameras, run_path, PathRun, Scheme, Setting, BYTES_PER_PIXEL};
use refl_core::tcrr::TcrrOptions;
use refl_core::Camera;
use std::fmt::Write as _;

/// The settings the report runs at `level`: the key-frame threshold swept
/// at the seed's parameters, then the iteration cap, the re-trace contrast
/// and the magnification threshold each varied at threshold 0.3; naive
/// warping at every threshold. Quick: the seed's setting only; default:
/// thresholds 0.1, 0.3, 0.5 and the re-trace contrast; long: thresholds
/// 0.1..0.5 and every variation.
pub fn report_settings(level: Level, tcrr: bool, naive: bool) -> Vec<Setting> {
    let base = TcrrOptions::default();
    let (quick, long) = (level == Level::Quick, level == Level::Long);
    let thresholds: &[f32] = match level {
        Level::Quick => &[0.3],
        Level::Default => &[0.1, 0.3, 0.5],
        Level::Long => &[0.1, 0.2, 0.3, 0.4, 0.5],
    };
    let mut v = Vec::new();
    if tcrr {
        for &t in thresholds {
            v.push(Setting {
                scheme: Scheme::Tcrr,
                threshold: t,
                params: base,
            });
        }
        let caps: &[u32] = if long { &[2, 4, 16] } else { &[] };
        for &c in caps {
            v.push(Setting {
                scheme: Scheme::Tcrr,
                threshold: 0.3,
                params: TcrrOptions {
                    max_iterations: c,
                    ..base
                },
            });
        }
        // The re-trace contrast test off (the seed's warping) and stricter.
        let contrasts: &[f32] = if quick { &[] } else { &[f32::INFINITY, 0.05] };
        for &c in contrasts {
            v.push(Setting {
                scheme: Scheme::Tcrr,
                threshold: 0.3,
                params: TcrrOptions {
                    retrace_contrast: c,
                    ..base
                },
            });
        }
        let mags: &[f32] = if long { &[2.0, 4.0, 64.0] } else { &[] };
        for &m in mags {
            v.push(Setting {
                scheme: Scheme::Tcrr,
                threshold: 0.3,
                params: TcrrOptions {
                    magnification: m,
                    ..base
                },
            });
        }
    }
    if naive {
        for &t in thresholds {
            v.push(Setting {
                scheme: Scheme::NaiveWarp,
                threshold: t,
                params: base,
            });
        }
    }
    v
}

/// The frames of the path studies at `level` and the path parameters they
/// span: quick 5 frames over the first 2% of the path, default 16, long 60
/// frames over the first quarter, the same camera step: about 2.5 cm of
/// camera travel per frame on the room path (a walking camera at 60 frames
/// per second); seed 000 Sec. 4.4 uses 500-frame paths.
pub fn path_frames(level: Level) -> (usize, (f32, f32)) {
    match level {
        Level::Quick => (5, (0.0, 0.02)),
        Level::Default => (16, (0.0, 0.25 * 16.0 / 60.0)),
        Level::Long => (60, (0.0, 0.25)),
    }
}

/// A path study's cameras, their count and the path parameters they span.
pub type StudyCameras = (Vec<Camera>, usize, (f32, f32));

/// The cameras of a path study on `s`'s scene: [`path_frames`] at the
/// run's level and image size; also the frame count and the span.
///
/// # Errors
/// A pose the scene's path cannot give, as a message.
pub fn study_cameras(s: &SceneRun<'_>) -> Result<StudyCameras, String> {
    let (frames, span) = path_frames(s.sizes.level);
    let cameras = path_cameras(s.scene, frames, span, s.sizes.width, s.sizes.height)
        .map_err(|e| format!("{}: camera: {e}", s.label))?;
    Ok((cameras, frames, span))
}

/// The [`PathRun`] of `s` over `cameras`.
pub fn path_run<'a>(s: &'a SceneRun<'a>, cameras: &'a [Camera]) -> PathRun<'a> {
    PathRun {
        shader: s.shader,
        label: s.label,
        cameras,
        threads: s.threads,
        pool: s.pool,
    }
}

/// Runs the report's TCRR rows for one scene: a dense frame sequence along
/// its camera path ([`path_frames`]) at the report's image size. Returns
/// the rows and a Markdown note.
///
/// # Errors
/// As [`run_path`].
pub fn report_rows(
    s: &SceneRun<'_>,
    tcrr: bool,
    naive: bool,
) -> Result<(Vec<Row>, String), String> {
    let (shader, label) = (s.shader, s.label);
    let settings = report_settings(s.sizes.level, tcrr, naive);
    if settings.is_empty() || shader.scene.camera_path.is_empty() {
        return Ok((Vec::new(), String::new()));
    }
    let (cameras, frames, span) = study_cameras(s)?;
    let out = run_path(&path_run(s, &cameras), &settings, Some((s.images, 1)))?;
    let mut note = String::new();
    let _ = writeln!(
        note,
        "  - TCRR path: {frames} frames over path parameters {span:?}; {BYTES_PER_PIXEL} caller-buffer bytes per pixel; \
         images of frame 1, the first after the initial key frame (`{label}_tcrr_retraced.png` marks re-traced \
         pixels red, seed 000 Fig. 7)"
    );
    for (name, pf) in out.per_frame.iter().take(1) {
        let keys: Vec<usize> = pf
            .iter()
            .enumerate()
            .filter(|(_, p)| p.0)
            .map(|(k, _)| k)
            .collect();
        let shares: Vec<String> = pf.iter().map(|p| format!("{:.2}", p.1)).collect();
        let _ = writeln!(
            note,
            "  - `{name}`: key frames {keys:?}; re-traced share per frame [{}]",
            shares.join(", ")
        );
    }
    Ok((out.rows, note))
}
