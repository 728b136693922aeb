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

ERROR_ITEMS = (
    ("ANGLE", "Angle", "Tolerance above 0: each baked rotation reduced within the Tolerance (degrees) of the "
                       "method, at every instant"),
    ("DISTANCE", "Distance", "Baked dense, then reduced as Reduce Keys with Error Distance does: per armature, "
                             "every bone's tail and shell points within Distance of the dense bake's"),
)

ROTATION_MODE_ITEMS = (
    ("KEEP", "Keep", "The target's current rotation mode"),
    ("QUATERNION", "Quaternion (WXYZ)", "Quaternion keys, hemisphere-continuous"),
    ("XYZ", "XYZ Euler", "Euler keys, continuous (no flips or 360° jumps)"),
    ("XZY", "XZY Euler", "Euler keys in the XZY order, continuous"),
    ("YXZ", "YXZ Euler", "Euler keys in the YXZ order, continuous"),
    ("YZX", "YZX Euler", "Euler keys in the YZX order, continuous"),
    ("ZXY", "ZXY Euler", "Euler keys in the ZXY order, continuous"),
    ("ZYX", "ZYX Euler", "Euler keys in the ZYX order, continuous"),
    ("AXIS_ANGLE", "Axis Angle", "Axis-angle keys, continuous"),
)


def bake_properties():
    """The bake settings as property definitions, shared by scene.quatcurve and the operator.
    `step` has no hard minimum so that a value below 1 is refused with a message, not clamped."""
    P = bpy.props
    return {
        "method": P.EnumProperty(name="Method", items=METHOD_ITEMS, default="SLERP",
                                 description="How the rotation travels from key to key in the baked keys"),
        "tension": P.FloatProperty(name="Tension", default=0.0, soft_min=-1.0, soft_max=1.0,
                                   description="TCB: how tightly the motion turns at keys, from -1 (rounder) to 1 (tight)"),
        "continuity": P.FloatProperty(name="Continuity", default=0.0, soft_min=-1.0, soft_max=1.0,
                                      description="TCB: from -1 (a sharp corner at keys) through 0 (smooth) to 1 "
                                                  "(bulging out at keys)"),
        "bias": P.FloatProperty(name="Bias", default=0.0, soft_min=-1.0, soft_max=1.0,
                                description="TCB: from -1 (undershoots at keys) to 1 (overshoots at keys)"),
        "shortest_path": P.BoolProperty(name="Shortest Path", default=True,
                                        description="Slerp: take the shorter way between keys (off: keep the "
                                                    "keyed quaternions' path)"),
        "clamped": P.BoolProperty(
            name="No Overshoot", default=True,
            description="Squad, TCB, Catmull-Rom: tangents clamped so that no segment overshoots its keys and "
                        "holds stay still; off: the textbook tangents"),
        "rotation_mode": P.EnumProperty(name="Rotation Mode", items=ROTATION_MODE_ITEMS, default="KEEP",
                                        description="Rotation mode of the baked keys (the object or bone is switched to it)"),
        "frame_start": P.IntProperty(name="Start", default=1, description="First frame to bake (a frame number)"),
        "frame_end": P.IntProperty(name="End", default=250, description="Last frame to bake (a frame number)"),
        "step": P.IntProperty(name="Step", default=1, soft_min=1, soft_max=100,
                              description="Frames between two baked keys, in frames (at least 1)"),
        "tolerance": P.FloatProperty(name="Tolerance (°)", default=0.0, soft_min=0.0, soft_max=10.0, precision=3,
                                     description="How far the baked keys may stray from the method, in degrees. 0: a key "
                                                 "every Step frames; above 0: only as many Bezier keys as "
                                                 "this allows"),
        "new_action": P.BoolProperty(name="New Action", default=True,
                                     description="Bake into a new action named after the original, which is "
                                                 "kept (fake user) and untouched; off: replace the rotation "
                                                 "curves in place"),
        "error": P.EnumProperty(
            name="Error", items=ERROR_ITEMS, default="ANGLE",
            description="What the reduction of the baked keys bounds: each rotation's angle (Tolerance), or how far "
                        "the armature's bones move (Distance)"),
        "distance": P.FloatProperty(
            name="Distance", default=0.0, min=0.0, soft_max=0.1, precision=4, subtype="DISTANCE", unit="LENGTH",
            description="How far, in scene units, any bone's tail or shell point may move from the dense bake's, in "
                        "the armature's object space, on every frame and key; 0: 1 mm in real size"),
        "shell": P.FloatProperty(
            name="Shell", default=0.0, min=0.0, soft_max=1.0, precision=3, subtype="DISTANCE", unit="LENGTH",
            description="Distance, in scene units, from each bone's head of the three points along its axes measured "
                        "with its tail; 0: 10 cm in real size"),
    }


class QuatCurveSettings(bpy.types.PropertyGroup):
    """scene.quatcurve"""
    __annotations__ = dict(
        bake_properties(),
        use_keyed_range=bpy.props.BoolProperty(
            name="Keyed Range", default=True,
            description="Bake from the first to the last key of the selection (off: from Start to End)"),
        last_summary=bpy.props.StringProperty(name="Last Bake", default="",
                                              description="Targets, keys and seconds of the last bake"),
        last_targets=bpy.props.IntProperty(name="Targets", default=0,
                                           description="Objects and bones the last bake wrote (a count)"),
        last_keys=bpy.props.IntProperty(name="Keys Written", default=0,
                                        description="Keys the last bake wrote (a count)"),
        last_seconds=bpy.props.FloatProperty(name="Seconds", default=0.0,
                                             description="How long the last bake took, in seconds"),
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
        clamped=getattr(values, "clamped", True), error=getattr(values, "error", "ANGLE"),
        distance=getattr(values, "distance", 0.0), shell=getattr(values, "shell", 0.0))


class QUATCURVE_OT_bake(bpy.types.Operator):
    """Replace the rotation of the selected objects or pose bones by keys on every Step frames (or as few as the Tolerance in degrees allows) that follow the chosen method; the original action is kept"""
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
