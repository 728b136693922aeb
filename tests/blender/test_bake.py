"""quatcurve.bake: what Blender plays back after a bake, for objects and pose bones, every mode."""

import math

import bpy
import numpy as np
import pytest
from mathutils import Quaternion

from bake_helpers import add_empty, add_rig, angles_between, evaluated, key, select_bones, select_objects
from quatcurve_blender import bake, fcurves, targets

TOL = 2e-5  # rad: float32 key storage, far below any interpolation difference


def run_bake(**kwargs):
    result = bpy.ops.quatcurve.bake(**kwargs)
    assert result == {"FINISHED"}
    return bpy.context.scene.quatcurve


@pytest.mark.parametrize("order", ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"])
def test_euler_method_reproduces_blenders_linear_euler_keys(scene, order):
    obj = add_empty("Cube", order)
    key(obj, "rotation_euler", [(1, (10, 20, 30)), (11, (-50, 60, 200)), (26, (120, -30, 400))],
        degrees=True)
    frames = np.arange(1, 27)
    before_q, before_angles = evaluated(obj, frames), evaluated(obj, frames, "values")
    select_objects(obj)
    run_bake(method="EULER")  # KEEP: the same order
    assert obj.rotation_mode == order
    after_q, after_angles = evaluated(obj, frames), evaluated(obj, frames, "values")
    assert angles_between(before_q, after_q).max() <= TOL
    # The angles themselves, turn counts included (200° → 400° on Z stays beyond 360°).
    assert np.abs(after_angles - before_angles).max() <= TOL


def test_quat_components_reproduces_blenders_quaternion_mode_with_sign_flips(scene):
    obj = add_empty("Cube", "QUATERNION")
    q1 = Quaternion((1, 1, 0, 0)).normalized()
    q2 = -Quaternion((0.2, 0.3, -0.9, 0.4)).normalized()   # stored in the opposite hemisphere
    assert q1.dot(q2) < 0
    key(obj, "rotation_quaternion", [(1, (1, 0, 0, 0)), (11, q1), (25, q2), (31, (0.5, 0.5, 0.5, 0.5))])
    frames = np.arange(1, 32)
    before = evaluated(obj, frames)
    select_objects(obj)
    run_bake(method="QUAT_COMPONENTS", rotation_mode="QUATERNION")
    after = evaluated(obj, frames, "values")
    assert angles_between(before, after).max() <= TOL
    # The written quaternions are hemisphere-continuous (the rotation path is Blender's, flip and all).
    assert (np.sum(after[1:] * after[:-1], axis=1) > 0).all()


def test_slerp_equals_mathutils_slerp_also_across_hemispheres(scene):
    obj = add_empty("Cube", "QUATERNION")
    q0 = Quaternion((0.9, 0.1, 0.3, -0.2)).normalized()
    q1 = -Quaternion((0.3, -0.6, 0.2, 0.7)).normalized()   # opposite hemisphere as stored
    q2 = Quaternion((0.1, 0.9, 0.1, 0.3)).normalized()
    assert q0.dot(q1) < 0
    key(obj, "rotation_quaternion", [(1, q0), (13, q1), (20, q2)])
    select_objects(obj)
    run_bake(method="SLERP", rotation_mode="QUATERNION")
    frames = np.arange(1, 21)
    expected = []
    for f in frames:
        a, b, t0, t1 = (q0, q1, 1, 13) if f <= 13 else (q1, q2, 13, 20)
        expected.append(tuple(a.slerp(b, (f - t0) / (t1 - t0))))
    assert angles_between(evaluated(obj, frames), expected).max() <= TOL


def test_fixed_angle_example_slerp_midpoint(scene):
    obj = add_empty("FixedAngle", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 90, 0)), (21, (90, 45, 90))], degrees=True)
    select_objects(obj)
    run_bake(method="SLERP")
    bpy.context.scene.frame_set(11)
    np.testing.assert_allclose(np.degrees(obj.rotation_euler), (90, 67.5, 90), atol=1e-3)


@pytest.mark.parametrize("method", ["SLERP", "SQUAD", "SPLINE_C2"])
def test_spin_of_100_degrees_per_key_turns_in_full_without_jumps(scene, method):
    obj = add_empty("Spin", "XYZ")
    key(obj, "rotation_euler", [(1 + 10 * k, (0, 0, 100 * k)) for k in range(8)], degrees=True)
    select_objects(obj)
    run_bake(method=method, rotation_mode="XYZ")
    frames = np.arange(1, 72)
    angles = np.degrees(evaluated(obj, frames, "values"))
    assert np.abs(np.diff(angles, axis=0)).max() < 15          # 10°/frame, no flips or 360° jumps
    assert angles[-1, 2] == pytest.approx(700, abs=1e-3)       # the full turn count survives
    np.testing.assert_allclose(angles[:, :2], 0, atol=1e-3)


def test_euler_sources_with_bezier_keys_and_modifiers_are_read_as_blender_evaluates_them(scene):
    obj = add_empty("Cube", "ZXY")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (8, (40, 10, 80)), (20, (-30, 60, 10))],
        interpolation="BEZIER", degrees=True)
    channels = fcurves.Channels.of(obj)
    channels.find("rotation_euler", 1).modifiers.new("GENERATOR").coefficients = (0.2, 0.01)
    keys_q = evaluated(obj, [1, 8, 20])
    select_objects(obj)
    run_bake(method="SQUAD", rotation_mode="QUATERNION")
    # An interpolating method passes through Blender's orientations at the keys.
    assert angles_between(evaluated(obj, [1, 8, 20]), keys_q).max() <= TOL


def test_axis_angle_output_and_source(scene):
    obj = add_empty("Cube", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 170)), (21, (0, 0, 200)), (31, (60, 0, 200))],
        degrees=True)
    select_objects(obj)
    run_bake(method="SLERP", rotation_mode="QUATERNION", new_action=False)
    frames = np.arange(1, 32)
    reference = evaluated(obj, frames)
    run_bake(method="SLERP", rotation_mode="AXIS_ANGLE", new_action=False)
    assert obj.rotation_mode == "AXIS_ANGLE"
    assert angles_between(evaluated(obj, frames), reference).max() <= TOL
    values = evaluated(obj, frames, "values")
    # Continuous through 180° (where the canonical angle would wrap): no axis or angle flips.
    assert np.abs(np.diff(values, axis=0)).max() < 0.35
    assert (np.sum(values[1:, 1:] * values[:-1, 1:], axis=1) > 0.9).all()
    assert values[20, 0] == pytest.approx(math.radians(200), abs=1e-4)
    # Read back from axis-angle (KEEP) with the same method: the same motion.
    run_bake(method="SLERP", rotation_mode="KEEP", new_action=False)
    assert obj.rotation_mode == "AXIS_ANGLE"
    assert angles_between(evaluated(obj, frames), reference).max() <= TOL


@pytest.mark.parametrize("method", ["SLERP", "SQUAD"])
def test_axis_angle_keys_keep_their_spins(scene, method):
    # Two axis-angle keys 720° apart about Z turn twice, as Blender plays the channels; the bake keeps
    # the turns (a curve through the keys' quaternions would see no motion at all).
    obj = add_empty("Spinner", "AXIS_ANGLE")
    key(obj, "rotation_axis_angle", [(1, (0, 0, 0, 1)), (41, (4 * math.pi, 0, 0, 1))])
    select_objects(obj)
    run_bake(method=method, rotation_mode="AXIS_ANGLE", new_action=False)
    values = evaluated(obj, np.arange(1, 42), "values")
    assert values[0, 0] == pytest.approx(0.0, abs=1e-6) and values[-1, 0] == pytest.approx(4 * math.pi, abs=1e-4)
    assert (np.diff(values[:, 0]) > 0).all()  # always forward
    np.testing.assert_allclose(values[:, 1:], [[0, 0, 1]] * 41, atol=1e-6)


def test_keep_with_a_quaternion_source_writes_quaternions(scene):
    obj = add_empty("Cube", "QUATERNION")
    key(obj, "rotation_quaternion", [(1, (1, 0, 0, 0)), (9, Quaternion((0, 0, 1), 2.0))])
    select_objects(obj)
    run_bake(method="NLERP", rotation_mode="KEEP")
    assert obj.rotation_mode == "QUATERNION"
    path = [f.data_path for f in fcurves.Channels.of(obj).fcurves]
    assert path.count("rotation_quaternion") == 4 and "rotation_euler" not in path


def test_new_action_keeps_the_original_and_everything_else(scene):
    obj = add_empty("Cube", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (11, (30, 60, 90))], degrees=True)
    key(obj, "location", [(1, (0, 0, 0)), (5, (1, 2, 3))], interpolation="BEZIER")
    key(obj, "scale", [(3, (1, 2, 1))], interpolation="CONSTANT")
    obj["power"] = 1.0
    obj.keyframe_insert('["power"]', frame=7)
    original = fcurves.active_action(obj)
    digest = fcurves.action_digest(original)
    others = {(f.data_path, f.array_index): fcurves.fcurve_digest(f).hexdigest()
              for f in fcurves.Channels.of(obj).fcurves if not f.data_path.startswith("rotation")}
    select_objects(obj)
    settings = run_bake(method="SQUAD", rotation_mode="QUATERNION")
    baked = fcurves.active_action(obj)
    assert baked != original and baked.name.startswith(original.name)
    assert original.use_fake_user and fcurves.action_digest(original) == digest
    channels = fcurves.Channels.of(obj)
    assert {(f.data_path, f.array_index): fcurves.fcurve_digest(f).hexdigest()
            for f in channels.fcurves if not f.data_path.startswith("rotation")} == others
    rotation = [f for f in channels.fcurves if f.data_path.startswith("rotation")]
    assert sorted((f.data_path, f.array_index) for f in rotation) == [("rotation_quaternion", i) for i in range(4)]
    assert all(fcurves.key_count(f) == 11 for f in rotation)
    assert settings.last_targets == 1 and settings.last_keys == 44 and "44 keys" in settings.last_summary


def test_in_place_replaces_only_the_rotation_curves(scene):
    obj = add_empty("Cube", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (11, (30, 60, 90))], degrees=True)
    key(obj, "location", [(1, (0, 0, 0)), (5, (1, 2, 3))])
    original = fcurves.active_action(obj)
    location = fcurves.fcurve_digest(fcurves.Channels.of(obj).find("location", 1)).hexdigest()
    actions = len(bpy.data.actions)
    select_objects(obj)
    run_bake(method="SLERP", rotation_mode="XYZ", new_action=False)
    assert fcurves.active_action(obj) == original and len(bpy.data.actions) == actions
    channels = fcurves.Channels.of(obj)
    assert fcurves.fcurve_digest(channels.find("location", 1)).hexdigest() == location
    assert fcurves.key_count(channels.find("rotation_euler", 0)) == 11


def test_pose_bone_bake_touches_only_the_selected_bones(scene):
    rig = add_rig(bones=("B0", "B1", "B2"))
    for i, name in enumerate(("B0", "B1", "B2")):
        key(rig.pose.bones[name], "rotation_quaternion",
            [(1, (1, 0, 0, 0)), (11, Quaternion((1, 0, 0), 1.0 + i)), (21, Quaternion((0, 1, 0), 2.0))])
    key(rig.pose.bones["B1"], "location", [(1, (0, 0, 0)), (21, (0, 1, 0))])
    original = fcurves.active_action(rig)
    digest = fcurves.action_digest(original)
    untouched = {(f.data_path, f.array_index): fcurves.fcurve_digest(f).hexdigest()
                 for f in fcurves.Channels.of(rig).fcurves if '"B1"].rotation' not in f.data_path}
    bpy.context.view_layer.objects.active = rig
    select_bones(rig, {"B1"})
    run_bake(method="SQUAD", rotation_mode="XYZ")
    assert fcurves.action_digest(original) == digest
    baked = fcurves.Channels.of(rig)
    assert {(f.data_path, f.array_index): fcurves.fcurve_digest(f).hexdigest()
            for f in baked.fcurves if '"B1"].rotation' not in f.data_path} == untouched
    assert rig.pose.bones["B1"].rotation_mode == "XYZ"
    assert [rig.pose.bones[b].rotation_mode for b in ("B0", "B2")] == ["QUATERNION", "QUATERNION"]
    path = rig.pose.bones["B1"].path_from_id("rotation_euler")
    assert all(fcurves.key_count(f) == 21 for f in baked.find_all(path, 3))


def test_objects_sharing_an_action_get_one_copy(scene):
    a, b = add_empty("A", "XYZ"), add_empty("B", "XYZ")
    key(a, "rotation_euler", [(1, (0, 0, 0)), (5, (0, 0, 90))], degrees=True)
    if fcurves.SLOTTED:
        key(b, "rotation_euler", [(1, (0, 0, 0)), (9, (90, 0, 0))], degrees=True)
        b.animation_data.action = a.animation_data.action   # a second slot of one action
        key(b, "rotation_euler", [(1, (0, 0, 0)), (9, (90, 0, 0))], degrees=True)
    else:
        b.animation_data_create().action = a.animation_data.action
    select_objects(a, b)
    settings = run_bake(method="SLERP", rotation_mode="QUATERNION")
    assert settings.last_targets == 2
    assert fcurves.active_action(a) == fcurves.active_action(b) != None  # noqa: E711
    assert fcurves.active_action(a).name.endswith("_slerp")


def test_step_and_explicit_frame_range(scene):
    obj = add_empty("Cube", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (30, (0, 0, 90))], degrees=True)
    select_objects(obj)
    run_bake(method="SLERP", frame_start=5, frame_end=20, step=4)
    frames, _ = fcurves.read_keys(fcurves.Channels.of(obj).find("rotation_euler", 2))
    np.testing.assert_array_equal(frames, [5, 9, 13, 17, 20])   # the last frame is always keyed


def test_default_frame_range_is_the_keyed_range_of_the_selection(scene):
    a, b = add_empty("A", "XYZ"), add_empty("B", "QUATERNION")
    key(a, "rotation_euler", [(3, (0, 0, 0)), (11, (0, 0, 90))], degrees=True)
    key(b, "rotation_quaternion", [(7, (1, 0, 0, 0)), (24, (0, 0, 0, 1))])
    select_objects(a, b)
    assert targets.default_frame_range(targets.gather_targets(bpy.context)) == (3, 24)
    run_bake(method="SLERP")
    for obj, prop in ((a, "rotation_euler"), (b, "rotation_quaternion")):
        frames, _ = fcurves.read_keys(fcurves.Channels.of(obj).find(prop, 0))
        assert (frames[0], frames[-1], len(frames)) == (3, 24, 22)


def test_the_plain_functions_bake_without_the_operator(scene):
    obj = add_empty("Cube", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 90))], degrees=True)
    result = bake.bake([targets.Target(obj)], bake.BakeSettings(method="TCB", tension=0.5,
                                                             rotation_mode="QUATERNION"))
    assert result.keys_written == 44 and result.seconds >= 0
    assert result.targets[0].name == "Cube" and result.targets[0].source_keys == 2
    assert "Cube" in result.lines()[0]


def test_operator_is_registered_with_undo_and_in_menus(scene):
    op = bpy.types.QUATCURVE_OT_bake
    assert {"REGISTER", "UNDO"} <= set(op.bl_options)
    assert bpy.ops.quatcurve.bake.idname() == "QUATCURVE_OT_bake"
    draw_funcs = bpy.types.VIEW3D_MT_object_animation._dyn_ui_initialize()
    assert any(getattr(f, "__name__", "") == "draw_bake_menu_item" for f in draw_funcs)


def test_panel_settings_drive_the_operator(scene):
    obj = add_empty("Cube", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (31, (0, 0, 90))], degrees=True)
    settings = bpy.context.scene.quatcurve
    settings.method, settings.rotation_mode, settings.step = "NLERP", "QUATERNION", 10
    settings.use_keyed_range, settings.frame_start, settings.frame_end = False, 11, 21
    select_objects(obj)
    run_bake()
    frames, _ = fcurves.read_keys(fcurves.Channels.of(obj).find("rotation_quaternion", 0))
    np.testing.assert_array_equal(frames, [11, 21])
    assert "Cube: Nlerp, XYZ → QUATERNION" in settings.last_lines  # the method's label, as the menu says it


def test_tolerance_goes_through_the_reduction_hook(scene, monkeypatch):
    """With a reducer plugged into bake.reduce_keys, tolerance > 0 writes its keys (here: every
    other frame, LINEAR) and reports them; the reducer gets the method's curve, to prove its keys
    against at every instant."""
    class Reduced:
        interpolation = "LINEAR"

        def __init__(self, frames, values):
            self.keys = [(frames[::2], values[::2, i], None, None) for i in range(values.shape[1])]
            self.key_count = sum(len(k[0]) for k in self.keys)
            self.max_error = self.bound = math.radians(0.05)

        def error_text(self, tolerance):
            return "max error 0.0500° at every instant"

    calls = []

    def reducer(frames, values, mode, tolerance, curve=None, one_key=True):
        calls.append((mode, tolerance))
        assert type(curve).__name__ == "Curve" and one_key  # (not a loop)
        return Reduced(frames, values)

    monkeypatch.setattr(bake, "reduce_keys", reducer)
    obj = add_empty("Cube", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (21, (0, 0, 90))], degrees=True)
    select_objects(obj)
    settings = run_bake(method="SLERP", rotation_mode="QUATERNION", tolerance=0.5)
    assert calls == [("QUATERNION", pytest.approx(math.radians(0.5)))]
    frames, _ = fcurves.read_keys(fcurves.Channels.of(obj).find("rotation_quaternion", 0))
    np.testing.assert_array_equal(frames, np.arange(1, 22, 2))
    assert settings.last_keys == 44 and "reduced to 44 keys within 0.5°" in settings.last_lines


def test_bake_clamped_is_an_option(scene):
    """SQUAD through a quick move then a long ease (keys at 1, 2, 102; 86° keyed in all): the default
    clamped tangents keep the path within the path rule; clamped=False bakes the textbook SQUAD,
    whose long segment wanders further."""
    keys = [(1, (1, 0, 0, 0)), (2, (0.766, 0.643, 0, 0)), (102, (0.74, 0.64, 0.05, 0.0))]
    lengths = {}
    for clamped in (True, False):
        obj = add_empty("Ease%d" % clamped, "QUATERNION")
        key(obj, "rotation_quaternion", keys)
        bake.bake([targets.Target(obj)], bake.BakeSettings(method="SQUAD", clamped=clamped,
                                                           rotation_mode="QUATERNION"))
        baked = targets.read_rotation_keys(targets.Target(obj))  # the baked action, a key every frame
        assert len(baked.frames) == 102
        lengths[clamped] = float(np.degrees(angles_between(baked.values[1:], baked.values[:-1])).sum())
    assert lengths[True] <= 1.5 * 86 + 10
    assert lengths[False] > lengths[True]


@pytest.mark.parametrize("method", ["SQUAD", "SLERP"])
def test_euler_bake_swinging_past_gimbal_lock_is_proved(scene, method, tmp_path):
    """Quaternion keys 10-20 frames apart (random, large turns) baked to XYZ with a tolerance of 0.05°:
    the paths that swing past XYZ's gimbal lock between frames keep one Euler branch from sample to
    sample, also where the reduction's proof adds samples (before, a change of branch stayed between two
    samples 1/1024 frame apart: above the tolerance, up to 11.7°). Every target is proved within the
    tolerance, and Blender's playback of the saved file, in a fresh process at 64 points per frame and
    100 random times, stays within it of the method's curve."""
    from everywhere_scenes import reference_curve
    from quatcurve_blender import fit
    from test_fit import fresh_blender_quats
    frames = (1, 11, 26, 40, 60, 75)
    objects = []
    for seed in (35, 36, 38, 39, 44, 46):
        q = np.random.default_rng(seed).normal(size=(len(frames), 4))
        obj = add_empty("Seed%d" % seed, "QUATERNION")
        key(obj, "rotation_quaternion", zip(frames, (tuple(v / np.linalg.norm(v)) for v in q)), interpolation="BEZIER")
        objects.append(obj)
    found = [targets.Target(o) for o in objects]
    keys = [fit.read_animator_keys(t) for t in found]
    result = bake.bake(found, bake.BakeSettings(method=method, rotation_mode="XYZ", tolerance=0.05))
    lines = result.lines()
    assert not any("ABOVE" in line for line in lines), lines
    assert sum("at every instant" in line for line in lines) == len(objects), lines
    rng = np.random.default_rng(1)
    times = np.unique(np.r_[np.arange(64, 75 * 64 + 1) / 64.0, np.round(rng.uniform(1, 75, 100) * 65536) / 65536])
    blend = tmp_path / "euler_bake.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    got = fresh_blender_quats(blend, [[o.name, None] for o in objects], times, tmp_path)
    for obj, k in zip(objects, keys):
        assert obj.rotation_mode == "XYZ"
        err = np.degrees(angles_between(got[obj.name], reference_curve(k, method).sample(times)))
        assert err.max() <= 0.05 + 1e-4, "%s: %.5f° at frame %s" % (obj.name, err.max(), times[err.argmax()])
