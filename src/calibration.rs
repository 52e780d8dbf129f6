//! The planner's cost and error model (issue 15, part 2): a table of the
//! whole-frame techniques the planner can choose from, each measured on the
//! reflective pixels of one roughness class and surface kind by
//! `refl calibrate` ([`crate::report::calibrate`]), with its provenance.
//!
//! Times are ratios, never absolute: `time_ratio` is a technique's time per
//! reflective pixel of its kind over the reference tracer's time per
//! reflective pixel at one ray (obvhs closest hit, shaded), both measured
//! in the same run on the same frames (the machine is shared and noisy;
//! milliseconds do not carry from one run to the next). `error_255` is the
//! mean absolute error (0..255, 8-bit sRGB composites) against the report's
//! ground truth on those pixels. A technique covers every pixel it is
//! given: where it cannot answer (a planar render that does not cover a
//! pixel), the pixel is ray traced and that time and error are counted.
//!
//! The checked-in table is `calibration/default.csv` (read with
//! [`Calibration::builtin`]): `#` comment lines first, among them the
//! `command:` that measured it and the `commit:` it was measured on (a
//! table without them is refused), then a CSV header
//! ([`Calibration::HEADER`]) and one row per technique, class and surface.

use crate::gbuffer::GBuffer;
use crate::render::{self, timed, ReflectionImage, Timed};
use crate::shade::Shader;
use glam::Vec3;
use refl_core::plan::{pass_bit, CostEntry, Pass, Surface};
use refl_core::summary::RoughnessClass;
use std::fmt::Write as _;

/// The checked-in calibration table's text.
pub const BUILTIN: &str = include_str!("../calibration/default.csv");

/// A whole-frame technique the planner can choose, at one setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Technique {
    /// The reference tracer (obvhs): one ray per mirror pixel, `samples`
    /// Phong-lobe samples per glossy pixel.
    Ray {
        /// Lobe samples per glossy pixel (at least 1).
        samples: u32,
    },
    /// The environment in the mirror direction (no visibility): the
    /// host's probe.
    EnvMap,
    /// refl-core's planar pass around the rasterizer at `1 / scale` of the
    /// resolution, the uncovered rest ray traced.
    Planar {
        /// Resolution divisor (1, 2, 4).
        scale: u32,
    },
    /// A hybrid (issue 15, part 3): refl-core's screen-space mirror pass
    /// with Hi-Z traversal (its default options, reversed-Z depth with an
    /// infinite far plane, the pyramid build inside the time) on the
    /// pixels, shading its hits with the frame's direct-lit color at the
    /// hit texel and its sky answers with the environment; the pass's list
    /// of rays it cannot answer (a ray off the screen, behind geometry, a
    /// hidden or back-face hit) traced by the host's tracer (obvhs).
    HiZRay,
}

impl Technique {
    /// The `method` column.
    pub fn method(&self) -> &'static str {
        match self {
            Technique::Ray { .. } => "ray",
            Technique::EnvMap => "envmap",
            Technique::Planar { .. } => "planar",
            Technique::HiZRay => "hiz+ray",
        }
    }

    /// The `setting` column.
    pub fn setting(&self) -> String {
        match self {
            Technique::Ray { samples } => format!("spp={samples}"),
            Technique::EnvMap => "analytic".into(),
            Technique::Planar { scale } => format!("resolution=1/{scale}"),
            Technique::HiZRay => "default".into(),
        }
    }

    /// `method setting`, for text.
    pub fn label(&self) -> String {
        format!("{} {}", self.method(), self.setting())
    }

    /// The technique of a `method` and `setting` column.
    ///
    /// # Errors
    /// A message naming the unknown method or the bad setting.
    pub fn parse(method: &str, setting: &str) -> Result<Self, String> {
        let number = |prefix: &str| -> Result<u32, String> {
            setting
                .strip_prefix(prefix)
                .and_then(|v| v.parse::<u32>().ok())
                .filter(|&v| v >= 1)
                .ok_or_else(|| {
                    format!("method {method}: setting '{setting}' is not {prefix}N with N >= 1")
                })
        };
        match method {
            "ray" => Ok(Technique::Ray {
                samples: number("spp=")?,
            }),
            "envmap" if setting == "analytic" => Ok(Technique::EnvMap),
            "envmap" => Err(format!(
                "method envmap: setting '{setting}' is not 'analytic'"
            )),
            "planar" => Ok(Technique::Planar {
                scale: number("resolution=1/")?,
            }),
            "hiz+ray" if setting == "default" => Ok(Technique::HiZRay),
            "hiz+ray" => Err(format!(
                "method hiz+ray: setting '{setting}' is not 'default'"
            )),
            other => Err(format!(
                "unknown method '{other}' (known: ray, envmap, planar, hiz+ray)"
            )),
        }
    }

    /// The passes it runs (refl-core's plan vocabulary): the host's
    /// tracer, the probe, or the planar pass (with the tracer for its
    /// uncovered rest).
    pub fn passes(&self) -> u32 {
        match self {
            Technique::Ray { .. } => pass_bit(Pass::HostRays),
            Technique::EnvMap => pass_bit(Pass::Probe),
            Technique::Planar { .. } => pass_bit(Pass::Planar) | pass_bit(Pass::HostRays),
            Technique::HiZRay => {
                pass_bit(Pass::HiZ) | pass_bit(Pass::Mirror) | pass_bit(Pass::HostRays)
            }
        }
    }

    /// The techniques measured on pixels of `class` on a `surface`.
    pub fn candidates(class: RoughnessClass, surface: Surface) -> Vec<Technique> {
        let mut v = Vec::new();
        match class {
            RoughnessClass::Mirror => v.extend([Technique::Ray { samples: 1 }, Technique::HiZRay]),
            _ => v.extend([1, 4, 16, 64].map(|samples| Technique::Ray { samples })),
        }
        v.push(Technique::EnvMap);
        if class == RoughnessClass::Mirror && surface == Surface::Planar {
            v.extend([1, 2, 4].map(|scale| Technique::Planar { scale }));
        }
        v
    }

    /// Renders the reflections of the reflective pixels where `mask` is
    /// true, timed; every masked reflective pixel is handled (pixels a
    /// planar render does not cover or the screen-space pass does not
    /// answer are ray traced, inside the time). `direct` is the frame's
    /// direct-lit image (the screen-space pass shades its hits with it;
    /// the host has it before reflections, so it is outside the time, as
    /// are the pass's G-buffer images and depth buffer).
    ///
    /// # Errors
    /// The planar and mirror passes' errors (never for a rendered
    /// G-buffer), as text.
    pub fn run(
        &self,
        shader: &Shader,
        g: &GBuffer,
        direct: &[Vec3],
        mask: &[bool],
        pool: &rayon::ThreadPool,
    ) -> Result<Timed<ReflectionImage>, String> {
        // The screen-space pass's inputs: the host's G-buffer images and
        // depth buffer, outside the time.
        let screen = if *self == Technique::HiZRay {
            let err = |e: refl_core::Error| format!("mirror pass: {e}");
            let images = crate::screen::PassImages::with_mask(g, Some(direct), mask);
            let depth = crate::screen::DepthBuffer::new(
                g,
                refl_core::DepthConvention::ReversedZ,
                f32::INFINITY,
            )
            .map_err(err)?;
            Some((images, depth))
        } else {
            None
        };
        let t = timed(|| -> Result<ReflectionImage, String> {
            Ok(match *self {
                Technique::Ray { samples } => {
                    render::reference_masked(shader, g, samples, mask, pool)
                }
                Technique::EnvMap => {
                    let mut out = ReflectionImage::empty(g.width(), g.height());
                    out.fill(
                        pool,
                        |i| mask[i] && g.is_reflective(i),
                        |i| render::mirror_env(g, i),
                    );
                    out
                }
                Technique::Planar { scale } => {
                    let mut objects = vec![false; shader.scene.objects.len()];
                    for (i, &m) in mask.iter().enumerate() {
                        if let Some(o) = objects.get_mut(g.object[i] as usize) {
                            *o |= m;
                        }
                    }
                    let mut img =
                        render::planar_mirror_of(shader, g, scale, &|o| objects[o as usize], pool)
                            .map_err(|e| format!("planar pass: {e}"))?;
                    let rest: Vec<bool> = (0..g.len())
                        .map(|i| mask[i] && !img.handled[i] && g.is_reflective(i))
                        .collect();
                    for (h, &m) in img.handled.iter_mut().zip(mask) {
                        *h &= m;
                    }
                    trace_rest(shader, g, &rest, &mut img, pool);
                    img
                }
                Technique::HiZRay => {
                    let (images, depth) = screen.as_ref().ok_or("hiz+ray: no pass inputs")?;
                    hiz_ray(shader, g, images, depth, mask, pool)?
                }
            })
        });
        t.value.map(|value| Timed { value, ms: t.ms })
    }
}

/// [`Technique::HiZRay`]: refl-core's mirror pass, then the host's tracer
/// on the pass's own list of rays it could not answer (issue 15, part 3).
///
/// A pixel the pass hit shades the frame's direct-lit color at the hit
/// texel; a pixel whose ray it answered as sky (in front of every surface
/// to the vanishing point) shades the environment in its mirror direction;
/// every ray of the pass's host list ([`refl_core::HostRay`]: origin,
/// direction, `t_min`) is traced by obvhs from `max(t_min, epsilon)` and
/// shaded as the reference shades a hit. A masked reflective pixel the
/// pass did not trace at all (no usable surface in its G-buffer) is ray
/// traced from the G-buffer, as the reference does.
fn hiz_ray(
    shader: &Shader,
    g: &GBuffer,
    images: &crate::screen::PassImages,
    depth: &crate::screen::DepthBuffer,
    mask: &[bool],
    pool: &rayon::ThreadPool,
) -> Result<ReflectionImage, String> {
    use rayon::prelude::*;
    use refl_core::MirrorStatus;
    let err = |e: refl_core::Error| format!("mirror pass: {e}");
    let method = crate::screen::ScreenMethod::HiZ(refl_core::hiz::HiZOptions::default());
    let image = depth.image().map_err(err)?;
    let (out, host) = crate::screen::run_with_host_rays(method, true, &image, images, pool)
        .map_err(err)?
        .value;
    let w = g.width() as usize;
    let mut img = ReflectionImage::empty(g.width(), g.height());
    let mut rest = vec![false; g.len()];
    for i in 0..g.len() {
        if !(mask[i] && g.is_reflective(i)) {
            continue;
        }
        match out.texels[i].status {
            MirrorStatus::Hit => {
                img.rgb[i] = Vec3::from_array(out.color[i]);
                img.handled[i] = true;
            }
            MirrorStatus::Sky => {
                img.rgb[i] = render::mirror_env(g, i);
                img.handled[i] = true;
            }
            // In the host list, traced below.
            s if s.needs_host() => {}
            _ => rest[i] = true,
        }
    }
    let traced: Vec<(usize, Vec3)> = pool.install(|| {
        host.par_iter()
            .filter_map(|r| {
                let i = r.y as usize * w + r.x as usize;
                (mask[i] && g.is_reflective(i)).then(|| {
                    let tmin = r.t_min.max(shader.epsilon);
                    (i, shader.trace_reflection(r.origin, r.dir, tmin))
                })
            })
            .collect()
    });
    for (i, c) in traced {
        img.rgb[i] = c;
        img.handled[i] = true;
    }
    trace_rest(shader, g, &rest, &mut img, pool);
    Ok(img)
}

/// The reference tracer at one ray on the pixels of `rest` (none: no
/// work), written into `img`.
fn trace_rest(
    shader: &Shader,
    g: &GBuffer,
    rest: &[bool],
    img: &mut ReflectionImage,
    pool: &rayon::ThreadPool,
) {
    if !rest.iter().any(|&r| r) {
        return;
    }
    let traced = render::reference_masked(shader, g, 1, rest, pool);
    for (i, &r) in rest.iter().enumerate() {
        if r {
            img.rgb[i] = traced.rgb[i];
            img.handled[i] = traced.handled[i];
        }
    }
}

/// One measured row of the table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationEntry {
    /// The technique and setting.
    pub technique: Technique,
    /// The roughness class of the pixels measured.
    pub class: RoughnessClass,
    /// Their surface kind.
    pub surface: Surface,
    /// Time per pixel over the reference tracer's time per pixel at one
    /// ray, same run.
    pub time_ratio: f32,
    /// Mean absolute error, 0..255.
    pub error_255: f32,
    /// Pixels measured (over all frames and scenes).
    pub pixels: u64,
    /// Frames measured.
    pub frames: u32,
}

/// A calibration table and its provenance.
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    /// The command that measured it.
    pub command: String,
    /// The commit it was measured on.
    pub commit: String,
    /// Every other comment line (date, sizes, machine), in order.
    pub notes: Vec<String>,
    /// The rows.
    pub entries: Vec<CalibrationEntry>,
}

/// Name of a class in the table.
pub fn class_name(c: RoughnessClass) -> &'static str {
    match c {
        RoughnessClass::Mirror => "mirror",
        RoughnessClass::Glossy => "glossy",
        RoughnessClass::Rough => "rough",
    }
}

/// Name of a surface kind in the table.
pub fn surface_name(s: Surface) -> &'static str {
    match s {
        Surface::Any => "any",
        Surface::Planar => "planar",
        Surface::Curved => "curved",
    }
}

impl Calibration {
    /// The CSV header of the table's rows.
    pub const HEADER: [&'static str; 8] = [
        "method",
        "setting",
        "class",
        "surface",
        "time_ratio",
        "error_255",
        "pixels",
        "frames",
    ];

    /// The checked-in table, `calibration/default.csv`.
    ///
    /// # Errors
    /// As [`Calibration::parse`] (a test keeps the file valid).
    pub fn builtin() -> Result<Self, String> {
        Self::parse(BUILTIN).map_err(|e| format!("calibration/default.csv: {e}"))
    }

    /// Reads a table (the format of [`Calibration::to_csv`]).
    ///
    /// # Errors
    /// A message naming the line and what is wrong: no `command:` or
    /// `commit:` comment, another header, a row with another number of
    /// fields, an unknown method, class or surface, a bad setting, a time
    /// or error that is not a finite number at least 0, a pixel or frame
    /// count that is not a whole number, a technique measured twice on the
    /// same class and surface, or no rows at all.
    pub fn parse(text: &str) -> Result<Self, String> {
        let (mut command, mut commit, mut notes) = (None, None, Vec::new());
        for line in text.lines() {
            let Some(c) = line.trim_start().strip_prefix('#') else {
                continue;
            };
            let c = c.trim();
            if let Some(v) = c.strip_prefix("command:") {
                command = Some(v.trim().to_owned());
            } else if let Some(v) = c.strip_prefix("commit:") {
                commit = Some(v.trim().to_owned());
            } else if !c.is_empty() {
                notes.push(c.to_owned());
            }
        }
        let command = command
            .filter(|c| !c.is_empty())
            .ok_or("no '# command:' line: the table must say which command measured it")?;
        let commit = commit
            .filter(|c| !c.is_empty())
            .ok_or("no '# commit:' line: the table must say which commit it was measured on")?;
        let mut reader = csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let header: Vec<String> = reader
            .headers()
            .map_err(|e| format!("header: {e}"))?
            .iter()
            .map(String::from)
            .collect();
        if header != Self::HEADER {
            return Err(format!(
                "header is '{}', expected '{}'",
                header.join(","),
                Self::HEADER.join(",")
            ));
        }
        let mut entries: Vec<CalibrationEntry> = Vec::new();
        for rec in reader.records() {
            let rec = rec.map_err(|e| e.to_string())?;
            let line = rec.position().map_or(0, |p| p.line());
            let at = |what: String| format!("line {line}: {what}");
            let f: Vec<&str> = rec.iter().collect();
            let technique = Technique::parse(f[0], f[1]).map_err(at)?;
            let class = match f[2] {
                "mirror" => RoughnessClass::Mirror,
                "glossy" => RoughnessClass::Glossy,
                "rough" => RoughnessClass::Rough,
                c => return Err(at(format!("class '{c}' is not mirror, glossy or rough"))),
            };
            let surface = match f[3] {
                "any" => Surface::Any,
                "planar" => Surface::Planar,
                "curved" => Surface::Curved,
                s => return Err(at(format!("surface '{s}' is not any, planar or curved"))),
            };
            let number = |k: usize| -> Result<f32, String> {
                match f[k].parse::<f32>() {
                    Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
                    _ => Err(at(format!(
                        "{} '{}' is not a finite number at least 0",
                        Self::HEADER[k],
                        f[k]
                    ))),
                }
            };
            let count = |k: usize| -> Result<u64, String> {
                f[k].parse::<u64>().map_err(|_| {
                    at(format!(
                        "{} '{}' is not a whole number",
                        Self::HEADER[k],
                        f[k]
                    ))
                })
            };
            let e = CalibrationEntry {
                technique,
                class,
                surface,
                time_ratio: number(4)?,
                error_255: number(5)?,
                pixels: count(6)?,
                frames: u32::try_from(count(7)?)
                    .map_err(|_| at(format!("frames '{}' is too large", f[7])))?,
            };
            if entries
                .iter()
                .any(|o| (o.technique, o.class, o.surface) == (e.technique, e.class, e.surface))
            {
                return Err(at(format!(
                    "{} on {} {} pixels is measured twice",
                    technique.label(),
                    f[3],
                    f[2]
                )));
            }
            entries.push(e);
        }
        if entries.is_empty() {
            return Err("no rows".into());
        }
        Ok(Calibration {
            command,
            commit,
            notes,
            entries,
        })
    }

    /// The table as refl-core's planner reads it: entry `k`'s `id` is `k`.
    /// An error below [`crate::report_out::ERROR_FLOOR`] counts as 0, as
    /// in the report's plot and Pareto front (exact up to a level on a
    /// handful of pixels: the planar pass at full resolution differs from
    /// the rays by 0.0001/255 where a float rounds the other way), so an
    /// exact technique that is faster dominates plain ray tracing.
    pub fn cost_table(&self) -> Vec<CostEntry> {
        self.entries
            .iter()
            .enumerate()
            .map(|(k, e)| CostEntry {
                id: k as u32,
                class: e.class,
                surface: e.surface,
                passes: e.technique.passes(),
                time_ratio: e.time_ratio,
                error_255: if crate::report_out::is_exact(f64::from(e.error_255)) {
                    0.0
                } else {
                    e.error_255
                },
            })
            .collect()
    }

    /// The table as text ([`Calibration::parse`] reads it back).
    pub fn to_csv(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# command: {}", self.command);
        let _ = writeln!(s, "# commit: {}", self.commit);
        for n in &self.notes {
            let _ = writeln!(s, "# {n}");
        }
        let _ = writeln!(s, "{}", Self::HEADER.join(","));
        for e in &self.entries {
            let _ = writeln!(
                s,
                "{},{},{},{},{:.5},{:.4},{},{}",
                e.technique.method(),
                e.technique.setting(),
                class_name(e.class),
                surface_name(e.surface),
                e.time_ratio,
                e.error_255,
                e.pixels,
                e.frames
            );
        }
        s
    }
}
