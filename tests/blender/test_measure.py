"""One measurement of the angle between rotations everywhere: a known 10° difference measures 10°
through quatcurve.angle_between, the tests' helpers and the demo's "measured by Blender" check
(build_scripts/demo_fit_check.py, run in a fresh process as the demo runs it)."""
import math
import os
import re
import subprocess
import sys

import bpy
import numpy as np
import pytest

from bake_helpers import add_empty, angles_between
from conftest import ROOT
from quatcurve_blender import fcurves, fit, native

CHECK = os.path.join(ROOT, "build_scripts", "demo_fit_check.py")
MODULE_DIR = os.path.join(ROOT, "addon", "quatcurve_blender")
IS_BINARY = bool(bpy.app.binary_path)


def about(axis, degrees):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    half = math.radians(degrees) / 2
    return np.r_[math.cos(half), math.sin(half) * axis]


ROTATIONS = [about((0, 0, 1), 0), about((1, 2, 3), 75), about((0, 1, 0), 170), about((1, -1, 0), 355)]


@pytest.mark.parametrize("start", range(len(ROTATIONS)))
def test_a_10_degree_difference_measures_10_degrees(addon, start):
    a = ROTATIONS[start]
    b = native.require().quat_multiply(a, about((3, -1, 2), 10))
    for measured in (native.require().angle_between(a, b), angles_between(a[None], b[None])[0],
                     native.require().angle_between(a, -b)):
        assert math.degrees(float(measured)) == pytest.approx(10.0, abs=1e-9)


def test_demo_fit_check_measures_a_10_degree_error_as_10_degrees(scene, tmp_path):
    """A quaternion object whose two animator keys hold still, with one key the fit would have
    generated turned 10° off between them: Blender plays 10° away from every method's curve there."""
    obj = add_empty("Held", "QUATERNION")
    still, off = about((0, 0, 1), 30), native.require().quat_multiply(about((0, 0, 1), 30), about((1, 0, 0), 10))
    for frame, q in ((1, still), (5, off), (9, still)):
        obj.rotation_quaternion = q
        obj.keyframe_insert("rotation_quaternion", frame=frame)
    for curve in fcurves.Channels.of(obj).find_all(obj.path_from_id("rotation_quaternion"), 4):
        curve.keyframe_points[1].type = fit.GENERATED_NAME
        for point in curve.keyframe_points:
            point.interpolation = "LINEAR"
    blend = str(tmp_path / "held.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    args = [blend, MODULE_DIR, "SLERP", "20", "4", "Held"]
    if IS_BINARY:
        cmd = [bpy.app.binary_path, "--background", "--factory-startup", "--python", CHECK, "--"] + args
    else:
        cmd = [sys.executable, CHECK] + args
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, PYTHONNOUSERSITE="1"))
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    row = [line for line in proc.stdout.splitlines() if line.strip().startswith("Held")]
    assert row, proc.stdout
    assert float(re.search(r"([0-9.]+)°", row[0]).group(1)) == pytest.approx(10.0, abs=1e-3)
