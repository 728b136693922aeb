"""Undo after quatcurve.set_turns, in a Blender with a window (run under Xvfb by tests/blender/test_turns.py):

    xvfb-run -a blender --factory-startup --python tests/blender/sessions/turns_undo_session.py -- VERDICT.json

A timer (the window must exist first) builds a quaternion object with three keys, fits it (SQUAD),
pushes an undo step and records the file state (every action's digest and the turn records); then
selects the first key, sets 2 turns through the operator with an undo push (as a button press
does), checks that the file changed, runs ed.undo and compares the state with the recording. The
verdict goes to VERDICT.json; Blender then quits."""

import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session_kit  # noqa: E402  (it puts addon/ and tests/blender/ on the path)
from session_kit import differences, window_override  # noqa: E402

import quatcurve_blender  # noqa: E402
from quatcurve_blender import fcurves  # noqa: E402


def state():
    out = {"actions": {a.name: fcurves.action_digest(a) for a in bpy.data.actions}}
    out["turns"] = {a.name: [[r.owner_path, r.frame, r.turns] for r in a.quatcurve_turns] for a in bpy.data.actions}
    return out


def build():
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    obj = bpy.data.objects.new("Spin", None)
    scene.collection.objects.link(obj)
    obj.rotation_mode = "QUATERNION"
    for frame, deg in ((1, 0), (13, 90), (21, 120)):
        obj.rotation_quaternion = (math.cos(math.radians(deg) / 2), 0, 0, math.sin(math.radians(deg) / 2))
        obj.keyframe_insert("rotation_quaternion", frame=frame)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    return obj


def session(verdict):
    quatcurve_blender.register()
    with window_override():
        obj = build()
        assert bpy.ops.quatcurve.fit(method="SQUAD", tolerance=0.05) == {"FINISHED"}
        for curve in fcurves.Channels.of(obj).fcurves:
            for p in curve.keyframe_points:
                p.select_control_point = p.co[0] == 1
        bpy.ops.ed.undo_push(message="quatcurve test: fitted")
        before = state()
        result = bpy.ops.quatcurve.set_turns("EXEC_DEFAULT", True, turns=2)
        turned = state()
        bpy.ops.ed.undo()
        after = state()
        verdict.update(result=sorted(result), changed=turned != before,
                       turns_after=[[f, n] for _, f, n in sum(turned["turns"].values(), [])],
                       restored=after == before,
                       differences=differences(before, after))


session_kit.start(session)
