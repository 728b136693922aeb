"""Sidebar panels "QuatCurve" in the 3D Viewport and the Graph Editor."""

import bpy

from . import native


def draw_status(layout):
    """Shows why the native module is unavailable; returns True when it is available."""
    if native.available():
        return True
    box = layout.box()
    box.alert = True
    box.label(text="Native module unavailable", icon="ERROR")
    # Long reasons are wrapped by hand: labels do not wrap.
    words, line = native.UNAVAILABLE_REASON.split(), ""
    for word in words:
        if len(line) + len(word) > 48:
            box.label(text=line)
            line = ""
        line = (line + " " + word).strip()
    if line:
        box.label(text=line)
    return False


class _SidebarPanel:
    bl_label = "QuatCurve"
    bl_region_type = "UI"
    bl_category = "QuatCurve"

    def draw(self, context):
        if draw_status(self.layout):
            self.layout.label(text="quatcurve %s" % native.module.__version__)


class QUATCURVE_PT_view3d(_SidebarPanel, bpy.types.Panel):
    bl_idname = "QUATCURVE_PT_view3d"
    bl_space_type = "VIEW_3D"


class QUATCURVE_PT_graph(_SidebarPanel, bpy.types.Panel):
    bl_idname = "QUATCURVE_PT_graph"
    bl_space_type = "GRAPH_EDITOR"


_classes = (QUATCURVE_PT_view3d, QUATCURVE_PT_graph)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
