#!/usr/bin/env bash
# The main command: installs what is missing, builds, then shows what QuatCurve does, all in Blender's
# background mode through the command line (addon/quatcurve_blender/cli.py):
#   1. the native core on the seed's worked examples (build_scripts/demo_native.py);
#   2. a demo scene built from scratch (build_scripts/demo_scene.py): the fixed-angle example, a 720°
#      spin, quaternion keys in opposite hemispheres, and an armature from ../shared/data/mocap/
#      mocapbank.bvh when that file is present;
#   3. that scene baked with SLERP, SQUAD and SPLINE_C2 into out/demo_<method>.blend (one file per
#      method: a bake reads the target's current action, so each method bakes from the original keys);
#   4. the comparison (with the SPLINE_C2 bake): out/report.json and one plot PNG per target beside
#      it, then the comparison table read from report.json;
#   5. the fit (cli.py --fit, SQUAD): FixedAngle, Hemisphere and Mocap keep their own keys and get fitted
#      handles and generated keys in out/demo_fit.blend; a fresh Blender without the add-on then plays
#      it at every frame and 4 subframes against the native curve (build_scripts/demo_fit_check.py).
#
#   build_scripts/demo.sh [--quick]
# --quick: SLERP and SPLINE_C2 on the three objects only (no motion capture) — the CTest test demo.quick.
# Environment: QUATCURVE_SKIP_SETUP=1 skips setup and build (ctest runs after the build);
# QUATCURVE_DEMO_OUT=DIR writes there instead of out/. Uses Debian's Blender binary, or the first bpy
# venv when the binary is missing.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

quick=0
for arg in "$@"; do
  case "$arg" in
    --quick) quick=1 ;;
    -h|--help) sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown argument $arg (see --help)" ;;
  esac
done

if [ -z "${QUATCURVE_SKIP_SETUP:-}" ]; then
  "$ROOT/build_scripts/setup.sh"
  "$ROOT/build_scripts/build.sh"
fi
OUT="${QUATCURVE_DEMO_OUT:-$ROOT/out}"
BVH="$(cd "$ROOT/.." && pwd)/shared/data/mocap/mocapbank.bvh"
CLI="$ROOT/addon/quatcurve_blender/cli.py"
start=$SECONDS

# A Blender runs a script: the binary in background mode, or a bpy venv's Python. A system Blender
# finds its Python through PATH, so PATH is the system's (a venv first on PATH would mislead it).
if [ -x "$BLENDER_BIN" ]; then
  blender_name="$("$BLENDER_BIN" --version 2>/dev/null | awk '/^Blender/{print $1" "$2; exit}') ($BLENDER_BIN)"
  run_script() { local script="$1"; shift
    env PATH=/usr/local/bin:/usr/bin:/bin "$BLENDER_BIN" --background --factory-startup --python-exit-code 1 \
      --python "$script" -- "$@"; }
  cli_shown="blender -b --python addon/quatcurve_blender/cli.py --"
  blender_minor="$BLENDER_BIN_PYTHON_MINOR"
else
  bpy_py=""
  for v in $BPY_VERSIONS; do [ -x "$(bpy_python "$v")" ] && { bpy_py="$(bpy_python "$v")"; blender_name="bpy $v ($bpy_py)"; blender_minor="$(bpy_python_minor "$v")"; break; }; done
  [ -n "$bpy_py" ] || die "no Blender: neither $BLENDER_BIN nor a bpy venv under $VENV_CACHE (run build_scripts/setup.sh)"
  run_script() { local script="$1"; shift; PYTHONPATH="$ROOT/addon" "$bpy_py" "$script" "$@"; }
  cli_shown="PYTHONPATH=addon python -m quatcurve_blender.cli"
fi
# Blender's own start, end and Info lines are left out (5.2 logs "Read blend" behind a time and a category).
quiet_blender() { sed -u -E '/^(Blender [0-9][0-9.]*( \(hash .*\))?|([0-9:.]+ +[a-z_.]+ +\| )?Read blend: .*|Info: .*|Blender quit)$/d'; }
section() { printf '\n== %s\n' "$*"; }

section "1. The native core on the seed's examples"
PYTHONPATH="$BUILD_DIR/python" "$VENV/bin/python" "$ROOT/build_scripts/demo_native.py"

section "2. The demo scene, built from scratch in $blender_name"
mkdir -p "$OUT"
rm -f "$OUT"/demo_*.blend "$OUT"/report.json "$OUT"/report_*.png
scene="$OUT/demo_scene.blend"
if [ "$quick" = 1 ]; then
  echo "quick mode: no motion capture"
  run_script "$ROOT/build_scripts/demo_scene.py" "$scene" | quiet_blender
elif [ -f "$BVH" ]; then
  run_script "$ROOT/build_scripts/demo_scene.py" "$scene" "$BVH" | quiet_blender
else
  echo "note: $BVH is not present: the scene has no motion-capture armature"
  run_script "$ROOT/build_scripts/demo_scene.py" "$scene" | quiet_blender
fi

section "3. Baking with several methods through the command line"
if [ "$quick" = 1 ]; then methods="SLERP SPLINE_C2"; else methods="SLERP SQUAD SPLINE_C2"; fi
last="${methods##* }"
for method in $methods; do
  lower="$(echo "$method" | tr 'A-Z' 'a-z')"
  args=(--method "$method" --output "$OUT/demo_$lower.blend")
  # The comparison rides along with the last bake (it reads the original keys, before baking).
  [ "$method" = "$last" ] && args+=(--compare --subframes 4 --report "$OUT/report.json")
  echo "\$ $cli_shown ${args[*]//$ROOT\//} ${scene#$ROOT/}"
  run_script "$CLI" "${args[@]}" "$scene" | quiet_blender
  echo
done

section "4. The comparison"
"$VENV/bin/python" "$ROOT/build_scripts/demo_table.py" "$OUT/report.json"

section "5. Fitting the animator's keys through the command line, measured by Blender"
fit_targets="FixedAngle,Hemisphere"
[ -f "$BVH" ] && [ "$quick" = 0 ] && fit_targets="$fit_targets,Mocap"
fit_args=(--fit --method SQUAD --tolerance 0.05 --subframes 4 --objects "$fit_targets" --output "$OUT/demo_fit.blend")
echo "\$ $cli_shown ${fit_args[*]//$ROOT\//} ${scene#$ROOT/}"
run_script "$CLI" "${fit_args[@]}" "$scene" | quiet_blender
echo
# The check loads the module built for the Python of the Blender that runs it (build.sh).
run_script "$ROOT/build_scripts/demo_fit_check.py" "$OUT/demo_fit.blend" "$(module_build_dir "$blender_minor")/python" SQUAD 0.05 4 \
  ${fit_targets//,/ } | quiet_blender

section "Written under ${OUT#$ROOT/}/"
for f in "$OUT"/demo_*.blend "$OUT"/report.json; do echo "  $(basename "$f")"; done
pngs=("$OUT"/report_*.png)
[ -f "${pngs[0]}" ] || die "no plot was written"
echo "  report_<target>.png: ${#pngs[@]} plots ($(basename "${pngs[0]}"), …)"
echo "demo finished in $((SECONDS - start)) s (open the .blend files in Blender; the plots are PNG images)"
