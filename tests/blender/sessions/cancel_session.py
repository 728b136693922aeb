"""Esc during a modal bake, in a Blender with a window (run under Xvfb by tests/blender/test_session.py):

    xvfb-run -a blender --factory-startup --enable-event-simulate \
        --python tests/blender/sessions/cancel_session.py -- VERDICT.json

Builds a 100-bone rig keyed over 10,000 frames, records the file state, starts the bake the way the
Bake button does (INVOKE_DEFAULT: modal, target by target, with progress), and once some but not all
targets are computed simulates an Esc key press (Window.event_simulate). Then checks that the
operator ended CANCELLED half way and that the file is unchanged: no new action, every action's
digest, assignments and rotation modes as before. The verdict goes to VERDICT.json.

Nothing here depends on how fast the bake runs: after HOLD_AT targets the session holds the bake
(its steps yield the same fraction without computing) until the Esc has been handled, so a fast
machine cannot finish the bake before the key press arrives. The hold gives up after 60 s, and the
verdict then says the Esc never reached the operator."""

import json
import os
import sys
import time
import traceback

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from session_kit import VERDICT, window_override  # noqa: E402  (it puts addon/ and tests/blender/ on the path)

import quatcurve_blender  # noqa: E402
from quatcurve_blender import bake, bake_ops, fcurves  # noqa: E402
import rigs  # noqa: E402

BONES, LAST_FRAME, KEY_EVERY = 100, 10_000, 10
HOLD_AT = 3        # targets computed when the bake is held for the Esc
HOLD_LIMIT = 60.0  # seconds the hold waits for the Esc before letting the bake go on

progress = []      # fraction done after each computed target, as the modal bake yields it
returned = []      # what each modal() call returned
verdict = {"ok": False}
phase = {"name": "start", "since": 0.0, "before": None}
hold = {"since": None, "released": False}


def record_progress():
    original = bake.BakePlan.compute_steps

    def compute_steps(self):
        for done in original(self):
            progress.append(done)
            yield done
            if len(progress) == HOLD_AT:
                # Held: the modal's timer ticks see the same fraction and no work is done, so the
                # simulated Esc is handled before the bake can go on.
                hold["since"] = time.perf_counter()
                while time.perf_counter() - hold["since"] < HOLD_LIMIT:
                    time.sleep(0.001)
                    yield done
                hold["released"] = True

    bake.BakePlan.compute_steps = compute_steps
    modal = bake_ops.QUATCURVE_OT_bake.modal

    def recording_modal(self, context, event):
        result = modal(self, context, event)
        returned.append(sorted(result))
        return result

    bake_ops.QUATCURVE_OT_bake.modal = recording_modal


def state():
    out = {"actions": {a.name: [fcurves.action_digest(a), a.use_fake_user] for a in bpy.data.actions}}
    for obj in bpy.data.objects:
        action = fcurves.active_action(obj)
        out["object " + obj.name] = [action.name if action else None, obj.rotation_mode,
                                     [pb.rotation_mode for pb in obj.pose.bones] if obj.pose else []]
    return out


def build_rig():
    for obj in list(bpy.context.scene.objects):
        bpy.data.objects.remove(obj)
    rigs.build_rig("Rig", LAST_FRAME, 7, BONES, KEY_EVERY)


def finish():
    with open(VERDICT, "w") as f:
        json.dump(verdict, f, indent=1)
    bpy.ops.wm.quit_blender()
    return None


def step():
    """A timer driving the session through its phases; returns the next interval (None: done)."""
    try:
        now = time.perf_counter()
        if phase["name"] == "start":
            quatcurve_blender.register()
            record_progress()
            with window_override():
                build_rig()
                bpy.context.view_layer.update()
                phase["before"] = state()
                verdict["invoke"] = sorted(bpy.ops.quatcurve.bake("INVOKE_DEFAULT", True, method="SQUAD",
                                                                  rotation_mode="QUATERNION"))
            phase.update(name="running", since=now)
        elif phase["name"] == "running":
            if hold["since"] is not None:
                verdict["progress_at_esc"] = progress[-1]
                bpy.context.window_manager.windows[0].event_simulate(type="ESC", value="PRESS")
                phase.update(name="cancelled", since=now)
            elif (progress and progress[-1] >= 1.0) or now - phase["since"] > HOLD_LIMIT:
                verdict["error"] = "the bake finished (or never reached its hold) before Esc: %s" % progress[-3:]
                return finish()
        elif phase["name"] == "cancelled" and (returned and returned[-1] == ["CANCELLED"] or hold["released"]):
            if hold["released"]:
                verdict["error"] = "the simulated Esc never reached the modal bake in %.0f s" % HOLD_LIMIT
                return finish()
            after = state()
            verdict["modal_returned"] = returned[-1] if returned else None
            verdict["targets_computed"] = len(progress)
            verdict["progress_final"] = progress[-1] if progress else None
            verdict["unchanged"] = after == phase["before"]
            verdict["new_actions"] = sorted(set(after["actions"]) - set(phase["before"]["actions"]))
            verdict["ok"] = True
            return finish()
        return 0.01
    except Exception:  # noqa: BLE001 — the verdict carries it
        verdict["error"] = traceback.format_exc()
        return finish()


bpy.app.timers.register(step, first_interval=0.5)
