"""Cleaning captured rotations (issue 36): the `quatcurve.clean` operator and clean.py, checked by
Blender's own playback of the written keys in a fresh Blender without the add-on (fresh_blender.py),
in every supported Blender.

The capture is synthetic with a known truth (a smooth motion), so the clean can be held against it:
rotation noise of 1° RMS by a fixed seed, planted spikes of 15°–25°, quaternion sign flips every 50
frames, and Euler rows written on the other Euler branch or a turn away. Under error='DISTANCE' the
capture is the Rigify-like chain of rigs.py (every rotation mode, Inherit Rotation off, inherit scale
None, connected bones) with the same noise and spikes on every bone, and the bound is held on the
virtual vertices of the armature Blender itself poses (pose_bone.matrix) in a fresh Blender.
"""

import math

import bpy
import numpy as np
import pytest

from quatcurve_blender import clean, fcurves, native, reduce, skeleton, targets
from test_fit import fresh_blender_quats
from test_reduce import keyed_object
from test_reduce_distance import posed, vertices
from test_session import windowed
import rigs

FRAMES = np.arange(1.0, 401.0)
NOISE_DEG = 1.0
SPIKES = (120, 121, 290)  # sample indices: a run of two, and one alone


def truth_quats(frames, seed):
    """A smooth motion: rotation vectors of a few slow sines (up to ~100°), as (N, 4) quaternions."""
    rng = np.random.default_rng(seed)
    t = frames[:, None] / 60.0
    r = np.sin(t * rng.uniform(0.4, 1.5, 3) + rng.uniform(0, 6, 3)) * rng.uniform(0.4, 0.9, 3)
    return _exp(r)


def _exp(r):
    angle = np.linalg.norm(r, axis=1, keepdims=True)
    axis = np.divide(r, angle, out=np.zeros_like(r), where=angle > 0)
    return np.hstack([np.cos(angle / 2), axis * np.sin(angle / 2)])


def _mul(a, b):
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=1)


def noisy_capture(truth, seed, flips=True):
    """The truth with isotropic rotation noise of NOISE_DEG RMS, the SPIKES frames turned 15°–25° about
    random axes, and (flips) the stored sign flipped on every other run of 50 frames."""
    rng = np.random.default_rng(seed)
    noise = rng.normal(scale=math.radians(NOISE_DEG) / math.sqrt(3), size=(len(truth), 3))
    for i in SPIKES:
        axis = rng.normal(size=3)
        noise[i] = axis / np.linalg.norm(axis) * math.radians(rng.uniform(15, 25))
    q = _mul(truth, _exp(noise))
    if flips:
        q[(np.arange(len(q)) // 50) % 2 == 1] *= -1
    return q


def angles_deg(a, b):
    return np.degrees(native.require().angle_between(a, b))


def keyed(name, mode, values):
    """keyed_object (test_reduce) at FRAMES, with location and scale keys the clean must leave as they are."""
    obj = keyed_object(name, FRAMES, values, mode)
    channels = fcurves.Channels.of(obj)
    channels.write("location", 0, FRAMES[::10], np.sin(FRAMES[::10] / 30.0), group="Object Transforms")
    channels.write("scale", 2, FRAMES[::25], 1.0 + 0.1 * np.cos(FRAMES[::25] / 40.0), group="Object Transforms")
    return obj


def euler_with_jumps(q, order):
    """Euler rows of q (order), every 37th row on the other Euler branch and every 53rd a turn away
    on X: the same rotations, the jumps a capture's Euler channels show."""
    qc = native.require()
    e = qc.quats_to_channels(q, order)
    mid = "XYZ".index(order[1])
    other = e.copy()
    for c in range(3):
        other[:, c] = (math.pi - e[:, c]) if c == mid else e[:, c] + math.pi
    rows = np.arange(len(e))
    e[rows % 37 == 5] = other[rows % 37 == 5]
    e[rows % 53 == 7, 0] += 2 * math.pi
    return e


def location_scale_keys(obj, action):
    channels = fcurves.Channels.of(obj, action)
    out = []
    for path, index in (("location", 0), ("scale", 2)):
        curve = channels.find(path, index)
        out.append(fcurves.read_keys(curve))
    return out


@pytest.fixture
def cleaner(scene):
    assert hasattr(bpy.types, "QUATCURVE_OT_clean")
    return scene


def select_only(*objects):
    if bpy.context.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    bpy.context.view_layer.update()
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj in objects)
    bpy.context.view_layer.objects.active = objects[0] if objects else None


def test_cleaned_keys_play_within_the_deviation_in_a_fresh_blender(cleaner, tmp_path):
    """Quaternion and Euler (XYZ, ZXY) captures cleaned with the default deviation (2.5 × the noise
    estimate): a fresh Blender plays the cleaned action within the reported deviation of every frame
    that is not a spike; the planted spikes are replaced, nothing flips, the error to the truth is at
    most half the noisy input's (RMS) and no frame is further than 3 × the noise from it; the original
    action is kept untouched, locations and scales are the same keys."""
    cases = []
    for k, mode in enumerate(("QUATERNION", "XYZ", "ZXY")):
        truth = truth_quats(FRAMES, 10 + k)
        noisy = noisy_capture(truth, 20 + k, flips=mode == "QUATERNION")
        values = noisy if mode == "QUATERNION" else euler_with_jumps(noisy, mode)
        cases.append((keyed("Capture_%s" % mode, mode, values), mode, truth, noisy))
    objects = [c[0] for c in cases]
    originals = [fcurves.active_action(o) for o in objects]
    digests = [fcurves.action_digest(a) for a in originals]
    result = clean.clean([targets.Target(o) for o in objects], clean.CleanSettings())
    print("\n" + "\n".join(result.lines()) + "\n" + result.summary())
    blend = tmp_path / "cleaned.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    played = fresh_blender_quats(blend, [[o.name, None] for o in objects], FRAMES, tmp_path)
    for (obj, mode, truth, noisy), original, digest, line in zip(cases, originals, digests, result.targets):
        action = fcurves.active_action(obj)
        assert action is not original and original.use_fake_user, line.line()
        assert fcurves.action_digest(original) == digest
        assert all(np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
                   for a, b in zip(location_scale_keys(obj, action), location_scale_keys(obj, original)))
        got = played[obj.name]
        spikes = np.array([int(round(f)) - 1 for f in line.spikes], dtype=int)
        assert set(SPIKES) <= set(spikes.tolist()), line.line()
        keep = np.ones(len(FRAMES), dtype=bool)
        keep[spikes] = False
        off = angles_deg(got, noisy)[keep]
        assert off.max() <= line.deviation_deg + 1e-3, "%s: %.4f° at frame %s" % (
            line.line(), off.max(), FRAMES[keep][off.argmax()])
        assert 0.5 * NOISE_DEG <= line.noise_deg <= 1.5 * NOISE_DEG, line.line()
        before, after = angles_deg(noisy, truth), angles_deg(got, truth)
        rms_before, rms_after = np.sqrt(np.mean(before[keep] ** 2)), np.sqrt(np.mean(after ** 2))
        print("%s: RMS to the truth %.3f° → %.3f°, max %.3f° → %.3f°" % (
            obj.name, rms_before, rms_after, before.max(), after.max()))
        assert rms_after <= 0.5 * rms_before, line.line()
        assert after.max() <= 3 * NOISE_DEG, "%s: %.3f° at frame %s" % (line.line(), after.max(),
                                                                         FRAMES[after.argmax()])
        # Nothing flips: consecutive played rotations stay close (the motion turns < 2° a frame).
        assert angles_deg(got[1:], got[:-1]).max() < 5.0


def test_reduce_on_the_way_out_keeps_the_bound(cleaner, tmp_path):
    """reduce=True: the cleaned keys reduced (BEZIER) within the tolerance of the dense cleaned keys at
    every instant — held in a fresh Blender at 64 points per frame and 200 random times against the
    dense clean of the same capture — so within deviation + tolerance of every non-spike frame, with
    far fewer keys than one per frame."""
    truth = truth_quats(FRAMES, 3)
    noisy = noisy_capture(truth, 4)
    dense, reduced = keyed("Dense", "QUATERNION", noisy), keyed("Reduced", "QUATERNION", noisy)
    plain = clean.clean([targets.Target(dense)], clean.CleanSettings())
    result = clean.clean([targets.Target(reduced)], clean.CleanSettings(reduce=True, tolerance=0.1))
    line = result.targets[0]
    assert "at every instant" in line.reduced_text and "ABOVE" not in line.reduced_text, line.line()
    assert line.keys_after < 0.5 * line.keys_before, line.line()
    assert line.spikes == plain.targets[0].spikes
    blend = tmp_path / "reduced.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    rng = np.random.default_rng(5)
    times = np.sort(np.concatenate([np.arange(FRAMES[0] * 64, FRAMES[-1] * 64 + 1) / 64.0,
                                    rng.uniform(FRAMES[0], FRAMES[-1], 200)]))
    played = fresh_blender_quats(blend, [["Dense", None], ["Reduced", None]], times, tmp_path)
    between = angles_deg(played["Reduced"], played["Dense"])
    assert between.max() <= 0.1 + 1e-4, "%.5f° at frame %s" % (between.max(), times[between.argmax()])
    at_frames = np.isin(times, FRAMES)
    keep = ~np.isin(times, [float(f) for f in line.spikes])
    assert angles_deg(played["Reduced"][at_frames & keep], noisy[np.isin(FRAMES, times[at_frames & keep])]).max() \
        <= line.deviation_deg + 0.1 + 1e-3, line.line()


def test_operator_reports_spikes_and_an_explicit_deviation(cleaner):
    """The operator on the selection: the panel's settings, an explicit deviation in degrees, the
    summary naming the spikes' target and largest departure; in place replaces the rotation curves."""
    truth = truth_quats(FRAMES, 7)
    obj = keyed("Op", "QUATERNION", noisy_capture(truth, 8))
    select_only(obj)
    assert bpy.ops.quatcurve.clean(deviation=2.0, new_action=False) == {"FINISHED"}
    settings = bpy.context.scene.quatcurve_clean
    assert "spike frames replaced on Op" in settings.last_summary, settings.last_summary
    assert "bound 2.0000°" in settings.last_lines, settings.last_lines
    assert fcurves.active_action(obj).name == "OpAction"  # in place


def test_refusals_name_the_target_and_change_nothing(cleaner):
    truth = truth_quats(FRAMES, 9)
    obj = keyed("Modded", "QUATERNION", noisy_capture(truth, 9))
    fcurves.Channels.of(obj).find("rotation_quaternion", 1).modifiers.new("NOISE")
    digest = fcurves.action_digest(fcurves.active_action(obj))
    with pytest.raises(clean.CleanError, match=r"Modded: .*modifiers"):
        clean.clean([targets.Target(obj)], clean.CleanSettings())
    select_only(obj)
    with pytest.raises(RuntimeError, match="Modded"):
        bpy.ops.quatcurve.clean()
    assert fcurves.action_digest(fcurves.active_action(obj)) == digest
    assert len(bpy.data.actions) == 1
    short = bpy.data.objects.new("Short", None)
    bpy.context.scene.collection.objects.link(short)
    short.rotation_mode = "QUATERNION"
    fcurves.new_action(short, "ShortAction")
    channels = fcurves.Channels.of(short, create=True)
    for i in range(4):
        channels.write("rotation_quaternion", i, np.array([1.0, 2.0]), np.array([1.0, 1.0]) * (i == 0))
    with pytest.raises(clean.CleanError, match="Short: 2 frames"):
        clean.clean([targets.Target(short)], clean.CleanSettings())
    with pytest.raises(clean.CleanError, match="deviation"):
        clean.clean([targets.Target(obj)], clean.CleanSettings(deviation=-1.0))
    select_only()
    with pytest.raises(RuntimeError, match="Nothing to clean"):
        bpy.ops.quatcurve.clean()


def noisy_chain():
    """rigs.build_chain_rig at FRAMES, every bone's rotation replaced by LINEAR keys of its smooth
    motion with noise and spikes (noisy_capture, a seed per bone; no sign flips), in the bone's own
    mode. Returns (rig, the truth {bone: (N, 4)}, the capture {bone: (N, 4)})."""
    rig = rigs.build_chain_rig(frames=len(FRAMES))
    qc = native.require()
    read = skeleton.read_armature(rig, [b.name for b in rig.data.bones])
    channels = fcurves.Channels.of(rig)
    truth, captured = {}, {}
    for k, (target, (mode, values), prop) in enumerate(zip(read.targets, read.rotations, read.props)):
        truth[target.bone] = qc.channels_to_quats(values, mode)
        captured[target.bone] = noisy_capture(truth[target.bone], 40 + k, flips=False)
        rows = qc.quats_to_channels(captured[target.bone], mode, reference=values[0])
        for i in range(rows.shape[1]):
            fcurves.write_keys(channels.find(target.data_path(prop), i), read.frames, rows[:, i], "LINEAR")
    return rig, truth, captured


def test_distance_bound_holds_on_blenders_pose_in_a_fresh_blender(cleaner, tmp_path):
    """error='DISTANCE' on a noisy chain (every rotation mode): a fresh Blender poses the cleaned
    action with every virtual vertex (reduce's: tail and shell points, armature space) within the
    reported bound of the captured pose's at every frame that is not a spike of the bone or a parent,
    measured from Blender's own pose_bone.matrix; the planted spikes are replaced; the clean gets
    closer to the truth than the capture; with the default distance (0: the noise's reach) and an
    explicit one."""
    rig, truth, captured = noisy_chain()
    original = fcurves.active_action(rig)
    shell = 0.1
    before = posed(rig, FRAMES, tmp_path, "captured")
    bones = [b.name for b in rig.data.bones]
    parents = {b.name: b.parent.name if b.parent else None for b in rig.data.bones}
    for distance in (0.0, 0.004):
        fcurves.assign_action(rig, original)
        result = clean.clean([targets.Target(rig, name) for name in bones],
                             clean.CleanSettings(error="DISTANCE", distance=distance, shell=shell))
        print("\n" + "\n".join(result.lines()) + "\n" + result.summary())
        blend = tmp_path / "cleaned.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
        played, matrices = fresh_blender_quats(blend, [[rig.name, b] for b in bones], FRAMES, tmp_path,
                                               matrices=True)
        spikes = {t.name.split("/", 1)[1]: {int(round(f)) - 1 for f in t.spikes} for t in result.targets}
        assert all(set(SPIKES) <= found for found in spikes.values()), result.lines()
        worst = 0.0
        for bone in rig.data.bones:
            skip, name = set(), bone.name
            while name is not None:  # the spike frames of the bone and its parents: no bound there
                skip |= spikes[name]
                name = parents[name]
            keep = np.ones(len(FRAMES), dtype=bool)
            keep[sorted(skip)] = False
            after = matrices["%s/%s" % (rig.name, bone.name)]
            d = np.linalg.norm(vertices(after, bone.length, shell)
                               - vertices(before[bone.name], bone.length, shell), axis=2).max(axis=1)[keep]
            worst = max(worst, float(d.max()))
            assert d.max() <= result.distance, "%s frame %s: %.6g above %.6g" % (
                bone.name, FRAMES[keep][d.argmax()], d.max(), result.distance)
        rms = [float(np.sqrt(np.mean(np.concatenate([angles_deg(q[b], truth[b]) for b in bones]) ** 2)))
               for q in (captured, {b: played["%s/%s" % (rig.name, b)] for b in bones})]
        print("Blender's worst distance %.6g, the result's %.6g, bound %.6g; RMS to the truth %.3f° → %.3f°" % (
            worst, result.worst_distance, result.distance, *rms))
        if distance:
            assert result.distance == distance
        assert result.shell == shell and "virtual vertices within" in result.summary()
        assert worst == pytest.approx(result.worst_distance, rel=1e-3, abs=1e-6)
        assert rms[1] < rms[0]


def test_distance_refusals(cleaner):
    """error='DISTANCE': a negative distance or shell, reduce on the way out, an unknown error, and
    what reduce's distance bound refuses (a constraint on a bone), each naming the cause; nothing
    written."""
    rig, _, _ = noisy_chain()
    found = [targets.Target(rig, b.name) for b in rig.data.bones]
    for settings, match in ((clean.CleanSettings(error="DISTANCE", distance=-0.001), "distance -0.001"),
                            (clean.CleanSettings(error="DISTANCE", shell=-1.0), "shell -1.0"),
                            (clean.CleanSettings(error="DISTANCE", reduce=True), "reduce: its bound is an angle"),
                            (clean.CleanSettings(error="LENGTH"), "error 'LENGTH'")):
        with pytest.raises(clean.CleanError, match=match):
            clean.clean(found, settings)
    rig.pose.bones["hand.L"].constraints.new("COPY_ROTATION")
    with pytest.raises(clean.CleanError, match="Chain/hand.L: constraint"):
        clean.clean(found, clean.CleanSettings(error="DISTANCE"))
    assert len(bpy.data.actions) == 1


def test_one_undo_takes_a_clean_back_in_a_window(tmp_path):
    """In a Blender with a window (sessions/clean_undo_session.py): a clean into a new action and one in
    place each change the file, and one ed.undo after each restores every action and the action played."""
    verdict = windowed("clean_undo_session.py", tmp_path / "clean_undo.json")
    for label, run in verdict["runs"].items():
        assert run["result"] == ["FINISHED"], label
        assert run["changed"], "%s: the clean changed nothing, so undo proves nothing" % label
        assert run["restored"], (label, run["differences"])
