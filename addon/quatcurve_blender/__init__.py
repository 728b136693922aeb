"""QuatCurve: orientation interpolation curves (slerp, squad, TCB, C2 splines) baked onto objects
and pose bones, and compared with Blender's own Euler and quaternion modes.

Blender up to 4.1 reads `bl_info`; 4.2+ reads blender_manifest.toml beside this file.
"""

bl_info = {
    "name": "QuatCurve",
    "author": "quatcurve developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "3D Viewport and Graph Editor > Sidebar > QuatCurve",
    "description": "Bake and compare orientation curves: slerp, squad, TCB, C2 rotation splines",
    "category": "Animation",
}

if "bpy" in locals():  # re-registration from Blender's "Reload Scripts"
    import importlib

    # Lowest layer first, so each module reloads against already-reloaded modules below it.
    for _name in ("native", "opsutil", "fcurves", "targets", "write", "plot", "reduce", "clean_arrays", "clean", "bake", "compare", "fit", "live",
                  "convert", "glb", "gltf", "bake_ops", "compare_ops", "reduce_ops", "clean_ops", "fit_ops", "convert_ops", "gltf_ops",
                  "trails", "ui"):
        if _name in locals():
            importlib.reload(locals()[_name])

import bpy  # noqa: E402

from . import native, fcurves, targets, write  # noqa: E402, F401  (reading and writing layers)
from . import bake, clean, compare, convert, fit, gltf, plot, reduce  # noqa: E402, F401   (tasks)
from . import live  # noqa: E402                                       (live fit: handlers)
from . import bake_ops, clean_ops, compare_ops, convert_ops, fit_ops, gltf_ops, reduce_ops  # noqa: E402  (operators and settings)
from . import trails, ui  # noqa: E402                                 (viewport drawing, panels)

_modules = (bake_ops, compare_ops, reduce_ops, clean_ops, fit_ops, convert_ops, gltf_ops, live, trails, ui)


def register():
    for mod in _modules:
        mod.register()


def unregister():
    for mod in reversed(_modules):
        mod.unregister()
