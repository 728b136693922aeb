"""The `quatcurve.export_gltf` operator (File > Export > glTF That Plays the Curve): the scene through
Blender's glTF exporter, rotation samplers replaced by few slerp keys within the tolerance of
each target's curve, or within a distance of its bones' virtual vertices (gltf.py)."""

import bpy
from bpy_extras.io_utils import ExportHelper

from . import fit, gltf, methods, native
from .targets import TargetError

METHOD_ITEMS = (
    ("AUTO", "Auto", "Fitted targets: their fit's method; others: what Blender plays"),
    ("BLENDER", "Blender's Playback", "What Blender plays, for every target"),
) + methods.enum_items(fit.METHODS)


ERROR_ITEMS = (
    ("ANGLE", "Angle", "Each rotation within the Tolerance (degrees) of its curve, at every instant"),
    ("DISTANCE", "Distance", "Per armature, every bone's tail and shell points within Distance of the curves' "
                             "pose on every frame and key (each object: its own shell points)"),
)


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
                                     description="Candidate key times per frame (the bound is proved between them)")
    error: bpy.props.EnumProperty(name="Error", items=ERROR_ITEMS, default="ANGLE",
                                  description="What the file's keys bound: each rotation's angle (Tolerance), or how "
                                              "far the armature's bones move (Distance)")
    distance: bpy.props.FloatProperty(
        name="Distance", default=0.0, min=0.0, soft_max=0.1, precision=4, subtype="DISTANCE", unit="LENGTH",
        description="How far, in scene units, any bone's tail or shell point in the file may move from the curves' "
                    "pose, in the armature's object space, on every frame and key; 0: 1 mm in real size")
    shell: bpy.props.FloatProperty(
        name="Shell", default=0.0, min=0.0, soft_max=1.0, precision=3, subtype="DISTANCE", unit="LENGTH",
        description="Distance, in scene units, from each bone's head of the three points along its axes measured "
                    "with its tail; 0: 10 cm in real size")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "method")
        layout.prop(self, "error")
        if self.error == "DISTANCE":
            layout.prop(self, "distance")
            layout.prop(self, "shell")
        else:
            layout.prop(self, "tolerance")
        layout.prop(self, "subframes")

    def execute(self, context):
        settings = gltf.ExportSettings(method=self.method, tolerance=self.tolerance, subframes=self.subframes,
                                       error=self.error, distance=self.distance, shell=self.shell)
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
