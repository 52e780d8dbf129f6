//! Shared by refl-core's property tests (included with `mod common;`).
//!
//! Every `proptest!` block takes its configuration from [`proptest_config`]:
//! under the test command the random generator starts from one fixed seed,
//! so a commit gives the same verdict on every run and every machine.
//! Random exploration (`scripts/explore.sh`, not part of CI) sets
//! `REFL_EXPLORE=1`; then the seed is proptest's own (`PROPTEST_RNG_SEED`
//! when set, else random) and the case count is multiplied by
//! `REFL_EXPLORE_SCALE` (default 20). Failures found either way are saved by
//! proptest in the `*.proptest-regressions` file beside the test, which is
//! checked in and replayed first on every run.

use proptest::test_runner::{Config, FileFailurePersistence, RngSeed};

/// The seed of every property test under the test command.
pub const FIXED_SEED: u64 = 0x7265_666c_5f73_6565; // "refl_see"

/// The configuration of a property test with `cases` cases (module docs).
pub fn proptest_config(cases: u32) -> Config {
    // Failures go to `<test file>.proptest-regressions` beside the test
    // (what the default, `SourceParallel`, falls back to for integration
    // tests, with a warning on every run).
    let mut c = Config {
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource(
            "proptest-regressions",
        ))),
        ..Config::default()
    };
    if std::env::var_os("REFL_EXPLORE").is_some() {
        let scale = std::env::var("REFL_EXPLORE_SCALE")
            .ok()
            .and_then(|s| s.parse::<u32>().ok())
            .unwrap_or(20);
        c.cases = cases.saturating_mul(scale.max(1));
        // scripts/explore.sh sums these lines.
        eprintln!("refl-explore: {} cases, seed {}", c.cases, c.rng_seed);
    } else {
        c.cases = cases;
        c.rng_seed = RngSeed::Fixed(FIXED_SEED);
    }
    c
}

/// Fuzz finding F31's case (the step target): a camera of 41x44 pixels with
/// an infinite far plane, a ray from view depth about 3 toward a surface at
/// linear depth 6,654,798.5 everywhere, and the thickness; traced with
/// `t_max = 1e30`, the segment nearly reaches its vanishing point.
#[allow(dead_code)]
pub fn f31_case() -> (refl_core::Camera, refl_core::Ray, f32) {
    let view = glam::Mat4::from_cols_array(&[
        -0.7737348,
        0.11041793,
        -0.62381274,
        0.0,
        0.0,
        0.98469335,
        0.17429559,
        0.0,
        0.63350964,
        0.13485856,
        -0.76189154,
        0.0,
        -0.34753847,
        0.40155032,
        -3.470898,
        1.0,
    ]);
    let cam =
        refl_core::Camera::try_new(view, 1.5270588, 0.7933138, f32::INFINITY, 41, 44).unwrap();
    let ray = refl_core::Ray {
        origin: glam::Vec3::new(-1.8234673, 0.54053485, -2.299697),
        dir: glam::Vec3::new(0.86716413, -0.43820888, 0.2366419),
    };
    (cam, ray, 0.38117036)
}

/// F31's surface depth ([`f31_case`]).
#[allow(dead_code)]
pub const F31_SURFACE: f32 = 6654798.5;
