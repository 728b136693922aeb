"""The native Euler conversion picks the branch Blender picks: quatcurve.quat_to_euler_blender
against mathutils' Quaternion.to_euler(order) and .to_euler(order, compat), in every Blender —
random quaternions, compat references, near and at gimbal lock.

Blender computes in float32, the native code in double: angles agree to float32 rounding (looser
near the lock, where the first and last angles are ill-conditioned), the rotation to 1e-5 rad.
References stay within 1 rad of the answer (plus whole turns), where Blender 3.4's compatible_eul
(5.1 rad thresholds) and later ones (π) agree."""

import math

import numpy as np
import pytest
from mathutils import Euler, Quaternion

from quatcurve_blender import native

ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")


def middle(order):
    return "XYZ".index(order[1])


def check_same_branch(q, order, got, want, compat=None, tol=2e-4):
    qc = native.require()
    got_q = qc.euler_to_quat(got, order)
    want_q = np.array(Euler(want, order).to_quaternion())
    assert float(qc.angle_between(got_q, q)) < 1e-5
    assert float(qc.angle_between(want_q, q)) < 1e-3  # float32 near the lock
    # The same branch: the middle angle (which separates the two solutions) and the distance from
    # the reference (or zero) agree.
    j = middle(order)
    assert got[j] == pytest.approx(want[j], abs=tol), (order, got, want)
    ref = np.zeros(3) if compat is None else np.asarray(compat)
    assert np.abs(got - ref).sum() == pytest.approx(np.abs(np.array(want) - ref).sum(), abs=3 * tol)


@pytest.mark.parametrize("order", ORDERS)
def test_random_quaternions(order):
    qc = native.require()
    rng = np.random.default_rng(7)
    for q in rng.normal(size=(300, 4)):
        q = q / np.linalg.norm(q)
        q32 = np.array(Quaternion(q))           # what Blender holds (float32)
        want = Quaternion(q32).to_euler(order)
        got = qc.quat_to_euler_blender(q32, order)
        e1 = qc.quat_to_euler(q32, order)
        e2 = np.array([math.remainder(e1[k] + (math.pi if k != middle(order) else 0.0), 2 * math.pi)
                       for k in range(3)])
        e2[middle(order)] = math.remainder(math.pi - e1[middle(order)], 2 * math.pi)
        if abs(np.abs(e1).sum() - np.abs(e2).sum()) < 1e-4:
            continue  # a tie within float32 rounding: either branch is Blender's
        check_same_branch(q32, order, got, want)
        np.testing.assert_allclose(got, want, atol=2e-5)


@pytest.mark.parametrize("order", ORDERS)
def test_compat_references(order):
    qc = native.require()
    rng = np.random.default_rng(8)
    for q in rng.normal(size=(300, 4)):
        q32 = np.array(Quaternion(q / np.linalg.norm(q)))
        base = qc.quat_to_euler_blender(q32, order)
        compat = base + rng.uniform(-1.0, 1.0, 3) + 2 * math.pi * rng.integers(-3, 4, 3)
        compat = np.array(Euler(compat, order))  # float32, as Blender holds it
        want = Quaternion(q32).to_euler(order, Euler(compat, order))
        got = qc.quat_to_euler_blender(q32, order, compat)
        check_same_branch(q32, order, got, want, compat)
        np.testing.assert_allclose(got, want, atol=5e-5)


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("off_lock", [0.0, 1e-3, 1e-2, 0.2])
def test_near_gimbal_lock(order, off_lock):
    qc = native.require()
    rng = np.random.default_rng(9)
    j = middle(order)
    for sign in (1.0, -1.0):
        for _ in range(20):
            angles = rng.uniform(-math.pi, math.pi, 3)
            angles[j] = sign * (math.pi / 2 - off_lock)
            q32 = np.array(Euler(angles, order).to_quaternion())
            want = Quaternion(q32).to_euler(order)
            got = qc.quat_to_euler_blender(q32, order)
            tol = 2e-4 if off_lock >= 1e-2 else 5e-2
            check_same_branch(q32, order, got, want, tol=tol)
            compat = np.array(want) + rng.uniform(-0.5, 0.5, 3)
            want_c = Quaternion(q32).to_euler(order, Euler(compat, order))
            got_c = qc.quat_to_euler_blender(q32, order, compat)
            check_same_branch(q32, order, got_c, want_c, compat, tol=tol)


def test_compare_converts_keys_as_blender_does():
    """compare's BLENDER_EULER_<ORDER> keys of a quaternion-keyed target: the first key
    to_euler(order), each next to_euler(order, previous) — Blender's own conversion."""
    from types import SimpleNamespace

    from quatcurve_blender import compare
    qc = native.require()
    rng = np.random.default_rng(10)
    angles = np.cumsum(rng.normal(0.0, 0.3, (40, 3)), axis=0) + [2.9, 0.4, 2.9]  # starts past 180°
    for order in ORDERS:
        q32 = np.array([np.array(Euler(a, order).to_quaternion()) for a in angles])
        got = compare.euler_keys(SimpleNamespace(mode="QUATERNION"), q32, order)
        previous = None
        for k, q in enumerate(q32):
            want = Quaternion(q).to_euler(order) if previous is None else Quaternion(q).to_euler(order, previous)
            np.testing.assert_allclose(got[k], want, atol=5e-4, err_msg="%s key %d" % (order, k))
            previous = want
        assert qc.angle_between(qc.channels_to_quats(got, order), q32).max() < 1e-5
