"""quatcurve.convert next to Rigify's pose.convert_rotation on the same scenes: how far each one's
playback drifts from the playback before (max degrees over every frame and 4 subframes, Blender's own
evaluation), and the keys before and after.

    python tests/bench/bench_convert.py                    (a bpy 4.5 / 5.0 Python)
    blender -b --factory-startup --python tests/bench/bench_convert.py

Scenes (pose bones: Rigify's converter handles pose bones, Euler <-> quaternion only):
- "Euler Bezier": bones keyed in XYZ, YXZ and ZXY, Bezier keys 60-200° apart (one spins 720°) -> QUATERNION.
- "quaternion Bezier": bones keyed in component-wise Bezier quaternions 40-150° apart -> XYZ.
- "mocap": ../shared/data/mocap/mocapbank.bvh through Blender's BVH importer (Euler keys on every frame,
  the file's rotation orders) -> QUATERNION (skipped when the file is absent).
Each scene is saved, converted by quatcurve.convert, reopened, converted by Rigify; the F-curves are
grouped by bone (Rigify finds channels by group only). `--smoke` (tests/bench/smoke.py): the same
scenes, sampled and converted at every frame only (no subframes).
"""

import math
import os
import sys
import tempfile
import time

import bpy
import numpy as np
from mathutils import Euler, Quaternion

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.join(ROOT, "build_scripts"))
sys.path.insert(0, os.path.join(ROOT, "tests", "bench"))

import quatcurve_blender  # noqa: E402
import smoke  # noqa: E402
from quatcurve_blender import fcurves  # noqa: E402

MOCAP = os.path.join(os.path.dirname(ROOT), "shared", "data", "mocap", "mocapbank.bvh")
TOL = 0.05
SUBFRAMES = 1 if smoke.SMOKE else 4


def rig_with(bone_modes):
    arm = bpy.data.armatures.new("Rig")
    rig = bpy.data.objects.new("Rig", arm)
    bpy.context.scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    rig.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    for i, name in enumerate(bone_modes):
        bone = arm.edit_bones.new(name)
        bone.head, bone.tail = (i, 0, 0), (i, 0, 1)
    bpy.ops.object.mode_set(mode="POSE")
    for name, mode in bone_modes.items():
        rig.pose.bones[name].rotation_mode = mode
    return rig


def euler_scene():
    rng = np.random.default_rng(11)
    modes = {"E%d_%s" % (i, m): m for i, m in enumerate(("XYZ", "YXZ", "ZXY") * 4)}
    rig = rig_with(modes)
    for n, pb in enumerate(rig.pose.bones):
        angles = np.zeros(3)
        for frame in (1, 13, 30, 42, 60):
            pb.rotation_euler = angles
            pb.keyframe_insert("rotation_euler", frame=frame, group=pb.name)
            angles = angles + np.radians(rng.uniform(-100, 100, 3))
            if n == 0:
                angles[2] += math.radians(180)  # spins: 720° by the last key
    return rig


def quaternion_scene():
    rng = np.random.default_rng(12)
    rig = rig_with({"Q%d" % i: "QUATERNION" for i in range(12)})
    for pb in rig.pose.bones:
        q = Quaternion()
        for frame in (1, 11, 26, 40, 60):
            pb.rotation_quaternion = q
            pb.keyframe_insert("rotation_quaternion", frame=frame, group=pb.name)
            axis = rng.normal(size=3)
            q = Quaternion(axis / np.linalg.norm(axis), math.radians(rng.uniform(40, 150))) @ q
    return rig


def mocap_scene():
    import demo_scene
    rig = demo_scene.import_bvh(MOCAP, rotate_mode="NATIVE")
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="POSE")
    return rig


def played(rig, times):
    scene, out = bpy.context.scene, []
    for t in times:
        scene.frame_set(int(math.floor(t)), subframe=float(t - math.floor(t)))
        out.append([list(pb.matrix_basis.to_quaternion()) for pb in rig.pose.bones])
    return np.array(out)  # (N, bones, 4)


def angles(a, b):
    d = np.abs(np.sum(a * b, axis=-1)) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(2 * np.arccos(np.clip(d, -1, 1)))


def rotation_keys(rig):
    total = 0
    channels = fcurves.Channels.of(rig)
    for fcurve in channels.fcurves:
        if "rotation" in fcurve.data_path:
            total += len(fcurve.keyframe_points)
    return total


def select_all_bones(rig, names):
    for pb in rig.pose.bones:
        if bpy.app.version >= (5, 0, 0):
            pb.select = pb.name in names
        else:
            pb.bone.select = pb.name in names


def enable_rigify():
    import addon_utils
    addon_utils.enable("rigify", default_set=True)
    return hasattr(bpy.ops.pose, "convert_rotation")


def run_scene(label, build, mode, folder):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    rig = build()
    action = fcurves.active_action(rig)
    frames = [r for r in action.frame_range]
    times = np.arange(math.ceil(frames[0]) * SUBFRAMES, math.floor(frames[1]) * SUBFRAMES + 1) / SUBFRAMES
    names = {pb.name for pb in rig.pose.bones if pb.rotation_mode != mode}
    before = played(rig, times)
    keys_before = rotation_keys(rig)
    path = os.path.join(folder, label.replace(" ", "_") + ".blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)

    quatcurve_blender.register()
    try:
        select_all_bones(rig, names)
        start = time.perf_counter()
        result = bpy.ops.quatcurve.convert(rotation_mode=mode, tolerance=TOL, subframes=SUBFRAMES)
        ours_s = time.perf_counter() - start
        assert result == {"FINISHED"}, result
        ours = angles(played(rig, times), before)
        keys_ours = rotation_keys(rig)
    finally:
        quatcurve_blender.unregister()

    bpy.ops.wm.open_mainfile(filepath=path)
    theirs_line = "Rigify's pose.convert_rotation is not available"
    if enable_rigify():
        rig = next(o for o in bpy.data.objects if o.type == "ARMATURE")
        bpy.context.view_layer.objects.active = rig
        bpy.ops.object.mode_set(mode="POSE")
        select_all_bones(rig, names)
        start = time.perf_counter()
        try:
            bpy.ops.pose.convert_rotation(target_rotation_mode=mode, affected_bones="SELECT",
                                          affected_actions="SINGLE", selected_action=fcurves.active_action(rig).name)
            theirs_s = time.perf_counter() - start
            theirs = angles(played(rig, times), before)
            at_keys = np.isin(times, np.unique(np.concatenate(
                [fcurves.read_keys(f)[0] for f in fcurves.Channels.of(rig).fcurves if "rotation" in f.data_path])))
            # Bones whose keys Rigify converts right (at its keys within 0.01°): its drift between keys.
            right = theirs[at_keys].max(axis=0) < 0.01
            between = ("%d bones right at the keys: max %.2f° between them" % (right.sum(), theirs[:, right].max())
                       if right.any() else "no bone right at its keys")
            theirs_line = ("Rigify: max %.2f° (median bone %.2f°; at its keys %.4f°; %s), %d -> %d keys, %.2f s "
                           "(quatcurve.convert's time / Rigify's: %.2f)"
                           % (theirs.max(), np.median(theirs.max(axis=0)), theirs[at_keys].max(), between,
                              keys_before, rotation_keys(rig), theirs_s, ours_s / max(theirs_s, 1e-9)))
        except RuntimeError as error:
            theirs_line = "Rigify failed: " + " ".join(str(error).split())[:200]
    print("%s (%d bones -> %s, frames %g-%g, %d samples each):\n  quatcurve.convert: max %.4f° (median bone "
          "%.4f°), %d -> %d keys, %.2f s\n  %s" % (
              label, len(names), mode, times[0], times[-1], len(times), ours.max(), np.median(ours.max(axis=0)),
              keys_before, keys_ours, ours_s, theirs_line))


def main():
    print("Blender %s, tolerance %g°, %d subframes" % (bpy.app.version_string, TOL, SUBFRAMES))
    with tempfile.TemporaryDirectory() as folder:
        run_scene("Euler Bezier", euler_scene, "QUATERNION", folder)
        run_scene("quaternion Bezier", quaternion_scene, "XYZ", folder)
        if os.path.exists(MOCAP):
            run_scene("mocap", mocap_scene, "QUATERNION", folder)
        else:
            print("mocap: %s missing, skipped" % os.path.relpath(MOCAP, ROOT))


if __name__ == "__main__":
    smoke.run(main)
