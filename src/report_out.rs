//! Report output: the summary table (CSV + Markdown), the error-vs-time plot
//! and PNG images. Pure output; the measurements come from [`crate::report`].

use plotters::prelude::*;
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::io;
use std::path::Path;

/// The columns every summary row has, in order. Method-specific columns
/// (hit rates, re-traced share, ...) follow them, sorted by name.
pub const BASE_COLUMNS: [&str; 11] = [
    "scene",
    "method",
    "setting",
    "threads",
    "time_ms",
    "reference_ms",
    "speedup",
    "coverage",
    "mean_abs_255",
    "psnr_db",
    "share_over_8",
];

/// One measured point: a method at one setting on one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Scene name (`room`, `concave`, `walkthrough`, or an OBJ file stem).
    pub scene: String,
    /// Method name (`reference`, `envmap`, `planar-mirror`, ...).
    pub method: String,
    /// The setting, as `key=value` pairs joined by `;`.
    pub setting: String,
    /// Worker threads used for the timed pass (and for the reference run).
    pub threads: usize,
    /// Median wall time of the method's reflection pass, ms.
    pub time_ms: f64,
    /// Median wall time of the ray-traced reference on the same pixels in
    /// the same run, same threads, ms.
    pub reference_ms: f64,
    /// `reference_ms / time_ms`.
    pub speedup: f64,
    /// Share of the scene's reflective pixels the method handles (its error
    /// is measured on those pixels only).
    pub coverage: f64,
    /// Mean absolute difference on the 0..255 scale over the handled pixels.
    pub mean_abs_255: f64,
    /// PSNR in dB over the handled pixels (infinite when identical).
    pub psnr_db: f64,
    /// Share of handled pixels whose largest channel error exceeds 8/255.
    pub share_over_8: f64,
    /// Method-specific columns as `(name, value)`.
    pub extra: Vec<(String, String)>,
}

impl Row {
    fn base_values(&self) -> [String; 11] {
        [
            self.scene.clone(),
            self.method.clone(),
            self.setting.clone(),
            self.threads.to_string(),
            format!("{:.4}", self.time_ms),
            format!("{:.4}", self.reference_ms),
            format!("{:.4}", self.speedup),
            format!("{:.6}", self.coverage),
            format!("{:.4}", self.mean_abs_255),
            if self.psnr_db.is_finite() {
                format!("{:.3}", self.psnr_db)
            } else {
                "inf".into()
            },
            format!("{:.6}", self.share_over_8),
        ]
    }
}

fn extra_columns(rows: &[Row]) -> Vec<String> {
    rows.iter()
        .flat_map(|r| r.extra.iter().map(|(k, _)| k.clone()))
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect()
}

fn all_values(row: &Row, extra: &[String]) -> Vec<String> {
    let mut v = row.base_values().to_vec();
    v.extend(extra.iter().map(|k| {
        row.extra
            .iter()
            .find(|(n, _)| n == k)
            .map(|(_, x)| x.clone())
            .unwrap_or_default()
    }));
    v
}

/// Writes `summary.csv`: the base columns then the method-specific ones.
pub fn write_csv(path: &Path, rows: &[Row]) -> io::Result<()> {
    let extra = extra_columns(rows);
    let mut w = csv::Writer::from_path(path)?;
    w.write_record(
        BASE_COLUMNS
            .iter()
            .map(|s| s.to_string())
            .chain(extra.iter().cloned()),
    )?;
    for r in rows {
        w.write_record(all_values(r, &extra))?;
    }
    w.flush()
}

/// The summary as a Markdown table.
pub fn markdown_table(rows: &[Row]) -> String {
    let extra = extra_columns(rows);
    let header: Vec<String> = BASE_COLUMNS
        .iter()
        .map(|s| s.to_string())
        .chain(extra.iter().cloned())
        .collect();
    let mut s = String::new();
    let _ = writeln!(s, "| {} |", header.join(" | "));
    let _ = writeln!(s, "|{}", "---|".repeat(header.len()));
    for r in rows {
        let _ = writeln!(s, "| {} |", all_values(r, &extra).join(" | "));
    }
    s
}

/// Writes an 8-bit RGB PNG.
pub fn save_png(path: &Path, width: u32, height: u32, rgb8: &[[u8; 3]]) -> io::Result<()> {
    let flat: Vec<u8> = rgb8.iter().flatten().copied().collect();
    image::save_buffer(path, &flat, width, height, image::ExtendedColorType::Rgb8)
        .map_err(io::Error::other)
}

/// Where the log-scale error axis of the plot ends: errors below it (an
/// exact method reads 0) are drawn at this value.
pub const ERROR_FLOOR: f64 = 1e-3;

/// Distinct, print-safe curve colors (Okabe-Ito).
const COLORS: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(230, 159, 0),
    RGBColor(0, 0, 0),
];

fn ensure_font() {
    use std::sync::Once;
    static FONT: Once = Once::new();
    FONT.call_once(|| {
        // The registry keeps the first registration; failure only means
        // unlabeled text, which plotters reports when drawing.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

/// Plots error (mean absolute difference, 0..255, log scale) against time
/// (ms, log scale) with one panel per scene and one curve per method, points
/// in the order of increasing time. Errors below [`ERROR_FLOOR`] (exact
/// methods) are drawn on the floor. Rows with zero time are skipped.
pub fn plot_error_vs_time(path: &Path, rows: &[Row]) -> io::Result<()> {
    ensure_font();
    let scenes: Vec<&str> = rows
        .iter()
        .map(|r| r.scene.as_str())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let methods: Vec<&str> = rows
        .iter()
        .map(|r| r.method.as_str())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let (w, h) = (900u32, 420 * scenes.len().max(1) as u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(io::Error::other)?;
        let panels = root.split_evenly((scenes.len().max(1), 1));
        for (scene, area) in scenes.iter().zip(panels.iter()) {
            let pts: Vec<&Row> = rows
                .iter()
                .filter(|r| r.scene == *scene && r.time_ms > 0.0)
                .collect();
            let (tmin, tmax) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), r| {
                (a.min(r.time_ms), b.max(r.time_ms))
            });
            let emax = pts
                .iter()
                .map(|r| r.mean_abs_255)
                .fold(ERROR_FLOOR, f64::max);
            if pts.is_empty() {
                continue;
            }
            let mut chart = ChartBuilder::on(area)
                .caption(format!("{scene}: error vs time"), ("sans-serif", 22))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(
                    (tmin * 0.7..tmax * 1.4).log_scale(),
                    (ERROR_FLOOR * 0.8..emax * 2.0).log_scale(),
                )
                .map_err(io::Error::other)?;
            chart
                .configure_mesh()
                .x_desc("time of the reflection pass (ms, log)")
                .y_desc("mean abs. difference (0..255, log)")
                .draw()
                .map_err(io::Error::other)?;
            for (i, m) in methods.iter().enumerate() {
                let mut series: Vec<(f64, f64)> = pts
                    .iter()
                    .filter(|r| r.method == *m)
                    .map(|r| (r.time_ms, r.mean_abs_255))
                    .collect();
                if series.is_empty() {
                    continue;
                }
                series.sort_by(|a, b| a.0.total_cmp(&b.0));
                let color = COLORS[i % COLORS.len()].to_rgba();
                chart
                    .draw_series(LineSeries::new(series.clone(), color.stroke_width(2)))
                    .map_err(io::Error::other)?;
                chart
                    .draw_series(series.iter().map(|&p| Circle::new(p, 4, color.filled())))
                    .map_err(io::Error::other)?
                    .label(*m)
                    .legend(move |(x, y)| Circle::new((x + 8, y), 4, color.filled()));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(io::Error::other)?;
        }
        root.present().map_err(io::Error::other)?;
    }
    image::save_buffer(path, &buf, w, h, image::ExtendedColorType::Rgb8).map_err(io::Error::other)
}
