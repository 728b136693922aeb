"""Scene-building and checking helpers for the bake and F-curve tests (not a test module).

Scenes are built with Blender's own keyframe_insert (few keys), so the tests do not depend on the
add-on's writer to set up their input; the interpolation of the keys is set through the RNA key
points (a per-key loop is fine at this size)."""

import math

import bpy
import numpy as np
from mathutils import Euler, Quaternion

from quatcurve_blender import fcurves, native


def add_empty(name, rotation_mode="XYZ"):
    obj = bpy.data.objects.new(name, None)
    bpy.context.scene.collection.objects.link(obj)
    obj.rotation_mode = rotation_mode
    return obj


def select_objects(*objects):
    if bpy.context.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj in objects)
    if objects:
        bpy.context.view_layer.objects.active = objects[0]


def add_rig(name="Rig", bones=("B0", "B1", "B2"), rotation_mode="QUATERNION"):
    arm = bpy.data.armatures.new(name)
    rig = bpy.data.objects.new(name, arm)
    bpy.context.scene.collection.objects.link(rig)
    select_objects(rig)
    bpy.ops.object.mode_set(mode="EDIT")
    for i, bone in enumerate(bones):
        eb = arm.edit_bones.new(bone)
        eb.head, eb.tail = (i, 0, 0), (i, 0, 1)
    bpy.ops.object.mode_set(mode="POSE")
    for pb in rig.pose.bones:
        pb.rotation_mode = rotation_mode
    return rig


def select_bones(rig, names):
    """Pose-mode bone selection: PoseBone.select from 5.0, Bone.select before."""
    for pb in rig.pose.bones:
        selected = pb.name in names
        if bpy.app.version >= (5, 0, 0):
            pb.select = selected
        else:
            pb.bone.select = selected


def key(owner, prop, frames_values, interpolation="LINEAR", degrees=False):
    """Keys owner.prop (an object or pose bone) at the given frames; sets every key's interpolation."""
    for frame, value in frames_values:
        value = [math.radians(v) for v in value] if degrees else list(value)
        setattr(owner, prop, value)
        owner.keyframe_insert(prop, frame=frame)
    set_interpolation(owner, prop, interpolation)


def add_uneven_euler_keys(rng):
    """An empty "Uneven" (XYZ) with 65 Bezier keys at uneven fractional frames (gaps of 0.011 to 12.25
    frames, on a 1/1024 grid; `rng` draws them and the noise) on smooth sines with 2° of noise and a
    400° spin about Z: (object, key frames)."""
    gaps = np.r_[rng.uniform(0.02, 0.3, 30), rng.uniform(0.5, 3, 30), [0.011, 0.013, 7.5, 12.25]]
    rng.shuffle(gaps)
    frames = np.round((1 + np.r_[0, np.cumsum(gaps)]) * 1024) / 1024
    angles = np.column_stack([50 * np.sin(frames / 9.0), 35 * np.sin(frames / 13.0 + 1),
                              60 * np.sin(frames / 11.0 + 2)])
    angles += rng.normal(scale=2.0, size=angles.shape)
    angles[:, 2] += 400 * (frames - 1) / (frames[-1] - 1)
    obj = add_empty("Uneven", "XYZ")
    key(obj, "rotation_euler", zip(frames.tolist(), angles.tolist()), interpolation="BEZIER", degrees=True)
    return obj, frames


def rotation_fcurves(owner, prop):
    channels = fcurves.Channels.of(owner.id_data)
    path = owner.path_from_id(prop)
    return [f for f in channels.fcurves if f.data_path == path]


def set_interpolation(owner, prop, interpolation):
    for fcurve in rotation_fcurves(owner, prop):
        for point in fcurve.keyframe_points:
            point.interpolation = interpolation
        fcurve.update()


def rotation_quat(owner):
    """The owner's current rotation as a unit mathutils Quaternion, built from its rotation mode as
    Blender builds it."""
    mode = owner.rotation_mode
    if mode == "QUATERNION":
        return Quaternion(owner.rotation_quaternion).normalized()
    if mode == "AXIS_ANGLE":
        angle, x, y, z = owner.rotation_axis_angle
        return Quaternion((x, y, z), angle)
    return Euler(owner.rotation_euler, mode).to_quaternion()


def evaluated(owner, frames, what="quat"):
    """Blender's evaluation (scene.frame_set) at each frame: quaternions (N, 4) or the raw property
    values of the current mode ('values')."""
    scene = bpy.context.scene
    out = []
    for frame in frames:
        scene.frame_set(int(frame))
        if what == "quat":
            out.append(tuple(rotation_quat(owner)))
        else:
            prop = fcurves.rotation_property(owner.rotation_mode)[0]
            out.append(tuple(getattr(owner, prop)))
    return np.array(out)


def angles_between(a, b):
    """Geodesic angle (rad) between rotations, row by row, sign-invariant: quatcurve.angle_between,
    the one measurement every test and the demo use."""
    return native.require().angle_between(np.asarray(a, float), np.asarray(b, float))


def file_state():
    """Everything a failed bake must leave alone: each action's digest and fake-user flag, each
    object's assigned action, rotation modes of objects and pose bones, and the action list."""
    state = {"actions": {a.name: (fcurves.action_digest(a), a.use_fake_user) for a in bpy.data.actions}}
    for obj in bpy.data.objects:
        action = fcurves.active_action(obj)
        state[obj.name] = (action.name if action else None, obj.rotation_mode,
                           tuple((pb.name, pb.rotation_mode) for pb in obj.pose.bones) if obj.pose else ())
    return state
