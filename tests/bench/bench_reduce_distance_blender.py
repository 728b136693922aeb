"""The add-on's reduction under the distance bound against its angular reduction and Blender's
Decimate, on the shared motion-capture clips imported by Blender's BVH importer (quaternion bones;
one run, prints a table; not a timed test).

Per clip, at a unit scale of 0.01 (the clips are in centimetres) and BEZIER per-channel keys:
- distance: reduce.reduce(error='DISTANCE') at its default, 1 mm with a 10 cm shell;
- angular: reduce.reduce(error='ANGLE') — what the add-on runs, reduce_keys_proved — at the largest
  tolerance whose worst virtual-vertex error stays within the same 1 mm (bisection), and at 0.1°;
- Decimate: graph.decimate in ERROR mode at the largest margin within the same 1 mm (bisection).
Every worst error is measured on Blender's evaluation of the written F-curves (every bone's channels
read back through skeleton.read_armature), posed natively (Skeleton.vertex_error) against the import.

Run with any Blender:
  ~/.cache/quatcurve/bpy-5.0.1/bin/python tests/bench/bench_reduce_distance_blender.py
  blender -b --factory-startup --python tests/bench/bench_reduce_distance_blender.py
`--smoke` (tests/bench/smoke.py): the smaller clip (freebvh) alone, 2 bisection steps instead of 8.
"""
import math
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, HERE)

import bench_reduce_blender as base  # noqa: E402  (import_clip, graph_editor_context, fresh_copy)
import smoke  # noqa: E402
from quatcurve_blender import fcurves, native, reduce, skeleton, targets  # noqa: E402

CLIPS = ("freebvh.bvh",) if smoke.SMOKE else ("mocapbank.bvh", "freebvh.bvh")
SCALE = 0.01             # scene unit scale: the clips are in centimetres
DISTANCE, SHELL = 0.001 / SCALE, 0.1 / SCALE
STEPS = 2 if smoke.SMOKE else 8


def motion(arm):
    """(ReadSkeleton of every bone, (B, N, 4) quaternions) of the armature's active action."""
    read = skeleton.read_armature(arm, [])
    qc = native.require()
    return read, np.stack([qc.channels_to_quats(v, m) for m, v in read.rotations])


def measured(arm, read0, q0):
    """(rotation keys, worst virtual-vertex distance in scene units) of the active action."""
    read, q = motion(arm)
    assert np.array_equal(read.frames, read0.frames)
    error = read0.skeleton().vertex_error((read0.locations, q0, read0.scales), (read.locations, q, read.scales), SHELL)
    return int(read.keys_before.sum()), error.distance


def run_reduce(arm, original, bones, **settings):
    """(keys, worst, seconds) of the add-on's reduction of every bone into a copy of the action."""
    copy = base.fresh_copy(arm, original, "copy")
    result = reduce.reduce([targets.Target(arm, b) for b in bones], reduce.ReduceSettings(**settings))
    out = measured(arm, *run_reduce.reference) + (result.seconds,)
    written = fcurves.active_action(arm)
    fcurves.assign_action(arm, original)
    fcurves.remove_action(written)
    fcurves.remove_action(copy)
    return out


def run_decimate(arm, original, margin):
    action = base.fresh_copy(arm, original, "decimate")
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj is arm)
    bpy.context.view_layer.objects.active = arm
    with bpy.context.temp_override(**base.graph_editor_context()):
        bpy.ops.graph.select_all(action="SELECT")
        bpy.ops.graph.decimate(mode="ERROR", remove_error_margin=margin)
    out = measured(arm, *run_reduce.reference)
    fcurves.assign_action(arm, original)
    fcurves.remove_action(action)
    return out


def largest_within(run, lo, hi):
    """The best (keys, worst, …) among the runs within DISTANCE, bisecting log(parameter) in [lo, hi]."""
    best = run(lo)
    assert best[1] <= DISTANCE, "fails the distance even at %g" % lo
    lo, hi = math.log(lo), math.log(hi)
    for _ in range(STEPS):
        mid = 0.5 * (lo + hi)
        r = run(math.exp(mid))
        if r[1] <= DISTANCE:
            lo, best = mid, min(best, r)
        else:
            hi = mid
    return math.exp(lo), best


def clip_row(name):
    bpy.context.scene.unit_settings.scale_length = SCALE
    arm, original = base.import_clip(os.path.join(ROOT, "..", "shared", "data", "mocap", name))
    bpy.context.scene.unit_settings.scale_length = SCALE
    read0, q0 = motion(arm)
    run_reduce.reference = (read0, q0)
    bones = [t.bone for t, r in zip(read0.targets, read0.keys_before) if r]
    dense = int(read0.keys_before.sum())
    dk, de, ds = run_reduce(arm, original, bones, error="DISTANCE")
    angle, (ak, ae, as_) = largest_within(
        lambda a: run_reduce(arm, original, bones, error="ANGLE", tolerance=a), 0.002, 0.2)
    _, d01, s01 = run_reduce(arm, original, bones, error="ANGLE", tolerance=0.1)
    margin, (mk, me) = largest_within(lambda m: run_decimate(arm, original, m), 1e-6, 1e-1)
    mm = 1000 * SCALE
    print(f"| {name} | {len(read0.names)} × {len(read0.frames)} | {dense:,} | {dk:,}, {de * mm:.3f} mm, {ds:.2f} s | "
          f"{angle:.4f}°, {ak:,}, {ae * mm:.3f} mm, {as_:.2f} s | {margin:.2g}, {mk:,}, {me * mm:.3f} mm | "
          f"{100 * (1 - dk / ak):.1f} % | {100 * (1 - dk / mk):.1f} % | {d01 * mm:.2f} mm, {s01:.2f} s | "
          f"{ds / as_:.2f}× |", flush=True)


def main():
    if not os.path.exists(os.path.join(ROOT, "..", "shared", "data", "mocap", CLIPS[0])):
        print("skipped: ../shared/data/mocap is absent")
        return 0
    print("| clip | bones × frames | rotation keys | distance 1 mm: keys, worst, s | angular within 1 mm: angle, "
          "keys, worst, s | Decimate within 1 mm: margin, keys, worst | fewer than angular | fewer than Decimate "
          "| angular at 0.1°: worst, s | time vs angular |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in CLIPS:
        clip_row(name)
    return 0


if __name__ == "__main__":
    smoke.run(main)
