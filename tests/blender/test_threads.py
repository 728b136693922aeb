"""Worker threads (issue 15): the bake's, the reduction's and the fit's native work runs on
workers.thread_count() threads, one target per task; the written keys must be the same, bit for bit,
whatever the thread count. Blender data is only touched on the main thread."""

import hashlib

import bpy
import numpy as np
import pytest

from quatcurve_blender import bake, fcurves, fit, reduce, targets, workers

import rigs


@pytest.fixture
def threads():
    saved = workers.THREADS
    yield
    workers.THREADS = saved


def _rig(name):
    rig = rigs.build_rig(name, last_frame=300, seed=7, bones=6, key_every=10)
    bpy.context.view_layer.update()
    return rig


def _digests(rig):
    """Every F-curve of the rig's action (not its slots: those carry the rig's name)."""
    h = hashlib.sha256()
    for fcurve in sorted(fcurves.all_fcurves(fcurves.active_action(rig)),
                         key=lambda f: (f.data_path, f.array_index)):
        fcurves.fcurve_digest(fcurve, h)
    return h.hexdigest()


@pytest.mark.parametrize("tolerance", [0.0, 0.1])
def test_bake_is_the_same_on_any_thread_count(scene, threads, tolerance):
    digests = []
    for count in (1, 2, 5):
        workers.THREADS = count
        rig = _rig("Rig%d" % count)
        original = fcurves.active_action(rig)
        found = [targets.Target(rig, pb.name) for pb in rig.pose.bones]
        settings = bake.BakeSettings(method="SQUAD", rotation_mode="XYZ", tolerance=tolerance)
        bake.bake(found, settings)
        assert fcurves.active_action(rig) != original
        digests.append(_digests(rig))
    assert digests[0] == digests[1] == digests[2]


def test_fit_is_the_same_on_any_thread_count(scene, threads):
    """The fit's targets go to a FitQueue's native workers as they are read; one bone's zero quaternion
    key fails the whole fit, naming that bone, on any thread count, before anything is written."""
    digests = []
    for count in (1, 2, 5):
        workers.THREADS = count
        rig = _rig("Rig%d" % count)
        found = [targets.Target(rig, pb.name) for pb in rig.pose.bones]
        result = fit.fit(found, fit.FitSettings(method="CATMULL_ROM", tolerance=0.05))
        assert len(result.targets) == len(found) and not any(t.skipped for t in result.targets)
        digests.append(_digests(rig))
    assert digests[0] == digests[1] == digests[2]
    for count in (1, 3):
        workers.THREADS = count
        rig = _rig("Bad%d" % count)
        bone = rig.pose.bones[3]
        for i in range(4):
            fcurves.Channels.of(rig).find(bone.path_from_id("rotation_quaternion"), i).keyframe_points[2].co[1] = 0.0
        before = _digests(rig)
        with pytest.raises(fit.FitError, match=r"Bad%d/%s: the quaternion is zero at frame" % (count, bone.name)):
            fit.fit([targets.Target(rig, pb.name) for pb in rig.pose.bones], fit.FitSettings(method="SQUAD"))
        assert _digests(rig) == before


def test_reduce_is_the_same_on_any_thread_count(scene, threads):
    digests, counts = [], []
    for count in (1, 2, 5):
        workers.THREADS = count
        rig = _rig("Rig%d" % count)
        found = [targets.Target(rig, pb.name) for pb in rig.pose.bones]
        bake.bake(found, bake.BakeSettings(method="SQUAD", rotation_mode="QUATERNION"))
        result = reduce.reduce(found, reduce.ReduceSettings(tolerance=0.1))
        counts.append(result.keys_after)
        digests.append(_digests(rig))
    assert counts[0] < 6 * 4 * 301
    assert digests[0] == digests[1] == digests[2] and counts[0] == counts[1] == counts[2]


def test_parallel_map_keeps_order_and_the_first_error(threads):
    workers.THREADS = 3
    assert workers.parallel_map(lambda x: x * x, range(10)) == [x * x for x in range(10)]

    def fail_odd(x):
        if x % 2:
            raise ValueError("item %d" % x)
        return x

    with pytest.raises(ValueError, match="item 1"):
        workers.parallel_map(fail_odd, range(10))


@pytest.mark.parametrize("count", [1, 4])
def test_reduce_error_names_the_first_failing_target_in_order(scene, threads, count):
    """Obj2's zero axis is refused by the native reducer (a worker) after Obj0 and Obj1 were written
    into copies of their actions: the copies go again, and the file is as it was."""
    workers.THREADS = count
    objects = []
    for k in range(4):
        obj = bpy.data.objects.new("Obj%d" % k, None)
        bpy.context.scene.collection.objects.link(obj)
        obj.rotation_mode = "AXIS_ANGLE" if k >= 2 else "QUATERNION"
        fcurves.new_action(obj, "Act%d" % k)
        channels = fcurves.Channels.of(obj, create=True)
        prop = "rotation_axis_angle" if k >= 2 else "rotation_quaternion"
        frames = np.arange(1, 31, dtype=np.float64)
        for i in range(4):
            channels.write(prop, i, frames, np.full(30, 1.0 if i == 0 else 0.0))
        objects.append(obj)
    before = sorted(a.name for a in bpy.data.actions)
    with pytest.raises(reduce.ReduceError, match="Obj2"):
        reduce.reduce([targets.Target(o) for o in objects], reduce.ReduceSettings())
    assert sorted(a.name for a in bpy.data.actions) == before
    assert [fcurves.active_action(o).name for o in objects] == ["Act%d" % k for k in range(4)]
