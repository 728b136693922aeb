"""Benchmark: bake and reduce against the physical limit of writing keys, in the Blender running it.

    blender --background --factory-startup --python tests/bench/bench_speed.py
    ~/.cache/quatcurve/bpy-4.5.15/bin/python tests/bench/bench_speed.py
    ~/.cache/quatcurve/bpy-5.0.1/bin/python tests/bench/bench_speed.py
    … -- --repeat 5 --profile     (more runs; cProfile of one bake and one reduce, by own time)
    … -- --threads 1              (worker threads of bake and reduce; default one per core)
    … -- --bake-only              (the bake, the limit and the bake's stages: no reduce, nla.bake or
                                   mocap counts, which take minutes)
    … -- --smoke                  (tests/bench/smoke.py: 2 bones x 101 frames, one run, nla.bake
                                   over 20 frames, 1 MiB settled, the profiles printed)

Everything on one rig (tests/blender/rigs.py): 100 bones keyed (quaternions) every 10 frames over
10,000 frames. Each measurement runs `--repeat` times (default 3), interleaved, and the best counts:
the machine is shared, so only ratios measured in the same run mean anything.

- bake:   bpy.ops.quatcurve.bake, SQUAD, every frame, QUATERNION output (1,000,100 bone-frames,
          4,000,400 LINEAR keys), from the rig's original action, into a new action. Printed twice:
          the whole call, and the bake's own work inside it (BakeResult.seconds: reading the
          sources, computing, writing the keys), which ends where the limit's writes end — before
          the view-layer update bpy.ops runs after every operator.
          Then `--repeat` more bakes with timers around their stages (StageTimes): reading the
          sources, copying the source action, writing the keys, the rest; reading + copying + the
          limit's writes is the floor of the bake's own work, printed as a ratio to the limit.
- limit:  the same number of LINEAR keys written the plainest bulk way, arrays prepared beforehand:
          on a fresh action of the same rig, per bone four new F-curves (in the bone's group, as a
          bake puts them) and per F-curve keyframe_points.add(n), foreach_set('co'),
          foreach_set('interpolation'). A bake cannot write its keys faster than this. Printed
          twice: the writes alone (the issue's limit), and with what a bake into a new action also
          pays: making the action and assigning it to the rig, and the view-layer update that bpy.ops
          runs after every operator (Blender evaluates the rig with the new action). Before each timed bake or reduce the rig is evaluated
          with its source action, so the update bpy.ops runs before an operator costs nothing.
Before each timed stage free memory is handed back to the system and 1 GiB is touched once
(settle_memory), so all stages start from the same allocator state and the same warm pages.
- nla.bake: Blender's own bake (pose, visual keying, selected bones) of the same kind of rig over
          300 frames; the ratio is ours over theirs in bone-frames per second.
- reduce: bpy.ops.quatcurve.reduce (0.1°, BEZIER, per channel) of the baked action (reads the dense
          keys, reduces them natively, writes the reduced keys into a new action).
- mocap:  key counts of the same reduction (native, as the operator calls it) on the shared clips
          ../shared/data/mocap/mocapbank.bvh and freebvh.bvh (skipped when missing).
Targets (issue #15): bake ≤ 1.2 × limit; reduce ≤ bake. Not a timed test: it only prints.
"""

import cProfile
import ctypes
import io
import math
import os
import pstats
import sys
import time

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))
sys.path.insert(0, os.path.join(ROOT, "tests", "python"))
sys.path.insert(0, os.path.join(ROOT, "tests", "bench"))

import quatcurve_blender  # noqa: E402
from quatcurve_blender import bake, fcurves, native, reduce, workers  # noqa: E402
import rigs  # noqa: E402
import smoke  # noqa: E402

BONES = 2 if smoke.SMOKE else 100
LAST_FRAME = 100 if smoke.SMOKE else 10_000
NLA_FRAMES = 20 if smoke.SMOKE else 300
KEY_EVERY = 10
CLIPS = ("mocapbank.bvh", "freebvh.bvh")


def options():
    argv = smoke.script_args()
    repeat = int(argv[argv.index("--repeat") + 1]) if "--repeat" in argv else (1 if smoke.SMOKE else 3)
    threads = int(argv[argv.index("--threads") + 1]) if "--threads" in argv else None
    return repeat, "--profile" in argv or smoke.SMOKE, threads, "--bake-only" in argv


def clear_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def play(rig, action):
    fcurves.assign_action(rig, action)


def drop(action):
    if action is not None and action.name in bpy.data.actions:
        fcurves.remove_action(action)


def _trimmer():
    try:
        return ctypes.CDLL("libc.so.6").malloc_trim
    except (OSError, AttributeError):  # not glibc (Blender 3.4 ships jemalloc, which keeps its pages)
        return None


_TRIM = _trimmer()


def release_free_memory():
    """Hands the memory the last stage freed back to the system (glibc's malloc_trim), so that every
    timed stage starts from the same allocator state. Writing 4 M keys touches ~290 MB of new key
    memory and Blender's evaluated copy of the new action as much again: fresh pages cost ~0.16 s in
    page faults, reused ones almost nothing, and which one a stage gets would otherwise depend on
    what the stage before it freed (bpy 4.5/5.0 use glibc malloc, which keeps part of it)."""
    if _TRIM is not None:
        _TRIM(0)


# Memory touched once before each timed stage (see settle_memory).
SETTLE_BYTES = 1 << 20 if smoke.SMOKE else 1 << 30


def settle_memory():
    """release_free_memory, then 1 GiB allocated, touched and freed. On this project's test machines
    (virtual machines whose host takes idle guest memory back) the first touch of memory the host
    took back costs ~20x a normal page fault (288 MB: 0.6 s against 0.03 s), and how much it took
    back depends on the seconds before. A stage would pay for it or not by chance; after this each
    stage pays the page faults a desktop pays (the kernel's zeroing), and only those."""
    release_free_memory()
    np.ones(SETTLE_BYTES // 8)  # allocated, written (touched) and freed
    release_free_memory()


def timed(call):
    settle_memory()
    begin = time.perf_counter()
    result = call()
    return time.perf_counter() - begin, result


def run_bake(rig, original):
    play(rig, original)
    bpy.context.view_layer.update()  # the switch back to the original is not the bake's cost
    seconds, result = timed(lambda: bpy.ops.quatcurve.bake(method="SQUAD", rotation_mode="QUATERNION", step=1))
    assert result == {"FINISHED"}, result
    keys = bpy.context.scene.quatcurve.last_keys
    own = bpy.context.scene.quatcurve.last_seconds  # BakeResult.seconds: before the update bpy.ops runs
    return seconds, own, keys, fcurves.active_action(rig)


def run_reduce(rig, baked):
    play(rig, baked)
    bpy.context.view_layer.update()
    seconds, result = timed(lambda: bpy.ops.quatcurve.reduce(tolerance=0.1, interpolation="BEZIER",
                                                             synchronized=False))
    assert result == {"FINISHED"}, result
    reduced = fcurves.active_action(rig)
    keys = sum(fcurves.key_count(f) for f in fcurves.all_fcurves(reduced)
               if f.data_path.endswith("rotation_quaternion"))
    play(rig, baked)
    drop(reduced)
    return seconds, keys


def limit_arrays(n_curves, n):
    """Per F-curve the (frame, value) float32 pairs and the LINEAR interpolation codes, made before
    the clock starts (values: a smooth unit-quaternion-like path, not that it matters to Blender)."""
    frames = np.arange(n, dtype=np.float32)
    kind = bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items["LINEAR"].value
    dtype = np.int8 if bpy.app.version < (4, 0, 0) else np.uint8
    ipo = np.full(n, kind, dtype=dtype)
    out = []
    for c in range(n_curves):
        co = np.empty((n, 2), dtype=np.float32)
        co[:, 0] = frames
        co[:, 1] = np.cos(frames * 1e-3 + c)
        out.append(co.ravel())
    return out, ipo


def run_limit(rig, original, arrays, ipo, n):
    """The plainest bulk write of the same keys on fresh F-curves of the rig (see the docstring),
    from the state a bake starts in: the rig evaluated with its source action. (Starting from the
    baked action instead, Blender's evaluated copy of the new action would reuse the memory of the
    baked one's, which the same update frees, and the update would look 0.15 s cheaper than a
    bake's.)"""
    previous = fcurves.active_action(rig)
    play(rig, original)
    bpy.context.view_layer.update()
    paths = [(pb.path_from_id("rotation_quaternion"), pb.name) for pb in rig.pose.bones]
    settle_memory()
    created = time.perf_counter()
    action = fcurves.new_action(rig, "Limit")  # a new action the rig plays, as a bake makes
    channels = fcurves.Channels.of(rig, action, create=True)
    bag = channels.action if not fcurves.SLOTTED else channels._bag
    begin = time.perf_counter()
    a = 0
    for path, group in paths:
        if fcurves.SLOTTED:
            grp = bag.groups.new(group)
        for i in range(4):
            if fcurves.SLOTTED:
                fcurve = bag.fcurves.new(path, index=i)
                fcurve.group = grp
            else:
                fcurve = bag.fcurves.new(path, index=i, action_group=group)
            points = fcurve.keyframe_points
            points.add(n)
            points.foreach_set("co", arrays[a])
            points.foreach_set("interpolation", ipo)
            a += 1
    seconds = time.perf_counter() - begin
    # foreach_set tags nothing: tag the action (its evaluated copy is made again from the new keys)
    # and the rig, so that the update bpy.ops runs after every operator evaluates the new keys here
    # too (the bake assigns its finished action, which tags both)
    action.update_tag()
    rig.update_tag(refresh={"TIME"})
    bpy.context.view_layer.update()
    with_update = time.perf_counter() - created
    play(rig, previous)
    drop(action)
    return seconds, with_update


def run_nla_bake():
    clear_scene()
    rigs.build_rig("Theirs", NLA_FRAMES, 2, BONES, KEY_EVERY)
    bpy.context.view_layer.update()
    seconds, _ = timed(lambda: bpy.ops.nla.bake(frame_start=0, frame_end=NLA_FRAMES - 1, step=1,
                                                only_selected=True, visual_keying=True, bake_types={"POSE"}))
    return seconds, BONES * NLA_FRAMES


def mocap_key_counts():
    """{clip: (rotation keys, reduced keys, seconds)} of the native reduction at 0.1° (BEZIER, per
    channel) of each shared clip's quaternion bones, the samples made hemisphere-continuous as
    reduce.reduce_values does."""
    import bvh  # tests/python: the BVH reader the Python benchmarks use
    out = {}
    for name in CLIPS:
        path = bvh.mocap_path(name)
        if not os.path.exists(path):
            continue
        clip = bvh.read_bvh(path)
        times = np.arange(1, clip.frames + 1, dtype=float)
        quats = [clip.quaternions(j) for j in clip.rotating_joints()]
        begin = time.perf_counter()
        kept = sum(reduce.reduce_values(times, q, "QUATERNION", math.radians(0.1)).key_count for q in quats)
        out[name] = (4 * len(quats) * clip.frames, kept, time.perf_counter() - begin)
    return out


def profile(label, call, top=25):
    prof = cProfile.Profile()
    prof.enable()
    call()
    prof.disable()
    text = io.StringIO()
    pstats.Stats(prof, stream=text).sort_stats("tottime").print_stats(top)
    print("---- profile: %s (by own time)" % label)
    print("\n".join(line for line in text.getvalue().splitlines() if line.strip())[:6000])


class StageTimes:
    """Wall time spent in named functions of the add-on during a call: wraps them while active
    (the wrappers cost ~1 µs a call, a few hundred calls per bake)."""

    def __init__(self, stages):
        self.stages = stages  # label → (owner, function name)
        self.seconds = dict.fromkeys(stages, 0.0)
        self._saved = []

    def _wrap(self, label, real):
        def timed_call(*args, **kwargs):
            begin = time.perf_counter()
            try:
                return real(*args, **kwargs)
            finally:
                self.seconds[label] += time.perf_counter() - begin
        return timed_call

    def __enter__(self):
        for label, (owner, name) in self.stages.items():
            real = getattr(owner, name)
            self._saved.append((owner, name, real))
            setattr(owner, name, self._wrap(label, real))
        return self

    def __exit__(self, *exc):
        for owner, name, real in reversed(self._saved):
            setattr(owner, name, real)


def bake_stages(rig, original, repeat):
    """Where the bake's own work goes: best of `repeat` instrumented bakes (by own work), each stage's
    seconds — reading the sources (bake.prepare), copying the source action, writing the keys (add +
    foreach_set, as the limit does) — and the rest (making the F-curves, waiting for the native
    workers, Python glue)."""
    best = None
    for _ in range(repeat):
        stages = StageTimes({"read": (bake, "prepare"), "copy": (fcurves, "copy_action"),
                             "write keys": (fcurves, "write_packed")})
        with stages:
            _, own, _, baked = run_bake(rig, original)
        drop(baked)
        if best is None or own < best[0]:
            best = own, dict(stages.seconds)
    own, seconds = best
    seconds["other"] = own - sum(seconds.values())
    return own, seconds


def main():
    repeat, want_profile, threads, bake_only = options()
    workers.THREADS = threads
    quatcurve_blender.register()
    clear_scene()
    rig = rigs.build_rig("Rig", LAST_FRAME, 1, BONES, KEY_EVERY)
    bpy.context.view_layer.update()  # the rig's own first evaluation is not the bake's cost
    original = fcurves.active_action(rig)
    original.use_fake_user = True
    n = LAST_FRAME + 1
    arrays, ipo = limit_arrays(4 * BONES, n)
    bakes, owns, limits, updated_limits, reduces = [], [], [], [], []
    baked, keys = None, 0
    for _ in range(repeat):
        drop(baked)
        seconds, own, keys, baked = run_bake(rig, original)
        bakes.append(seconds)
        owns.append(own)
        seconds, with_update = run_limit(rig, original, arrays, ipo, n)
        limits.append(seconds)
        updated_limits.append(with_update)
        if not bake_only:
            seconds, reduced_keys = run_reduce(rig, baked)
            reduces.append(seconds)
    assert keys == 4 * BONES * n, keys
    if want_profile:
        drop(baked)
        profile("bake", lambda: run_bake(rig, original))
        baked = fcurves.active_action(rig)
        if not bake_only:
            profile("reduce", lambda: run_reduce(rig, baked))
    drop(baked)
    own_staged, stages = bake_stages(rig, original, repeat)
    if not bake_only:
        baked = run_bake(rig, original)[3]  # the reduce's source again
    del arrays
    bake_s, own_s, limit_s, updated_s = min(bakes), min(owns), min(limits), min(updated_limits)
    if not bake_only:
        reduce_s = min(reduces)
        theirs_s, theirs_bf = run_nla_bake()
        nla_ratio = (BONES * n / bake_s) / (theirs_bf / theirs_s)
        mocap = mocap_key_counts()

    print("Blender %s, quatcurve %s; %d bones x %s frames, SQUAD -> QUATERNION, %s keys; best of %d; %s"
          % (bpy.app.version_string, native.require().__version__, BONES, f"{n:,}", f"{keys:,}", repeat,
             "%d worker thread%s" % (workers.thread_count(), "" if workers.thread_count() == 1 else "s")
             if hasattr(workers, "thread_count") else "no worker threads"))
    print("  %-34s %9s   %s" % ("stage", "seconds", "runs"))
    rows = (("bake (quatcurve.bake)", bake_s, bakes), ("  its own work (before the update)", own_s, owns),
            ("limit (add + foreach_set co, ipo)", limit_s, limits),
            ("limit + new action + scene update", updated_s, updated_limits))
    if not bake_only:
        rows += (("reduce (0.1 deg, BEZIER per channel)", reduce_s, reduces),
                 ("nla.bake, %d bones x %d frames" % (BONES, NLA_FRAMES), theirs_s, [theirs_s]))
    for name, best, runs in rows:
        print("  %-34s %9.3f   %s" % (name, best, " ".join("%.3f" % r for r in runs)))
    print("  bake / limit:         %.2f   (target <= 1.2; the limit's keys written, not yet evaluated, "
          "the bake's keys evaluated by Blender)" % (bake_s / limit_s))
    print("  bake's own work / limit: %.2f  (both until the keys are written, before Blender evaluates them)"
          % (own_s / limit_s))
    print("  bake / (limit+action+update): %.2f  (both into a new action the rig plays, until Blender has "
          "evaluated the new keys, as bpy.ops does after every operator)" % (bake_s / updated_s))
    print("  bake's own work, instrumented (best of %d, %.3f s): %s" % (
        repeat, own_staged, ", ".join("%s %.3f" % kv for kv in stages.items())))
    print("    reading + copying + the limit's writes: %.2f x the limit (the floor of the bake's own work)"
          % ((stages["read"] + stages["copy"] + limit_s) / limit_s))
    if bake_only:
        quatcurve_blender.unregister()
        return
    print("  bake vs nla.bake:     %.0fx  (bone-frames per second)" % nla_ratio)
    print("  reduce / bake:        %.2f   (target <= 1.0); %s keys -> %s"
          % (reduce_s / bake_s, f"{keys:,}", f"{reduced_keys:,}"))
    for name, (total, kept, seconds) in mocap.items():
        print("  mocap %-15s %s rotation keys -> %s at 0.1 deg (%.2f %%), %.2f s"
              % (name, f"{total:,}", f"{kept:,}", 100.0 * kept / total, seconds))
    if not mocap:
        print("  mocap: ../shared/data/mocap not found, key counts skipped")
    quatcurve_blender.unregister()


smoke.run(main)
