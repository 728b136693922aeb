#!/usr/bin/env bash
# package.windows: the Windows packages of dist/ (build_scripts/package.sh) run on this Linux machine under
# wine (Debian wine64), in python.org's embeddable Windows CPython 3.11 and 3.13, signature-checked
# (build_scripts/cross_inputs.py), and in Blender's own Windows builds as Python modules (PyPI bpy):
#   1. each win_amd64 module needs only its python3XX.dll, KERNEL32 and the UCRT (objdump -p);
#   2. it imports under wine and samples a SLERP midpoint;
#   3. the native Python tests (tests/python) that wine's numpy and scipy allow (see WINE_LEFT_OUT);
#   4. Windows bpy 4.5.15 (cp311) and 5.2.3 (cp313) install the extension zip into a clean user folder whose
#      path holds a space and a non-ASCII letter, bake once and fit once (tests/package/install_and_bake.py:
#      Blender's own playback within 0.05° of the module's curve).
# Skips (CTest counts it skipped) only where wine64 is not installed. The Windows inputs are fetched once into
# the cache by cross_inputs.py (build_scripts/setup.sh does it beforehand).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/../../build_scripts/common.sh"

WINE=/usr/lib/wine/wine64  # Debian's wine64 package; /usr/bin/wine is a launcher that looks for 32-bit wine first
[ -x "$WINE" ] || WINE="$(command -v wine64 || true)"
if [ -z "$WINE" ]; then
  echo "package.windows SKIPPED: wine64 is not installed (Debian wine64; build_scripts/setup.sh installs it)"
  exit 0
fi
WINESERVER="$(dirname "$WINE")/wineserver"
[ -x "$WINESERVER" ] || WINESERVER="$(command -v wineserver)"
version="$(sed -n 's/^version = "\(.*\)"/\1/p' "$ROOT/addon/quatcurve_blender/blender_manifest.toml")"
extension="$ROOT/dist/quatcurve_blender-$version-extension.zip"
# Python minor, its tag, the bpy release that runs it.
MINORS=("3.11 cp311 4.5.15" "3.13 cp313 5.2.3")
# tests/python left out under wine, and why (every other file runs; the cp313 run also leaves out the files
# whose oracle is scipy, which has no wheel that wine 8 runs for Python 3.13):
WINE_LEFT_OUT=(
  "test_fuzz.py"    # 100,000 cases in child processes under resource limits (POSIX `resource`): minutes, and the
                    # module's behaviour is the same as on Linux, which runs it
  "test_docs.py"    # reads the documents; no module
  "test_flamenco.py"  # needs node
  "test_curve.py"   # its scipy oracle uses Rotation(scalar_first=...) (scipy 1.14+); wine 8 runs scipy < 1.14 only
)
# Tests left out by name: their scipy oracle takes N-dimensional Rotation arrays (scipy 1.15+).
WINE_DESELECTED="not test_euler_filter_keeps_orientations_and_removes_jumps"
# The files whose oracle reaches scipy: they import it, or fcurve_reference.py (which imports it inside).
SCIPY_FILES="$(cd "$ROOT/tests/python" && grep -l -E "^\s*(import scipy|from scipy|import fcurve_reference)" test_*.py | tr '\n' ' ')"

# PYTHONDONTWRITEBYTECODE: the Linux suites' .pyc files of tests/ have the same names; PYTHONIOENCODING: the
# console's code page would turn ° into ?.
export WINEPREFIX="$VENV_CACHE/cross/wineprefix" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml=" \
  PYTHONDONTWRITEBYTECODE=1 PYTHONIOENCODING=utf-8
work="$(mktemp -d "${TMPDIR:-/tmp}/quatcurve wine é.XXXXXX")"
win() { printf 'Z:%s' "${1//\//\\}"; }  # wine maps / to drive Z:
cross_inputs() { "$VENV/bin/python" "$ROOT/build_scripts/cross_inputs.py" "$@"; }
# One wineserver for every run below (each wine start then takes ~2 s, not ~15), its background
# processes started once with no terminal (they would hold a run's output pipe open).
"$WINESERVER" -p < /dev/null > /dev/null 2>&1
trap '"$WINESERVER" -k 2>/dev/null || true; rm -rf "$work"' EXIT
"$WINE" "$(cross_inputs windows-python 3.11)/python.exe" -c "" < /dev/null > /dev/null 2>&1 || true

# wpython MINOR PYTHONPATH COMMAND...: the embeddable CPython MINOR under wine (output through cat: wine's
# console handling otherwise rewrites it), PYTHONPATH a ;-list of Windows paths.
wpython() {
  local minor="$1" path="$2"; shift 2
  (cd "$work" && PYTHONPATH="$path" "$WINE" "$(cross_inputs windows-python "$minor")/python.exe" "$@" < /dev/null 2>&1 | cat)
  return "${PIPESTATUS[0]}"
}

passed=0 failed=0
result() {  # NAME OK LOG [SUMMARY-PATTERN]
  if [ "$2" = 0 ]; then
    passed=$((passed + 1)); echo "package.windows/$1: $(grep -E "${4:-^}" "$3" | tr '\n' ' ')"
  else
    failed=$((failed + 1)); echo "package.windows/$1 FAILED:"; tail -30 "$3"
  fi
}

for entry in "${MINORS[@]}"; do
  read -r minor tag bpy <<< "$entry"
  if ! ls "$ROOT"/dist/wheels/quatcurve-*-"$tag"-"$tag"-*.whl > /dev/null 2>&1; then
    echo "package.windows/$tag: left out: no $tag wheel of any platform in dist/ (no Python $minor here to build one)"
    continue
  fi
  log="$work/$tag.log" module="$work/module-$tag"
  mkdir -p "$module"

  # ---- 1. the module's DLLs ----------------------------------------------------------------------
  ok=0
  {
    wheel="$(ls "$ROOT"/dist/wheels/quatcurve-*-"$tag"-"$tag"-win_amd64.whl)"
    "$VENV/bin/python" -m zipfile -e "$wheel" "$module"
    pyd="$(ls "$module"/quatcurve*.pyd)"
    dlls="$(objdump -p "$pyd" | sed -n 's/^\s*DLL Name: //p' | sort -u)"
    extra="$(grep -v -x -E "python${tag#cp}\.dll|KERNEL32\.dll|api-ms-win-crt-[a-z]+-l1-1-0\.dll" <<< "$dlls" || true)"
    [ -z "$extra" ] || { echo "$(basename "$pyd") needs $(echo $extra) (only python${tag#cp}.dll, KERNEL32 and the UCRT allowed)"; exit 1; }
    echo "module: $(basename "$wheel") $(( $(stat -c %s "$wheel") / 1024 )) KiB; $(basename "$pyd") needs $(echo $dlls | tr ' ' ',')"
  } > "$log" 2>&1 || ok=$?
  result "$tag-dlls" "$ok" "$log" "^module:"

  # ---- 2. import and sample ------------------------------------------------------------------------
  site="$(cross_inputs windows-site "tests-$tag")"
  ok=0
  wpython "$minor" "$(win "$module");$(win "$site")" -c '
import sys, numpy as np, quatcurve as qc
q = qc.Curve([0.0, 10.0], [[1, 0, 0, 0], [0, 0, 0, 1]], "SLERP").sample([5.0])
angle = np.degrees(qc.angle_between(q, [1.0, 0.0, 0.0, 0.0]))[0]
assert abs(angle - 90.0) < 1e-9, angle
print("imported: %s in CPython %s (win32) under wine, numpy %s: SLERP midpoint %.6f deg (expected 90)"
      % (qc.__file__.rsplit("\\", 1)[-1], sys.version.split()[0], np.__version__, angle))' > "$log" 2>&1 || ok=$?
  result "$tag-import" "$ok" "$log" "^imported:"

  # ---- 3. the native Python tests ----------------------------------------------------------------
  args=(-m pytest -q -p no:cacheprovider)
  for f in "${WINE_LEFT_OUT[@]}"; do args+=(--ignore "$(win "$ROOT/tests/python/$f")"); done
  args+=(-k "$WINE_DESELECTED")
  if [ "$tag" != cp311 ]; then  # no scipy here
    for f in $SCIPY_FILES; do args+=(--ignore "$(win "$ROOT/tests/python/$f")"); done
  fi
  ok=0
  wpython "$minor" "$(win "$module");$(win "$site")" "${args[@]}" "$(win "$ROOT/tests/python")" > "$log" 2>&1 || ok=$?
  result "$tag-pytest" "$ok" "$log" "(passed|failed)"

  # ---- 4. Blender's own Windows build installs the extension, bakes and fits -------------------------
  bpysite="$(cross_inputs windows-site "bpy-$bpy")"
  user="$work/user $tag ü"
  mkdir -p "$user"
  ok=0
  BLENDER_USER_RESOURCES="$(win "$user")" wpython "$minor" "$(win "$bpysite");$(win "$site")" \
    "$(win "$ROOT/tests/package/install_and_bake.py")" "$(win "$extension")" > "$log" 2>&1 || ok=$?
  result "bpy-$bpy" "$ok" "$log" "^(Blender|native module|baked|fitted):?"
done

echo "package.windows: $passed passed, $failed failed"
[ "$failed" = 0 ]
