#!/usr/bin/env bash
# cargo-fuzz (libFuzzer + AddressSanitizer, leak detection on) targets of
# refl's C ABI (fuzz/, issue 12 part 3).
#
#   scripts/fuzz.sh smoke              every target 1500 executions from the
#                                      checked-in corpus, seed 1 (about 60 s
#                                      in all, the same verdict every run),
#                                      then every reproducer in
#                                      fuzz/artifacts-found once;
#                                      fails on any crash, contract
#                                      violation, leak or timeout
#   scripts/fuzz.sh run TARGET SECONDS one long run (new inputs go to
#                                      fuzz/corpus-local/TARGET, ignored)
#   scripts/fuzz.sh campaign TARGET CPU_SECONDS
#                                      runs TARGET in chunks (CHUNK wall
#                                      seconds each, default 900) until its
#                                      processes used CPU_SECONDS of CPU
#                                      time (user + system), appending one
#                                      line per chunk to fuzz/campaign.tsv
#                                      (checked in: the fuzzing record);
#                                      stops at the first failure
#   scripts/fuzz.sh minimize [TARGET]  merges fuzz/corpus-local into
#                                      fuzz/corpus and `cargo fuzz cmin`s it
#   scripts/fuzz.sh list               the targets
#   scripts/fuzz.sh build              builds every target
#
# Every run prints per target the executions (libFuzzer's
# stat::number_of_executed_units, -print_final_stats=1) and the coverage
# (cov: edges, ft: features, from the final stats line).
#
# Environment: FUZZ_TIMEOUT (libFuzzer -timeout, seconds, default 10),
# REFL_FUZZ_NO_BUILD (use the binaries already built, e.g.
# for a long campaign while the sources change), SMOKE_RUNS (executions per target in smoke, default 1500),
# SMOKE_SECONDS (time cap per smoke target, default 60), JOBS (cargo
# build jobs, default 2), REFL_FUZZ_STRICT (1 or a list such as F6,F7:
# also fail on the known findings listed in fuzz/README.md).
#
# Toolchain: nightly when `rustup toolchain list` has it, otherwise the
# default toolchain with RUSTC_BOOTSTRAP=1 (cargo-fuzz needs -Z flags).
# cargo-fuzz itself is installed with `cargo install cargo-fuzz --locked`
# when missing.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
fuzz_dir=$(pwd)

if command -v rustup >/dev/null 2>&1 && rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
  cargo_fuzz=(cargo +nightly fuzz)
  rustc_vv=$(rustc +nightly -vV)
else
  export RUSTC_BOOTSTRAP=1
  cargo_fuzz=(cargo fuzz)
  rustc_vv=$(rustc -vV)
fi
if ! cargo fuzz --version >/dev/null 2>&1; then
  echo "installing cargo-fuzz (cargo install cargo-fuzz --locked)"
  cargo install cargo-fuzz --locked -j "${JOBS:-2}"
fi
export CARGO_BUILD_JOBS="${JOBS:-2}"
triple=$(sed -n 's/^host: //p' <<<"$rustc_vv")
bin_dir="$fuzz_dir/target/$triple/release"

targets() {
  for f in fuzz_targets/*.rs; do basename "$f" .rs; done
}

# The commit the binaries were built from (+dirty when core, ffi or fuzz
# had uncommitted changes), recorded in target/built-commit.
source_commit() {
  local c
  c=$(git -C "$fuzz_dir" rev-parse --short HEAD 2>/dev/null || echo unknown)
  if [ -n "$(git -C "$fuzz_dir" status --porcelain -- ../core ../ffi . 2>/dev/null | grep -v '^??' || true)" ]; then
    c="$c+dirty"
  fi
  echo "$c"
}

build() {
  if [ -n "${REFL_FUZZ_NO_BUILD:-}" ] && [ -f target/built-commit ]; then
    echo "using the targets built from $(cat target/built-commit) (REFL_FUZZ_NO_BUILD)"
    return
  fi
  echo "building fuzz targets (${cargo_fuzz[*]} build, AddressSanitizer)"
  local c
  c=$(source_commit)
  "${cargo_fuzz[@]}" build
  echo "$c" >target/built-commit
}

# Common libFuzzer flags: ASan's leak detection is on by default; a slow
# input (FUZZ_TIMEOUT wall seconds, default 10) or more than 2 GiB is a
# failure too. libFuzzer's timeout is wall time: a campaign run at a low
# priority beside other work (nice 19) can starve an input past it, so
# such campaigns raise it (a real hang still trips it).
lf_flags=(-print_final_stats=1 -detect_leaks=1 -rss_limit_mb=2048 -timeout="${FUZZ_TIMEOUT:-10}")

# summary TARGET LOG STATUS: one line of executions and coverage.
summary() {
  local t=$1 log=$2 st=$3
  local execs cov ft
  # `|| true`: a run that died before its first stats line has none, and
  # under `set -o pipefail` a grep without a match would end the script
  # before the failure is reported.
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1 || true)
  cov=$(grep -Eo 'cov: [0-9]+' "$log" | tail -n 1 | awk '{print $2}' || true)
  ft=$(grep -Eo 'ft: [0-9]+' "$log" | tail -n 1 | awk '{print $2}' || true)
  printf '%-14s %-6s executions %-9s cov %-6s ft %-6s\n' "$t" "$st" "${execs:-?}" "${cov:-?}" "${ft:-?}"
}

# fuzz_one TARGET SECONDS OUT_CORPUS LOG: runs TARGET from its checked-in
# corpus (read only) for SECONDS, new inputs to OUT_CORPUS; artifacts of
# failures under fuzz/artifacts/TARGET/.
fuzz_one() {
  local t=$1 secs=$2 out=$3 log=$4
  mkdir -p "$out" "corpus/$t" "artifacts/$t"
  "$bin_dir/$t" "${lf_flags[@]}" "${extra_flags[@]}" -max_total_time="$secs" \
    -artifact_prefix="artifacts/$t/" "$out" "corpus/$t" >"$log" 2>&1
}

# replay_found TARGET LOG: runs every reproducer of TARGET's findings
# (fuzz/artifacts-found/TARGET/, fixed or documented) once, appending to
# LOG. Many are not in the corpus (a minimized corpus keeps the inputs
# that add coverage, not the ones that once failed), so the smoke run
# replays them here.
replay_found() {
  local t=$1 log=$2
  local files=(artifacts-found/"$t"/*)
  [ -e "${files[0]}" ] || return 0
  "$bin_dir/$t" "${lf_flags[@]}" -runs=1 "${files[@]}" >>"$log" 2>&1
}

# known_target TARGET: exits 2 unless TARGET is one of `targets`.
known_target() {
  targets | grep -x "$1" >/dev/null || { echo "unknown target $1 (scripts/fuzz.sh list)" >&2; exit 2; }
}

# report_failure TARGET LOG: the panic or sanitizer report and the
# reproducers of a failed run; exits 1.
report_failure() {
  grep -E -A20 'panicked at|ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)' "$2" | head -n 60 || true
  ls -1 "artifacts/$1/" 2>/dev/null | sed "s|^|  reproducer: fuzz/artifacts/$1/|" || true
  exit 1
}

# Extra libFuzzer flags (the smoke run's fixed seed and run count).
extra_flags=()

cmd=${1:-smoke}
case "$cmd" in
  list)
    targets
    ;;
  build)
    build
    ;;
  smoke)
    build
    mapfile -t all < <(targets)
    # Deterministic: a fixed libFuzzer seed and a fixed number of
    # executions per target (SMOKE_RUNS, default 1500: about 60 s in all
    # here), so the same commit gives the same verdict; SMOKE_SECONDS per
    # target (default 60) only caps a slow machine.
    runs=${SMOKE_RUNS:-1500}
    per=${SMOKE_SECONDS:-60}
    extra_flags=(-seed=1 -runs="$runs")
    tmp=$(mktemp -d)
    trap 'rm -rf "$tmp"' EXIT
    echo "smoke: ${#all[@]} targets, ${runs} executions each (seed 1)"
    failed=()
    for t in "${all[@]}"; do
      log="$tmp/$t.log"
      found="$tmp/$t.found.log"
      : >"$found"
      if fuzz_one "$t" "$per" "$tmp/corpus-$t" "$log" && replay_found "$t" "$found"; then
        summary "$t" "$log" ok
      else
        summary "$t" "$log" FAIL
        failed+=("$t")
        grep -E -A12 'panicked at|ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)' "$log" "$found" | head -n 40 || true
        ls -1 "artifacts/$t/" 2>/dev/null | sed "s|^|  reproducer: fuzz/artifacts/$t/|" || true
        sed -n 's|^Running: |  failing found reproducer (the last run): fuzz/|p' "$found" | tail -n 1
      fi
    done
    if [ ${#failed[@]} -gt 0 ]; then
      echo "fuzz smoke FAILED: ${failed[*]} (reproduce: fuzz/target/$triple/release/TARGET fuzz/artifacts/TARGET/crash-...)" >&2
      exit 1
    fi
    echo "fuzz smoke: ${#all[@]} passed, 0 failed"
    ;;
  run)
    t=${2:?usage: scripts/fuzz.sh run TARGET SECONDS}
    secs=${3:?usage: scripts/fuzz.sh run TARGET SECONDS}
    known_target "$t"
    build
    log="$fuzz_dir/target/fuzz-$t.log"
    echo "running $t for $secs s (log: fuzz/target/fuzz-$t.log, new inputs: fuzz/corpus-local/$t)"
    st=ok
    fuzz_one "$t" "$secs" "corpus-local/$t" "$log" || st=FAIL
    summary "$t" "$log" "$st"
    [ "$st" = ok ] || report_failure "$t" "$log"
    ;;
  campaign)
    t=${2:?usage: scripts/fuzz.sh campaign TARGET CPU_SECONDS}
    want=${3:?usage: scripts/fuzz.sh campaign TARGET CPU_SECONDS}
    known_target "$t"
    build
    ledger="$fuzz_dir/campaign.tsv"
    [ -f "$ledger" ] || printf 'date\tcommit\ttarget\twall_s\tcpu_s\texecutions\tcov\tft\tstatus\n' >"$ledger"
    commit=$(cat target/built-commit)
    used=0
    chunk=${CHUNK:-900}
    while awk -v u="$used" -v w="$want" 'BEGIN { exit !(u < w) }'; do
      log="$fuzz_dir/target/campaign-$t.log"
      mkdir -p "corpus-local/$t" "corpus/$t" "artifacts/$t"
      tfile=$(mktemp)
      start=$(date +%s)
      st=ok
      /usr/bin/time -o "$tfile" -f '%U %S' \
        "$bin_dir/$t" "${lf_flags[@]}" -max_total_time="$chunk" \
        -artifact_prefix="artifacts/$t/" "corpus-local/$t" "corpus/$t" >"$log" 2>&1 || st=FAIL
      wall=$(( $(date +%s) - start ))
      cpu=$(tail -n 1 "$tfile" | awk '{ printf "%.0f", $1 + $2 }')
      rm -f "$tfile"
      used=$(( used + cpu ))
      execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
      cov=$(grep -Eo 'cov: [0-9]+' "$log" | tail -n 1 | awk '{print $2}')
      ft=$(grep -Eo 'ft: [0-9]+' "$log" | tail -n 1 | awk '{print $2}')
      printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$(date -u +%FT%TZ)" "$commit" "$t" "$wall" "$cpu" \
        "${execs:-?}" "${cov:-?}" "${ft:-?}" "$st" >>"$ledger"
      summary "$t" "$log" "$st"
      [ "$st" = ok ] || report_failure "$t" "$log"
    done
    echo "$t: $used CPU-s this campaign"
    ;;
  minimize)
    mapfile -t all < <(if [ -n "${2:-}" ]; then echo "$2"; else targets; fi)
    build
    for t in "${all[@]}"; do
      mkdir -p "corpus/$t"
      if [ -d "corpus-local/$t" ]; then
        # Keep only the local inputs that add coverage.
        "$bin_dir/$t" -merge=1 -rss_limit_mb=2048 -timeout=10 "corpus/$t" "corpus-local/$t" >/dev/null 2>&1
      fi
      "${cargo_fuzz[@]}" cmin "$t" "corpus/$t" -- -rss_limit_mb=2048 -timeout=10 >"target/cmin-$t.log" 2>&1
      printf '%-14s %4d inputs, %6d bytes\n' "$t" "$(ls "corpus/$t" | wc -l)" "$(cat corpus/"$t"/* 2>/dev/null | wc -c)"
    done
    ;;
  *)
    sed -n '2,25p' "$0" >&2
    exit 2
    ;;
esac
