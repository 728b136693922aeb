"""Settings stored on the scene (`scene.quatcurve`): what the panel shows and the Bake button uses,
and the last bake's summary. The enum item lists are shared with the operator."""

import bpy

METHOD_ITEMS = (
    ("EULER", "Euler (linear angles)", "Each Euler angle linear between keys: Blender's Euler mode with LINEAR keys"),
    ("QUAT_COMPONENTS", "Quaternion components", "w, x, y, z linear then normalized, no hemisphere fix: "
                                                 "Blender's quaternion mode with LINEAR keys"),
    ("NLERP", "Nlerp", "Normalized linear interpolation with hemisphere fix"),
    ("SLERP", "Slerp", "Constant angular speed within each segment"),
    ("SQUAD", "Squad", "Shoemake's spherical quadrangle: smooth (C1) through the keys"),
    ("CATMULL_ROM", "Catmull-Rom", "Spherical Catmull-Rom: smooth (C1) through the keys"),
    ("TCB", "TCB", "Kochanek-Bartels: tension, continuity and bias"),
    ("SPLINE_C2", "C2 spline", "Continuous angular velocity and acceleration"),
)

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


_classes = (QuatCurveSettings,)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.quatcurve = bpy.props.PointerProperty(type=QuatCurveSettings)


def unregister():
    del bpy.types.Scene.quatcurve
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
