#!/usr/bin/env bash
# Configures, builds and runs the C/C++ tests of librefl against Embree 3
# twice: a normal build (cpp_tests/build) and an AddressSanitizer +
# UndefinedBehaviorSanitizer build (cpp_tests/build-asan), each with
# `ctest --output-on-failure`.
#
#   scripts/cpp_tests.sh [CROSSCHECK_DIR]
#
# CROSSCHECK_DIR: a directory written by
#   cargo run --release -p refl -- export-crosscheck CROSSCHECK_DIR
# Given, the obvhs_crosscheck test runs in both builds; otherwise it is
# skipped (CMake says so). Needs cmake, a C/C++ compiler and libembree-dev.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

crosscheck=""
if [ $# -ge 1 ] && [ -n "$1" ]; then
  crosscheck=$(cd "$1" && pwd)
fi
jobs=$(nproc 2>/dev/null || echo 2)

run() {
  local dir=$1 verbosity=$2; shift 2
  echo "==== cpp_tests: $dir ($*) ===="
  cmake -S "$root/cpp_tests" -B "$root/cpp_tests/$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DREFL_CROSSCHECK_DIR="$crosscheck" "$@"
  cmake --build "$root/cpp_tests/$dir" -j "$jobs"
  ctest --test-dir "$root/cpp_tests/$dir" --output-on-failure $verbosity -j "$jobs"
}

# The plain build prints every test's figures (agreement, error, rays/s).
run build --verbose -DREFL_SANITIZE=OFF
# halt_on_error: a sanitizer report fails the test, as -fno-sanitize-recover does.
ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1:abort_on_error=0} \
UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1} \
  run build-asan "" -DREFL_SANITIZE=ON

# The README's two link lines, as a C++ user types them (issue 13 part 5):
# the archive named explicitly, and -lrefl with an rpath to librefl.so.
echo "==== cpp_tests: README link lines (static and shared) ===="
cargo build --locked --release -p refl-ffi
link_dir="$root/target/readme-link"
rm -rf "$link_dir"
mkdir -p "$link_dir"
c++ -std=c++17 cpp_tests/example.cpp -Iinclude target/release/librefl.a -lpthread -ldl -lm \
  -o "$link_dir/example-static"
cp target/release/librefl.so "$link_dir/"
c++ -std=c++17 cpp_tests/example.cpp -Iinclude -Ltarget/release -lrefl -Wl,-rpath,'$ORIGIN' \
  -o "$link_dir/example-shared"
"$link_dir/example-static" >/dev/null
"$link_dir/example-shared" >/dev/null
# The static program needs no librefl.so; the shared one loads the copy
# beside it.
if grep -q librefl <<<"$(ldd "$link_dir/example-static" 2>&1)"; then
  echo "example-static depends on librefl.so" >&2
  exit 1
fi
grep -q "$link_dir/librefl.so" <<<"$(ldd "$link_dir/example-shared")"
echo "README link lines: static $(stat -c %s target/release/librefl.a) bytes (librefl.a), shared $(stat -c %s target/release/librefl.so) bytes (librefl.so)"
