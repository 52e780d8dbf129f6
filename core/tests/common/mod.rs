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
