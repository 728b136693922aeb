"""What the windowed sessions (tests/blender/sessions/*_session.py, each run under Xvfb by a test with
tests/blender/test_session.py's `windowed`) share: the paths, the verdict file named after `--`, the
3D Viewport's context, the differences of two recorded states, and the timer that runs a session
once the window exists and writes its verdict, whatever happens, before Blender quits."""

import inspect
import json
import os
import sys
import traceback

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
for folder in (os.path.join(ROOT, "addon"), os.path.join(ROOT, "tests", "blender")):
    if folder not in sys.path:
        sys.path.insert(0, folder)

VERDICT = sys.argv[sys.argv.index("--") + 1]


def window_override():
    """The context of the first window's 3D Viewport (any area if there is none), as a button sees it."""
    window = bpy.context.window_manager.windows[0]
    area = next((a for a in window.screen.areas if a.type == "VIEW_3D"), window.screen.areas[0])
    return bpy.context.temp_override(window=window, area=area, screen=window.screen)


def differences(before, after):
    """{key: [before, after]} of the keys whose recorded values differ."""
    return {k: [before.get(k), after.get(k)] for k in set(before) | set(after) if before.get(k) != after.get(k)}


def start(session, **verdict):
    """Runs session(verdict) from a timer once the window exists. A session that is a generator runs
    step by step: each value it yields is the seconds until its next step. The verdict ({"ok": True}
    when the session ends, its traceback under "error" when it raises) is written to VERDICT, then
    Blender quits."""
    verdict = dict(verdict, ok=False)
    steps = None

    def tick():
        nonlocal steps
        try:
            if steps is None:
                steps = session(verdict)
                if not inspect.isgenerator(steps):
                    steps = iter(())
            return next(steps)
        except StopIteration:
            verdict["ok"] = True
        except Exception:  # noqa: BLE001 — the verdict carries it
            verdict["error"] = traceback.format_exc()
        with open(VERDICT, "w") as f:
            json.dump(verdict, f, indent=1)
        bpy.ops.wm.quit_blender()
        return None

    bpy.app.timers.register(tick, first_interval=0.5)
