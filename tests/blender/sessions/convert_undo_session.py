"""Undo after quatcurve.convert, in a Blender with a window (run under Xvfb by tests/blender/test_convert.py):

    xvfb-run -a blender --factory-startup --python tests/blender/sessions/convert_undo_session.py -- VERDICT.json

A timer (the window must exist first) builds a scene — an object with Euler keys in a group and
location keys, a fitted quaternion object, a rig whose bone has axis-angle keys — pushes an undo step
and records the file state; then converts the objects (to QUATERNION and to XYZ, through the operator
with an undo push, as a button press does), checks that the file changed, runs ed.undo and compares
the state with the recording (every action's digest, fit records, rotation modes and values). The
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
    bpy.context.scene.frame_set(5)
    out = {"actions": {a.name: fcurves.action_digest(a) for a in bpy.data.actions}}
    out["fit records"] = {a.name: [[r.slot, r.owner_path, r.prop, r.method, r.signature, r.key_frames]
                                   for r in a.quatcurve_fits] for a in bpy.data.actions}
    for obj in bpy.data.objects:
        bones = [[pb.name, pb.rotation_mode, [round(v, 5) for v in pb.matrix_basis.to_quaternion()]]
                 for pb in obj.pose.bones] if obj.pose else []
        out["object " + obj.name] = [obj.rotation_mode, [round(v, 5) for v in obj.matrix_basis.to_quaternion()], bones]
    return out


def build():
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    cube = bpy.data.objects.new("Cube", None)
    scene.collection.objects.link(cube)
    cube.rotation_mode = "XYZ"
    for frame, z in ((1, 0), (11, 90), (21, 400)):
        cube.rotation_euler = (0, math.radians(z / 3), math.radians(z))
        cube.keyframe_insert("rotation_euler", frame=frame, group="Turn")
        cube.location = (frame * 0.1, 0, 0)
        cube.keyframe_insert("location", frame=frame)
    quat = bpy.data.objects.new("Quat", None)
    scene.collection.objects.link(quat)
    quat.rotation_mode = "QUATERNION"
    for frame, q in ((1, (1, 0, 0, 0)), (9, (0.5, 0.5, 0.5, 0.5)), (21, (0, 0, 1, 0))):
        quat.rotation_quaternion = q
        quat.keyframe_insert("rotation_quaternion", frame=frame)
    for obj in scene.objects:
        obj.select_set(obj == quat)
    bpy.context.view_layer.objects.active = quat
    bpy.ops.quatcurve.fit(method="SQUAD", tolerance=0.05)
    for obj in scene.objects:
        obj.select_set(obj in (cube, quat))
    bpy.context.view_layer.objects.active = cube


def session(verdict):
    quatcurve_blender.register()
    with window_override():
        build()
        bpy.ops.ed.undo_push(message="quatcurve test: scene")
        before = state()
        for mode in ("AXIS_ANGLE", "ZXY"):
            result = bpy.ops.quatcurve.convert("EXEC_DEFAULT", True, rotation_mode=mode, tolerance=0.05)
            converted = state()
            bpy.ops.ed.undo()
            after = state()
            verdict["rounds"].append({
                "mode": mode, "result": sorted(result), "changed": converted != before,
                "modes_after_convert": [converted["object Cube"][0], converted["object Quat"][0]],
                "restored": after == before,
                "differences": differences(before, after)})


session_kit.start(session, rounds=[])
