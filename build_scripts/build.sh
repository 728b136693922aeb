#!/usr/bin/env bash
# Configures and builds everything (library, Python module, tests, benchmarks) into build/.
# Extra arguments go to CMake's configure step, e.g. -DQUATCURVE_SANITIZE=ON.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

mkdir -p "$BUILD_DIR"
cmake -S "$ROOT" -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release \
  -DPython_EXECUTABLE="$VENV/bin/python" \
  -Dpybind11_DIR="$("$VENV/bin/python" -m pybind11 --cmakedir)" \
  -DQUATCURVE_BLENDERS="$(blender_list)" "$@" >"$BUILD_DIR/configure.log" 2>&1 \
  || { cat "$BUILD_DIR/configure.log" >&2; die "CMake configure failed"; }
cmake --build "$BUILD_DIR" -j"$(nproc)" >"$BUILD_DIR/build.log" 2>&1 \
  || { grep -E -B2 -A12 "error|Error" "$BUILD_DIR/build.log" | head -150 >&2; die "build failed (full log: $BUILD_DIR/build.log)"; }
log "built $(ls "$BUILD_DIR"/python/quatcurve*.so)"
