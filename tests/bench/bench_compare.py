"""Benchmark: the demo's comparison, plots included, next to the bake of the same scene, in one run.

    blender --background --factory-startup --python tests/bench/bench_compare.py [-- BVH]
    ~/.cache/quatcurve/bpy-4.5.15/bin/python tests/bench/bench_compare.py [BVH]

The scene is the demo's (build_scripts/demo_scene.py: FixedAngle, Spin, Hemisphere and, when the
BVH file is present — default ../shared/data/mocap/mocapbank.bvh — the 19-bone motion-capture
armature, 455 frames). It is compared as the demo does (`--compare --subframes 4`: every target,
every engine method, Blender's modes) and each stage is timed: the metrics (compare.compare), the
plots drawn (plot.py) and turned into image datablocks (compare.make_images), and the JSON report
with one PNG per target (compare.write_report). Then the same targets are baked with SPLINE_C2, as
the demo's last bake. Target: the whole comparison ≤ 3 s. Not a timed test: it only prints.
"""

import os
import sys
import tempfile
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.join(ROOT, "build_scripts"))

import demo_scene  # noqa: E402
from quatcurve_blender import bake, compare, targets  # noqa: E402

DEFAULT_BVH = os.path.join(os.path.dirname(ROOT), "shared", "data", "mocap", "mocapbank.bvh")


def timed(label, timings, function, *args):
    begin = time.perf_counter()
    result = function(*args)
    timings.append((label, time.perf_counter() - begin))
    return result


def main(bvh):
    folder = tempfile.mkdtemp(prefix="quatcurve_bench_compare_")
    scene_path = os.path.join(folder, "demo_scene.blend")
    demo_scene.build(scene_path, bvh if os.path.exists(bvh) else None)
    found = targets.animated_targets(bpy.context.scene.objects)

    timings = []
    report = timed("metrics (compare.compare)", timings, compare.compare, found, compare.CompareSettings(subframes=4))
    timed("plots drawn (plot.py)", timings, lambda: [t.render_plot() for t in report.targets])
    timed("image datablocks (make_images)", timings, compare.make_images, report)
    timed("report + PNGs (write_report)", timings, compare.write_report, report, os.path.join(folder, "report.json"))
    total = sum(seconds for _, seconds in timings)

    begin = time.perf_counter()
    result = bake.bake(found, bake.BakeSettings(method="SPLINE_C2"))
    baked = time.perf_counter() - begin

    print("bench_compare: Blender %s, %d targets (%s), %d sources, samples every 1/4 frame; files in %s"
          % (bpy.app.version_string, len(report.targets), "with motion capture" if os.path.exists(bvh)
             else "no motion capture: %s missing" % bvh, sum(len(t.sources) for t in report.targets), folder))
    for label, seconds in timings:
        print("  %-34s %7.3f s" % (label, seconds))
    print("  %-34s %7.3f s   (target <= 3 s)" % ("compare, plots included", total))
    print("  %-34s %7.3f s   (%s keys; compare / bake = %.1f)"
          % ("bake SPLINE_C2, same targets", baked, f"{result.keys_written:,}", total / baked))


if __name__ == "__main__":
    argv = sys.argv  # Blender's binary: its own options, then "--" and ours; the bpy module: the script's
    args = argv[argv.index("--") + 1:] if "--" in argv else (argv[1:] if argv[0].endswith(".py") else [])
    main(os.path.abspath(args[0]) if args else DEFAULT_BVH)
