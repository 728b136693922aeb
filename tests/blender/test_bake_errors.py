"""Every refused bake: the operator reports, returns CANCELLED and changes nothing (every action's
digest, assignments and rotation modes are compared before and after)."""

import math

import bpy
import numpy as np
import pytest

from bake_helpers import add_empty, add_rig, file_state, key, select_bones, select_objects
from quatcurve_blender import bake, bake_ops, fcurves, targets


def refused(match, **kwargs):
    """Runs the operator, expects an error report matching `match` and no change to the file.
    (In background mode an operator's error report is raised as RuntimeError; its return value is
    CANCELLED, which `bake_cancelled` checks through the operator's execute directly.)"""
    before = file_state()
    with pytest.raises(RuntimeError, match=match):
        bpy.ops.quatcurve.bake(**kwargs)
    assert file_state() == before
    return before


@pytest.fixture
def keyed(scene):
    obj = add_empty("Cube", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 90))], degrees=True)
    key(obj, "location", [(1, (0, 0, 0)), (11, (1, 0, 0))])
    select_objects(obj)
    return obj


def test_nothing_selected(scene):
    obj = add_empty("Cube")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 1))])
    select_objects()
    refused("Nothing to bake: no objects selected")


def test_no_bones_selected_in_pose_mode(scene):
    rig = add_rig()
    key(rig.pose.bones["B0"], "rotation_quaternion", [(1, (1, 0, 0, 0)), (5, (0, 1, 0, 0))])
    select_bones(rig, set())
    refused("Nothing to bake: no pose bones selected")


def test_target_without_any_animation(scene):
    obj = add_empty("Still")
    select_objects(obj)
    refused(r"Still: no rotation animation \(rotation mode XYZ, no keys on rotation_euler\)")


def test_target_with_only_location_keys_among_good_targets(keyed):
    other = add_empty("Mover")
    key(other, "location", [(1, (0, 0, 0)), (5, (1, 1, 1))])
    select_objects(keyed, other)
    refused("Mover: no rotation animation")


def test_keys_in_another_rotation_mode_are_named(keyed):
    keyed.rotation_mode = "QUATERNION"
    refused("Cube: no rotation animation .*rotation_euler is keyed")


def test_euler_method_for_quaternion_keys_is_named(scene):
    """Method EULER lerps Euler angle keys: a quaternion or axis-angle target is refused naming it and
    its mode (before: the native API's 'build it with Curve::from_euler'; found by random scenes)."""
    obj = add_empty("Quat", "QUATERNION")
    key(obj, "rotation_quaternion", [(1, (1, 0, 0, 0)), (11, (0.7071, 0, 0, 0.7071))])
    select_objects(obj)
    refused(r"Quat: method Euler \(linear angles\) interpolates Euler angle keys, and its keys are QUATERNION",
            method="EULER")


def test_unselected_bone_without_animation_is_not_a_target_but_a_selected_one_is(scene):
    rig = add_rig()
    key(rig.pose.bones["B0"], "rotation_quaternion", [(1, (1, 0, 0, 0)), (5, (0, 1, 0, 0))])
    select_bones(rig, {"B0", "B2"})
    refused("Rig/B2: no rotation animation")


def test_nan_in_the_source(keyed):
    fcurve = fcurves.Channels.of(keyed).find("rotation_euler", 1)
    fcurve.keyframe_points.foreach_set("co", np.array([1, 0, 11, np.nan], dtype=np.float32))
    refused(r"Cube: rotation_euler\[1\] is nan at frame 11")


def test_zero_quaternion_in_the_source(scene):
    obj = add_empty("Cube", "QUATERNION")
    key(obj, "rotation_quaternion", [(1, (1, 0, 0, 0)), (7, (0, 0, 0, 0))])
    select_objects(obj)
    refused("Cube: the quaternion is zero at frame 7")


def _failing_last(monkeypatch, threads, bad_keys):
    """Three good targets, one with only NLA strips, then 'Zz' keyed with bad_keys, all selected;
    returns the list the names of the targets written are appended to."""
    from quatcurve_blender import workers, write
    monkeypatch.setattr(workers, "THREADS", threads)
    good = [add_empty("Good%d" % i, "QUATERNION") for i in range(3)]
    for obj in good:
        key(obj, "rotation_quaternion", [(1, (1, 0, 0, 0)), (7, (0, 1, 0, 0))])
    strip_only = add_empty("Good9", "QUATERNION")
    key(strip_only, "rotation_quaternion", [(1, (1, 0, 0, 0)), (7, (0, 0, 1, 0))])
    anim = strip_only.animation_data
    anim.nla_tracks.new().strips.new("Strip", 1, fcurves.active_action(strip_only))
    anim.action = None
    bad = add_empty("Zz", "QUATERNION")
    key(bad, "rotation_quaternion", bad_keys)
    select_objects(*good, strip_only, bad)
    assert [t.name for t in targets.gather_targets(bpy.context)][-1] == "Zz"
    written = []
    real = write._write_keys
    monkeypatch.setattr(write, "_write_keys", lambda channels, item: (written.append(item.target.name),
                                                                       real(channels, item)))
    return written


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_a_target_failing_after_others_were_written_leaves_nothing_behind(scene, monkeypatch, threads):
    # Into new actions the bake writes each target while the next ones compute: the last target's
    # curve refuses its keys (spacings of 0.02 and 29,999 frames: a SQUAD tangent cannot carry one
    # over the other) on a worker, after the first ones were written, and the new actions made so far
    # (copies, and a new one for a target with only NLA strips) are removed.
    written = _failing_last(monkeypatch, threads, [(1, (1, 0, 0, 0)), (1.02, (1, 0.001, 0, 0)),
                                                   (30000, (0, 1, 0, 0))])
    refused(r"Zz: times\[2\]: .* SQUAD needs neighbouring key spacings", method="SQUAD", frame_start=1,
            frame_end=7)
    assert written == ["Good0", "Good1", "Good2", "Good9"]  # written, then removed again


@pytest.mark.parametrize("threads", [1, 2])
def test_keys_refused_while_reading_stop_the_bake_before_any_write(scene, monkeypatch, threads):
    written = _failing_last(monkeypatch, threads, [(1, (1, 0, 0, 0)), (7, (0, 0, 0, 0))])
    refused("Zz: the quaternion is zero at frame 7")
    assert written == []


def test_empty_frame_range(keyed):
    refused(r"frame range 10\.\.5 is empty", frame_start=10, frame_end=5)


def test_frame_range_longer_than_ten_million_frames_is_refused_before_allocating(keyed):
    refused("at most 10,000,000 frames", frame_start=0, frame_end=10_000_001)
    with pytest.raises(bake.BakeError, match="at most"):
        bake.bake_frames(0.0, 1e300, 1.0)  # would not fit in memory: refused, not attempted


@pytest.mark.parametrize("step", [0, -3])
def test_step_below_one(keyed, step):
    refused("step %d: must be at least 1 frame" % step, step=step)


def test_tolerance_above_zero_bakes_reduced_keys(keyed):
    # Key reduction is part of every build (bake imports reduce): a tolerance above 0 bakes.
    assert bpy.ops.quatcurve.bake(tolerance=0.1) == {"FINISHED"}


def test_negative_tolerance(keyed):
    refused("tolerance -1°: must be 0 or more", tolerance=-1)


def test_library_linked_and_override_protected_objects(scene, tmp_path):
    source = add_empty("Linked", "XYZ")
    key(source, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 90))], degrees=True)
    library_file = str(tmp_path / "library.blend")
    bpy.data.libraries.write(library_file, {source}, fake_user=True)
    bpy.data.objects.remove(source)
    with bpy.data.libraries.load(library_file, link=True) as (data_from, data_to):
        data_to.objects = ["Linked"]
    linked = data_to.objects[0]
    assert linked.library is not None
    bpy.context.scene.collection.objects.link(linked)
    select_objects(linked)
    refused("Linked: the object is library-linked and cannot be changed")
    override = linked.override_create(remap_local_usages=True)  # replaces the linked one in the scene
    assert override.override_library is not None
    select_objects(override)
    refused("Linked: the object is override-protected and cannot be changed")


def test_cancelled_result_from_execute(keyed):
    """The operator's own return value on error (bpy.ops turns the report into an exception in
    background mode, so call the class's execute directly)."""
    op = bpy.types.QUATCURVE_OT_bake
    before = file_state()
    fake = _FakeOperator(step=0)
    assert op.execute(fake, bpy.context) == {"CANCELLED"}
    assert fake.messages and "step 0" in fake.messages[0][1]
    assert file_state() == before


class _FakeOperator:
    """Stands in for an operator instance: attributes, is_property_set, report."""

    def __init__(self, **given):
        from quatcurve_blender import bake_ops
        defaults = {name: getattr(bpy.context.scene.quatcurve, name) for name in bake_ops.bake_properties()}
        self.__dict__.update(defaults)
        self.__dict__.update(given)
        self._given = set(given)
        self.messages = []
        self.properties = self

    def is_property_set(self, name):
        return name in self._given

    def report(self, kind, message):
        self.messages.append((kind, message))

    def _fill_from_scene(self, context):
        return bpy.types.QUATCURVE_OT_bake._fill_from_scene(self, context)

    def _prepare(self, context):
        return bpy.types.QUATCURVE_OT_bake._prepare(self, context)

    def _finish(self, context, plan):
        return bpy.types.QUATCURVE_OT_bake._finish(self, context, plan)


def test_errors_from_the_plain_functions_name_the_target(scene):
    obj = add_empty("Still")
    with pytest.raises(bake.BakeError, match="Still"):
        bake.bake([targets.Target(obj)], bake.BakeSettings())
    with pytest.raises(bake.BakeError, match="method 'LERP': unknown"):
        bake.check_settings(bake.BakeSettings(method="LERP"))
    assert math.isclose(bake.bake_frames(1, 2, 1.0)[-1], 2)
