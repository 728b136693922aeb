"""Runs pytest inside a Blender: `blender --background --python run_pytest.py -- ARGS` (Debian's
binary, whose system Python has python3-pytest) or `PYTHON run_pytest.py ARGS` (a venv with bpy)."""

import os
import sys

import pytest

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
code = int(pytest.main(["-q", "-p", "no:cacheprovider", "-rs", *args]))
sys.stdout.flush()
sys.stderr.flush()
if "--" in sys.argv:
    sys.exit(code)  # the Blender binary: its own exit path is reliable
# The bpy module can deadlock in its exit-time destructors (seen with 4.5): the verdict is known, leave.
os._exit(code)
