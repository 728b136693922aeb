"""Test and benchmark rigs (support code, not a test module): the big armature of the bake
benchmark and the undo / cancel / memory sessions. Callers put addon/ on sys.path first."""

import bpy
import numpy as np

from quatcurve_blender import fcurves


def build_rig(name="Rig", last_frame=10_000, seed=3, bones=100, key_every=10):
    """An armature of `bones` bones side by side (no chain), each with random quaternion keys every
    `key_every` frames from frame 0 to `last_frame`, written in bulk; the rig is the only selected
    object and active, in Pose mode, with every bone selected. Returns the rig."""
    arm = bpy.data.armatures.new(name)
    rig = bpy.data.objects.new(name, arm)
    bpy.context.scene.collection.objects.link(rig)
    for obj in bpy.context.scene.objects:
        obj.select_set(obj == rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    for i in range(bones):
        bone = arm.edit_bones.new("Bone%03d" % i)
        bone.head, bone.tail = (i * 0.1, 0, 0), (i * 0.1, 0, 1)
    bpy.ops.object.mode_set(mode="POSE")
    fcurves.new_action(rig, name + "Action")
    channels = fcurves.Channels.of(rig, create=True)
    rng = np.random.default_rng(seed)
    frames = np.arange(0, last_frame + 1, key_every, dtype=np.float64)
    for pb in rig.pose.bones:
        pb.rotation_mode = "QUATERNION"
        quats = rng.normal(size=(len(frames), 4))
        quats /= np.linalg.norm(quats, axis=1, keepdims=True)
        path = pb.path_from_id("rotation_quaternion")
        for i in range(4):
            channels.write(path, i, frames, quats[:, i], group=pb.name)
        if bpy.app.version >= (5, 0, 0):
            pb.select = True
        else:
            pb.bone.select = True
    return rig
