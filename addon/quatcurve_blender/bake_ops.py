"""The `quatcurve.bake` operator and the bake settings and last result (`scene.quatcurve`): gathers
the selection and settings, calls bake.py (the function the CLI calls), reports.

Properties not given by the caller come from the panel's settings (`scene.quatcurve`); the frame
range defaults to the keyed range of the selection. In the UI (a window, not background mode) the
bake runs modally, target by target, with window-manager progress; Esc cancels and, since nothing is
written before the last step, leaves no partial result. In background mode and from scripts
(`bpy.ops.quatcurve.bake()`, which calls execute) it runs synchronously.
"""

import time

import bpy

from . import bake, methods, native, opsutil, targets
from .targets import TargetError

METHOD_ITEMS = methods.enum_items(methods.ALL)

ROTATION_MODE_ITEMS = (
    ("KEEP", "Keep", "The target's current rotation mode"),
    ("QUATERNION", "Quaternion (WXYZ)", "Quaternion keys, hemisphere-continuous"),
    ("XYZ", "XYZ Euler", "Euler keys, continuous (no flips or 360° jumps)"),
    ("XZY", "XZY Euler", ""),
    ("YXZ", "YXZ Euler", ""),
    ("YZX", "YZX Euler", ""),
    ("ZXY", "ZXY Euler", ""),
    ("ZYX", "ZYX Euler", ""),
    ("AXIS_ANGLE", "Axis Angle", "Axis-angle keys, continuous"),
)


def bake_properties():
    """The bake settings as property definitions, shared by scene.quatcurve and the operator.
    `step` has no hard minimum so that a value below 1 is refused with a message, not clamped."""
    P = bpy.props
    return {
        "method": P.EnumProperty(name="Method", items=METHOD_ITEMS, default="SLERP",
                                 description="How orientations are interpolated between the keys"),
        "tension": P.FloatProperty(name="Tension", default=0.0, soft_min=-1.0, soft_max=1.0,
                                   description="TCB tension: 1 tightens the curve at keys, -1 rounds it"),
        "continuity": P.FloatProperty(name="Continuity", default=0.0, soft_min=-1.0, soft_max=1.0,
                                      description="TCB continuity: 0 keeps the curve smooth at keys"),
        "bias": P.FloatProperty(name="Bias", default=0.0, soft_min=-1.0, soft_max=1.0,
                                description="TCB bias: overshoot (+) or undershoot (-) at keys"),
        "shortest_path": P.BoolProperty(name="Shortest Path", default=True,
                                        description="Slerp: take the shorter way between keys (off: keep the "
                                                    "keyed quaternions' path)"),
        "clamped": P.BoolProperty(
            name="No Overshoot", default=True,
            description="Squad, TCB, Catmull-Rom: tangents clamped so that no segment overshoots its keys and "
                        "holds stay still; off: the textbook tangents"),
        "rotation_mode": P.EnumProperty(name="Rotation Mode", items=ROTATION_MODE_ITEMS, default="KEEP",
                                        description="Rotation mode of the baked keys (the target's mode is set to it)"),
        "frame_start": P.IntProperty(name="Start", default=1, description="First baked frame"),
        "frame_end": P.IntProperty(name="End", default=250, description="Last baked frame"),
        "step": P.IntProperty(name="Step", default=1, soft_min=1, soft_max=100,
                              description="Frames between baked keys (at least 1)"),
        "tolerance": P.FloatProperty(name="Tolerance (°)", default=0.0, soft_min=0.0, soft_max=10.0, precision=3,
                                     description="Degrees. 0: a key every Step frames. Above 0: as few keys as "
                                                 "the angular bound allows (key reduction, Bezier keys)"),
        "new_action": P.BoolProperty(name="New Action", default=True,
                                     description="Bake into a new action named after the original, which is "
                                                 "kept (fake user) and untouched; off: replace the rotation "
                                                 "curves in place"),
    }


class QuatCurveSettings(bpy.types.PropertyGroup):
    """scene.quatcurve"""
    __annotations__ = dict(
        bake_properties(),
        use_keyed_range=bpy.props.BoolProperty(
            name="Keyed Range", default=True,
            description="Bake over the keyed range of the selection (off: use Start and End)"),
        last_summary=bpy.props.StringProperty(name="Last Bake", default=""),
        last_targets=bpy.props.IntProperty(name="Targets", default=0),
        last_keys=bpy.props.IntProperty(name="Keys Written", default=0),
        last_seconds=bpy.props.FloatProperty(name="Seconds", default=0.0),
        last_lines=bpy.props.StringProperty(name="Last Bake Details", default="",
                                            description="One line per target, newline-separated"),
    )


def store_result(settings, result):
    """Records a BakeResult in scene.quatcurve for the panel."""
    settings.last_summary = result.summary()
    settings.last_targets = len(result.targets)
    settings.last_keys = min(result.keys_written, 2 ** 31 - 1)
    settings.last_seconds = result.seconds
    settings.last_lines = "\n".join(result.lines())


_BAKE_PROPERTIES = tuple(bake_properties())


def settings_from(values, frame_range=(None, None)):
    """BakeSettings from `values` (the operator, scene.quatcurve: anything with the bake property
    names) and a (frame_start, frame_end) pair whose None ends mean the keyed range."""
    start, end = frame_range
    return bake.BakeSettings(
        method=values.method, rotation_mode=values.rotation_mode, frame_start=start, frame_end=end,
        step=values.step, tolerance=values.tolerance, new_action=values.new_action, tension=values.tension,
        continuity=values.continuity, bias=values.bias, shortest_path=values.shortest_path,
        clamped=getattr(values, "clamped", True))


class QUATCURVE_OT_bake(bpy.types.Operator):
    """Bake the rotation of the selected objects or pose bones with an orientation curve method"""
    bl_idname = "quatcurve.bake"
    bl_label = "Bake Orientation Curves"
    bl_options = {"REGISTER", "UNDO"}
    __annotations__ = bake_properties()

    def _fill_from_scene(self, context):
        """Unset properties take the panel's values; an unset frame range means the keyed range
        (or the panel's Start/End when its Keyed Range is off). Returns (start, end) or None."""
        scene_settings = getattr(context.scene, "quatcurve", None)
        opsutil.take_scene_settings(self, scene_settings, _BAKE_PROPERTIES, skip=("frame_start", "frame_end"))
        start_set = self.properties.is_property_set("frame_start")
        end_set = self.properties.is_property_set("frame_end")
        if scene_settings is not None and not scene_settings.use_keyed_range:
            if not start_set:
                self.frame_start = scene_settings.frame_start
            if not end_set:
                self.frame_end = scene_settings.frame_end
            start_set = end_set = True
        return (self.frame_start if start_set else None, self.frame_end if end_set else None)

    def _prepare(self, context):
        native.require()
        start, end = self._fill_from_scene(context)
        settings = settings_from(self, (start, end))
        plan = bake.prepare(targets.gather_targets(context), settings)
        # Show the range used in the redo panel (and reuse it on redo).
        self.frame_start, self.frame_end = int(round(plan.frames[0])), int(round(plan.frames[-1]))
        return plan

    def _finish(self, context, plan):
        result = plan.write()
        scene_settings = getattr(context.scene, "quatcurve", None)
        if scene_settings is not None:
            store_result(scene_settings, result)
        for note in result.notes():
            self.report({"WARNING"}, note)
        self.report({"INFO"}, "Baked " + result.summary())
        return {"FINISHED"}

    def execute(self, context):
        try:
            plan = self._prepare(context)
            return self._finish(context, plan)  # computes while it writes (BakePlan.write)
        except (TargetError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._plan = self._prepare(context)
        except (TargetError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self._steps = self._plan.compute_steps()
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _end_modal(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()

    def modal(self, context, event):
        if event.type == "ESC":
            self._end_modal(context)
            self.report({"WARNING"}, "Bake cancelled: nothing was changed")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"RUNNING_MODAL"}  # the bake holds the UI: no edits while it reads the data
        deadline = time.perf_counter() + 0.1
        try:
            for done in self._steps:
                context.window_manager.progress_update(int(done * 1000))
                if time.perf_counter() > deadline:
                    return {"RUNNING_MODAL"}
        except (TargetError, RuntimeError) as error:
            self._end_modal(context)
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self._end_modal(context)
        return self._finish(context, self._plan)


_classes = (QuatCurveSettings, QUATCURVE_OT_bake)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.quatcurve = bpy.props.PointerProperty(type=QuatCurveSettings)


def unregister():
    del bpy.types.Scene.quatcurve
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
