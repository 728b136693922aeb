"""fit_keys: the reducer with an animator's keys forced (reduce.hpp "fitting with given keys"). The
bound is checked with quatcurve.blender_evaluate (Blender's evaluation, itself tested against
Blender in tests/blender/test_blender_eval.py)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation as R

import quatcurve as qc

DEG = np.pi / 180


def evaluate(keys, frames):
    return np.stack([qc.blender_evaluate(ch.frames, ch.values, frames, keys.interpolation,
                                         ch.handle_left, ch.handle_right) for ch in keys.channels], axis=-1)


def quat_errors(keys, t, q):
    e = evaluate(keys, t)
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    d = np.abs(np.sum(e * q / np.linalg.norm(q, axis=1, keepdims=True), axis=1))
    return 2 * np.arccos(np.minimum(d, 1))


@pytest.mark.parametrize("method", ["SLERP", "SQUAD", "CATMULL_ROM", "SPLINE_C2"])
def test_curve_through_animator_keys(method):
    key_t = np.array([1.0, 5.0, 6.0, 30.0, 31.0, 60.0])
    rots = R.from_rotvec([[0, 0, 0], [0.8, 0, 0], [0.8, 0.9, 0], [0, 1.4, 1.4], [0.1, 1.5, 1.2], [2.0, 0.2, 0]])
    key_q = np.roll(rots.as_quat(), 1, axis=1)
    for i in range(1, len(key_q)):
        if key_q[i] @ key_q[i - 1] < 0:
            key_q[i] = -key_q[i]
    t = np.arange(1.0, 60.0 + 1e-9, 0.25)  # every frame and 3 subframes
    q = qc.Curve(key_t, key_q, method).sample(t)
    forced = np.searchsorted(t, key_t)
    q[forced] = key_q  # the animator's values exactly
    r = qc.fit_keys(t, q, forced, 0.05 * DEG)
    assert r.max_error <= 0.05 * DEG
    assert quat_errors(r, t, q).max() <= 0.05 * DEG + 1e-6
    for c, ch in enumerate(r.channels):
        pos = np.searchsorted(ch.indices, forced)
        np.testing.assert_array_equal(ch.indices[pos], forced)
        np.testing.assert_array_equal(ch.values[pos], key_q[:, c].astype(np.float32))
        np.testing.assert_array_equal(ch.frames[pos], key_t)


def test_euler_mode_and_errors():
    t = np.arange(0.0, 20.0 + 1e-9, 0.25)
    a = np.stack([0.3 * np.sin(0.2 * t), 1.2 * np.sin(0.1 * t + 0.4), 4 * np.pi * t / 20], axis=1)
    forced = np.array([0, 20, 40, 80])
    r = qc.fit_keys(t, a, forced, 0.01 * DEG, mode="ZXY")
    assert len(r.channels) == 3 and r.max_error <= 0.01 * DEG
    with pytest.raises(ValueError, match=r"forced\[1\]: not increasing"):
        qc.fit_keys(t, a, [40, 20], 0.01, mode="ZXY")
    with pytest.raises(ValueError, match=r"forced\[0\]: not a sample index"):
        qc.fit_keys(t, a, [0.5], 0.01, mode="ZXY")
    with pytest.raises(ValueError, match="values: expected shape"):
        qc.fit_keys(t, a, [0], 0.01)  # QUATERNION mode needs (N, 4)
    with pytest.raises(ValueError, match="min_gap"):
        qc.fit_keys(t, a, [0], 0.01, mode="XYZ", min_gap=-1)
