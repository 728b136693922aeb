"""Sidebar panels "QuatCurve" in the 3D Viewport and the Graph Editor."""

import bpy

from . import compare, compare_ops, fit_ops, native, opsutil, reduce_ops, trails


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
    opsutil.draw_method_options(col, settings)
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


def draw_compare_table(layout, settings, max_targets=4, active=None):
    """The last comparison: per target a table (source, max deviation, speed ratio, path length) and
    the recommendation, wrapped by hand (labels do not wrap); the active target's first."""
    table = compare_ops.last_table(settings)
    if not table:
        return
    table = sorted(table, key=lambda t: t["name"] != active)  # stable: the active target first
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


def draw_compare_plot(layout, context, compare_settings, preview_scale=9.0):
    """The active target's comparison plot: a preview of its image (Blender renders image previews
    in the background; until then a placeholder) and the button that opens it in an Image Editor."""
    target = trails.active_target(context)
    name = target.name if target is not None else None
    # The plot image compare made for this target (compare_ops keeps only the last run's table, but
    # every compared target's image stays, named by compare.image_name).
    entry = next((t for t in compare_ops.last_table(compare_settings) if t["name"] == name), None)
    image_name = entry["image"] if entry and entry.get("image") else compare.image_name(name) if name else ""
    image = bpy.data.images.get(image_name) if image_name else None
    if image is None:
        if name:
            layout.label(text="No plot of %s yet: Compare it" % name, icon="IMAGE_DATA")
        return
    box = layout.box()
    box.label(text=name, icon="IMAGE_DATA")
    preview = image.preview_ensure()
    if preview is not None and preview.icon_id:
        box.template_icon(icon_value=preview.icon_id, scale=preview_scale)
    op = box.operator("quatcurve.show_compare_plot", text="Show in Image Editor", icon="WINDOW")
    op.image_name = image.name


class QUATCURVE_OT_show_compare_plot(bpy.types.Operator):
    """Open a comparison plot in an Image Editor (the active target's by default)"""
    bl_idname = "quatcurve.show_compare_plot"
    bl_label = "Show Comparison Plot in Image Editor"
    bl_options = {"REGISTER"}
    image_name: bpy.props.StringProperty(name="Image", default="",
                                         description="The plot image (empty: the active target's)")

    def execute(self, context):
        name = self.image_name
        if not name:
            target = trails.active_target(context)
            name = compare.image_name(target.name) if target is not None else ""
        image = bpy.data.images.get(name)
        if image is None:
            self.report({"WARNING"}, "No comparison plot %s: run Compare first" % (repr(name) if name else "(no active target)"))
            return {"CANCELLED"}
        window = context.window
        if bpy.app.background or window is None:
            self.report({"WARNING"}, "No window to show '%s' in (background mode); it is in bpy.data.images" % name)
            return {"CANCELLED"}
        area = show_in_image_editor(context, window, image)
        if area is None:
            self.report({"WARNING"}, "No area could be turned into an Image Editor for '%s'" % name)
            return {"CANCELLED"}
        self.report({"INFO"}, "Showing '%s'" % name)
        return {"FINISHED"}


def show_in_image_editor(context, window, image):
    """The window's Image Editor showing `image`: an existing one, else the operator's area (or the
    largest one) split in two, its new half made an Image Editor. Returns the area (None if none)."""
    screen = window.screen
    area = next((a for a in screen.areas if a.type == "IMAGE_EDITOR"), None)
    if area is None:
        source = context.area if context.area is not None and context.area.type != "EMPTY" else \
            max(screen.areas, key=lambda a: a.width * a.height)
        before = set(a.as_pointer() for a in screen.areas)
        with context.temp_override(window=window, screen=screen, area=source):
            bpy.ops.screen.area_split(direction="VERTICAL", factor=0.5)
        area = next((a for a in screen.areas if a.as_pointer() not in before), None)
        if area is None:
            return None
        area.type = "IMAGE_EDITOR"
    space = area.spaces.active
    space.image = image
    region = next((r for r in area.regions if r.type == "WINDOW"), None)
    try:  # the whole plot in view; a failure here leaves it shown as it is
        with context.temp_override(window=window, screen=screen, area=area, region=region):
            bpy.ops.image.view_all(fit_view=True)
    except RuntimeError:
        pass
    area.tag_redraw()
    return area


# ---- panels ---------------------------------------------------------------------------------------
# A parent panel per editor and one small class per task below it; a task's panel is the same class
# in every editor (see _task_panels). A new task adds one class to TASK_PANELS.

class _SidebarPanel:
    bl_label = "QuatCurve"
    bl_region_type = "UI"
    bl_category = "QuatCurve"

    def draw(self, context):
        layout = self.layout
        if draw_status(layout):
            layout.label(text="quatcurve %s" % native.module.__version__)
        target = trails.active_target(context)
        layout.label(text=target.name if target is not None else "No active object",
                     icon="BONE_DATA" if target is not None and target.bone else "OBJECT_DATA")


class QUATCURVE_PT_view3d(_SidebarPanel, bpy.types.Panel):
    bl_idname = "QUATCURVE_PT_view3d"
    bl_space_type = "VIEW_3D"


class QUATCURVE_PT_graph(_SidebarPanel, bpy.types.Panel):
    bl_idname = "QUATCURVE_PT_graph"
    bl_space_type = "GRAPH_EDITOR"


def big_button(layout, operator, text, icon):
    """A task's main button, taller than the settings above it."""
    row = layout.row()
    row.scale_y = 1.4
    row.operator(operator, text=text, icon=icon)


class _TaskPanel:
    """A task's subpanel, shown when its scene settings (scene.<settings>) are registered."""
    settings = ""

    @classmethod
    def poll(cls, context):
        return getattr(context.scene, cls.settings, None) is not None


class BakePanel(_TaskPanel):
    """Bake: settings, button, last bake."""
    task = "bake"
    settings = "quatcurve"
    bl_label = "Bake"
    bl_options = set()

    def draw(self, context):
        settings = context.scene.quatcurve
        layout = self.layout
        draw_bake_settings(layout, settings)
        big_button(layout, "quatcurve.bake", "Bake", "ACTION")
        draw_last_result(layout, settings)


class ReducePanel(_TaskPanel):
    """Reduce Keys: settings, button, last reduction."""
    task = "reduce"
    settings = "quatcurve_reduce"
    bl_label = "Reduce Keys"
    bl_options = {"DEFAULT_CLOSED"}


    def draw(self, context):
        reduce_ops.draw_settings(self.layout, context.scene.quatcurve_reduce)


class FitPanel(_TaskPanel):
    """Fit: the animator's own keys play a method — settings, Fit / Unmark, Live, ease, last fit."""
    task = "fit"
    settings = "quatcurve_fit"
    bl_label = "Fit Rotation Keys"
    bl_options = {"DEFAULT_CLOSED"}


    def draw(self, context):
        fit_ops.draw_settings(self.layout, context.scene.quatcurve_fit, context)


class ComparePanel(_TaskPanel):
    """Compare: settings, button, the active target's plot, the last table."""
    task = "compare"
    settings = "quatcurve_compare"
    bl_label = "Compare"
    bl_options = set()

    def draw(self, context):
        settings = context.scene.quatcurve_compare
        layout = self.layout
        draw_compare_settings(layout, settings)
        big_button(layout, "quatcurve.compare", "Compare", "GRAPH")
        draw_compare_plot(layout, context, settings)
        target = trails.active_target(context)
        draw_compare_table(layout, settings, active=target.name if target is not None else None)


class TrailsPanel(_TaskPanel):
    """Orientation Trails (3D Viewport): the toggle in the header, settings, what is drawn."""
    task = "trails"
    settings = "quatcurve_trails"
    bl_label = "Orientation Trails"
    bl_options = set()
    spaces = ("VIEW_3D",)


    def draw_header(self, context):
        self.layout.prop(context.scene.quatcurve_trails, "show", text="")

    def draw(self, context):
        settings = context.scene.quatcurve_trails
        layout = self.layout
        layout.active = settings.show
        col = layout.column(align=True)
        col.prop(settings, "show_method")
        sub = col.row()
        sub.active = settings.show_method
        sub.prop(settings, "method", text="")
        layout.row().prop(settings, "axis", expand=True)
        col = layout.column(align=True)
        col.prop(settings, "step")
        col.prop(settings, "size")
        col.prop(settings, "use_scene_range")
        draw_trail_status(layout, context, settings)


def draw_trail_status(layout, context, settings):
    """What the trails show for the active target (or why nothing), and the colour legend."""
    if not settings.show:
        return
    target = trails.active_target(context)
    if target is None or not native.available():
        return
    method, frame_range = trails.settings_key(settings, context.scene)
    trail = trails.CACHE.get(target, method, frame_range)
    col = layout.column(align=True)
    col.scale_y = 0.8
    if trail.error:
        wrapped_labels(col, trail.error, 44)
        return
    col.label(text="%s: frames %g..%g" % (target.name, trail.frames[0], trail.frames[-1]))
    col.label(text="Magenta: Blender's evaluation")
    if method:
        col.label(text="Cyan: %s" % method)


TASK_PANELS = (FitPanel, BakePanel, ReducePanel, ComparePanel, TrailsPanel)


def _task_panels():
    """One Panel class per task and editor, child of that editor's QuatCurve panel."""
    out = []
    for parent in (QUATCURVE_PT_view3d, QUATCURVE_PT_graph):
        for task in TASK_PANELS:
            if parent.bl_space_type not in getattr(task, "spaces", (parent.bl_space_type,)):
                continue
            idname = "%s_%s" % (parent.bl_idname, task.task)
            out.append(type(idname, (task, bpy.types.Panel), {
                "bl_idname": idname, "bl_space_type": parent.bl_space_type, "bl_region_type": "UI",
                "bl_category": parent.bl_category, "bl_parent_id": parent.bl_idname,
                "bl_options": set(task.bl_options)}))
    return tuple(out)


_classes = (QUATCURVE_OT_show_compare_plot, QUATCURVE_PT_view3d, QUATCURVE_PT_graph) + _task_panels()
# Menus that list the bake (so F3 menu search finds it): Object/Pose > Animation, Graph Editor > Key.
_MENUS = ("VIEW3D_MT_object_animation", "GRAPH_MT_key")


def draw_bake_menu_item(self, context):
    self.layout.separator()
    self.layout.operator("quatcurve.fit", icon="IPO_EASE_IN_OUT")
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
