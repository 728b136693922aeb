"""Live fit and undo, in a Blender with a window (run under Xvfb by tests/blender/test_live.py):

    xvfb-run -a blender --factory-startup --python tests/blender/sessions/live_undo_session.py -- VERDICT.json

Timers drive it (the window must exist, and live mode refits from its own timer there): an empty
with quaternion keys is fitted through the operator with an undo push (as a button press does), live
is switched on, the state is recorded; a key is inserted and an undo step pushed (what an insert
operator does); live mode refits from its timer (after its debounce on 3.4). Then ed.undo must give
back exactly the recorded state (one undo step for the insert and its refit together), and ed.redo
the refitted state again. The verdict goes to VERDICT.json; Blender then quits."""

import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session_kit  # noqa: E402  (it puts addon/ and tests/blender/ on the path)
from session_kit import window_override  # noqa: E402

import quatcurve_blender  # noqa: E402
from quatcurve_blender import fcurves, live  # noqa: E402

KEYS = [(1, (1, 0, 0, 0)), (5, (0.7071, 0.7071, 0, 0)), (6, (0.5, 0.5, 0.5, 0.5)), (30, (-0.2, 0.1, 0.9, -0.38))]


def state():
    """Every action's digest (F-curves: keys, handles, types of interpolation) and fit records."""
    out = {}
    for action in bpy.data.actions:
        out[action.name] = [fcurves.action_digest(action),
                            [[r.owner_path, r.method, r.signature] for r in action.quatcurve_fits]]
    return out


def wait_for(condition, seconds=60.0):
    """Yields (timer steps) until condition() holds or `seconds` passed (a limit for a stuck session, not
    a timing: a fast machine goes on at once); then once more for a settle."""
    end = time.perf_counter() + seconds
    while not condition() and time.perf_counter() < end:
        yield 0.1
    yield 0.5


def session(verdict):
    quatcurve_blender.register()
    scene = bpy.context.scene
    with window_override():
        for obj in list(scene.objects):
            bpy.data.objects.remove(obj)
        obj = bpy.data.objects.new("Quat", None)
        scene.collection.objects.link(obj)
        obj.rotation_mode = "QUATERNION"
        for frame, q in KEYS:
            obj.rotation_quaternion = q
            obj.keyframe_insert("rotation_quaternion", frame=frame)
        obj.select_set(True)
        bpy.context.view_layer.objects.active = obj
        verdict["fit"] = sorted(bpy.ops.quatcurve.fit("EXEC_DEFAULT", True, method="SQUAD", tolerance=0.05))
    scene.quatcurve_fit.live = True
    yield 0.5
    live.STATS.reset()
    before = state()
    with window_override():
        obj.rotation_quaternion = (0.6, 0.2, 0.7, 0.3)
        obj.keyframe_insert("rotation_quaternion", frame=15)
        bpy.ops.ed.undo_push(message="Insert Keyframe")
    inserted = state()
    yield from wait_for(lambda: live.STATS.refits >= 1)
    refitted = state()
    verdict["refits_after_insert"] = live.STATS.refits
    verdict["refit_changed_keys"] = refitted != inserted
    verdict["debounced"] = live.STATS.deferred
    with window_override():
        bpy.ops.ed.undo()
    undone = state()
    yield 1.0  # live mode's timer after undo_post: signatures match, nothing to refit
    verdict["undo_restored"] = undone == before
    verdict["still_restored"] = state() == before
    verdict["refits_after_undo"] = live.STATS.refits
    verdict["differences"] = {k: [before.get(k), undone.get(k)] for k in set(before) | set(undone)
                              if before.get(k) != undone.get(k)}
    with window_override():
        bpy.ops.ed.redo()
    yield from wait_for(lambda: state() == refitted)
    verdict["redo_refitted"] = state() == refitted
    verdict["refits_after_redo"] = live.STATS.refits
    verdict["errors"] = list(live.STATS.errors)
    quatcurve_blender.unregister()


session_kit.start(session, blender=bpy.app.version_string)
