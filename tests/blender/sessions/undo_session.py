"""Undo after a bake and after a fit, in a Blender with a window (run under Xvfb by
tests/blender/test_session.py):

    xvfb-run -a blender --factory-startup --python tests/blender/sessions/undo_session.py -- VERDICT.json

A timer (the window must exist first) builds a scene — an object with Euler rotation keys in a
group and location keys, and one with axis-angle keys that spin past 360° — pushes an undo step and records the file state; then, twice (into a new
action, and in place), bakes through the operator with an undo push (as a button press does),
checks that the bake changed the file, runs ed.undo and compares the state with the recording. Then
the fit ("fit_rounds"): a fit of the original keys, undone; and a refit of a fitted file (another
method and tolerance), undone back to the first fit — keys, handles, key types and the fit records
on the action. The verdict goes to VERDICT.json; Blender then quits."""

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
    """Every action's digest and fake user, each object's action, rotation modes (objects and pose
    bones), the current rotation values at frame 5."""
    bpy.context.scene.frame_set(5)
    out = {"actions": {a.name: [fcurves.action_digest(a), a.use_fake_user] for a in bpy.data.actions}}
    out["fit records"] = {a.name: [[r.slot, r.owner_path, r.method, round(r.tolerance, 6), r.signature, r.key_frames]
                                   for r in a.quatcurve_fits] for a in bpy.data.actions}
    for obj in bpy.data.objects:
        action = fcurves.active_action(obj)
        bones = [[pb.name, pb.rotation_mode, [round(v, 6) for v in pb.rotation_quaternion]]
                 for pb in obj.pose.bones] if obj.pose else []
        out["object " + obj.name] = [action.name if action else None, obj.rotation_mode,
                                     [round(v, 6) for v in obj.rotation_euler],
                                     [round(v, 6) for v in obj.rotation_axis_angle], bones]
    return out


def build():
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    cube = bpy.data.objects.new("Cube", None)
    scene.collection.objects.link(cube)
    cube.rotation_mode = "XYZ"
    for frame, z in ((1, 0), (11, 90), (21, 200)):
        cube.rotation_euler = (0, math.radians(z / 3), math.radians(z))
        cube.keyframe_insert("rotation_euler", frame=frame, group="Turn")
        cube.location = (frame * 0.1, 0, 0)
        cube.keyframe_insert("location", frame=frame)
    axis = bpy.data.objects.new("Axis", None)
    scene.collection.objects.link(axis)
    axis.rotation_mode = "AXIS_ANGLE"
    for frame, value in ((1, (0, 0, 0, 1)), (11, (math.radians(400), 0, 0.3, 1)), (21, (math.radians(450), 1, 0, 0))):
        axis.rotation_axis_angle = value
        axis.keyframe_insert("rotation_axis_angle", frame=frame)
    for obj in scene.objects:
        obj.select_set(obj in (cube, axis))
    bpy.context.view_layer.objects.active = cube


def session(verdict):
    quatcurve_blender.register()
    with window_override():
        build()
        bpy.ops.ed.undo_push(message="quatcurve test: scene")
        before = state()
        verdict["rounds"] = []
        for kwargs in (dict(method="SQUAD", rotation_mode="QUATERNION", new_action=True),
                       dict(method="SLERP", rotation_mode="KEEP", new_action=False)):
            # undo=True: push an undo step as the UI does for an operator with the UNDO flag
            # (a plain call from a script does not).
            result = bpy.ops.quatcurve.bake("EXEC_DEFAULT", True, **kwargs)
            baked = state()
            bpy.ops.ed.undo()
            after = state()
            verdict["rounds"].append({
                "bake": kwargs, "result": sorted(result), "bake_changed_file": baked != before,
                "new_actions": sorted(set(baked["actions"]) - set(after["actions"])),
                "restored": after == before,
                "differences": differences(before, after)})
        verdict["fit_rounds"] = []
        # 1: the original keys fitted, undone. 2: a fitted file refitted (another method and
        # tolerance), undone back to the first fit.
        for name, first, kwargs in (("fit", None, dict(method="SQUAD", tolerance=0.01)),
                                    ("refit", dict(method="SLERP", tolerance=0.05),
                                     dict(method="TCB", tension=0.5, tolerance=0.01))):
            if first is not None:
                bpy.ops.quatcurve.fit("EXEC_DEFAULT", True, **first)
            start = state()
            result = bpy.ops.quatcurve.fit("EXEC_DEFAULT", True, **kwargs)
            fitted = state()
            bpy.ops.ed.undo()
            after = state()
            verdict["fit_rounds"].append({
                "fit": name, "result": sorted(result), "fit_changed_file": fitted != start,
                "records_after_fit": fitted["fit records"], "restored": after == start,
                "differences": differences(start, after)})


session_kit.start(session)
