"""The bound at every instant (issue 27), in every Blender: what fit, live refit, ease, turns, reduce
and the bake's reduction write plays — in a fresh Blender without the add-on, from the saved .blend —
within the tolerance of its reference at 64 points per frame and at 200 random times (a fixed seed),
not only at the frames and quarter frames the fit samples.

Scenes (everywhere_scenes.py): Euler XYZ, YXZ and ZXY objects with the issue's gimbal-lock keys and
spins beyond 360°; a quaternion object whose stored signs flip between keys; an axis-angle object
with spins; a rig whose bones use Rigify's modes (quaternion, YXZ, ZXY with a key at the lock) and
axis-angle; the LINEAR quaternion keys Blender's glTF importer writes. The reference is the
method's native curve through the animator's keys as keyed (targets.build_curve with the fit's
options, and the eases and turns set), for reduce the original keys' own playback. Each test builds
one copy of its scenes per method, writes one .blend and evaluates it in one fresh process; it fails
naming case, scene, method, owner, frame and degrees of every owner above its bound, and prints the
table of the largest deviations."""
import math
from dataclasses import replace

import bpy
import numpy as np
import pytest

from bake_helpers import select_objects
from everywhere_scenes import (SCENES, Row, build, check_times, deviation, refused, reference_curve,
                               rotation_prop, verdict)
from quatcurve_blender import bake, fcurves, fit, live, reduce
from quatcurve_blender.targets import TargetError
from test_fit import fresh_blender_quats

METHODS = fit.METHODS  # quatcurve.METHODS without Blender's own per-channel ones: what fit offers
TOL = 0.05         # degrees: fit, live, ease, turns
REDUCE_TOL = 0.1   # degrees: reduce and the bake's reduction
TASK_ERRORS = (RuntimeError, TargetError)  # an operator's error report (background mode), a task's own error


def run_task(built, operator, function):
    """Runs a task on one scene copy as a user does: its objects selected, through the operator
    (Object mode); its pose bones through the operator's own function on Targets."""
    objects = [b.target.object for b in built if b.target.bone is None]
    bones = [b.target for b in built if b.target.bone is not None]
    if objects:
        select_objects(*objects)
        assert operator() == {"FINISHED"}
    if bones:
        function(bones)


def generated_count(target):
    """Keys of the fit's generated type on the target's rotation channels."""
    prop, count = fcurves.rotation_property(target.owner.rotation_mode)
    curves = fcurves.Channels.of(target.id_data).find_all(target.data_path(prop), count)
    return sum(int((fcurves.read_key_types(c) == fit.KEY_TYPE_GENERATED).sum()) for c in curves if c is not None)


def played(owners, tmp_path, name, per_frame=64, randoms=200, each_range=False):
    """Saves the file and evaluates the owners ([Built]) in one fresh Blender without the add-on at
    check_times over their keyed ranges — one grid and `randoms` random times over all of them, or with
    each_range those of every owner's own range (so that each gets its `randoms` random times).
    Returns (times, {owner name: (N, 4) quaternions})."""
    blend = tmp_path / ("%s.blend" % name)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    if each_range:
        ranges = dict.fromkeys((b.first, b.last) for b in owners)
        times = np.unique(np.concatenate([check_times(a, b, per_frame, randoms) for a, b in ranges]))
    else:
        times = check_times(min(b.first for b in owners), max(b.last for b in owners), per_frame, randoms)
    requests = [list(r) for r in dict.fromkeys(tuple(b.request) for b in owners)]
    return times, fresh_blender_quats(blend, requests, times, tmp_path)


def reported_bound(target):
    """What the fit reports for a fitted target now (its result line's max error, degrees): the bound it
    proved at every instant. The plan is deterministic, so planning the keys again gives the figure
    the last fit or refit printed."""
    keys = fit.read_animator_keys(target)
    record = fit.find_record(fcurves.active_action(target.id_data), target)
    plan = fit.plan_target(keys, fit.settings_of(record), *fit.refit_eases(keys, target, record))
    return math.degrees(plan.max_error)


def against_curves(case, checks, tmp_path, bound, rows, fitted=True):
    """Appends one Row per check (built, method, scene, reference curve, note): Blender's playback in
    a fresh process against the curve over the owner's keyed range, held to `bound`. A fitted target
    whose fit reports a bound above the tolerance adds a failing row of its own: a fit that cannot
    reach the tolerance must refuse, and is a failure here even where the playback stays within."""
    if not checks:
        return
    times, got = played([c[0] for c in checks], tmp_path, case)
    for built, method, scene, curve, note in checks:
        inside = (times >= built.first) & (times <= built.last)
        if fitted:
            reported = reported_bound(built.target)
            if reported > bound:
                rows.append(Row(case, scene, method, built.spec.label, reported, math.nan, bound,
                                "the fit reports %.4f° (ABOVE the tolerance)" % reported))
        rows.append(deviation(case, scene, method, built.spec.label, got[built.name], curve.sample(times), times,
                              bound, note, inside))


def fit_copy(built, method):
    run_task(built, lambda: bpy.ops.quatcurve.fit(method=method, tolerance=TOL),
             lambda found: fit.fit(found, fit.FitSettings(method=method, tolerance=TOL)))


def fitted_copies(scenes, owners=None):
    """One copy per method of each scene (only the `owners` labels when given), each fitted with its
    method. Returns ([(built, method, scene, animator keys before the fit)], refused rows)."""
    copies, rows = [], []
    for scene in scenes:
        for method in METHODS:
            built = build(scene, method, only=owners)
            keys = [fit.read_animator_keys(b.target) for b in built]
            try:
                fit_copy(built, method)
            except TASK_ERRORS as error:
                rows += [refused("fit", scene, method, b.spec.label, TOL, error) for b in built]
                continue
            copies += [(b, method, scene, k) for b, k in zip(built, keys)]
    return copies, rows


@pytest.mark.parametrize("scene_name", list(SCENES))
def test_fit_plays_the_method_at_every_instant(scene, scene_name, tmp_path):
    """Every method on one scene type (objects through the fit operator, pose bones through
    fit.fit): Blender's playback within the tolerance of the method's curve through the keys as
    keyed, from the first key to the last."""
    copies, rows = fitted_copies([scene_name])
    checks = [(b, method, s, reference_curve(keys, method), "%d generated keys" % generated_count(b.target))
              for b, method, s, keys in copies]
    against_curves("fit", checks, tmp_path, TOL, rows)
    failures = verdict(rows, "fit, scene %s" % scene_name)
    assert not failures, failures


# ---- live refit, ease, turns: the fitted keys changed afterwards -----------------------------------------

def point_at(target, channel, frame):
    """The animator's key (not a generated one) at `frame` on rotation channel `channel`."""
    prop = rotation_prop(target.owner.rotation_mode)
    curve = fcurves.Channels.of(target.id_data).find(target.data_path(prop), channel)
    point = next(p for p in curve.keyframe_points if p.co[0] == frame and p.type != fit.GENERATED_NAME)
    return curve, point


def key_index(keys, frame):
    return int(np.flatnonzero(keys.frames == frame)[0])


# (scene, owner, frame, channel, change): a key's value changed with Live on (its handles along).
LIVE_EDITS = (("euler", "XYZ", 12, 0, math.radians(25)), ("euler", "ZXY", 28, 2, math.radians(-30)),
              ("quaternion", "Flips", 14, 2, 0.3), ("axis_angle", "Axis", 20, 0, math.radians(-40)),
              ("rig", "Tweak", 35, 1, math.radians(-30)), ("gltf", "GltfObj", 31, 1, 0.25))


def test_live_refit_plays_the_method_at_every_instant(scene, tmp_path):
    """Fitted, then Live on and one key of each copy changed: the refit plays the method through the
    animator's keys as keyed with that one change (the key's new value as Blender stores it). The
    other keys are taken as keyed, not as the fit wrote them: an Euler key at gimbal lock that the
    fit wrote as another triple is the same rotation, and must leave the path as it was."""
    live.STATS.reset()
    live.drag_hook = None
    copies, rows = [], []
    for scene_name, label, frame, channel, change in LIVE_EDITS:
        found, refused_rows = fitted_copies([scene_name], owners=(label,))
        copies += [(c, frame, channel, change) for c in found]
        rows += refused_rows
    try:
        scene.quatcurve_fit.live = True
        bpy.context.view_layer.update()
        live.STATS.reset()
        edited = []
        for (built, method, scene_name, keys), frame, channel, change in copies:
            curve, point = point_at(built.target, channel, frame)
            point.co[1] += change
            point.handle_left[1] += change
            point.handle_right[1] += change
            curve.update()
            want = keys.values.copy()
            k = key_index(keys, frame)
            now = fit.read_animator_keys(built.target).values[k]  # the key as stored (a quaternion's sign as fitted)
            want[k] = now
            edited.append((built, method, scene_name, replace(keys, values=want)))
        bpy.context.view_layer.update()  # the depsgraph handler refits (background mode: at once)
        refits, errors = live.STATS.refits, list(live.STATS.errors)
    finally:
        scene.quatcurve_fit.live = False
        live.on_load()
    note = "%d refits for %d edits%s" % (refits, len(edited), ("; " + "; ".join(errors)) if errors else "")
    checks = [(b, method, s, reference_curve(keys, method), note) for b, method, s, keys in edited]
    against_curves("live", checks, tmp_path, TOL, rows)
    failures = verdict(rows, "live refit")
    assert not failures, failures
    assert refits == len(edited) and not errors, note


def select_keys(target, frames):
    """Selects the rotation keys on `frames` (every channel), deselects the others."""
    prop, count = fcurves.rotation_property(target.owner.rotation_mode)
    for curve in fcurves.Channels.of(target.id_data).find_all(target.data_path(prop), count):
        for p in curve.keyframe_points:
            p.select_control_point = p.select_left_handle = p.select_right_handle = p.co[0] in frames


# (scene, owner, frames): keys eased in EASE_IN and out EASE_OUT through the operator.
EASED = (("euler", "XYZ", (12, 28)), ("euler", "YXZ", (4, 40)), ("quaternion", "Flips", (6, 30)),
         ("axis_angle", "Axis", (9, 26)), ("gltf", "GltfObj", (11, 41)))
EASE_IN, EASE_OUT = 0.8, 0.5


def test_ease_plays_the_eased_method_at_every_instant(scene, tmp_path):
    """Fitted, then two keys of each copy eased through the set_ease operator (it refits): the
    playback follows the method's curve with those eases (the same path, slower into and out of the
    keys)."""
    copies, rows = [], []
    for scene_name, label, frames in EASED:
        found, refused_rows = fitted_copies([scene_name], owners=(label,))
        copies += [(c, frames) for c in found]
        rows += refused_rows
    for (built, _, _, _), frames in copies:
        select_keys(built.target, frames)
    select_objects(*[c[0][0].target.object for c in copies])
    checks = []
    try:
        assert bpy.ops.quatcurve.set_ease(ease_in=EASE_IN, ease_out=EASE_OUT) == {"FINISHED"}
    except TASK_ERRORS as error:
        rows += [refused("ease", s, m, b.spec.label, TOL, error) for (b, m, s, _), _ in copies]
    else:
        for (built, method, scene_name, keys), frames in copies:
            chosen = np.isin(keys.frames, frames)
            curve = reference_curve(keys, method, ease_in=np.where(chosen, EASE_IN, 0.0),
                                    ease_out=np.where(chosen, EASE_OUT, 0.0))
            checks.append((built, method, scene_name, curve, "keys %s eased" % (frames,)))
    against_curves("ease", checks, tmp_path, TOL, rows)
    failures = verdict(rows, "ease in %g / out %g" % (EASE_IN, EASE_OUT))
    assert not failures, failures


# (scene, owner, frame, turns): extra full turns on the segment leaving the key at `frame`.
TURNED = (("quaternion", "Flips", 6, 1), ("gltf", "GltfObj", 11, -1), ("rig", "Q", 14, 2))


def test_turns_play_the_turned_method_at_every_instant(scene, tmp_path):
    """Fitted quaternion targets (objects through the set_turns operator, a pose bone through
    fit.set_turns), one segment given 1, −1 or 2 extra turns: the playback follows the method's curve
    with those turns."""
    checks, rows = [], []
    for scene_name, label, frame, turns in TURNED:
        copies, refused_rows = fitted_copies([scene_name], owners=(label,))
        rows += refused_rows
        for built, _, _, _ in copies:
            select_keys(built.target, {frame})
        try:
            run_task([c[0] for c in copies], lambda: bpy.ops.quatcurve.set_turns(turns=turns),
                     lambda found: fit.set_turns(found, turns))
        except TASK_ERRORS as error:
            rows += [refused("turns", s, m, b.spec.label, TOL, error) for b, m, s, _ in copies]
            continue
        for built, method, _, keys in copies:
            per_key = np.where(keys.frames == frame, float(turns), 0.0)
            checks.append((built, method, scene_name, reference_curve(keys, method, turns=per_key),
                           "%+d turns leaving frame %d" % (turns, frame)))
    against_curves("turns", checks, tmp_path, TOL, rows)
    failures = verdict(rows, "turns")
    assert not failures, failures


# ---- reduce and the bake's reduction -------------------------------------------------------------------

def sign_flip_frames(quats, times):
    """Where the original's own quaternion channels flip hemisphere: (mask, count) — True inside each
    frame (f, f+1) whose whole-frame values lie in opposite hemispheres (Blender swings through the
    flip there; the reduction keeps the original's keys around it), and how many such frames."""
    whole = np.flatnonzero(times == np.floor(times))
    out, count = np.zeros(len(times), dtype=bool), 0
    for a, b in zip(whole, whole[1:]):
        if np.dot(quats[a], quats[b]) < 0:
            out[(times > times[a]) & (times < times[b])] = True
            count += 1
    return out, count


def test_reduce_holds_between_frames(scene, tmp_path):
    """quatcurve.reduce at 0.1° on every scene's keys and on dense per-frame keys (a quaternion clip
    whose signs flip every 7th frame, an XYZ clip with a spin): the reduced playback within 0.1° of
    the original keys' own playback at every check time inside each owner's keyed range — 64 points
    per frame and 200 random times over that range — inside the frames where the original's
    quaternion channels flip sign too (checked: the dense clip has them)."""
    pairs, rows = [], []
    for scene_name in list(SCENES) + ["dense"]:
        original = build(scene_name, "ORIG")
        reduced = build(scene_name, "REDUCED")
        try:
            run_task(reduced, lambda: bpy.ops.quatcurve.reduce(tolerance=REDUCE_TOL, new_action=True),
                     lambda found: reduce.reduce(found, reduce.ReduceSettings(tolerance=REDUCE_TOL)))
        except TASK_ERRORS as error:
            rows += [refused("reduce", scene_name, "BEZIER", b.spec.label, REDUCE_TOL, error) for b in reduced]
            continue
        pairs += [(o, r, scene_name) for o, r in zip(original, reduced)]
    times, got = played([o for o, _, _ in pairs] + [r for _, r, _ in pairs], tmp_path, "reduce", each_range=True)
    flip_frames = 0
    for o, r, scene_name in pairs:
        inside = (times >= o.first) & (times <= o.last)
        assert np.isin(check_times(o.first, o.last), times[inside]).all()  # 64 per frame, 200 random, its own
        count = sign_flip_frames(got[o.name], times)[1] if o.spec.mode == "QUATERNION" else 0
        flip_frames += count
        rows.append(deviation("reduce", scene_name, "BEZIER", o.spec.label, got[r.name], got[o.name], times,
                              REDUCE_TOL, "%d frames of the original's sign flips checked" % count if count else "",
                              inside))
    assert flip_frames > 0  # the dense clip's flips are among the times checked
    failures = verdict(rows, "reduce at %g°, against the original's playback" % REDUCE_TOL)
    assert not failures, failures


def test_bake_reduction_plays_the_method_at_every_instant(scene, tmp_path):
    """quatcurve.bake with tolerance 0.1° (its key reduction), every method, every scene, each owner in
    its own rotation mode: the reduced keys' playback within 0.1° of the method's curve."""
    checks, rows = [], []
    for scene_name in SCENES:
        for method in METHODS:
            built = build(scene_name, "BAKE_" + method)
            keys = [fit.read_animator_keys(b.target) for b in built]
            try:
                run_task(built, lambda: bpy.ops.quatcurve.bake(method=method, tolerance=REDUCE_TOL),
                         lambda found: bake.bake(found, bake.BakeSettings(method=method, tolerance=REDUCE_TOL)))
            except TASK_ERRORS as error:
                rows += [refused("bake", scene_name, method, b.spec.label, REDUCE_TOL, error) for b in built]
                continue
            checks += [(b, method, scene_name, reference_curve(k, method), "") for b, k in zip(built, keys)]
    against_curves("bake", checks, tmp_path, REDUCE_TOL, rows, fitted=False)
    failures = verdict(rows, "bake with tolerance %g°" % REDUCE_TOL)
    assert not failures, failures
