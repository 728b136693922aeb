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
    return qc.angle_between(evaluate(keys, t), q)


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


def axis_angle_errors(keys, t, values):
    """Rotation angle between Blender's evaluation of the axis-angle keys (axis normalized) and the
    rotations of `values` (angle, x, y, z), at `t`."""
    e = evaluate(keys, t)
    return qc.angle_between(qc.channels_to_quats(e, "AXIS_ANGLE"), qc.channels_to_quats(values, "AXIS_ANGLE"))


def axis_angle_dense(key_t, key_v, method, subframes=4):
    """The method's curve through axis-angle keys (spins kept), sampled every 1/subframes frame, as
    axis-angle channels continuous from each segment's left key to its right key (axis_angle_span),
    keys exact."""
    t = np.union1d(np.arange(key_t[0], key_t[-1] + 1e-9, 1.0 / subframes), key_t)
    q = qc.Curve.from_axis_angle(key_t, key_v, method).sample(t)
    forced = np.searchsorted(t, key_t)
    values = np.empty((len(t), 4))
    for k in range(len(key_t) - 1):
        idx = np.arange(forced[k], forced[k + 1] + 1)
        values[idx] = qc.axis_angle_span(q[idx], key_v[k], key_v[k + 1])
    values[forced] = key_v
    return t, values, forced


@pytest.mark.parametrize("method", ["SLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2"])
def test_axis_angle_mode(method):
    # Spins beyond 360° between keys (0 → 400° → 760° about a tilted axis), an axis change, a
    # non-unit axis (Blender normalizes it) and a key at angle 0 (the axis free there).
    key_t = np.array([1.0, 9.0, 20.0, 26.0, 40.0])
    key_v = np.array([[0.0, 0.0, 0.0, 2.0],
                      [400 * DEG, 0.0, 0.3, 1.0],
                      [760 * DEG, 0.0, 0.3, 1.0],
                      [800 * DEG, 1.0, 0.2, 0.4],
                      [700 * DEG, 0.5, -0.5, 0.7]])
    t, values, forced = axis_angle_dense(key_t, key_v, method)
    r = qc.fit_keys(t, values, forced, 0.05 * DEG, mode="AXIS_ANGLE")
    assert len(r.channels) == 4 and r.max_error <= 0.05 * DEG
    assert axis_angle_errors(r, t, values).max() <= 0.05 * DEG - 1e-6
    for c, ch in enumerate(r.channels):
        pos = np.searchsorted(ch.indices, forced)
        np.testing.assert_array_equal(ch.indices[pos], forced)
        np.testing.assert_array_equal(ch.values[pos], key_v[:, c].astype(np.float32))
    # The spins are in the angle channel: between the 400° and 760° keys (same axis) Blender's
    # evaluated angle climbs the full turn, no shortcut the shorter way round.
    inside = (t >= 9.0) & (t <= 20.0)
    angle = evaluate(r, t[inside])[:, 0]
    assert np.all(np.diff(angle) > 0) and angle[0] == np.float32(400 * DEG) and angle[-1] == np.float32(760 * DEG)


def test_axis_angle_reduce_and_errors():
    t = np.arange(0.0, 40.0 + 1e-9)
    q = qc.Curve.from_axis_angle([0, 20, 40], [[0, 0, 0, 1], [7.0, 0, 1, 1], [9.0, 1, 0, 0]], "SQUAD").sample(t)
    v = qc.quats_to_channels(q, "AXIS_ANGLE", [0, 0, 0, 1])
    r = qc.reduce_keys_axis_angle(t, v, 0.1 * DEG, "BEZIER", False)
    assert r.max_error <= 0.1 * DEG and r.key_count < 4 * len(t) / 3
    assert axis_angle_errors(r, t, v).max() <= 0.1 * DEG
    lin = qc.reduce_keys_axis_angle(t, v, 0.1 * DEG, detailed=True)
    assert lin.max_error <= 0.1 * DEG and lin.synchronized
    bad = v.copy()
    bad[7, 1:] = 0
    with pytest.raises(ValueError, match=r"values\[7\]: zero-length axis"):
        qc.fit_keys(t, bad, [0, 40], 0.01, mode="AXIS_ANGLE")
    bad[7] = [np.nan, 0, 0, 1]
    with pytest.raises(ValueError, match=r"values\[7\] angle: "):
        qc.fit_keys(t, bad, [0, 40], 0.01, mode="AXIS_ANGLE")
    with pytest.raises(ValueError, match="values: expected shape"):
        qc.fit_keys(t, v[:, :3], [0], 0.01, mode="AXIS_ANGLE")


def test_axis_angle_span_arrives_at_the_keyed_representation():
    # 800° → 700° crosses 720° (the identity) with the axis turning: the curve passes near the
    # identity, not through it, so the forward lift comes out at (≈740°, −axis). The span switches to
    # the backward lift there: it ends at the key as keyed, and the one jump is near the identity.
    key_v = np.array([[800 * DEG, 1.0, 0.2, 0.4], [700 * DEG, 0.5, -0.5, 0.7]])
    t = np.linspace(0.0, 10.0, 41)
    q = qc.Curve.from_axis_angle([0.0, 10.0], key_v, "SLERP").sample(t)
    fwd = qc.quats_to_channels(q, "AXIS_ANGLE", key_v[0])
    span = qc.axis_angle_span(q, key_v[0], key_v[1])
    assert fwd[-1, 1:] @ key_v[1, 1:] < 0  # the other representation (≈740°, −axis)
    np.testing.assert_allclose(span[-1, 0], key_v[1, 0], atol=1e-9)
    assert span[-1, 1:] @ key_v[1, 1:] > 0
    np.testing.assert_allclose(qc.channels_to_quats(span, "AXIS_ANGLE") * np.sign(
        np.sum(qc.channels_to_quats(span, "AXIS_ANGLE") * q, axis=1))[:, None], q, atol=1e-12)
    jumps = np.flatnonzero(np.abs(np.diff(span[:, 0])) > 10 * DEG)
    assert len(jumps) <= 1
    for j in jumps:
        assert min(abs(np.sin(span[j, 0] / 2)), abs(np.sin(span[j + 1, 0] / 2))) < 0.2


@pytest.mark.parametrize("method", ["SLERP", "SQUAD", "TCB", "SPLINE_C2"])
def test_refit_reuses_unchanged_segments(method):
    """fit_through_keys(previous=...): after one key moved, only the key segments it shapes are fitted
    again (KeyFit.refitted); keys and handles elsewhere are the previous fit's, and prove_playback of
    the whole result against the new curve, an independent proof over every sample, is within the
    tolerance."""
    rng = np.random.default_rng(5)
    kf = np.arange(1.0, 400.0, 10.0)
    q = np.cumsum(rng.normal(scale=0.15, size=(len(kf), 4)), axis=0) + [1, 0, 0, 0]
    q = (q / np.linalg.norm(q, axis=1, keepdims=True)).astype(np.float32).astype(float)
    tol = 0.05 * DEG

    def fit(values, previous=None):
        curve = qc.Curve(kf, values, method=method)
        values = values * np.where(np.sum(curve.sample(kf) * values, axis=1) < 0, -1.0, 1.0)[:, None]
        return curve, qc.fit_through_keys(curve, kf, values, "QUATERNION", subframes=4, tolerance=tol,
                                          previous=previous)

    _, first = fit(q)
    assert first.refitted == len(kf) - 1
    assert len(first.segment_bounds) == len(kf) - 1
    assert first.proof.bound == pytest.approx(first.segment_bounds.max())
    moved = q.copy()
    moved[20, 1] += 0.03
    moved[20] = (moved[20] / np.linalg.norm(moved[20])).astype(np.float32)
    curve, refit = fit(moved, previous=first)
    assert 2 <= refit.refitted <= (len(kf) - 1 if method == "SPLINE_C2" else 4)
    proof = qc.prove_playback(curve, list(refit.keys.channels), "BEZIER", "QUATERNION", refit.times, tol,
                              min_step=1 / 65536)
    assert proof.proven and refit.proof.proven
    assert proof.bound <= tol
    if method != "SPLINE_C2":
        far = kf[:17]  # segments 0..15 end before key 18, which a SQUAD or TCB change at key 20 leaves alone
        for new, old in zip(refit.keys.channels, first.keys.channels):
            a, b = np.isin(new.frames, far), np.isin(old.frames, far)
            np.testing.assert_array_equal(new.values[a], old.values[b])
            np.testing.assert_array_equal(new.handle_right[a], old.handle_right[b])
            np.testing.assert_array_equal(new.handle_left[a], old.handle_left[b])
    with pytest.raises(TypeError):
        qc.fit_through_keys(curve, kf, moved, "QUATERNION", subframes=4, tolerance=tol, previous="first")


@pytest.mark.parametrize("mode", ["QUATERNION", "XYZ", "AXIS_ANGLE"])
def test_fit_channels_is_the_curve_the_signs_and_fit_through_keys(mode):
    """fit_channels(keys): Curve.from_channels, quaternion keys in the sign the curve reaches them with,
    then fit_through_keys — the same keys, handles, samples and proof bit for bit, with and without a
    previous fit; a bad key or option is refused as Curve.from_channels refuses it."""
    rng = np.random.default_rng(11)
    kf = np.arange(1.0, 200.0, 10.0)
    if mode == "QUATERNION":
        v = np.cumsum(rng.normal(scale=0.15, size=(len(kf), 4)), axis=0) + [1, 0, 0, 0]
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        v[::3] *= -1  # stored with either sign
    elif mode == "XYZ":
        v = np.cumsum(rng.normal(scale=0.3, size=(len(kf), 3)), axis=0)
    else:
        v = np.column_stack([np.cumsum(rng.normal(scale=0.3, size=len(kf))) + 1.0, rng.normal(size=(len(kf), 3))])
    tol = 0.05 * DEG

    def by_hand(values, previous=None):
        curve = qc.Curve.from_channels(kf, values, mode, "SQUAD")
        if mode == "QUATERNION":
            values = values * np.where(np.sum(curve.sample(kf) * values, axis=1) < 0, -1.0, 1.0)[:, None]
        return values, qc.fit_through_keys(curve, kf, values, mode, subframes=4, tolerance=tol, previous=previous)

    def same(a, b):
        np.testing.assert_array_equal(a.times, b.times)
        assert a.proof.bound == b.proof.bound and a.refitted == b.refitted
        for x, y in zip(a.keys.channels, b.keys.channels):
            for name in ("indices", "frames", "values", "handle_left", "handle_right"):
                np.testing.assert_array_equal(getattr(x, name), getattr(y, name))

    signed, expected = by_hand(v)
    first = qc.fit_channels(kf, v, mode, "SQUAD", subframes=4, tolerance=tol)
    same(first, expected)
    np.testing.assert_array_equal(first.key_values, signed)
    assert first.curve.method == "SQUAD" and len(first.curve.times) == len(kf)
    moved = v.copy()
    moved[8, 1] += 0.05
    _, again = by_hand(moved, previous=expected)
    refit = qc.fit_channels(kf, moved, mode, "SQUAD", subframes=4, tolerance=tol, previous=first)
    same(refit, again)
    assert 0 < refit.refitted < len(kf) - 1
    with pytest.raises(ValueError, match="tension"):
        qc.fit_channels(kf, v, mode, "SQUAD", subframes=4, tolerance=tol, tension=0.5)
    if mode == "QUATERNION":
        zero = v.copy()
        zero[4] = 0.0
        with pytest.raises(ValueError, match="zero"):
            qc.fit_channels(kf, zero, mode, "SQUAD", subframes=4, tolerance=tol)


@pytest.mark.parametrize("threads", [0, 1, 2])
def test_fit_queue_gives_fit_channels_in_push_order(threads):
    """FitQueue: each job pushed is fit_channels of its arguments bit for bit, taken in push order
    (pushed while the workers run), with a previous fit the caller no longer holds; a job's error
    comes with it alone; bad arguments are refused at push, a push after close() too; a queue dropped
    with jobs running returns."""
    rng = np.random.default_rng(5)
    kf = np.arange(1.0, 120.0, 10.0)
    tol = 0.05 * DEG
    values = []
    for _ in range(6):
        v = np.cumsum(rng.normal(scale=0.15, size=(len(kf), 4)), axis=0) + [1, 0, 0, 0]
        values.append(v / np.linalg.norm(v, axis=1, keepdims=True))
    firsts = [qc.fit_channels(kf, v, "QUATERNION", "SQUAD", subframes=4, tolerance=tol) for v in values]
    moved = [v.copy() for v in values]
    for m in moved:
        m[5, 2] += 0.04
    moved[3][7] = 0.0  # a zero quaternion: this job's error alone
    queue = qc.FitQueue(threads=threads, window=2)
    for i, m in enumerate(moved):
        queue.push(kf, m, "QUATERNION", "SQUAD", subframes=4, tolerance=tol, previous=qc.fit_channels(
            kf, values[i], "QUATERNION", "SQUAD", subframes=4, tolerance=tol))  # held by the queue alone
    with pytest.raises(ValueError, match="key_values"):
        queue.push(kf, np.ones((len(kf), 3)), "QUATERNION", "SQUAD", subframes=4, tolerance=tol)
    with pytest.raises(ValueError, match="method"):
        queue.push(kf, moved[0], "QUATERNION", "CUBIC", subframes=4, tolerance=tol)
    with pytest.raises(TypeError, match="previous: expected a quatcurve.KeyFit or None, got str"):
        queue.push(kf, moved[0], "QUATERNION", "SQUAD", subframes=4, tolerance=tol, previous="first")
    assert len(queue) == 6 and queue.remaining == 6
    queue.close()
    with pytest.raises(ValueError, match="closed"):
        queue.push(kf, moved[0], "QUATERNION", "SQUAD", subframes=4, tolerance=tol)
    for i, m in enumerate(moved):
        if i == 3:
            with pytest.raises(ValueError, match="zero"):
                next(queue)
            continue
        got = next(queue)
        want = qc.fit_channels(kf, m, "QUATERNION", "SQUAD", subframes=4, tolerance=tol, previous=firsts[i])
        assert 0 < got.refitted < len(kf) - 1 and got.refitted == want.refitted
        np.testing.assert_array_equal(got.times, want.times)
        assert got.proof.bound == want.proof.bound
        for x, y in zip(got.keys.channels, want.keys.channels):
            for name in ("indices", "frames", "values", "handle_left", "handle_right"):
                np.testing.assert_array_equal(getattr(x, name), getattr(y, name))
    assert queue.remaining == 0
    assert list(queue) == []
    dropped = qc.FitQueue(threads=threads)
    for v in values:
        dropped.push(kf, v, "QUATERNION", "SQUAD", subframes=4, tolerance=tol)
    del dropped

