"""The F-curve adapter (fcurves.py) on legacy (3.4) and slotted (4.4+) actions."""

import bpy
import numpy as np
import pytest

from bake_helpers import add_empty, add_rig, key, rotation_fcurves
from quatcurve_blender import fcurves


def test_branch_follows_the_blender_version(scene):
    assert fcurves.SLOTTED == (bpy.app.version >= (4, 4, 0))
    if bpy.app.version >= (5, 0, 0):
        # The legacy API is gone in 5.0: the slotted path is the only one that can work there.
        assert "fcurves" not in bpy.types.Action.bl_rna.properties


def test_write_then_read_keys_in_bulk(scene):
    obj = add_empty("Cube")
    key(obj, "location", [(1, (0, 0, 0))])
    channels = fcurves.Channels.of(obj)
    frames = np.arange(10001, dtype=np.float64)
    values = np.sin(frames * 0.01)
    fcurve = channels.write('["prop"]', 0, frames, values, group="Props")
    got_f, got_v = fcurves.read_keys(fcurve)
    np.testing.assert_array_equal(got_f, frames)
    np.testing.assert_allclose(got_v, values, atol=1e-7)  # float32 storage
    assert fcurve.group.name == "Props"
    assert {p.interpolation for p in fcurve.keyframe_points[:5]} == {"LINEAR"}
    assert fcurve.evaluate(5000.5) == pytest.approx(0.5 * (values[5000] + values[5001]), abs=1e-6)
    # Rewriting replaces the keys.
    fcurves.write_keys(fcurve, [1.0, 2.0], [3.0, 4.0])
    assert fcurves.key_count(fcurve) == 2


def test_bezier_keys_with_free_handles_are_kept_as_written(scene):
    obj = add_empty("Cube")
    key(obj, "location", [(1, (0, 0, 0))])
    channels = fcurves.Channels.of(obj)
    left = np.array([[0.0, 1.0], [8.0, -2.0]])
    right = np.array([[3.0, 1.5], [12.0, 0.0]])
    fcurve = channels.write('["prop"]', 0, [1, 10], [1.0, -1.0], interpolation="BEZIER",
                            handle_left=left, handle_right=right)
    got_left, got_right = fcurves.read_handles(fcurve)
    np.testing.assert_allclose(got_left, left, atol=1e-6)
    np.testing.assert_allclose(got_right, right, atol=1e-6)
    assert {p.handle_left_type for p in fcurve.keyframe_points} == {"FREE"}


def _handle_types(fcurve):
    return [(p.handle_left_type, p.handle_right_type) for p in fcurve.keyframe_points]


@pytest.mark.parametrize("count", [7, 10, 13])
def test_a_rewrite_with_handles_makes_every_handle_type_free(scene, count):
    """Rewriting keys with handles (a refit: fewer, as many or more keys) leaves FREE handle types on
    every key, also where they were changed since the last write (Blender 3.x: key slots are kept and
    only the types that are not FREE are set)."""
    obj = add_empty("Cube")
    key(obj, "location", [(1, (0, 0, 0))])
    channels = fcurves.Channels.of(obj)
    frames = np.arange(10.0) * 3
    values = np.sin(frames)
    fcurve = channels.write('["prop"]', 0, frames, values, interpolation="BEZIER",
                            handle_left=np.stack([frames - 1, values], 1), handle_right=np.stack([frames + 1, values], 1))
    kinds = ["AUTO", "VECTOR", "ALIGNED", "AUTO_CLAMPED"]
    points = fcurve.keyframe_points
    for i, kind in enumerate(kinds):
        points[2 * i + 1].handle_left_type = kind
        points[2 * i + 2].handle_right_type = kinds[-1 - i]
    points[9].handle_left_type = points[9].handle_right_type = "VECTOR"
    assert len({t for pair in _handle_types(fcurve) for t in pair}) == 5
    frames = np.arange(count) * 2.5 + 1
    values = np.cos(frames)
    left, right = np.stack([frames - 0.5, values + 0.1], 1), np.stack([frames + 0.5, values - 0.1], 1)
    fcurves.write_keys(fcurve, frames, values, interpolation="BEZIER", handle_left=left, handle_right=right)
    assert _handle_types(fcurve) == [("FREE", "FREE")] * count
    got_left, got_right = fcurves.read_handles(fcurve)
    np.testing.assert_allclose(got_left, left, atol=1e-6)
    np.testing.assert_allclose(got_right, right, atol=1e-6)
    np.testing.assert_allclose(fcurves.read_keys(fcurve)[1], values, atol=1e-7)
    assert {p.interpolation for p in points} == {"BEZIER"}


@pytest.mark.parametrize("interpolation", ["LINEAR", "BEZIER", "CONSTANT", "ELASTIC"])
@pytest.mark.parametrize("modifier", [None, "GENERATOR", "NOISE"])
def test_evaluate_equals_blenders_own_evaluation(scene, interpolation, modifier):
    obj = add_empty("Cube")
    key(obj, "rotation_euler", [(1, (0, 10, 20)), (7, (30, -40, 50)), (20, (100, 0, -20))],
        interpolation=interpolation, degrees=True)
    frames = np.concatenate([[-5.0, 1.0, 7.0, 20.0, 33.0], np.linspace(0, 21, 43)])
    for fcurve in rotation_fcurves(obj, "rotation_euler"):
        if modifier:
            fcurve.modifiers.new(modifier)
        expected = [fcurve.evaluate(float(f)) for f in frames]
        np.testing.assert_array_equal(fcurves.evaluate(fcurve, frames), expected)


def test_channels_of_a_pose_bone_and_of_an_object_in_the_same_action(scene):
    rig = add_rig()
    key(rig.pose.bones["B1"], "rotation_quaternion", [(1, (1, 0, 0, 0)), (5, (0, 1, 0, 0))])
    key(rig, "location", [(1, (1, 2, 3))])
    channels = fcurves.Channels.of(rig)
    path = rig.pose.bones["B1"].path_from_id("rotation_quaternion")
    found = channels.find_all(path, 4)
    assert all(f is not None for f in found)
    np.testing.assert_array_equal(fcurves.key_frames(found), [1, 5])
    assert channels.find("location", 0) is not None
    assert channels.remove({path}) == 4
    assert channels.find(path, 0) is None and channels.find("location", 0) is not None


def test_copy_action_keeps_every_channel_and_the_slot(scene):
    obj = add_empty("Cube")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (9, (1, 2, 3))])
    key(obj, "location", [(1, (0, 0, 0)), (4, (1, 1, 1))])
    original = fcurves.active_action(obj)
    copy = fcurves.copy_action(original, original.name + "_copy")
    assert copy.name == original.name + "_copy"
    assert fcurves.action_digest(copy) == fcurves.action_digest(original)
    fcurves.assign_action(obj, copy)
    assert fcurves.active_action(obj) == copy
    assert len(list(fcurves.Channels.of(obj).fcurves)) == 6
    if fcurves.SLOTTED:
        assert obj.animation_data.action_slot.identifier == original.slots[0].identifier
    # A changed key changes the digest.
    fcurve = fcurves.Channels.of(obj).find("location", 2)
    fcurve.keyframe_points[1].co[1] += 0.5
    assert fcurves.action_digest(copy) != fcurves.action_digest(original)


def test_scratch_channels_are_removed_afterwards(scene):
    before = set(bpy.data.actions)
    with fcurves.scratch_channels() as scratch:
        fcurve = scratch.write("rotation_euler", 2, [1, 11], [0.0, 1.0])
        assert fcurve.evaluate(6) == pytest.approx(0.5)
        assert len(bpy.data.actions) == len(before) + 1
    assert set(bpy.data.actions) == before


def test_protection_reasons(scene):
    obj = add_empty("Cube")
    assert fcurves.is_protected(obj) == ""
    assert fcurves.is_protected(None) == ""


@pytest.mark.parametrize("interpolation", ["BEZIER", "LINEAR"])
def test_evaluate_scratch_keys_matches_keys_made_by_keyframe_insert(scene, interpolation):
    obj = add_empty("Cube")
    keys = [(1, (0, 10, 20)), (7, (30, -40, 50)), (20, (100, 0, -20))]
    key(obj, "rotation_euler", keys, interpolation=interpolation, degrees=True)
    curves = sorted(rotation_fcurves(obj, "rotation_euler"), key=lambda f: f.array_index)
    frames = np.linspace(-2, 24, 60)
    expected = np.column_stack([[f.evaluate(float(x)) for x in frames] for f in curves])
    actions = len(bpy.data.actions)
    got = fcurves.evaluate_scratch_keys("rotation_euler", [k[0] for k in keys],
                                        np.radians([k[1] for k in keys]), frames, interpolation)
    assert np.abs(got - expected).max() < 1e-6
    assert len(bpy.data.actions) == actions
