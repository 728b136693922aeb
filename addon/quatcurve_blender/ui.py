"""Sidebar panels "QuatCurve" in the 3D Viewport and the Graph Editor."""

import bpy

from . import compare_ops, native, reduce_ops


def draw_status(layout):
    """Shows why the native module is unavailable; returns True when it is available."""
    if native.available():
        return True
    box = layout.box()
    box.alert = True
    box.label(text="Native module unavailable", icon="ERROR")
    wrapped_labels(box, native.UNAVAILABLE_REASON, 48)
    return False


def wrapped_labels(layout, text, width):
    """`text` as labels of at most about `width` characters (Blender's labels do not wrap)."""
    line = ""
    for word in text.split():
        if len(line) + len(word) > width:
            layout.label(text=line)
            line = ""
        line = (line + " " + word).strip()
    if line:
        layout.label(text=line)


def draw_bake_settings(layout, settings):
    """The bake settings of scene.quatcurve (the Bake button uses them)."""
    col = layout.column(align=True)
    col.prop(settings, "method", text="")
    if settings.method == "TCB":
        col.prop(settings, "tension")
        col.prop(settings, "continuity")
        col.prop(settings, "bias")
    elif settings.method == "SLERP":
        col.prop(settings, "shortest_path")
    layout.prop(settings, "rotation_mode", text="Output")
    col = layout.column(align=True)
    col.prop(settings, "use_keyed_range")
    if not settings.use_keyed_range:
        row = col.row(align=True)
        row.prop(settings, "frame_start")
        row.prop(settings, "frame_end")
    col.prop(settings, "step")
    col.prop(settings, "tolerance")
    layout.prop(settings, "new_action")


def draw_last_result(layout, settings, max_lines=8):
    """Summary of the last bake: targets, keys written, seconds, and one line per target."""
    if not settings.last_summary:
        return
    box = layout.box()
    box.label(text="Last bake", icon="INFO")
    col = box.column(align=True)
    col.label(text="Targets: %d" % settings.last_targets)
    col.label(text="Keys written: {:,}".format(settings.last_keys))
    col.label(text="Seconds: %.2f" % settings.last_seconds)
    lines = settings.last_lines.splitlines()
    col = box.column(align=True)
    col.scale_y = 0.8
    for line in lines[:max_lines]:
        col.label(text=line)
    if len(lines) > max_lines:
        col.label(text="… and %d more" % (len(lines) - max_lines))


def draw_compare_settings(layout, settings):
    """The compare settings of scene.quatcurve_compare (the Compare button uses them)."""
    col = layout.column(align=True)
    col.prop(settings, "subframes")
    col.prop(settings, "all_euler_orders")
    col.prop(settings, "key_interpolation")
    layout.prop(settings, "report_path", text="")


def _table_row(layout, cells):
    """source | max deviation | speed ratio | path length; the source column is wider."""
    split = layout.split(factor=0.46)
    split.label(text=cells[0])
    row = split.row()
    for cell in cells[1:]:
        row.label(text=cell)


def draw_compare_table(layout, settings, max_targets=4):
    """The last comparison: per target a table (source, max deviation, speed ratio, path length) and
    the recommendation, wrapped by hand (labels do not wrap)."""
    table = compare_ops.last_table(settings)
    if not table:
        return
    box = layout.box()
    box.label(text="Last compare: " + settings.last_summary, icon="INFO")
    for target in table[:max_targets]:
        col = box.column(align=True)
        col.label(text=target["name"], icon="OBJECT_DATA")
        _table_row(col, ("Source", "Max dev", "Ratio", "Length"))
        for row in target["rows"]:
            _table_row(col, row)
        wrapped_labels(col, target["recommendation"], 52)
        if target.get("image"):
            col.label(text="Plot: image '%s'" % target["image"], icon="IMAGE_DATA")
    if len(table) > max_targets:
        box.label(text="… and %d more (see the report)" % (len(table) - max_targets))


class _SidebarPanel:
    bl_label = "QuatCurve"
    bl_region_type = "UI"
    bl_category = "QuatCurve"

    def draw(self, context):
        layout = self.layout
        if draw_status(layout):
            layout.label(text="quatcurve %s" % native.module.__version__)
        settings = getattr(context.scene, "quatcurve", None)
        if settings is None:
            return
        draw_bake_settings(layout, settings)
        row = layout.row(align=True)
        row.scale_y = 1.4
        row.operator("quatcurve.bake", text="Bake", icon="ACTION")
        if hasattr(bpy.types, "QUATCURVE_OT_compare"):
            row.operator("quatcurve.compare", text="Compare", icon="GRAPH")
        draw_last_result(layout, settings)
        compare_settings = getattr(context.scene, "quatcurve_compare", None)
        if compare_settings is not None:
            box = layout.box()
            box.label(text="Compare", icon="GRAPH")
            draw_compare_settings(box, compare_settings)
            draw_compare_table(layout, compare_settings)
        reduce_settings = getattr(context.scene, "quatcurve_reduce", None)
        if reduce_settings is not None:
            box = layout.box()
            box.label(text="Reduce Keys", icon="IPO_BEZIER")
            reduce_ops.draw_settings(box, reduce_settings)


class QUATCURVE_PT_view3d(_SidebarPanel, bpy.types.Panel):
    bl_idname = "QUATCURVE_PT_view3d"
    bl_space_type = "VIEW_3D"


class QUATCURVE_PT_graph(_SidebarPanel, bpy.types.Panel):
    bl_idname = "QUATCURVE_PT_graph"
    bl_space_type = "GRAPH_EDITOR"


_classes = (QUATCURVE_PT_view3d, QUATCURVE_PT_graph)
# Menus that list the bake (so F3 menu search finds it): Object/Pose > Animation, Graph Editor > Key.
_MENUS = ("VIEW3D_MT_object_animation", "GRAPH_MT_key")


def draw_bake_menu_item(self, context):
    self.layout.separator()
    self.layout.operator("quatcurve.bake", icon="ACTION")
    self.layout.operator("quatcurve.compare", icon="GRAPH")
    self.layout.operator("quatcurve.reduce", icon="IPO_BEZIER")


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    for name in _MENUS:
        getattr(bpy.types, name).append(draw_bake_menu_item)


def unregister():
    for name in _MENUS:
        getattr(bpy.types, name).remove(draw_bake_menu_item)
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
