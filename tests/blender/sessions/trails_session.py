"""Orientation trails and the sidebar's subpanels in a Blender with a window (run under Xvfb by
tests/blender/test_ui_xvfb.py):

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup --window-geometry 0 0 1600 900 \
        --enable-event-simulate DEMO.blend --python tests/blender/sessions/trails_session.py -- VERDICT.json SHOTS

On the demo scene (build_scripts/demo_scene.py): for FixedAngle, Spin and a Mocap bone in turn, makes
the target active, compares it (so the Compare subpanel has its recommendation), turns the trails on (Blender's
evaluation and SLERP side by side), frames the view on it and saves a screenshot SHOTS/trails_<name>.png
of the window; for FixedAngle also one with the trails off, and the window positions of trail points
(projected with view3d_utils.location_3d_to_region_2d) for the test to look up in both. Then the
subpanels in the Graph Editor, and "Show in Image Editor". The verdict goes to VERDICT.json."""

import json
import math
import os
import sys
import traceback

import bpy
from bpy_extras import view3d_utils
from mathutils import Quaternion, Vector

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
sys.path.insert(0, os.path.join(ROOT, "addon"))

import quatcurve_blender  # noqa: E402
from quatcurve_blender import trails, ui  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from window_clicks import open_subpanels  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
VERDICT, SHOTS = ARGS[0], ARGS[1]
os.makedirs(SHOTS, exist_ok=True)
verdict = {"ok": False, "errors": [], "drawn": {}, "screenshots": {}, "points": {}, "clicks": 0}


def record_draws(cls):
    draw = cls.draw

    def recording_draw(self, context):
        try:
            draw(self, context)
        except Exception:
            verdict["errors"].append(traceback.format_exc())
            raise
        verdict["drawn"][cls.bl_idname] = verdict["drawn"].get(cls.bl_idname, 0) + 1
    cls.draw = recording_draw


for cls in ui._classes:
    if issubclass(cls, bpy.types.Panel):
        record_draws(cls)
trail_draw = trails.draw_view3d


def recording_trail_draw():
    try:
        trail_draw()
        verdict["drawn"]["trails"] = verdict["drawn"].get("trails", 0) + 1
    except Exception:
        verdict["errors"].append(traceback.format_exc())


trails.draw_view3d = recording_trail_draw  # the handler registered below calls this one
quatcurve_blender.register()
# Xvfb draws with Mesa's llvmpipe on the CPU: the 3D Viewport's multisample anti-aliasing doubles every
# redraw's cost there and no check here looks at edge smoothing.
bpy.context.preferences.system.viewport_aa = "OFF"
verdict["draw_handlers"] = len(trails.draw_handlers())

win = bpy.context.window_manager.windows[0]
area = max((a for a in win.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
space = area.spaces.active
scene = bpy.context.scene
settings = scene.quatcurve_trails
settings.show, settings.show_method, settings.method, settings.axis = True, True, "SLERP", "X"

# (object, bone, axis, step, size, view rotation): the view looks down on each from the front-right.
TARGETS = [("FixedAngle", None, "X", 2, 1.0), ("Spin", None, "X", 3, 1.0)]
if "Mocap" in bpy.data.objects:
    TARGETS.append(("Mocap", "LeftShoulder", "Y", 10, 0.6))


def screenshot(name):
    path = os.path.join(SHOTS, name + ".png")
    with bpy.context.temp_override(window=win, area=area):
        bpy.ops.screen.screenshot(filepath=path)
    verdict["screenshots"][name] = path
    return path


def open_tab(panel):
    """Shows the sidebar and clicks down its tab strip (right edge) until `panel` draws."""
    area.spaces.active.show_region_ui = True
    yield
    yield
    region = next(r for r in area.regions if r.type == "UI")
    x = region.x + region.width - 9
    for y in range(region.y + region.height - 12, region.y, -12):
        if verdict["drawn"].get(panel):
            break
        win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
        win.event_simulate(type="LEFTMOUSE", value="PRESS", x=x, y=y)
        win.event_simulate(type="LEFTMOUSE", value="RELEASE", x=x, y=y)
        verdict["clicks"] += 1
        yield
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=area.x + 5, y=area.y + 5)  # no tooltip
    yield


def activate(obj_name, bone):
    obj = bpy.data.objects[obj_name]
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    for o in scene.objects:
        o.select_set(o is obj)
    bpy.context.view_layer.objects.active = obj
    if bone is not None:
        with bpy.context.temp_override(window=win, area=area):
            bpy.ops.object.mode_set(mode="POSE")
        for b in obj.data.bones:
            b.select = b.name == bone
        obj.data.bones.active = obj.data.bones[bone]
    return obj


def frame_view(origin, size):
    """The view from the front-right, a little above, around `origin`."""
    rv3d = space.region_3d
    rv3d.view_perspective = "PERSP"
    rv3d.view_location = Vector(origin)
    rv3d.view_rotation = Quaternion((0.82, 0.43, 0.17, 0.33)).normalized()
    rv3d.view_distance = 3.5 * size
    space.overlay.show_floor = space.overlay.show_axis_x = space.overlay.show_axis_y = False


def project(points):
    """Window pixel positions (x, y from the bottom-left) of world points, None when off the 3D
    region or behind the sidebar."""
    region = next(r for r in area.regions if r.type == "WINDOW")
    ui_region = next(r for r in area.regions if r.type == "UI")
    out = []
    for p in points:
        xy = view3d_utils.location_3d_to_region_2d(region, space.region_3d, Vector(p))
        if xy is None:
            out.append(None)
            continue
        x, y = region.x + xy.x, region.y + xy.y
        inside = region.x + 8 < x < min(region.x + region.width, ui_region.x) - 8 and region.y + 8 < y < region.y + region.height - 40
        out.append([x, y] if inside else None)
    return out


def session():
    yield from open_tab("QUATCURVE_PT_view3d")
    for obj_name, bone, axis, step, size in TARGETS:
        activate(obj_name, bone)
        settings.axis, settings.step, settings.size = axis, step, size
        result = bpy.ops.quatcurve.compare()
        verdict.setdefault("compare", {})[obj_name] = sorted(result)
        found = trails.current_points(bpy.context, settings)
        target, trail, points = found
        assert not trail.error, trail.error
        origin = points[trails.BLENDER].origin
        frame_view(origin, size)
        for _ in range(4):
            yield
        name = "trails_" + obj_name
        screenshot(name)
        verdict["points"][name] = {
            source: {"frames": p.frames.tolist(), "tips": project(p.tips)} for source, p in points.items()}
        verdict.setdefault("targets", {})[obj_name] = target.name
        if obj_name == "FixedAngle":
            settings.show = False
            yield
            yield
            screenshot("trails_FixedAngle_off")
            settings.show = True
            yield
    verdict["shader"] = trails._shaders.get("polyline", trails._shaders.get("uniform", ("?",)))[0]
    # The subpanels, opened (the add-on opens only Fit): 3D Viewport (FixedAngle active: its
    # recommendation in Compare), then Graph Editor.
    yield from open_subpanels(win, area, verdict["drawn"], ["QUATCURVE_PT_view3d_" + p
                                                            for p in ("bake", "compare", "trails")])
    activate("FixedAngle", None)
    settings.axis, settings.step, settings.size = "X", 2, 1.0
    frame_view(trails.world_frame(trails.active_target(bpy.context))[0], 1.0)
    yield
    yield
    screenshot("subpanels_view3d")
    ui_region = next(r for r in area.regions if r.type == "UI")
    for _ in range(12):  # scroll the sidebar down to the Orientation Trails subpanel
        win.event_simulate(type="WHEELDOWNMOUSE", value="PRESS",
                           x=ui_region.x + ui_region.width // 2, y=ui_region.y + ui_region.height // 2)
        yield
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=area.x + 5, y=area.y + 5)
    yield
    screenshot("subpanels_view3d_scrolled")
    area.type = "GRAPH_EDITOR"
    yield from open_tab("QUATCURVE_PT_graph")
    yield from open_subpanels(win, area, verdict["drawn"], ["QUATCURVE_PT_graph_compare"])
    activate("FixedAngle", None)
    yield
    screenshot("subpanels_graph")
    area.type = "VIEW_3D"
    yield
    with bpy.context.temp_override(window=win, area=area):
        verdict["show_plot"] = sorted(bpy.ops.quatcurve.show_compare_plot())
    yield
    yield
    editors = [a for a in win.screen.areas if a.type == "IMAGE_EDITOR"]
    verdict["image_editor"] = editors[0].spaces.active.image.name if editors and editors[0].spaces.active.image else None
    screenshot("plot_in_image_editor")


steps = session()


def tick():
    try:
        next(steps)
        return 0.02  # the next step after Blender's next redraw (timers run once per main-loop pass)
    except StopIteration:
        pass
    except Exception:
        verdict["errors"].append(traceback.format_exc())
    verdict["ok"] = not verdict["errors"]
    with open(VERDICT, "w") as f:
        json.dump(verdict, f, indent=1)
    bpy.ops.wm.quit_blender()


bpy.app.timers.register(tick, first_interval=0.5)
