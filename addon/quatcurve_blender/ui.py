"""Sidebar panels "QuatCurve" in the 3D Viewport and the Graph Editor."""

import bpy

from . import clean_ops, compare, compare_ops, fit_ops, methods, native, opsutil, reduce_ops, trails


def draw_status(layout):
    """Shows why the native module is unavailable; returns True when it is available."""
    if native.available():
        return True
    box = layout.box()
    box.alert = True
    box.label(text="Native module unavailable", icon="ERROR")
    wrapped_labels(box, native.UNAVAILABLE_REASON, 48)
    return False


wrapped_labels = opsutil.wrapped_labels


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
    col = layout.column(align=True)
    col.row(align=True).prop(settings, "error", expand=True)
    if settings.error == "DISTANCE":
        col.prop(settings, "distance", text="Distance (0: 1 mm)" if settings.distance == 0 else "Distance")
        col.prop(settings, "shell", text="Shell (0: 10 cm)" if settings.shell == 0 else "Shell")
    else:
        col.prop(settings, "tolerance")
    layout.prop(settings, "new_action")


def draw_last_result(layout, settings, max_lines=8, width=40):
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
        wrapped_labels(col, line, width)
    if len(lines) > max_lines:
        col.label(text="… and %d more" % (len(lines) - max_lines))


def draw_compare_settings(layout, settings):
    """The compare settings of scene.quatcurve_compare (the Compare button uses them)."""
    col = layout.column(align=True)
    col.prop(settings, "subframes")
    col.prop(settings, "all_euler_orders")
    col = layout.column(align=True)
    col.label(text="Blender's keys:")
    col.prop(settings, "key_interpolation", text="")
    col = layout.column(align=True)
    col.label(text="Report file (optional):")
    col.prop(settings, "report_path", text="")


def label_width(context, default=40):
    """How many characters of label text fit across the region drawing now, inside a box (labels do
    not wrap): about 7 pixels a character at UI scale 1, 50 pixels of margins."""
    region = getattr(context, "region", None) if context is not None else None
    if region is None or region.width <= 0:
        return default
    scale = context.preferences.view.ui_scale if context.preferences is not None else 1.0
    return max(16, int((region.width - 50 * scale) / (7.2 * scale)))


def compared_entry(context, settings):
    """(entry, is the active target's, how many targets) of the last comparison: the active target's
    entry, else its first one (None without a result)."""
    table = compare_ops.last_table(settings)
    target = trails.active_target(context) if context is not None else None
    name = target.name if target is not None else None
    entry = next((t for t in table if t["name"] == name), None)
    return (entry, True, len(table)) if entry is not None else (table[0] if table else None, False, len(table))


def draw_compare_result(layout, context, settings):
    """The panel's view of the last comparison: the recommendation as one sentence (the active
    target's; when the active target was not compared, the last compared one's, said so), the
    buttons that open the table (a popup wide enough for every column) and the plot."""
    entry, active, count = compared_entry(context, settings)
    if entry is None:
        return
    box = layout.box()
    col = box.column(align=True)
    width = label_width(context)
    if active:
        col.label(text=entry["name"], icon=target_icon(entry["name"]))
    else:
        wrapped_labels(col, "Last compared: %s" % entry["name"], width)
    wrapped_labels(col, entry.get("sentence") or entry["recommendation"], width)
    if count > 1:
        col.label(text="%d more in the Table" % (count - 1))
    row = box.row(align=True)
    row.operator("quatcurve.compare_table", text="Table", icon="SPREADSHEET" if _has_icon("SPREADSHEET") else "TEXT")
    op = row.operator("quatcurve.show_compare_plot", text="Plot", icon="IMAGE_DATA")
    op.image_name = entry.get("image") or ""


def target_icon(name):
    """A pose bone's comparison is named 'Armature/Bone'."""
    return "BONE_DATA" if "/" in name else "OBJECT_DATA"


def _has_icon(name):
    return name in bpy.types.UILayout.bl_rna.functions["label"].parameters["icon"].enum_items.keys()


# The comparison table's columns: (two header lines, the source row's key, format, width in UI units).
# Jerk: compare measures the largest jump of angular acceleration at a key (an impulse of jerk there).
COMPARE_COLUMNS = (
    (("Source", ""), "label", "%s", 8.0),
    (("Max deviation", "from Slerp (°)"), "max_deviation_deg", "%.2f°", 6.5),
    (("Speed ratio", "fastest / slowest"), "speed_ratio", None, 6.5),
    (("Path length", "(°)"), "path_length_deg", "%.1f°", 6.5),
    (("Speed jump", "at keys (°/frame)"), "velocity_jump_deg", "%.3f", 6.5),
    (("Jerk at keys", "(accel. jump, °/frame²)"), "acceleration_jump_deg", "%.4f", 8.5),
)
POPUP_TARGETS = 3  # targets shown in the popup (a popup does not scroll); the rest are in the report


def cell_text(row, key, fmt):
    value = row.get(key)
    if fmt is None:  # the speed ratio: a stop inside a segment reads "stops", as in the report
        return "stops" if value is None else compare._ratio_text(value)
    if value is None:
        return "∞" if key != "label" else "?"
    return fmt % value


def popup_width(context):
    """The table popup's width in pixels: every column at its width, and the margins."""
    units = sum(c[3] for c in COMPARE_COLUMNS) + 2.0
    scale = context.preferences.view.ui_scale if context is not None and context.preferences is not None else 1.0
    return int(units * 20 * scale)


def draw_compare_table(layout, settings, active=None, max_targets=POPUP_TARGETS, width=150):
    """The last comparison, the active target's first: per target a table (one column per measure,
    headers with units, the recommended method ticked), the recommendation's sentence and its
    reasons (wrapped to `width` characters), the path rule's breaks and a button for its plot."""
    table = compare_ops.last_table(settings)
    if not table:
        layout.label(text="No comparison yet: select objects or bones and press Compare", icon="INFO")
        return
    table = sorted(table, key=lambda t: t["name"] != active)  # stable: the active target first
    for target in table[:max_targets]:
        box = layout.box()
        head = box.row()
        frames = target.get("key_frames") or []
        head.label(text="%s   %s, %d keys, frames %g to %g" % (
            target["name"], target.get("rotation_mode", ""), len(frames), frames[0], frames[-1])
            if frames else target["name"], icon=target_icon(target["name"]))
        if target.get("image"):
            sub = head.row()
            sub.alignment = "RIGHT"
            op = sub.operator("quatcurve.show_compare_plot", text="Show Plot", icon="IMAGE_DATA")
            op.image_name = target["image"]
        row = box.row(align=True)
        for header, key, fmt, units in COMPARE_COLUMNS:
            col = row.column(align=True)
            col.ui_units_x = units
            if key != "label":
                col.alignment = "RIGHT"
            col.label(text=header[0])
            col.label(text=header[1])
            for source in target.get("sources") or rows_as_sources(target):
                if key == "label":
                    col.label(text=source["label"],
                              icon="CHECKMARK" if source["source"] == target["method"] else "BLANK1")
                else:
                    col.label(text=cell_text(source, key, fmt))
        col = box.column(align=True)
        if target.get("sentence"):
            col.label(text=target["sentence"], icon="INFO")
        sub = col.column(align=True)
        sub.scale_y = 0.8
        wrapped_labels(sub, target["recommendation"], width)
        for line in target.get("path_rule", []):
            wrapped_labels(sub, "Path rule: " + line, width)
    if len(table) > max_targets:
        layout.label(text="… and %d more targets: set a Report file to see every one" % (len(table) - max_targets))


def rows_as_sources(target):
    """The source rows of a table stored without figures (the display strings of `rows`)."""
    return [{"source": r[0], "label": compare_ops.source_label(r[0])} for r in target.get("rows", [])]


class QUATCURVE_OT_compare_table(bpy.types.Operator):
    """Show the last comparison as a table: for each source its largest deviation from Slerp (°), how much its speed varies, its path length (°), and the jumps of speed (°/frame) and acceleration (°/frame²) at the keys"""
    bl_idname = "quatcurve.compare_table"
    bl_label = "Comparison Table"
    bl_options = {"REGISTER"}

    def _active(self, context):
        target = trails.active_target(context)
        return target.name if target is not None else None

    def invoke(self, context, event):
        settings = getattr(context.scene, "quatcurve_compare", None)
        if settings is None or not compare_ops.last_table(settings):
            self.report({"WARNING"}, "No comparison yet: select objects or bones and press Compare")
            return {"CANCELLED"}
        return context.window_manager.invoke_popup(self, width=popup_width(context))

    def draw(self, context):
        draw_compare_table(self.layout, context.scene.quatcurve_compare, active=self._active(context),
                           width=int(popup_width(context) / 7))

    def execute(self, context):
        """From a script or the F3 search without a window: the table goes to the Info log."""
        settings = getattr(context.scene, "quatcurve_compare", None)
        table = compare_ops.last_table(settings) if settings is not None else []
        if not table:
            self.report({"WARNING"}, "No comparison yet: select objects or bones and press Compare")
            return {"CANCELLED"}
        for target in table:
            for source in target.get("sources") or rows_as_sources(target):
                figures = ["%s %s" % (" ".join(h).strip(), cell_text(source, key, fmt))
                           for h, key, fmt, _ in COMPARE_COLUMNS[1:] if key in source]
                self.report({"INFO"}, "%s, %s: %s" % (target["name"], source["label"], "; ".join(figures)))
            self.report({"INFO"}, "%s: %s" % (target["name"], target.get("sentence") or target["recommendation"]))
        return {"FINISHED"}


class QUATCURVE_OT_show_compare_plot(bpy.types.Operator):
    """Open the comparison plot (speed in °/frame and deviation from Slerp in ° over the frames) in an Image Editor, splitting this area when the window has none"""
    bl_idname = "quatcurve.show_compare_plot"
    bl_label = "Show Comparison Plot in Image Editor"
    bl_options = {"REGISTER"}
    image_name: bpy.props.StringProperty(
        name="Image", default="", description="Name of the plot image to show (empty: the active object's or bone's)")

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
# A parent panel per editor (the active target's name) and one small class per task below it, in
# TASK_PANELS order: Fit first and open, then Bake, Reduce Keys, Compare and Orientation Trails,
# closed. A task's panel is the same class in every editor (see _task_panels).
#
# Where another tool adds itself (docs/ui.md, "Adding a tool"):
# - a row inside the Fit panel (a tool on the fitted keys): a function draw(layout, context) in
#   FIT_ROWS, drawn below the ease and turns rows;
# - a panel of its own (a task with settings, e.g. rotation mode conversion, glTF export): a
#   _TaskPanel subclass in TASK_PANELS, closed by default (bl_options {"DEFAULT_CLOSED"});
# - the F3 search and the Key / Animation menus: a line in draw_bake_menu_item.


class _SidebarPanel:
    bl_label = "QuatCurve"
    bl_region_type = "UI"
    bl_category = "QuatCurve"

    def draw(self, context):
        layout = self.layout
        draw_status(layout)
        target = trails.active_target(context)
        layout.label(text=target.name if target is not None else "Select an object or pose bone",
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
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return getattr(context.scene, cls.settings, None) is not None


# Rows other tools add to the Fit panel, below the ease and turns rows: functions draw(layout, context).
FIT_ROWS = ()


class FitPanel(_TaskPanel):
    """Fit (open): the method and Live on one line, tolerance, Fit / Unmark, ease, FIT_ROWS, the
    active target's fit and the last fit."""
    task = "fit"
    settings = "quatcurve_fit"
    bl_label = "Fit Rotation Keys"
    bl_options = set()

    def draw(self, context):
        fit_ops.draw_settings(self.layout, context.scene.quatcurve_fit, context, extra_rows=FIT_ROWS,
                              width=label_width(context))


class BakePanel(_TaskPanel):
    """Bake: settings, button, last bake."""
    task = "bake"
    settings = "quatcurve"
    bl_label = "Bake"

    def draw(self, context):
        settings = context.scene.quatcurve
        layout = self.layout
        draw_bake_settings(layout, settings)
        big_button(layout, "quatcurve.bake", "Bake", "ACTION")
        draw_last_result(layout, settings, width=label_width(context))


class ReducePanel(_TaskPanel):
    """Reduce Keys: settings, button, last reduction."""
    task = "reduce"
    settings = "quatcurve_reduce"
    bl_label = "Reduce Keys"

    def draw(self, context):
        reduce_ops.draw_settings(self.layout, context.scene.quatcurve_reduce, width=label_width(context))


class CleanPanel(_TaskPanel):
    """Clean Capture: settings, button, last clean."""
    task = "clean"
    settings = "quatcurve_clean"
    bl_label = "Clean Capture"

    def draw(self, context):
        clean_ops.draw_settings(self.layout, context.scene.quatcurve_clean, width=label_width(context))


class ComparePanel(_TaskPanel):
    """Compare: settings, button, the recommendation in one sentence, Table (popup) and Plot buttons."""
    task = "compare"
    settings = "quatcurve_compare"
    bl_label = "Compare"

    def draw(self, context):
        settings = context.scene.quatcurve_compare
        layout = self.layout
        draw_compare_settings(layout, settings)
        big_button(layout, "quatcurve.compare", "Compare", "GRAPH")
        draw_compare_result(layout, context, settings)


class TrailsPanel(_TaskPanel):
    """Orientation Trails (3D Viewport): the toggle in the header, settings, what is drawn."""
    task = "trails"
    settings = "quatcurve_trails"
    bl_label = "Orientation Trails"
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
        col.label(text="Cyan: %s" % methods.label(method))


# The task panels in the order they are drawn (a new task: one class here).
TASK_PANELS = (FitPanel, BakePanel, ReducePanel, CleanPanel, ComparePanel, TrailsPanel)


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


_classes = (QUATCURVE_OT_show_compare_plot, QUATCURVE_OT_compare_table, QUATCURVE_PT_view3d, QUATCURVE_PT_graph) + _task_panels()
# Menus that list the bake (so F3 menu search finds it): Object/Pose > Animation, Graph Editor > Key.
_MENUS = ("VIEW3D_MT_object_animation", "GRAPH_MT_key")


def draw_bake_menu_item(self, context):
    """The add-on's operators in the menus above (all of them, not only the bake)."""
    self.layout.separator()
    self.layout.operator("quatcurve.fit", icon="IPO_EASE_IN_OUT")
    self.layout.operator("quatcurve.bake", icon="ACTION")
    self.layout.operator("quatcurve.compare", icon="GRAPH")
    self.layout.operator("quatcurve.reduce", icon="IPO_BEZIER")
    self.layout.operator("quatcurve.clean", icon="MOD_SMOOTH")


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
