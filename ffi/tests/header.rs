//! `include/refl.h` must equal the header cbindgen generates from the
//! current sources (build.rs writes it to `$OUT_DIR/refl.h`).
//!
//! Run with `REFL_BLESS_HEADER=1` to rewrite the checked-in header.

use std::path::PathBuf;

#[test]
fn checked_in_header_is_current() {
    check("refl.h");
}

/// `include/refl_config.h` is the default build's (every family); the
/// test runs with the default features.
#[test]
#[cfg(feature = "all")]
fn checked_in_config_header_is_current() {
    check("refl_config.h");
}

fn check(name: &str) {
    let generated_path = PathBuf::from(env!("OUT_DIR")).join(name);
    let checked_in_path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../include")
        .join(name);
    let generated = std::fs::read_to_string(&generated_path)
        .unwrap_or_else(|e| panic!("reading {}: {e}", generated_path.display()));

    if std::env::var_os("REFL_BLESS_HEADER").is_some_and(|v| v == "1") {
        std::fs::write(&checked_in_path, &generated)
            .unwrap_or_else(|e| panic!("writing {}: {e}", checked_in_path.display()));
        eprintln!("rewrote {}", checked_in_path.display());
        return;
    }

    let checked_in = std::fs::read_to_string(&checked_in_path).unwrap_or_default();
    if checked_in != generated {
        let first_diff = checked_in
            .lines()
            .zip(generated.lines())
            .position(|(a, b)| a != b)
            .map(|i| i + 1)
            .unwrap_or_else(|| checked_in.lines().count().min(generated.lines().count()) + 1);
        panic!(
            "include/{name} is stale (first difference at line {first_diff}; \
             checked in: {} lines, generated: {} lines).\n\
             The C header is generated from ffi/src by cbindgen. Regenerate it with\n\
             \n    REFL_BLESS_HEADER=1 cargo test -p refl-ffi --test header\n\n\
             and commit include/{name}. Generated copy: {}",
            checked_in.lines().count(),
            generated.lines().count(),
            generated_path.display()
        );
    }
}
