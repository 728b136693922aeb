"""The `quatcurve.reduce` operator and the reduce settings and last result (`scene.quatcurve_reduce`).

Reduces the existing rotation keys of the selected objects (Object mode) or pose bones (Pose mode)
— imported motion capture, bakes — into a new action by default, or in place. error='ANGLE' (the
default, the bound every other task uses: degrees per rotation) or 'DISTANCE' (per armature, the
virtual vertices within `distance` in object space: reduce.reduce_distance). Reports the rotation
keys before and after and the largest error, measured at every frame and original key. Properties
not given by the caller come from the panel's settings.
"""

import bpy

from . import opsutil, reduce

INTERPOLATION_ITEMS = (
    ("BEZIER", "Bezier", "Bezier keys with fitted handles (FREE, broken at keys): the fewest keys"),
    ("LINEAR", "Linear", "Linear keys: every kept key is an original sample"),
)
ERROR_ITEMS = (
    ("ANGLE", "Angle", "Each rotation within the Tolerance (degrees) of the original, target by target"),
    ("DISTANCE", "Distance", "Per armature, every bone's tail and the points at Shell along its axes within "
                             "Distance of the original in the armature's object space (ACL's error metric); "
                             "objects: their own three shell points"),
)


def reduce_properties():
    """The reduce settings as property definitions, shared by scene.quatcurve_reduce and the operator."""
    P = bpy.props
    return {
        "tolerance": P.FloatProperty(
            name="Tolerance (°)", default=0.1, min=0.0, soft_max=10.0, precision=3,
            description="How far the reduced rotation may stray from the original, in degrees, checked on every "
                        "frame and original key (larger: fewer keys)"),
        "error": P.EnumProperty(
            name="Error", items=ERROR_ITEMS, default="ANGLE",
            description="What the bound is on: each rotation's angle, or how far the armature's bones move"),
        "distance": P.FloatProperty(
            name="Distance", default=0.0, min=0.0, soft_max=0.1, precision=4, subtype="DISTANCE", unit="LENGTH",
            description="How far, in scene units, any bone's tail or shell point may move from the original, in the armature's "
                        "object space, on every frame and original key; 0: 1 mm in real size (the unit scale "
                        "taken into account)"),
        "shell": P.FloatProperty(
            name="Shell", default=0.0, min=0.0, soft_max=1.0, precision=3, subtype="DISTANCE", unit="LENGTH",
            description="Distance, in scene units, from each bone's head of the three points along its axes measured "
                        "with its tail (a skinned vertex's typical distance); 0: 10 cm in real size"),
        "interpolation": P.EnumProperty(name="Interpolation", items=INTERPOLATION_ITEMS, default="BEZIER",
                                        description="The kind of keys written"),
        "synchronized": P.BoolProperty(
            name="Synchronized", default=False,
            description="Same key frames on every rotation channel of a target (glTF export, hand "
                        "editing); off: each channel keeps its own keys where that saves keys"),
        "new_action": P.BoolProperty(
            name="New Action", default=True,
            description="Write into a new action named after the original, which is kept (fake user) "
                        "and untouched; off: replace the rotation curves in place"),
    }


class QuatCurveReduceSettings(bpy.types.PropertyGroup):
    """scene.quatcurve_reduce: the panel's reduce settings and the last reduction's summary."""
    __annotations__ = dict(
        reduce_properties(),
        **opsutil.last_result_properties("Reduce", "Keys before and after, and the largest error, of the last "
                                                   "reduction"),
    )


def draw_settings(layout, settings, max_lines=6, width=40):
    """The panel's reduce box: settings, button, last result (wrapped at `width` characters)."""
    col = layout.column(align=True)
    col.row(align=True).prop(settings, "error", expand=True)
    if settings.error == "DISTANCE":
        col.prop(settings, "distance", text="Distance (0: 1 mm)" if settings.distance == 0 else "Distance")
        col.prop(settings, "shell", text="Shell (0: 10 cm)" if settings.shell == 0 else "Shell")
    else:
        col.prop(settings, "tolerance")
    col.prop(settings, "interpolation", text="")
    col.prop(settings, "synchronized")
    col.prop(settings, "new_action")
    layout.operator("quatcurve.reduce", text="Reduce Keys", icon="IPO_BEZIER")
    opsutil.draw_last_result(layout, settings, max_lines, width)


class QUATCURVE_OT_reduce(bpy.types.Operator):
    """Remove rotation keys of the selected objects or pose bones (motion capture, bakes) while the rotation stays within the Tolerance, in degrees, or (Error: Distance) every bone's tail and shell points stay within the Distance in the armature's space; into a new action by default"""
    bl_idname = "quatcurve.reduce"
    bl_label = "Reduce Rotation Keys"
    bl_options = {"REGISTER", "UNDO"}
    __annotations__ = reduce_properties()

    def execute(self, context):
        def settings(op):
            return reduce.ReduceSettings(tolerance=op.tolerance, interpolation=op.interpolation,
                                         synchronized=op.synchronized, new_action=op.new_action, error=op.error,
                                         distance=op.distance, shell=op.shell)
        return opsutil.run_task(self, context, "quatcurve_reduce", reduce_properties(), settings, reduce.reduce,
                                "reduce", report_prefix="Reduced ")


_classes = (QuatCurveReduceSettings, QUATCURVE_OT_reduce)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.quatcurve_reduce = bpy.props.PointerProperty(type=QuatCurveReduceSettings)


def unregister():
    del bpy.types.Scene.quatcurve_reduce
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
