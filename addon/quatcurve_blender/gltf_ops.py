"""The `quatcurve.export_gltf` operator (File > Export > glTF That Plays the Curve): the scene through
Blender's glTF exporter, rotation samplers replaced by few slerp keys within the tolerance of
each target's curve (gltf.py)."""

import bpy
from bpy_extras.io_utils import ExportHelper

from . import fit, gltf, methods, native
from .targets import TargetError

METHOD_ITEMS = (
    ("AUTO", "Auto", "Fitted targets: their fit's method; others: what Blender plays"),
    ("BLENDER", "Blender's Playback", "What Blender plays, for every target"),
) + methods.enum_items(fit.METHODS)


class QUATCURVE_OT_export_gltf(bpy.types.Operator, ExportHelper):
    """Export the scene to binary glTF with few rotation keys that play each target's curve"""
    bl_idname = "quatcurve.export_gltf"
    bl_label = "Export glTF (QuatCurve)"
    bl_options = {"REGISTER"}
    filename_ext = ".glb"
    filter_glob: bpy.props.StringProperty(default="*.glb", options={"HIDDEN"})
    method: bpy.props.EnumProperty(name="Curve", items=METHOD_ITEMS, default="AUTO",
                                   description="The curve each rotation sampler plays")
    tolerance: bpy.props.FloatProperty(
        name="Tolerance (°)", default=0.1, min=0.0, soft_min=1e-3, soft_max=5.0, precision=3,
        description="Largest angle between the file's rotation (slerp between keys) and the curve, at every "
                    "frame and subframe")
    subframes: bpy.props.IntProperty(name="Subframes", default=20, min=1, max=100,
                                     description="Points per frame where the tolerance is checked")

    def execute(self, context):
        settings = gltf.ExportSettings(method=self.method, tolerance=self.tolerance, subframes=self.subframes)
        try:
            native.require()
            result = gltf.export(context.scene, self.filepath, settings)
        except (TargetError, RuntimeError, OSError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, result.summary())
        return {"FINISHED"}


def menu_export(self, context):
    self.layout.operator(QUATCURVE_OT_export_gltf.bl_idname, text="glTF That Plays the Curve (.glb)")


def register():
    bpy.utils.register_class(QUATCURVE_OT_export_gltf)
    bpy.types.TOPBAR_MT_file_export.append(menu_export)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(menu_export)
    bpy.utils.unregister_class(QUATCURVE_OT_export_gltf)
