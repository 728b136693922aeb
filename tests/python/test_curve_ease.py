"""Ease in / ease out for every method (native/src/curve_ease.cpp): zero angular velocity at fully
eased keys, keys hit, the path unchanged (scipy's Slerp as the SLERP oracle)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation as R
from scipy.spatial.transform import Slerp

import quatcurve as qc

METHODS = ("NLERP", "SLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2")
T = np.array([1.0, 5.0, 6.0, 20.0, 24.0])
ROTS = R.from_rotvec([[0, 0, 0], [0.8, 0, 0], [0.8, 0.8, 0], [0, 1.4, 1.4], [0.3, -1, 0.2]])
KEYS = np.roll(ROTS.as_quat(), 1, axis=1)  # (w, x, y, z)


@pytest.mark.parametrize("method", METHODS)
def test_full_ease_stops_at_keys_and_keeps_the_path(method):
    ease_in, ease_out = [0, 1, 0.3, 0, 0.5], [1, 0, 0.6, 1, 0]
    slow = qc.Curve(T, KEYS, method, ease_in=ease_in, ease_out=ease_out)
    plain = qc.Curve(T, KEYS, method)
    assert np.abs(slow.angular_velocity(np.array([1.0, 20.0]))).max() < 1e-12
    assert np.linalg.norm(slow.angular_velocity(5.0 - 1e-9)) < 1e-6
    at_keys = slow.sample(T)
    assert np.all(np.abs(np.sum(at_keys * KEYS, axis=1)) > 1 - 1e-12)
    # same path: every eased sample lies on the plain curve's dense path
    path = plain.sample(np.linspace(1, 24, 11501))
    probe = slow.sample(np.linspace(1.05, 23.9, 60))
    nearest = qc.angle_between(probe[:, None, :], path[None, :, :]).min(axis=1)
    assert np.all(nearest < 2e-3)


def test_eased_slerp_is_scipy_slerp_at_warped_times():
    # ease_out 1 at key 0 over segment [1, 5]: u' = u² (a = 1, b = 0, k = 1)
    c = qc.Curve(T[:2], KEYS[:2], "SLERP", ease_out=[1.0, 0.0])
    u = np.linspace(0, 1, 11)
    ref = Slerp(T[:2], ROTS[:2])(1 + 4 * u ** 2)
    got = R.from_quat(np.roll(c.sample(1 + 4 * u), -1, axis=1))
    assert (got * ref.inv()).magnitude().max() < 1e-12


def test_ease_out_of_range_is_refused():
    with pytest.raises(ValueError, match=r"ease_in\[0\]"):
        qc.Curve(T, KEYS, "SLERP", ease_in=1.5)
    with pytest.raises(ValueError, match="ease_out: expected one value or one per key"):
        qc.Curve(T, KEYS, "SQUAD", ease_out=[0.1, 0.2])
