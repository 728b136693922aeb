#!/usr/bin/env bash
# package.install: builds the packages (build_scripts/package.sh) and checks the Linux ones as a user gets them
# (the Windows ones: tests/package/windows.sh; the macOS ones: check_macos.py).
#   1. wheels: `auditwheel show` of each module wheel, which must be manylinux_2_28_x86_64 (check_wheels.py);
#      one per Python the Blenders below run (cp311; cp313 for Blender 5.1+), all listed in the extension.
#   2. every Blender named in $QUATCURVE_BLENDERS (NAME=COMMAND;…): installs the right package into a clean
#      user directory, bakes once and fits once (install_and_bake.py).
#   3. the cibuildwheel configuration selects cp311 and cp313 on Linux, Windows and macOS.
# The recipe `pip wheel .` (pyproject.toml) is what step 1's wheels are built by, and the platform's default
# compiler builds the same CMakeLists.txt in build.sh: a third build with both would check nothing new.
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

# ---- 3. the cibuildwheel recipe ------------------------------------------------------------------
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
