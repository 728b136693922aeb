#!/usr/bin/env bash
# package.install: builds the packages (build_scripts/package.sh) and checks the Linux ones as a user gets them
# (the Windows ones: tests/package/windows.sh; the macOS ones: check_macos.py).
#   1. wheels: `auditwheel show` of each module wheel, which must be manylinux_2_28_x86_64 (check_wheels.py);
#      one per Python the Blenders below run (cp311; cp313 for Blender 5.1+), all listed in the extension.
#   2. every Blender named in $QUATCURVE_BLENDERS (NAME=COMMAND;…): installs the right package into a clean
#      user directory, bakes once and fits once (install_and_bake.py).
#   3. `pip wheel .` with the platform's default compiler, as a CI on any platform builds it (the recipe
#      in pyproject.toml), and the module it builds imports and samples a curve.
#   4. the cibuildwheel configuration selects cp311 and cp313 on Linux, Windows and macOS.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
PY="$ROOT/.venv/bin/python"
# CTest's package.build has run package.sh already (QUATCURVE_PACKAGES_BUILT=1).
[ "${QUATCURVE_PACKAGES_BUILT:-}" = 1 ] || "$ROOT/build_scripts/package.sh"
version="$(sed -n 's/^version = "\(.*\)"/\1/p' "$ROOT/addon/quatcurve_blender/blender_manifest.toml")"
passed=0 failed=0
result() {  # NAME OK LOG [SUMMARY-PATTERN]
  if [ "$2" = 0 ]; then
    passed=$((passed + 1)); echo "package/$1: $(grep -E "${4:-^}" "$3" | tr '\n' ' ')"
  else
    failed=$((failed + 1)); echo "package/$1 FAILED:"; tail -20 "$3"
  fi
}
IFS=';' read -ra blenders <<< "${QUATCURVE_BLENDERS:?set QUATCURVE_BLENDERS}"

# ---- 1. the wheels -------------------------------------------------------------------------------
expect=(--expect cp311)
for entry in "${blenders[@]}"; do
  cmd="${entry#*=}"
  [ "$(basename "$cmd")" = blender ] && continue
  tag="$("$cmd" -c 'import sys; print("cp%d%d" % sys.version_info[:2])' 2>/dev/null || true)"
  [ -n "$tag" ] && [[ " ${expect[*]} " != *" $tag "* ]] && expect+=(--expect "$tag")
done
log="$(mktemp)"
ok=0; "$PY" "$ROOT/tests/package/check_wheels.py" "$ROOT/dist" "${expect[@]}" > "$log" 2>&1 || ok=$?
cat "$log"
result wheels "$ok" "$log" "^wheels:"
rm -f "$log"

# ---- 2. install, bake and fit in every Blender ---------------------------------------------------
for entry in "${blenders[@]}"; do
  name="${entry%%=*}" cmd="${entry#*=}"
  user="$(mktemp -d)"
  if [ "$(basename "$cmd")" = blender ]; then
    zip="$ROOT/dist/quatcurve_blender-$version-legacy-linux-x64-cp311.zip"
    run=(env PATH=/usr/local/bin:/usr/bin:/bin BLENDER_USER_SCRIPTS="$user/scripts" BLENDER_USER_CONFIG="$user/config"
         "$cmd" --background --factory-startup --python-exit-code 1 --python "$ROOT/tests/package/install_and_bake.py" -- "$zip")
  else
    zip="$ROOT/dist/quatcurve_blender-$version-extension.zip"
    run=(env BLENDER_USER_RESOURCES="$user" "$cmd" "$ROOT/tests/package/install_and_bake.py" "$zip")
  fi
  ok=0; (cd "$user" && "${run[@]}") > "$user.log" 2>&1 || ok=$?
  result "$name" "$ok" "$user.log" "^(native module|baked|fitted):"
  rm -rf "$user" "$user.log"
done

# ---- 3. pip wheel . with the default compiler ----------------------------------------------------
out="$(mktemp -d)"
ok=0
{
  env SKBUILD_BUILD_DIR="$ROOT/build-wheels/cmake-default" CMAKE_BUILD_PARALLEL_LEVEL="${CMAKE_BUILD_PARALLEL_LEVEL:-2}" \
    "$PY" -m pip wheel "$ROOT" --no-deps --disable-pip-version-check -q -w "$out/wheel" 2>&1 | grep -v "^WARNING: Location" || true
  wheel="$(ls "$out"/wheel/quatcurve-*.whl)"
  # For comparison only: what this machine's compiler makes needs this machine's glibc.
  needs="$("$ROOT/.venv/bin/auditwheel" show "$wheel" 2>/dev/null | tr '\n' ' ' | grep -o 'platform tag: "[^"]*"' || true)"
  echo "pip wheel .: $(basename "$wheel") ($(( $(stat -c %s "$wheel") / 1024 )) KiB; auditwheel show: ${needs:-no tag})"
  (cd "$out" && "$PY" -m zipfile -e "$wheel" mod && cd mod && "$PY" -c '
import numpy as np, quatcurve as qc
q = qc.Curve([0.0, 10.0], [[1, 0, 0, 0], [0, 0, 0, 1]], "SLERP").sample([5.0])
angle = np.degrees(qc.angle_between(q, [1.0, 0.0, 0.0, 0.0]))[0]
assert abs(angle - 90.0) < 1e-9, angle
print("pip wheel . module: %s imports, SLERP midpoint turns %.6f deg (expected 90)" % (qc.__file__.rsplit("/", 1)[-1], angle))')
} > "$out/log" 2>&1 || ok=$?
result pip-wheel "$ok" "$out/log" "^pip wheel \."
rm -rf "$out"

# ---- 4. the cibuildwheel recipe ------------------------------------------------------------------
log="$(mktemp)"
ok=0
{
  for platform in linux windows macos; do
    ids="$(cd "$ROOT" && "$ROOT/.venv/bin/cibuildwheel" --print-build-identifiers --platform "$platform" | tr '\n' ' ')"
    echo "cibuildwheel $platform: $ids"
    for py in cp311 cp313; do [[ "$ids" == *"$py-"* ]] || { echo "no $py build for $platform"; exit 1; }; done
  done
} > "$log" 2>&1 || ok=$?
result cibuildwheel "$ok" "$log" "^cibuildwheel "
rm -f "$log"

echo "package: $passed passed, $failed failed"
[ "$failed" = 0 ]
