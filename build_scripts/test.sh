#!/usr/bin/env bash
# Every test suite: C++ (GoogleTest), Python (pytest, scipy as oracle) and the Blender background
# suites under Debian's Blender 3.4.1 and the bpy 4.5, 5.0 (Python 3.11) and 5.2 (Python 3.13)
# modules. Installs what is missing first; a Blender whose Python this machine lacks is skipped, and
# the summary says so. Exit status: non-zero on any failure.  Extra arguments go to ctest (e.g. -R blender).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

"$ROOT/build_scripts/setup.sh"
"$ROOT/build_scripts/build.sh"
cd "$BUILD_DIR"
set +e
ctest --output-on-failure -j"$(nproc)" "$@" > "$BUILD_DIR/ctest.log" 2>&1
status=$?
set -e
# Failures in full, then per-suite counts and CTest's own closing summary.
grep -E -v "^\s+(Start|[0-9]+/[0-9]+ Test) .*Passed" "$BUILD_DIR/ctest.log" | grep -v "^\s*Start " | sed -n '/tests passed/q;p' | tail -n 400
grep -E "^\s*[0-9]+/[0-9]+ Test" "$BUILD_DIR/ctest.log" | sed -E 's/.*Test +#[0-9]+: ([^. ]+)\..*(Passed|Failed|\*\*\*[A-Za-z]+).*/\1 \2/' \
  | sort | uniq -c | awk '{printf "  %-10s %-10s %d\n", $2, $3, $1}'
sed -n '/tests passed/,$p' "$BUILD_DIR/ctest.log"
blender_skips | sed 's/^/  note: /'
exit $status
