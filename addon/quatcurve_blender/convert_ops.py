"""The `quatcurve.convert` operator: the selected objects (Object mode) or pose bones (Pose mode) get a
new rotation mode and their rotation keys are converted so that Blender plays the same motion
(convert.py). In the 3D Viewport's Object > Animation and Pose menus ("Convert Rotation Mode, Keep
Motion"); a dialog asks for the settings."""

import bpy

from . import convert, native, targets
from .targets import TargetError

MODE_ITEMS = (
    ("QUATERNION", "Quaternion (WXYZ)", "No gimbal lock"),
    ("XYZ", "XYZ Euler", "XYZ rotation order"),
    ("XZY", "XZY Euler", "XZY rotation order"),
    ("YXZ", "YXZ Euler", "YXZ rotation order"),
    ("YZX", "YZX Euler", "YZX rotation order"),
    ("ZXY", "ZXY Euler", "ZXY rotation order"),
    ("ZYX", "ZYX Euler", "ZYX rotation order"),
    ("AXIS_ANGLE", "Axis Angle", "Axis Angle (W+XYZ): a rotation about an axis"),
)
ACTION_ITEMS = (
    ("ACTIVE", "Active", "The action each target plays"),
    ("ALL", "All", "Every action in the file that animates the target's rotation"),
)


def convert_properties():
    P = bpy.props
    return {
        "rotation_mode": P.EnumProperty(name="Rotation Mode", items=MODE_ITEMS, default="QUATERNION",
                                        description="The new rotation mode"),
        "tolerance": P.FloatProperty(
            name="Tolerance (°)", default=0.05, min=1e-4, soft_max=5.0, precision=3,
            description="Largest angle between Blender's playback after and before the conversion, in degrees: "
                        "at every instant where the old keys are all Bezier or all linear (proved), else at "
                        "every checked point"),
        "subframes": P.IntProperty(name="Subframes", default=4, min=1, max=64,
                                   description="Samples per frame the new keys are fitted to (where the conversion "
                                               "is not proved, the points where the tolerance is checked)"),
        "actions": P.EnumProperty(name="Actions", items=ACTION_ITEMS, default="ACTIVE",
                                  description="Which actions to convert"),
    }


def settings_from(props):
    return convert.ConvertSettings(rotation_mode=props.rotation_mode, tolerance=props.tolerance,
                                   subframes=props.subframes, actions=props.actions)


class QUATCURVE_OT_convert(bpy.types.Operator):
    """Change the rotation mode of the selected objects or pose bones, converting their rotation keys so \
that Blender plays the same motion (within the tolerance, between keys too)"""
    bl_idname = "quatcurve.convert"
    bl_label = "Convert Rotation Mode, Keep Motion"
    bl_options = {"REGISTER", "UNDO"}
    __annotations__ = convert_properties()

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        try:
            native.require()
            result = convert.convert(targets.gather_targets(context, verb="convert"), settings_from(self))
        except (TargetError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        context.scene.frame_set(context.scene.frame_current)  # show the pose in the new mode
        for line in result.lines():
            print("quatcurve.convert: " + line)
        self.report({"INFO"}, result.summary())
        return {"FINISHED"}


def draw_menu(self, context):
    self.layout.separator()
    self.layout.operator(QUATCURVE_OT_convert.bl_idname)


_menus = ("VIEW3D_MT_object_animation", "VIEW3D_MT_pose")


def register():
    bpy.utils.register_class(QUATCURVE_OT_convert)
    for name in _menus:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.append(draw_menu)


def unregister():
    for name in _menus:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.remove(draw_menu)
    bpy.utils.unregister_class(QUATCURVE_OT_convert)
