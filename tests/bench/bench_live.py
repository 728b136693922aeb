"""Live fit: how long a refit takes after a key change, and where the time goes (prints a table; not
a timed test).

Cases (SQUAD, 0.05°, 4 subframes, live mode on, the change made from Python, then
view_layer.update() — the depsgraph handler refits inside it, as in background mode):
- one bone with 50 keys (a key every 10 frames), one key's value changed;     target ≤ 1 ms
- a 100-bone × 1,000-frame action with a key every 10 frames (100 keys per bone):
  one key of one bone changed (100 signatures checked, 1 refit) and one key of every bone changed
  (100 refits: a whole pose keyed);                                              target ≤ 50 ms
- nothing relevant changed (a location key): the signature checks alone.
Each case is run REPEAT times (the changed value alternates), the median printed. Stages come from
live.STATS (targets: finding the fitted targets; read: the animator keys; signature; plan: the main
thread's wait for the fits — a quatcurve.FitQueue's native worker threads fit each changed target as
soon as it is read — and each fit's plan (fit.plan_of); write: keys into Blender); `native` is the CPU
time of the quatcurve calls made from Python (fit_channels, Curve; a single refit's fit runs in the
queue's next() on the main thread and does not count), measured by wrapping the module;
`other threads` the CPU time of every thread but the main one over the update (the queue's workers,
Blender's own threads; the workers of an add-on given by --addon); `cpu` is the process's CPU time
over the update (every thread: what the refit costs, less sensitive than the wall time to other jobs
on the machine).

  blender -b --factory-startup --python tests/bench/bench_live.py
  ~/.cache/quatcurve/bpy-4.5.15/bin/python tests/bench/bench_live.py

`--smoke` (tests/bench/smoke.py): each case once, the big action cut to 3 bones x 100 frames.
`--profile`: the last run of each case under cProfile (its time counts with the profiler's cost), its
top functions by own time.
`--addon DIR`: import quatcurve_blender from DIR (a folder holding it, with its module built) instead of
this tree's addon/ — the previous release's add-on, run by the same script for a before → after table:

  git archive <commit> addon | tar -x -C /tmp/before   # and copy that commit's built quatcurve*.so in
  blender -b --factory-startup --python tests/bench/bench_live.py -- --addon /tmp/before/addon
"""
import cProfile
import os
import pstats
import statistics
import sys
import time

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests", "bench"))
import smoke  # noqa: E402

ARGS = smoke.script_args()
ADDON = ARGS[ARGS.index("--addon") + 1] if "--addon" in ARGS else os.path.join(ROOT, "addon")
sys.path.insert(0, os.path.abspath(ADDON))

import quatcurve_blender  # noqa: E402
from quatcurve_blender import fcurves, fit, live, native, targets  # noqa: E402

REPEAT = 1 if smoke.SMOKE else 7
PROFILE = "--profile" in ARGS
BIG_BONES, BIG_FRAMES = (3, 100) if smoke.SMOKE else (100, 1000)
NATIVE = [0.0]


class _Timed:
    """Stands in for the native module, or a class, function or curve of it: calls add their time to
    NATIVE. Attributes are looked up on the wrapped object, so a class keeps its static constructors
    (`Curve.from_channels`) and the module its constants. A curve a call returns comes back wrapped
    (its `sample` is timed too); wrapped arguments are unwrapped, so native functions receive their
    own types (`fit_through_keys(curve, ...)`)."""

    def __init__(self, inner):
        self._inner = inner

    def __getattr__(self, name):
        value = getattr(self._inner, name)
        return _Timed(value) if callable(value) else value

    def __call__(self, *args, **kwargs):
        args = [_unwrapped(a) for a in args]
        kwargs = {k: _unwrapped(v) for k, v in kwargs.items()}
        t = time.thread_time()
        out = self._inner(*args, **kwargs)
        NATIVE[0] += time.thread_time() - t
        return _Timed(out) if type(out).__name__ == "Curve" else out


def _unwrapped(value):
    return value._inner if isinstance(value, _Timed) else value


def build_rig(name, bones, frames, every):
    """An armature with quaternion bones keyed every `every` frames over `frames` (a smooth random walk)."""
    arm = bpy.data.armatures.new(name)
    rig = bpy.data.objects.new(name, arm)
    bpy.context.scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    for i in range(bones):
        eb = arm.edit_bones.new("B%03d" % i)
        eb.head, eb.tail = (i * 0.1, 0, 0), (i * 0.1, 0, 1)
    bpy.ops.object.mode_set(mode="OBJECT")
    fcurves.new_action(rig, name + "Action")
    channels = fcurves.Channels.of(rig, create=True)
    rng = np.random.default_rng(7)
    key_frames = np.arange(1, frames + 1, every, dtype=np.float64)
    for pb in rig.pose.bones:
        pb.rotation_mode = "QUATERNION"
        q = np.cumsum(rng.normal(scale=0.15, size=(len(key_frames), 4)), axis=0) + [1, 0, 0, 0]
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        for c in range(4):
            channels.write(pb.path_from_id("rotation_quaternion"), c, key_frames, q[:, c], interpolation="BEZIER")
    return rig


def nudge(rig, bone_names, k, amount):
    """Changes the value of the k-th animator key of channel 1 of each named bone."""
    channels = fcurves.Channels.of(rig)
    for name in bone_names:
        curve = channels.find(rig.pose.bones[name].path_from_id("rotation_quaternion"), 1)
        frames, _ = fcurves.read_keys(curve)
        types = fcurves.read_key_types(curve)
        mine = np.flatnonzero(types != fit.KEY_TYPE_GENERATED)
        curve.keyframe_points[int(mine[k])].co[1] += amount


def measure(label, rig, bone_names, change=True, expect=None):
    rows = []
    for r in range(REPEAT):
        if change:
            nudge(rig, bone_names, 3, 0.02 if r % 2 == 0 else -0.02)
        else:
            rig.location = (r, 0, 0)
            rig.keyframe_insert("location", frame=r + 1)
        live.STATS.reset()
        NATIVE[0] = 0.0
        profile = cProfile.Profile() if PROFILE and r == REPEAT - 1 else None
        if profile is not None:
            profile.enable()
        t, cpu, main = time.perf_counter(), time.process_time(), time.thread_time()
        bpy.context.view_layer.update()
        total, cpu, main = time.perf_counter() - t, time.process_time() - cpu, time.thread_time() - main
        if profile is not None:
            profile.disable()
            pstats.Stats(profile).sort_stats(os.environ.get("QC_SORT", "tottime")).print_stats(int(os.environ.get("QC_ROWS", "22")))
        assert not live.STATS.errors, (label, live.STATS)
        if expect is not None:
            assert live.STATS.refits == expect, (label, live.STATS)
        rows.append((total, dict(live.STATS.seconds), NATIVE[0], live.STATS.checks, live.STATS.refits, cpu, cpu - main))
    total = statistics.median(r[0] for r in rows)
    stages = {s: statistics.median(r[1].get(s, 0.0) for r in rows) for s in ("targets", "read", "signature", "plan", "write")}
    nat = statistics.median(r[2] for r in rows)
    cpu = statistics.median(r[5] for r in rows)
    others = statistics.median(r[6] for r in rows)
    handler = sum(stages.values())
    print("%-34s %8.2f ms, cpu %7.2f ms  (handler %7.2f: targets %.2f, read %.2f, signature %.2f, plan %.2f "
          "[native %.2f, other threads %.2f], write %.2f; %d checked, %d refitted)" % (
              label, total * 1e3, cpu * 1e3, handler * 1e3, stages["targets"] * 1e3, stages["read"] * 1e3,
              stages["signature"] * 1e3, stages["plan"] * 1e3, nat * 1e3, others * 1e3, stages["write"] * 1e3,
              rows[0][3], rows[0][4]))
    return total, nat


def main():
    quatcurve_blender.register()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    native.require()
    real_require = native.require
    settings = fit.FitSettings(method="SQUAD", tolerance=0.05, subframes=4)
    one = build_rig("One", 1, 491, 10)  # 50 keys
    big = build_rig("Big", BIG_BONES, BIG_FRAMES, 10)  # a key every 10 frames (100 per bone in a full run)
    t = time.perf_counter()
    first = fit.fit([targets.Target(one, pb.name) for pb in one.pose.bones], settings)
    t1 = time.perf_counter()
    second = fit.fit([targets.Target(big, pb.name) for pb in big.pose.bones], settings)
    t2 = time.perf_counter()
    print("quatcurve live refit, Blender %s (%s), add-on %s" % (
        bpy.app.version_string, "binary" if bpy.app.binary_path else "bpy module", os.path.dirname(quatcurve_blender.__file__)))
    print("initial fit: One %.1f ms (%s); Big %.0f ms (%s)" % ((t1 - t) * 1e3, first.summary(), (t2 - t1) * 1e3,
                                                             second.summary()))
    bpy.context.scene.quatcurve_fit.live = True
    bpy.context.view_layer.update()
    native.require = lambda: _Timed(real_require())
    try:
        measure("1 bone x 50 keys, 1 key changed", one, ["B000"], expect=1)
        measure("%d bones, 1 key of 1 bone" % BIG_BONES, big, ["B%03d" % (42 % BIG_BONES)], expect=1)
        measure("%d bones, 1 key of every bone" % BIG_BONES, big, [pb.name for pb in big.pose.bones],
                expect=BIG_BONES)
        measure("%d bones, a location key" % BIG_BONES, big, [], change=False, expect=0)
    finally:
        native.require = real_require
    quatcurve_blender.unregister()


smoke.run(main)
