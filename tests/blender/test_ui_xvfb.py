"""The sidebar panel in a real window: Debian's Blender under Xvfb opens the "QuatCurve" tab in the 3D
Viewport and in the Graph Editor, after a bake, and saves a screenshot of each; the panels must
have drawn without a Python error.

Runs in the Blender 3.4.1 binary's pass only (it starts that executable under xvfb-run); skips, saying
why, in the bpy-module passes (4.5, 5.0, 5.2: a bpy module runs in background mode only, with no
window even under Xvfb) and where xvfb-run is missing. The session script below is written to
a temporary folder and run as `xvfb-run -a blender --factory-startup --enable-event-simulate
--python SESSION -- VERDICT.json`. Sidebar tabs cannot be chosen from Python in 3.4
(Region.active_panel_category came later), so the session clicks down the tab strip with simulated
mouse events until the panel draws.

The other two tests run session scripts from tests/blender/sessions/ on a larger screen and check
their screenshots by pixels: trails_session.py (orientation trails where the orientation projects,
the subpanels) and panel_session.py (the panel on a selected rig, the comparison table popup, a
fitted curve in the Graph Editor and its generated keys in the Dope Sheet; docs/ui.md).
Screenshots are kept in build/screenshots/ (or $QUATCURVE_SCREENSHOTS)."""

import json
import os
import shutil
import subprocess
import textwrap

import bpy
import numpy as np
import pytest

from conftest import ADDON_DIR

SESSION = textwrap.dedent('''
    import json, math, os, sys, traceback
    import bpy
    sys.path.insert(0, ADDON_DIR)
    import quatcurve_blender
    from quatcurve_blender import ui

    OUT = sys.argv[sys.argv.index("--") + 1]
    verdict = {"ok": False, "drawn": {}, "errors": [], "clicks": 0, "screenshots": []}

    def record_draws(cls):
        draw = cls.draw
        def recording_draw(self, context):
            try:
                draw(self, context)
            except Exception:
                verdict["errors"].append(traceback.format_exc())
                raise
            verdict["drawn"][cls.__name__] = verdict["drawn"].get(cls.__name__, 0) + 1
        cls.draw = recording_draw

    record_draws(ui.QUATCURVE_PT_view3d)
    record_draws(ui.QUATCURVE_PT_graph)
    quatcurve_blender.register()
    cube = bpy.data.objects["Cube"]  # the factory startup scene's
    cube.rotation_mode = "XYZ"
    for frame, z in ((1, 0), (21, 90)):
        cube.rotation_euler = (0, 0, math.radians(z))
        cube.keyframe_insert("rotation_euler", frame=frame)
    verdict["bake"] = sorted(bpy.ops.quatcurve.bake(method="SQUAD", rotation_mode="QUATERNION"))
    win = bpy.context.window_manager.windows[0]
    area = next(a for a in win.screen.areas if a.type == "VIEW_3D")

    def screenshot(name):
        path = OUT + "." + name + ".png"
        with bpy.context.temp_override(window=win, area=area):
            bpy.ops.screen.screenshot(filepath=path)
        verdict["screenshots"].append(path)

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
        yield

    def session():
        yield from open_tab("QUATCURVE_PT_view3d")
        screenshot("view3d")
        area.type = "GRAPH_EDITOR"
        yield from open_tab("QUATCURVE_PT_graph")
        screenshot("graph")

    steps = session()

    def tick():
        try:
            next(steps)
            return 0.02
        except StopIteration:
            pass
        except Exception:
            verdict["errors"].append(traceback.format_exc())
        verdict["ok"] = not verdict["errors"]
        with open(OUT, "w") as f:
            json.dump(verdict, f, indent=1)
        bpy.ops.wm.quit_blender()

    bpy.app.timers.register(tick, first_interval=0.5)
''')


def debian_blender():
    """The running Blender executable when this is the Blender 3.4 binary's pass, else None."""
    path = bpy.app.binary_path
    if not path or not os.path.basename(path).startswith("blender") or bpy.app.version[:2] != (3, 4):
        return None
    return path


def no_window_reason():
    """Why this pass cannot open a window ('' when it can: the Blender 3.4 binary under xvfb-run)."""
    if not bpy.app.binary_path:
        return ("Blender %s is the bpy module here: it runs in background mode only (bpy.app.background is "
                "True and there is no window to draw in, even under Xvfb), so the window test runs in the "
                "Blender 3.4.1 binary's pass" % bpy.app.version_string)
    if debian_blender() is None:
        return "the window test runs in the Debian Blender 3.4.1 binary's pass (this is %s, %s)" % (
            bpy.app.version_string, bpy.app.binary_path)
    if shutil.which("xvfb-run") is None:
        return "xvfb-run is missing (Debian: apt-get install xvfb xauth): no window for the UI test"
    return ""


def test_sidebar_panels_draw_in_a_window(tmp_path):
    reason = no_window_reason()
    if reason:
        pytest.skip(reason)
    blender, xvfb = debian_blender(), shutil.which("xvfb-run")
    session = tmp_path / "ui_session.py"
    session.write_text("ADDON_DIR = %r\n" % ADDON_DIR + SESSION)
    verdict_path = tmp_path / "verdict.json"
    env = dict(os.environ, PATH="/usr/local/bin:/usr/bin:/bin")  # the system Python's home (see CMake)
    proc = subprocess.run([xvfb, "-a", blender, "--factory-startup", "--enable-event-simulate",
                           "--python", str(session), "--", str(verdict_path)],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=240, env=env)
    log = proc.stdout
    assert verdict_path.exists(), "the window session wrote no verdict (exit %s):\n%s" % (proc.returncode, log[-4000:])
    verdict = json.loads(verdict_path.read_text())
    assert verdict["ok"], "the session failed:\n%s\n%s" % ("\n".join(verdict["errors"]), log[-3000:])
    assert verdict["bake"] == ["FINISHED"]
    assert verdict["drawn"].get("QUATCURVE_PT_view3d") and verdict["drawn"].get("QUATCURVE_PT_graph"), verdict
    assert "Traceback" not in log and "Error: Python" not in log, log[-3000:]
    for path in verdict["screenshots"]:
        image = bpy.data.images.load(path)
        try:
            width, height = image.size
            assert width >= 640 and height >= 480
            pixels = np.empty(width * height * 4, dtype=np.float32)
            image.pixels.foreach_get(pixels)
            assert pixels.reshape(-1, 4)[:, :3].std() > 0.02, "blank screenshot %s" % path
        finally:
            bpy.data.images.remove(image)
    print("screenshots: %s" % ", ".join(verdict["screenshots"]))


# ---- orientation trails and subpanels on the demo scene (sessions/trails_session.py) -----------------

ROOT = os.path.dirname(ADDON_DIR)
MOCAP = os.path.join(os.path.dirname(ROOT), "shared", "data", "mocap", "mocapbank.bvh")
# Screenshots are kept for people to look at: QUATCURVE_SCREENSHOTS, else build/screenshots/.
SCREENSHOTS = os.environ.get("QUATCURVE_SCREENSHOTS") or os.path.join(ROOT, "build", "screenshots")
# The window sessions click their way through the sidebar's closed subpanels, a redraw between
# clicks: on a loaded two-core machine one takes up to a few minutes. A hang still ends.
MAGENTA = lambda rgb: (rgb[..., 0] > 0.7) & (rgb[..., 2] > 0.7) & (rgb[..., 1] < 0.35)  # noqa: E731
CYAN = lambda rgb: (rgb[..., 1] > 0.7) & (rgb[..., 2] > 0.7) & (rgb[..., 0] < 0.35)  # noqa: E731


def load_rgb(path):
    """(H, W, 3) floats of a PNG, rows bottom to top (window coordinates)."""
    image = bpy.data.images.load(path)
    try:
        width, height = image.size
        pixels = np.empty(width * height * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        return pixels.reshape(height, width, 4)[..., :3]
    finally:
        bpy.data.images.remove(image)


def colour_near(rgb, xy, is_colour, radius=3):
    """True when a pixel within `radius` of window position xy has the colour."""
    x, y = int(round(xy[0])), int(round(xy[1]))
    patch = rgb[max(0, y - radius):y + radius + 1, max(0, x - radius):x + radius + 1]
    return bool(is_colour(patch).any())


def test_trails_drawn_where_the_orientation_projects(tmp_path):
    reason = no_window_reason()
    if reason:
        pytest.skip(reason)
    blender, xvfb = debian_blender(), shutil.which("xvfb-run")
    env = dict(os.environ, PATH="/usr/local/bin:/usr/bin:/bin")
    demo = tmp_path / "demo_scene.blend"
    subprocess.run([blender, "--background", "--factory-startup", "--python",
                    os.path.join(ROOT, "build_scripts", "demo_scene.py"), "--", str(demo)]
                   + ([MOCAP] if os.path.exists(MOCAP) else []),
                   check=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=240, env=env)
    verdict_path = tmp_path / "trails.json"
    proc = subprocess.run([xvfb, "-a", "-s", "-screen 0 1600x900x24", blender, "--factory-startup",
                           "--window-geometry", "0", "0", "1600", "900", "--enable-event-simulate", str(demo),
                           "--python", os.path.join(os.path.dirname(__file__), "sessions", "trails_session.py"),
                           "--", str(verdict_path), SCREENSHOTS],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600, env=env)
    log = proc.stdout
    assert verdict_path.exists(), "the session wrote no verdict (exit %s):\n%s" % (proc.returncode, log[-4000:])
    verdict = json.loads(verdict_path.read_text())
    assert verdict["ok"], "the session failed:\n%s\n%s" % ("\n".join(verdict["errors"]), log[-3000:])
    assert "Traceback" not in log, log[-3000:]
    assert verdict["draw_handlers"] == 1 and verdict["drawn"].get("trails")
    for panel in ("bake", "compare", "trails"):
        assert verdict["drawn"].get("QUATCURVE_PT_view3d_" + panel), verdict["drawn"]
    assert verdict["drawn"].get("QUATCURVE_PT_graph_compare"), verdict["drawn"]
    assert all(v == ["FINISHED"] for v in verdict["compare"].values()), verdict["compare"]
    assert verdict["show_plot"] == ["FINISHED"] and verdict["image_editor"] == "QuatCurve compare: FixedAngle"

    # FixedAngle: Blender's Euler path (magenta) bows away from SLERP's great circle (cyan). Where the
    # two tips are apart, each colour sits on its own projected tip, and nothing magenta is there
    # with the trails off.
    shot, off = (load_rgb(verdict["screenshots"][n]) for n in ("trails_FixedAngle", "trails_FixedAngle_off"))
    tips = verdict["points"]["trails_FixedAngle"]
    blender_tips, slerp_tips = tips["BLENDER"]["tips"], tips["SLERP"]["tips"]
    apart = [i for i, (b, s) in enumerate(zip(blender_tips, slerp_tips))
             if b is not None and s is not None and np.hypot(b[0] - s[0], b[1] - s[1]) > 10]
    assert len(apart) >= 5, "the two trails should part in the middle of the range: %s" % tips
    for i in apart:
        assert colour_near(shot, blender_tips[i], MAGENTA), "no magenta at frame %s's tip %s" % (i + 1, blender_tips[i])
        assert colour_near(shot, slerp_tips[i], CYAN), "no cyan at frame %s's tip %s" % (i + 1, slerp_tips[i])
        assert not colour_near(off, blender_tips[i], MAGENTA), "magenta with the trails off at %s" % blender_tips[i]
    # Spin and the Mocap bone: SLERP (on top) runs where Blender's trail runs; cyan on nearly every tip.
    for name in [n for n in ("trails_Spin", "trails_Mocap") if n in verdict["points"]]:
        shot = load_rgb(verdict["screenshots"][name])
        seen = [p for p in verdict["points"][name]["SLERP"]["tips"] if p is not None]
        found = sum(colour_near(shot, p, CYAN) for p in seen)
        assert len(seen) >= 10 and found >= 0.9 * len(seen), "%s: cyan at %d of %d tips" % (name, found, len(seen))
    print("screenshots in %s: %s" % (SCREENSHOTS, ", ".join(sorted(verdict["screenshots"]))))


# ---- the panel on a rig, the comparison table popup, the fitted curve (sessions/panel_session.py) -------

def near(rgb, colour, tolerance=0.06):
    return np.all(np.abs(rgb - np.asarray(colour[:3], dtype=np.float32)) <= tolerance, axis=-1)


def test_panel_popup_and_fitted_curve_in_a_window(tmp_path):
    reason = no_window_reason()
    if reason:
        pytest.skip(reason)
    env = dict(os.environ, PATH="/usr/local/bin:/usr/bin:/bin")
    verdict_path = tmp_path / "panel.json"
    proc = subprocess.run([shutil.which("xvfb-run"), "-a", "-s", "-screen 0 1600x1000x24", debian_blender(),
                           "--factory-startup", "--window-geometry", "0", "0", "1600", "1000",
                           "--enable-event-simulate", "--python",
                           os.path.join(os.path.dirname(__file__), "sessions", "panel_session.py"),
                           "--", str(verdict_path), SCREENSHOTS],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600, env=env)
    log = proc.stdout
    assert verdict_path.exists(), "the session wrote no verdict (exit %s):\n%s" % (proc.returncode, log[-4000:])
    verdict = json.loads(verdict_path.read_text())
    assert verdict["ok"], "the session failed:\n%s\n%s" % ("\n".join(verdict["errors"]), log[-3000:])
    assert "Traceback" not in log, log[-3000:]
    assert verdict["compare"] == ["FINISHED"] and verdict["fit"] == ["FINISHED"]
    shots = verdict["screenshots"]

    # Default state: the parent and Fit drew, the other tasks only their headers (closed). The
    # sidebar at Blender's default width; the recommendation wrapped into lines that fit it.
    assert set(verdict["drawn_default"]) == {"QUATCURVE_PT_view3d", "QUATCURVE_PT_view3d_fit"}, verdict["drawn_default"]
    assert verdict["drawn"].get("QUATCURVE_PT_view3d_compare"), "the Compare header click did not open it"
    sidebar = verdict["sidebar"]
    assert 200 <= sidebar["width"] <= 260, sidebar
    lines = verdict["sidebar_lines"]
    assert " ".join(lines["lines"]) == verdict["sentence"] and len(lines["lines"]) >= 2
    assert max(lines["widths"]) <= sidebar["width"] - 40, lines

    # The popup: it drew, it is as wide as its columns, and every text fits its column (blf widths).
    assert verdict["table"] == ["RUNNING_MODAL"] and verdict["drawn"].get("compare_table")
    text = verdict["text"]
    for column in text["columns"]:
        room = column["units"] * text["unit_px"] - 8
        for t, w in zip(column["texts"], column["widths"]):
            assert w <= room, "%r is %d pixels wide, its column has %d" % (t, w, room)
    before, popup = load_rgb(shots["compare_popup_before"]), load_rgb(shots["compare_popup"])
    changed = np.abs(popup - before).max(axis=-1) > 0.1
    cols, rows = np.nonzero(changed.any(axis=0))[0], np.nonzero(changed.any(axis=1))[0]
    assert len(cols) and len(rows), "the popup screenshot shows no popup"
    width, height = cols[-1] - cols[0] + 1, rows[-1] - rows[0] + 1
    columns_px = sum(c["units"] for c in text["columns"]) * text["unit_px"]
    assert columns_px <= width <= text["popup_width"] + 60 and height >= 200, (width, height, columns_px)
    assert cols[0] <= verdict["mouse"][0] <= cols[-1]  # opened under the mouse

    # The Graph Editor: a key point (drawn black, nothing selected) at every key of the fitted curves.
    graph = load_rgb(shots["graph_fitted"])
    gx, gy, gw, gh = verdict["graph_region"]
    black = lambda rgb: rgb.max(axis=-1) < 0.08  # noqa: E731
    inside = [p for p in verdict["graph_keys"] if gx + 4 < p[0] < gx + gw - 4 and gy + 4 < p[1] < gy + gh - 4]
    assert len(inside) == len(verdict["graph_keys"]) == len(verdict["keys"]), (len(inside), len(verdict["keys"]))
    missing = [p for p in inside if not colour_near(graph, p, black, radius=2)]
    assert not missing, "no key point drawn at %s" % missing

    # The Dope Sheet: generated keys in Blender's colour for them (JITTER in 3.4, GENERATED from 4.2),
    # the animator's keys in the keyframe colour and never in that one.
    sheet = load_rgb(shots["dopesheet_fitted"])
    sx, sy, sw, sh = verdict["sheet_region"]
    colours = verdict["colours"]
    generated = sorted({f for f, g in verdict["keys"] if g})
    animator = sorted({f for f, g in verdict["keys"] if not g})
    assert len(animator) == 4 and generated, verdict["keys"]
    for frames, colour, other in ((generated, "generated", "keyframe"), (animator, "keyframe", "generated")):
        for f in frames:
            x = int(round(verdict["sheet_x"]["%g" % f]))
            strip = sheet[sy:sy + sh, x - 3:x + 4]
            assert near(strip, colours[colour]).sum() >= 4, "frame %g: no %s key drawn" % (f, colour)
            assert not near(strip, colours[other], 0.03).any(), "frame %g: a %s key drawn" % (f, other)
    print("screenshots in %s: %s" % (SCREENSHOTS, ", ".join(sorted(shots))))
