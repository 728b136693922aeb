"""The benchmarks' `--help` (tests/bench/smoke.py): each prints its own docstring and exits 0
without running. The benchmarks that need no Blender are run here, in this build's Python; the ones
run by Blender share the same smoke.run."""

import ast
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench"
PLAIN = sorted(p for p in BENCH.glob("*.py")
               if p.name != "smoke.py" and "\nimport bpy" not in "\n" + p.read_text(encoding="utf-8"))


@pytest.mark.parametrize("script", PLAIN, ids=lambda p: p.name)
@pytest.mark.parametrize("flag", ["--help", "-h"])
def test_help_prints_the_docstring_and_runs_nothing(script, flag):
    text = script.read_text(encoding="utf-8")
    if ("scipy" in text or "test_curve_tangents" in text) and importlib.util.find_spec("scipy") is None:
        pytest.skip("%s imports scipy, absent here" % script.name)  # (the Windows cp313 suite has none)
    doc = ast.get_docstring(ast.parse(text))
    assert doc, script.name
    # UTF-8 both ways, whatever the console's code page (Windows' is not: the docstrings have ° and —).
    done = subprocess.run([sys.executable, str(script), flag], capture_output=True, timeout=60,
                          env=dict(os.environ, PYTHONIOENCODING="utf-8"), cwd=BENCH.parents[1])
    assert done.returncode == 0, done.stderr.decode("utf-8", "replace")
    assert done.stdout.decode("utf-8").replace("\r\n", "\n").strip() == doc.strip()
