"""Key reduction against Blender's Decimate on real motion capture (one run, prints a table).

Imports ../shared/data/mocap/mocapbank.bvh with Blender's own BVH importer as quaternion bones, then
at 0.1°:
- ours: quatcurve.reduce_keys per bone (BEZIER per-channel, and the other variants for reference),
  written with the add-on's F-curve adapter into a copy of the action;
- Blender's graph.decimate in ERROR mode on another copy, its margin searched for the fewest keys
  whose max angular error is at most 0.1°.
Every error is measured with Blender's own evaluation of the rotation F-curves at every frame (then
normalized), against the imported keys. Keys are counted as Blender counts them: keyframe_points of
the rotation_quaternion F-curves.

Run with any Blender:
  ~/.cache/quatcurve/bpy-4.5.15/bin/python tests/bench/bench_reduce_blender.py
  blender -b --factory-startup --python tests/bench/bench_reduce_blender.py
`--smoke` (tests/bench/smoke.py): the clip's first 60 frames, Decimate at 4 margins.
"""
import builtins
import math
import os
import sys
import tempfile
import time

import bpy
import addon_utils  # importable once bpy is
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, HERE)

import smoke  # noqa: E402
from quatcurve_blender import fcurves, native  # noqa: E402

CLIP = os.path.normpath(os.path.join(ROOT, "..", "shared", "data", "mocap", "mocapbank.bvh"))
TOL_DEG = 0.1
SMOKE_FRAMES = 60
# The margin search: bisection steps, then points scanned around the margin found.
SEARCH_STEPS, SCAN_POINTS = (1, 2) if smoke.SMOKE else (16, 13)


def first_frames(path, frames, folder):
    """A copy of the BVH file at `path` with its first `frames` frames, in `folder`."""
    with open(path) as f:
        head, motion = f.read().split("MOTION", 1)
    lines = [line for line in motion.strip().splitlines() if line.strip()]  # Frames:, Frame Time:, rows
    out = os.path.join(folder, os.path.basename(path))
    with open(out, "w") as f:
        f.write(head + "MOTION\nFrames: %d\n%s\n" % (frames, lines[1].strip()))
        f.writelines(line + "\n" for line in lines[2:2 + frames])
    return out


def import_clip(path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("io_anim_bvh", default_set=True)
    # Blender 3.x's importer opens files with mode 'rU', which Python 3.11 rejects: it gets an `open`
    # that drops the 'U' (as build_scripts/demo_scene.py does; the importer is otherwise unchanged).
    from io_anim_bvh import import_bvh as importer

    def open_text(file, mode="r", *args, **kwargs):
        return builtins.open(file, mode.replace("U", ""), *args, **kwargs)

    importer.open = open_text
    bpy.ops.import_anim.bvh(filepath=path, rotate_mode="QUATERNION", frame_start=1,
                            use_fps_scale=False, update_scene_fps=False, update_scene_duration=True)
    arm = next(o for o in bpy.data.objects if o.type == "ARMATURE")
    return arm, fcurves.active_action(arm)


def rotation_curves(arm, action):
    """{bone name: [w, x, y, z] F-curves} in `action` (bones whose rotation is animated)."""
    channels = fcurves.Channels.of(arm, action)
    out = {}
    for bone in arm.pose.bones:
        found = channels.find_all('pose.bones["%s"].rotation_quaternion' % bone.name, 4)
        if all(f is not None for f in found):
            out[bone.name] = found
    return out


def measure(arm, action, frames, reference):
    """(rotation keys, max angular error in degrees) of `action` under Blender's evaluation."""
    curves = rotation_curves(arm, action)
    keys, worst = 0, 0.0
    for name, ref in reference.items():
        fc = curves[name]
        keys += sum(fcurves.key_count(f) for f in fc)
        q = np.stack([fcurves.evaluate(f, frames) for f in fc], axis=1)
        worst = max(worst, float(np.degrees(native.require().angle_between(q, ref)).max()))
    return keys, worst


def fresh_copy(arm, original, name):
    action = fcurves.copy_action(original, name)
    fcurves.assign_action(arm, action)
    return action


def ours(arm, original, frames, reference, interpolation, synchronized, qc):
    t0 = time.perf_counter()
    action = fresh_copy(arm, original, "ours")
    curves = rotation_curves(arm, action)
    for name, ref in reference.items():
        r = qc.reduce_keys(frames, ref, math.radians(TOL_DEG), interpolation, synchronized)
        for c, fc in enumerate(curves[name]):
            if interpolation == "BEZIER":
                ch = r.channels[c]
                fcurves.write_keys(fc, ch.frames, ch.values, "BEZIER", ch.handle_left, ch.handle_right)
            else:
                idx = np.asarray(r if synchronized else r[c])
                fcurves.write_keys(fc, frames[idx], ref[idx, c], "LINEAR")
    seconds = time.perf_counter() - t0
    keys, err = measure(arm, action, frames, reference)
    fcurves.remove_action(action)
    return keys, err, seconds


def graph_editor_context():
    win = bpy.context.window_manager.windows[0]
    area = win.screen.areas[0]
    area.type = "GRAPH_EDITOR"
    region = next(r for r in area.regions if r.type == "WINDOW")
    # Show every bone's channels, not only those of selected bones.
    area.spaces.active.dopesheet.show_only_selected = False
    area.spaces.active.dopesheet.show_hidden = True
    return dict(window=win, screen=win.screen, area=area, region=region,
                space_data=area.spaces.active)


def decimate(arm, original, frames, reference, margin):
    action = fresh_copy(arm, original, "decimate")
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj is arm)
    bpy.context.view_layer.objects.active = arm
    t0 = time.perf_counter()
    with bpy.context.temp_override(**graph_editor_context()):
        bpy.ops.graph.select_all(action="SELECT")
        bpy.ops.graph.decimate(mode="ERROR", remove_error_margin=margin)
    seconds = time.perf_counter() - t0
    keys, err = measure(arm, action, frames, reference)
    fcurves.remove_action(action)
    return keys, err, seconds


def search_decimate(arm, original, frames, reference):
    """The margin giving the fewest rotation keys with max error <= TOL_DEG: bisection on log(margin)
    for the largest passing margin, then a scan around it (Decimate is not strictly monotone)."""
    tried = {}

    def run(m):
        if m not in tried:
            tried[m] = decimate(arm, original, frames, reference, m)
        return tried[m]

    lo, hi = math.log(1e-6), math.log(1e-1)
    assert run(math.exp(lo))[1] <= TOL_DEG, "Decimate fails the bound even at the smallest margin"
    for _ in range(SEARCH_STEPS):
        mid = 0.5 * (lo + hi)
        if run(math.exp(mid))[1] <= TOL_DEG:
            lo = mid
        else:
            hi = mid
    for f in np.linspace(0.7, 1.3, SCAN_POINTS):
        run(math.exp(lo) * f)
    passing = [(k, e, s, m) for m, (k, e, s) in tried.items() if e <= TOL_DEG]
    keys, err, seconds, margin = min(passing)
    return keys, err, seconds, margin, len(tried)


def main():
    if not os.path.exists(CLIP):
        print("skipped: %s is absent (the shared mocap clips)" % os.path.relpath(CLIP, ROOT))
        return
    qc = native.require()
    with tempfile.TemporaryDirectory() as folder:
        arm, original = import_clip(first_frames(CLIP, SMOKE_FRAMES, folder) if smoke.SMOKE else CLIP)
    original.use_fake_user = True
    curves = rotation_curves(arm, original)
    frames = fcurves.key_frames(curves[next(iter(curves))])
    reference = {name: np.stack([fcurves.read_keys(f)[1] for f in fc], axis=1)
                 for name, fc in curves.items()}
    total = sum(fcurves.key_count(f) for fc in curves.values() for f in fc)
    print("Blender %s, %s: %d frames, %d bones, %d rotation keys; tolerance %.2f deg"
          % (bpy.app.version_string, os.path.basename(CLIP), len(frames), len(curves), total, TOL_DEG))
    rows = []
    for interpolation, synchronized in (("BEZIER", False), ("BEZIER", True), ("LINEAR", True),
                                        ("LINEAR", False)):
        k, e, s = ours(arm, original, frames, reference, interpolation, synchronized, qc)
        rows.append(("quatcurve %s %s" % (interpolation, "synchronized" if synchronized
                                          else "per-channel"), k, e, s))
    dk, de, ds, margin, trials = search_decimate(arm, original, frames, reference)
    rows.append(("Decimate (ERROR, margin %.3g)" % margin, dk, de, ds))
    print("  %-36s %7s %8s %16s %8s" % ("method", "keys", "%", "max error (deg)", "seconds"))
    for name, k, e, s in rows:
        print("  %-36s %7d %7.2f%% %16.5f %8.3f" % (name, k, 100.0 * k / total, e, s))
    best = rows[0]
    print("  ratio ours (%s) / Decimate: %.3f (target <= 0.70); bound %s at every frame; "
          "Decimate margin search: %d runs" % (best[0], best[1] / dk, "holds" if best[2] <= TOL_DEG
                                               else "FAILS", trials))


if __name__ == "__main__":
    smoke.run(main)
