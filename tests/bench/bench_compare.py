"""Benchmark: the demo's comparison, plots included, next to the bake of the same scene, in one run.

    blender --background --factory-startup --python tests/bench/bench_compare.py [-- BVH]
    ~/.cache/quatcurve/bpy-4.5.15/bin/python tests/bench/bench_compare.py [BVH]

The scene is the demo's (build_scripts/demo_scene.py: FixedAngle, Spin, Hemisphere and, when the
BVH file is present — default ../shared/data/mocap/mocapbank.bvh — the 19-bone motion-capture
armature, 455 frames). It is compared as the demo does (`--compare --subframes 4`: every target,
every engine method, Blender's modes) and each stage is timed as the CLI runs it: the metrics
(compare.compare), the plots drawn (plot.py), the image datablocks saved as PNG by Blender and packed
(compare.save_plots), and the JSON report (compare.write_report). Then the same targets are baked with SPLINE_C2, as
the demo's last bake. Target: the whole comparison ≤ 3 s. Not a timed test: it only prints.
`--smoke` (tests/bench/smoke.py): the same stages once, one sample per frame.
"""

import os
import sys
import tempfile
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.join(ROOT, "build_scripts"))
sys.path.insert(0, os.path.join(ROOT, "tests", "bench"))

import demo_scene  # noqa: E402
import smoke  # noqa: E402
from quatcurve_blender import bake, compare, targets  # noqa: E402

DEFAULT_BVH = os.path.join(os.path.dirname(ROOT), "shared", "data", "mocap", "mocapbank.bvh")
SUBFRAMES = 1 if smoke.SMOKE else 4


def timed(label, timings, function, *args):
    """Runs function(*args), recording (label, wall seconds, CPU seconds of this process): on a
    shared machine the CPU time is the steadier figure."""
    begin, cpu = time.perf_counter(), time.process_time()
    result = function(*args)
    timings.append((label, time.perf_counter() - begin, time.process_time() - cpu))
    return result


def main(bvh):
    folder = tempfile.mkdtemp(prefix="quatcurve_bench_compare_")
    scene_path = os.path.join(folder, "demo_scene.blend")
    demo_scene.build(scene_path, bvh if os.path.exists(bvh) else None)
    found = targets.animated_targets(bpy.context.scene.objects)

    timings = []
    report = timed("metrics (compare.compare)", timings, compare.compare, found,
                   compare.CompareSettings(subframes=SUBFRAMES))
    timed("plots drawn (plot.py)", timings, lambda: [t.render_plot() for t in report.targets])
    report_path = os.path.join(folder, "report.json")
    timed("images + PNGs (save_plots)", timings, compare.save_plots, report, report_path)
    timed("JSON report (write_report)", timings, compare.write_report, report, report_path)
    total = sum(t[1] for t in timings)
    total_cpu = sum(t[2] for t in timings)

    begin, cpu = time.perf_counter(), time.process_time()
    result = bake.bake(found, bake.BakeSettings(method="SPLINE_C2"))
    baked, baked_cpu = time.perf_counter() - begin, time.process_time() - cpu

    print("bench_compare: Blender %s, %d targets (%s), %d sources, samples every 1/%d frame; files in %s"
          % (bpy.app.version_string, len(report.targets), "with motion capture" if os.path.exists(bvh)
             else "no motion capture: %s missing" % bvh, sum(len(t.sources) for t in report.targets), SUBFRAMES,
             folder))
    print("  %-34s %9s %9s" % ("", "wall", "CPU"))
    for label, seconds, cpu in timings:
        print("  %-34s %7.3f s %7.3f s" % (label, seconds, cpu))
    print("  %-34s %7.3f s %7.3f s   (target <= 3 s)" % ("compare, plots included", total, total_cpu))
    print("  %-34s %7.3f s %7.3f s   (%s keys; compare / bake = %.0f wall, %.0f CPU)"
          % ("bake SPLINE_C2, same targets", baked, baked_cpu, f"{result.keys_written:,}", total / baked,
             total_cpu / max(baked_cpu, 1e-9)))


if __name__ == "__main__":
    paths = [a for a in smoke.script_args() if a != "--smoke"]
    smoke.run(main, os.path.abspath(paths[0]) if paths else DEFAULT_BVH)
