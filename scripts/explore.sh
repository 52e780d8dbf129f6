#!/usr/bin/env bash
# Random exploration of refl-core's property tests (issue 12). Not part of CI:
# the test command runs every property test from one fixed seed
# (core/tests/common/mod.rs), so a commit's verdict never depends on luck;
# this script runs the same tests from fresh random seeds with many more
# cases, for as long as it is given.
#
#   scripts/explore.sh [MINUTES] [SCALE]
#
# MINUTES (default 60): wall-clock budget; rounds start until it is spent.
# SCALE (default 20): case multiplier over the test command's counts.
# Each round draws a seed from /dev/urandom and runs every test named prop_*
# in core/tests with REFL_EXPLORE=1 and that seed. A failing case is saved by
# proptest in core/tests/<file>.proptest-regressions (check it in, then fix
# the kernel or the oracle); the round's log goes to target/explore/ and the
# script stops there, since every later round would replay that case.
# At the end the script prints the rounds, the cases run, the CPU seconds
# spent and the failures.
set -uo pipefail
cd "$(dirname "$0")/.."
minutes=${1:-60}
scale=${2:-20}
log_dir=target/explore
mkdir -p "$log_dir"
# Optimized, with debug assertions and overflow checks kept, in its own
# target folder so the test command's build is left alone.
export CARGO_TARGET_DIR=target/explore/build
export CARGO_PROFILE_DEV_OPT_LEVEL=2
export CARGO_PROFILE_DEV_DEBUG_ASSERTIONS=true
export CARGO_PROFILE_DEV_OVERFLOW_CHECKS=true
cargo test --locked -q -p refl-core --features all --no-run 2>&1 | tail -n 3
end=$(( $(date +%s) + minutes * 60 ))
rounds=0 cases=0 failures=0
cpu0=$(awk '{print $16+$17}' /proc/$$/stat)
t_start=$(date +%s)
while [ "$(date +%s)" -lt "$end" ]; do
  seed=$(od -An -N8 -tu8 /dev/urandom | tr -d ' ')
  out="$log_dir/round-$seed.log"
  if REFL_EXPLORE=1 REFL_EXPLORE_SCALE="$scale" PROPTEST_RNG_SEED="$seed" \
      cargo test --locked -q -p refl-core --features all -- prop_ --nocapture --test-threads=1 >"$out" 2>&1; then
    status=ok
  else
    status=FAILED
    failures=$((failures + 1))
    cp "$out" "$log_dir/failure-$seed.log"
  fi
  n=$(grep -o 'refl-explore: [0-9]* cases' "$out" | awk '{s += $2} END {print s + 0}')
  rounds=$((rounds + 1))
  cases=$((cases + n))
  echo "round $rounds seed $seed: $n cases, $status"
  [ "$status" = ok ] && rm -f "$out"
  if [ "$status" = FAILED ]; then
    # proptest saved the case in a *.proptest-regressions file, which every
    # later round would replay and fail on: stop here, check it in, fix.
    echo "stopping at the first failure: see $log_dir/failure-$seed.log"
    break
  fi
done
# CPU time of this shell's children (user + system, in clock ticks).
ticks=$(getconf CLK_TCK)
cpu1=$(awk '{print $16+$17}' /proc/$$/stat)
echo "explore: $rounds rounds, $cases cases, $failures failing rounds," \
  "$(( (cpu1 - cpu0) / ticks )) CPU s in $(( $(date +%s) - t_start )) s wall"
git status --short -- 'core/tests/*.proptest-regressions'
[ "$failures" -eq 0 ]
