"""The `quatcurve.bake` operator: gathers the selection and settings, calls bake.py, reports.

Properties not given by the caller come from the panel's settings (`scene.quatcurve`); the frame
range defaults to the keyed range of the selection. In the UI (a window, not background mode) the
bake runs modally, target by target, with window-manager progress; Esc cancels and, since nothing is
written before the last step, leaves no partial result. In background mode and from scripts
(`bpy.ops.quatcurve.bake()`, which calls execute) it runs synchronously.
"""

import time

import bpy

from . import bake, native, props

_BAKE_PROPERTIES = tuple(props.bake_properties())


def settings_from(values, frame_range=(None, None)):
    """BakeSettings from `values` (the operator, scene.quatcurve: anything with the bake property
    names) and a (frame_start, frame_end) pair whose None ends mean the keyed range."""
    start, end = frame_range
    return bake.BakeSettings(
        method=values.method, rotation_mode=values.rotation_mode, frame_start=start, frame_end=end,
        step=values.step, tolerance=values.tolerance, new_action=values.new_action, tension=values.tension,
        continuity=values.continuity, bias=values.bias, shortest_path=values.shortest_path)


class QUATCURVE_OT_bake(bpy.types.Operator):
    """Bake the rotation of the selected objects or pose bones with an orientation curve method"""
    bl_idname = "quatcurve.bake"
    bl_label = "Bake Orientation Curves"
    bl_options = {"REGISTER", "UNDO"}
    __annotations__ = props.bake_properties()

    def _fill_from_scene(self, context):
        """Unset properties take the panel's values; an unset frame range means the keyed range
        (or the panel's Start/End when its Keyed Range is off). Returns (start, end) or None."""
        scene_settings = getattr(context.scene, "quatcurve", None)
        if scene_settings is not None:
            for name in _BAKE_PROPERTIES:
                if name not in ("frame_start", "frame_end") and not self.properties.is_property_set(name):
                    setattr(self, name, getattr(scene_settings, name))
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
        plan = bake.prepare(bake.gather_targets(context), settings)
        # Show the range used in the redo panel (and reuse it on redo).
        self.frame_start, self.frame_end = int(round(plan.frames[0])), int(round(plan.frames[-1]))
        return plan

    def _finish(self, context, plan):
        result = plan.write()
        scene_settings = getattr(context.scene, "quatcurve", None)
        if scene_settings is not None:
            props.store_result(scene_settings, result)
        for note in result.notes():
            self.report({"WARNING"}, note)
        self.report({"INFO"}, "Baked " + result.summary())
        return {"FINISHED"}

    def execute(self, context):
        try:
            plan = self._prepare(context)
            plan.compute()
            return self._finish(context, plan)
        except (bake.BakeError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._plan = self._prepare(context)
        except (bake.BakeError, RuntimeError) as error:
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
        except (bake.BakeError, RuntimeError) as error:
            self._end_modal(context)
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self._end_modal(context)
        return self._finish(context, self._plan)


_classes = (QUATCURVE_OT_bake,)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
