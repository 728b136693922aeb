"""The `quatcurve.clean` operator and the clean settings and last result (`scene.quatcurve_clean`).

Cleans the rotation keys of the selected objects (Object mode) or pose bones (Pose mode) — captured
motion with jitter, spikes and sign flips — into a new action by default (clean.py). Reports the spike
frames replaced (on which targets, the largest departure), the flips removed and the largest
deviation from the frames that are not spikes: an angle per target (error='ANGLE'), or per armature
the worst distance of the virtual vertices (error='DISTANCE', reduce's definition). Properties not
given by the caller come from the panel's settings.
"""

import bpy

from . import clean, opsutil, reduce_ops

ERROR_ITEMS = (
    ("ANGLE", "Angle", "Each rotation within the Deviation (degrees) of every captured frame that is not a spike"),
    ("DISTANCE", "Distance", "Per armature, every bone's tail and the points at Shell along its axes within Distance of "
                             "the captured pose, in the armature's space, at every frame that is not a spike; "
                             "objects: their own three shell points"),
)


def clean_properties():
    """The clean settings as property definitions, shared by scene.quatcurve_clean and the operator."""
    P = bpy.props
    return {
        "deviation": P.FloatProperty(
            name="Deviation (°)", default=0.0, min=0.0, soft_max=10.0, precision=3,
            description="How far the cleaned rotation may stray from each captured frame that is not a spike, "
                        "in degrees; 0: 2.5 times the clip's own noise, estimated target by target"),
        "error": P.EnumProperty(
            name="Error", items=ERROR_ITEMS, default="ANGLE",
            description="What the bound is on: each rotation's angle, or how far the armature's bones move"),
        "distance": P.FloatProperty(
            name="Distance", default=0.0, min=0.0, soft_max=0.1, precision=4, subtype="DISTANCE", unit="LENGTH",
            description="How far, in scene units, any bone's tail or shell point may move from the captured pose, "
                        "in the armature's space, at every frame that is not a spike; 0: the noise's own reach, "
                        "2.5 times a bone's noise angle times how far its vertices and its children's reach, the "
                        "largest over the bones"),
        "shell": reduce_ops.reduce_properties()["shell"],
        "spikes": P.BoolProperty(
            name="Replace Spikes", default=True,
            description="Find frames (runs of up to 3) far off what their neighbours predict, by much more than "
                        "the clip's noise, and replace them by the curve through their neighbours"),
        "reduce": P.BoolProperty(
            name="Reduce", default=False,
            description="Reduce the cleaned keys (Bezier) within the Tolerance of them at every instant; off: "
                        "one linear key per frame"),
        "tolerance": P.FloatProperty(
            name="Tolerance (°)", default=0.1, min=0.0, soft_max=10.0, precision=3,
            description="With Reduce: how far the reduced rotation may stray from the cleaned keys, in degrees, "
                        "at every instant"),
        "new_action": reduce_ops.reduce_properties()["new_action"],
    }


class QuatCurveCleanSettings(bpy.types.PropertyGroup):
    """scene.quatcurve_clean: the panel's clean settings and the last clean's summary."""
    __annotations__ = dict(
        clean_properties(),
        **opsutil.last_result_properties("Clean", "Spikes replaced, flips removed and the largest deviation of "
                                                  "the last clean"),
    )


def draw_settings(layout, settings, max_lines=6, width=40):
    """The panel's clean box: settings, button, last result (wrapped at `width` characters)."""
    col = layout.column(align=True)
    col.row(align=True).prop(settings, "error", expand=True)
    if settings.error == "DISTANCE":
        col.prop(settings, "distance", text="Distance (0: from noise)" if settings.distance == 0 else "Distance")
        col.prop(settings, "shell", text="Shell (0: 10 cm)" if settings.shell == 0 else "Shell")
    else:
        col.prop(settings, "deviation",
                 text="Deviation (0: from noise)" if settings.deviation == 0 else "Deviation (°)")
    col.prop(settings, "spikes")
    col.prop(settings, "reduce")
    if settings.reduce:
        col.prop(settings, "tolerance")
    col.prop(settings, "new_action")
    layout.operator("quatcurve.clean", text="Clean Rotations", icon="MOD_SMOOTH")
    opsutil.draw_last_result(layout, settings, max_lines, width)


class QUATCURVE_OT_clean(bpy.types.Operator):
    """Clean the rotation keys of the selected objects or pose bones (motion capture): sign flips removed, spikes replaced by the curve through their neighbours, jitter smoothed on the sphere of rotations within the Deviation of every other frame, or (Error: Distance) with every bone's tail and shell points within the Distance; into a new action by default"""
    bl_idname = "quatcurve.clean"
    bl_label = "Clean Rotations"
    bl_options = {"REGISTER", "UNDO"}
    __annotations__ = clean_properties()

    def execute(self, context):
        def settings(op):
            return clean.CleanSettings(deviation=op.deviation, spikes=op.spikes, reduce=op.reduce,
                                       tolerance=op.tolerance, new_action=op.new_action, error=op.error,
                                       distance=op.distance, shell=op.shell)
        return opsutil.run_task(self, context, "quatcurve_clean", clean_properties(), settings, clean.clean,
                                "clean", report_prefix="Cleaned ")


_classes = (QuatCurveCleanSettings, QUATCURVE_OT_clean)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.quatcurve_clean = bpy.props.PointerProperty(type=QuatCurveCleanSettings)


def unregister():
    del bpy.types.Scene.quatcurve_clean
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
