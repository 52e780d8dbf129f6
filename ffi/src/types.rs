//! Flat `#[repr(C)]` value types of the C ABI and their conversions to and
//! from refl-core's types. No glam type crosses the boundary.

use refl_core::glam::{Mat4, Vec2, Vec3};
use refl_core::{Camera, DepthConvention, Error, Ray};

/// A 2-component float vector (a pixel position, or a two-channel texel).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_vec2 {
    /// First component (pixel x: right).
    pub x: f32,
    /// Second component (pixel y: down).
    pub y: f32,
}

/// A 3-component float vector (a point or direction in world space, or a
/// three-channel texel).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_vec3 {
    /// X component.
    pub x: f32,
    /// Y component.
    pub y: f32,
    /// Z component.
    pub z: f32,
}

/// A 4-component float vector (a four-channel texel).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_vec4 {
    /// X (red) component.
    pub x: f32,
    /// Y (green) component.
    pub y: f32,
    /// Z (blue) component.
    pub z: f32,
    /// W (alpha) component.
    pub w: f32,
}

/// An 8-bit RGBA texel.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct refl_rgba8 {
    /// Red.
    pub r: u8,
    /// Green.
    pub g: u8,
    /// Blue.
    pub b: u8,
    /// Alpha.
    pub a: u8,
}

/// A 4x4 float matrix, column-major: element (row r, column c) is
/// `m[4 * c + r]`, the layout of OpenGL and glam. Points are column vectors
/// multiplied on the right (`p' = M p`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_mat4 {
    /// The 16 elements, column by column.
    pub m: [f32; 16],
}

/// A ray `origin + t * dir`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_ray {
    /// Start point, world space.
    pub origin: refl_vec3,
    /// Direction, world space; unit length when produced by refl.
    pub dir: refl_vec3,
}

/// A pinhole camera: world-to-view transform, symmetric perspective
/// projection and image size. A plain value: fill it yourself or get one
/// from `refl_camera_look_at` / `refl_mirror_camera`. Every function that
/// takes a camera validates it (`refl_camera_validate` states the rules).
///
/// Conventions: right-handed world, view space looks down -Z; pixel (x, y)
/// has its center at (x + 0.5, y + 0.5), origin top-left, y down.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct refl_camera {
    /// World-to-view matrix. Its 3x3 part must be orthonormal within 1e-4
    /// (a rotation, or a rotation times a reflection for a mirrored camera)
    /// and its last row must be exactly (0, 0, 0, 1).
    pub view: refl_mat4,
    /// Vertical field of view in radians, in (0, pi).
    pub fov_y: f32,
    /// Near plane distance, finite and > 0. (Named `z_near`, not `near`:
    /// `near` and `far` are macros in <windows.h>.)
    pub z_near: f32,
    /// Far plane distance, > `z_near`; may be +infinity.
    pub z_far: f32,
    /// Image width in pixels, > 0. The aspect ratio is width / height.
    pub width: u32,
    /// Image height in pixels, > 0.
    pub height: u32,
}

/// An oriented plane `dot(normal, p) + d = 0`.
///
/// Planes produced by refl have a unit normal. A plane you fill yourself
/// may have any finite non-zero normal; refl then uses the equivalent
/// `(normal / |normal|, d / |normal|)`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_plane {
    /// Normal (a, b, c); points to the plane's front side.
    pub normal: refl_vec3,
    /// Offset d of `a x + b y + c z + d = 0`.
    pub d: f32,
}

/// A projected or reprojected point: its pixel position and depth, or a
/// flag saying it has none.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct refl_projection {
    /// Pixel x (0 when `valid` is false).
    pub x: f32,
    /// Pixel y (0 when `valid` is false).
    pub y: f32,
    /// Linear depth (`refl_camera_project`, `refl_camera_reproject`) or stored
    /// depth in the matrix's convention (`refl_camera_apply_reprojection`); 0 when
    /// `valid` is false.
    pub depth: f32,
    /// True if the point lies in front of the eye plane and the result is
    /// finite; false for points at or behind the eye, which have no image
    /// position.
    pub valid: bool,
}

/// How a depth buffer encodes distance. Functions take the value as a
/// `uint32_t` and return `REFL_STATUS_INVALID_ARGUMENT` for anything else.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum refl_depth_convention {
    /// Linear view depth: the positive distance along the view's -Z axis.
    Linear = 0,
    /// Post-projection depth in [0, 1], near = 0, far = 1 (D3D, Vulkan,
    /// glClipControl(.., GL_ZERO_TO_ONE)).
    ZeroToOne = 1,
    /// Reversed-Z post-projection depth, near = 1, far = 0; with an
    /// infinite far plane d = near / z.
    ReversedZ = 2,
}

/// Decodes a `refl_depth_convention` passed as `uint32_t`.
pub(crate) fn convention(v: u32) -> Result<DepthConvention, Error> {
    match v {
        0 => Ok(DepthConvention::Linear),
        1 => Ok(DepthConvention::ZeroToOne),
        2 => Ok(DepthConvention::ReversedZ),
        _ => Err(Error::InvalidArgument),
    }
}

impl From<refl_depth_convention> for DepthConvention {
    fn from(c: refl_depth_convention) -> Self {
        match c {
            refl_depth_convention::Linear => Self::Linear,
            refl_depth_convention::ZeroToOne => Self::ZeroToOne,
            refl_depth_convention::ReversedZ => Self::ReversedZ,
        }
    }
}

impl From<Vec2> for refl_vec2 {
    fn from(v: Vec2) -> Self {
        Self { x: v.x, y: v.y }
    }
}
impl From<refl_vec2> for Vec2 {
    fn from(v: refl_vec2) -> Self {
        Vec2::new(v.x, v.y)
    }
}
impl From<Vec3> for refl_vec3 {
    fn from(v: Vec3) -> Self {
        Self {
            x: v.x,
            y: v.y,
            z: v.z,
        }
    }
}
impl From<refl_vec3> for Vec3 {
    fn from(v: refl_vec3) -> Self {
        Vec3::new(v.x, v.y, v.z)
    }
}
impl From<Mat4> for refl_mat4 {
    fn from(m: Mat4) -> Self {
        Self {
            m: m.to_cols_array(),
        }
    }
}
impl From<refl_mat4> for Mat4 {
    fn from(m: refl_mat4) -> Self {
        Mat4::from_cols_array(&m.m)
    }
}
impl From<Ray> for refl_ray {
    fn from(r: Ray) -> Self {
        Self {
            origin: r.origin.into(),
            dir: r.dir.into(),
        }
    }
}

impl From<refl_ray> for Ray {
    fn from(r: refl_ray) -> Self {
        Self {
            origin: r.origin.into(),
            dir: r.dir.into(),
        }
    }
}

impl From<&Camera> for refl_camera {
    fn from(c: &Camera) -> Self {
        Self {
            view: c.view().into(),
            fov_y: c.fov_y(),
            z_near: c.near(),
            z_far: c.far(),
            width: c.width(),
            height: c.height(),
        }
    }
}

impl TryFrom<&refl_camera> for Camera {
    type Error = Error;
    /// Validates through `Camera::try_new`.
    fn try_from(c: &refl_camera) -> Result<Self, Error> {
        Camera::try_new(c.view.into(), c.fov_y, c.z_near, c.z_far, c.width, c.height)
    }
}

/// `Camera::try_from(c)`, with a last-error detail that names the argument
/// `name` and the field that was refused.
pub(crate) fn camera_named(c: &refl_camera, name: &str) -> Result<Camera, Error> {
    Camera::try_from(c).map_err(|e| {
        let why = if c.width == 0 || c.height == 0 {
            "zero width or height"
        } else if !(c.fov_y > 0.0 && c.fov_y < core::f32::consts::PI) {
            "fov_y not in (0, pi)"
        } else if !(c.z_near > 0.0 && c.z_near.is_finite() && (1.0 / c.z_near).is_finite()) {
            "z_near not finite and positive (or 1 / z_near overflows)"
        } else if !(c.z_far > c.z_near) {
            "z_far not beyond z_near"
        } else if !c.view.m.iter().all(|v| v.is_finite()) {
            "view matrix not finite"
        } else if e == Error::InvalidArgument {
            "projection scale (1 / tan(fov_y / 2), times the aspect) or eye not representable in f32"
        } else {
            "view matrix not a rigid transform (rotation and translation)"
        };
        crate::status::fail(e, format_args!("`{name}`: {why}"))
    })
}

#[cfg(feature = "mirror")]
impl From<&refl_core::Plane> for refl_plane {
    fn from(p: &refl_core::Plane) -> Self {
        Self {
            normal: p.normal().into(),
            d: p.d(),
        }
    }
}

#[cfg(feature = "mirror")]
impl TryFrom<&refl_plane> for refl_core::Plane {
    type Error = Error;
    /// Rebuilds a core plane with `Plane::try_new`: a unit normal and its
    /// `d` are kept bit for bit; a non-unit normal is normalized and `d`
    /// scaled with it.
    ///
    /// Errors: `InvalidArgument` for a non-finite normal or `d`,
    /// `DegenerateGeometry` for a zero normal.
    fn try_from(p: &refl_plane) -> Result<Self, Error> {
        refl_core::Plane::try_new(p.normal.into(), p.d)
    }
}

impl refl_projection {
    /// A valid projection from core's `(x, y, depth)` or an invalid one.
    pub(crate) fn from_option(p: Option<Vec3>) -> Self {
        match p {
            Some(v) => Self {
                x: v.x,
                y: v.y,
                depth: v.z,
                valid: true,
            },
            None => Self::default(),
        }
    }
}

// Texel layouts the image views reinterpret: refl's vector structs must be
// the core's array texels, bit for bit.
const _: () = {
    use core::mem::{align_of, size_of};
    assert!(size_of::<refl_vec2>() == size_of::<[f32; 2]>());
    assert!(align_of::<refl_vec2>() == align_of::<[f32; 2]>());
    assert!(size_of::<refl_vec3>() == size_of::<[f32; 3]>());
    assert!(align_of::<refl_vec3>() == align_of::<[f32; 3]>());
    assert!(size_of::<refl_vec4>() == size_of::<[f32; 4]>());
    assert!(align_of::<refl_vec4>() == align_of::<[f32; 4]>());
    assert!(size_of::<refl_rgba8>() == size_of::<[u8; 4]>());
    assert!(align_of::<refl_rgba8>() == align_of::<[u8; 4]>());
    assert!(size_of::<refl_mat4>() == 64);
    assert!(size_of::<refl_camera>() == 84);
    // refl_status is a uint32_t on the wire.
    assert!(size_of::<crate::refl_status>() == 4);
};

// ---------------------------------------------------------------------------
// Seed 003 clusters (`refl_core::cluster`).

/// Clustering options (seed 003 Sec. 3.2). Defaults:
/// `refl_cluster_options_default`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg(feature = "cluster")]
pub struct refl_cluster_options {
    /// Azimuth bins of an object covering the whole frame alone (seed: 13),
    /// 1..=1024.
    pub max_theta_bins: u32,
    /// Polar bins of an object covering the whole frame alone (seed: 8),
    /// 1..=1024.
    pub max_phi_bins: u32,
    /// Multiplier of the seed's modulation a_R / n_v (seed: 1), finite and
    /// > 0: larger gives more, smaller clusters.
    pub gain: f32,
}

#[cfg(feature = "cluster")]
impl From<refl_core::cluster::ClusterOptions> for refl_cluster_options {
    fn from(p: refl_core::cluster::ClusterOptions) -> Self {
        Self {
            max_theta_bins: p.max_theta_bins,
            max_phi_bins: p.max_phi_bins,
            gain: p.gain,
        }
    }
}

#[cfg(feature = "cluster")]
impl From<refl_cluster_options> for refl_core::cluster::ClusterOptions {
    fn from(p: refl_cluster_options) -> Self {
        Self {
            max_theta_bins: p.max_theta_bins,
            max_phi_bins: p.max_phi_bins,
            gain: p.gain,
        }
    }
}

/// The bins of one reflective object in the current frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg(feature = "cluster")]
pub struct refl_cluster_object_bins {
    /// Azimuth bins (0 if the object is not visible).
    pub theta_bins: u32,
    /// Polar bins (0 if the object is not visible).
    pub phi_bins: u32,
    /// Cluster id of the object's first bin.
    pub first: u32,
}

#[cfg(feature = "cluster")]
impl From<refl_core::cluster::ObjectBins> for refl_cluster_object_bins {
    fn from(b: refl_core::cluster::ObjectBins) -> Self {
        Self {
            theta_bins: b.theta_bins,
            phi_bins: b.phi_bins,
            first: b.first,
        }
    }
}

#[cfg(feature = "cluster")]
impl From<refl_cluster_object_bins> for refl_core::cluster::ObjectBins {
    fn from(b: refl_cluster_object_bins) -> Self {
        Self {
            theta_bins: b.theta_bins,
            phi_bins: b.phi_bins,
            first: b.first,
        }
    }
}

/// Cluster camera options (seed 003 Sec. 3.3, 3.5). Defaults:
/// `refl_cluster_camera_options_default`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg(feature = "cluster")]
pub struct refl_cluster_camera_options {
    /// D: distance from the image plane to the far plane (the scene
    /// diameter for mirrors, nearer for glossy clusters), finite and > 0.
    pub far_distance: f32,
    /// Half-angle (radians, [0, 1.5)) of the glossy cone the frame must hold;
    /// 0 for mirrors.
    pub cone_half_angle: f32,
    /// Multiplier of the resolution from the cluster's pixel spacing,
    /// finite and > 0.
    pub resolution_scale: f32,
    /// Largest depth-image width or height, > 0.
    pub max_resolution: u32,
    /// Clusters with fewer pixels fall back, >= 2.
    pub min_pixels: u32,
    /// Upper bound of f (Eq. 1), >= 1; also f when d_F <= d_n.
    pub max_f: f32,
    /// The cluster pass brings a glossy cluster's far plane to
    /// min(D, r / tan(lobe max_angle)): where the lobe's cone has spread
    /// over a disc of radius r (world units, Sec. 3.5 item 2); > 0,
    /// +infinity (the default) keeps D.
    pub glossy_blur_radius: f32,
}

#[cfg(feature = "cluster")]
impl From<refl_core::cluster::ClusterCameraOptions> for refl_cluster_camera_options {
    fn from(p: refl_core::cluster::ClusterCameraOptions) -> Self {
        Self {
            far_distance: p.far_distance,
            cone_half_angle: p.cone_half_angle,
            resolution_scale: p.resolution_scale,
            max_resolution: p.max_resolution,
            min_pixels: p.min_pixels,
            max_f: p.max_f,
            glossy_blur_radius: p.glossy_blur_radius,
        }
    }
}

#[cfg(feature = "cluster")]
impl From<refl_cluster_camera_options> for refl_core::cluster::ClusterCameraOptions {
    fn from(p: refl_cluster_camera_options) -> Self {
        Self {
            far_distance: p.far_distance,
            cone_half_angle: p.cone_half_angle,
            resolution_scale: p.resolution_scale,
            max_resolution: p.max_resolution,
            min_pixels: p.min_pixels,
            max_f: p.max_f,
            glossy_blur_radius: p.glossy_blur_radius,
        }
    }
}

/// Why a cluster gets no camera (its pixels fall back to the environment);
/// `REFL_CLUSTER_FALLBACK_NONE` when it has one.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg(feature = "cluster")]
pub enum refl_cluster_fallback {
    /// The cluster has a camera.
    None = 0,
    /// Fewer than `min_pixels` pixels (one-pixel clusters among them).
    TooFewPixels = 1,
    /// The normals cancel out or their mean faces away from the eye.
    FacesAway = 2,
    /// No reflected ray reaches the far plane.
    NoRays = 3,
    /// The rays span more than a pinhole frustum holds.
    TooWide = 4,
    /// The camera is not representable (f32 overflow, a degenerate
    /// frustum); only `refl_cluster_plan` records it (`refl_cluster_build_camera`
    /// returns `REFL_STATUS_DEGENERATE_GEOMETRY` instead).
    Degenerate = 5,
}

#[cfg(feature = "cluster")]
impl From<refl_core::cluster::ClusterFallback> for refl_cluster_fallback {
    fn from(f: refl_core::cluster::ClusterFallback) -> Self {
        use refl_core::cluster::ClusterFallback as F;
        match f {
            F::TooFewPixels => Self::TooFewPixels,
            F::FacesAway => Self::FacesAway,
            F::NoRays => Self::NoRays,
            F::TooWide => Self::TooWide,
            F::Degenerate => Self::Degenerate,
        }
    }
}

#[cfg(feature = "cluster")]
impl refl_cluster_fallback {
    /// The reason of a `refl_cluster_camera.fallback` value: `None` for
    /// `REFL_CLUSTER_FALLBACK_NONE` or an unknown value.
    pub(crate) fn reason(v: u32) -> Option<refl_core::cluster::ClusterFallback> {
        use refl_core::cluster::ClusterFallback as F;
        Some(match v {
            1 => F::TooFewPixels,
            2 => F::FacesAway,
            3 => F::NoRays,
            4 => F::TooWide,
            5 => F::Degenerate,
            _ => return None,
        })
    }
}

/// A cluster camera (seed 003 Sec. 3.3), or a fallback reason.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg(feature = "cluster")]
pub struct refl_cluster_camera {
    /// `REFL_CLUSTER_FALLBACK_NONE` (0) if the fields below describe a
    /// camera, else the `refl_cluster_fallback` reason (other fields 0).
    pub fallback: u32,
    /// The camera to render the cluster depth image with.
    pub camera: refl_camera,
    /// Render only geometry strictly on the positive side of this plane
    /// (unit normal).
    pub clip: refl_plane,
    /// Centroid P_c of the cluster's surface points.
    pub centroid: refl_vec3,
    /// Unit mean normal n_c, toward the eye.
    pub normal: refl_vec3,
    /// The mirrored eye e_0.
    pub eye0: refl_vec3,
    /// f of Eq. 1 after its guards (1 exactly for planar clusters).
    pub f: f32,
    /// Eq. 1's diagonals d_n, d_f, d_F.
    pub diagonals: [f32; 3],
    /// Every pixel on the image plane with the mean normal: the camera
    /// eye is e_0 exactly.
    pub planar: bool,
    /// The cluster is concave (seed 003 Sec. 4.4): the center of the
    /// paraboloid fitted to its points lies behind the image plane by more
    /// than 1e-4 of its extent. Never for a planar cluster.
    pub concave: bool,
    /// D, the far plane's distance from the image plane.
    pub far_distance: f32,
    /// Pixels whose reflected ray reaches the far plane.
    pub pixels_used: u32,
}

#[cfg(feature = "cluster")]
impl refl_cluster_camera {
    /// A camera result, or a fallback with zeroed fields.
    pub fn from_view(v: &refl_core::cluster::ClusterView) -> Self {
        use refl_core::cluster::ClusterView;
        match v {
            ClusterView::Camera(c) => Self {
                fallback: refl_cluster_fallback::None as u32,
                camera: (&c.camera).into(),
                clip: refl_plane {
                    normal: c.clip.normal.into(),
                    d: -c.clip.normal.dot(c.clip.point),
                },
                centroid: c.centroid.into(),
                normal: c.normal.into(),
                eye0: c.eye0.into(),
                f: c.f,
                diagonals: c.diagonals,
                planar: c.planar,
                concave: c.concave,
                far_distance: c.far_distance,
                pixels_used: c.pixels_used,
            },
            ClusterView::Fallback(r) => Self {
                fallback: refl_cluster_fallback::from(*r) as u32,
                camera: refl_camera {
                    view: refl_mat4 { m: [0.0; 16] },
                    fov_y: 0.0,
                    z_near: 0.0,
                    z_far: 0.0,
                    width: 0,
                    height: 0,
                },
                clip: refl_plane::default(),
                centroid: refl_vec3::default(),
                normal: refl_vec3::default(),
                eye0: refl_vec3::default(),
                f: 0.0,
                diagonals: [0.0; 3],
                planar: false,
                concave: false,
                far_distance: 0.0,
                pixels_used: 0,
            },
        }
    }
}

#[cfg(feature = "cluster")]
impl TryFrom<&refl_cluster_camera> for refl_core::cluster::ClusterCamera {
    type Error = Error;
    /// `InvalidArgument` for a fallback record or a non-unit clip normal;
    /// the camera's own status if it is invalid. The remaining fields are
    /// validated by `refl_cluster_finalize`.
    fn try_from(c: &refl_cluster_camera) -> Result<Self, Error> {
        if c.fallback != refl_cluster_fallback::None as u32 {
            return Err(Error::InvalidArgument);
        }
        let camera = camera_named(&c.camera, "camera")?;
        let n = Vec3::from(c.clip.normal);
        if !(n.is_finite() && c.clip.d.is_finite() && (n.length_squared() - 1.0).abs() <= 1e-3) {
            return Err(Error::InvalidArgument);
        }
        Ok(Self {
            camera,
            clip: refl_core::cluster::ClipPlane {
                point: -n * c.clip.d,
                normal: n,
            },
            centroid: c.centroid.into(),
            normal: c.normal.into(),
            eye0: c.eye0.into(),
            f: c.f,
            diagonals: c.diagonals,
            planar: c.planar,
            concave: c.concave,
            far_distance: c.far_distance,
            pixels_used: c.pixels_used,
        })
    }
}

/// The reflected rays per pixel (seed 003 Sec. 3.5): one mirror ray, or a
/// truncated Phong lobe.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg(feature = "cluster")]
pub struct refl_cluster_lobe {
    /// Rays per pixel: 1 = the mirror ray only; 2..=64 sample the lobe.
    pub rays: u32,
    /// Phong exponent n of cos^n around the mirror direction (finite,
    /// >= 0; ignored for one ray).
    pub exponent: f32,
    /// Truncation half-angle in radians, (0, 1.5) (ignored for one ray);
    /// `refl_cluster_lobe_angle` gives the angle holding a share of the energy.
    pub max_angle: f32,
}

#[cfg(feature = "cluster")]
impl From<refl_core::cluster::Lobe> for refl_cluster_lobe {
    fn from(l: refl_core::cluster::Lobe) -> Self {
        Self {
            rays: l.rays,
            exponent: l.exponent,
            max_angle: l.max_angle,
        }
    }
}

// `refl_cluster_objects.lobes` is read in place as refl-core's lobes.
#[cfg(feature = "cluster")]
const _: () = {
    use core::mem::{align_of, offset_of, size_of};
    use refl_core::cluster::Lobe;
    assert!(size_of::<refl_cluster_lobe>() == size_of::<Lobe>());
    assert!(align_of::<refl_cluster_lobe>() == align_of::<Lobe>());
    assert!(offset_of!(refl_cluster_lobe, rays) == offset_of!(Lobe, rays));
    assert!(offset_of!(refl_cluster_lobe, exponent) == offset_of!(Lobe, exponent));
    assert!(offset_of!(refl_cluster_lobe, max_angle) == offset_of!(Lobe, max_angle));
};

#[cfg(feature = "cluster")]
impl From<refl_cluster_lobe> for refl_core::cluster::Lobe {
    fn from(l: refl_cluster_lobe) -> Self {
        Self {
            rays: l.rays,
            exponent: l.exponent,
            max_angle: l.max_angle,
        }
    }
}

/// The reflection of one cluster pixel (`refl_cluster_finalize`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg(feature = "cluster")]
pub struct refl_cluster_shade {
    /// Sum of hit colors times their weights over the traced rays; the
    /// reflection is rgb + env_weight * env(env_dir) + (1 - hit_weight -
    /// env_weight) * diffuse.
    pub rgb: refl_vec3,
    /// Sum of hit weights over the traced rays.
    pub hit_weight: f32,
    /// Share of the traced rays that fell back to the environment.
    pub env_weight: f32,
    /// Mean direction of the rays that fell back (the mirror direction if
    /// none did).
    pub env_dir: refl_vec3,
    /// The pixel's mirror direction.
    pub mirror_dir: refl_vec3,
    /// Rays traced.
    pub rays: u32,
    /// Rays that hit.
    pub hits: u32,
    /// Depth texels read over all rays.
    pub fetches: u32,
    /// Steps over all rays.
    pub steps: u32,
    /// Rays answered by their concave cluster itself (seed 003 Sec. 4.4,
    /// `refl_cluster_pass_options.second_intersection`), within `hits`;
    /// always 0 from `refl_cluster_finalize`.
    pub self_hits: u32,
}

#[cfg(feature = "cluster")]
impl From<refl_core::cluster::ClusterShade> for refl_cluster_shade {
    fn from(s: refl_core::cluster::ClusterShade) -> Self {
        (&s).into()
    }
}

#[cfg(feature = "cluster")]
impl From<&refl_core::cluster::ClusterShade> for refl_cluster_shade {
    fn from(s: &refl_core::cluster::ClusterShade) -> Self {
        Self {
            rgb: s.rgb.into(),
            hit_weight: s.hit_weight,
            env_weight: s.env_weight,
            env_dir: s.env_dir.into(),
            mirror_dir: s.mirror_dir.into(),
            rays: s.rays,
            hits: s.hits,
            fetches: s.fetches,
            steps: s.steps,
            self_hits: s.self_hits,
        }
    }
}

/// One fade of the cone tracing (seed 004 Listing 4.8), when `enabled`:
/// the factor is 1 at or below `start`, 0 at or above `end`, linear
/// between.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg(feature = "cone")]
pub struct refl_cone_fade_range {
    /// Whether this fade applies.
    pub enabled: bool,
    /// Where the fade begins.
    pub start: f32,
    /// Where it reaches 0; must be greater than `start`.
    pub end: f32,
}

/// The fades of seed 004 Sec. 4.6.1 (`refl_core::cone::Fades`); a fade
/// whose `enabled` is false is left out.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg(feature = "cone")]
pub struct refl_cone_fades {
    /// Over `dot(reflected, toward_eye)` in [-1, 1].
    pub toward_camera: refl_cone_fade_range,
    /// Over `max(|2u - 1|, |2v - 1|)` of the normalized hit position (1 on
    /// the border).
    pub border: refl_cone_fade_range,
    /// Over the ray's travel distance in world units.
    pub travel: refl_cone_fade_range,
}

/// Settings of the cone trace (`refl_core::cone::ConeOptions`);
/// `refl_cone_options_default` gives 8 circles, bias 0, visibility on,
/// isotropic, 1% depth tolerance.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg(feature = "cone")]
pub struct refl_cone_options {
    /// Most circles (clamped to 64).
    pub max_circles: u32,
    /// Added to the circle's mip level `log2(2 r)` (-1 is the seed's
    /// `log2(r)`); finite.
    pub level_bias: f32,
    /// Weight samples by the pre-integrated visibility.
    pub use_visibility: bool,
    /// Largest anisotropic stretch at grazing angles (seed 004
    /// Sec. 4.6.8), `>= 1`; 1 is isotropic.
    pub max_stretch: f32,
    /// Relative depth tolerance of the cone sphere weight, `>= 0`.
    pub depth_tolerance: f32,
    /// Divide by the accumulated coverage (a weighted mean of the samples);
    /// false: the uncovered rest blends the fallback (the seed).
    pub normalize: bool,
}

/// A screen-space cone: apex at the reflection ray's start, axis to its
/// Hi-Z hit (`refl_core::cone::Cone`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg(feature = "cone")]
pub struct refl_cone {
    /// Apex: the reflection ray's start projected, level-0 pixels.
    pub apex: refl_vec2,
    /// Linear depth of the apex, > 0.
    pub apex_depth: f32,
    /// The hit pixel (`refl_trace_result::pixel`).
    pub hit: refl_vec2,
    /// Linear depth of the hit (`refl_trace_result::depth`), > 0.
    pub hit_depth: f32,
    /// Half-angle in radians, in [0, pi/2) (`refl_cone_angle_from_*`).
    pub theta: f32,
    /// `dot(normal, toward_eye)` of the reflector, for the anisotropic
    /// stretch; 1 when unused.
    pub n_dot_v: f32,
    /// World distance from the apex to the hit (`refl_trace_result::t`) for
    /// the view-space cone size, or 0 for the seed's screen-space triangle;
    /// finite, >= 0.
    pub travel: f32,
}

/// What `refl_cone_trace` returns.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg(feature = "cone")]
pub struct refl_cone_result {
    /// The integrated color, the uncovered rest blended with the fallback.
    pub color: refl_vec3,
    /// Accumulated coverage in [0, 1] (1 - the fallback's weight).
    pub coverage: f32,
    /// Circles taken.
    pub circles: u32,
    /// Pyramid texels read.
    pub fetches: u32,
}

/// Settings of `refl_cone_multiray` (`refl_core::cone::MultiRayOptions`);
/// `refl_cone_multiray_options_default` gives the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg(feature = "cone")]
pub struct refl_cone_multiray_options {
    /// Rays per pixel, > 0 (seed 003 Sec. 3.5 uses 8 to 49).
    pub rays: u32,
    /// Cranley-Patterson rotation of the Hammersley set, finite (e.g.
    /// hashed from the pixel index).
    pub rotation: refl_vec2,
    /// Hi-Z settings of each ray.
    pub hiz: crate::hiz::refl_hiz_options,
}

/// What `refl_cone_multiray` returns.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg(feature = "cone")]
pub struct refl_cone_multiray_result {
    /// The Phong-weighted mean color.
    pub color: refl_vec3,
    /// Rays traced (not below the surface).
    pub traced: u32,
    /// Rays that hit in screen space.
    pub hits: u32,
    /// Hi-Z iterations summed over the rays.
    pub iterations: u32,
}
