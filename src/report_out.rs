//! Report output: the summary table (CSV + Markdown), the error-vs-time plot
//! and PNG images. Pure output; the measurements come from [`crate::report`].

use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
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

/// Where the log-scale error axis of the plot ends. Errors below it read as
/// exact: drawn hollow on a band labelled "exact (error 0)" under the axis
/// floor. An exact method measures 0; an error under 0.001 on the 0..255
/// scale also prints as 0.0000 in the summary.
pub const ERROR_FLOOR: f64 = 1e-3;

/// The methods that render primary visibility along a camera path (see
/// [`crate::epipolar`]), not reflections: the plot gives their rows a panel
/// of their own per scene.
pub const PRIMARY_VISIBILITY_METHODS: [&str; 3] = ["epipolar", "orsa", "irsa"];

/// A marker shape of the error-vs-time plot, drawn filled (a measured
/// error) or hollow (exact). Every shape but the circle is drawn as one
/// simple polygon, [`Marker::outline`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Marker {
    /// A disc.
    Circle,
    /// An axis-aligned square.
    Square,
    /// A square standing on a corner.
    Diamond,
    /// A triangle pointing up.
    TriangleUp,
    /// A triangle pointing down.
    TriangleDown,
    /// A triangle pointing left.
    TriangleLeft,
    /// A triangle pointing right.
    TriangleRight,
    /// A regular pentagon, a corner up.
    Pentagon,
    /// A regular hexagon, corners left and right.
    Hexagon,
    /// A five-pointed star.
    Star,
    /// A thick `+`.
    Plus,
    /// A thick `x`.
    Cross,
    /// Two triangles meeting at their tips, one above the other.
    Hourglass,
    /// Two triangles meeting at their tips, side by side.
    Bowtie,
    /// An arrowhead pointing up (a triangle with a notch in its base).
    Chevron,
    /// An arrowhead pointing down.
    ChevronDown,
    /// A kite: a rhombus stretched downward.
    Kite,
}

impl Marker {
    /// Every shape, in the order the unknown-method fallback indexes them.
    pub const ALL: [Marker; 17] = [
        Marker::Circle,
        Marker::Square,
        Marker::Diamond,
        Marker::TriangleUp,
        Marker::TriangleDown,
        Marker::TriangleLeft,
        Marker::TriangleRight,
        Marker::Pentagon,
        Marker::Hexagon,
        Marker::Star,
        Marker::Plus,
        Marker::Cross,
        Marker::Hourglass,
        Marker::Bowtie,
        Marker::Chevron,
        Marker::ChevronDown,
        Marker::Kite,
    ];

    /// The shape's outline as pixel offsets from the point it marks (`y`
    /// down), for a marker of about `r` pixels radius: the corners of one
    /// simple polygon, not closed (the last corner is not the first again).
    /// The circle's is a 20-gon; the plot draws a true circle instead.
    pub fn outline(self, r: f64) -> Vec<(i32, i32)> {
        use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
        // A regular n-gon of radius `r`, its first corner at angle `a0`
        // (counter-clockwise from +x, `y` up).
        let ngon = |n: usize, a0: f64, r: f64| -> Vec<(f64, f64)> {
            (0..n)
                .map(|k| {
                    let a = a0 + 2.0 * PI * k as f64 / n as f64;
                    (r * a.cos(), -r * a.sin())
                })
                .collect()
        };
        let plus = |r: f64| -> Vec<(f64, f64)> {
            let (w, l) = (0.4 * r, 1.2 * r);
            vec![
                (-w, -l),
                (w, -l),
                (w, -w),
                (l, -w),
                (l, w),
                (w, w),
                (w, l),
                (-w, l),
                (-w, w),
                (-l, w),
                (-l, -w),
                (-w, -w),
            ]
        };
        let hourglass = |r: f64| -> Vec<(f64, f64)> {
            let (s, d) = (r, 0.3 * r);
            vec![(-s, -s), (s, -s), (d, 0.0), (s, s), (-s, s), (-d, 0.0)]
        };
        let pts = match self {
            Marker::Circle => ngon(20, 0.0, r),
            Marker::Square => ngon(4, FRAC_PI_4, 1.25 * r),
            Marker::Diamond => ngon(4, FRAC_PI_2, 1.3 * r),
            Marker::TriangleUp => ngon(3, FRAC_PI_2, 1.35 * r),
            Marker::TriangleDown => ngon(3, -FRAC_PI_2, 1.35 * r),
            Marker::TriangleLeft => ngon(3, PI, 1.35 * r),
            Marker::TriangleRight => ngon(3, 0.0, 1.35 * r),
            Marker::Pentagon => ngon(5, FRAC_PI_2, 1.15 * r),
            Marker::Hexagon => ngon(6, 0.0, 1.1 * r),
            Marker::Star => (0..10)
                .map(|k| {
                    let a = FRAC_PI_2 + PI * k as f64 / 5.0;
                    let rr = if k % 2 == 0 { 1.45 * r } else { 0.6 * r };
                    (rr * a.cos(), -rr * a.sin())
                })
                .collect(),
            Marker::Plus => plus(r),
            Marker::Cross => {
                let c = FRAC_PI_4.cos();
                plus(r)
                    .into_iter()
                    .map(|(x, y)| (c * (x - y), c * (x + y)))
                    .collect()
            }
            Marker::Hourglass => hourglass(r),
            Marker::Bowtie => hourglass(r).into_iter().map(|(x, y)| (y, x)).collect(),
            Marker::Chevron => vec![(0.0, -1.2 * r), (r, r), (0.0, 0.35 * r), (-r, r)],
            Marker::ChevronDown => vec![(0.0, 1.2 * r), (-r, -r), (0.0, -0.35 * r), (r, -r)],
            Marker::Kite => vec![
                (0.0, -r),
                (0.75 * r, -0.25 * r),
                (0.0, 1.3 * r),
                (-0.75 * r, -0.25 * r),
            ],
        };
        pts.into_iter()
            .map(|(x, y)| (x.round() as i32, y.round() as i32))
            .collect()
    }
}

/// How the plot draws one method: its color and its marker shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MethodStyle {
    /// The marker color.
    pub color: RGBColor,
    /// The marker shape.
    pub marker: Marker,
}

const fn style(r: u8, g: u8, b: u8, marker: Marker) -> MethodStyle {
    MethodStyle {
        color: RGBColor(r, g, b),
        marker,
    }
}

/// The style of every method the report knows, in legend order: each its
/// own color and its own shape, so a method reads the same in every panel
/// and every run. The colors are far apart (CIEDE2000 at least 20 between
/// any two) and dark enough to read on white.
pub const KNOWN_METHOD_STYLES: [(&str, MethodStyle); 17] = [
    ("reference", style(0x00, 0x00, 0x00, Marker::Circle)),
    ("envmap", style(0x65, 0x45, 0x22, Marker::Square)),
    ("planar-mirror", style(0xE3, 0x77, 0xC2, Marker::Diamond)),
    ("epipolar", style(0x00, 0x72, 0xB2, Marker::Pentagon)),
    ("orsa", style(0xBE, 0x00, 0x32, Marker::Bowtie)),
    ("irsa", style(0x32, 0xCD, 0x32, Marker::Hexagon)),
    ("step", style(0xF3, 0x84, 0x00, Marker::TriangleDown)),
    ("hiz", style(0x56, 0xB4, 0xE9, Marker::TriangleUp)),
    ("layered", style(0x00, 0x88, 0x56, Marker::TriangleRight)),
    ("cluster", style(0x87, 0x56, 0x92, Marker::Cross)),
    ("tcrr", style(0x00, 0x60, 0x64, Marker::Star)),
    ("naive-warp", style(0xC2, 0xB2, 0x80, Marker::TriangleLeft)),
    ("cone", style(0x4B, 0x00, 0x82, Marker::Plus)),
    ("multiray", style(0xFA, 0x80, 0x72, Marker::Hourglass)),
    ("hiz-temporal", style(0x4B, 0x00, 0x1E, Marker::Chevron)),
    // Teal: the color farthest (CIEDE2000 24.7) from the others once
    // dark olive went to `planned`, 34.5 from the fallback colors.
    ("hiz-bounce", style(0x00, 0xD0, 0xC0, Marker::Kite)),
    // Dark olive: the color farthest (CIEDE2000 23) from the others, the
    // front's grey and (17.6) the fallback colors.
    ("planned", style(0x78, 0x78, 0x00, Marker::ChevronDown)),
];

/// Styles for methods missing from [`KNOWN_METHOD_STYLES`]. No known
/// method has any of these colors, and each shape is paired with a color
/// far from that of the known method with the same shape, so an unknown
/// method never looks like a known one.
const FALLBACK_STYLES: [MethodStyle; 12] = [
    style(0x8C, 0x56, 0x4B, Marker::Hexagon),
    style(0xB8, 0x86, 0x0B, Marker::Plus),
    style(0xE2, 0x58, 0x22, Marker::TriangleRight),
    style(0x80, 0x00, 0x00, Marker::TriangleLeft),
    style(0xBC, 0xBD, 0x22, Marker::Circle),
    style(0x2B, 0x3D, 0x26, Marker::Hourglass),
    style(0x8C, 0x56, 0x4B, Marker::TriangleUp),
    style(0xB8, 0x86, 0x0B, Marker::Diamond),
    style(0xE2, 0x58, 0x22, Marker::Star),
    style(0x80, 0x00, 0x00, Marker::Pentagon),
    style(0xBC, 0xBD, 0x22, Marker::Cross),
    style(0x2B, 0x3D, 0x26, Marker::TriangleDown),
];

/// The style of `method`: its entry in [`KNOWN_METHOD_STYLES`], else one
/// of a fixed set of fallback styles picked by a hash of the name (the
/// same in every run), none of which a known method has.
pub fn method_style(method: &str) -> MethodStyle {
    if let Some((_, s)) = KNOWN_METHOD_STYLES.iter().find(|(m, _)| *m == method) {
        return *s;
    }
    // FNV-1a: fixed, unlike std's randomly seeded hasher.
    let h = method.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    });
    FALLBACK_STYLES[(h % FALLBACK_STYLES.len() as u64) as usize]
}

/// Where `method` goes in a legend: known methods in table order, then
/// the others by name.
fn legend_key(method: &str) -> (usize, &str) {
    let i = KNOWN_METHOD_STYLES
        .iter()
        .position(|(m, _)| *m == method)
        .unwrap_or(KNOWN_METHOD_STYLES.len());
    (i, method)
}

/// Whether a measured error reads as exact (below [`ERROR_FLOOR`]).
pub fn is_exact(mean_abs_255: f64) -> bool {
    mean_abs_255 < ERROR_FLOOR
}

/// The Pareto front of `(time, error)` points, lower being better in both:
/// the indices of the points that no other point dominates (another point
/// dominates one when it is no slower and no worse, and faster or better),
/// sorted by time, then error, then index. Errors below [`ERROR_FLOOR`]
/// count as 0, so exact points tie on error. Identical points are all on
/// the front. Points with a NaN or infinite coordinate are never on it and
/// dominate nothing.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let key = |(t, e): (f64, f64)| (t, if is_exact(e) { 0.0 } else { e });
    let valid: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    let mut front: Vec<usize> = valid
        .iter()
        .copied()
        .filter(|&i| {
            let (t, e) = key(points[i]);
            !valid.iter().any(|&j| {
                let (tj, ej) = key(points[j]);
                tj <= t && ej <= e && (tj < t || ej < e)
            })
        })
        .collect();
    front.sort_by(|&a, &b| {
        let (ka, kb) = (key(points[a]), key(points[b]));
        ka.0.total_cmp(&kb.0)
            .then(ka.1.total_cmp(&kb.1))
            .then(a.cmp(&b))
    });
    front
}

/// What a panel of the plot shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PanelKind {
    /// Reflection methods (every method not in
    /// [`PRIMARY_VISIBILITY_METHODS`]).
    Reflection,
    /// Primary visibility along a camera path
    /// ([`PRIMARY_VISIBILITY_METHODS`]).
    PrimaryVisibility,
}

impl PanelKind {
    /// The kind of panel `method`'s rows go to.
    pub fn of(method: &str) -> PanelKind {
        if PRIMARY_VISIBILITY_METHODS.contains(&method) {
            PanelKind::PrimaryVisibility
        } else {
            PanelKind::Reflection
        }
    }
}

/// One panel of the plot: the plotted rows of one scene and one kind.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel<'a> {
    /// The scene.
    pub scene: &'a str,
    /// Reflection or primary-visibility rows.
    pub kind: PanelKind,
    /// The rows, in input order.
    pub rows: Vec<&'a Row>,
}

/// Whether the plot draws `row`: a positive, finite time and a finite
/// error (rows with zero time were not timed).
fn plotted(row: &Row) -> bool {
    row.time_ms > 0.0 && row.time_ms.is_finite() && row.mean_abs_255.is_finite()
}

/// The panels of the plot: scenes in order of first appearance, each with
/// its reflection panel then its primary-visibility panel; a panel without
/// plotted rows (zero time, non-finite time or error) is left out.
pub fn split_panels(rows: &[Row]) -> Vec<Panel<'_>> {
    let mut panels: Vec<Panel<'_>> = Vec::new();
    for r in rows.iter().filter(|r| plotted(r)) {
        let kind = PanelKind::of(&r.method);
        match panels
            .iter_mut()
            .find(|p| p.scene == r.scene && p.kind == kind)
        {
            Some(p) => p.rows.push(r),
            None => panels.push(Panel {
                scene: &r.scene,
                kind,
                rows: vec![r],
            }),
        }
    }
    let scene_order = |s: &str| rows.iter().position(|r| r.scene == s);
    panels.sort_by_key(|p| (scene_order(p.scene), p.kind));
    panels
}

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

/// Plot size: each panel is `PANEL_W` x `PANEL_H` pixels, of which the
/// right `LEGEND_W` are its legend.
const PANEL_W: u32 = 1100;
const PANEL_H: u32 = 420;
const LEGEND_W: u32 = 210;
/// Marker radius, pixels.
const MARKER_R: f64 = 5.5;
/// The exact band spans `ERROR_FLOOR * BAND_LOW .. ERROR_FLOOR * BAND_HIGH`
/// under the axis floor; exact points sit at `ERROR_FLOOR * EXACT_Y`, the
/// band's geometric middle.
const BAND_LOW: f64 = 0.3;
const BAND_HIGH: f64 = 0.75;
const EXACT_Y: f64 = 0.474;
const BAND_COLOR: RGBColor = RGBColor(232, 232, 232);
const FRONT_COLOR: RGBColor = RGBColor(110, 110, 110);
const GRID_DECADE: RGBColor = RGBColor(200, 200, 200);
const GRID_MINOR: RGBColor = RGBColor(235, 235, 235);
/// Radius of the ring around a Pareto-front point, pixels.
const FRONT_RING_R: i32 = 11;

/// A tick label with as many decimals as the value needs (`0.001`, `0.2`,
/// `20`).
fn tick_label(v: f64) -> String {
    if !(v > 0.0) {
        return format!("{v}");
    }
    let decimals = (-v.log10().floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

/// A vertical grid line of the time axis.
#[derive(Clone, Copy, Debug, PartialEq)]
struct TimeTick {
    /// Where, ms.
    value: f64,
    /// A power of ten (a darker line).
    decade: bool,
    /// Labelled: 1, 2 or 5 times a power of ten (only powers of ten when
    /// the axis spans more than 6 decades; every line when that would
    /// label fewer than 3).
    labelled: bool,
}

/// The time axis grid over `lo..=hi` (ms, `0 < lo <= hi`): every
/// `m * 10^k`, `m` in 1..=9, in increasing order.
fn time_ticks(lo: f64, hi: f64) -> Vec<TimeTick> {
    if !(lo > 0.0 && lo <= hi && hi.is_finite()) {
        return Vec::new();
    }
    let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let many = k1 - k0 > 6;
    let mut ticks = Vec::new();
    for k in k0..=k1 {
        for m in 1..=9u8 {
            // Formatting rounds `m * 10^k` back to its decimal digits.
            let value = f64::from(m) * 10f64.powi(k);
            if value >= lo && value <= hi {
                ticks.push(TimeTick {
                    value,
                    decade: m == 1,
                    labelled: m == 1 || (!many && (m == 2 || m == 5)),
                });
            }
        }
    }
    // A short axis (under a decade or so) would show one or two labels:
    // label every line.
    if ticks.iter().filter(|t| t.labelled).count() < 3 {
        for t in &mut ticks {
            t.labelled = true;
        }
    }
    ticks
}

/// Draws `style`'s marker centered on `at`: filled, or hollow (white inside,
/// a thicker outline) for an exact point.
fn draw_marker<CT: CoordTranslate>(
    area: &DrawingArea<BitMapBackend<'_>, CT>,
    at: CT::From,
    style: MethodStyle,
    hollow: bool,
) -> io::Result<()> {
    let (fill, stroke) = if hollow {
        (WHITE.filled(), style.color.stroke_width(2))
    } else {
        (style.color.filled(), style.color.stroke_width(1))
    };
    let drawn = if style.marker == Marker::Circle {
        // A true circle: a small polygon rounds to pixels as a diamond.
        let r = MARKER_R.round() as i32;
        area.draw(
            &(EmptyElement::at(at) + Circle::new((0, 0), r, fill) + Circle::new((0, 0), r, stroke)),
        )
    } else {
        let outline = style.marker.outline(MARKER_R);
        let mut closed = outline.clone();
        closed.push(outline[0]);
        area.draw(
            &(EmptyElement::at(at)
                + Polygon::new(outline, fill)
                + PathElement::new(closed, stroke)),
        )
    };
    drawn.map_err(io::Error::other)
}

/// Draws the grey ring that marks a point of the Pareto front.
fn draw_front_ring<CT: CoordTranslate>(
    area: &DrawingArea<BitMapBackend<'_>, CT>,
    at: CT::From,
) -> io::Result<()> {
    area.draw(
        &(EmptyElement::at(at) + Circle::new((0, 0), FRONT_RING_R, FRONT_COLOR.stroke_width(2))),
    )
    .map_err(io::Error::other)
}

/// The staircase through a Pareto front sorted by time: from each point
/// right to the next point's time, then down to it.
fn front_steps(front: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut path = Vec::with_capacity(front.len() * 2);
    for (k, &p) in front.iter().enumerate() {
        if k > 0 {
            path.push((p.0, front[k - 1].1));
        }
        path.push(p);
    }
    path
}

/// Draws one panel: the chart left, its legend right.
fn draw_panel(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    panel: &Panel<'_>,
) -> io::Result<()> {
    let (chart_area, legend_area) = area.split_horizontally(PANEL_W - LEGEND_W);
    let y_of = |e: f64| {
        if is_exact(e) {
            ERROR_FLOOR * EXACT_Y
        } else {
            e
        }
    };
    let pts: Vec<(f64, f64)> = panel
        .rows
        .iter()
        .map(|r| (r.time_ms, r.mean_abs_255))
        .collect();
    let (tmin, tmax) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let emax = pts.iter().map(|p| p.1).fold(ERROR_FLOOR * 10.0, f64::max);
    let (x0, x1) = (tmin * 0.7, tmax * 1.4);
    let (title, x_desc) = match panel.kind {
        PanelKind::Reflection => (
            format!("{}: reflection methods, error vs time", panel.scene),
            "time of the reflection pass (ms, log)",
        ),
        PanelKind::PrimaryVisibility => (
            format!(
                "{}: primary visibility along the camera path, error vs time",
                panel.scene
            ),
            "time per frame of the primary-visibility pass (ms, log)",
        ),
    };
    let mut chart = ChartBuilder::on(&chart_area)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(64)
        .build_cartesian_2d(
            (x0..x1).log_scale(),
            (ERROR_FLOOR * BAND_LOW..emax * 2.0).log_scale(),
        )
        .map_err(io::Error::other)?;
    chart
        .configure_mesh()
        // The time grid and labels are drawn below (`time_ticks`):
        // plotters puts none under the first power of ten.
        .disable_x_mesh()
        .set_tick_mark_size(LabelAreaPosition::Bottom, 0)
        .x_label_formatter(&|_| String::new())
        .x_desc(x_desc)
        .y_desc("mean abs. difference (0..255, log); exact = band")
        // No ticks inside the exact band: it is not on the log scale.
        .y_label_formatter(&|v| {
            if *v < ERROR_FLOOR * 0.999 {
                String::new()
            } else {
                tick_label(*v)
            }
        })
        .draw()
        .map_err(io::Error::other)?;

    // The time grid, ticks and labels.
    let plot = chart.plotting_area();
    let (ox, oy) = area.get_base_pixel();
    let y_lo = ERROR_FLOOR * BAND_LOW;
    let tick_font = ("sans-serif", 12)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Top));
    for t in time_ticks(x0, x1) {
        let grid = if t.decade { GRID_DECADE } else { GRID_MINOR };
        plot.draw(&PathElement::new(
            vec![(t.value, y_lo), (t.value, emax * 2.0)],
            grid.stroke_width(1),
        ))
        .map_err(io::Error::other)?;
        if t.labelled {
            let (px, py) = chart.backend_coord(&(t.value, y_lo));
            let (px, py) = (px - ox, py - oy);
            area.draw(&PathElement::new(
                vec![(px, py), (px, py + 5)],
                BLACK.stroke_width(1),
            ))
            .map_err(io::Error::other)?;
            area.draw(&Text::new(
                tick_label(t.value),
                (px, py + 8),
                tick_font.clone(),
            ))
            .map_err(io::Error::other)?;
        }
    }

    // The exact band, its label and its "0" tick.
    plot.draw(&Rectangle::new(
        [(x0, ERROR_FLOOR * BAND_LOW), (x1, ERROR_FLOOR * BAND_HIGH)],
        BAND_COLOR.filled(),
    ))
    .map_err(io::Error::other)?;
    let label = ("sans-serif", 13).into_font().color(&RGBColor(80, 80, 80));
    plot.draw(
        &(EmptyElement::at((x0, ERROR_FLOOR * EXACT_Y))
            + Text::new(
                "exact (error 0)",
                (6, 0),
                label.pos(Pos::new(HPos::Left, VPos::Center)),
            )),
    )
    .map_err(io::Error::other)?;
    let (ax, ay) = chart.backend_coord(&(x0, ERROR_FLOOR * EXACT_Y));
    area.draw(&Text::new(
        "0",
        (ax - ox - 8, ay - oy),
        ("sans-serif", 12)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Right, VPos::Center)),
    ))
    .map_err(io::Error::other)?;

    // The Pareto front under the points.
    let front: Vec<(f64, f64)> = pareto_front(&pts)
        .into_iter()
        .map(|i| (pts[i].0, y_of(pts[i].1)))
        .collect();
    plot.draw(&DashedPathElement::new(
        front_steps(&front),
        8,
        5,
        FRONT_COLOR.stroke_width(3),
    ))
    .map_err(io::Error::other)?;

    for &p in &front {
        draw_front_ring(plot, p)?;
    }

    // The points, method by method in legend order.
    let mut methods: Vec<&str> = panel.rows.iter().map(|r| r.method.as_str()).collect();
    methods.sort_by_key(|m| legend_key(m));
    methods.dedup();
    for m in &methods {
        let style = method_style(m);
        for r in panel.rows.iter().filter(|r| r.method == *m) {
            let exact = is_exact(r.mean_abs_255);
            draw_marker(plot, (r.time_ms, y_of(r.mean_abs_255)), style, exact)?;
        }
    }

    // The legend, right of the chart.
    let text = ("sans-serif", 14)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let small = ("sans-serif", 12)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let put = |t: &str, x: i32, y: i32, style: &TextStyle<'_>| {
        legend_area
            .draw(&Text::new(t.to_string(), (x, y), style.clone()))
            .map_err(io::Error::other)
    };
    let mut y = 48;
    // Rows closer together when many methods share the panel, so the
    // legend ends inside it.
    let line = ((PANEL_H as i32 - 150) / methods.len().max(1) as i32).clamp(12, 20);
    for m in &methods {
        draw_marker(&legend_area, (18, y), method_style(m), false)?;
        put(m, 34, y, &text)?;
        y += line;
    }
    y += 10;
    let hollow = MethodStyle {
        color: RGBColor(60, 60, 60),
        marker: Marker::Circle,
    };
    draw_marker(&legend_area, (18, y), hollow, true)?;
    put("hollow: exact (error 0,", 34, y, &text)?;
    put("i.e. < 0.001), on the band", 34, y + 15, &small)?;
    put("at the bottom of the axis", 34, y + 29, &small)?;
    y += line + 34;
    legend_area
        .draw(&DashedPathElement::new(
            vec![(2, y), (34, y)],
            8,
            5,
            FRONT_COLOR.stroke_width(3),
        ))
        .map_err(io::Error::other)?;
    draw_front_ring(&legend_area, (18, y))?;
    put("Pareto front (ringed):", 40, y, &text)?;
    put("no other point is both", 40, y + 15, &small)?;
    put("faster and lower in error", 40, y + 29, &small)?;
    Ok(())
}

/// Plots error (mean absolute difference, 0..255, log scale) against time
/// (ms, log scale). One panel per scene for the reflection methods and one
/// per scene for the primary-visibility methods
/// ([`PRIMARY_VISIBILITY_METHODS`]), see [`split_panels`]. Every method has
/// its own color and marker ([`method_style`]), listed in a legend right of
/// each panel; each row is one point (no lines between a method's
/// settings). Errors below [`ERROR_FLOOR`] are exact and drawn hollow on a
/// band labelled "exact (error 0)" under the log axis. The Pareto front of
/// each panel ([`pareto_front`]) is a grey dashed staircase through
/// its points, each ringed. Rows with zero
/// time (or a non-finite time or error) are skipped.
pub fn plot_error_vs_time(path: &Path, rows: &[Row]) -> io::Result<()> {
    ensure_font();
    let panels = split_panels(rows);
    let (w, h) = (PANEL_W, PANEL_H * panels.len().max(1) as u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(io::Error::other)?;
        let areas = root.split_evenly((panels.len().max(1), 1));
        for (panel, area) in panels.iter().zip(areas.iter()) {
            draw_panel(area, panel)?;
        }
        root.present().map_err(io::Error::other)?;
    }
    image::save_buffer(path, &buf, w, h, image::ExtendedColorType::Rgb8).map_err(io::Error::other)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scene: &str, method: &str, time_ms: f64, mean_abs_255: f64) -> Row {
        Row {
            scene: scene.into(),
            method: method.into(),
            setting: "s".into(),
            threads: 1,
            time_ms,
            reference_ms: 1.0,
            speedup: 1.0,
            coverage: 1.0,
            mean_abs_255,
            psnr_db: f64::INFINITY,
            share_over_8: 0.0,
            extra: Vec::new(),
        }
    }

    /// sRGB (D65) to CIELAB.
    fn lab(c: RGBColor) -> (f64, f64, f64) {
        let lin = |u: u8| {
            let u = f64::from(u) / 255.0;
            if u <= 0.04045 {
                u / 12.92
            } else {
                ((u + 0.055) / 1.055).powf(2.4)
            }
        };
        let (r, g, b) = (lin(c.0), lin(c.1), lin(c.2));
        let x = (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047;
        let y = 0.2126 * r + 0.7152 * g + 0.0722 * b;
        let z = (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883;
        let f = |t: f64| {
            if t > 216.0 / 24389.0 {
                t.cbrt()
            } else {
                (24389.0 / 27.0 * t + 16.0) / 116.0
            }
        };
        let (fx, fy, fz) = (f(x), f(y), f(z));
        (116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz))
    }

    /// CIEDE2000 color difference (Sharma, Wu, Dalal 2005).
    fn delta_e2000(c1: RGBColor, c2: RGBColor) -> f64 {
        let ((l1, a1, b1), (l2, a2, b2)) = (lab(c1), lab(c2));
        let p7 = |c: f64| (c.powi(7) / (c.powi(7) + 25f64.powi(7))).sqrt();
        let cb = (a1.hypot(b1) + a2.hypot(b2)) / 2.0;
        let g = 0.5 * (1.0 - p7(cb));
        let (a1p, a2p) = ((1.0 + g) * a1, (1.0 + g) * a2);
        let (c1p, c2p) = (a1p.hypot(b1), a2p.hypot(b2));
        let hue = |b: f64, a: f64| b.atan2(a).to_degrees().rem_euclid(360.0);
        let (h1p, h2p) = (hue(b1, a1p), hue(b2, a2p));
        let dlp = l2 - l1;
        let dcp = c2p - c1p;
        let dhp = if c1p * c2p == 0.0 {
            0.0
        } else if h2p - h1p > 180.0 {
            h2p - h1p - 360.0
        } else if h2p - h1p < -180.0 {
            h2p - h1p + 360.0
        } else {
            h2p - h1p
        };
        let dhp_big = 2.0 * (c1p * c2p).sqrt() * (dhp / 2.0).to_radians().sin();
        let lbp = (l1 + l2) / 2.0;
        let cbp = (c1p + c2p) / 2.0;
        let hbp = if c1p * c2p == 0.0 {
            h1p + h2p
        } else if (h1p - h2p).abs() > 180.0 {
            (h1p + h2p + 360.0) / 2.0
        } else {
            (h1p + h2p) / 2.0
        };
        let cosd = |d: f64| d.to_radians().cos();
        let t =
            1.0 - 0.17 * cosd(hbp - 30.0) + 0.24 * cosd(2.0 * hbp) + 0.32 * cosd(3.0 * hbp + 6.0)
                - 0.20 * cosd(4.0 * hbp - 63.0);
        let dth = 30.0 * (-((hbp - 275.0) / 25.0).powi(2)).exp();
        let rc = 2.0 * p7(cbp);
        let sl = 1.0 + 0.015 * (lbp - 50.0).powi(2) / (20.0 + (lbp - 50.0).powi(2)).sqrt();
        let sc = 1.0 + 0.045 * cbp;
        let sh = 1.0 + 0.015 * cbp * t;
        let rt = -(2.0 * dth).to_radians().sin() * rc;
        ((dlp / sl).powi(2)
            + (dcp / sc).powi(2)
            + (dhp_big / sh).powi(2)
            + rt * (dcp / sc) * (dhp_big / sh))
            .sqrt()
    }

    #[test]
    fn delta_e2000_sanity() {
        // Sanity of the metric the palette is checked with: identical colors
        // differ by 0, black and white by 100, and it is symmetric.
        let (k, w) = (RGBColor(0, 0, 0), RGBColor(255, 255, 255));
        assert!(delta_e2000(k, k).abs() < 1e-9);
        assert!((delta_e2000(k, w) - 100.0).abs() < 0.1);
        let (a, b) = (RGBColor(0xE3, 0x77, 0xC2), RGBColor(0x56, 0xB4, 0xE9));
        assert!((delta_e2000(a, b) - delta_e2000(b, a)).abs() < 1e-9);
    }

    #[test]
    fn known_styles_are_unique_and_far_apart() {
        let s = &KNOWN_METHOD_STYLES;
        for (i, (mi, si)) in s.iter().enumerate() {
            // Dark enough to read on the white background.
            assert!(lab(si.color).0 < 80.0, "{mi} too light");
            // Far from the band and the front's grey.
            assert!(delta_e2000(si.color, BAND_COLOR) > 15.0, "{mi}");
            for (mj, sj) in &s[i + 1..] {
                assert_ne!(mi, mj);
                assert_ne!(si.marker, sj.marker, "{mi} and {mj} share a marker");
                let d = delta_e2000(si.color, sj.color);
                assert!(d >= 20.0, "{mi} and {mj}: CIEDE2000 {d:.1}");
            }
        }
        for m in Marker::ALL {
            assert!(s.iter().any(|(_, st)| st.marker == m), "{m:?} unused");
        }
    }

    #[test]
    fn every_report_method_has_a_known_style() {
        let known: BTreeSet<&str> = KNOWN_METHOD_STYLES.iter().map(|(m, _)| *m).collect();
        let report: BTreeSet<&str> = crate::report::METHODS.iter().copied().collect();
        assert_eq!(known, report);
        for m in crate::report::METHODS {
            assert_eq!(method_style(m), KNOWN_METHOD_STYLES[legend_key(m).0].1);
        }
    }

    #[test]
    fn fallback_styles_are_unlike_any_known() {
        for (i, f) in FALLBACK_STYLES.iter().enumerate() {
            assert!(!FALLBACK_STYLES[i + 1..].contains(f), "{f:?} twice");
            assert!(lab(f.color).0 < 80.0, "{f:?} too light");
            for (m, k) in &KNOWN_METHOD_STYLES {
                let d = delta_e2000(f.color, k.color);
                assert!(d >= 12.0, "{f:?} vs {m}: CIEDE2000 {d:.1}");
                if f.marker == k.marker {
                    assert!(d >= 35.0, "{f:?} vs {m}, same marker: {d:.1}");
                }
            }
        }
    }

    #[test]
    fn unknown_methods_get_a_stable_fallback_style() {
        let names = [
            "",
            "foo",
            "bar",
            "ssr",
            "hiz2",
            "step-v2",
            "Reference",
            "planar",
            "x",
            "a-very-long-method-name",
        ];
        for n in names {
            let s = method_style(n);
            assert!(FALLBACK_STYLES.contains(&s), "{n}: {s:?}");
        }
        // Pinned: the hash is fixed, not per process or per build.
        assert_eq!(
            method_style("foo"),
            FALLBACK_STYLES[0xdcb2_7518_fed9_d577 % 12]
        );
        // The names spread over the fallback styles.
        let used: Vec<MethodStyle> = names.iter().map(|n| method_style(n)).collect();
        let distinct = FALLBACK_STYLES.iter().filter(|f| used.contains(f)).count();
        assert!(distinct >= 6, "{distinct}");
    }

    #[test]
    fn legend_order_is_the_table_then_names() {
        let mut m = vec!["zeta", "hiz", "alpha", "reference", "step"];
        m.sort_by_key(|m| legend_key(m));
        assert_eq!(m, ["reference", "step", "hiz", "alpha", "zeta"]);
    }

    #[test]
    fn marker_outlines_are_distinct_bounded_polygons() {
        let r = MARKER_R;
        let mut seen = Vec::new();
        for m in Marker::ALL {
            let o = m.outline(r);
            assert!(o.len() >= 3, "{m:?}");
            assert!(
                o.iter()
                    .all(|&(x, y)| x.abs() <= 2 * r as i32 && y.abs() <= 2 * r as i32),
                "{m:?}: {o:?}"
            );
            // Non-degenerate: spans at least the radius both ways.
            let span = |f: fn(&(i32, i32)) -> i32| {
                o.iter().map(f).max().unwrap() - o.iter().map(f).min().unwrap()
            };
            assert!(
                span(|p| p.0) >= r as i32 && span(|p| p.1) >= r as i32,
                "{m:?}: {o:?}"
            );
            assert!(!seen.contains(&o), "{m:?} repeats a shape");
            seen.push(o);
        }
        // Orientation: up points up (y down in pixels).
        assert!(Marker::TriangleUp.outline(r).iter().map(|p| p.1).min() == Some(-7));
        assert!(Marker::TriangleDown.outline(r).iter().map(|p| p.1).max() == Some(7));
    }

    #[test]
    fn pareto_front_on_a_hand_made_set() {
        // time, error; lower is better in both.
        let pts = [
            (10.0, 5.0), // 0: front
            (20.0, 2.0), // 1: front
            (15.0, 6.0), // 2: dominated by 0
            (30.0, 2.0), // 3: dominated by 1 (same error, slower)
            (40.0, 0.5), // 4: front
            (5.0, 9.0),  // 5: front (fastest)
            (25.0, 3.0), // 6: dominated by 1
        ];
        assert_eq!(pareto_front(&pts), vec![5, 0, 1, 4]);
        assert!(pareto_front(&[]).is_empty());
        assert_eq!(pareto_front(&[(1.0, 1.0)]), vec![0]);
    }

    #[test]
    fn pareto_front_ties_and_exact_points() {
        let pts = [
            (10.0, 4.0),  // 0: front, tied with 1
            (10.0, 4.0),  // 1: front (identical points dominate neither)
            (10.0, 6.0),  // 2: same time, worse: dominated
            (50.0, 0.0),  // 3: exact: front
            (50.0, 5e-4), // 4: below the floor reads exact: tied with 3, front
            (60.0, 0.0),  // 5: exact but slower than 3: dominated
            (40.0, 2e-3), // 6: just above the floor: front, not exact
            (45.0, 2e-3), // 7: dominated by 6
        ];
        assert_eq!(pareto_front(&pts), vec![0, 1, 6, 3, 4]);
        // An exact point that is also the fastest is the whole front.
        assert_eq!(
            pareto_front(&[(3.0, 1.0), (1.0, 0.0), (2.0, 1e-4)]),
            vec![1]
        );
    }

    #[test]
    fn pareto_front_ignores_non_finite_points() {
        let pts = [
            (f64::NAN, 0.0),
            (1.0, f64::NAN),
            (2.0, 3.0),
            (f64::INFINITY, 0.0),
            (0.5, f64::INFINITY),
        ];
        assert_eq!(pareto_front(&pts), vec![2]);
    }

    #[test]
    fn front_steps_go_right_then_down() {
        assert!(front_steps(&[]).is_empty());
        assert_eq!(front_steps(&[(1.0, 9.0)]), vec![(1.0, 9.0)]);
        assert_eq!(
            front_steps(&[(1.0, 9.0), (2.0, 4.0), (5.0, 1.0)]),
            vec![(1.0, 9.0), (2.0, 9.0), (2.0, 4.0), (5.0, 4.0), (5.0, 1.0)]
        );
    }

    #[test]
    fn split_panels_separates_primary_visibility_and_skips_untimed_rows() {
        let rows = vec![
            row("room", "reference", 10.0, 0.1),
            row("walk", "epipolar", 14.0, 0.0),
            row("walk", "hiz", 6.0, 1.8),
            row("room", "hiz", 0.0, 1.0), // untimed: skipped
            row("walk", "orsa", 9.0, 0.0),
            row("walk", "irsa", 4.0, 0.0),
            row("room", "orsa", f64::NAN, 0.0), // untimed: skipped
            row("room", "step", 30.0, f64::NAN), // no error: skipped
            row("walk", "new-method", 3.0, 2.0),
            row("only-pv", "irsa", 2.0, 0.0),
            row("empty", "hiz", 0.0, 1.0), // no panel at all
        ];
        let p = split_panels(&rows);
        let summary: Vec<(&str, PanelKind, Vec<&str>)> = p
            .iter()
            .map(|p| {
                (
                    p.scene,
                    p.kind,
                    p.rows.iter().map(|r| r.method.as_str()).collect(),
                )
            })
            .collect();
        assert_eq!(
            summary,
            vec![
                ("room", PanelKind::Reflection, vec!["reference"]),
                ("walk", PanelKind::Reflection, vec!["hiz", "new-method"]),
                (
                    "walk",
                    PanelKind::PrimaryVisibility,
                    vec!["epipolar", "orsa", "irsa"]
                ),
                ("only-pv", PanelKind::PrimaryVisibility, vec!["irsa"]),
            ]
        );
        assert!(split_panels(&[]).is_empty());
        for m in PRIMARY_VISIBILITY_METHODS {
            assert_eq!(PanelKind::of(m), PanelKind::PrimaryVisibility);
        }
        assert_eq!(PanelKind::of("planar-mirror"), PanelKind::Reflection);
    }

    #[test]
    fn tick_labels_use_the_decimals_they_need() {
        assert_eq!(tick_label(0.001), "0.001");
        assert_eq!(tick_label(0.2), "0.2");
        assert_eq!(tick_label(1.0), "1");
        assert_eq!(tick_label(20.000000000000004), "20");
        assert_eq!(tick_label(0.30000000000000004), "0.3");
    }

    #[test]
    fn time_ticks_cover_the_axis_below_the_first_power_of_ten() {
        let t = time_ticks(2.8, 28.0);
        let v: Vec<f64> = t.iter().map(|t| t.value).collect();
        assert_eq!(v, [3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 20.0]);
        let labels = |t: &[TimeTick]| -> Vec<String> {
            t.iter()
                .filter(|t| t.labelled)
                .map(|t| tick_label(t.value))
                .collect()
        };
        assert_eq!(labels(&t), ["5", "10", "20"]);
        assert_eq!(t.iter().filter(|t| t.decade).count(), 1);
        assert_eq!(labels(&time_ticks(0.05, 0.3)), ["0.05", "0.1", "0.2"]);
        // A wide axis labels powers of ten only.
        let wide = time_ticks(1e-3, 1e5);
        assert!(wide.iter().filter(|t| t.labelled).all(|t| t.decade));
        assert_eq!(wide.iter().filter(|t| t.labelled).count(), 9);
        // A short one labels every line.
        assert_eq!(
            labels(&time_ticks(6.9, 45.0)),
            ["7", "8", "9", "10", "20", "30", "40"]
        );
        assert!(time_ticks(0.0, 1.0).is_empty());
        assert!(time_ticks(2.0, 1.0).is_empty());
    }

    /// Renders synthetic rows: three panels (two scenes, one with
    /// primary-visibility rows), exact points included; the PNG decodes at
    /// the expected size and shows the methods' colors.
    #[test]
    fn plot_renders_a_png_of_the_expected_size() {
        let mut rows = Vec::new();
        for (i, (m, _)) in KNOWN_METHOD_STYLES.iter().enumerate() {
            let t = 1.0 + i as f64;
            let primary = PanelKind::of(m) == PanelKind::PrimaryVisibility;
            let scene = if i % 2 == 0 && !primary { "a" } else { "b" };
            rows.push(row(
                scene,
                m,
                t,
                0.5 * (KNOWN_METHOD_STYLES.len() - i) as f64,
            ));
            rows.push(row(scene, m, 1.5 * t, 0.0));
        }
        rows.push(row("a", "unknown", 0.0, 1.0));
        let dir = std::env::temp_dir().join(format!("refl-plot-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("error_vs_time.png");
        plot_error_vs_time(&path, &rows).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        let panels = split_panels(&rows).len() as u32;
        assert_eq!(panels, 3);
        assert_eq!(img.dimensions(), (PANEL_W, PANEL_H * panels));
        for (m, s) in &KNOWN_METHOD_STYLES {
            let c = [s.color.0, s.color.1, s.color.2];
            assert!(img.pixels().any(|p| p.0 == c), "{m}'s color is missing");
        }
        // No rows still writes a (blank) image.
        plot_error_vs_time(&path, &[]).unwrap();
        assert_eq!(
            image::open(&path).unwrap().to_rgb8().dimensions(),
            (PANEL_W, PANEL_H)
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Renders a `summary.csv` (its base columns) to look at:
    /// `REFL_PLOT_CSV=report/summary.csv REFL_PLOT_PNG=/tmp/p.png cargo test
    /// -p refl --lib plot_from_csv -- --ignored`.
    #[test]
    #[ignore = "needs REFL_PLOT_CSV and REFL_PLOT_PNG"]
    fn plot_from_csv() {
        let csv_path = std::env::var("REFL_PLOT_CSV").expect("REFL_PLOT_CSV");
        let png = std::env::var("REFL_PLOT_PNG").expect("REFL_PLOT_PNG");
        let mut rd = csv::Reader::from_path(csv_path).unwrap();
        let header = rd.headers().unwrap().clone();
        let col = |n: &str| header.iter().position(|h| h == n).unwrap();
        let rows: Vec<Row> = rd
            .records()
            .map(|rec| {
                let rec = rec.unwrap();
                let f = |n: &str| rec[col(n)].parse::<f64>().unwrap();
                Row {
                    scene: rec[col("scene")].into(),
                    method: rec[col("method")].into(),
                    setting: rec[col("setting")].into(),
                    threads: rec[col("threads")].parse().unwrap(),
                    time_ms: f("time_ms"),
                    reference_ms: f("reference_ms"),
                    speedup: f("speedup"),
                    coverage: f("coverage"),
                    mean_abs_255: f("mean_abs_255"),
                    psnr_db: f("psnr_db"),
                    share_over_8: f("share_over_8"),
                    extra: Vec::new(),
                }
            })
            .collect();
        plot_error_vs_time(Path::new(&png), &rows).unwrap();
    }
}
