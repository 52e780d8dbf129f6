#!/usr/bin/env bash
# The install step as a C/C++ host uses it (part of scripts/test.sh):
#
#  1. scripts/install.sh into a temporary prefix (every family); checks the
#     installed file list, the soname and its links;
#  2. a separate CMake project (cpp_tests/consumer) that only calls
#     find_package(refl CONFIG REQUIRED) builds the README's C++ example
#     against refl::refl (shared) and refl::refl_static, and runs both;
#  3. the same example built with `c++ $(pkg-config --cflags --libs refl)`
#     runs;
#  4. a library with the hiz family alone: refl_config.h names it alone, the
#     other families' functions are neither declared nor exported, and a C99
#     program using only Hi-Z (cpp_tests/consumer/hiz_only.c) builds against
#     it (pkg-config, shared; and static) and runs.
# Prints the size of each installed library.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
builds="$root/target/install-test"
fail() { echo "install test: $*" >&2; exit 1; }

echo "-- install (every family) into $work/all"
bash scripts/install.sh --prefix "$work/all" --build-dir "$builds/all" >"$work/install-all.log" \
  || { cat "$work/install-all.log"; fail "install failed"; }
version=$(sed -n 's/^version = "\([0-9.]*\)"$/\1/p' Cargo.toml | head -n 1)
so_version="0.$(cut -d. -f2 <<<"$version")"
expected="include/refl.h
include/refl_config.h
lib/cmake/refl/reflConfig.cmake
lib/cmake/refl/reflConfigVersion.cmake
lib/librefl.a
lib/librefl.so
lib/librefl.so.$so_version
lib/librefl.so.$version
lib/pkgconfig/refl.pc"
got=$(cd "$work/all" && find . \( -type f -o -type l \) | sed 's|^\./||' | LC_ALL=C sort)
[ "$got" = "$expected" ] || fail "installed files differ from the expected list:
$got"
echo "$got" | sed 's/^/   /'
[ "$(readlink "$work/all/lib/librefl.so")" = "librefl.so.$so_version" ] || fail "librefl.so link"
[ "$(readlink "$work/all/lib/librefl.so.$so_version")" = "librefl.so.$version" ] || fail "soname link"
grep -q "Library soname: \[librefl.so.$so_version\]" <<<"$(readelf -d "$work/all/lib/librefl.so.$version")" \
  || fail "librefl.so.$version lacks the soname librefl.so.$so_version"
for f in MIRROR HIZ DEPTH_IMAGE CONE LAYERED CLUSTER TCRR EPIPOLAR; do
  grep -q "^#define REFL_FEATURE_$f 1" "$work/all/include/refl_config.h" || fail "refl_config.h lacks $f"
done

echo "-- find_package(refl CONFIG REQUIRED): shared and static targets"
cmake -S cpp_tests/consumer -B "$work/consumer" -DCMAKE_PREFIX_PATH="$work/all" \
  -DCMAKE_BUILD_TYPE=Release >"$work/consumer.log" || { cat "$work/consumer.log"; fail "configure"; }
cmake --build "$work/consumer" >>"$work/consumer.log" 2>&1 || { cat "$work/consumer.log"; fail "build"; }
"$work/consumer/example_shared" >/dev/null || fail "example_shared failed"
"$work/consumer/example_static" >/dev/null || fail "example_static failed"
grep -q "librefl.so.$so_version => $work/all/lib/" <<<"$(ldd "$work/consumer/example_shared")" \
  || fail "example_shared does not load the installed librefl.so.$so_version"
if grep -q librefl <<<"$(ldd "$work/consumer/example_static" 2>&1)"; then fail "example_static loads librefl"; fi

echo "-- pkg-config"
export PKG_CONFIG_PATH="$work/all/lib/pkgconfig"
[ "$(pkg-config --modversion refl)" = "$version" ] || fail "pkg-config --modversion"
# shellcheck disable=SC2046
c++ -std=c++17 cpp_tests/example.cpp $(pkg-config --cflags --libs refl) -o "$work/example_pc"
LD_LIBRARY_PATH="$work/all/lib" "$work/example_pc" >/dev/null || fail "pkg-config example failed"

echo "-- one family: --features hiz"
bash scripts/install.sh --prefix "$work/hiz" --build-dir "$builds/hiz" --features hiz \
  >"$work/install-hiz.log" || { cat "$work/install-hiz.log"; fail "hiz install failed"; }
grep -q '^#define REFL_FEATURE_HIZ 1' "$work/hiz/include/refl_config.h" || fail "hiz config"
if grep -q '^#define REFL_FEATURE_\(CONE\|LAYERED\|CLUSTER\|TCRR\|EPIPOLAR\|MIRROR\) 1' \
  "$work/hiz/include/refl_config.h"; then fail "the hiz build's refl_config.h names other families"; fi
if nm -D --defined-only "$work/hiz/lib/librefl.so.$version" | grep -Eq ' refl_(cone|layered|cluster|tcrr|epipolar|planar)_'; then
  fail "the hiz library exports other families' functions"
fi
grep -q ' refl_hiz_trace_rays$' <<<"$(nm -D --defined-only "$work/hiz/lib/librefl.so.$version")" || fail "no refl_hiz_trace_rays"
# A call into a family the build lacks does not compile.
printf '#include "refl.h"\nint main(void) { struct refl_cone_options o = refl_cone_options_default(); return (int)o.max_iterations; }\n' >"$work/cone.c"
if cc -std=c99 -Werror -c "$work/cone.c" -I"$work/hiz/include" -o "$work/cone.o" 2>/dev/null; then
  fail "refl_cone_options_default is declared in the hiz build's header"
fi
export PKG_CONFIG_PATH="$work/hiz/lib/pkgconfig"
# shellcheck disable=SC2046
cc -std=c99 -Wall -Werror cpp_tests/consumer/hiz_only.c $(pkg-config --cflags --libs refl) -lm -o "$work/hiz_shared"
LD_LIBRARY_PATH="$work/hiz/lib" "$work/hiz_shared" || fail "hiz_only (shared) failed"
# shellcheck disable=SC2046
cc -std=c99 -Wall -Werror cpp_tests/consumer/hiz_only.c $(pkg-config --cflags refl) "$work/hiz/lib/librefl.a" \
  $(pkg-config --static --libs-only-l refl | sed 's/-lrefl //') -lm -o "$work/hiz_static"
"$work/hiz_static" >/dev/null || fail "hiz_only (static) failed"

echo "-- installed sizes (bytes; librefl.a stripped of debug info, librefl.so of unneeded symbols)"
for b in all hiz; do
  printf '   %-4s librefl.a %9d  librefl.so %8d  exported refl_ functions %d\n' "$b" \
    "$(stat -c %s "$work/$b/lib/librefl.a")" "$(stat -c %s "$work/$b/lib/librefl.so.$version")" \
    "$(nm -D --defined-only "$work/$b/lib/librefl.so.$version" | grep -c ' refl_')"
done
echo "install test: ok"
