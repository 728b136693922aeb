"""Runs pytest inside a Blender: `blender --background --python run_pytest.py -- ARGS` (Debian's
binary, whose system Python has python3-pytest) or `PYTHON run_pytest.py ARGS` (a venv with bpy)."""

import sys

import pytest

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
code = int(pytest.main(["-q", "-p", "no:cacheprovider", "-rs", *args]))
sys.stdout.flush()
sys.exit(code)
