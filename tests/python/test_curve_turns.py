"""Turns (curve.hpp, "Turns"): the segment leaving a key turns N extra full turns about its own axis,
for every method (quaternion, Euler and axis-angle keys, with ease); unit output, keys hit; still
segments borrow a neighbour's axis or are refused; bad values are refused."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation as R

import quatcurve as qc

METHODS = ("NLERP", "SLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2")
T = np.array([1.0, 5.0, 15.0, 20.0])
KEYS = np.roll(R.from_rotvec([[0, 0, 0], [0.6, 0.1, 0], [0.9, 0.6, 0.1], [0.3, 1.3, 0.5]]).as_quat(), 1, axis=1)


def qmul(a, b):
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)


def signed_turn(curve, t0, t1, axis, n=4000):
    """The signed turn about `axis` (frame of the curve at t0) over [t0, t1]: 2·atan2(v·u, w) of
    conj(q(t0))·q(t) unwrapped along dense samples (the samples are sign-continuous); checks unit
    output, and returns the path length (sum of the angles between samples) too."""
    q = curve.sample(np.linspace(t0, t1, n + 1))
    assert np.abs(np.linalg.norm(q, axis=1) - 1).max() < 1e-12
    p = qmul(q[0] * [1, -1, -1, -1], q)
    angle = np.unwrap(2 * np.arctan2(p[:, 1:] @ (axis / np.linalg.norm(axis)), p[:, 0]))
    length = qc.angle_between(q[1:], q[:-1]).sum()
    return angle[-1] - angle[0], length


def rotvec(a, b):
    """The shortest rotation vector from key a to key b (frame of a), w, x, y, z keys."""
    return (R.from_quat(np.roll(a, -1)).inv() * R.from_quat(np.roll(b, -1))).as_rotvec()


def keys_hit(curve, keys, tol=1e-9):
    return qc.angle_between(curve.sample(curve.times), keys).max() < tol


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("turns", [1, 2, -1])
def test_segment_turns_n_more_times(method, turns):
    plain = qc.Curve(T, KEYS, method)
    curve = qc.Curve(T, KEYS, method, turns=[0, turns, 0, 0])
    r = rotvec(KEYS[1], KEYS[2])
    theta = np.linalg.norm(r)
    assert signed_turn(plain, 5, 15, r)[0] == pytest.approx(theta, abs=1e-6)
    turn, length = signed_turn(curve, 5, 15, r)
    assert turn == pytest.approx(theta + 2 * np.pi * turns, abs=1e-6)
    assert length >= abs(theta + 2 * np.pi * turns) - 1e-6
    assert keys_hit(curve, KEYS)
    # the neighbours keep their own turn
    r0 = rotvec(KEYS[0], KEYS[1])
    assert signed_turn(curve, 1, 5, r0)[0] == pytest.approx(np.linalg.norm(r0), abs=1e-6)
    assert curve.options["turns"].tolist() == [0, turns, 0, 0]


@pytest.mark.parametrize("method", METHODS)
def test_turns_with_ease_from_euler_and_axis_angle(method):
    # about Z: 0 → 90° (90°), then 90° → 400° (a spin of 310° already): turns add to the path's turn
    t = np.array([0.0, 10.0, 20.0])
    angles = np.radians([[0, 0, 0], [0, 0, 90], [0, 0, 400]])
    turns = [1, -1, 0]
    path = np.radians([90, 310])
    curve = qc.Curve.from_euler(t, angles, "XYZ", method, turns=turns, ease_in=[0, 1, 0.5], ease_out=[0.4, 0, 0])
    for i in range(2):
        assert signed_turn(curve, t[i], t[i + 1], [0, 0, 1])[0] == pytest.approx(path[i] + 2 * np.pi * turns[i],
                                                                               abs=1e-6)
    keys = np.roll(R.from_euler("xyz", angles).as_quat(), 1, axis=1)
    assert keys_hit(curve, keys)
    values = np.array([[0, 0, 0, 1], [np.pi / 2, 0, 0, 1], [np.radians(400), 0, 0, 1]])
    curve = qc.Curve.from_axis_angle(t, values, method, turns=2)
    for i in range(2):
        assert signed_turn(curve, t[i], t[i + 1], [0, 0, 1])[0] == pytest.approx(path[i] + 4 * np.pi, abs=1e-6)


@pytest.mark.parametrize("method", METHODS)
def test_still_segment_takes_the_previous_else_the_next_axis(method):
    a = R.from_rotvec([0.4, 0, 0])
    b = R.from_rotvec([0, 0.9, 0])
    qa, qb = np.roll(a.as_quat(), 1), np.roll(b.as_quat(), 1)
    keys = np.array([[1, 0, 0, 0], qa, qa, qb])
    curve = qc.Curve([0, 10, 20, 30], keys, method, turns=[0, 1, 0, 0])
    assert signed_turn(curve, 10, 20, [1, 0, 0])[0] == pytest.approx(2 * np.pi, abs=1e-6)
    assert keys_hit(curve, keys)
    keys = np.array([qa, -qa, qb])  # q and −q: the same rotation, no previous segment
    curve = qc.Curve([0, 10, 20], keys, method, turns=[-1, 0, 0])
    r = rotvec(qa, qb)
    assert signed_turn(curve, 0, 10, r)[0] == pytest.approx(-2 * np.pi, abs=1e-6)
    with pytest.raises(ValueError, match=r"turns\[1\]: key 1 and key 2 are the same rotation and neither "
                                         r"neighbouring segment turns"):
        qc.Curve([0, 10, 20, 30], [qa, qa, qa, qa], method, turns=[0, 1, 0, 0])


def test_bad_turns_are_refused():
    with pytest.raises(ValueError, match=r"turns\[0\]: 0.500000 is not a whole number"):
        qc.Curve(T, KEYS, "SLERP", turns=0.5)
    with pytest.raises(ValueError, match=r"turns\[2\]: not a finite number"):
        qc.Curve(T, KEYS, "SQUAD", turns=[0, 1, np.nan, 0])
    with pytest.raises(ValueError, match=r"turns\[0\]: not a finite number"):
        qc.Curve(T, KEYS, "TCB", turns=np.inf)
    with pytest.raises(ValueError, match=r"turns: expected one value or one per key \(4\), got 3"):
        qc.Curve(T, KEYS, "SPLINE_C2", turns=[1, 1, 1])
    with pytest.raises(ValueError, match="turns: not an option of method QUAT_COMPONENTS"):
        qc.Curve(T, KEYS, "QUAT_COMPONENTS", turns=1)
    with pytest.raises(ValueError, match="turns: not an option of method EULER"):
        qc.Curve.from_euler(T, np.zeros((4, 3)), "XYZ", "EULER", turns=1)
    with pytest.raises(ValueError, match="beyond the supported"):
        qc.Curve(T, KEYS, "NLERP", turns=[0, 1e6, 0, 0])
