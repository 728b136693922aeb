"""Orientation trails (trails.py), their data in background mode in every Blender: the tripods' and the
axis tip's world-space points against Blender's own matrices at each frame (frame_set), for a keyed
object and a pose bone under a posed parent in a moved, rotated, scaled armature; the method's trail
against the native curve; the cache (hit, recomputed after a key change, after a settings change);
nothing registered for drawing in background mode; the subpanels and the plot operator."""

import math

import bpy
import numpy as np
import pytest
from mathutils import Euler, Matrix, Quaternion, Vector

from quatcurve_blender import compare, fcurves, trails, ui

SIZE = 0.75


def world_axis_ends(matrix, origin, size=SIZE):
    """(3, 3): origin + size * each normalized column (X, Y, Z) of a world matrix's 3x3."""
    m = np.array(matrix.to_3x3(), dtype=np.float64)
    cols = m.T / np.linalg.norm(m.T, axis=1, keepdims=True)
    return np.asarray(origin, dtype=np.float64) + size * cols


def points_now(target, trail, axis="X", step=5):
    origin, basis = trails.world_frame(target)
    return trails.trail_points(trail, origin, basis, axis, SIZE, step)


@pytest.fixture
def keyed_object(scene):
    """'Turner': Euler XYZ, Bezier keys at 1, 11, 31 (a turn over all three axes), at (1, 2, 3),
    scaled (1, 2, 0.5), the active object."""
    obj = bpy.data.objects.new("Turner", None)
    scene.collection.objects.link(obj)
    obj.location, obj.scale = (1, 2, 3), (1, 2, 0.5)
    obj.rotation_mode = "XYZ"
    for frame, degrees in ((1, (0, 0, 0)), (11, (30, 80, -20)), (31, (120, 10, 200))):
        obj.rotation_euler = [math.radians(d) for d in degrees]
        obj.keyframe_insert("rotation_euler", frame=frame)
    bpy.context.view_layer.objects.active = obj
    scene.frame_set(1)
    return obj


def test_object_tripods_and_tips_are_blenders_world_axes(keyed_object):
    scene = bpy.context.scene
    target = trails.active_target(bpy.context)
    assert target.name == "Turner" and target.bone is None
    trail = trails.compute_local(target)
    assert not trail.error and list(trail.frames) == list(range(1, 32))
    found = points_now(target, trail, "Y", step=5)
    blender = found[trails.BLENDER]
    assert list(blender.tripod_frames) == [1, 6, 11, 16, 21, 26, 31]
    for i, frame in enumerate(trail.frames):
        scene.frame_set(int(frame))
        ends = world_axis_ends(keyed_object.matrix_world, keyed_object.matrix_world.translation)
        np.testing.assert_allclose(blender.tips[i], ends[1], atol=1e-5)
        picked = np.flatnonzero(blender.tripod_frames == frame)
        if len(picked):
            np.testing.assert_allclose(blender.tripods[picked[0]], ends, atol=1e-5)
    np.testing.assert_allclose(blender.origin, (1, 2, 3))


def test_method_trail_is_the_native_curve_through_the_keys(keyed_object):
    target = trails.active_target(bpy.context)
    trail = trails.compute_local(target, method="SLERP")
    found = points_now(target, trail, "X")
    keys = (Euler((0, 0, 0)).to_quaternion(), Euler([math.radians(d) for d in (30, 80, -20)]).to_quaternion())
    for frame in (1, 4, 6, 11):
        q = keys[0].slerp(keys[1], (frame - 1) / 10)
        expected = Vector((1, 2, 3)) + SIZE * (q @ Vector((1, 0, 0)))
        np.testing.assert_allclose(found["SLERP"].tips[frame - 1], expected, atol=1e-5)
    # Blender's Bezier Euler keys and slerp agree at the keys and nowhere much in between.
    np.testing.assert_allclose(found["SLERP"].tips[10], found[trails.BLENDER].tips[10], atol=1e-5)
    assert np.abs(found["SLERP"].tips[5] - found[trails.BLENDER].tips[5]).max() > 1e-3


@pytest.fixture
def posed_bone(scene):
    """'Rig' (moved, rotated, scaled 0.5) with 'Upper' → 'Lower'; Upper posed (not keyed) 40° about
    X, Lower keyed in quaternions at frames 1 and 21; Pose mode, Lower active."""
    arm = bpy.data.armatures.new("Rig")
    rig = bpy.data.objects.new("Rig", arm)
    scene.collection.objects.link(rig)
    rig.location, rig.rotation_euler, rig.scale = (2, -1, 0.5), (0, 0, math.radians(30)), (0.5, 0.5, 0.5)
    bpy.context.view_layer.objects.active = rig
    rig.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    upper = arm.edit_bones.new("Upper")
    upper.head, upper.tail = (0, 0, 0), (0, 0, 1)
    lower = arm.edit_bones.new("Lower")
    lower.head, lower.tail, lower.roll = (0, 0, 1), (0, 1, 1.5), 0.3
    lower.parent = upper
    bpy.ops.object.mode_set(mode="POSE")
    rig.pose.bones["Upper"].rotation_mode = "XYZ"
    rig.pose.bones["Upper"].rotation_euler = (math.radians(40), 0, 0)
    pb = rig.pose.bones["Lower"]
    pb.rotation_mode = "QUATERNION"
    for frame, q in ((1, Quaternion()), (21, Quaternion((0.3, 1, 0.2), math.radians(150)))):
        pb.rotation_quaternion = q
        pb.keyframe_insert("rotation_quaternion", frame=frame)
    arm.bones.active = arm.bones["Lower"]
    scene.frame_set(1)
    yield rig
    bpy.ops.object.mode_set(mode="OBJECT")


def test_pose_bone_tripods_and_tips_are_blenders_world_axes(posed_bone):
    scene = bpy.context.scene
    target = trails.active_target(bpy.context)
    assert target.name == "Rig/Lower"
    trail = trails.compute_local(target)
    assert not trail.error and len(trail.frames) == 21
    found = points_now(target, trail, "Z", step=4)[trails.BLENDER]
    pb = posed_bone.pose.bones["Lower"]
    for i, frame in enumerate(trail.frames):
        scene.frame_set(int(frame))
        head = posed_bone.matrix_world @ pb.head
        ends = world_axis_ends(posed_bone.matrix_world @ pb.matrix, head)
        np.testing.assert_allclose(found.origin, head, atol=1e-5)
        np.testing.assert_allclose(found.tips[i], ends[2], atol=1e-5)
        picked = np.flatnonzero(found.tripod_frames == frame)
        if len(picked):
            np.testing.assert_allclose(found.tripods[picked[0]], ends, atol=1e-5)


def test_cache_hits_until_the_keys_or_settings_change(keyed_object):
    cache = trails.TrailCache()
    target = trails.active_target(bpy.context)
    first = cache.get(target, "SQUAD")
    assert (cache.computed, cache.hits) == (1, 0)
    assert cache.get(target, "SQUAD") is first and (cache.computed, cache.hits) == (1, 1)
    cache.mark_dirty()  # something changed somewhere, not these keys: the signature still matches
    assert cache.get(target, "SQUAD") is first and (cache.computed, cache.hits) == (1, 2)
    move_key(keyed_object)
    cache.mark_dirty()
    second = cache.get(target, "SQUAD")
    assert second is not first and (cache.computed, cache.hits) == (2, 2)
    assert np.abs(second.quats[trails.BLENDER][10] - first.quats[trails.BLENDER][10]).max() > 0.05
    assert cache.get(target, "SLERP") is not second and cache.computed == 3       # another method
    assert set(cache.get(target, None).quats) == {trails.BLENDER} and cache.computed == 4
    assert cache.get(target, None, (5, 9)).frames.tolist() == [5, 6, 7, 8, 9]   # another range


def move_key(obj):
    fcurve = fcurves.Channels.of(obj).find("rotation_euler", 2)
    fcurve.keyframe_points[1].co.y += math.radians(30)
    fcurve.update()


def test_a_key_change_reaches_the_cache_through_the_depsgraph(keyed_object):
    target = trails.active_target(bpy.context)
    trails.CACHE.clear()
    before = trails.CACHE.get(target)
    bpy.context.view_layer.update()
    assert trails.CACHE.get(target) is before
    move_key(keyed_object)
    bpy.context.view_layer.update()  # depsgraph_update_post: the cache checks signatures again
    after = trails.CACHE.get(target)
    assert after is not before and after.signature != before.signature


def test_targets_without_rotation_keys_say_why(scene):
    obj = bpy.data.objects.new("Still", None)
    scene.collection.objects.link(obj)
    trail = trails.compute_local(trails.targets.Target(obj))
    assert "no rotation animation" in trail.error
    assert trails.trail_points(trail, np.zeros(3), np.eye(3)) == {}
    bpy.context.view_layer.objects.active = None
    assert trails.active_target(bpy.context) is None


def test_nothing_is_registered_for_drawing_in_background(addon):
    assert bpy.app.background
    assert trails.draw_handlers() == []
    assert hasattr(bpy.types.Scene, "quatcurve_trails")
    assert trails._on_depsgraph_update in bpy.app.handlers.depsgraph_update_post


def test_unregister_removes_every_handler(addon):
    addon.unregister()
    try:
        assert trails._on_depsgraph_update not in bpy.app.handlers.depsgraph_update_post
        assert not hasattr(bpy.types.Scene, "quatcurve_trails") and trails.draw_handlers() == []
    finally:
        addon.register()


def test_subpanels_one_per_task_under_each_editor(addon):
    for parent in ("QUATCURVE_PT_view3d", "QUATCURVE_PT_graph"):
        children = {cls.bl_idname: cls for cls in ui._classes if getattr(cls, "bl_parent_id", "") == parent}
        tasks = {"fit", "bake", "reduce", "clean", "compare"} | ({"trails"} if parent.endswith("view3d") else set())
        assert set(children) == {"%s_%s" % (parent, t) for t in tasks}
        for idname in children:
            assert hasattr(bpy.types, idname)
    assert "DEFAULT_CLOSED" in ui._classes[-1].bl_options or any(
        "DEFAULT_CLOSED" in cls.bl_options for cls in ui._classes if hasattr(cls, "bl_parent_id"))


def test_show_plot_reports_no_window_in_background(keyed_object):
    keyed_object.select_set(True)
    assert bpy.ops.quatcurve.show_compare_plot() == {"CANCELLED"}        # no plot yet
    assert bpy.ops.quatcurve.compare() == {"FINISHED"}
    assert bpy.data.images.get(compare.image_name("Turner")) is not None
    assert bpy.ops.quatcurve.show_compare_plot() == {"CANCELLED"}        # a plot, but no window
