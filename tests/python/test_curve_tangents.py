"""Overshoot-free tangents from Python (native/src/curve_tangents.cpp): the path rule on uneven key
spacing, holds that hold, continuity, keys hit, and the textbook tangents behind clamped=False.
scipy is the oracle for the key rotations."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation as R

import quatcurve as qc

CLAMPED = ("SQUAD", "TCB", "CATMULL_ROM")
DEG = np.pi / 180


def wxyz(rot):
    q = rot.as_quat()
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def chain(arcs, axes):
    """Keys whose segments turn by arcs[i] about axes[i] (local frames), starting at identity."""
    rot = R.identity()
    keys = [wxyz(rot)]
    for arc, axis in zip(arcs, axes):
        rot = rot * R.from_rotvec(arc * np.asarray(axis, float) / np.linalg.norm(axis))
        keys.append(wxyz(rot))
    return np.array(keys)


def angles(a, b):
    """Rotation angle between rotations (either sign), accurate also for tiny angles."""
    return qc.angle_between(a, b)


def path_lengths(curve, n=400):
    t = curve.times
    out = []
    for a, b in zip(t[:-1], t[1:]):
        q = curve.sample(np.linspace(a, b, n + 1))
        out.append(angles(q[1:], q[:-1]).sum())
    return np.array(out)


def check(curve, keys, path_rule=True):
    np.testing.assert_array_less(angles(curve.sample(curve.times), keys), 1e-9)
    arcs = angles(keys[1:], keys[:-1])
    lengths = path_lengths(curve)
    if path_rule:
        assert np.all(lengths <= qc.PATH_RULE_FACTOR * arcs + qc.PATH_RULE_SLACK), (lengths / DEG, arcs / DEG)
    reported = curve.segment_paths()
    np.testing.assert_allclose(reported[:, 0], arcs, atol=1e-9)
    assert np.all(reported[:, 1] <= lengths + 1e-9)
    dense = curve.sample(np.linspace(curve.times[0], curve.times[-1], 20001))
    np.testing.assert_allclose(np.linalg.norm(dense, axis=-1), 1.0, atol=1e-12)
    return lengths, arcs


@pytest.mark.parametrize("method", CLAMPED)
@pytest.mark.parametrize("ratio", [1, 10, 100, 1000])
@pytest.mark.parametrize("arc", [5, 40, 120])
@pytest.mark.parametrize("turning", [False, True])
def test_path_rule_on_uneven_spacing(method, ratio, arc, turning):
    rng = np.random.default_rng(ratio + arc)
    t = np.array([1, 2, 2 + ratio, 3 + ratio, 3 + 2 * ratio, 4 + 2 * ratio], float)
    axes = rng.normal(size=(5, 3)) if turning else [(0, 0, 1)] * 5
    keys = chain([arc * DEG] * 5, axes)
    check(qc.Curve(t, keys, method), keys)
    # velocity continuous at every key (C1; TCB with continuity 0)
    c = qc.Curve(t, keys, method)
    left = c.angular_velocity(t[1:-1] - 1e-7 * np.diff(t)[:-1])
    right = c.angular_velocity(t[1:-1])
    np.testing.assert_allclose(left, right, atol=1e-4 * (1 + np.abs(right).max()))


@pytest.mark.parametrize("method", CLAMPED)
def test_issue_example_quick_move_then_long_ease(method):
    keys = chain([80 * DEG, 6 * DEG], [(1, 0, 0), (0.2, 1, 0)])
    t = np.array([1.0, 2.0, 102.0])
    lengths, arcs = check(qc.Curve(t, keys, method), keys)
    assert lengths[1] <= 1.5 * arcs[1] + 10 * DEG
    textbook = path_lengths(qc.Curve(t, keys, method, clamped=False))
    if method == "CATMULL_ROM":
        assert textbook[1] > 720 * DEG  # the textbook non-uniform Catmull-Rom spins round


@pytest.mark.parametrize("method", CLAMPED)
def test_hold_stays_still_next_to_fast_moves(method):
    keys = chain([90 * DEG, 0.0, 120 * DEG], [(0, 0, 1), (0, 0, 1), (1, 0, 0)])
    t = np.array([1.0, 3.0, 203.0, 205.0])
    c = qc.Curve(t, keys, method)
    hold = c.sample(np.linspace(3, 203, 801))
    assert angles(hold, keys[1]).max() <= 1e-12
    textbook = qc.Curve(t, keys, method, clamped=False).sample(np.linspace(3, 203, 801))
    assert angles(textbook, keys[1]).max() > 1 * DEG  # the textbook tangents drift through the hold
    check(c, keys)


def test_random_hand_key_timings_every_method():
    rng = np.random.default_rng(5)
    gaps = np.array([0.5, 1, 2, 3, 5, 8, 12, 24, 48, 120])
    for trial in range(25):
        n = 4 + trial % 6
        t = np.cumsum(np.r_[1.0, rng.choice(gaps, n - 1)])
        arcs = np.where(rng.random(n - 1) < 0.2, 0.0, rng.random(n - 1) * 170 * DEG)
        keys = chain(arcs, rng.normal(size=(n - 1, 3)))
        for method in ("SLERP", "NLERP") + CLAMPED:
            check(qc.Curve(t, keys, method), keys)
        check(qc.Curve(t, keys, "SPLINE_C2"), keys, path_rule=False)


def test_even_spacing_smooth_motion_is_unchanged_by_the_clamp():
    keys = chain([(30 + 5 * i) * DEG for i in range(8)], [(np.cos(0.3 * i), np.sin(0.3 * i), 0.5) for i in range(8)])
    t = 1 + 4.0 * np.arange(9)
    s = np.linspace(1, 33, 321)
    for method in CLAMPED:
        np.testing.assert_array_equal(qc.Curve(t, keys, method).sample(s),
                                      qc.Curve(t, keys, method, clamped=False).sample(s))


def test_catmull_rom_is_continuous_on_the_issue_keys():
    keys = np.array([wxyz(R.from_rotvec(a * DEG * np.array(ax, float) / np.linalg.norm(ax)))
                     for a, ax in ((30, (1, 0, 0)), (110, (1, 1, 0)), (160, (0, 1, 1)), (75, (0.3, -1, 0.2)))])
    for i in range(1, 4):
        if keys[i] @ keys[i - 1] < 0:
            keys[i] = -keys[i]
    t = np.array([1.0, 2.0, 30.0, 90.0])
    for clamped in (True, False):
        c = qc.Curve(t, keys, "CATMULL_ROM", clamped=clamped)
        pair = c.sample(np.array([13.143745144, 13.143745145]))
        assert angles(pair[0], pair[1]) < 1e-6
        dense = c.sample(np.linspace(1, 90, 89001))
        assert angles(dense[1:], dense[:-1]).max() < 0.05


def test_spline_c2_overshoot_is_reported():
    keys = chain([80 * DEG, 6 * DEG], [(1, 0, 0), (0.2, 1, 0)])
    paths = qc.Curve([1.0, 2.0, 102.0], keys, "SPLINE_C2").segment_paths()
    assert paths[1, 1] > qc.PATH_RULE_FACTOR * paths[1, 0] + qc.PATH_RULE_SLACK


def test_bad_clamped_and_samples():
    keys = chain([0.5], [(0, 0, 1)])
    with pytest.raises(ValueError, match="clamped: not an option of method SLERP"):
        qc.Curve([0.0, 1.0], keys, "SLERP", clamped=True)
    with pytest.raises(ValueError, match="clamped: expected a bool"):
        qc.Curve([0.0, 1.0], keys, "SQUAD", clamped=0.5)
    with pytest.raises(ValueError, match="samples_per_segment"):
        qc.Curve([0.0, 1.0], keys, "SQUAD").segment_paths(0)
