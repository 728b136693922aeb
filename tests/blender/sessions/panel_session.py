"""The sidebar panel on a selected rig, the comparison table popup and a fitted curve, in a Blender
with a window (run under Xvfb by tests/blender/test_ui_xvfb.py):

    xvfb-run -a -s "-screen 0 1600x1000x24" blender --factory-startup --window-geometry 0 0 1600 1000 \
        --enable-event-simulate --python tests/blender/sessions/panel_session.py -- VERDICT.json SHOTS

Builds a three-bone rig whose middle bone ("Upper") has four quaternion keys, selects that bone in
Pose mode, compares it and fits it with the recommended method, then saves screenshots of the window
into SHOTS:
- panel_rig.png: the 3D Viewport with the sidebar's QuatCurve tab at its default width (Fit open,
  the other tasks closed);
- panel_compare.png: the same with the Compare subpanel opened by a click on its header (the
  recommendation's sentence, the Table and Plot buttons);
- compare_popup.png (and compare_popup_before.png, the same moment without it): the table popup
  opened from the Table button's operator under the mouse;
- graph_fitted.png: the Graph Editor on the fitted bone's curves, the sidebar's QuatCurve tab;
- dopesheet_fitted.png: the Dope Sheet, where Blender draws the generated keys (GENERATED from 4.2,
  JITTER in 3.4) small and in their own colour.
The verdict (what drew, the operators' results, where the keys and the popup are in window pixels,
the widths of the popup's texts measured with blf) goes to VERDICT.json for the test to check."""

import json
import math
import os
import sys
import traceback

import blf
import bpy
from mathutils import Euler, Quaternion

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
sys.path.insert(0, os.path.join(ROOT, "addon"))

import quatcurve_blender  # noqa: E402
from quatcurve_blender import compare_ops, fcurves, fit, ui  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from window_clicks import open_subpanels  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
VERDICT, SHOTS = ARGS[0], ARGS[1]
os.makedirs(SHOTS, exist_ok=True)
verdict = {"ok": False, "errors": [], "drawn": {}, "screenshots": {}, "clicks": 0}


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
popup_draw = ui.QUATCURVE_OT_compare_table.draw


def recording_popup_draw(self, context):
    try:
        popup_draw(self, context)
        verdict["drawn"]["compare_table"] = verdict["drawn"].get("compare_table", 0) + 1
    except Exception:
        verdict["errors"].append(traceback.format_exc())
        raise


ui.QUATCURVE_OT_compare_table.draw = recording_popup_draw
quatcurve_blender.register()
# Xvfb draws with Mesa's llvmpipe on the CPU: the 3D Viewport's multisample anti-aliasing doubles every
# redraw's cost there and no check here looks at edge smoothing.
bpy.context.preferences.system.viewport_aa = "OFF"

win = bpy.context.window_manager.windows[0]
area = max((a for a in win.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
scene = bpy.context.scene
KEYS = {1: (0, 0, 0), 11: (70, 0, 20), 21: (40, 60, -30), 31: (0, 10, 90)}  # Upper: Euler degrees per frame


def build_rig():
    """Rig: Root -> Upper -> Lower, standing up at the origin; Upper keyed in quaternions."""
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    arm = bpy.data.armatures.new("Rig")
    rig = bpy.data.objects.new("Rig", arm)
    scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    rig.select_set(True)
    with bpy.context.temp_override(window=win, area=area):
        bpy.ops.object.mode_set(mode="EDIT")
        parent = None
        for name, head, tail in (("Root", (0, 0, 0), (0, 0, 0.6)), ("Upper", (0, 0, 0.6), (0, 0, 1.6)),
                                 ("Lower", (0, 0, 1.6), (0, 0, 2.4))):
            bone = arm.edit_bones.new(name)
            bone.head, bone.tail, bone.parent = head, tail, parent
            parent = bone
        bpy.ops.object.mode_set(mode="POSE")
    upper = rig.pose.bones["Upper"]
    upper.rotation_mode = "QUATERNION"
    for frame, angles in KEYS.items():
        upper.rotation_quaternion = Euler([math.radians(a) for a in angles], "XYZ").to_quaternion()
        upper.keyframe_insert("rotation_quaternion", frame=frame, group="Upper")
    for bone in rig.pose.bones:
        select_bone(rig, bone.name, bone.name == "Upper")
    arm.bones.active = arm.bones["Upper"]
    scene.frame_start, scene.frame_end, scene.frame_current = 1, 31, 16
    return rig


def select_bone(rig, name, state):
    pose_bone = rig.pose.bones[name]
    if hasattr(pose_bone, "select"):  # 5.0+
        pose_bone.select = state
    else:
        rig.data.bones[name].select = state


def screenshot(name):
    path = os.path.join(SHOTS, name + ".png")
    with bpy.context.temp_override(window=win, area=area):
        bpy.ops.screen.screenshot(filepath=path)
    verdict["screenshots"][name] = path
    return path


def mouse_to(x, y):
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=int(x), y=int(y))


def click(x, y):
    mouse_to(x, y)
    win.event_simulate(type="LEFTMOUSE", value="PRESS", x=int(x), y=int(y))
    win.event_simulate(type="LEFTMOUSE", value="RELEASE", x=int(x), y=int(y))
    verdict["clicks"] += 1


def region_of(kind):
    return next(r for r in area.regions if r.type == kind)


def open_tab(panel):
    """Shows the sidebar and clicks down its tab strip (right edge) until `panel` draws."""
    area.spaces.active.show_region_ui = True
    yield
    yield
    region = region_of("UI")
    x = region.x + region.width - 9
    for y in range(region.y + region.height - 12, region.y, -12):
        if verdict["drawn"].get(panel):
            break
        click(x, y)
        yield
    mouse_to(area.x + 5, area.y + 5)  # no tooltip
    yield


def frame_rig(rig):
    space = area.spaces.active
    rv3d = space.region_3d
    rv3d.view_perspective = "PERSP"
    rv3d.view_location = (0.0, 0.0, 1.2)
    rv3d.view_rotation = Quaternion((0.78, 0.48, 0.20, 0.34)).normalized()
    rv3d.view_distance = 5.0
    space.overlay.show_floor = True


def key_frames_and_types(rig):
    """Every key of Upper's rotation curves: (frame, generated?) pairs."""
    out = []
    for fc in fcurves.Channels.of(rig).fcurves:
        if '"Upper"' not in fc.data_path:
            continue
        frames = fcurves.read_keys(fc)[0]
        types = fcurves.read_key_types(fc) if hasattr(fcurves, "read_key_types") else \
            [fit.KEY_TYPE_GENERATED if k.type == fit.GENERATED_NAME else 0 for k in fc.keyframe_points]
        out += [(float(f), int(t) == fit.KEY_TYPE_GENERATED) for f, t in zip(frames, types)]
    return out


def text_widths():
    """Pixel widths of the popup's texts in Blender's UI font at the UI's size (blf), per column."""
    scale = set_font_size()
    entry = compare_ops.last_result(scene, "Rig/Upper") or compare_ops.last_table(scene.quatcurve_compare)[0]
    columns = []
    for header, key, fmt, units in ui.COMPARE_COLUMNS:
        texts = list(header) + [ui.cell_text(s, key, fmt) for s in entry["sources"]]
        columns.append({"units": units, "texts": texts, "widths": [blf.dimensions(0, t)[0] for t in texts]})
    return {"ui_scale": scale, "unit_px": 20 * scale, "columns": columns, "popup_width": ui.popup_width(bpy.context)}


def set_font_size():
    styles = bpy.context.preferences.ui_styles[0]
    style = getattr(styles, "widget_label", None) or styles.widget  # labels' font (5.x: one widget font)
    scale = bpy.context.preferences.view.ui_scale
    blf.size(0, style.points * scale)  # the UI font is blf's font 0; 3.4 and later take points at 72 dpi
    return scale


def sidebar_lines(region):
    """The recommendation as the Compare subpanel wraps it in `region`, and each line's width in
    pixels (blf)."""
    class Context:  # what ui.label_width reads
        preferences = bpy.context.preferences
    Context.region = region
    set_font_size()
    sentence = compare_ops.last_table(scene.quatcurve_compare)[0]["sentence"]
    lines = []
    ui.wrapped_labels(type("Layout", (), {"label": lambda self, text: lines.append(text)})(), sentence,
                      ui.label_width(Context))
    return {"lines": lines, "widths": [blf.dimensions(0, t)[0] for t in lines]}


def session():
    rig = build_rig()
    frame_rig(rig)
    scene.quatcurve_fit.method, scene.quatcurve_compare.subframes = "SQUAD", 8  # as an animator sets them
    with bpy.context.temp_override(window=win, area=area):  # compare the animator's keys, fit as recommended
        verdict["compare"] = sorted(bpy.ops.quatcurve.compare())
        scene.quatcurve_fit.method = compare_ops.last_table(scene.quatcurve_compare)[0]["method"]
        verdict["fit"] = sorted(bpy.ops.quatcurve.fit())
    verdict["keys"] = key_frames_and_types(rig)
    verdict["sentence"] = compare_ops.last_table(scene.quatcurve_compare)[0]["sentence"]
    yield from open_tab("QUATCURVE_PT_view3d")
    for _ in range(3):
        yield
    ui_region = region_of("UI")
    verdict["sidebar"] = {"x": ui_region.x, "width": ui_region.width, "height": ui_region.height}
    verdict["sidebar_lines"] = sidebar_lines(ui_region)
    screenshot("panel_rig")
    verdict["drawn_default"] = dict(verdict["drawn"])

    yield from open_subpanels(win, area, verdict["drawn"], ["QUATCURVE_PT_view3d_compare"])
    select_bone(rig, "Upper", True)  # the clicks below the panels went through to the viewport
    yield
    yield
    screenshot("panel_compare")

    # The table popup, as the Table button opens it: under the mouse, in the middle of the viewport.
    window_region = region_of("WINDOW")
    mx, my = window_region.x + window_region.width // 2 - 200, window_region.y + window_region.height // 2 + 150
    mouse_to(mx, my)
    yield
    yield
    screenshot("compare_popup_before")
    with bpy.context.temp_override(window=win, area=area, region=window_region):
        verdict["table"] = sorted(bpy.ops.quatcurve.compare_table("INVOKE_DEFAULT"))
    for _ in range(3):
        yield
    verdict["mouse"] = [mx, my]
    verdict["text"] = text_widths()
    screenshot("compare_popup")
    win.event_simulate(type="ESC", value="PRESS", x=mx, y=my)
    win.event_simulate(type="ESC", value="RELEASE", x=mx, y=my)
    yield

    # The fitted curves in the Graph Editor, all in view, and the Dope Sheet's key types.
    select_bone(rig, "Upper", True)
    for fc in fcurves.Channels.of(rig).fcurves:  # no key selected: every key in its type's colour
        fcurves.write_key_selection(fc, [False] * len(fc.keyframe_points))
    area.type = "GRAPH_EDITOR"
    yield
    with bpy.context.temp_override(window=win, area=area, region=region_of("WINDOW")):
        bpy.ops.graph.view_all()
    yield from open_tab("QUATCURVE_PT_graph")
    yield
    graph = region_of("WINDOW")
    verdict["graph_keys"] = []
    for fc in fcurves.Channels.of(rig).fcurves:
        frames, values = fcurves.read_keys(fc)[:2]
        for f, v in zip(frames, values):
            x, y = graph.view2d.view_to_region(float(f), float(v), clip=False)
            verdict["graph_keys"].append([graph.x + x, graph.y + y])
    verdict["graph_region"] = [graph.x, graph.y, graph.width, graph.height]
    screenshot("graph_fitted")

    area.type = "DOPESHEET_EDITOR"
    area.spaces.active.ui_mode = "DOPESHEET"
    yield
    with bpy.context.temp_override(window=win, area=area, region=region_of("WINDOW")):
        bpy.ops.action.view_all()
    with bpy.context.temp_override(window=win, area=area, region=region_of("CHANNELS")):
        bpy.ops.anim.channels_expand(all=True)  # the four quaternion channels, each in its own row
    for _ in range(2):
        yield
    sheet = region_of("WINDOW")
    verdict["sheet_region"] = [sheet.x, sheet.y, sheet.width, sheet.height]
    verdict["sheet_x"] = {"%g" % f: sheet.x + sheet.view2d.view_to_region(f, 0.0, clip=False)[0]
                          for f, _ in verdict["keys"]}
    theme = bpy.context.preferences.themes[0].dopesheet_editor
    generated = next(n for n in ("keyframe_generated", "keyframe_jitter") if hasattr(theme, n))
    verdict["colours"] = {"generated": list(getattr(theme, generated)), "keyframe": list(theme.keyframe),
                          "generated_name": generated}
    screenshot("dopesheet_fitted")


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
