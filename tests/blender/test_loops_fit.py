"""Fit, Live, ease, turns and Convert on looping targets (issue 28), in every Blender: a target whose
rotation channels carry Blender's plain Cycles modifier is fitted with the method's closed curve, the
modifiers stay, and Blender — in a fresh process without the add-on, from the saved .blend — plays
the method within the tolerance over three periods before and three after the keyed one.

Scenes: a quaternion loop, an XYZ loop with uneven key spacing, an XYZ wheel keyed 0° → 360° about
Z with Repeat with Offset (it keeps turning), and a rig whose quaternion and YXZ bones loop over one
period. The reference is the method's native closed curve through the animator's keys
(everywhere_scenes.reference_curve with cyclic=True). test_seam_velocity_jump prints the README's
figure: the jump of angular velocity at the seam for Blender's own cyclic Bezier, each method fitted
as a loop, and the same keys fitted open."""
import math

import bpy
import numpy as np
import pytest
from mathutils import Euler, Quaternion

from bake_helpers import add_empty, add_rig, key, rotation_fcurves, select_bones, select_objects
from everywhere_scenes import Built, Owner, check_times, deviation, verdict
from quatcurve_blender import convert, fcurves, fit, live, targets
from test_everywhere import select_keys
from test_fit import fresh_blender_quats

METHODS = fit.METHODS
TOL = 0.05        # degrees
PERIODS = 3       # periods checked before and after the keyed one
PER_FRAME = 64    # check points per frame over the seven periods (and 200 random times)


def quat(axis, degrees):
    return tuple(Quaternion(axis, math.radians(degrees)))


def euler(*degrees):
    return tuple(math.radians(d) for d in degrees)


Q0 = quat((1, 0.3, 0), 20)
QUAT_LOOP = Owner("QuatLoop", "QUATERNION", ((1, Q0), (9, quat((0.2, 1, 0.4), 80)), (17, quat((0, 0.3, 1), 130)),
                                             (25, Q0)))
EULER_LOOP = Owner("EulerLoop", "XYZ", ((1, euler(10, -20, 5)), (4, euler(60, 10, 40)), (15, euler(-30, 40, 120)),
                                        (25, euler(10, -20, 5))))
WHEEL = Owner("Wheel", "XYZ", ((1, euler(0, 0, 0)), (7, euler(15, 10, 150)), (25, euler(0, 0, 360))))
RIG = (Owner("Hip", "QUATERNION", ((1, Q0), (13, quat((0, 1, 0.2), 60)), (25, Q0)), bone=True),
       Owner("Knee", "YXZ", ((1, euler(20, 0, 0)), (7, euler(80, 10, -5)), (25, euler(20, 0, 0))), bone=True))
SCENE = (QUAT_LOOP, EULER_LOOP, WHEEL) + RIG


def make_loop(owner, prop, offset=False):
    """Blender's plain Cycles modifier on every rotation channel (Repeat, or Repeat with Offset)."""
    for curve in rotation_fcurves(owner, prop):
        m = curve.modifiers.new("CYCLES")
        if offset:
            m.mode_before = m.mode_after = "REPEAT_OFFSET"


def build(suffix, specs=SCENE, cyclic=True):
    """One copy of the scene's owners: objects '<label>.<suffix>', bones in a rig 'Rig.<suffix>'. The
    wheel repeats with offset, the others repeat; cyclic=False leaves every owner open."""
    bones = [s.label for s in specs if s.bone]
    rig = add_rig("Rig.%s" % suffix, bones=tuple(bones)) if bones else None
    out = []
    for spec in specs:
        if spec.bone:
            owner = rig.pose.bones[spec.label]
            owner.rotation_mode = spec.mode
            target = targets.Target(rig, spec.label)
        else:
            owner = add_empty("%s.%s" % (spec.label, suffix), spec.mode)
            target = targets.Target(owner)
        prop = fcurves.rotation_property(spec.mode)[0]
        key(owner, prop, spec.keys, interpolation=spec.interpolation)
        if cyclic:
            make_loop(owner, prop, offset=spec is WHEEL)
        out.append(Built(spec, target))
    bpy.context.view_layer.update()
    return out


def cycle_modes(target):
    """Per rotation channel: (modifier type, mode_before, mode_after) of each modifier."""
    prop = fcurves.rotation_property(target.owner.rotation_mode)[0]
    return [[(m.type, m.mode_before, m.mode_after) for m in c.modifiers]
            for c in sorted(rotation_fcurves(target.owner, prop), key=lambda c: c.array_index)]


def loop_times(built):
    first, last = built[0].first, built[0].last
    period = last - first
    return check_times(first - PERIODS * period, last + PERIODS * period, PER_FRAME, 200)


def played(built, tmp_path, name, times):
    blend = tmp_path / ("%s.blend" % name)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    requests = [list(r) for r in dict.fromkeys(tuple(b.request) for b in built)]
    return fresh_blender_quats(blend, requests, times, tmp_path)


def closed_curve(keys, method, **per_key):
    """The method's native closed curve through AnimatorKeys `keys` (the fit's default options,
    per-key ease/turns as given): what Blender must play, in every period."""
    options = fit.curve_options(fit.FitSettings(method=method), **per_key)
    return targets.build_curve(keys.mode, keys.frames, keys.values, method, keys.name, cyclic=True, **options)


def reference(target, method, **per_key):
    keys = fit.read_animator_keys(target)
    assert keys.loop is not None, target.name
    return closed_curve(keys, method, **per_key)


def check_rows(case, method, built, quats, times, rows, **per_key):
    for b in built:
        want = reference(b.target, method, **(per_key.get(b.spec.label) or {}))
        rows.append(deviation(case, "loops", method, b.spec.label, quats[b.name], want.sample(times), times,
                              TOL))


def fit_all(built, method):
    """Objects through the operator (selected, Object mode), bones through fit.fit."""
    objects = [b.target.object for b in built if b.target.bone is None]
    bones = [b.target for b in built if b.target.bone is not None]
    if objects:
        select_objects(*objects)
        assert bpy.ops.quatcurve.fit(method=method, tolerance=TOL) == {"FINISHED"}
    if bones:
        fit.fit(bones, fit.FitSettings(method=method, tolerance=TOL))


# ---- fit ---------------------------------------------------------------------------------------------

def test_fit_plays_each_method_as_a_loop_over_periods(scene, tmp_path):
    copies, rows = {}, []
    for method in METHODS:
        built = copies[method] = build(method)
        before = {b.name: cycle_modes(b.target) for b in built}
        fit_all(built, method)
        for b in built:
            assert cycle_modes(b.target) == before[b.name], b.name  # the Cycles modifiers stay
            keys = fit.read_animator_keys(b.target)
            np.testing.assert_array_equal(keys.frames, [f for f, _ in b.spec.keys])
            assert keys.loop.period == b.last - b.first
    times = loop_times(copies[METHODS[0]])
    quats = played([b for built in copies.values() for b in built], tmp_path, "fit", times)
    for method, built in copies.items():
        check_rows("fit", method, built, quats, times, rows)
    failed = verdict(rows, "fit on loops over %d periods each side" % PERIODS)
    assert not failed, failed


def angular_velocity(q, h):
    """World angular velocities (deg/frame) between consecutive quaternions h frames apart."""
    q = np.asarray(q, float)
    d = np.array([tuple(Quaternion(b) @ Quaternion(a).conjugated()) for a, b in zip(q[:-1], q[1:])])
    d *= np.where(d[:, :1] < 0, -1.0, 1.0)
    s = np.linalg.norm(d[:, 1:], axis=1, keepdims=True)
    angle = 2 * np.arctan2(s, d[:, :1])
    return np.degrees(np.where(s > 1e-12, d[:, 1:] / np.maximum(s, 1e-300), 0) * angle / h)


SEAM_H = 1 / 64


def seam_jump(quats_before, quats_after):
    """|ω arriving − ω leaving| (deg/frame) from three samples each side, SEAM_H apart, the velocity
    at each end extrapolated to second order."""
    wb = angular_velocity(quats_before, SEAM_H)   # at the midpoints -1.5h, -0.5h
    wa = angular_velocity(quats_after, SEAM_H)    # midpoints 0.5h, 1.5h
    arriving = 1.5 * wb[1] - 0.5 * wb[0]
    leaving = 1.5 * wa[0] - 0.5 * wa[1]
    return float(np.linalg.norm(arriving - leaving))


def test_seam_velocity_jump(scene, tmp_path):
    """The README's figure: Blender's own cyclic Bezier (auto-clamped handles, Cycles), each method
    fitted as a loop, the same keys fitted open (no modifier: the velocity arriving at the last key
    against the velocity leaving the first), and the method's own curve, at the quaternion and the
    uneven Euler loop."""
    specs = (QUAT_LOOP, EULER_LOOP)
    auto = build("AUTO", specs)
    for b in auto:
        for curve in rotation_fcurves(b.target.owner, fcurves.rotation_property(b.spec.mode)[0]):
            curve.update()  # Blender's cycle-aware auto handles
    looped = {m: build("LOOP_" + m, specs) for m in METHODS}
    opened = {m: build("OPEN_" + m, specs, cyclic=False) for m in METHODS}
    for method in METHODS:
        fit_all(looped[method], method)
        fit_all(opened[method], method)
    start, end = QUAT_LOOP.keys[0][0], QUAT_LOOP.keys[-1][0]
    h = SEAM_H
    before = [end - 2 * h, end - h, end]
    after = [start, start + h, start + 2 * h]
    times = np.array(before + after)
    everyone = auto + [b for m in METHODS for b in looped[m] + opened[m]]
    quats = played(everyone, tmp_path, "seam", times)

    def jump(b):
        q = quats[b.name]
        return seam_jump(q[:3], q[3:])

    lines = ["%-12s %-10s %14s %14s %14s" % ("owner", "method", "method's own", "fitted loop", "fitted open")]
    for i, spec in enumerate(specs):
        lines.append("%-12s %-10s %14s %14.4f %14s" % (spec.label, "Blender", "", jump(auto[i]), ""))
        for method in METHODS:
            keys = fit.read_animator_keys(looped[method][i].target)
            curve = closed_curve(keys, method)
            own = seam_jump(curve.sample(before), curve.sample(after))
            loop_jump, open_jump = jump(looped[method][i]), jump(opened[method][i])
            lines.append("%-12s %-10s %14.4f %14.4f %14.4f" % (spec.label, method, own, loop_jump, open_jump))
            if method in ("SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2"):  # C1 methods: no corner at the seam
                assert loop_jump < 0.1 * max(open_jump, 1.0), (spec.label, method, loop_jump, open_jump)
    print("\n[loops] angular velocity jump at the seam, deg/frame (Blender %s):\n%s"
          % (bpy.app.version_string, "\n".join(lines)))


# ---- live, ease, turns ------------------------------------------------------------------------------

@pytest.fixture
def live_scene(scene):
    live.STATS.reset()
    live.drag_hook = None
    yield scene
    live.drag_hook = None
    live.on_load()


def set_key(target, frame, values):
    """Sets the rotation keys at `frame` on every channel (what the animator's keying writes)."""
    prop = fcurves.rotation_property(target.owner.rotation_mode)[0]
    for curve in rotation_fcurves(target.owner, prop):
        for p in curve.keyframe_points:
            if abs(p.co[0] - frame) < 1e-4:
                shift = values[curve.array_index] - p.co[1]
                p.co[1] += shift
                p.handle_left[1] += shift
                p.handle_right[1] += shift
        curve.update()


def test_live_keeps_a_loop_closed(live_scene, tmp_path):
    """A middle key edited, then both end keys together (cycle-aware keying updates the other end):
    each refit plays the closed curve; one end key alone is no loop (left as it is, the reason kept);
    removing the modifiers refits open, adding them back closes it again."""
    built = build("LIVE", (QUAT_LOOP, EULER_LOOP))
    fit_all(built, "SPLINE_C2")
    live_scene.quatcurve_fit.live = True
    bpy.context.view_layer.update()
    live.STATS.reset()
    quat_t, euler_t = built[0].target, built[1].target
    set_key(quat_t, 9, quat((0.5, 1, 0), 70))
    bpy.context.view_layer.update()
    assert live.STATS.refits == 1, live.STATS
    set_key(euler_t, 1, euler(0, -10, 20))
    set_key(euler_t, 25, euler(0, -10, 20))
    bpy.context.view_layer.update()
    assert live.STATS.refits == 2, live.STATS
    for b in built:
        assert fit.find_record(fcurves.active_action(b.target.id_data), b.target).signature == \
            fit.read_animator_keys(b.target).signature()
    times = loop_times(built)
    quats = played(built, tmp_path, "live", times)
    rows = []
    check_rows("live", "SPLINE_C2", built, quats, times, rows)
    failed = verdict(rows, "live on loops")
    assert not failed, failed

    set_key(euler_t, 1, euler(30, -10, 20))  # the end key alone: not the first rotation
    bpy.context.view_layer.update()
    assert live.STATS.refits == 2 and any("EulerLoop.LIVE" in e and "frame" in e for e in live.STATS.errors), \
        live.STATS.errors
    set_key(euler_t, 1, euler(0, -10, 20))
    for curve in rotation_fcurves(quat_t.owner, "rotation_quaternion"):
        curve.modifiers.remove(curve.modifiers[0])
    # The Graph Editor's Add and Delete Modifier tag the action for the depsgraph; FModifiers.new and
    # .remove from Python do not (3.4), or not always: tag it as the editor does.
    fcurves.active_action(quat_t.id_data).update_tag()
    bpy.context.view_layer.update()
    keys = fit.read_animator_keys(quat_t)
    assert keys.loop is None and fit.find_record(fcurves.active_action(quat_t.id_data), quat_t).signature == \
        keys.signature()
    make_loop(quat_t.owner, "rotation_quaternion")
    fcurves.active_action(quat_t.id_data).update_tag()
    bpy.context.view_layer.update()
    keys = fit.read_animator_keys(quat_t)
    assert keys.loop is not None and fit.find_record(fcurves.active_action(quat_t.id_data), quat_t).signature == \
        keys.signature()


def test_ease_at_the_seam_and_turns_into_it(scene, tmp_path):
    """Ease out on the first key and ease in on the last apply at the seam; turns on the key before the
    last turn the segment into the seam. Blender plays the eased, turned closed curve."""
    built = build("EASE", (QUAT_LOOP, EULER_LOOP))
    fit_all(built, "CATMULL_ROM")
    ends = {b.spec.label: (b.first, b.last) for b in built}
    for b in built:
        select_keys(b.target, [ends[b.spec.label][0], ends[b.spec.label][1]])
    select_objects(*[b.target.object for b in built])
    assert bpy.ops.quatcurve.set_ease(ease_in=0.6, ease_out=0.4) == {"FINISHED"}
    quat_t = built[0].target
    select_keys(quat_t, [17])
    select_objects(quat_t.object)
    assert bpy.ops.quatcurve.set_turns(turns=1) == {"FINISHED"}
    per_key = {}
    for b in built:
        keys = fit.read_animator_keys(b.target)
        record = fit.find_record(fcurves.active_action(b.target.id_data), b.target)
        ease_in, ease_out, turns = fit.refit_eases(keys, b.target, record)
        assert ease_out[0] == pytest.approx(0.4) and ease_in[-1] == pytest.approx(0.6), (ease_in, ease_out)
        per_key[b.spec.label] = dict(ease_in=ease_in, ease_out=ease_out,
                                     turns=turns if keys.mode == "QUATERNION" else None)
    assert per_key["QuatLoop"]["turns"][2] == 1
    times = loop_times(built)
    quats = played(built, tmp_path, "ease", times)
    rows = []
    check_rows("ease", "CATMULL_ROM", built, quats, times, rows, **per_key)
    failed = verdict(rows, "ease and turns on loops")
    assert not failed, failed


# ---- convert ------------------------------------------------------------------------------------------

def test_convert_keeps_the_loop(scene, tmp_path):
    """The wheel (Repeat with Offset) becomes a quaternion loop that turns the same; the quaternion
    loop becomes a ZXY loop; the rig's bones convert too. Blender plays the same rotations over the
    periods before and after as before the conversion."""
    built = build("CONV")
    times = loop_times(built)
    before = played(built, tmp_path, "before", times)
    modes = {"QuatLoop": "ZXY", "EulerLoop": "QUATERNION", "Wheel": "QUATERNION", "Hip": "XYZ", "Knee": "QUATERNION"}
    for b in built:
        found = [b.target]
        result = convert.convert(found, convert.ConvertSettings(rotation_mode=modes[b.spec.label], tolerance=TOL))
        assert result.converted, result.lines()
        assert b.target.owner.rotation_mode == modes[b.spec.label]
        for channel in cycle_modes(b.target):
            assert len(channel) == 1 and channel[0][0] == "CYCLES", (b.name, channel)
        assert fit.read_animator_keys(b.target).loop is not None
    wheel = next(b for b in built if b.spec is WHEEL)
    assert all(c[0][1:] == ("REPEAT", "REPEAT") for c in cycle_modes(wheel.target))
    after = played(built, tmp_path, "after", times)
    # The conversion holds its tolerance at its samples (every quarter frame), in every period.
    samples = np.abs(times * 4 - np.round(times * 4)) < 1e-9
    rows = [deviation("convert", "loops", "-", b.spec.label, after[b.name], before[b.name], times, TOL, mask=samples)
            for b in built]
    failed = verdict(rows, "convert of loops against the playback before")
    assert not failed, failed


# ---- refusals ---------------------------------------------------------------------------------------

def refusal_cases():
    def mirror(curves):
        curves[0].modifiers[0].mode_after = "MIRROR"

    def noise(curves):
        curves[1].modifiers.new("NOISE")

    def periods(curves):
        curves[2].keyframe_points.insert(30, 0.0)

    def offset(curves):
        for c in curves:
            c.modifiers[0].mode_before = c.modifiers[0].mode_after = "REPEAT_OFFSET"
        curves[2].keyframe_points[-1].co[1] += 1.0

    return [("mirror", mirror, r"EulerLoop\.NO: rotation_euler\[0\] has a Cycles modifier in modes REPEAT/MIRROR"),
            ("noise", noise, r"EulerLoop\.NO: rotation_euler\[1\] has F-curve modifiers after its Cycles modifier \(NOISE\)"),
            ("periods", periods, r"EulerLoop\.NO: rotation_euler\[0\] loops over frames 1–25 and rotation_euler\[2\] over 1–30"),
            ("offset", offset, r"EulerLoop\.NO: rotation_euler\[2\] repeats with offset .* not whole turns")]


@pytest.mark.parametrize("case, change, message", refusal_cases(), ids=[c[0] for c in refusal_cases()])
def test_refusals_name_target_channel_and_modifier_and_change_nothing(scene, case, change, message):
    (b,) = build("NO", (EULER_LOOP,))
    curves = sorted(rotation_fcurves(b.target.owner, "rotation_euler"), key=lambda c: c.array_index)
    change(curves)
    for c in curves:
        c.update()
    action = fcurves.active_action(b.target.id_data)
    state = fcurves.action_digest(action)
    with pytest.raises(fit.FitError, match=message):
        fit.fit([b.target], fit.FitSettings(method="SQUAD", tolerance=TOL))
    select_objects(b.target.object)
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.quatcurve.fit(method="SQUAD", tolerance=TOL)
    if case != "offset":  # convert reads the played rotation, which any whole or not offset has
        with pytest.raises(convert.ConvertError, match=message.replace(r"EulerLoop\.NO", r"EulerLoop\.NO \(action '[^']*'\)")):
            convert.convert([b.target], convert.ConvertSettings(rotation_mode="QUATERNION", tolerance=TOL))
    assert fcurves.action_digest(action) == state
    assert not len(action.quatcurve_fits)
