"""quatcurve.set_turns in every Blender: the segment leaving each selected key of a fitted quaternion
target turns N extra full turns about its own axis (every method, 1, 2 and -1 turns), and Blender's own
evaluation — in a fresh process without the add-on, from the saved .blend — plays it within the
tolerance at every frame and 4 subframes; the turns are stored per key, kept by refits and live
refits and carried along when keys move; axis-angle targets get their turns in the angle keys (every
key the same rotation); refusals (a still segment without a neighbour's axis, Euler targets, no
selected key, a target not fitted) change nothing; undo in a window (sessions/turns_undo_session.py)."""
import math

import bpy
import numpy as np
import pytest

from bake_helpers import add_empty, angles_between, file_state, key, select_objects
from quatcurve_blender import fcurves, fit, live, native
from test_fit import check_times, fresh_blender_quats, rotation_keys
from test_session import windowed

METHODS = ("SLERP", "NLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2")
TOL = 0.05  # degrees


def rz(deg):
    a = math.radians(deg) / 2
    return (math.cos(a), 0.0, 0.0, math.sin(a))


# 0 → 90° about Z over frames 1..13 (the segment that turns), then on to a tilted key
KEYS = [(1, (1.0, 0.0, 0.0, 0.0)), (13, rz(90)), (21, (0.5, 0.5, 0.5, 0.5))]


def select_keys(owner, frames):
    """Selects the rotation keys on `frames` (every channel), deselects the others."""
    prop, count = fcurves.rotation_property(owner.rotation_mode)
    for curve in fcurves.Channels.of(owner.id_data).find_all(owner.path_from_id(prop), count):
        for p in curve.keyframe_points:
            p.select_control_point = p.select_left_handle = p.select_right_handle = p.co[0] in frames


def spin_object(name, keys=KEYS, method="SLERP"):
    obj = add_empty(name, "QUATERNION")
    key(obj, "rotation_quaternion", keys, interpolation="BEZIER")
    select_objects(obj)
    assert bpy.ops.quatcurve.fit(method=method, tolerance=TOL) == {"FINISHED"}
    return obj


def turn_about(quats, axis):
    """The signed turn (radians) about `axis` of the quaternions relative to the first: 2·atan2(v·u, w),
    unwrapped (the quaternions' signs made continuous first)."""
    q = np.array(quats, float)
    for i in range(1, len(q)):
        if np.dot(q[i], q[i - 1]) < 0:
            q[i] = -q[i]
    w0, v0 = q[0, 0], -q[0, 1:]
    w = w0 * q[:, 0] - q[:, 1:] @ v0
    v = w0 * q[:, 1:] + q[:, :1] * v0 + np.cross(v0, q[:, 1:])
    angle = np.unwrap(2 * np.arctan2(v @ np.asarray(axis, float), w))
    return angle[-1] - angle[0]


def test_every_method_and_turn_count_plays_in_a_fresh_blender(scene, tmp_path):
    """One object per method and turn count (1, 2, -1 on the segment leaving frame 1), set through the
    operator; one fresh process evaluates them all."""
    qc = native.require()
    frames = np.array([f for f, _ in KEYS], float)
    values = np.array([v for _, v in KEYS], float)
    cases = [(m, n) for m in METHODS for n in (1, 2, -1)]
    generated = {}
    for method, n in cases:
        obj = spin_object("%s_%d" % (method, n), method=method)
        select_keys(obj, {1})
        assert bpy.ops.quatcurve.set_turns(turns=n) == {"FINISHED"}
        action, target = fcurves.active_action(obj), fit.targets.Target(obj)
        np.testing.assert_array_equal(fit.key_turns(action, target, frames), [n, 0, 0])
        generated[obj.name] = sum(int((t == fit.KEY_TYPE_GENERATED).sum()) for _, _, t in rotation_keys(obj))
    blend = tmp_path / "turns.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    times = check_times(1, 21)
    got = fresh_blender_quats(blend, [[name, None] for name in generated], times, tmp_path)
    on_segment = times <= 13
    for method, n in cases:
        name = "%s_%d" % (method, n)
        want = qc.Curve(frames, values, method, turns=[n, 0, 0]).sample(times)
        err = np.degrees(angles_between(got[name], want))
        assert err.max() <= TOL + 1e-4, "%s: max %.5f° at frame %s (%d generated keys)" % (
            name, err.max(), times[err.argmax()], generated[name])
        turned = turn_about(got[name][on_segment], (0, 0, 1))
        assert turned == pytest.approx(math.pi / 2 + 2 * math.pi * n, abs=math.radians(0.5)), name
        print("turns %s %+d: %d generated keys, max error %.5f° (Blender, fresh process), turn %.2f°"
              % (name, n, generated[name], err.max(), math.degrees(turned)))


def test_720_spin_between_equal_keys_takes_the_next_segments_axis(scene, tmp_path):
    """Two equal keys (frames 1 and 49) and a third 90° about Z later: two turns on the still segment
    spin 720° about Z (the next segment's axis) — the measured figure of docs/turns.md."""
    qc = native.require()
    keys = [(1, (1.0, 0.0, 0.0, 0.0)), (49, (1.0, 0.0, 0.0, 0.0)), (61, rz(90))]
    obj = spin_object("Spin720", keys, method="SLERP")
    select_keys(obj, {1})
    assert bpy.ops.quatcurve.set_turns(turns=2) == {"FINISHED"}
    blend = tmp_path / "spin.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    times = check_times(1, 61)
    got = fresh_blender_quats(blend, [["Spin720", None]], times, tmp_path)["Spin720"]
    frames = np.array([f for f, _ in keys], float)
    want = qc.Curve(frames, np.array([v for _, v in keys], float), "SLERP", turns=[2, 0, 0]).sample(times)
    err = np.degrees(angles_between(got, want))
    generated = sum(int((t == fit.KEY_TYPE_GENERATED).sum()) for _, _, t in rotation_keys(obj))
    assert err.max() <= TOL + 1e-4
    assert turn_about(got[times <= 49], (0, 0, 1)) == pytest.approx(4 * math.pi, abs=math.radians(0.5))
    print("720° spin (SLERP, 4 channels): %d generated keys, max error %.5f° (Blender %s, fresh process)"
          % (generated, err.max(), bpy.app.version_string))


def test_refit_live_refit_and_moved_keys_keep_the_turns(scene):
    qc = native.require()
    obj = spin_object("Live", method="SQUAD")
    select_keys(obj, {13})
    assert bpy.ops.quatcurve.set_turns(turns=-1) == {"FINISHED"}
    action, target = fcurves.active_action(obj), fit.targets.Target(obj)
    # a refit through the fit operator keeps them
    assert bpy.ops.quatcurve.fit(method="TCB", tolerance=TOL) == {"FINISHED"}
    np.testing.assert_array_equal(fit.key_turns(action, target, np.array([1, 13, 21.0])), [0, -1, 0])
    # live: the key at 13 moves to 15; the turns go with it and the refit plays them
    live.STATS.reset()
    live.drag_hook = None
    scene.quatcurve_fit.live = True
    try:
        bpy.context.view_layer.update()
        for curve in fcurves.Channels.of(obj).find_all(obj.path_from_id("rotation_quaternion"), 4):
            for p in curve.keyframe_points:
                if p.co[0] == 13 and p.type != fit.GENERATED_NAME:
                    p.co[0] = 15
                    p.handle_left[0] += 2
                    p.handle_right[0] += 2
            curve.update()
        bpy.context.view_layer.update()
        assert live.STATS.refits == 1, live.STATS
    finally:
        scene.quatcurve_fit.live = False
        live.on_load()
    frames = np.array([1, 15, 21.0])
    np.testing.assert_array_equal(fit.key_turns(action, target, frames), [0, -1, 0])
    values = np.array([v for _, v in KEYS], float)
    want = qc.Curve(frames, values, "TCB", turns=[0, -1, 0])
    times = np.arange(1, 22, 0.5)
    got = []
    for t in times:
        scene.frame_set(int(t), subframe=float(t - int(t)))
        got.append(tuple(obj.rotation_quaternion))
    err = np.degrees(angles_between(np.array(got), want.sample(times)))
    assert err.max() <= TOL + 1e-3, "max %.4f° at frame %s" % (err.max(), times[err.argmax()])
    # set_ease keeps the turns; unfit removes them
    select_keys(obj, {1})
    assert bpy.ops.quatcurve.set_ease(ease_in=0.0, ease_out=0.5) == {"FINISHED"}
    np.testing.assert_array_equal(fit.key_turns(action, target, frames), [0, -1, 0])
    assert bpy.ops.quatcurve.unfit() == {"FINISHED"}
    assert len(action.quatcurve_turns) == 0


def test_the_refit_reports_its_bound_and_warns_above_the_tolerance(scene):
    """Set Turns and Set Ease refit, and report the refit's bound as a fit does: 2 turns on a 12-frame
    segment keep the tolerance; 50 turns on an NLERP segment of 1.7 frames cannot (its quaternion keys
    would need to be closer than a fit writes them) — the report says so, with the bound Blender's
    playback keeps, where it once said only '+50 turns on 1 key' (found by random keys)."""
    obj = spin_object("Kept")
    select_keys(obj, {1})
    assert bpy.ops.quatcurve.set_turns(turns=2) == {"FINISHED"}
    summary = bpy.context.scene.quatcurve_fit.last_summary
    assert summary.startswith("+2 turns on 1 key, refit 1 target: max error ") and "ABOVE" not in summary, summary
    assert float(summary.split("max error ")[1].split("°")[0]) <= TOL
    assert bpy.ops.quatcurve.set_ease(ease_in=0.5) == {"FINISHED"}
    assert bpy.context.scene.quatcurve_fit.last_summary.startswith("Ease in 0.50 / out 0.00 on 1 key, refit 1 target")

    frames = (1000.0, 1002.81, 1004.5122)
    quats = ((-0.01256, 0.51669, -0.62644, -0.58348), (0.21193, 0.35880, -0.51923, -0.74616),
             (0.21193, 0.35880, -0.51923, -0.74616))
    fast = spin_object("Fast", list(zip(frames, quats)), method="NLERP")
    select_keys(fast, {np.float32(1002.81)})
    assert bpy.ops.quatcurve.set_turns(turns=50) == {"FINISHED"}
    summary = bpy.context.scene.quatcurve_fit.last_summary
    assert "+50 turns on 1 key, refit 1 target: max error" in summary and "ABOVE the tolerance on Fast" in summary, summary
    bound = float(summary.split("max error ")[1].split("°")[0])
    assert bound > TOL
    lines = bpy.context.scene.quatcurve_fit.last_lines
    assert "Fast: QUATERNION" in lines and "ABOVE the tolerance" in lines, lines


def test_set_turns_from_python(scene):
    """fit.set_turns is the operator's function: scripts call it on Targets."""
    obj = spin_object("Script")
    select_keys(obj, {1, 21})  # the last key has no segment: its selection is ignored
    assert fit.set_turns([fit.targets.Target(obj)], 3).changed == 1
    action = fcurves.active_action(obj)
    np.testing.assert_array_equal(fit.key_turns(action, fit.targets.Target(obj), np.array([1, 13, 21.0])), [3, 0, 0])
    select_keys(obj, {1})
    assert fit.set_turns([fit.targets.Target(obj)], 0).changed == 1
    assert len(action.quatcurve_turns) == 0
    for bad in (0.5, float("nan"), 1e9):
        with pytest.raises(fit.FitError, match="must be a whole number"):
            fit.set_turns([fit.targets.Target(obj)], bad)


@pytest.mark.parametrize("case", ["still", "euler", "no_selection", "not_fitted"])
def test_refusals_name_the_target_and_change_nothing(scene, case):
    if case == "still":  # two equal keys: no axis of their own and no neighbour
        obj = spin_object("Still", [(1, rz(30)), (11, rz(30))])
        expect = r"Still: turns\[0\]: the key at frame 1 and the key at frame 11 are the same rotation"
    elif case == "euler":
        obj = add_empty("Euler", "XYZ")
        key(obj, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 1.0))], interpolation="BEZIER")
        select_objects(obj)
        bpy.ops.quatcurve.fit(method="SLERP", tolerance=TOL)
        expect = "Euler: rotation mode XYZ: Euler keys already keep their turns"
    elif case == "no_selection":
        obj = spin_object("Unselected")
        expect = "no selected rotation key"
    else:
        obj = add_empty("Plain", "QUATERNION")
        key(obj, "rotation_quaternion", KEYS, interpolation="BEZIER")
        select_objects(obj)
        expect = r"Plain: not fitted \(fit it first"
    select_keys(obj, set() if case == "no_selection" else {1})
    state = file_state()
    records = [len(fcurves.active_action(obj).quatcurve_turns)]
    with pytest.raises(RuntimeError, match=expect):
        bpy.ops.quatcurve.set_turns(turns=1)
    assert file_state() == state
    assert [len(fcurves.active_action(obj).quatcurve_turns)] == records


def test_undo_restores_the_keys_and_the_turns(tmp_path):
    verdict = windowed("turns_undo_session.py", tmp_path / "turns_undo.json")
    assert verdict["result"] == ["FINISHED"]
    assert verdict["changed"], "set_turns changed nothing, so undo proves nothing"
    assert verdict["turns_after"] == [[1.0, 2]]
    assert verdict["restored"], verdict["differences"]


def test_turns_apply_to_quaternion_keys_only(scene):
    """A target whose rotation mode changed to Euler after its turns were set plays its Euler keys' own
    turns: the stored turns are not added (the Euler channels, kept as keyed, could not add one)."""
    qc = native.require()
    obj = spin_object("Switched")
    select_keys(obj, {1})
    assert bpy.ops.quatcurve.set_turns(turns=1) == {"FINISHED"}
    angles = [(1, (0.0, 0.0, 0.0)), (13, (0.0, 0.0, math.pi / 2)), (21, (0.3, 0.2, 1.0))]
    obj.rotation_mode = "XYZ"
    key(obj, "rotation_euler", angles, interpolation="BEZIER")
    assert bpy.ops.quatcurve.fit(method="SLERP", tolerance=TOL) == {"FINISHED"}
    frames = np.array([f for f, _ in angles], float)
    want = qc.Curve.from_euler(frames, np.array([a for _, a in angles]), "XYZ", "SLERP").sample(check_times(1, 21))
    got = []
    for t in check_times(1, 21):
        scene.frame_set(int(t), subframe=float(t - int(t)))
        got.append(obj.matrix_world.to_quaternion()[:])
    err = np.degrees(angles_between(np.array(got), want))
    assert err.max() <= TOL + 1e-3, "max %.4f° at frame %s" % (err.max(), check_times(1, 21)[err.argmax()])


@pytest.mark.parametrize("method", ["SLERP", "SQUAD"])
def test_axis_angle_turns_live_in_the_angle_keys_and_play_in_a_fresh_blender(scene, tmp_path, method):
    """Axis-angle keys 0°, 90°, 180°, 150° about Z (frames 1, 11, 21, 31): 1, 2, -1 and 0 turns on the
    segment leaving frame 11 move the angles of the keys after it by whole turns (each key the same
    rotation, every other segment the same change), the fit plays the spin, and the turns are not
    stored apart (the keys carry them, so a live refit keeps them)."""
    qc = native.require()
    keys = [(1, (0.0, 0, 0, 1)), (11, (math.radians(90), 0, 0, 1)), (21, (math.radians(180), 0, 0, 1)),
            (31, (math.radians(150), 0, 0, 1))]
    frames = np.array([f for f, _ in keys], float)
    rotations = qc.channels_to_quats(np.array([v for _, v in keys], float), "AXIS_ANGLE")
    objects = {}
    for n, want in ((1, [0, 90, 540, 510]), (2, [0, 90, 900, 870]), (-1, [0, 90, -180, -210]), (0, [0, 90, 180, 150])):
        obj = add_empty("AA%s_%d" % (method, n), "AXIS_ANGLE")
        key(obj, "rotation_axis_angle", keys, interpolation="BEZIER")
        select_objects(obj)
        assert bpy.ops.quatcurve.fit(method=method, tolerance=TOL) == {"FINISHED"}
        select_keys(obj, {11})
        assert bpy.ops.quatcurve.set_turns(turns=n) == {"FINISHED"}
        got = fit.read_animator_keys(fit.targets.Target(obj)).values
        np.testing.assert_allclose(np.degrees(got[:, 0]), want, atol=1e-4)
        assert angles_between(qc.channels_to_quats(got, "AXIS_ANGLE"), rotations).max() < 1e-6
        assert len(fcurves.active_action(obj).quatcurve_turns) == 0
        objects[obj.name] = (n, got)
    blend = tmp_path / "axis_turns.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    times = check_times(1, 31)
    played = fresh_blender_quats(blend, [[name, None] for name in objects], times, tmp_path)
    segment = (times >= 11) & (times <= 21)
    for name, (n, got) in objects.items():
        want = qc.Curve.from_axis_angle(frames, got, method).sample(times)
        err = np.degrees(angles_between(played[name], want))
        assert err.max() <= TOL + 1e-4, "%s: max %.5f° at frame %s" % (name, err.max(), times[err.argmax()])
        turned = turn_about(played[name][segment], (0, 0, 1))
        assert turned == pytest.approx(math.radians(90 + 360 * n), abs=math.radians(0.5)), name
