//! The report's multi-frame studies: measurements that run once per scene
//! over a camera path or a set of scene variants rather than per frame,
//! each one implementation of [`Study`].
//!
//! Whether a study runs on a scene comes from the scene's [`Content`]: the
//! TCRR path and the temporal-filtering path wherever there is a camera
//! path and reflective pixels, multiple bounces wherever perfect mirrors
//! are in view, the
//! glossy study wherever glossy reflectors are in view, the epipolar path
//! wherever the camera path runs inside walls (an interior walk).

use super::content::Content;
use super::Sizes;
use crate::report_out::Row;
use crate::scene::Scene;
use crate::shade::Shader;
use crate::tracer::Tracer;
use std::path::Path;

/// What a study sees of a scene.
pub struct SceneRun<'a> {
    /// Scene label (rows, file names).
    pub label: &'a str,
    /// The scene.
    pub scene: &'a Scene,
    /// Its tracer.
    pub tracer: &'a Tracer,
    /// Its shader.
    pub shader: &'a Shader<'a>,
    /// Sizes of the run.
    pub sizes: &'a Sizes,
    /// Worker threads of `pool`.
    pub threads: usize,
    /// Every timed pass's pool.
    pub pool: &'a rayon::ThreadPool,
    /// The images folder.
    pub images: &'a Path,
}

/// What a study produced.
#[derive(Default)]
pub struct StudyOut {
    /// Rows of `summary.csv`.
    pub rows: Vec<Row>,
    /// Lines for the scene's notes in `summary.md`.
    pub notes: String,
    /// A section of its own in `summary.md` (after the summary table).
    pub section: String,
}

impl StudyOut {
    /// Rows and notes, no section of its own.
    pub fn of_rows((rows, notes): (Vec<Row>, String)) -> Self {
        Self {
            rows,
            notes,
            section: String::new(),
        }
    }
}

/// A multi-frame study of the report.
pub trait Study {
    /// What `summary.md` calls the study.
    fn name(&self) -> &'static str;
    /// The method names of its rows (`--method` selects them).
    fn methods(&self) -> &'static [&'static str];
    /// Whether the study can run on a scene with `content`.
    ///
    /// # Errors
    /// The reason the scene's content rules the study out.
    fn applies(&self, content: &Content) -> Result<(), String>;
    /// Runs the study's `selected` methods on `s`.
    ///
    /// # Errors
    /// A message naming the scene and what failed.
    fn run(&self, s: &SceneRun<'_>, selected: &[&str]) -> Result<StudyOut, String>;
}

/// Every study, in report order.
pub fn all() -> Vec<Box<dyn Study>> {
    vec![
        Box::new(TcrrPath),
        Box::new(TemporalPath),
        Box::new(Bounces),
        Box::new(GlossyStudy),
        Box::new(EpipolarPath),
        Box::new(ClusterResolution),
    ]
}

/// Seed 003's Table 4: the cluster method at several output resolutions
/// ([`super::cluster_res::report_rows`]), `--long` only.
struct ClusterResolution;

impl Study for ClusterResolution {
    fn name(&self) -> &'static str {
        "cluster output resolution"
    }

    fn methods(&self) -> &'static [&'static str] {
        &["cluster"]
    }

    fn applies(&self, content: &Content) -> Result<(), String> {
        if content.reflective_pixels == 0 {
            Err("no reflective pixels in view".into())
        } else {
            Ok(())
        }
    }

    fn run(&self, s: &SceneRun<'_>, _selected: &[&str]) -> Result<StudyOut, String> {
        if s.sizes.level != super::Level::Long {
            return Ok(StudyOut::default());
        }
        super::cluster_res::report_rows(s).map(StudyOut::of_rows)
    }
}

/// Seed 004's temporal filtering of the Hi-Z mirror pass along a dense
/// stretch of the camera path ([`super::temporal::report_rows`]).
struct TemporalPath;

impl Study for TemporalPath {
    fn name(&self) -> &'static str {
        "temporal path"
    }

    fn methods(&self) -> &'static [&'static str] {
        &["hiz-temporal"]
    }

    fn applies(&self, content: &Content) -> Result<(), String> {
        TcrrPath.applies(content)
    }

    fn run(&self, s: &SceneRun<'_>, _selected: &[&str]) -> Result<StudyOut, String> {
        super::temporal::report_rows(s).map(StudyOut::of_rows)
    }
}

/// Seed 004's multiple bounces (Sec. 4.6.4) on a static camera at the
/// first pose ([`super::bounce::report_rows`]).
struct Bounces;

impl Study for Bounces {
    fn name(&self) -> &'static str {
        "multiple bounces"
    }

    fn methods(&self) -> &'static [&'static str] {
        &[super::bounce::METHOD]
    }

    fn applies(&self, content: &Content) -> Result<(), String> {
        if content.path_poses == 0 {
            Err("no camera pose".into())
        } else if content.reflective_pixels == content.glossy_pixels {
            Err("no perfect mirror in view".into())
        } else {
            Ok(())
        }
    }

    fn run(&self, s: &SceneRun<'_>, _selected: &[&str]) -> Result<StudyOut, String> {
        super::bounce::report_rows(s).map(StudyOut::of_rows)
    }
}

/// Seed 000's temporally coherent reflection reprojection and its naive
/// warping baseline along a dense stretch of the camera path
/// ([`super::tcrr::report_rows`]).
struct TcrrPath;

impl Study for TcrrPath {
    fn name(&self) -> &'static str {
        "TCRR path"
    }

    fn methods(&self) -> &'static [&'static str] {
        &["tcrr", "naive-warp"]
    }

    fn applies(&self, content: &Content) -> Result<(), String> {
        if content.path_poses < 2 {
            Err("no camera path".into())
        } else if content.reflective_pixels == 0 {
            Err("no reflective pixels in view".into())
        } else {
            Ok(())
        }
    }

    fn run(&self, s: &SceneRun<'_>, selected: &[&str]) -> Result<StudyOut, String> {
        super::tcrr::report_rows(
            s,
            selected.contains(&"tcrr"),
            selected.contains(&"naive-warp"),
        )
        .map(StudyOut::of_rows)
    }
}

/// Cone tracing (seed 004) and multi-ray (seed 003 Sec. 3.5) against the
/// Monte-Carlo reference at low sample counts on the scene's reflectors
/// made glossy ([`super::glossy::report_rows`]).
struct GlossyStudy;

impl Study for GlossyStudy {
    fn name(&self) -> &'static str {
        "glossy study"
    }

    fn methods(&self) -> &'static [&'static str] {
        &["cone", "multiray"]
    }

    fn applies(&self, content: &Content) -> Result<(), String> {
        if content.glossy_pixels == 0 {
            Err("no glossy reflector in view".into())
        } else {
            Ok(())
        }
    }

    fn run(&self, s: &SceneRun<'_>, selected: &[&str]) -> Result<StudyOut, String> {
        // Quick (CI): half the frame, 64-sample ground truth.
        let sizes = s.sizes;
        let scale = if sizes.quick() { 2 } else { 1 };
        let study = super::glossy::StudySizes {
            width: sizes.width / scale,
            height: sizes.height / scale,
            truth_samples: sizes.glossy_truth_samples,
            runs: sizes.runs,
            level: sizes.level,
        };
        let (rows, section) = super::glossy::report_rows(
            s.scene,
            s.tracer,
            study,
            (selected.contains(&"cone"), selected.contains(&"multiray")),
            s.threads,
            s.pool,
            s.images,
        )?;
        Ok(StudyOut {
            rows,
            notes: String::new(),
            section,
        })
    }
}

/// Seed 002's reprojected ray casting of primary visibility along the
/// camera path, against ORSA and IRSA ([`crate::epipolar::measure`],
/// [`super::epipolar::rows`]).
struct EpipolarPath;

impl Study for EpipolarPath {
    fn name(&self) -> &'static str {
        "epipolar walkthrough"
    }

    fn methods(&self) -> &'static [&'static str] {
        &crate::epipolar::METHODS
    }

    fn applies(&self, content: &Content) -> Result<(), String> {
        if content.path_poses < 2 {
            Err("no camera path".into())
        } else if !content.interior {
            Err("the camera path does not run inside walls (not an interior walk)".into())
        } else {
            Ok(())
        }
    }

    fn run(&self, s: &SceneRun<'_>, selected: &[&str]) -> Result<StudyOut, String> {
        let measured = crate::epipolar::measure(
            s.scene,
            s.tracer,
            &s.sizes.path,
            s.sizes.runs,
            s.pool,
            Some(s.images),
        )?;
        let (rows, notes) =
            super::epipolar::rows(s.scene, &s.sizes.path, &measured, s.threads, Some(s.images))?;
        Ok(StudyOut {
            rows: rows
                .into_iter()
                .filter(|r| selected.contains(&r.method.as_str()))
                .collect(),
            notes,
            section: String::new(),
        })
    }
}
