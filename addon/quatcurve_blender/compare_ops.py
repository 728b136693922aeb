"""The `quatcurve.compare` operator and the compare settings and last result (`scene.quatcurve_compare`).

The operator gathers the selection (objects in Object mode, pose bones in Pose mode), calls
compare.py, puts each target's plot in an image datablock (Image Editor), writes the JSON report and
the PNGs when `report_path` is set, stores the table for the panel, and reports. It never changes
animation data.
"""

import json

import bpy

from . import compare, native, opsutil

KEY_INTERPOLATION_ITEMS = (
    ("BEZIER", "Bezier (auto-clamped)", "Blender's default for new keys"),
    ("LINEAR", "Linear", "Linear keys"),
)


def compare_properties():
    """Compare settings as property definitions, shared by scene.quatcurve_compare and the operator."""
    P = bpy.props
    return {
        "report_path": P.StringProperty(
            name="Report", subtype="FILE_PATH", default="",
            description="JSON report to write (the plots go beside it as PNG); empty: no files"),
        "subframes": P.IntProperty(
            name="Samples per Frame", default=1, min=1, max=100,
            description="Samples per frame (1: every frame; more for finer speed profiles)"),
        "all_euler_orders": P.BoolProperty(
            name="All Euler Orders", default=False,
            description="Compare Blender's Euler mode in all six orders (off: the target's order)"),
        "key_interpolation": P.EnumProperty(
            name="Blender Keys", items=KEY_INTERPOLATION_ITEMS, default="BEZIER",
            description="Key type of the Euler and quaternion curves Blender evaluates for comparison"),
    }


_COMPARE_PROPERTIES = tuple(compare_properties())


class QuatCurveCompareSettings(bpy.types.PropertyGroup):
    """scene.quatcurve_compare: the panel's compare settings and the last comparison's table."""
    __annotations__ = dict(
        compare_properties(),
        last_summary=bpy.props.StringProperty(name="Last Compare", default=""),
        last_table=bpy.props.StringProperty(
            name="Last Compare Table", default="",
            description="JSON: [{name, rows: [[source, max deviation, speed ratio, path length]], "
                        "recommendation, method, no_difference, path_rule: [line], image}]"),
    )


def store_result(settings, report):
    """Records a CompareReport in scene.quatcurve_compare for the panel."""
    settings.last_summary = report.summary()
    settings.last_table = json.dumps([
        {"name": t.name, "rows": [list(r) for r in t.table_rows()],
         "recommendation": t.recommendation.get("text", ""), "method": t.recommendation.get("method", ""),
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
    """Compare interpolation methods with Blender's Euler and quaternion modes on the selected objects or pose bones"""
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
