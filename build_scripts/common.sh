# Shared settings for the build scripts; sourced, not run.
# Override any of these from the environment.
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${QUATCURVE_BUILD_DIR:-$ROOT/build}"
# The bpy module wheels are large (~400 MB each): their venvs live in a per-user cache shared by
# every clone, keyed by version, so a fresh clone does not download them again.
VENV_CACHE="${QUATCURVE_VENV_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/quatcurve}"

# The Blenders the background suites run in. Each embeds one CPython minor and loads only a module
# built for it, so the module is built once per minor: cp311 serves 3.4.1, 4.5 and 5.0, cp313 serves
# 5.2. The builds sit side by side in the add-on (the ABI tag in the file name keeps them apart).
#   Debian's Blender binary (3.4.1 on Debian 12) and the system Python it runs.
BLENDER_BIN="${QUATCURVE_BLENDER:-/usr/bin/blender}"
BLENDER_BIN_PYTHON_MINOR="${QUATCURVE_BLENDER_PYTHON_MINOR:-3.11}"
#   Blender as a Python module, one venv each: the 4.5 LTS and 5.0 (cp311), the 5.2 LTS (cp313).
BPY_VERSIONS="${QUATCURVE_BPY_VERSIONS-4.5.15 5.0.1 5.2.3}"
# The primary build: $BUILD_DIR with every test and the python.pytest suite, its venv $VENV (below).
# Each other minor a Blender needs gets a module-only build in $BUILD_DIR/cp<MM> and a build venv.
PYTHON_MINOR="${QUATCURVE_PYTHON_MINOR:-3.11}"

# ccache (setup.sh installs it) keeps every compiled object under ~/.cache/ccache: a second clone, or a
# second tree of the same flags, compiles nothing it compiled before. Paths below the clone are hashed
# relative to it, so clones in different folders share the cache.
if command -v ccache >/dev/null 2>&1 && [ -z "${QUATCURVE_NO_CCACHE:-}" ]; then
  CCACHE_LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  export CCACHE_BASEDIR="$ROOT" CCACHE_NOHASHDIR=1
else
  CCACHE_LAUNCHER=()
fi

log() { printf '[quatcurve] %s\n' "$*" >&2; }
die() { printf '[quatcurve] error: %s\n' "$*" >&2; exit 1; }

as_root() {
  if [ "$(id -u)" = 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
    die "need root to run: $* (install it by hand or run as root)"; fi
}

# bpy_python_minor VERSION: the CPython minor a bpy release on PyPI is built for (Blender follows
# the VFX reference platform: 3.4–4.0 on 3.10, 4.1–5.0 on 3.11, 5.1 and later on 3.13).
bpy_python_minor() {
  case "$1" in
    3.*|4.0|4.0.*) echo 3.10 ;;
    4.*|5.0|5.0.*) echo 3.11 ;;
    *) echo 3.13 ;;
  esac
}

# find_python MINOR: an interpreter of that CPython minor, or nothing: the system's (Debian's), else
# the newest pyenv build, else one on PATH (a pyenv shim counts only if it runs).
find_python() {
  local minor="$1" p pyenv_root="${PYENV_ROOT:-$HOME/.pyenv}"
  [ -x "/usr/bin/python$minor" ] && { echo "/usr/bin/python$minor"; return; }
  command -v pyenv >/dev/null 2>&1 && pyenv_root="$(pyenv root)"
  p="$(ls -d "$pyenv_root/versions/$minor".*/bin/python 2>/dev/null | sort -V | tail -1)"
  [ -n "$p" ] && [ -x "$p" ] && { echo "$p"; return; }
  p="$(command -v "python$minor" 2>/dev/null)" || return 0
  "$p" -c '' >/dev/null 2>&1 && echo "$p"
  return 0
}

# base_python [MINOR]: the interpreter venvs of that minor (default $PYTHON_MINOR) are made from.
base_python() {
  local minor="${1:-$PYTHON_MINOR}" p
  p="$(find_python "$minor")"
  [ -n "$p" ] || die "no Python $minor found: $(python_missing "$minor")"
  echo "$p"
}

python_missing() {
  echo "looked for /usr/bin/python$1, \$(pyenv root)/versions/$1.*/bin/python and python$1 on PATH"
}

bpy_python() { echo "$VENV_CACHE/bpy-$1/bin/python"; }

# The pinned zig (PyPI ziglang, build_scripts/requirements-dev.txt) that builds the packages lives in a
# venv of the per-user cache, at one path for every clone: zig keys its cache of the libc++ and libc it
# builds for each target (~/.cache/zig) by its own library's path, so a zig inside each clone's .venv
# would build them again in every clone.
zig_venv() { echo "$VENV_CACHE/$(grep -E '^ziglang==' "$ROOT/build_scripts/requirements-dev.txt" | sed 's/==/-/')"; }

# build_venv MINOR / module_build_dir MINOR: the venv whose interpreter and pybind11 build the module
# for MINOR (the root .venv is Python 3.11's, Debian 12's own; another minor's is .venv-cp<MM>), and
# the build directory of that module.
build_venv() { if [ "$1" = 3.11 ]; then echo "$ROOT/.venv"; else echo "$ROOT/.venv-cp${1/./}"; fi; }
module_build_dir() { if [ "$1" = "$PYTHON_MINOR" ]; then echo "$BUILD_DIR"; else echo "$BUILD_DIR/cp${1/./}"; fi; }
# The primary build's venv: the pinned development requirements (numpy, scipy, pytest, pybind11, …).
VENV="$(build_venv "$PYTHON_MINOR")"

# load_blenders: BLENDERS, one "NAME MINOR COMMAND" line per Blender to test (COMMAND: a blender
# executable, or a bpy venv's python, which exists once setup.sh has run), and PYTHONS, "MINOR PATH"
# per minor found here. Computed once per shell (asking the binary its version starts it): call it
# before using the functions below from command substitutions.
load_blenders() {
  [ -n "${BLENDERS+set}" ] && return
  local v minor p
  BLENDERS="" PYTHONS=""
  if [ -x "$BLENDER_BIN" ]; then
    BLENDERS="$("$BLENDER_BIN" --version 2>/dev/null | awk '/^Blender/{print $2; exit}') $BLENDER_BIN_PYTHON_MINOR $BLENDER_BIN"$'\n'
  fi
  for v in $BPY_VERSIONS; do BLENDERS+="bpy-$v $(bpy_python_minor "$v") $(bpy_python "$v")"$'\n'; done
  for minor in $(printf '%s\n' "$PYTHON_MINOR" $(awk '{print $2}' <<< "$BLENDERS") | awk 'NF && !seen[$0]++'); do
    p="$(find_python "$minor")"
    if [ -n "$p" ]; then PYTHONS+="$minor $p"$'\n'; fi
  done
}

# have_python MINOR: whether an interpreter of that minor was found (see load_blenders).
have_python() { load_blenders; grep -q "^$1 " <<< "$PYTHONS"; }

# blender_list: NAME=COMMAND;… of every Blender whose Python is here (so its module can be built).
blender_list() {
  load_blenders
  local list="" name minor cmd
  while read -r name minor cmd; do
    [ -n "$name" ] && have_python "$minor" && list="$list;$name=$cmd"
  done <<< "$BLENDERS"
  echo "${list#;}"
}

# blender_skips: one line per Blender left out of blender_list, saying why.
blender_skips() {
  load_blenders
  local name minor cmd
  while read -r name minor cmd; do
    [ -n "$name" ] && ! have_python "$minor" &&
      echo "the $name suite is skipped: it runs Python $minor, and no Python $minor is here to build the module for it ($(python_missing "$minor"))"
  done <<< "$BLENDERS"
  return 0
}

# python_minors: the minors to build the module for ($PYTHON_MINOR first), each with a Blender to run it.
python_minors() {
  load_blenders
  local name minor cmd
  { echo "$PYTHON_MINOR"
    while read -r name minor cmd; do
      [ -n "$name" ] && have_python "$minor" && echo "$minor"
    done <<< "$BLENDERS"; } | awk '!seen[$0]++'
}
