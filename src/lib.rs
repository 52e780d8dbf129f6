//! The root package of refl: built-in scenes, the obvhs reference tracer,
//! G-buffer and depth-image producers, the reflection renderers built on
//! refl-core, and `refl report` (error against run time for every method).
//!
//! The library is named `refl_app` (the package is `refl`) so that its
//! artifacts do not collide with refl-ffi's `librefl`.
#![doc = include_str!("../README.md")]

pub mod bounce;
pub mod calibration;
pub mod cluster;
pub mod cone;
pub mod epipolar;
pub mod epipolar_shadow;
pub mod export;
pub mod extrapolate;
pub mod gbuffer;
pub mod growth;
pub mod layered;
pub mod layered_render;
pub mod probe;
pub mod raster;
pub mod render;
pub mod report;
pub mod report_out;
pub mod scene;
pub mod screen;
pub mod shade;
pub mod tcrr;
pub mod temporal;
pub mod tracer;
pub mod upsample;
