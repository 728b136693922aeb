# Shared settings for the build scripts; sourced, not run.
# Override any of these from the environment.
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${QUATCURVE_BUILD_DIR:-$ROOT/build}"
VENV="$ROOT/.venv"
# The bpy module wheels are large (~400 MB each): their venvs live in a per-user cache shared by
# every clone, keyed by version, so a fresh clone does not download them again.
VENV_CACHE="${QUATCURVE_VENV_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/quatcurve}"
# One CPython minor for every Blender we test (3.4.1 Debian, bpy 4.5, bpy 5.0 all run 3.11).
PYTHON_MINOR="${QUATCURVE_PYTHON_MINOR:-3.11}"
# Pinned Blender-as-a-module versions: the 4.5 LTS and the 5.0 series (cp311). Blender 5.1+ is
# cp313, and none is pinned for it yet: name some in QUATCURVE_BPY_VERSIONS on such a machine.
if [ "$PYTHON_MINOR" = 3.11 ]; then BPY_VERSIONS="${QUATCURVE_BPY_VERSIONS-4.5.15 5.0.1}"
else BPY_VERSIONS="${QUATCURVE_BPY_VERSIONS-}"; fi
# Debian's Blender binary (3.4.1 on Debian 12).
BLENDER_BIN="${QUATCURVE_BLENDER:-/usr/bin/blender}"

log() { printf '[quatcurve] %s\n' "$*" >&2; }
die() { printf '[quatcurve] error: %s\n' "$*" >&2; exit 1; }

as_root() {
  if [ "$(id -u)" = 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
    die "need root to run: $* (install it by hand or run as root)"; fi
}

# The base interpreter for the venvs: the system's python$PYTHON_MINOR first (Debian's), else any on PATH.
base_python() {
  local p
  for p in "/usr/bin/python$PYTHON_MINOR" "$(command -v "python$PYTHON_MINOR" 2>/dev/null)"; do
    [ -n "$p" ] && [ -x "$p" ] && { echo "$p"; return; }
  done
  die "python$PYTHON_MINOR not found (Debian 12: apt-get install python3)"
}

bpy_python() { echo "$VENV_CACHE/bpy-$1/bin/python"; }

# NAME=COMMAND;… list of every Blender the background tests run in.
blender_list() {
  local list="" v
  # Debian's binary runs Python 3.11: it can load only a cp311 build.
  [ -x "$BLENDER_BIN" ] && [ "$PYTHON_MINOR" = 3.11 ] && list="$("$BLENDER_BIN" --version 2>/dev/null | awk '/^Blender/{print $2; exit}')=$BLENDER_BIN"
  for v in $BPY_VERSIONS; do list="$list;bpy-$v=$(bpy_python "$v")"; done
  echo "${list#;}"
}
