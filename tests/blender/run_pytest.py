"""Runs pytest inside a Blender: `blender --background --python run_pytest.py -- ARGS` (Debian's
binary, whose system Python has python3-pytest) or `PYTHON run_pytest.py ARGS` (a venv with bpy)."""

import hashlib
import os
import sys
import tempfile

import pytest


def base_temp():
    """pytest's base directory for this source tree and this Blender, emptied by pytest when a run
    starts. pytest's default, a new numbered directory per run, is cleaned up only at interpreter
    exit, which the bpy module skips (os._exit below): each run would leave its scenes' .blend files
    behind. Two runs of one Blender on one tree at once need their own --basetemp."""
    tree = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    key = hashlib.sha1((tree + "\0" + sys.executable).encode()).hexdigest()[:12]
    parent = os.path.join(tempfile.gettempdir(), "quatcurve-pytest")
    os.makedirs(parent, exist_ok=True)
    return os.path.join(parent, key)


args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
if not any(a == "--basetemp" or a.startswith("--basetemp=") for a in args):
    args = ["--basetemp", base_temp(), *args]
code = int(pytest.main(["-q", "-p", "no:cacheprovider", "-rs", *args]))
sys.stdout.flush()
sys.stderr.flush()
if "--" in sys.argv:
    sys.exit(code)  # the Blender binary: its own exit path is reliable
# The bpy module can deadlock in its exit-time destructors (seen with 4.5): the verdict is known, leave.
os._exit(code)
