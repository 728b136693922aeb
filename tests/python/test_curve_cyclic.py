"""Loops (curve.hpp, "Loops"): Curve(..., cyclic=True) and the same option in from_euler,
from_axis_angle and from_channels: keys hit, the curve repeats with its period before, inside and
after the keys, is as smooth at the seam as at an interior key, keeps turns on the seam segment;
a last key that is not the first rotation is refused with both keys, frames and the angle named."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation as R

import quatcurve as qc

METHODS = ("QUAT_COMPONENTS", "NLERP", "SLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2")
SMOOTH = ("SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2")
T = np.array([0.0, 4.0, 5.0, 11.0, 20.0])
ROTVECS = np.array([[0, 0, 0.3], [0.9, 0.2, 0.1], [0.7, 0.8, 0.2], [0.1, 0.2, 0.7], [0, 0, 0.3]])
KEYS = np.roll(R.from_rotvec(ROTVECS).as_quat(), 1, axis=1)
KEYS[-1] *= -1  # the same rotation, either sign


def angle(a, b):
    return qc.angle_between(a, b)


def fd_velocity(curve, t, d=1e-6):
    """World-frame velocities from [t − d, t] and [t, t + d] (scipy as the oracle)."""
    q = curve.sample(np.array([t - d, t, t + d]))
    r = R.from_quat(np.roll(q, -1, axis=1))
    return (r[1] * r[0].inv()).as_rotvec() / d, (r[2] * r[1].inv()).as_rotvec() / d


@pytest.mark.parametrize("method", METHODS)
def test_keys_hit_and_the_curve_repeats(method):
    c = qc.Curve(T, KEYS, method, cyclic=True)
    assert c.options["cyclic"] is True
    assert angle(c.sample(T), KEYS).max() < 1e-12
    t = np.linspace(0, 20, 203)
    q0, w0 = c.sample(t), c.angular_velocity(t)
    for k in range(-3, 4):
        assert angle(c.sample(t + 20 * k), q0).max() < 1e-11
        assert np.abs(c.angular_velocity(t + 20 * k) - w0).max() < 1e-9
    if method != "QUAT_COMPONENTS":  # sign-continuous over several periods
        q = c.sample(np.linspace(-40, 60, 20001))
        assert np.sum(q[1:] * q[:-1], axis=1).min() > 0


@pytest.mark.parametrize("method", SMOOTH)
def test_the_seam_is_smooth(method):
    c = qc.Curve(T, KEYS, method, cyclic=True)
    left, right = fd_velocity(c, 20.0)
    il, ir = fd_velocity(c, 11.0)
    ol, orr = fd_velocity(qc.Curve(T, KEYS, method), 20.0)
    assert np.linalg.norm(left - right) < 1e-4
    assert np.linalg.norm(il - ir) < 1e-4
    assert np.linalg.norm(ol - orr) > 1e-2  # the open curve stops at its last key


def test_spline_c2_acceleration_across_the_seam():
    c = qc.Curve(T, KEYS, "SPLINE_C2", cyclic=True)
    d = 1e-4
    w = c.angular_velocity(np.array([20 - 2 * d, 20 - d, 20 + d, 20 + 2 * d]))
    assert np.linalg.norm((w[3] - w[2]) / d - (w[1] - w[0]) / d) < 1e-3


@pytest.mark.parametrize("method", ("SLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2"))
def test_wheel_through_every_constructor(method):
    """0 → 360° about Z in 3 keys: the end is the start's rotation; one turn per period."""
    t = np.array([0.0, 12.0, 24.0])
    z = np.array([0.0, np.pi, 2 * np.pi])
    euler = np.column_stack([np.zeros(3), np.zeros(3), z])
    axis_angle = np.column_stack([z, np.zeros(3), np.zeros(3), np.ones(3)])
    curves = [qc.Curve.from_euler(t, euler, "XYZ", method, cyclic=True),
              qc.Curve.from_axis_angle(t, axis_angle, method, cyclic=True),
              qc.Curve.from_channels(t, euler, "XYZ", method, cyclic=True),
              qc.Curve.from_channels(t, axis_angle, "AXIS_ANGLE", method, cyclic=True)]
    for c in curves:
        w = c.angular_velocity(np.array([-30.0, 0.0, 23.999, 24.0, 100.0]))
        assert np.abs(w[:, 2] - 2 * np.pi / 24).max() < 1e-6


def test_turns_on_the_seam_segment():
    t = np.array([0.0, 8.0, 20.0])
    q = np.array([[1.0, 0, 0, 0], [np.cos(1.0), 0, 0, np.sin(1.0)], [1.0, 0, 0, 0]])
    c = qc.Curve(t, q, "SQUAD", cyclic=True, turns=[0, 1, 0])
    assert c.segment_paths()[1, 0] == pytest.approx(2.0 + 2 * np.pi)
    left, right = fd_velocity(c, 20.0)
    assert np.linalg.norm(left - right) < 1e-4


@pytest.mark.parametrize("build", ("quats", "channels", "euler"))
def test_a_loop_that_does_not_close_is_refused(build):
    t = np.array([0.0, 10.0, 30.0])
    with pytest.raises(ValueError) as e:
        if build == "quats":
            q = np.array([[1.0, 0, 0, 0], [np.cos(0.5), 0, 0, np.sin(0.5)], [np.cos(0.05), 0, 0, np.sin(0.05)]])
            qc.Curve(t, q, "SLERP", cyclic=True)
        elif build == "channels":
            qc.Curve.from_channels(t, [[0, 0, 0], [0, 0, 1.0], [0, 0, 0.1]], "XYZ", "SPLINE_C2", cyclic=True)
        else:
            qc.Curve.from_euler(t, [[0, 0, 0], [0, 0, 1.0], [0, 0, 0.1]], "XYZ", "EULER", cyclic=True)
    msg = str(e.value)
    assert "key 2, frame 30" in msg and "key 0, frame 0" in msg
    assert "5.7296°" in msg
    assert "key the first pose again at frame 30" in msg


def test_option_is_listed_and_checked():
    for method in qc.METHODS:
        assert "cyclic" in qc.METHOD_OPTIONS[method]
    with pytest.raises(ValueError, match="cyclic: expected a bool"):
        qc.Curve(T, KEYS, "SLERP", cyclic=2)
    assert qc.Curve(T, KEYS, "SLERP").options["cyclic"] is False


def test_motion_bounds_across_the_seam():
    for method in METHODS:
        c = qc.Curve(T, KEYS, method, cyclic=True)
        for lo, hi in ((18.0, 23.0), (-103.0, -95.0), (55.0, 90.0)):
            speed, _ = c.motion_bounds(lo, hi)
            t = np.linspace(lo, hi, 4001)
            q = c.sample(t)
            assert (angle(q[1:], q[:-1]) / (t[1] - t[0])).max() <= speed * (1 + 1e-6)
            assert np.linalg.norm(c.angular_velocity(t), axis=1).max() <= speed * (1 + 1e-9)


def test_reduce_slerp_loop():
    c = qc.Curve(T, KEYS, "SPLINE_C2", cyclic=True)
    t = np.arange(21.0)
    q = c.sample(t)
    r = qc.reduce_slerp(t, q, 0.01, cyclic=True)
    assert r.indices[0] == 0 and r.indices[-1] == 20
    assert qc.angle_between(r.quats[0], r.quats[-1]) < 1e-15
    assert r.max_error <= 0.01
    q[-1] = q[5]
    with pytest.raises(ValueError, match=r"sample 20, time 20.*sample 0, time 0.*° apart"):
        qc.reduce_slerp(t, q, 0.01, cyclic=True)
