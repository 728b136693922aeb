"""The glTF export under the distance bound against its angular export, on the shared motion-capture
clips imported by Blender's BVH importer (quaternion bones; one run, prints a table; not a timed test).

Per clip (whole clip, every frame of its action), at a unit scale of 0.01 (the clips are in
centimetres), each export written by gltf.export into a .glb:
- default: Blender's own exporter sampling every frame (the oracle's reference file);
- DISTANCE: gltf.ExportSettings(error='DISTANCE') at its default, 1 mm with a 10 cm shell (0.1 and
  10 scene units); its own reported worst distance (result.distances) is printed beside the measured one;
- ANGLE at 0.1°: gltf.ExportSettings(tolerance=0.1);
- ANGLE within 1 mm: the largest tolerance whose measured worst distance stays within the same 1 mm
  (bisection of log(tolerance) in [0.002°, 0.2°]; the run with the fewest keys among those within).
Rotation keys are counted in the file (every rotation sampler's keys). Every worst distance is
measured independently of the add-on by tests/blender/test_gltf_distance.py's oracle: the file
played as the glTF specification says, each bone's virtual vertices (tail and the three shell
points) against Blender's own pose_bone.matrix at every frame of the exported range. Times are the
whole gltf.export call (Blender's exporter included), wall clock.

Run with any Blender:
  ~/.cache/quatcurve/bpy-5.0.1/bin/python tests/bench/bench_gltf_distance_blender.py
  blender -b --factory-startup --python tests/bench/bench_gltf_distance_blender.py
`--smoke` (tests/bench/smoke.py): the smaller clip (freebvh) alone, 2 bisection steps instead of 8.
"""
import math
import os
import sys
import tempfile
import time

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))  # the oracle (conftest registers nothing at import)
sys.path.insert(0, HERE)

import bench_reduce_blender as base  # noqa: E402  (import_clip)
import smoke  # noqa: E402
from quatcurve_blender import gltf  # noqa: E402
from test_gltf_distance import GlbNodes, Oracle  # noqa: E402

MOCAP = os.path.normpath(os.path.join(ROOT, "..", "shared", "data", "mocap"))
CLIPS = ("freebvh.bvh",) if smoke.SMOKE else ("mocapbank.bvh", "freebvh.bvh")
SCALE = 0.01             # scene unit scale: the clips are in centimetres
DISTANCE, SHELL = 0.001 / SCALE, 0.1 / SCALE   # the DISTANCE export's defaults, in scene units
STEPS = 2 if smoke.SMOKE else 8


def measured_export(oracle, path, settings):
    """(rotation keys in the file, measured worst distance in scene units, seconds, ExportResult)."""
    start = time.perf_counter()
    result = gltf.export(bpy.context.scene, path, settings)
    seconds = time.perf_counter() - start
    glb = GlbNodes(path)
    return glb.rotation_keys, oracle.worst(glb, SHELL)[0], seconds, result


def largest_within(run, lo, hi):
    """(tolerance, (keys, worst, …)) of the run with the fewest keys among those within DISTANCE,
    bisecting log(tolerance) in [lo, hi]."""
    best = (lo, run(lo))
    assert best[1][1] <= DISTANCE, "ANGLE at %g° is already beyond the distance" % lo
    lo, hi = math.log(lo), math.log(hi)
    for _ in range(STEPS):
        mid = 0.5 * (lo + hi)
        r = run(math.exp(mid))
        if r[1] <= DISTANCE:
            lo = mid
            if r[0] < best[1][0]:
                best = (math.exp(mid), r)
        else:
            hi = mid
    return best


def clip_row(name, folder):
    """The table's row of one clip."""
    path = os.path.join(MOCAP, name)
    if not os.path.exists(path):
        return "| %s | skipped: %s not found |" % (name, os.path.relpath(path, ROOT))
    bpy.context.scene.unit_settings.scale_length = SCALE
    arm, _ = base.import_clip(path)
    scene = bpy.context.scene
    scene.unit_settings.scale_length = SCALE
    oracle = Oracle(arm, os.path.join(folder, "default.glb"))
    out = os.path.join(folder, "out.glb")
    dk, de, ds, result = measured_export(oracle, out, gltf.ExportSettings(error="DISTANCE"))
    reported = max(d.distance for d in result.distances)
    ak, ae, as_, _ = measured_export(oracle, out, gltf.ExportSettings(tolerance=0.1))
    tolerance, (bk, be, bs, _) = largest_within(
        lambda a: measured_export(oracle, out, gltf.ExportSettings(tolerance=a)), 0.002, 0.2)
    mm = 1000 * SCALE
    return (f"| {name} | {len(arm.data.bones)} × {len(oracle.frames)} | {oracle.default.rotation_keys:,} | "
            f"{ak:,}, {ae * mm:.3f} mm, {as_:.2f} s | {tolerance:.4f}°, {bk:,}, {be * mm:.3f} mm, {bs:.2f} s | "
            f"{dk:,}, {de * mm:.3f} mm (reported {reported * mm:.3f} mm), {ds:.2f} s | "
            f"{100 * (1 - dk / bk):.1f} % | {ds / as_:.2f}× |")


def main():
    if not any(os.path.exists(os.path.join(MOCAP, name)) for name in CLIPS):
        print("skipped: %s is absent (the shared mocap clips)" % os.path.relpath(MOCAP, ROOT))
        return 0
    with tempfile.TemporaryDirectory(prefix="bench-gltf-") as folder:
        rows = [clip_row(name, folder) for name in CLIPS]  # the exporter logs as it goes: the table after
    print("Blender %s; unit scale %g; DISTANCE bound %g mm, shell %g cm; worst distances measured by the oracle "
          "(tests/blender/test_gltf_distance.py); whole clips; %d bisection steps" % (
              bpy.app.version_string, SCALE, DISTANCE * SCALE * 1000, SHELL * SCALE * 100, STEPS))
    print("| clip | bones × frames | default: rotation keys | ANGLE 0.1°: keys, worst, s | ANGLE within 1 mm: "
          "tolerance, keys, worst, s | DISTANCE 1 mm: keys, worst, s | DISTANCE fewer keys than ANGLE within 1 mm "
          "| time DISTANCE / ANGLE 0.1° |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    smoke.run(main)
