"""Undo after quatcurve.clean, in a Blender with a window (run under Xvfb by tests/blender/test_clean.py):

    xvfb-run -a blender --factory-startup --python tests/blender/sessions/clean_undo_session.py -- VERDICT.json

A timer (the window must exist first) builds a quaternion object with a noisy key on every frame (a
spike and a sign flip among them) and a location key, pushes an undo step and records the file state
(every action's digest, which action the object plays, the action names); then cleans it through the
operator twice, with an undo push each as a button press does — once into a new action, once in
place — checks that each changed the file, runs ed.undo after each and compares the state with the
recording. The verdict goes to VERDICT.json; Blender then quits."""

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
    obj = bpy.data.objects["Capture"]
    action = fcurves.active_action(obj)
    return {"actions": {a.name: fcurves.action_digest(a) for a in bpy.data.actions},
            "playing": action.name if action else None}


def build():
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    obj = bpy.data.objects.new("Capture", None)
    scene.collection.objects.link(obj)
    obj.rotation_mode = "QUATERNION"
    for frame in range(1, 121):
        a = 0.02 * frame + 0.01 * math.sin(frame * 1.7) + (0.35 if frame == 60 else 0.0)  # noise-like, a spike
        b = 0.3 * math.sin(frame / 15.0) + 0.008 * math.cos(frame * 2.3)
        w, x, y, z = math.cos(a / 2) * math.cos(b / 2), math.sin(b / 2), 0.0, math.sin(a / 2) * math.cos(b / 2)
        sign = -1.0 if 40 <= frame < 80 else 1.0  # a sign flip and back
        obj.rotation_quaternion = (sign * w, sign * x, sign * y, sign * z)
        obj.keyframe_insert("rotation_quaternion", frame=frame)
    obj.location = (1.0, 2.0, 3.0)
    obj.keyframe_insert("location", frame=1)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    return obj


def session(verdict):
    quatcurve_blender.register()
    with window_override():
        build()
        bpy.ops.ed.undo_push(message="quatcurve test: captured")
        before = state()
        for label, new_action in (("new action", True), ("in place", False)):
            result = bpy.ops.quatcurve.clean("EXEC_DEFAULT", True, new_action=new_action)
            cleaned = state()
            bpy.ops.ed.undo()
            after = state()
            verdict["runs"][label] = dict(result=sorted(result), changed=cleaned != before,
                                          restored=after == before, differences=differences(before, after))


session_kit.start(session, runs={})
