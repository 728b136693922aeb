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


# A Rigify-like chain: (name, parent, head, tail, connected, inherit rotation, inherit scale, mode),
# the modes Rigify's controls use (quaternion, YXZ, ZXY), an axis-angle bone, one bone that does not
# inherit rotation and one that does not inherit scale.
CHAIN = (
    ("root", None, (0, 0, 1.0), (0, 0, 1.1), False, True, "FULL", "QUATERNION"),
    ("spine", "root", (0, 0, 1.1), (0, 0.02, 1.35), True, True, "FULL", "YXZ"),
    ("chest", "spine", (0, 0.02, 1.35), (0, 0, 1.55), True, True, "FULL", "QUATERNION"),
    ("head", "chest", (0, 0, 1.6), (0, 0, 1.85), False, False, "FULL", "ZXY"),
    ("shoulder.L", "chest", (0.05, 0, 1.5), (0.2, 0, 1.5), False, True, "NONE", "QUATERNION"),
    ("upper_arm.L", "shoulder.L", (0.2, 0, 1.5), (0.45, 0, 1.45), True, True, "FULL", "AXIS_ANGLE"),
    ("forearm.L", "upper_arm.L", (0.45, 0, 1.45), (0.7, -0.02, 1.45), True, True, "FULL", "XYZ"),
    ("hand.L", "forearm.L", (0.7, -0.02, 1.45), (0.8, -0.02, 1.45), True, True, "FULL", "QUATERNION"),
    ("thigh.L", "root", (0.1, 0, 1.0), (0.1, 0, 0.55), False, True, "FULL", "YXZ"),
    ("shin.L", "thigh.L", (0.1, 0, 0.55), (0.1, 0.02, 0.1), True, True, "FULL", "QUATERNION"),
)


def build_chain_rig(name="Chain", frames=60, seed=5, chain=None):
    """A Rigify-like armature (CHAIN, or `chain`: rows as CHAIN's) keyed at every frame 1..frames
    with smooth random motion in each bone's rotation mode (BEZIER keys), location keys on the root
    and on one connected bone (unused by Blender), scale keys on the shoulder (where the chain has
    them); the rig is selected and active, in Pose mode, every bone selected. Returns the rig."""
    chain = CHAIN if chain is None else chain
    arm = bpy.data.armatures.new(name)
    rig = bpy.data.objects.new(name, arm)
    bpy.context.scene.collection.objects.link(rig)
    for obj in bpy.context.scene.objects:
        obj.select_set(obj == rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    for bone_name, parent, head, tail, connected, inherit_rotation, inherit_scale, _ in chain:
        bone = arm.edit_bones.new(bone_name)
        bone.head, bone.tail = head, tail
        if parent:
            bone.parent = arm.edit_bones[parent]
            bone.use_connect = connected
        bone.use_inherit_rotation = inherit_rotation
        bone.inherit_scale = inherit_scale
    bpy.ops.object.mode_set(mode="POSE")
    fcurves.new_action(rig, name + "Action")
    channels = fcurves.Channels.of(rig, create=True)
    rng = np.random.default_rng(seed)
    t = np.arange(1, frames + 1, dtype=np.float64)

    def wave(count, amplitude):
        """count smooth channels: sums of three sines of random phase and period 15..60 frames."""
        out = np.zeros((len(t), count))
        for c in range(count):
            for _ in range(3):
                period, phase = rng.uniform(15, 60), rng.uniform(0, 2 * np.pi)
                out[:, c] += amplitude / 3 * np.sin(2 * np.pi * t / period + phase)
        return out

    def key(pb, prop, values):
        path = pb.path_from_id(prop)
        for i in range(values.shape[1]):
            # Blender's automatic handles, as keys an animator sets get them (the bulk write leaves them at 0).
            channels.write(path, i, t, values[:, i], group=pb.name, interpolation="BEZIER").update()

    for bone_name, *_, mode in chain:
        pb = rig.pose.bones[bone_name]
        pb.rotation_mode = mode
        angles = wave(3, 0.6)
        if mode == "QUATERNION":
            half = angles / 2
            quats = np.column_stack([np.ones(len(t)), half])
            key(pb, "rotation_quaternion", quats / np.linalg.norm(quats, axis=1, keepdims=True))
        elif mode == "AXIS_ANGLE":
            axis = np.column_stack([np.full(len(t), 0.3), np.ones(len(t)), 0.2 + angles[:, 2] / 3])
            key(pb, "rotation_axis_angle", np.column_stack([0.4 + angles[:, 0], axis]))
        else:
            key(pb, "rotation_euler", angles)
        if bpy.app.version >= (5, 0, 0):
            pb.select = True
        else:
            pb.bone.select = True
    if chain is CHAIN:
        key(rig.pose.bones["root"], "location", wave(3, 0.3))
        key(rig.pose.bones["forearm.L"], "location", wave(3, 0.1))   # connected: Blender ignores it
        key(rig.pose.bones["shoulder.L"], "scale", 1.0 + wave(3, 0.2))
    return rig
