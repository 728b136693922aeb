"""Peak memory of the big bake, in a fresh Blender (run by tests/blender/test_session.py):

    blender --background --factory-startup --python tests/blender/sessions/memory_bake.py -- RESULT.json
    PYTHON_WITH_BPY tests/blender/sessions/memory_bake.py RESULT.json

Builds a 100-bone rig with quaternion keys every 10 frames over 10,000 frames (written in bulk),
then bakes it dense with SQUAD into quaternions through the operator (1,000,100 bone-frames,
4,000,400 keys). Memory by the process's own accounting: resource.getrusage(RUSAGE_SELF).ru_maxrss
(peak RSS, KiB on Linux) before and after the bake, and the current RSS before it (/proc/self/statm),
so `added_peak_mib` = peak after − current before bounds what the bake added at its peak."""

import json
import os
import resource
import sys
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))

import quatcurve_blender  # noqa: E402
import rigs  # noqa: E402

RESULT = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else sys.argv[1]
BONES, LAST_FRAME, KEY_EVERY = 100, 10_000, 10


def peak_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def current_mib():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2.0 ** 20


def build_rig():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    rigs.build_rig("Rig", LAST_FRAME, 3, BONES, KEY_EVERY)


def main():
    quatcurve_blender.register()
    build_rig()
    bpy.context.view_layer.update()
    peak_before, current_before = peak_mib(), current_mib()
    begin = time.perf_counter()
    result = bpy.ops.quatcurve.bake(method="SQUAD", rotation_mode="QUATERNION", step=1)
    seconds = time.perf_counter() - begin
    peak_after = peak_mib()
    settings = bpy.context.scene.quatcurve
    out = {"blender": bpy.app.version_string, "result": sorted(result), "seconds": seconds,
           "targets": settings.last_targets, "keys": settings.last_keys,
           "peak_before_mib": peak_before, "current_before_mib": current_before, "peak_after_mib": peak_after,
           "peak_delta_mib": peak_after - peak_before, "added_peak_mib": peak_after - current_before}
    with open(RESULT, "w") as f:
        json.dump(out, f, indent=1)


main()
# Skip the interpreter's teardown: the bpy 4.5 module, freeing 4 million keys after its leak
# detector ran, prints for minutes at exit. The result is written; nothing else is pending.
sys.stdout.flush()
os._exit(0)
