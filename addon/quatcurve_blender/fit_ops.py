"""The `quatcurve.fit`, `quatcurve.unfit`, `quatcurve.set_ease` and `quatcurve.set_turns` operators, the
fit settings and last result (`scene.quatcurve_fit`), and the records fit keeps on actions
(`Action.quatcurve_fits`, `Action.quatcurve_eases`, `Action.quatcurve_turns`).

Fit shapes the selected objects' (Object mode) or pose bones' (Pose mode) own rotation keys so that
Blender plays the chosen method (fit.py). Properties not given by the caller come from the panel's
settings, as for bake and reduce.
"""

import bpy

from . import fcurves, fit, live, methods, native, opsutil, targets
from .targets import TargetError

METHOD_ITEMS = methods.enum_items(methods.CURVE_METHODS)


def fit_properties():
    """The fit settings as property definitions, shared by scene.quatcurve_fit and the operator."""
    P = bpy.props
    return {
        "method": P.EnumProperty(name="Method", items=METHOD_ITEMS, default="SLERP",
                                 description="How the rotation travels from key to key; Fit shapes your keys so "
                                             "that Blender plays it"),
        "tolerance": P.FloatProperty(
            name="Tolerance (°)", default=0.05, min=1e-4, soft_max=5.0, precision=3,
            description="How far Blender's playback may stray from the method, in degrees, checked on every "
                        "frame and between frames (smaller: more generated keys)"),
        "tension": P.FloatProperty(name="Tension", default=0.0, min=-1.0, max=1.0,
                                  description="TCB: how tightly the motion turns at keys, from -1 (rounder, "
                                              "overshoots) to 1 (tight, slows into keys)"),
        "continuity": P.FloatProperty(name="Continuity", default=0.0, min=-1.0, max=1.0,
                                      description="TCB: from -1 (a sharp corner at keys) through 0 (smooth) "
                                                  "to 1 (bulging out at keys)"),
        "bias": P.FloatProperty(name="Bias", default=0.0, min=-1.0, max=1.0,
                                description="TCB: from -1 (the motion undershoots, leaning toward the next key) "
                                            "to 1 (overshoots, carrying on from the previous key)"),
        "shortest_path": P.BoolProperty(name="Shortest Path", default=True,
                                        description="Slerp: turn the short way round between keys (off: as the "
                                                    "keyed values say, which may turn the long way)"),
        "clamped": P.BoolProperty(
            name="No Overshoot", default=True,
            description="Squad, TCB, Catmull-Rom: tangents clamped so that no segment overshoots its keys "
                        "and holds stay still; off: the textbook tangents"),
        "subframes": P.IntProperty(name="Subframes", default=4, min=1, max=64,
                                   description="How often each frame the tolerance is checked, in checks per "
                                               "frame (matters for motion blur and slowed-down playback)"),
    }


class QuatCurveFitRecord(bpy.types.PropertyGroup):
    """Action.quatcurve_fits item: one fitted target's rotation channels (slot, owner path) and the
    settings it was fitted with; signature and key_frames describe the animator's keys then."""
    __annotations__ = dict(
        {name: prop for name, prop in fit_properties().items() if name != "method"},
        method=bpy.props.StringProperty(name="Method", default="SLERP",
                                        description="The method this target was fitted with"),
        slot=bpy.props.StringProperty(name="Slot", description="The action slot of the fitted target (4.4+)"),
        owner_path=bpy.props.StringProperty(
            name="Owner Path", description="Whose rotation was fitted: '' (the object) or the pose bone's path"),
        prop=bpy.props.StringProperty(
            name="Rotation Property", description="The fitted rotation channels (rotation_quaternion, ...)"),
        signature=bpy.props.StringProperty(
            name="Signature", description="A digest of the animator's keys when fitted (Live refits when it changes)"),
        key_frames=bpy.props.StringProperty(name="Key Frames",
                                            description="The animator's key frames when fitted, in frames"),
        bound=bpy.props.FloatProperty(
            name="Bound", subtype="ANGLE", unit="ROTATION", default=-1.0, precision=4,
            description="The bound the last fit or live refit proved at every instant between Blender's playback "
                        "and the method's curve, in degrees here (radians to scripts); negative: not known "
                        "(a record from an earlier version)"),
    )


class QuatCurveEaseRecord(bpy.types.PropertyGroup):
    """Action.quatcurve_eases item: ease in / ease out of one key (by frame) of a target."""
    __annotations__ = dict(
        slot=bpy.props.StringProperty(name="Slot", description="The action slot of the eased target (4.4+)"),
        owner_path=bpy.props.StringProperty(
            name="Owner Path", description="Whose key is eased: '' (the object) or the pose bone's path"),
        frame=bpy.props.FloatProperty(name="Frame", description="The eased key's frame, in frames"),
        ease_in=bpy.props.FloatProperty(name="Ease In", min=0.0, max=1.0,
                                        description="How much the motion slows into this key, from 0 to 1"),
        ease_out=bpy.props.FloatProperty(name="Ease Out", min=0.0, max=1.0,
                                         description="How much the motion starts slowly out of this key, from 0 to 1"),
    )


class QuatCurveTurnsRecord(bpy.types.PropertyGroup):
    """Action.quatcurve_turns item: the extra full turns of the segment leaving one key (by frame)."""
    __annotations__ = dict(
        slot=bpy.props.StringProperty(name="Slot", description="The action slot of the turned target (4.4+)"),
        owner_path=bpy.props.StringProperty(
            name="Owner Path", description="Whose key turns: '' (the object) or the pose bone's path"),
        frame=bpy.props.FloatProperty(name="Frame", description="The key's frame, in frames"),
        turns=bpy.props.IntProperty(name="Turns",
                                    description="Extra full turns of the segment leaving this key (a count)"),
    )


def turns_property():
    return bpy.props.IntProperty(
        name="Turns", default=0, min=-10000, max=10000, soft_min=-10, soft_max=10,
        description="Extra full turns of the segment leaving each selected key, about its own axis "
                    "(negative: the other way; quaternion targets)")


class QuatCurveFitSettings(bpy.types.PropertyGroup):
    """scene.quatcurve_fit: the panel's fit settings, live mode, the ease to set, the last result."""
    __annotations__ = dict(
        fit_properties(),
        live=bpy.props.BoolProperty(
            name="Live", default=False, update=lambda self, context: live.switched(self.id_data),
            description="Keep fitted targets fitted while you edit their rotation keys (insert, move, delete, "
                        "change, undo): their generated keys and handles are refitted after each change"),
        ease_in=bpy.props.FloatProperty(name="Ease In", default=0.0, min=0.0, max=1.0,
                                        description="How much the motion slows down into the selected keys, from "
                                                    "0 (no ease) to 1 (comes to rest); the path stays the same"),
        ease_out=bpy.props.FloatProperty(name="Ease Out", default=0.0, min=0.0, max=1.0,
                                         description="How much the motion starts slowly out of the selected keys, "
                                                     "from 0 (no ease) to 1 (from rest); the path stays the same"),
        turns=turns_property(),
        last_summary=bpy.props.StringProperty(name="Last Fit", default="",
                                              description="Targets and keys of the last fit"),
        last_lines=bpy.props.StringProperty(name="Last Fit Details", default="",
                                            description="One line per fitted target, newline-separated"),
    )


def settings_from(props):
    """FitSettings from an operator or the scene settings."""
    return fit.FitSettings(method=props.method, tolerance=props.tolerance, tension=props.tension,
                           continuity=props.continuity, bias=props.bias, shortest_path=props.shortest_path,
                           clamped=props.clamped, subframes=props.subframes)


def draw_settings(layout, settings, context=None, extra_rows=(), width=40):
    """The panel's fit box: the method and Live on one line, tolerance and the method's options, Fit /
    Unmark, ease, turns, `extra_rows` (functions draw(layout, context) other tools add, see ui.FIT_ROWS),
    whether the active target is fitted, the last fit's summary (wrapped at `width` characters; a
    line per target stays in settings.last_lines)."""
    row = layout.row(align=True)
    row.prop(settings, "method", text="")
    row.prop(settings, "live", toggle=True, icon="REC" if settings.live else "PLAY")
    col = layout.column(align=True)
    col.prop(settings, "tolerance")
    opsutil.draw_method_options(col, settings)
    row = layout.row(align=True)
    row.scale_y = 1.4
    row.operator("quatcurve.fit", text="Fit Rotation Keys", icon="IPO_EASE_IN_OUT")
    row.operator("quatcurve.unfit", text="", icon="X")
    col = layout.column(align=True)
    col.prop(settings, "ease_in")
    col.prop(settings, "ease_out")
    col.operator("quatcurve.set_ease", text="Set Ease on Selected Keys")
    row = layout.row(align=True)
    row.prop(settings, "turns")
    row.operator("quatcurve.set_turns", text="Set Turns")
    for draw in extra_rows:
        draw(layout, context)
    if context is not None:
        status = active_status(context)
        if status:
            layout.label(text=status, icon="CHECKMARK")
    if settings.last_summary:
        col = layout.column(align=True)
        col.scale_y = 0.8
        opsutil.wrapped_labels(col, settings.last_summary, width)


def active_status(context):
    """'Fitted: Squad, 0.05°' for the active target when it carries a fit record, else ''."""
    obj = context.active_object
    if obj is None:
        return ""
    bone = context.active_pose_bone.name if context.mode == "POSE" and context.active_pose_bone else None
    target = targets.Target(obj, bone)
    action = fcurves.active_action(obj)
    record = fit.find_record(action, target) if action is not None else None
    return "Fitted: %s, %.3g°" % (methods.label(record.method), record.tolerance) if record is not None else ""


class QUATCURVE_OT_fit(bpy.types.Operator):
    """Shape the handles of the selected objects' or pose bones' own rotation keys, adding generated keys where needed, so that Blender plays the chosen method within the Tolerance (degrees)"""
    bl_idname = "quatcurve.fit"
    bl_label = "Fit Rotation Keys"
    bl_options = {"REGISTER", "UNDO"}
    __annotations__ = fit_properties()

    def execute(self, context):
        return opsutil.run_task(self, context, "quatcurve_fit", fit_properties(), settings_from, fit.fit, "fit")


class QUATCURVE_OT_unfit(bpy.types.Operator):
    """Stop treating the selected objects or bones as fitted: their keys and handles stay as they are and are yours to edit; Live no longer refits them"""
    bl_idname = "quatcurve.unfit"
    bl_label = "Unmark Fitted Rotation"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            names = fit.unfit(targets.gather_targets(context, verb="unmark"))
        except TargetError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, "Unmarked %s" % (", ".join(names) if names else "nothing (no fitted target selected)"))
        return {"FINISHED"}


class QUATCURVE_OT_set_ease(bpy.types.Operator):
    """Slow the motion into (ease in) and out of (ease out) the selected rotation keys of fitted objects or bones, from 0 to 1, keeping the path, and refit them"""
    bl_idname = "quatcurve.set_ease"
    bl_label = "Set Ease on Selected Keys"
    bl_options = {"REGISTER", "UNDO"}
    ease_in: bpy.props.FloatProperty(name="Ease In", default=0.0, min=0.0, max=1.0,
                                     description="How much the motion slows down into the keys, from 0 (no ease) "
                                                 "to 1 (comes to rest)")
    ease_out: bpy.props.FloatProperty(name="Ease Out", default=0.0, min=0.0, max=1.0,
                                      description="How much the motion starts slowly out of the keys, from 0 (no "
                                                  "ease) to 1 (from rest)")

    def execute(self, context):
        opsutil.take_scene_settings(self, getattr(context.scene, "quatcurve_fit", None), ("ease_in", "ease_out"))
        try:
            native.require()
            result = set_ease(targets.gather_targets(context, verb="ease"), self.ease_in, self.ease_out)
        except (TargetError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return report_refit(self, context, result)


def report_refit(operator, context, result):
    """Reports a fit.RefitResult as the fit reports its result: the summary (a warning where a
    refit's bound is above its tolerance), and the lines for the panel."""
    settings = getattr(context.scene, "quatcurve_fit", None)
    if settings is not None:
        settings.last_summary = result.summary()
        settings.last_lines = "\n".join(result.lines())
    operator.report({"WARNING"} if result.above() else {"INFO"}, result.summary())
    return {"FINISHED"}


def set_ease(found, ease_in, ease_out):
    """Sets the ease of the selected animator keys of each fitted target and refits it with its own
    settings. Returns a fit.RefitResult (the keys changed; each refit's bound and notes). Raises
    FitError for a target that is not fitted."""
    plans, changed = [], 0
    for target in found:
        keys = fit.read_animator_keys(target)
        action = fcurves.active_action(target.id_data)
        record = fit.find_record(action, target)
        if record is None:
            raise fit.FitError("%s: not fitted (fit it first: ease is part of the fit)" % target.name)
        chosen = keys.selected.any(axis=0)
        if not chosen.any():
            continue
        e_in, e_out = fit.key_eases(action, target, keys.frames)
        e_in[chosen], e_out[chosen] = ease_in, ease_out
        changed += int(chosen.sum())
        turns = fit.key_turns(action, target, keys.frames)
        plan = fit.plan_target(keys, fit.settings_of(record), e_in, e_out, turns, previous=fit.last_fit(action, target))
        if plan is not None:
            plans.append((plan, target))
    for plan, target in plans:
        fit.write_plan(plan, target)
    return fit.RefitResult("Ease in %.2f / out %.2f" % (ease_in, ease_out), changed, [p for p, _ in plans])


class QUATCURVE_OT_set_turns(bpy.types.Operator):
    """Turn the segment leaving each selected rotation key of the selected fitted quaternion or
    axis-angle targets by extra full turns about its own axis, and refit them"""
    bl_idname = "quatcurve.set_turns"
    bl_label = "Set Turns on Selected Keys"
    bl_options = {"REGISTER", "UNDO"}
    turns: turns_property()

    def execute(self, context):
        opsutil.take_scene_settings(self, getattr(context.scene, "quatcurve_fit", None), ("turns",))
        try:
            native.require()
            result = fit.set_turns(targets.gather_targets(context, verb="turn"), self.turns)
        except (TargetError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return report_refit(self, context, result)


_classes = (QuatCurveFitRecord, QuatCurveEaseRecord, QuatCurveTurnsRecord, QuatCurveFitSettings, QUATCURVE_OT_fit,
            QUATCURVE_OT_unfit, QUATCURVE_OT_set_ease, QUATCURVE_OT_set_turns)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.quatcurve_fit = bpy.props.PointerProperty(type=QuatCurveFitSettings)
    bpy.types.Action.quatcurve_fits = bpy.props.CollectionProperty(type=QuatCurveFitRecord)
    bpy.types.Action.quatcurve_eases = bpy.props.CollectionProperty(type=QuatCurveEaseRecord)
    bpy.types.Action.quatcurve_turns = bpy.props.CollectionProperty(type=QuatCurveTurnsRecord)


def unregister():
    del bpy.types.Action.quatcurve_turns
    del bpy.types.Action.quatcurve_eases
    del bpy.types.Action.quatcurve_fits
    del bpy.types.Scene.quatcurve_fit
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
