"""The sidebar panel's layout, the comparison table popup and the tooltips, in background mode (the
drawing into a recording layout; test_ui_xvfb.py draws the same panels in a window).

- Fit comes first and open, its method and Live on one row; Bake, Reduce Keys, Compare and Orientation
  Trails below it, closed by default.
- Compare shows the recommendation as one sentence and two buttons (the table popup, the plot); the
  popup has a column per measure with its unit, wide enough for the longest source name.
- Every property and operator of the add-on has a tooltip, and every number's tooltip says its unit.
"""

import math
import re

import blf
import bpy
from quatcurve_blender import bake_ops, compare_ops, fit_ops, reduce_ops, trails, ui


class Recorder:
    """Enough of UILayout for the add-on's panels: records what is drawn as a tree of
    (kind, text, children), with the attributes the panels set."""

    def __init__(self, kind="layout", text=""):
        self.kind, self.text, self.children = kind, text, []
        self.scale_y, self.active, self.alignment, self.ui_units_x, self.alert = 1.0, True, "EXPAND", 0.0, False

    def _child(self, kind, text=""):
        child = Recorder(kind, text)
        self.children.append(child)
        return child

    def box(self):
        return self._child("box")

    def column(self, align=False):
        return self._child("column")

    def row(self, align=False):
        return self._child("row")

    def split(self, factor=0.0, align=False):
        return self._child("split")

    def separator(self):
        self._child("separator")

    def label(self, text="", icon="NONE"):
        self._child("label", text)

    def prop(self, data, name, text=None, **kwargs):
        assert name in data.bl_rna.properties, name
        self._child("prop", name)

    def operator(self, idname, text="", icon="NONE"):
        child = self._child("operator", idname)
        return type("OperatorProperties", (), {})()

    def template_icon(self, **kwargs):
        self._child("icon")

    def walk(self):
        yield self
        for child in self.children:
            yield from child.walk()

    def texts(self, kind):
        return [n.text for n in self.walk() if n.kind == kind]


def text_width(text):
    """Pixels of `text` in Blender's UI font (blf's font 0) at the labels' size and the UI scale."""
    styles = bpy.context.preferences.ui_styles[0]
    style = getattr(styles, "widget_label", None) or styles.widget  # 5.x: one font size for widgets
    blf.size(0, style.points * bpy.context.preferences.view.ui_scale)
    return blf.dimensions(0, text)[0]


def keyed_cube(scene, name="Cube"):
    obj = bpy.data.objects.new(name, None)
    scene.collection.objects.link(obj)
    obj.rotation_mode = "XYZ"
    for frame, angles in ((1, (0, 90, 0)), (11, (30, 20, 60)), (21, (90, 45, 90))):
        obj.rotation_euler = [math.radians(a) for a in angles]
        obj.keyframe_insert("rotation_euler", frame=frame)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    return obj


# ---- the panels ------------------------------------------------------------------------------------

def test_fit_first_and_open_the_other_tasks_closed(addon):
    assert ui.TASK_PANELS[0] is ui.FitPanel and "DEFAULT_CLOSED" not in ui.FitPanel.bl_options
    for task in ui.TASK_PANELS[1:]:
        assert "DEFAULT_CLOSED" in task.bl_options, task.bl_label
    assert [t.task for t in ui.TASK_PANELS] == ["fit", "bake", "reduce", "clean", "compare", "trails"]
    for parent in ("QUATCURVE_PT_view3d", "QUATCURVE_PT_graph"):
        children = [c for c in ui._classes if getattr(c, "bl_parent_id", "") == parent]
        tasks = [c.task for c in children]
        assert tasks == ["fit", "bake", "reduce", "clean", "compare"] + (["trails"] if parent.endswith("view3d") else [])
        for cls in children:
            assert ("DEFAULT_CLOSED" in cls.bl_options) == (cls.task != "fit"), cls.bl_idname
            assert getattr(bpy.types, cls.bl_idname).bl_parent_id == parent


def test_fit_method_and_live_share_the_first_row(scene):
    layout = Recorder()
    fit_ops.draw_settings(layout, scene.quatcurve_fit, bpy.context, extra_rows=ui.FIT_ROWS)
    first = layout.children[0]
    assert first.kind == "row" and [c.text for c in first.children] == ["method", "live"]
    assert layout.texts("operator") == ["quatcurve.fit", "quatcurve.unfit", "quatcurve.set_ease", "quatcurve.set_turns"]


def test_fit_says_whether_the_active_target_is_fitted(scene):
    keyed_cube(scene)
    assert fit_ops.active_status(bpy.context) == ""
    assert bpy.ops.quatcurve.fit(method="SPLINE_C2", tolerance=0.05) == {"FINISHED"}
    assert fit_ops.active_status(bpy.context) == "Fitted: C2 Spline, 0.05°"


def test_fit_rows_draw_inside_the_fit_panel(scene):
    drawn = []

    def draw_turns(layout, context):
        drawn.append(context)
        layout.label(text="Turns")

    layout = Recorder()
    fit_ops.draw_settings(layout, scene.quatcurve_fit, bpy.context, extra_rows=(draw_turns,))
    assert drawn == [bpy.context] and "Turns" in layout.texts("label")
    labels = [n.text or n.kind for n in layout.walk() if n.kind in ("label", "operator")]
    assert labels.index("Turns") > labels.index("quatcurve.set_ease")


# ---- compare: one sentence in the panel, the table in a popup ----------------------------------------

def test_the_panel_shows_one_sentence_and_opens_table_and_plot(scene):
    keyed_cube(scene)
    layout = Recorder()
    ui.draw_compare_result(layout, bpy.context, scene.quatcurve_compare)
    assert layout.children == []  # nothing compared yet
    assert bpy.ops.quatcurve.compare() == {"FINISHED"}
    ui.draw_compare_result(layout, bpy.context, scene.quatcurve_compare)
    entry = compare_ops.last_result(scene, "Cube")
    sentence = entry["sentence"]
    assert sentence.count(".") == 1 and sentence.endswith(".") and len(sentence) < 110, sentence
    method = compare_ops.METHOD_NAMES[entry["method"]]
    assert method in sentence
    # Wrapped into labels of the sidebar's width: the words in order, nothing else.
    labels = layout.texts("label")
    assert labels[0] == "Cube" and " ".join(labels[1:]) == sentence
    assert layout.texts("operator") == ["quatcurve.compare_table", "quatcurve.show_compare_plot"]
    assert not any(n.kind == "prop" for n in layout.walk())  # no table in the sidebar


def test_the_panel_shows_the_active_targets_sentence_first(scene):
    keyed_cube(scene, "Other")
    cube = keyed_cube(scene, "Cube")
    assert bpy.ops.quatcurve.compare() == {"FINISHED"}
    for active in ("Other", "Cube"):
        bpy.context.view_layer.objects.active = bpy.data.objects[active]
        layout = Recorder()
        ui.draw_compare_result(layout, bpy.context, scene.quatcurve_compare)
        labels = layout.texts("label")
        assert labels[0] == active and labels[-1] == "1 more in the Table"
        popup = Recorder()
        ui.draw_compare_table(popup, scene.quatcurve_compare, active=active)
        assert popup.children[0].children[0].children[0].text.startswith(active + " ")
    assert cube.select_get()
    # An active target that was not compared: the last compared one's sentence, said so.
    bpy.context.view_layer.objects.active = keyed_cube(scene, "Third")
    layout = Recorder()
    ui.draw_compare_result(layout, bpy.context, scene.quatcurve_compare)
    first = compare_ops.last_table(scene.quatcurve_compare)[0]
    assert layout.texts("label")[0] == "Last compared: " + first["name"]
    assert " ".join(layout.texts("label")[1:]) == first["sentence"] + " 1 more in the Table"


def test_the_popup_table_has_every_column_with_its_unit(scene):
    keyed_cube(scene)
    assert bpy.ops.quatcurve.compare() == {"FINISHED"}
    layout = Recorder()
    ui.draw_compare_table(layout, scene.quatcurve_compare, active="Cube")
    box = layout.children[0]
    table = next(c for c in box.children if c.kind == "row" and len(c.children) == len(ui.COMPARE_COLUMNS))
    entry = compare_ops.last_result(scene, "Cube")
    headers = [" ".join(t for t in col.texts("label")[:2]) for col in table.children]
    assert headers[0].startswith("Source")
    for header, unit in zip(headers[1:], ("°", "fastest / slowest", "°", "°/frame", "°/frame²")):
        assert unit in header, headers
    assert "Jerk" in headers[5]
    sources = table.children[0].texts("label")[2:]
    assert sources == [s["label"] for s in entry["sources"]]
    assert "Slerp" in sources and "Blender (as keyed)" in sources and "Blender Euler XYZ" in sources
    slerp = entry["sources"][sources.index("Slerp")]
    assert table.children[1].texts("label")[2 + sources.index("Slerp")] == "0.00°"
    assert slerp["speed_ratio"] is not None and slerp["velocity_jump_deg"] >= 0
    # Every text narrower than its column in this Blender's UI font (blf; a UI unit is 20 pixels at
    # UI scale 1, 8 of them margins), and the popup as wide as the columns.
    for (header, key, fmt, units), col in zip(ui.COMPARE_COLUMNS, table.children):
        assert col.ui_units_x == units
        for text in col.texts("label"):
            assert text_width(text) + (20 if key == "label" else 0) <= units * 20 - 8, (text, text_width(text))
    assert ui.popup_width(bpy.context) >= sum(c[3] for c in ui.COMPARE_COLUMNS) * 20
    # The sentence, then the reasons and the plot button.
    texts = box.texts("label")
    assert entry["sentence"] in texts and "quatcurve.show_compare_plot" in box.texts("operator")


def test_the_sentence_fits_the_default_sidebar(scene):
    # Blender's default sidebar is 229 pixels wide at UI scale 1 (measured in 3.4 under Xvfb; the
    # window test checks it there): the wrapped lines fit inside its box, in this Blender's font.
    class Region:
        width = 229

    class Context:
        region, preferences = Region, bpy.context.preferences

    keyed_cube(scene)
    assert bpy.ops.quatcurve.compare() == {"FINISHED"}
    longest = [compare_ops.recommendation_sentence(r) for r in (
        {"method": "SPLINE_C2", "methods": {"SPLINE_C2": {"eligible": True, "smooth": True}}},
        {"method": "CATMULL_ROM", "methods": {"CATMULL_ROM": {"eligible": False}}})]
    for sentence in [compare_ops.last_result(scene, "Cube")["sentence"]] + longest:
        layout = Recorder()
        ui.wrapped_labels(layout, sentence, ui.label_width(Context))
        lines = layout.texts("label")
        assert " ".join(lines) == sentence
        assert max(text_width(line) for line in lines) <= Region.width - 40, lines


def test_the_table_operator_reports_in_background_and_refuses_without_a_comparison(scene):
    keyed_cube(scene)
    assert bpy.ops.quatcurve.compare_table() == {"CANCELLED"}  # a warning: "No comparison yet"
    assert bpy.ops.quatcurve.compare() == {"FINISHED"}
    assert bpy.ops.quatcurve.compare_table() == {"FINISHED"}


def test_the_sentence_says_which_method_and_why():
    verdict = {"eligible": True, "smooth": True}
    assert compare_ops.recommendation_sentence({"method": "SQUAD", "methods": {"SQUAD": verdict}}) == \
        "Use Squad: it passes through your keys at a steady speed and turns smoothly at them."
    assert compare_ops.recommendation_sentence(
        {"method": "SLERP", "methods": {"SLERP": dict(verdict, smooth=False)}}) == \
        "Use Slerp: it passes through your keys at a steady speed."
    assert compare_ops.recommendation_sentence({"method": "SLERP", "no_difference": True}) == \
        "Any method plays these keys the same way; Slerp is enough."
    assert compare_ops.recommendation_sentence({"method": "TCB", "methods": {"TCB": {"eligible": False}}}) == \
        "No method is clean here; TCB keeps the steadiest speed (see the table)."
    assert compare_ops.source_label("BLENDER_EULER_ZXY") == "Blender Euler ZXY"


# ---- tooltips ---------------------------------------------------------------------------------------

SETTINGS = (bake_ops.QuatCurveSettings, compare_ops.QuatCurveCompareSettings, reduce_ops.QuatCurveReduceSettings,
            fit_ops.QuatCurveFitSettings, trails.QuatCurveTrailSettings, fit_ops.QuatCurveFitRecord,
            fit_ops.QuatCurveEaseRecord, fit_ops.QuatCurveTurnsRecord)
# A number's tooltip says its unit (degrees, frames, scene units, seconds, full turns, a count) or its range.
UNIT = re.compile(r"degree|°|frame|scene unit|second|turns|count|from -?[01] ")


def addon_operators():
    """(identifier, RNA type) of every quatcurve.* operator (its own properties, its description)."""
    return [("quatcurve." + name, getattr(bpy.ops.quatcurve, name).get_rna_type()) for name in dir(bpy.ops.quatcurve)]


def test_every_operator_and_property_has_a_tooltip_with_its_unit(addon):
    operators = addon_operators()
    assert {"quatcurve.fit", "quatcurve.compare_table", "quatcurve.show_compare_plot"} <= {op for op, _ in operators}
    missing = []
    structs = operators + [(cls.__name__, cls.bl_rna) for cls in SETTINGS]
    for owner, rna in structs:
        if owner.startswith("quatcurve.") and len(rna.description.split()) < 5:
            missing.append("%s: operator tooltip %r" % (owner, rna.description))
        for prop in rna.properties:
            if prop.identifier == "rna_type" or prop.is_hidden:  # hidden: never shown, so no tooltip
                continue
            where = "%s.%s" % (owner, prop.identifier)
            if len(prop.description.split()) < 3:
                missing.append("%s: tooltip %r" % (where, prop.description))
            elif prop.type in ("INT", "FLOAT") and not UNIT.search(prop.description):
                missing.append("%s: no unit in %r" % (where, prop.description))
            if prop.type == "ENUM":
                missing += ["%s: item %s has no tooltip" % (where, item.identifier)
                            for item in prop.enum_items if not item.description]
    assert not missing, "\n".join(missing)
