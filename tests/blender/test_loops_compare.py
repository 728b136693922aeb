"""Compare on loops (issue 28): a target whose rotation channels carry Blender's plain Cycles
modifier is compared through its seam — the seam is a key like the others, so the jump of angular
velocity there is in the key metrics of Blender's evaluation, Blender's modes (scratch channels with
a Cycles modifier: Blender's cycle-aware auto handles) and every method's closed curve — and the
report marks the target cyclic with its period. Scenes: the quaternion loop and the uneven XYZ loop
of test_loops_fit.py. test_seam_jumps prints the README's figure."""
import json
import math

import numpy as np
import pytest

from compare_helpers import schema_errors
from quatcurve_blender import compare, fcurves, native
from test_loops_fit import EULER_LOOP, QUAT_LOOP, build, rotation_fcurves

SPECS = (QUAT_LOOP, EULER_LOOP)
SMOOTH = ("SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2")
SUBFRAMES = 8


def seam_jump(source):
    """The angular velocity jump at the seam (the first key; the last is the same key), deg/frame."""
    jumps = source.metrics["velocity_jumps"]
    assert math.isclose(jumps[0], jumps[-1], rel_tol=1e-6, abs_tol=1e-9)  # one seam, measured twice
    return math.degrees(jumps[0])


def seam_speed(frames, quats):
    """Angular speed (deg/frame) leaving the seam: over the first sample interval of the period."""
    qc = native.require()
    return math.degrees(float(qc.angular_deviation(quats[:1], quats[1:2])[0]) / (frames[1] - frames[0]))


@pytest.fixture
def loops(scene):
    return build("CMP", SPECS)


def test_seam_jumps(loops, tmp_path):
    settings = compare.CompareSettings(subframes=SUBFRAMES)
    report = compare.compare([b.target for b in loops], settings)
    path = str(tmp_path / "loops.json")
    compare.write_report(report, path)
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    assert schema_errors(data) == []
    qc = native.require()
    lines = ["%-10s %-22s %10s %10s %10s" % ("owner", "source", "vel. jump", "acc. jump", "speed")]
    for b, t, js in zip(loops, report.targets, data["targets"]):
        assert js["cyclic"] is True and js["period"] == b.last - b.first
        assert js["frames"]["start"] == b.first and js["frames"]["end"] == b.last  # one period sampled
        table = "\n".join(report.table_lines())
        assert "a loop: period %g frames" % (b.last - b.first) in table
        # The table names sources as the menus do; the JSON keeps the identifiers.
        assert "  C2 Spline " in table and "  Blender Euler XYZ " in table and "SPLINE_C2" not in table, table
        jumps = {name: seam_jump(s) for name, s in t.sources.items()}
        # Blender's playback without a Cycles modifier, the clip's time wrapped (a player looping it):
        # the same keys, auto-clamped handles computed for an open curve.
        prop = "rotation_quaternion" if b.spec.mode == "QUATERNION" else "rotation_euler"
        key_frames = np.array([f for f, _ in b.spec.keys], float)
        key_values = np.array([v for _, v in b.spec.keys], float)
        seam = compare.seam_frames(t.frames, key_frames)
        wrapped = b.first + np.mod(seam.frames - b.first, b.last - b.first)
        wrapped[seam.period.stop - 1] = b.last
        values = fcurves.evaluate_scratch_keys(prop, key_frames, key_values, wrapped)
        quats = qc.channels_to_quats(values, b.spec.mode) if b.spec.mode != "QUATERNION" else \
            values / np.linalg.norm(values, axis=1, keepdims=True)
        velocity, acceleration = qc.key_jumps(seam.frames, quats, seam.key_frames)
        jumps["Blender, no modifier"] = math.degrees(velocity[1])
        accelerations = {name: math.degrees(s.metrics["acceleration_jumps"][0]) for name, s in t.sources.items()}
        accelerations["Blender, no modifier"] = math.degrees(acceleration[1])
        speeds = {name: seam_speed(t.frames, s.quats) for name, s in t.sources.items()}
        speeds["Blender, no modifier"] = seam_speed(seam.frames[seam.period], quats[seam.period])
        for name, jump in jumps.items():
            lines.append("%-10s %-22s %10.3f %10.3f %10.3f" % (b.spec.label, name, jump, accelerations[name],
                                                                speeds[name]))
        slerp = jumps["SLERP"]
        assert slerp > 5.0, (b.name, slerp)
        for method in SMOOTH:
            assert jumps[method] < 0.1 * slerp, (b.name, method, jumps[method], slerp)
        assert jumps[compare.SOURCE_BLENDER] < 0.1 * slerp, (b.name, jumps)   # Blender's cyclic auto handles
        order = b.spec.mode if b.spec.mode != "QUATERNION" else "XYZ"
        assert jumps[compare.euler_source(order)] < 0.1 * slerp, (b.name, jumps)
        assert jumps[compare.SOURCE_BLENDER_QUATERNION] < 0.1 * slerp, (b.name, jumps)
        # Without the modifier Blender's auto-clamped handles are flat at both ends: no velocity jump
        # (Bezier handles are aligned) but the motion slows into the seam, where the keys do not ask
        # for it — on the Euler loop; the quaternion loop's components all turn at its seam key, so
        # its clamped handles are flat with the modifier too.
        assert jumps["Blender, no modifier"] < 0.1 * slerp
        if b.spec is EULER_LOOP:
            assert speeds["Blender, no modifier"] < 0.3 * speeds[compare.SOURCE_BLENDER], speeds
        # The seam counts in the largest jump, as any key: SLERP's is at least the seam's.
        assert js["sources"]["SLERP"]["max_velocity_jump_deg_per_frame"] >= slerp - 1e-9
    print("\n[loops] compare: angular velocity jump at the seam, deg/frame, %d samples per frame:\n%s"
          % (SUBFRAMES, "\n".join(lines)))


def test_open_target_is_not_cyclic(scene):
    built = build("OPEN", (QUAT_LOOP,), cyclic=False)
    report = compare.compare([built[0].target], compare.CompareSettings())
    js = report.targets[0].to_json()
    assert js["cyclic"] is False and js["period"] is None
    assert schema_errors(report.to_json()) == []


def test_mirror_cycle_is_refused(scene):
    built = build("MIRROR", (QUAT_LOOP,))
    target = built[0].target
    curve = sorted(rotation_fcurves(target.owner, "rotation_quaternion"), key=lambda c: c.array_index)[1]
    curve.modifiers[0].mode_before = curve.modifiers[0].mode_after = "MIRROR"
    with pytest.raises(compare.CompareError) as error:
        compare.compare([target], compare.CompareSettings())
    text = str(error.value)
    assert target.name in text and "rotation_quaternion[1]" in text and "MIRROR" in text, text
