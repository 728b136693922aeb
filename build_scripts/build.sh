#!/usr/bin/env bash
# Configures and builds everything (library, Python module, tests, benchmarks) into build/, then the
# module alone once more for every other Python minor a tested Blender runs (build/cp313 for bpy 5.2,
# with .venv-cp313's pybind11). Each build copies its module into addon/quatcurve_blender/, where the
# builds sit side by side (quatcurve.cpython-311-….so, quatcurve.cpython-313-….so).
# Extra arguments go to CMake's configure step of build/, e.g. -DQUATCURVE_SANITIZE=ON.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
[ -x "$VENV/bin/python" ] || die "$VENV is missing: run build_scripts/setup.sh first (build_scripts/test.sh runs both)"
load_blenders

# configure_and_build DIR PYTHON_VENV [CMAKE ARGS…] -- [BUILD ARGS…]
configure_and_build() {
  local dir="$1" venv="$2"; shift 2
  local configure=() build=()
  while [ $# -gt 0 ] && [ "$1" != -- ]; do configure+=("$1"); shift; done
  [ $# -gt 0 ] && shift
  build=("$@")
  mkdir -p "$dir"
  cmake -S "$ROOT" -B "$dir" -DCMAKE_BUILD_TYPE=Release "${CCACHE_LAUNCHER[@]}" \
    -DPython_EXECUTABLE="$venv/bin/python" \
    -Dpybind11_DIR="$("$venv/bin/python" -m pybind11 --cmakedir)" \
    "${configure[@]}" >"$dir/configure.log" 2>&1 \
    || { cat "$dir/configure.log" >&2; die "CMake configure of $dir failed"; }
  cmake --build "$dir" -j"$(nproc)" "${build[@]}" >"$dir/build.log" 2>&1 \
    || { grep -E -B2 -A12 "error|Error" "$dir/build.log" | head -150 >&2; die "build failed (full log: $dir/build.log)"; }
}

configure_and_build "$BUILD_DIR" "$VENV" -DQUATCURVE_BLENDERS="$(blender_list)" "$@"
log "built $(ls "$BUILD_DIR"/python/quatcurve*.so)"
for minor in $(python_minors); do
  [ "$minor" = "$PYTHON_MINOR" ] && continue
  dir="$(module_build_dir "$minor")"
  # The library does not depend on Python: the primary tree's archive is linked, only the bindings compile.
  configure_and_build "$dir" "$(build_venv "$minor")" -DQUATCURVE_TESTS=OFF \
    -DQUATCURVE_CORE_LIBRARY="$BUILD_DIR/libquatcurve_core.a" -- --target quatcurve
  log "built $(ls "$dir"/python/quatcurve*.so) (Python $minor)"
done
