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

    for _name in ("native", "fcurves", "bake", "props", "operators", "plot", "compare", "operators_compare", "reduce", "operators_reduce", "ui"):
        if _name in locals():
            importlib.reload(locals()[_name])

import bpy  # noqa: E402

from . import native, ui  # noqa: E402
from . import bake, fcurves, operators, props  # noqa: E402, F401
from . import compare, operators_compare, plot  # noqa: E402, F401
from . import operators_reduce, reduce  # noqa: E402, F401

_modules = (props, operators, operators_compare, operators_reduce, ui)


def register():
    for mod in _modules:
        mod.register()


def unregister():
    for mod in reversed(_modules):
        mod.unregister()
