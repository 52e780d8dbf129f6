//! Generates the C header from this crate's sources with cbindgen into
//! `$OUT_DIR/refl.h`. The checked-in copy, `include/refl.h`, is compared
//! with it by `tests/header.rs` (and rewritten with `REFL_BLESS_HEADER=1`).
//!
//! The sources are parsed directly (`with_src`), not through
//! `cargo metadata`, so the build script never runs cargo recursively.

use std::path::PathBuf;

fn main() {
    let dir = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR"));
    let config_path = dir.join("cbindgen.toml");
    println!("cargo:rerun-if-changed={}", config_path.display());
    println!("cargo:rerun-if-changed={}", dir.join("src").display());

    let mut config = cbindgen::Config::from_file(&config_path)
        .unwrap_or_else(|e| panic!("reading {}: {e}", config_path.display()));
    // The header states the version it was generated for.
    config.header = Some(format!(
        "{}\n/* refl {} */",
        config.header.as_deref().unwrap_or(""),
        env!("CARGO_PKG_VERSION")
    ));
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src").join("lib.rs"))
        .generate()
        .unwrap_or_else(|e| panic!("cbindgen failed: {e}"));
    bindings.write_to_file(out.join("refl.h"));
}
