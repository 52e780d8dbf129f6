//! # refl-core
//!
//! Reflection-rendering kernels: pure math over buffers the caller owns.
//!
//! * `#![no_std]`, no allocation: every image, pyramid and scratch buffer is a
//!   view over caller memory ([`ImageView`], [`ImageViewMut`]); size queries
//!   such as [`image::try_required_len`] say how much to allocate.
//! * f32 kernels (what a GPU port would run); the tests carry f64 oracles.
//! * Safe code (`#![deny(unsafe_code)]`) but for two audited modules, both
//!   x86-64 only: the SSE2 loads of the Hi-Z pyramid's 2x2 fold (`hiz.rs`,
//!   module `sse2`, each load with its bounds argument) and the Hi-Z
//!   walk's AVX2 ray stream (`hiz/avx2.rs`: its gathers read texel indices
//!   checked against the pyramid's length; entered only where CPUID says
//!   AVX2 runs, via the `cpufeatures` crate).
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
//! mirror pass), `backface`, `temporal` (the history buffer and temporal
//! filter of seed 004 Sec. 4.6.4-4.6.5), `bounce` (multiple bounces from
//! the previous final image, Sec. 4.6.4), `extrapolate` (the bilateral
//! dilation of Sec. 4.6.2) and `upsample` (fewer rays:
//! half-resolution and staggered tracing, cross-bilateral upsampling,
//! temporal super-sampling; seed 004 Sec. 4.7.3-4.7.4) with `hiz` or
//! `depth-image`. Each module's
//! documentation has a runnable example (`# Example`) of its main pass or
//! kernel.
//!
//! The specification is five papers ("seeds"); every formula cites the seed
//! and the equation or section it implements. Errata found in the seeds are
//! noted where they are corrected.
//!
//! # Seeds to items
//!
//! Where each cited section, algorithm and equation of the seeds is
//! implemented (paths from the crate root; each item needs its module's
//! feature). The seeds: 000 Xie, Wang, Dutré, "Reflection reprojection
//! using temporal coherence" (TCRR); 001 Zhang, Hsieh, Shen, "Real-time
//! Reflections on Curved Objects Using Layered Depth Textures"; 002 Havran,
//! Bittner, Seidel, "Exploiting Temporal Coherence in Ray Casted
//! Walkthroughs"; 003 Wang, Xie, Ke, Popescu, "Second-Order Feed-Forward
//! Rendering for Specular and Glossy Reflections"; 004 Uludag, "Hi-Z
//! Screen-Space Cone-Traced Reflections".
//!
//! | seed | section / equation | item |
//! |---|---|---|
//! | 000 (TCRR) | Alg. 1 (the method: key frame, reuse, re-trace) | `tcrr` |
//! | 000 (TCRR) | Sec. 3.1 reflection buffers generation | `tcrr::ReflectionBuffers` |
//! | 000 (TCRR) | Sec. 3.2.1 reflection pixel matching, Fig. 4 distance function | `tcrr::reflection_distance` |
//! | 000 (TCRR) | Sec. 3.2.1, Alg. 2 neighborhood search | `tcrr::try_search`, `tcrr::Surfel`, `tcrr::INVALID_OFFSET` |
//! | 000 (TCRR) | Sec. 3.2.2 reflection shifting | `tcrr::try_shift` |
//! | 000 (TCRR) | Sec. 3.2.2, Fig. 5 motion-parallax cuts | `tcrr::TcrrOptions::reflected_discontinuity` |
//! | 000 (TCRR) | Sec. 3.3 depth-based warping | `tcrr::try_warp` |
//! | 000 (TCRR) | Sec. 3.3 re-trace list | `tcrr::try_retrace_list` |
//! | 000 (TCRR) | Sec. 3.3 Fresnel blending, Alg. 1 line 7 composition | `tcrr::fresnel_weight`, `tcrr::try_compose` |
//! | 000 (TCRR) | Sec. 4.1 implementation parameters | `tcrr::TcrrOptions` |
//! | 000 (TCRR) | Sec. 4.3 / 4.4 reflection-reuse strategy | `tcrr::KeyFramePolicy` |
//! | 000 (TCRR) | Sec. 5 (future work): re-trace by local contrast | `tcrr::TcrrOptions::retrace_contrast` |
//! | 001 (layered depth textures) | Sec. 3.2 potential reflection regions, Fig. 2 | `layered::try_prr_classify`, `layered::PrrClass` |
//! | 001 (layered depth textures) | Sec. 3.2 regions per reflector triangle in the pass | `layered_pass::try_prr_masks`, `layered_pass::prr_radii`, `layered_pass::LayeredPass::try_with_regions` |
//! | 001 (layered depth textures) | Sec. 3.3 orthographic face rendering | `layered::LayeredGrid::try_face_ray` |
//! | 001 (layered depth textures) | Sec. 3.3 ray in the object's local space | `layered::LayeredGrid::try_with_transform` |
//! | 001 (layered depth textures) | Sec. 3.3, Alg. 1 linear then binary search | `layered::LayeredMap::try_trace`, `layered::LayeredOptions` |
//! | 001 (layered depth textures) | Sec. 3.3 early-stop threshold | `layered::LayeredOptions::early_stop_texels` |
//! | 001 (layered depth textures) | Sec. 3.4 concave objects: layers, back depth from the opposite face | `layered::LayeredMapMut::try_fill_column` |
//! | 001 (layered depth textures) | Sec. 3.4, Alg. 1 lines 6-17 inside test | `layered::LayeredMap::inside`, `layered::LayeredMap::exit` |
//! | 001 (layered depth textures) | Fig. 5 the face that sees the surface | `layered::LayeredHit::mismatch` |
//! | 001 (layered depth textures) | Sec. 3.2-3.4 as one pass | `layered_pass::LayeredPass` |
//! | 001 (layered depth textures) | Appendix: the reflector plane | `mirror::Plane::try_from_triangle` |
//! | 001 (layered depth textures) | Appendix: mirror matrix and virtual camera | `mirror::mirror_matrix`, `mirror::try_mirrored_camera` |
//! | 001 (layered depth textures) | Appendix: planar reflection pass | `planar::PlanarPass` |
//! | 002 (ray-casted walkthroughs) | Sec. 3.1 data structures (POS, AIP) | `epipolar::PosEntry`, `epipolar::AipEntry` |
//! | 002 (ray-casted walkthroughs) | Sec. 3.2, Alg. 1 reprojection | `epipolar::try_reproject` |
//! | 002 (ray-casted walkthroughs) | Sec. 3.3, Alg. 2 rendering | `epipolar::decide`, `epipolar::try_decide_band` |
//! | 002 (ray-casted walkthroughs) | Sec. 4.1 view frustum error | `epipolar::frustum_contains` |
//! | 002 (ray-casted walkthroughs) | Sec. 4.2 occlusion error: epipoles | `epipolar::Epipoles` |
//! | 002 (ray-casted walkthroughs) | Sec. 4.2, Fig. 4 occlusion-compatible order | `epipolar::Quadrants` |
//! | 002 (ray-casted walkthroughs) | Sec. 4.2 epipolar lines | `epipolar::line_bins`, `epipolar::OCCLUDER_GAP` |
//! | 002 (ray-casted walkthroughs) | Sec. 4.3 regular resampling | `epipolar::resample_slot` |
//! | 002 (ray-casted walkthroughs) | Sec. 4.3.1 abrupt camera motion | `epipolar::EpipolarOptions::abrupt_frames` |
//! | 002 (ray-casted walkthroughs) | Sec. 5.1 implementing reprojection | `epipolar::Reprojector` |
//! | 002 (ray-casted walkthroughs) | Sec. 5.2 handling background | `epipolar::PosEntry::background`, `epipolar::BACKGROUND_OBJECT` |
//! | 002 (ray-casted walkthroughs) | Sec. 5.3 shifting ray origin | `epipolar::EpipolarOptions::shift_origin` |
//! | 002 (ray-casted walkthroughs) | Fig. 6 why a pixel is traced | `epipolar::Reason` |
//! | 003 (second-order feed-forward) | Sec. 3.2 clustering: object shares, bin layout | `cluster::try_count_objects`, `cluster::try_bin_layout` |
//! | 003 (second-order feed-forward) | Sec. 3.2 clustering: normal bins, cluster ids | `cluster::normal_bin`, `cluster::try_assign_clusters`, `cluster::try_cluster_ranges` |
//! | 003 (second-order feed-forward) | Sec. 3.3 cluster camera construction, Eq. 1 | `cluster::try_cluster_camera`, `cluster::ClusterCamera` |
//! | 003 (second-order feed-forward) | Sec. 3.4 reflected ray / depth image intersection | `step::try_step`, `trace::refine_hit` |
//! | 003 (second-order feed-forward) | Sec. 3.1 step 3c, Sec. 3.4 finalization of a cluster | `cluster::try_finalize_cluster` |
//! | 003 (second-order feed-forward) | Sec. 3.5 item 1: the widened cluster frame | `cluster::ClusterCameraOptions::cone_half_angle` |
//! | 003 (second-order feed-forward) | Sec. 3.5 item 2: glossy fade | `cluster::FinalizeInput::fade` |
//! | 003 (second-order feed-forward) | Sec. 3.5 item 3: the lobe of reflected rays | `cluster::Lobe`, `lobe::sample_truncated_phong_lobe` |
//! | 003 (second-order feed-forward) | Sec. 3.5 multi-ray glossy reflections | `cone::try_multiray`, `lobe::phong_lobe_weight`, `lobe::cone_ray_direction` |
//! | 003 (second-order feed-forward) | Sec. 3.2-3.5 as one pass | `cluster::ClusterPass` |
//! | 003 (second-order feed-forward) | Sec. 4.1.1 small clusters | `cluster::ClusterFallback` |
//! | 003 (second-order feed-forward) | Sec. 4.2.2 single-ray glossy reflection with a neighborhood average | `cluster::FinalizeInput::single_ray`, `cluster::ClusterPassOptions::glossy_single_ray` |
//! | 003 (second-order feed-forward) | Sec. 4.4 concave clusters: detection, second intersection | `cluster::center_height`, `cluster::ClusterCamera::concave`, `cluster::ClusterPassOptions::second_intersection` |
//! | 003 (second-order feed-forward) | Sec. 4.3 planar reflectors | `step::try_step` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.4.1 / 4.5.1, Listing 4.3 Hi-Z pass | `hiz::try_build_hiz`, `hiz::try_build_hiz_level_rows` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.4.2 / 4.5.2, Listing 4.4 pre-integration | `cone::try_build_visibility_pyramid`, `cone::try_build_visibility_level_rows` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.4.3, Listings 4.2 / 4.5 ray-tracing pass | `hiz::try_trace_hiz`, `hiz::HiZOptions` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.4.3 reflection vector | `mirror::reflect`, `mirror::try_reflect` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.4.3 depth linear in screen space | `camera::DepthConvention` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.4.4 / 4.5.4 pre-convolution | `cone::try_build_color_pyramid`, `cone::convolution_weights` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.4.5, Eq. 4.1 cone angle | `lobe::try_cone_angle_from_phong`, `lobe::CONE_XI`, `lobe::MIRROR_POWER_START` |
//! | 004 (Hi-Z cone tracing) | Eq. 4.1 the Phong lobe's inverse CDF | `lobe::try_phong_lobe_angle`, `lobe::sample_phong_lobe` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.4.5, Eq. 4.2 isosceles triangle | `cone::isosceles_opposite`, `cone::isosceles_inradius` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.4.5 / 4.5.5, Listing 4.7 cone tracing | `cone::try_cone_trace`, `cone::ConeCircles`, `cone::cone_mip_level` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.6.1, Listing 4.8 fading artifacts | `cone::Fades`, `cone::FadeRange`, `cone::blend_fade` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.6.2 extrapolation of surfaces: bilateral dilation of the holes | `extrapolate::ExtrapolatePass`, `extrapolate::ExtrapolateOptions` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.6.4 reprojection matrix | `camera::try_reprojection_matrix` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.6.4 Listing 4.9 re-projection into the previous frame, 4.6.5 temporal filtering | `temporal::TemporalPass`, `temporal::History`, `temporal::HistoryTexel` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.6.4 approximate multiple ray bounces: the previous final image, re-projected (Listing 4.9), as the reflection pass's source | `bounce::BouncePass`, `bounce::PreviousFrame`, `bounce::BounceOptions` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.6.6 travel behind surfaces, 4.6.7 marching toward the camera | `hiz::try_trace_hiz` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.6.8 anisotropic reflections | `cone::ConeOptions::max_stretch` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.7.1 combining linear and Hi-Z traversal | `hiz::HiZOptions::prologue_steps`, `hiz::HiZOptions::stop_level` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.7.3 interleaved spatial coherence: one ray per 2x2 block | `upsample::Subsample`, `upsample::Pattern`, `upsample::HalfPass` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.7.3 signal reconstruction, 4.7.4 cross-bilateral upsampling (Kopf et al. 2007 Eq. 2) | `upsample::UpsamplePass`, `upsample::UpsampleOptions` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.7.4 re-trace of the pixels at depth discontinuities | `upsample::UpsampleStatus::Retrace`, `upsample::UpsampleOptions::retrace` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.7.4 temporal super-sampling over four frames | `upsample::FRAME_CYCLE`, `upsample::frame_sub_pixel`, `upsample::UpsampleStatus::answers` |
//! | 004 (Hi-Z cone tracing) | Sec. 4.4-4.6 as one pass | `glossy::GlossyPass` |
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![deny(missing_docs)]
#![deny(unsafe_code)]

#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub mod backface;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub mod bounce;
pub mod camera;
#[cfg(feature = "cluster")]
pub mod cluster;
#[cfg(feature = "cone")]
pub mod cone;
#[cfg(feature = "epipolar")]
pub mod epipolar;
pub mod error;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub mod extrapolate;
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
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub mod upsample;

pub use camera::{Camera, DepthConvention, Ray};
pub use error::Error;
pub use image::{ImageView, ImageViewMut, RowRange};
#[cfg(feature = "layered")]
pub use layered::{
    try_layered_len, try_prr_classify, ColumnFill, ColumnRay, Face, LayerHit, LayeredGrid,
    LayeredHit, LayeredLen, LayeredMap, LayeredMapMut, LayeredMiss, LayeredOptions, LayeredStamp,
    LayeredTrace, LayeredWork, PrrClass, PrrTriangle, EXIT_ENTRY_TEXELS, LAYERED_STAMP_LEN,
};
#[cfg(all(feature = "layered", any(feature = "depth-image", feature = "hiz")))]
pub use layered_pass::{
    layered_pass_scratch_len, prr_mask_words, prr_radii, try_prepare_layered_pass, try_prr_masks,
    try_prr_masks_len, LayeredBound, LayeredHostRay, LayeredMapSet, LayeredPass,
    LayeredPassOptions, LayeredPassSink, LayeredPassStats, LayeredPassStatus, LayeredPassTexel,
    PrrRadii, PrrStats, PRR_NO_REGION,
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
    hiz_stream_lanes, try_build_hiz, try_build_hiz_level0_rows, try_build_hiz_level_rows,
    try_hiz_len, try_stamp_hiz, try_trace_hiz, try_trace_hiz_rays, try_trace_hiz_rays_scalar,
    try_trace_hiz_stats, HiZ, HiZLayout, HiZLevel, HiZOptions, HiZStats, HiZTexel, PyramidBand,
    PyramidStamp, PyramidTexel, HIZ_STAMP_TEXELS,
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
