#!/usr/bin/env bash
# Builds the installable packages into dist/:
#   dist/wheels/quatcurve-<v>-cp311-cp311-linux_x86_64.whl   the native module (pip wheel .)
#   dist/quatcurve_blender-<v>-legacy-cp311.zip              Blender 3.4–4.1: Preferences → Add-ons → Install
#   dist/quatcurve_blender-<v>-extension.zip                 Blender 4.2+: Install from Disk (validated)
# For Blender 5.1+ (Python 3.13) on a machine that has python3.13 and its headers:
#   QUATCURVE_PYTHON_MINOR=3.13 build_scripts/package.sh
# builds a cp313 wheel instead; wheels already in dist/wheels (e.g. a cp311 one) are listed in the
# extension too, so one extension zip can serve Blender 4.2–5.0 and 5.1+.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

"$ROOT/build_scripts/setup.sh"
DIST="$ROOT/dist"
mkdir -p "$DIST/wheels"
py="$(base_python)"
[ "$PYTHON_MINOR" = 3.11 ] && py="$VENV/bin/python"
log "building the module wheel with $py"
"$py" -m pip wheel "$ROOT" --no-deps -q -w "$DIST/wheels" 2>&1 | grep -v "^WARNING: Location" >&2 || true
ls "$DIST"/wheels/quatcurve-*-cp"${PYTHON_MINOR/./}"-*.whl >/dev/null 2>&1 || die "the wheel build failed"

# Blender's own extension tool ships with the bpy module (and with Blender ≥ 4.2 binaries).
ext=""
for v in $BPY_VERSIONS; do
  cand="$(ls -d "$VENV_CACHE/bpy-$v"/lib/python*/site-packages/bpy/*/scripts/addons_core/bl_pkg/cli/blender_ext.py 2>/dev/null | head -1)"
  [ -n "$cand" ] && { ext="$cand"; extpy="$(bpy_python "$v")"; }
done
wheels=()
for w in "$DIST"/wheels/quatcurve-*.whl; do wheels+=(--wheel "$w"); done
if [ -n "$ext" ]; then
  "$extpy" "$ROOT/build_scripts/package.py" "${wheels[@]}" --out "$DIST" --blender-ext "$ext"
else
  "$VENV/bin/python" "$ROOT/build_scripts/package.py" "${wheels[@]}" --out "$DIST"
fi
