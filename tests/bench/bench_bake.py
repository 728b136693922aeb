"""Benchmark: baking a 100-bone armature with quatcurve.bake against Blender's own nla.bake.

    blender --background --factory-startup --python tests/bench/bench_bake.py
    ~/.cache/quatcurve/bpy-4.5.15/bin/python tests/bench/bench_bake.py

Ours: 100 bones keyed (quaternions) every 10 frames over 10,000 frames, baked dense (every frame)
with SQUAD into quaternions through the operator — 1,000,100 bone-frames. Blender's: bpy.ops.nla.bake
(pose, visual keying, selected bones) on the same kind of rig over 300 frames, in the same run.
Prints seconds, bone-frames per second and the ratio. Targets: ours ≤ 1.0 s, ratio ≥ 100×.
Not a timed test: it only prints. `--smoke` (tests/bench/smoke.py): 2 bones, ours over 100 frames,
Blender's over 10.
"""

import os
import sys
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))
sys.path.insert(0, os.path.join(ROOT, "tests", "bench"))

import quatcurve_blender  # noqa: E402
import rigs  # noqa: E402
import smoke  # noqa: E402

BONES = 2 if smoke.SMOKE else 100
KEY_EVERY = 10
OURS_LAST = 100 if smoke.SMOKE else 10_000  # ours: frames 0..OURS_LAST
THEIRS_FRAMES = 10 if smoke.SMOKE else 300


def build_rig(name, last_frame, seed):
    return rigs.build_rig(name, last_frame, seed, BONES, KEY_EVERY)


def clear_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def bench_ours():
    clear_scene()
    build_rig("Ours", OURS_LAST, seed=1)
    bpy.context.view_layer.update()  # the rig's own first evaluation is not the bake's cost
    begin = time.perf_counter()
    result = bpy.ops.quatcurve.bake(method="SQUAD", rotation_mode="QUATERNION", step=1)
    seconds = time.perf_counter() - begin
    assert result == {"FINISHED"}, result
    settings = bpy.context.scene.quatcurve
    bone_frames = settings.last_targets * (OURS_LAST + 1)
    return seconds, bone_frames, settings.last_keys


def bench_blender():
    clear_scene()
    build_rig("Theirs", THEIRS_FRAMES, seed=2)
    bpy.context.view_layer.update()
    begin = time.perf_counter()
    bpy.ops.nla.bake(frame_start=0, frame_end=THEIRS_FRAMES - 1, step=1, only_selected=True, visual_keying=True,
                     bake_types={"POSE"})
    seconds = time.perf_counter() - begin
    return seconds, BONES * THEIRS_FRAMES


def main():
    quatcurve_blender.register()
    ours_s, ours_bf, keys = bench_ours()
    theirs_s, theirs_bf = bench_blender()
    ours_rate, theirs_rate = ours_bf / ours_s, theirs_bf / theirs_s
    print("Blender %s" % bpy.app.version_string)
    print("quatcurve.bake SQUAD  %d bones x %s frames: %.3f s, %s keys, %.0f K bone-frames/s (target <= 1.0 s)"
          % (BONES, f"{OURS_LAST + 1:,}", ours_s, f"{keys:,}", ours_rate / 1e3))
    print("nla.bake visual pose  %d bones x %d frames:    %.3f s, %.1f K bone-frames/s"
          % (BONES, THEIRS_FRAMES, theirs_s, theirs_rate / 1e3))
    print("ratio: %.0fx (target >= 100x)" % (ours_rate / theirs_rate))
    quatcurve_blender.unregister()


smoke.run(main)
