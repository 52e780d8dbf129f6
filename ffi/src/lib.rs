//! # refl-ffi
//!
//! The C ABI of refl-core, built as `librefl` (static and shared). The C
//! header `include/refl.h` is generated from this crate by cbindgen (see
//! `build.rs`, `cbindgen.toml`) and checked in; `tests/header.rs` fails if
//! it is stale (`REFL_BLESS_HEADER=1 cargo test -p refl-ffi --test header`
//! rewrites it).
//!
//! Conventions of every export (meshoptimizer / rustls-ffi style; the
//! naming and signature rules are `docs/api.md`'s, enforced on the header by
//! `tests/conventions.rs`):
//!
//! * Outputs first, then inputs. Small values (vectors, rays, image
//!   descriptors) are passed by value; cameras, planes and matrices by
//!   pointer.
//! * Every function returns a [`refl_status`] (except the library-level
//!   `refl_version*`, `refl_status_string`, `refl_last_error_message` and
//!   the `refl_<module>_options_default(void)` functions, which return
//!   their value); `REFL_STATUS_OK` is 0. Each
//!   pointer is checked (NULL, then alignment) before it is read, and
//!   `REFL_STATUS_NULL_POINTER` comes only with a NULL pointer; when several
//!   arguments are bad, which one is reported is not specified (the
//!   last-error message names it). (This read "NULL pointers first" until
//!   the fuzz targets showed exports that check a misaligned output, a row
//!   range or a face before a later NULL.)
//! * Outputs are written only on success: every input is validated before
//!   the first output byte is written, so a failed call leaves every output
//!   byte untouched. Single-value outputs are computed into locals and
//!   stored last, so they may alias an input; arrays are borrowed in place
//!   (nothing is copied: no export allocates, `tests/alloc.rs`), so an
//!   output array must not overlap an input (`REFL_STATUS_INVALID_ARGUMENT`).
//! * Enums cross the boundary as `uint32_t` and are validated: an unknown
//!   value is `REFL_STATUS_INVALID_ARGUMENT`, never undefined behavior.
//! * No panic crosses the boundary: each call runs inside `catch_unwind`
//!   and a caught panic is `REFL_STATUS_PANIC`. This needs the default
//!   `panic = "unwind"`; a `panic = "abort"` profile turns such a bug into
//!   an abort instead (never into undefined behavior).
//! * Cameras are validated on every call (`refl_camera_validate`).
//!
//! The Rust types here double as a Rust view of the ABI (the crate is also
//! an `rlib`), which the crate's tests use.
#![allow(non_camel_case_types)]
#![deny(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]
#![warn(clippy::undocumented_unsafe_blocks)]
// A library built with fewer families (`--no-default-features --features
// hiz`, ...) leaves some shared checking helpers unused.
#![cfg_attr(not(feature = "all"), allow(dead_code, unused_imports))]

mod camera;
#[cfg(feature = "cluster")]
mod cluster;
#[cfg(feature = "cone")]
mod cone;
#[cfg(feature = "epipolar")]
mod epipolar;
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
mod gbuffer;
#[cfg(feature = "cone")]
mod glossy;
#[cfg(feature = "hiz")]
mod hiz;
mod image;
#[cfg(feature = "layered")]
mod layered;
#[cfg(feature = "mirror")]
mod mirror;
mod ptr;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
mod ssr;
mod status;
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
mod summary;
#[cfg(feature = "tcrr")]
mod tcrr;
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
mod trace;
mod types;
// The passes of issue 13 added after the rest (keeps the header's order).
#[cfg(any(feature = "depth-image", feature = "hiz"))]
mod backface;
#[cfg(feature = "mirror")]
mod planar;
// The cluster pass (issue 13, seed 003).
#[cfg(feature = "cluster")]
mod cluster_pass;
// The layered-maps pass (issue 13).
#[cfg(all(feature = "layered", any(feature = "depth-image", feature = "hiz")))]
mod layered_pass;
// The temporal filter (issue 18, seed 004 Sec. 4.6.4-4.6.5).
#[cfg(any(feature = "depth-image", feature = "hiz"))]
mod temporal;
// Multiple bounces, extrapolation and fewer rays (issue 18, seed 004 Sec.
// 4.6.2, 4.6.4, 4.7.3-4.7.4).
#[cfg(any(feature = "depth-image", feature = "hiz"))]
mod bounce;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
mod extrapolate;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
mod upsample;

#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub use backface::*;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub use bounce::*;
pub use camera::*;
#[cfg(feature = "cluster")]
pub use cluster::*;
#[cfg(feature = "cluster")]
pub use cluster_pass::*;
#[cfg(feature = "cone")]
pub use cone::*;
#[cfg(feature = "epipolar")]
pub use epipolar::*;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub use extrapolate::*;
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub use gbuffer::*;
#[cfg(feature = "cone")]
pub use glossy::*;
#[cfg(feature = "hiz")]
pub use hiz::*;
pub use image::*;
#[cfg(feature = "layered")]
pub use layered::*;
#[cfg(all(feature = "layered", any(feature = "depth-image", feature = "hiz")))]
pub use layered_pass::*;
#[cfg(feature = "mirror")]
pub use mirror::*;
#[cfg(feature = "mirror")]
pub use planar::*;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub use ssr::*;
pub use status::*;
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub use summary::*;
#[cfg(feature = "tcrr")]
pub use tcrr::*;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub use temporal::*;
#[cfg(any(feature = "depth-image", feature = "hiz", feature = "mirror"))]
pub use trace::*;
pub use types::*;
#[cfg(any(feature = "depth-image", feature = "hiz"))]
pub use upsample::*;
