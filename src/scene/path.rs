//! Camera paths: poses on an orbit, uniform Catmull-Rom splines through
//! points, and [`Scene::pose_at`], the interpolation between a scene's poses.

use super::{CameraPose, Scene};
use glam::Vec3;
use std::path::Path;

/// Vertical field of view of a camera-path file's poses without one.
const PATH_FILE_FOV_DEG: f32 = 60.0;

/// Reads a camera path from a text file: one pose per line,
/// `eye_x eye_y eye_z target_x target_y target_z [fov_y_degrees]`
/// separated by commas or whitespace; empty lines and lines starting with
/// `#` are skipped. Up is +y; the field of view defaults to 60 degrees.
///
/// # Errors
/// A message naming the file and line for an unreadable file, a line that
/// is not 6 or 7 numbers, a non-finite value, an eye equal to its target,
/// a view straight up or down (the up vector is +y), a field of view
/// outside (0, 180) degrees, or fewer than two poses.
pub fn load_camera_path(path: &Path) -> Result<Vec<CameraPose>, String> {
    let file = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| format!("{file}: {e}"))?;
    let mut poses = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let at = format!("{file}: line {}", k + 1);
        let v = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| {
                t.parse::<f32>()
                    .map_err(|e| format!("{at}: '{t}' is not a number ({e})"))
            })
            .collect::<Result<Vec<f32>, String>>()?;
        if !(v.len() == 6 || v.len() == 7) {
            return Err(format!(
                "{at}: expected 6 or 7 numbers (eye x y z, target x y z, optional field of view in degrees), \
                 found {}",
                v.len()
            ));
        }
        if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
            return Err(format!("{at}: non-finite value {bad}"));
        }
        let (eye, target) = (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]));
        let dir = target - eye;
        if dir == Vec3::ZERO {
            return Err(format!("{at}: the eye is its target"));
        }
        if dir.normalize().cross(Vec3::Y).length() < 1e-4 {
            return Err(format!("{at}: the view is straight up or down (up is +y)"));
        }
        let fov = v.get(6).copied().unwrap_or(PATH_FILE_FOV_DEG);
        if !(fov > 0.0 && fov < 180.0) {
            return Err(format!(
                "{at}: field of view {fov} degrees is outside (0, 180)"
            ));
        }
        poses.push(CameraPose {
            eye,
            target,
            up: Vec3::Y,
            fov_y: fov.to_radians(),
        });
    }
    if poses.len() < 2 {
        return Err(format!(
            "{file}: a camera path needs at least 2 poses, found {}",
            poses.len()
        ));
    }
    Ok(poses)
}

impl Scene {
    /// A pose between the path's poses, for frame sequences denser than the
    /// stored path: `s` runs from 0 (first pose) to 1 (last pose, clamped);
    /// eye and target follow uniform Catmull-Rom splines through the stored
    /// poses (so `s = k / (n - 1)` gives pose `k`), up and field of view are
    /// those of the nearest stored pose. `None` for an empty path.
    pub fn pose_at(&self, s: f32) -> Option<CameraPose> {
        let n = self.camera_path.len();
        let nearest = self
            .camera_path
            .get((s.clamp(0.0, 1.0) * (n.max(1) - 1) as f32).round() as usize)?;
        if n == 1 {
            return Some(*nearest);
        }
        let eyes: Vec<Vec3> = self.camera_path.iter().map(|p| p.eye).collect();
        let targets: Vec<Vec3> = self.camera_path.iter().map(|p| p.target).collect();
        Some(CameraPose {
            eye: catmull_rom(&eyes, s),
            target: catmull_rom(&targets, s),
            ..*nearest
        })
    }
}

/// `n` poses on a horizontal arc around `center` (angle 0 on +Z), the eye
/// height moving from `height.0` to `height.1`, all looking at `target`.
pub(super) fn orbit_path(
    center: Vec3,
    radius: f32,
    height: (f32, f32),
    angles: (f32, f32),
    n: usize,
    target: Vec3,
    fov_y: f32,
) -> Vec<CameraPose> {
    (0..n)
        .map(|k| {
            let s = k as f32 / (n - 1) as f32;
            let a = angles.0 + (angles.1 - angles.0) * s;
            let eye = center
                + Vec3::new(
                    radius * a.sin(),
                    height.0 + (height.1 - height.0) * s,
                    radius * a.cos(),
                );
            CameraPose {
                eye,
                target,
                up: Vec3::Y,
                fov_y,
            }
        })
        .collect()
}

/// Uniform Catmull-Rom spline through `points` at parameter `s in [0, 1]`
/// (clamped), end points duplicated.
pub(super) fn catmull_rom(points: &[Vec3], s: f32) -> Vec3 {
    let n = points.len();
    let x = s.clamp(0.0, 1.0) * (n - 1) as f32;
    let i = (x.floor() as usize).min(n - 2);
    let t = x - i as f32;
    let p = |k: isize| points[(i as isize + k).clamp(0, n as isize - 1) as usize];
    let (p0, p1, p2, p3) = (p(-1), p(0), p(1), p(2));
    let t2 = t * t;
    let t3 = t2 * t;
    0.5 * ((2.0 * p1)
        + (p2 - p0) * t
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t3)
}
