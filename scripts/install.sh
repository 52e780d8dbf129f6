#!/usr/bin/env bash
# Installs refl's C library (header, librefl.a, librefl.so with its soname
# links, refl.pc, the CMake package) under a prefix, with the root
# CMakeLists.txt:
#
#   scripts/install.sh --prefix /usr/local                  every family
#   scripts/install.sh --prefix "$HOME/.local" --features hiz,mirror
#
# Options: --prefix DIR (default /usr/local), --features LIST (refl-ffi's
# Cargo features: all, or families among mirror, hiz, depth-image, cone,
# layered, cluster, tcrr, epipolar; default all), --build-dir DIR (default
# target/cmake-install). Needs cmake >= 3.19 and cargo.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
prefix=/usr/local
features=all
build_dir="$root/target/cmake-install"
while [ $# -gt 0 ]; do
  case "$1" in
    --prefix) prefix=$2; shift 2 ;;
    --features) features=$2; shift 2 ;;
    --build-dir) build_dir=$2; shift 2 ;;
    -h|--help) sed -n '2,12p' "$0" | cut -c3-; exit 0 ;;
    *) echo "unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
cmake -S "$root" -B "$build_dir" -DCMAKE_INSTALL_PREFIX="$prefix" -DREFL_FEATURES="$features" >/dev/null
cmake --build "$build_dir"
cmake --install "$build_dir"
