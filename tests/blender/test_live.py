"""Live fit (live.py) in every Blender, background mode: the depsgraph handler runs on
view_layer.update() / frame_set. After an inserted, a moved, a deleted and a changed key the target
is refitted once (the animator's keys stay exactly, up to quaternion signs; Blender's evaluation
plays the method); nothing is touched (digest, refit count) for a location key, with live off, or for
our own write coming back; a drag defers (test hook, 4.2+ modal operators, 3.4's debounce); only the
changed bone of a rig refits. Undo in a window (Debian's Blender under Xvfb): sessions/live_undo_session.py."""
import math
from types import SimpleNamespace

import bpy
import numpy as np
import pytest

from bake_helpers import add_empty, add_rig, angles_between, evaluated, key, select_bones, select_objects
from quatcurve_blender import fcurves, fit, live, native

TOL = 0.05  # degrees
QUAT_KEYS = [(1, (1, 0, 0, 0)), (5, (0.7071, 0.7071, 0, 0)), (6, (0.5, 0.5, 0.5, 0.5)),
             (30, (-0.2, 0.1, 0.9, -0.38)), (31, (0.1, 0.2, 0.9, -0.37))]


def rotation_keys(owner):
    """Per rotation channel: (frames, values, types) of every key."""
    prop, count = fcurves.rotation_property(owner.rotation_mode)
    out = []
    for curve in fcurves.Channels.of(owner.id_data).find_all(owner.path_from_id(prop), count):
        frames, values = fcurves.read_keys(curve)
        out.append((frames, values, fcurves.read_key_types(curve)))
    return out


def animator_keys(owner):
    """(frames, values (K, C)) of the animator's keys (the union over channels: all keyed together here)."""
    chans = [(f[t != fit.KEY_TYPE_GENERATED], v[t != fit.KEY_TYPE_GENERATED]) for f, v, t in rotation_keys(owner)]
    for f, _ in chans[1:]:
        np.testing.assert_array_equal(f, chans[0][0])
    return chans[0][0], np.stack([v for _, v in chans], axis=1)


def generated_keys(owner):
    return [(f[t == fit.KEY_TYPE_GENERATED], v[t == fit.KEY_TYPE_GENERATED]) for f, v, t in rotation_keys(owner)]


def digest(owner):
    return fcurves.action_digest(fcurves.active_action(owner.id_data))


def update():
    bpy.context.view_layer.update()


def assert_plays_method(owner, frames, values, method="SQUAD"):
    """Blender's evaluation at every frame (frame_set) within TOL of the method's curve through the keys."""
    qc = native.require()
    times = np.arange(frames[0], frames[-1] + 1)
    if owner.rotation_mode == "QUATERNION":
        want = qc.Curve(frames, values, method).sample(times)
    else:
        want = qc.Curve.from_euler(frames, values, order=owner.rotation_mode, method=method).sample(times)
    got = evaluated(owner, times)
    err = np.degrees(angles_between(got, want))
    assert err.max() <= TOL + 1e-3, "max %.4f° at frame %s" % (err.max(), times[err.argmax()])


@pytest.fixture
def live_scene(scene):
    live.STATS.reset()
    live.drag_hook = None
    yield scene
    live.drag_hook = None
    live.on_load()


@pytest.fixture
def fitted(live_scene):
    """A quaternion empty with rotation and location keys, fitted with SQUAD, live on."""
    obj = add_empty("Quat", "QUATERNION")
    key(obj, "rotation_quaternion", QUAT_KEYS, interpolation="BEZIER")
    obj.keyframe_insert("location", frame=1)
    select_objects(obj)
    assert bpy.ops.quatcurve.fit(method="SQUAD", tolerance=TOL) == {"FINISHED"}
    live_scene.quatcurve_fit.live = True
    update()
    assert live.STATS.refits == 0  # signatures match: nothing to do
    live.STATS.reset()
    return obj


def free_frame(owner, near):
    """A frame near `near` at least 0.05 from every key of the rotation curves (no merge on update)."""
    taken = np.concatenate([f for f, _, _ in rotation_keys(owner)])
    for f in np.arange(near, near + 3, 0.1):
        if np.abs(taken - f).min() > 0.05:
            return round(float(f), 4)
    raise AssertionError("no free frame near %s" % near)


def test_insert_refits_once_and_keeps_the_animators_keys(fitted):
    before_frames, before_values = animator_keys(fitted)
    generated_before = generated_keys(fitted)
    frame = free_frame(fitted, 15)
    new = np.array([0.6, 0.2, 0.7, 0.3])
    new /= np.linalg.norm(new)
    fitted.rotation_quaternion = new
    fitted.keyframe_insert("rotation_quaternion", frame=frame)
    update()
    assert live.STATS.refits == 1, live.STATS
    frames, values = animator_keys(fitted)
    np.testing.assert_array_equal(frames, np.sort(np.r_[before_frames, np.float32(frame)]))
    k = int(np.searchsorted(frames, np.float32(frame)))
    np.testing.assert_array_equal(np.abs(np.delete(values, k, axis=0)), np.abs(before_values))
    np.testing.assert_allclose(np.abs(values[k]), np.abs(new), atol=1e-7)
    assert any(not np.array_equal(f, f0) for (f, _), (f0, _) in zip(generated_keys(fitted), generated_before))
    assert fit.find_record(fcurves.active_action(fitted), fit.targets.Target(fitted)).signature == \
        fit.read_animator_keys(fit.targets.Target(fitted)).signature()
    # no loop: our own write comes back as an update, finds equal signatures
    state = digest(fitted)
    update()
    update()
    bpy.context.scene.frame_set(3)
    assert live.STATS.refits == 1 and digest(fitted) == state
    want = np.array([v for _, v in QUAT_KEYS[:3]] + [tuple(new)] + [v for _, v in QUAT_KEYS[3:]], float)
    assert_plays_method(fitted, frames.astype(float), want)


def test_refit_records_its_proved_bound_which_blender_keeps_between_frames(fitted):
    """The fit record's bound is the last fit's or refit's proof (fit.last_fit), for scripts; Blender's
    own F-curve evaluation at 64 points a frame and 200 random times stays within it."""
    qc = native.require()
    action = fcurves.active_action(fitted)
    target = fit.targets.Target(fitted)
    assert 0.0 < fit.find_record(action, target).bound <= math.radians(TOL)  # the Fit operator's
    fit.find_record(action, target).bound = 3.0  # no proof's: the refit must write its own
    frame = free_frame(fitted, 15)
    new = np.array([0.6, 0.2, 0.7, 0.3]) / np.linalg.norm([0.6, 0.2, 0.7, 0.3])
    fitted.rotation_quaternion = new
    fitted.keyframe_insert("rotation_quaternion", frame=frame)
    update()
    assert live.STATS.refits == 1, live.STATS
    bound = fit.find_record(action, target).bound
    assert bound == pytest.approx(fit.last_fit(action, target).proof.bound, rel=1e-6)
    assert 0.0 < bound <= math.radians(TOL)
    frames, _ = animator_keys(fitted)
    want = np.array([v for _, v in QUAT_KEYS[:3]] + [tuple(new)] + [v for _, v in QUAT_KEYS[3:]], float)
    curve = qc.Curve(frames.astype(float), want, "SQUAD")
    rng = np.random.default_rng(5)
    times = np.r_[np.arange(frames[0], frames[-1], 1.0 / 64), frames[-1], rng.uniform(frames[0], frames[-1], 200)]
    prop, count = fcurves.rotation_property(fitted.rotation_mode)
    curves = fcurves.Channels.of(fitted).find_all(fitted.path_from_id(prop), count)
    got = np.array([[c.evaluate(t) for c in curves] for t in times])
    err = angles_between(got, curve.sample(times))
    assert err.max() <= bound + 1e-6, "%.6f° at frame %.4f, bound %.6f°" % (
        math.degrees(err.max()), times[err.argmax()], math.degrees(bound))


def move_key(owner, old, new):
    """Moves the key at frame `old` to `new` on every rotation channel (handles along), as a drag does."""
    prop, count = fcurves.rotation_property(owner.rotation_mode)
    for curve in fcurves.Channels.of(owner.id_data).find_all(owner.path_from_id(prop), count):
        for point in curve.keyframe_points:
            if point.co[0] == old and point.type != fit.GENERATED_NAME:
                point.co[0] = new
                point.handle_left[0] += new - old
                point.handle_right[0] += new - old
        curve.update()


def test_moved_key_refits(fitted):
    _, before_values = animator_keys(fitted)
    target = free_frame(fitted, 12)
    move_key(fitted, 6, target)
    update()
    assert live.STATS.refits == 1, live.STATS
    frames, values = animator_keys(fitted)
    np.testing.assert_array_equal(frames, np.array([1, 5, target, 30, 31], np.float32))
    np.testing.assert_array_equal(np.abs(values), np.abs(before_values))
    want = np.array([v for _, v in QUAT_KEYS], float)
    assert_plays_method(fitted, frames.astype(float), want)


def test_deleted_key_refits(fitted):
    fitted.keyframe_delete("rotation_quaternion", frame=5)
    update()
    assert live.STATS.refits == 1, live.STATS
    frames, _ = animator_keys(fitted)
    np.testing.assert_array_equal(frames, [1, 6, 30, 31])
    want = np.array([v for f, v in QUAT_KEYS if f != 5], float)
    assert_plays_method(fitted, frames.astype(float), want)


def test_changed_value_refits_euler_keys_exactly(live_scene):
    obj = add_empty("Euler", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (11, (30, 10, 200)), (25, (0, 40, 300))],
        interpolation="BEZIER", degrees=True)
    select_objects(obj)
    bpy.ops.quatcurve.fit(method="SLERP", tolerance=TOL)
    live_scene.quatcurve_fit.live = True
    update()
    live.STATS.reset()
    curve = fcurves.Channels.of(obj).find(obj.path_from_id("rotation_euler"), 2)
    point = next(p for p in curve.keyframe_points if p.co[0] == 11)
    point.co[1] = math.radians(150)
    update()
    assert live.STATS.refits == 1
    frames, values = animator_keys(obj)
    np.testing.assert_array_equal(frames, [1, 11, 25])
    np.testing.assert_array_equal(values, np.radians([(0, 0, 0), (30, 10, 150), (0, 40, 300)]).astype(np.float32))
    assert_plays_method(obj, frames.astype(float), values, method="SLERP")


def test_a_refit_makes_handle_types_changed_by_the_animator_free_again(fitted):
    # A handle type changed alone refits nothing (the fit reads no handle types); the next refit writes
    # fitted FREE handles on every key again, wherever the changed ones sit.
    prop_path = fitted.path_from_id("rotation_quaternion")
    curves = fcurves.Channels.of(fitted).find_all(prop_path, 4)
    curves[1].keyframe_points[1].handle_left_type = "VECTOR"
    curves[2].keyframe_points[2].handle_right_type = "AUTO_CLAMPED"
    curves[3].keyframe_points[-1].handle_left_type = curves[3].keyframe_points[-1].handle_right_type = "ALIGNED"
    update()
    assert live.STATS.refits == 0
    point = next(p for p in curves[0].keyframe_points if p.co[0] == 6)
    point.co[1] += 0.05
    update()
    assert live.STATS.refits == 1, live.STATS
    for curve in fcurves.Channels.of(fitted).find_all(prop_path, 4):
        assert {(p.handle_left_type, p.handle_right_type) for p in curve.keyframe_points} == {("FREE", "FREE")}


def test_location_key_changes_nothing(fitted):
    fitted.location = (1, 2, 3)
    fitted.keyframe_insert("location", frame=9)
    state = digest(fitted)
    update()
    assert live.STATS.calls >= 1 and live.STATS.checks == 1, live.STATS  # checked, found equal
    assert live.STATS.refits == 0 and digest(fitted) == state


def test_unchanged_targets_are_not_read_again(fitted, monkeypatch):
    # The fixture's check read the keys (found fitted, its raw digest kept); later updates that leave
    # the rotation keys alone cost two bulk reads per channel, not a full read; a change of an
    # animator key's type is read in full and refits.
    from quatcurve_blender import fit
    reads = []
    real = fit.read_animator_keys
    monkeypatch.setattr(fit, "read_animator_keys", lambda target, *read: (reads.append(target.name), real(target, *read))[1])
    for frame in (9, 10, 11):
        fitted.location = (frame, 2, 3)
        fitted.keyframe_insert("location", frame=frame)
        update()
    assert reads == [] and live.STATS.checks == 3 and live.STATS.refits == 0, (reads, live.STATS)
    curve = fcurves.Channels.of(fitted).find(fitted.path_from_id("rotation_quaternion"), 0)
    first = next(p for p in curve.keyframe_points if p.type == "KEYFRAME")
    first.type = "BREAKDOWN"
    update()
    assert live.STATS.refits == 1 and reads == ["Quat"], (reads, live.STATS)


def test_live_off_leaves_everything_then_on_catches_up(fitted):
    bpy.context.scene.quatcurve_fit.live = False
    update()
    fitted.keyframe_delete("rotation_quaternion", frame=5)
    state = digest(fitted)
    update()
    bpy.context.scene.frame_set(4)
    assert live.STATS.refits == 0 and live.STATS.checks == 0 and digest(fitted) == state
    bpy.context.scene.quatcurve_fit.live = True  # switched on: edits made while off are refitted
    update()
    assert live.STATS.refits == 1 and digest(fitted) != state


def test_unfitted_action_is_ignored(live_scene):
    obj = add_empty("Plain", "QUATERNION")
    key(obj, "rotation_quaternion", QUAT_KEYS, interpolation="BEZIER")
    live_scene.quatcurve_fit.live = True
    update()
    obj.keyframe_delete("rotation_quaternion", frame=5)
    state = digest(obj)
    update()
    assert live.STATS.checks == 0 and live.STATS.refits == 0 and digest(obj) == state


def test_a_drag_defers_the_refit_until_it_ends(fitted):
    dragging = [True]
    live.drag_hook = lambda: dragging[0]
    fitted.keyframe_delete("rotation_quaternion", frame=5)
    state = digest(fitted)
    update()
    update()
    assert live.STATS.refits == 0 and live.STATS.deferred >= 1 and digest(fitted) == state
    assert live.process_pending() == live.POLL  # what the timer does while the drag runs
    dragging[0] = False
    assert live.process_pending() is None  # the drag ended: the timer's next call refits
    assert live.STATS.refits == 1 and digest(fitted) != state
    assert live.process_pending() is None and live.STATS.refits == 1


def test_modal_operators_tell_a_drag(monkeypatch):
    """4.2+: a transform (or a graph/dope sheet slider) in any window's modal operators is a drag;
    navigation is not. 3.4 has no such list: never a drag, the debounce covers it."""
    def windows(*names):
        return [SimpleNamespace(modal_operators=[SimpleNamespace(bl_idname=n) for n in names])]
    monkeypatch.setattr(live, "HAS_MODAL_LIST", True)
    monkeypatch.setattr(live, "_windows", lambda: windows("VIEW3D_OT_rotate", "TRANSFORM_OT_transform"))
    assert live.drag_in_progress()
    monkeypatch.setattr(live, "_windows", lambda: windows("GRAPH_OT_blend_to_neighbor"))
    assert live.drag_in_progress()
    monkeypatch.setattr(live, "_windows", lambda: windows("VIEW3D_OT_rotate") + windows())
    assert not live.drag_in_progress()
    monkeypatch.undo()
    assert live.HAS_MODAL_LIST == (bpy.app.version >= (4, 2, 0))
    assert not live.drag_in_progress()  # background: no modal operator runs


def test_debounce_without_a_modal_list(fitted, monkeypatch):
    """Blender 3.4 with a window: the handler only schedules; the timer refits once the keys have not
    changed for DEBOUNCE seconds."""
    scheduled = []
    monkeypatch.setattr(live, "HAS_MODAL_LIST", False)
    monkeypatch.setattr(live, "_windowed", lambda: True)
    monkeypatch.setattr(live, "_schedule", scheduled.append)
    fitted.keyframe_delete("rotation_quaternion", frame=5)
    update()
    assert scheduled == [live.DEBOUNCE] and live.STATS.refits == 0
    wait = live.process_pending()
    assert 0 < wait <= live.DEBOUNCE and live.STATS.refits == 0
    monkeypatch.setattr(live, "_last_change", live._last_change - live.DEBOUNCE)
    assert live.process_pending() is None and live.STATS.refits == 1


def test_only_the_changed_bone_refits(live_scene):
    rig = add_rig("Rig", bones=("A", "B", "C"))
    for pb in rig.pose.bones:
        key(pb, "rotation_quaternion", QUAT_KEYS, interpolation="BEZIER")
    select_bones(rig, ("A", "B", "C"))
    assert bpy.ops.quatcurve.fit(method="CATMULL_ROM", tolerance=TOL) == {"FINISHED"}
    live_scene.quatcurve_fit.live = True
    update()
    live.STATS.reset()

    def bone_digests():
        chans = fcurves.Channels.of(rig)
        return {pb.name: [fcurves.fcurve_digest(chans.find(pb.path_from_id("rotation_quaternion"), i)).hexdigest()
                          for i in range(4)] for pb in rig.pose.bones}
    before = bone_digests()
    rig.pose.bones["B"].keyframe_delete("rotation_quaternion", frame=6)
    update()
    after = bone_digests()
    assert live.STATS.refits == 1 and live.STATS.checks == 3, live.STATS
    assert after["A"] == before["A"] and after["C"] == before["C"] and after["B"] != before["B"]
    frames, _ = animator_keys(rig.pose.bones["B"])
    np.testing.assert_array_equal(frames, [1, 5, 30, 31])


def test_a_key_that_cannot_be_fitted_is_left_and_noted(fitted):
    curve = fcurves.Channels.of(fitted).find(fitted.path_from_id("rotation_quaternion"), 1)
    point = next(p for p in curve.keyframe_points if p.co[0] == 5)
    point.co[1] = float("nan")
    state = digest(fitted)
    update()
    assert live.STATS.refits == 0 and digest(fitted) == state
    assert any("is nan at frame 5" in e for e in live.STATS.errors), live.STATS.errors


def test_handlers_are_registered_once_and_removed(addon):
    lists = (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.undo_post, bpy.app.handlers.redo_post,
             bpy.app.handlers.load_post)
    live.register()  # twice (the session registered the add-on already): still once each
    assert [sum(h in (live.on_depsgraph_update, live.on_undo_redo, live.on_load) for h in hs) for hs in lists] == \
        [1, 1, 1, 1]
    live.unregister()
    assert not any(h in hs for hs in lists for h in (live.on_depsgraph_update, live.on_undo_redo, live.on_load))
    live.register()


def test_undo_after_a_live_refit_restores_the_file_exactly(tmp_path):
    """Debian's Blender with a window (Xvfb), live mode refitting from its timer: insert a key → live
    refit → ed.undo gives back exactly the file before the insert (the refit made no undo step of its
    own), ed.redo the refitted keys."""
    import test_session  # not `from … import`: its tests would be collected here too
    verdict = test_session.windowed("live_undo_session.py", tmp_path / "live_undo.json")
    assert verdict["fit"] == ["FINISHED"] and not verdict["errors"], verdict
    assert verdict["refits_after_insert"] == 1 and verdict["refit_changed_keys"], verdict
    assert verdict["undo_restored"] and verdict["still_restored"], verdict["differences"]
    assert verdict["refits_after_undo"] == 1, "live mode refitted after undo: %s" % verdict
    assert verdict["redo_refitted"] and verdict["refits_after_redo"] == 2, verdict


def test_only_generated_keys_left_is_noted_not_raised(fitted):
    # The animator deletes every key of their own: only the fit's generated keys are left, which are
    # no poses to fit through. The refit leaves the target as it is and notes why.
    prop_path = fitted.path_from_id("rotation_quaternion")
    for curve in fcurves.Channels.of(fitted).find_all(prop_path, 4):
        points = curve.keyframe_points
        for i in reversed(range(len(points))):
            if fcurves.read_key_types(curve)[i] != fit.KEY_TYPE_GENERATED:
                points.remove(points[i])
    state = digest(fitted)
    update()
    assert live.STATS.refits == 0 and digest(fitted) == state
    assert any("Quat: no animator keys on rotation_quaternion" in e for e in live.STATS.errors), live.STATS.errors
    select_objects(fitted)
    with pytest.raises(RuntimeError, match="Quat: no animator keys on rotation_quaternion"):
        bpy.ops.quatcurve.fit(method="SQUAD", tolerance=TOL)


def test_a_channel_left_with_generated_keys_only_is_read_where_the_others_are_keyed(fitted):
    # One channel's own keys deleted: its values at the animator's frames are Blender's evaluation of
    # what is left (the generated keys), as for a channel not keyed on a frame; the target is refitted.
    curve = fcurves.Channels.of(fitted).find(fitted.path_from_id("rotation_quaternion"), 2)
    points = curve.keyframe_points
    for i in reversed(range(len(points))):
        if fcurves.read_key_types(curve)[i] != fit.KEY_TYPE_GENERATED:
            points.remove(points[i])
    update()
    assert live.STATS.refits == 1 and not live.STATS.errors, live.STATS
    frames, _ = animator_keys(fitted)
    np.testing.assert_array_equal(frames, [f for f, _ in QUAT_KEYS])


def test_a_refit_fits_only_the_segments_an_edit_changed(fitted, monkeypatch):
    """The fit is kept (fit.last_fit) and lends the next refit its unchanged key segments: a value
    changed at the last key refits the segments its SQUAD tangents reach, the result still plays the
    method; the kept fits are bounded by their samples, the oldest dropped first."""
    target = fit.targets.Target(fitted)
    action = fcurves.active_action(fitted)
    first = fit.last_fit(action, target)
    assert first is not None and first.refitted == len(QUAT_KEYS) - 1
    frames, values = animator_keys(fitted)
    curve = fcurves.Channels.of(fitted).find("rotation_quaternion", 1)
    last = int(np.flatnonzero(fcurves.read_keys(curve)[0] == frames[-1])[0])
    curve.keyframe_points[last].co[1] += 0.05
    update()
    assert live.STATS.refits == 1, live.STATS
    again = fit.last_fit(action, target)
    assert again is not first and 1 <= again.refitted <= 2  # the last two segments at most
    frames, values = animator_keys(fitted)
    assert_plays_method(fitted, frames.astype(float), values)
    # the kept fits' budget: with room for one target's samples only, a second target's fit evicts the first
    monkeypatch.setattr(fit, "_LAST_FITS_SAMPLES", len(again.times))
    other = add_empty("Other", "QUATERNION")
    key(other, "rotation_quaternion", QUAT_KEYS, interpolation="BEZIER")
    select_objects(other)
    assert bpy.ops.quatcurve.fit(method="SQUAD", tolerance=TOL) == {"FINISHED"}
    assert fit.last_fit(fcurves.active_action(other), fit.targets.Target(other)) is not None
    assert fit.last_fit(action, target) is None


def curve_state(owner):
    """Per rotation F-curve: its digest (keys, handles, interpolation, handle types), key types and selection."""
    prop, count = fcurves.rotation_property(owner.rotation_mode)
    out = []
    for curve in fcurves.Channels.of(owner.id_data).find_all(owner.path_from_id(prop), count):
        out.append((fcurves.fcurve_digest(curve).hexdigest(), fcurves.read_key_types(curve).tolist(),
                    fcurves.read_key_selection(curve).tolist()))
    return out


def test_a_refit_over_kept_key_slots_leaves_what_a_full_write_leaves(fitted, monkeypatch):
    """A refit that keeps the F-curves' key slots (fit._rewrite_kept: same key count, types and
    selection) writes handles, interpolation and handle types on every key: what an animator changed
    in a segment the edit did not reach (an interpolation, a handle moved, a handle type) is fitted
    again, and the F-curves end up as the full write (new key slots) of the same fit leaves them."""
    kept = []
    real = fcurves.rewrite_handles
    monkeypatch.setattr(fcurves, "rewrite_handles", lambda *a: kept.append(a[0]) or real(*a))
    curves = fcurves.Channels.of(fitted).find_all(fitted.path_from_id("rotation_quaternion"), 4)
    frames, _ = animator_keys(fitted)
    second = [int(np.flatnonzero(fcurves.read_keys(c)[0] == frames[1])[0]) for c in curves]
    curves[2].keyframe_points[second[2]].interpolation = "LINEAR"
    curves[3].keyframe_points[second[3]].handle_right = (curves[3].keyframe_points[second[3]].co[0] + 1, 3.0)
    curves[0].keyframe_points[second[0]].handle_left_type = "VECTOR"
    curves[1].keyframe_points[second[1]].select_control_point = True
    last = int(np.flatnonzero(fcurves.read_keys(curves[1])[0] == frames[-1])[0])
    curves[1].keyframe_points[last].co[1] += 0.05
    update()
    assert live.STATS.refits == 1 and len(kept) == 4, (live.STATS, kept)
    assert fit.last_fit(fcurves.active_action(fitted), fit.targets.Target(fitted)).refitted <= 2
    refitted = curve_state(fitted)
    # the same fit written in full: new key slots, every key's types and selection written
    target = fit.targets.Target(fitted)
    action = fcurves.active_action(fitted)
    keys = fit.read_animator_keys(target)
    record = fit.find_record(action, target)
    plan = fit.plan_target(keys, fit.settings_of(record), *fit.refit_eases(keys, target, record),
                           previous=fit.last_fit(action, target))
    assert plan.fit.refitted == 0  # nothing changed since: every segment is the refit's
    monkeypatch.setattr(fit, "_rewrite_kept", lambda *a: False)
    with fit.record_index():
        fit.write_plan(plan, target)
    assert curve_state(fitted) == refitted
    assert any(s for _, _, sel in refitted for s in sel)  # the animator's selection stayed
    frames, values = animator_keys(fitted)
    assert_plays_method(fitted, frames.astype(float), values)


def test_two_objects_playing_one_actions_channels_are_refitted_once(fitted):
    """A second object playing the fitted action through the same slot (a linked duplicate) shares
    its F-curves: an edit refits them once, and both objects play the method."""
    twin = add_empty("Twin", "QUATERNION")
    anim = twin.animation_data_create()
    anim.action = fcurves.active_action(fitted)
    if fcurves.SLOTTED:
        anim.action_slot = fitted.animation_data.action_slot
    update()
    live.STATS.reset()
    frames, _ = animator_keys(fitted)
    curve = fcurves.Channels.of(fitted).find("rotation_quaternion", 1)
    last = int(np.flatnonzero(fcurves.read_keys(curve)[0] == frames[-1])[0])
    curve.keyframe_points[last].co[1] += 0.05
    update()
    assert live.STATS.refits == 1 and not live.STATS.errors, live.STATS
    frames, values = animator_keys(fitted)
    assert_plays_method(fitted, frames.astype(float), values)
    assert_plays_method(twin, frames.astype(float), values)


@pytest.mark.parametrize("threads", [1, 3])
def test_many_targets_refit_on_native_workers_as_one_by_one(live_scene, monkeypatch, threads):
    """A refit of several bones at once (a quatcurve.FitQueue's workers fit them while the next are
    read): each bone's keys and handles are those a refit of that bone alone writes; a bone whose
    edited key cannot be fitted (a zero quaternion) is named and left as it was, the others written."""
    from quatcurve_blender import workers
    monkeypatch.setattr(workers, "THREADS", threads)
    names = ("A", "B", "C", "D")
    rigs_ = []
    for name in ("Together", "Alone"):
        rig = add_rig(name, bones=names)
        for pb in rig.pose.bones:
            key(pb, "rotation_quaternion", QUAT_KEYS, interpolation="BEZIER")
        select_bones(rig, names)
        assert bpy.ops.quatcurve.fit(method="SQUAD", tolerance=TOL) == {"FINISHED"}
        rigs_.append(rig)
    live_scene.quatcurve_fit.live = True
    update()
    live.STATS.reset()

    def edit(rig, bone, zero=False):
        chans = fcurves.Channels.of(rig)
        for i in range(4):
            curve = chans.find(rig.pose.bones[bone].path_from_id("rotation_quaternion"), i)
            point = next(p for p in curve.keyframe_points if p.co[0] == 6)
            point.co[1] = 0.0 if zero else point.co[1] + 0.03 * (i + 1)

    def state(rig, bone):
        chans = fcurves.Channels.of(rig)
        return [fcurves.fcurve_digest(chans.find(rig.pose.bones[bone].path_from_id("rotation_quaternion"), i)).hexdigest()
                for i in range(4)]

    together, alone = rigs_
    for bone in ("A", "B", "D"):
        edit(together, bone)
    edit(together, "C", zero=True)
    left = state(together, "C")
    update()
    assert live.STATS.refits == 3, live.STATS
    assert live.STATS.errors == ["Together/C: the quaternion is zero at frame 6 (no rotation defined)"], live.STATS.errors
    assert state(together, "C") == left
    for bone in ("A", "B", "D"):  # the same edit, one bone at a time
        live.STATS.reset()
        edit(alone, bone)
        update()
        assert live.STATS.refits == 1 and not live.STATS.errors, live.STATS
        assert state(alone, bone) == state(together, bone), bone
