//! # refl-core
//!
//! Reflection-rendering kernels: pure math over buffers the caller owns.
//!
//! * `#![no_std]`, no allocation: every image, pyramid and scratch buffer is a
//!   view over caller memory ([`ImageView`], [`ImageViewMut`]); size queries
//!   such as [`image::try_required_len`] say how much to allocate.
//! * f32 kernels (what a GPU port would run); the tests carry f64 oracles.
//! * One module per algorithm family, each behind a Cargo feature so that an
//!   engine compiles only what its scenes need. `mirror` is on by default.
//! * Conventions (shared by every module): right-handed world, view space
//!   looks down -Z, "linear depth" is the positive distance along -Z; pixel
//!   `(x, y)` has its center at `(x + 0.5, y + 0.5)`, origin top-left, y down;
//!   depth buffers come in the three [`DepthConvention`]s.
//!
//! # Features
//!
//! | feature | modules | seed (paper) | what it enables |
//! |---|---|---|---|
//! | (always) | `camera`, `error`, `image`, `lobe` | | cameras and the three depth conventions, reprojection, image views over caller memory, the one `Error`; lobe math (roughness to Phong power, the lobe's inverse CDF, cone angle, Hammersley points, lobe and cone sampling) |
//! | `mirror` (default) | `mirror`, `planar` | 001 appendix, 004 Sec. 4.4.3 | planar reflection: mirror matrix, mirrored camera, oblique projection, the planar mirror pass |
//! | `hiz` | `hiz` | 004 (Hi-Z cone tracing) Sec. 4.4.1, 4.4.3, 4.6.6, 4.6.7, 4.7.1 | Hi-Z min/max pyramid and traversal; the mirror pass with `MirrorMethod::HiZ` |
//! | `depth-image` | `step` | 003 (second-order feed-forward) Sec. 3.4 | ray / depth-image intersection by per-pixel stepping; the mirror pass with `MirrorMethod::Step` |
//! | `cone` (implies `hiz`) | `cone`, `glossy` | 004 Sec. 4.4-4.6, 003 Sec. 3.5 | glossy reflections: color and visibility pyramids, cone tracing, multi-ray, the glossy pass |
//! | `layered` | `layered`; `layered_pass` with `depth-image` or `hiz` | 001 (layered depth textures) Sec. 3.2-3.4, Alg. 1 | layered depth cube maps, the potential-reflection-region test, the layered pass, back depth from maps |
//! | `cluster` (implies `depth-image`) | `cluster` | 003 Sec. 3.2-3.5 | second-order reflections: normal-bin clustering, cluster cameras, finalization, the cluster pass |
//! | `tcrr` | `tcrr` | 000 (temporal reflection reprojection) | reflection buffers, neighborhood search, shifting, warping, re-trace list, composition, key-frame policy |
//! | `epipolar` | `epipolar` | 002 (ray-casted walkthroughs) | reprojected ray casting: POS/AIP buffers, epipolar ordering, per-pixel decisions for the host's tracer |
//! | `all` | all of the above | | every family |
//!
//! The shared modules come with the families that use them: `gbuffer`,
//! `trace`, `summary` (the frame summary a planner reads) and `plan` (the
//! passes a frame needs) with `mirror`, `hiz` or `depth-image`; `ssr` (the screen-space
//! mirror pass), `backface` and `temporal` (the history buffer and temporal
//! filter of seed 004 Sec. 4.6.4-4.6.5) with `hiz` or `depth-image`. Each module's
//! documentation has a runnable example (`# Example`) of its main pass or
//! kernel.
//!
//! The specification is five papers ("seeds"); every formula cites the seed
//! and the equation or section it implements. Errata found in the seeds are
//! noted where they are corrected.
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![deny(missing_docs)]
#![deny(unsafe_code)]

#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub mod backface;
pub mod camera;
#[cfg(feature = "cluster")]
pub mod cluster;
#[cfg(feature = "cone")]
pub mod cone;
#[cfg(feature = "epipolar")]
pub mod epipolar;
pub mod error;
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub mod gbuffer;
#[cfg(feature = "cone")]
pub mod glossy;
#[cfg(feature = "hiz")]
pub mod hiz;
pub mod image;
#[cfg(feature = "layered")]
pub mod layered;
#[cfg(all(feature = "layered", any(feature = "depth-image", feature = "hiz")))]
pub mod layered_pass;
pub mod lobe;
#[cfg(feature = "mirror")]
pub mod mirror;
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub mod plan;
#[cfg(feature = "mirror")]
pub mod planar;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub mod ssr;
#[cfg(feature = "depth-image")]
pub mod step;
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub mod summary;
#[cfg(feature = "tcrr")]
pub mod tcrr;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub mod temporal;
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub mod trace;

pub use camera::{Camera, DepthConvention, Ray};
pub use error::Error;
pub use image::{ImageView, ImageViewMut, RowRange};
#[cfg(feature = "layered")]
pub use layered::{
    try_layered_len, try_prr_classify, ColumnFill, ColumnRay, Face, LayerHit, LayeredGrid,
    LayeredHit, LayeredLen, LayeredMap, LayeredMapMut, LayeredMiss, LayeredOptions, LayeredStamp,
    LayeredTrace, LayeredWork, PrrClass, EXIT_ENTRY_TEXELS, LAYERED_STAMP_LEN,
};
#[cfg(all(feature = "layered", any(feature = "depth-image", feature = "hiz")))]
pub use layered_pass::{
    layered_pass_scratch_len, try_prepare_layered_pass, LayeredBound, LayeredHostRay,
    LayeredMapSet, LayeredPass, LayeredPassOptions, LayeredPassSink, LayeredPassStats,
    LayeredPassStatus, LayeredPassTexel,
};
#[cfg(feature = "mirror")]
pub use mirror::{
    mirror_matrix, mirror_point, reflect, try_mirrored_camera, try_oblique_projection, try_reflect,
    Plane,
};
#[cfg(feature = "mirror")]
pub use planar::{
    PlanarOptions, PlanarPass, PlanarRay, PlanarRect, PlanarRender, PlanarSetup, PlanarSink,
    PlanarStats, PlanarStatus, PlanarTexel,
};

#[cfg(all(feature = "layered", any(feature = "depth-image", feature = "hiz")))]
pub use backface::try_back_depth_layered;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub use backface::{try_back_depth, BackDepthStats};
#[cfg(feature = "cone")]
pub use cone::{
    try_build_color_pyramid, try_build_visibility_pyramid, try_color_pyramid_len,
    try_cone_angle_from_phong, try_cone_angle_from_roughness, try_cone_trace, try_multiray,
    try_stamp_color_pyramid, try_stamp_visibility_pyramid, try_visibility_pyramid_len, ColorTexel,
    Cone, ConeOptions, ConePyramids, ConeResult, FadeRange, Fades, MultiRayOptions, MultiRayResult,
    COLOR_STAMP_TEXELS, VISIBILITY_STAMP_LEN,
};
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub use gbuffer::{GBuffer, NormalSpace, Surface};
#[cfg(feature = "cone")]
pub use glossy::{
    try_glossy_scratch_len, try_prepare_glossy, GlossyMethod, GlossyOptions, GlossyPass,
    GlossyScratch, GlossyScratchLen, GlossyScratchMut, GlossySink, GlossyStats, GlossyTexel,
};
#[cfg(feature = "hiz")]
pub use hiz::{
    try_build_hiz, try_build_hiz_level0_rows, try_build_hiz_level_rows, try_hiz_len, try_stamp_hiz,
    try_trace_hiz, try_trace_hiz_rays, try_trace_hiz_stats, HiZ, HiZLayout, HiZLevel, HiZOptions,
    HiZStats, HiZTexel, PyramidBand, PyramidStamp, PyramidTexel, HIZ_STAMP_TEXELS,
};
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub use ssr::{
    HostRay, MirrorMethod, MirrorOptions, MirrorPass, MirrorRay, MirrorSink, MirrorStats,
    MirrorStatus, MirrorTexel,
};
#[cfg(feature = "depth-image")]
pub use step::{try_step, try_step_rays, StepOptions};
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub use trace::{DepthHit, DepthImage, Miss, Thickness, Trace, Work};

#[cfg(feature = "tcrr")]
pub use tcrr::{
    reflection_distance, KeyFramePolicy, Reflected, ReflectionBuffers, TcrrOptions, INVALID_OFFSET,
};

/// Re-export of the glam version refl-core is built against, so that callers
/// can name the exact vector and matrix types of the Rust API.
pub use glam;
