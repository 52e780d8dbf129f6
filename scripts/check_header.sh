#!/usr/bin/env bash
# Checks include/refl.h against the library and the tests:
#  1. it compiles as strict C99 and C++17 (-Wall -Wextra -Werror -pedantic);
#  2. the refl_* functions it declares are exactly the refl_* functions
#     librefl exports (given a static library, default target/release/librefl.a);
#  3. cpp_tests/hostile_input.cpp calls every declared function.
# (Staleness against the Rust sources is ffi/tests/header.rs's job.)
#
#   scripts/check_header.sh [path/to/librefl.a]
set -euo pipefail
cd "$(dirname "$0")/.."
lib=${1:-target/release/librefl.a}
header=include/refl.h
cc=${CC:-cc}
cxx=${CXX:-c++}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0

printf '#include "refl.h"\nint main(void) { return refl_status_string(0) == 0; }\n' > "$tmp/h.c"
cp "$tmp/h.c" "$tmp/h.cpp"
"$cc" -std=c99 -Wall -Wextra -Werror -pedantic -Iinclude -c "$tmp/h.c" -o "$tmp/h_c.o"
"$cxx" -std=c++17 -Wall -Wextra -Werror -pedantic -Iinclude -c "$tmp/h.cpp" -o "$tmp/h_cpp.o"
echo "header compiles as C99 and C++17"

# Declarations: a return type then `refl_name(` at the start of a line.
grep -oE '^[A-Za-z0-9_ *]*[ *]refl_[a-z0-9_]+\(' "$header" | grep -oE 'refl_[a-z0-9_]+\($' | tr -d '(' |
  sort -u > "$tmp/declared"
echo "$(wc -l < "$tmp/declared") functions declared"

if [ -f "$lib" ]; then
  nm -g --defined-only "$lib" 2>/dev/null | awk '$2 == "T" && $3 ~ /^refl_/ { print $3 }' | sort -u > "$tmp/exported"
  if ! diff -u "$tmp/declared" "$tmp/exported" > "$tmp/diff"; then
    echo "declared (-) and exported (+) functions differ:" >&2
    cat "$tmp/diff" >&2
    fail=1
  else
    echo "librefl exports exactly the declared functions"
  fi
else
  echo "$lib not found: export check skipped (build it with cargo build -p refl-ffi --release)" >&2
fi

missing=$(while read -r f; do grep -qw "$f" cpp_tests/hostile_input.cpp || echo "$f"; done < "$tmp/declared")
if [ -n "$missing" ]; then
  echo "hostile_input.cpp does not call: $missing" >&2
  fail=1
else
  echo "hostile_input.cpp calls every declared function"
fi
exit $fail
