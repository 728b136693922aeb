"""The `quatcurve.compare` operator and the compare settings and last result (`scene.quatcurve_compare`).

The operator gathers the selection (objects in Object mode, pose bones in Pose mode), calls
compare.py, puts each target's plot in an image datablock (Image Editor), writes the JSON report and
the PNGs when `report_path` is set, stores the table for the panel, and reports. It never changes
animation data.
"""

import json

import bpy

from . import compare, methods, native, opsutil

KEY_INTERPOLATION_ITEMS = (
    ("BEZIER", "Bezier (auto-clamped)", "Blender's default for new keys: rotation eases in and out of every key"),
    ("LINEAR", "Linear", "Straight lines between keys in each channel"),
)

# Display names of the compared sources (the report and the CLI keep the source identifiers).
METHOD_NAMES = {method: methods.label(method) for method in methods.ALL}
SOURCE_NAMES = compare.SOURCE_NAMES
source_label = compare.source_label  # 'Slerp', 'Blender Euler XYZ', 'Blender (as keyed)'; lives in compare.py


def compare_properties():
    """Compare settings as property definitions, shared by scene.quatcurve_compare and the operator."""
    P = bpy.props
    return {
        "report_path": P.StringProperty(
            name="Report", subtype="FILE_PATH", default="",
            description="Also save the comparison as a file: a JSON report at this path, each plot beside it "
                        "as a PNG. Empty: no files (the plots are still images in this .blend)"),
        "subframes": P.IntProperty(
            name="Samples per Frame", default=1, min=1, max=100,
            description="How often each frame the rotation is measured, in samples per frame (1: on every "
                        "frame; more shows speed changes between frames, and takes longer)"),
        "all_euler_orders": P.BoolProperty(
            name="All Euler Orders", default=False,
            description="Also show how Blender's Euler rotation plays your keys in each of the six axis "
                        "orders (off: only in the order the object or bone uses)"),
        "key_interpolation": P.EnumProperty(
            name="Blender Keys", items=KEY_INTERPOLATION_ITEMS, default="BEZIER",
            description="The key interpolation Blender's own Euler and quaternion rotation are played with "
                        "for the comparison"),
    }


_COMPARE_PROPERTIES = tuple(compare_properties())


class QuatCurveCompareSettings(bpy.types.PropertyGroup):
    """scene.quatcurve_compare: the panel's compare settings and the last comparison's table."""
    __annotations__ = dict(
        compare_properties(),
        last_summary=bpy.props.StringProperty(
            name="Last Compare", default="", description="Targets, sources and seconds of the last comparison"),
        last_table=bpy.props.StringProperty(
            name="Last Compare Table", default="",
            description="The last comparison for the panel (JSON: [{name, rotation_mode, key_frames, rows: "
                        "[[source, max deviation, speed ratio, path length]], sources: [{source, label, "
                        "max_deviation_deg, speed_ratio, path_length_deg, velocity_jump_deg, "
                        "acceleration_jump_deg}], recommendation, sentence, method, no_difference, "
                        "path_rule: [line], image}])"),
    )


def source_rows(comparison):
    """Per source of a TargetComparison, the figures the panel's table shows, in degrees (None: not
    finite): {source, label, max_deviation_deg, speed_ratio, path_length_deg, velocity_jump_deg (°/frame),
    acceleration_jump_deg (°/frame²)}."""
    rows = []
    for name, s in comparison.sources.items():
        m = s.metrics
        rows.append({"source": name, "label": source_label(name),
                     "max_deviation_deg": compare._deg(m["max_deviation"]),
                     "speed_ratio": compare._num(m["speed_ratio"]),
                     "path_length_deg": compare._deg(m["path_length"]),
                     "velocity_jump_deg": compare._deg(m["max_velocity_jump"]),
                     "acceleration_jump_deg": compare._deg(m["max_acceleration_jump"])})
    return rows


def recommendation_sentence(recommendation):
    """The recommendation as one sentence an animator reads at a glance (the reasons are in the
    table's popup): which method, and why in a few words."""
    method = recommendation.get("method", "")
    name = METHOD_NAMES.get(method, method)
    verdict = recommendation.get("methods", {}).get(method, {})
    if not method:
        return ""
    if recommendation.get("no_difference"):
        return "Any method plays these keys the same way; %s is enough." % name
    if verdict.get("eligible"):
        return "Use %s: it passes through your keys at a steady speed%s." % (
            name, " and turns smoothly at them" if verdict.get("smooth") else "")
    return "No method is clean here; %s keeps the steadiest speed (see the table)." % name


def store_result(settings, report):
    """Records a CompareReport in scene.quatcurve_compare for the panel."""
    settings.last_summary = report.summary()
    settings.last_table = json.dumps([
        {"name": t.name, "rotation_mode": t.rotation_mode, "key_frames": [float(f) for f in t.key_frames],
         "rows": [list(r) for r in t.table_rows()], "sources": source_rows(t),
         "recommendation": t.recommendation.get("text", ""), "sentence": recommendation_sentence(t.recommendation),
         "method": t.recommendation.get("method", ""),
         "no_difference": bool(t.recommendation.get("no_difference", False)),
         "path_rule": [b.text() for b in t.path_rule], "image": t.image_name or ""}
        for t in report.targets])


def last_table(settings):
    """The stored table: [{name, rows, recommendation, method, no_difference, path_rule, image}] ([] when
    there is none)."""
    try:
        return json.loads(settings.last_table) if settings.last_table else []
    except ValueError:
        return []


def last_result(scene, target_name):
    """The last comparison of one target ('Cube', 'Armature/Bone') as stored for the panel — {name,
    rows, recommendation (text), method, no_difference, path_rule (lines), image (its plot's image
    datablock name)} — or None. With compare.last_plot_image(target_name) for the image itself."""
    settings = getattr(scene, "quatcurve_compare", None)
    if settings is None:
        return None
    return next((t for t in last_table(settings) if t["name"] == target_name), None)


class QUATCURVE_OT_compare(bpy.types.Operator):
    """Measure how each method and Blender's own Euler and quaternion rotation move through the selected objects' or pose bones' keys (deviation in degrees, speed, path length), recommend a method and plot it; changes no keys"""
    bl_idname = "quatcurve.compare"
    bl_label = "Compare Orientation Curves"
    bl_options = {"REGISTER"}
    __annotations__ = compare_properties()

    def _settings(self, context):
        """Unset properties take the panel's values."""
        opsutil.take_scene_settings(self, getattr(context.scene, "quatcurve_compare", None), _COMPARE_PROPERTIES)
        return compare.CompareSettings(subframes=int(self.subframes), all_euler_orders=bool(self.all_euler_orders),
                                       key_interpolation=self.key_interpolation)

    def execute(self, context):
        try:
            native.require()
            settings = self._settings(context)
            report = compare.compare(compare.gather_targets(context), settings)
            written = ""
            if self.report_path:  # the images are saved as PNG, then packed from those files
                path, pngs = compare.write_report(report, bpy.path.abspath(self.report_path))
                written = "; wrote %s and %d plot%s" % (path, len(pngs), "" if len(pngs) == 1 else "s")
            else:
                compare.make_images(report)
        except (compare.CompareError, RuntimeError, OSError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        scene_settings = getattr(context.scene, "quatcurve_compare", None)
        if scene_settings is not None:
            store_result(scene_settings, report)
        for target in report.targets:
            self.report({"INFO"}, "%s: %s" % (target.name, target.recommendation["text"]))
        self.report({"INFO"}, "Compared " + report.summary() + written)
        return {"FINISHED"}


_classes = (QuatCurveCompareSettings, QUATCURVE_OT_compare)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.quatcurve_compare = bpy.props.PointerProperty(type=QuatCurveCompareSettings)


def unregister():
    del bpy.types.Scene.quatcurve_compare
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
