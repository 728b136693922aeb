"""Shared by the operator and settings modules (bake_ops, reduce_ops, compare_ops, fit_ops): the
panel's settings for the properties a caller did not set, and the method-specific settings drawn
in a panel, and the body of a task operator."""

from . import methods, native, targets


def take_scene_settings(operator, scene_settings, names, skip=()):
    """Every property in `names` (but `skip`) that the caller did not set takes the scene
    settings' value (the panel's), so the operator run from a script and from the panel agree."""
    if scene_settings is None:
        return
    for name in names:
        if name not in skip and not operator.properties.is_property_set(name):
            setattr(operator, name, getattr(scene_settings, name))


def draw_method_options(col, settings):
    """The options of settings.method that the native module lists for it (methods.option_names):
    TCB's tension, continuity, bias; SLERP's shortest path; the No Overshoot (clamped) option of the
    tangent methods."""
    methods.draw_options(col, settings)


def wrapped_labels(layout, text, width):
    """`text` as labels of at most about `width` characters (Blender's labels do not wrap)."""
    line = ""
    for word in text.split():
        if line and len(line) + 1 + len(word) > width:
            layout.label(text=line)
            line = ""
        line = (line + " " + word).strip()
    if line:
        layout.label(text=line)


def last_result_properties(task, what):
    """The panel's record of a task's last result, as property definitions: last_summary (`what`)
    and last_lines (one line per target)."""
    import bpy
    return dict(last_summary=bpy.props.StringProperty(name="Last %s" % task, default="", description=what),
                last_lines=bpy.props.StringProperty(name="Last %s Details" % task, default="",
                                                    description="One line per target, newline-separated"))


def draw_last_result(layout, settings, max_lines, width):
    """The last result's summary and its first `max_lines` target lines, wrapped at `width` characters."""
    if not settings.last_summary:
        return
    col = layout.column(align=True)
    col.scale_y = 0.8
    for line in [settings.last_summary] + settings.last_lines.splitlines()[:max_lines]:
        wrapped_labels(col, line, width)


def run_task(operator, context, scene_attr, names, make_settings, task, verb, report_prefix=""):
    """The body of a task operator (fit, reduce): the panel's settings for unset properties, the task
    on the selection, errors reported (CANCELLED, nothing changed), the summary and one line per
    target stored for the panel."""
    scene_settings = getattr(context.scene, scene_attr, None)
    take_scene_settings(operator, scene_settings, names)
    try:
        native.require()
        result = task(targets.gather_targets(context, verb=verb), make_settings(operator))
    except (targets.TargetError, RuntimeError) as error:
        operator.report({"ERROR"}, str(error))
        return {"CANCELLED"}
    if scene_settings is not None:
        scene_settings.last_summary = result.summary()
        scene_settings.last_lines = "\n".join(result.lines())
    operator.report({"INFO"}, report_prefix + result.summary())
    return {"FINISHED"}
