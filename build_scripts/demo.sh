#!/usr/bin/env bash
# The main command: builds what is needed, then demonstrates the native core on the seed's worked
# examples. (The full Blender demo — bake, compare, report and plot — arrives with the CLI issue.)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

"$ROOT/build_scripts/setup.sh"
"$ROOT/build_scripts/build.sh"
"$VENV/bin/python" "$ROOT/build_scripts/demo_native.py"
