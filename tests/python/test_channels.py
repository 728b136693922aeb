"""quatcurve channels API: quaternions <-> channel values of Blender's rotation modes, continuous
along a sequence, Blender's Euler branch choice, and the sampling policies."""

import math

import numpy as np
import pytest

import quatcurve as qc

ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")
MODES = ("QUATERNION",) + ORDERS + ("AXIS_ANGLE",)


def random_path(n=200, seed=3):
    """A wandering orientation path with sign flips between neighbours."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(0.0, 0.15, (n, 3))
    q = [np.array([1.0, 0, 0, 0])]
    for s in steps[1:]:
        angle = np.linalg.norm(s)
        d = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * s / angle])
        q.append(qc.quat_multiply(d, q[-1]))
    q = np.array(q)
    return q * np.where(rng.random(n) < 0.3, -1.0, 1.0)[:, None]


def angles(a, b):
    return np.asarray(qc.angle_between(a, b))


@pytest.mark.parametrize("mode", MODES)
def test_round_trip_and_continuity(mode):
    q = random_path()
    values = qc.quats_to_channels(q, mode)
    assert values.shape == (len(q), 3 if mode in ORDERS else 4)
    assert angles(qc.channels_to_quats(values, mode), q).max() < 1e-9
    jumps = np.abs(np.diff(values, axis=0)).max()
    assert jumps < 2.0, "a flip or 2 pi jump in %s: %g" % (mode, jumps)


def test_quaternions_are_hemisphere_continuous_from_the_reference():
    q = random_path()
    out = qc.quats_to_channels(q, "QUATERNION", reference=-q[0])
    assert np.allclose(out[0], -q[0])
    assert (np.einsum("ij,ij->i", out[1:], out[:-1]) >= 0).all()


def test_axis_angle_keeps_axis_side_and_unwraps_the_angle():
    # A spin about z through 3 turns: the angle keeps growing, the axis stays (0, 0, 1).
    t = np.linspace(0, 6 * math.pi, 121)
    q = np.column_stack([np.cos(t / 2), 0 * t, 0 * t, np.sin(t / 2)])
    out = qc.quats_to_channels(q, "AXIS_ANGLE")
    np.testing.assert_allclose(out[:, 0], t, atol=1e-9)
    np.testing.assert_allclose(out[:, 1:], np.tile([0, 0, 1.0], (len(t), 1)), atol=1e-9)
    ref = qc.quats_to_channels(q, "AXIS_ANGLE", reference=[-2 * math.pi, 0, 0, -1])
    assert ref[0, 3] == pytest.approx(-1.0) and (np.diff(ref[:, 0]) < 0).all()


def test_euler_follows_a_per_sample_reference():
    # Keyed angles beyond a turn are kept (the reference path's turn count).
    path = np.column_stack([np.linspace(0, 4 * math.pi, 50), np.zeros(50), np.zeros(50)])
    q = qc.euler_to_quat(path, "XYZ")
    np.testing.assert_allclose(qc.quats_to_channels(q, "XYZ", reference=path), path, atol=1e-9)


def test_euler_starting_at_gimbal_lock_is_continuous():
    # The fixed-angle example: (0, 90, 0) -> (90, 45, 90) slerped; the locked first sample takes the
    # member of its family next to its neighbour.
    a, b = qc.euler_to_quat(np.radians([[0, 90, 0], [90, 45, 90]]), "XYZ")
    t = np.linspace(0, 1, 41)[:, None]
    half = math.acos(float(np.dot(a, b)))
    q = (np.sin((1 - t) * half) * a + np.sin(t * half) * b) / math.sin(half)
    out = qc.quats_to_channels(q, "XYZ")
    assert np.abs(np.diff(out, axis=0)).max() < 0.1


def blender_to_euler_reference(q, order, compat=None):
    """Blender's mat3_normalized_to_eulo2 + compatible_eul (3.5+) in numpy, as a plain reference."""
    e1 = qc.quat_to_euler(q, order)
    i, j, k = "XYZ".index(order[0]), "XYZ".index(order[1]), "XYZ".index(order[2])
    e2 = e1.copy()
    e2[i] = math.remainder(e1[i] + math.pi, 2 * math.pi)
    e2[j] = math.remainder(math.pi - e1[j], 2 * math.pi)
    e2[k] = math.remainder(e1[k] + math.pi, 2 * math.pi)
    if compat is None:
        return e2 if np.abs(e1).sum() > np.abs(e2).sum() else e1

    def compatible(e):
        e = e.copy()
        d = e - compat
        for n in range(3):
            if d[n] > math.pi:
                e[n] -= math.floor(d[n] / (2 * math.pi) + 0.5) * 2 * math.pi
            elif d[n] < -math.pi:
                e[n] += math.floor(-d[n] / (2 * math.pi) + 0.5) * 2 * math.pi
        return e
    e1, e2 = compatible(e1), compatible(e2)
    return e2 if np.abs(e1 - compat).sum() > np.abs(e2 - compat).sum() else e1


@pytest.mark.parametrize("order", ORDERS)
def test_blender_euler_branch(order):
    rng = np.random.default_rng(11)
    q = rng.normal(size=(300, 4))
    compat = rng.uniform(-7, 7, (300, 3))
    plain = qc.quat_to_euler_blender(q, order)
    with_compat = qc.quat_to_euler_blender(q, order, compat)
    for s in range(len(q)):
        np.testing.assert_allclose(plain[s], blender_to_euler_reference(q[s], order), atol=1e-12)
        np.testing.assert_allclose(with_compat[s], blender_to_euler_reference(q[s], order, compat[s]), atol=1e-12)
    assert angles(qc.euler_to_quat(plain, order), q).max() < 1e-9
    assert angles(qc.euler_to_quat(with_compat, order), q).max() < 1e-9


def test_blender_picks_the_smaller_solution_where_quat_to_euler_does_not():
    q = qc.euler_to_quat(np.radians([170.0, 10.0, 170.0]), "XYZ")
    np.testing.assert_allclose(np.degrees(qc.quat_to_euler_blender(q, "XYZ")), [-10, 170, -10], atol=1e-9)
    np.testing.assert_allclose(np.degrees(qc.quat_to_euler(q, "XYZ")), [170, 10, 170], atol=1e-9)


def test_blender_branch_along_a_sequence():
    q = random_path(seed=5)
    out = qc.quats_to_channels(q, "ZXY", euler="blender")
    np.testing.assert_allclose(out[0], qc.quat_to_euler_blender(q[0], "ZXY"))
    for s in range(1, len(q)):
        np.testing.assert_allclose(out[s], qc.quat_to_euler_blender(q[s], "ZXY", out[s - 1]))


def test_bad_input_names_the_row():
    with pytest.raises(ValueError, match=r"quats\[1\]: zero-length"):
        qc.quats_to_channels([[1, 0, 0, 0], [0, 0, 0, 0]], "XYZ")
    with pytest.raises(ValueError, match=r"values\[1\] axis: zero-length"):
        qc.channels_to_quats([[1, 0, 0, 1], [1, 0, 0, 0]], "AXIS_ANGLE")
    with pytest.raises(ValueError, match="unknown rotation mode 'xyz'"):
        qc.channels_to_quats([[0, 0, 0]], "xyz")
    with pytest.raises(ValueError, match="reference"):
        qc.quats_to_channels([[1, 0, 0, 0]] * 3, "QUATERNION", reference=np.zeros((3, 4)))


def test_sampling_policies():
    np.testing.assert_array_equal(qc.step_frames(1, 10, 4), [1, 5, 9, 10])
    np.testing.assert_array_equal(qc.step_frames(1, 9, 4), [1, 5, 9])
    np.testing.assert_allclose(qc.sample_frames([1, 2.5, 3], 2), [1, 1.5, 2, 2.5, 3])
    np.testing.assert_allclose(qc.sample_frames([1, 1.00005, 2], 1), [1, 1.00005, 2])
    np.testing.assert_allclose(qc.whole_frame_samples([0.5, 2.25, 3]), [0.5, 1, 2, 2.25, 3])
    left, right = qc.segment_handles([0, 3, 9], [0, 3, 0])
    np.testing.assert_allclose(left, [[-1, -1], [2, 2], [7, 1]])
    np.testing.assert_allclose(right, [[1, 1], [5, 2], [11, -1]])
    left, right = qc.segment_handles([4], [2])
    np.testing.assert_allclose(left, [[3, 2]])
    np.testing.assert_allclose(right, [[5, 2]])
    with pytest.raises(ValueError, match=r"key_frames\[1\]: not increasing"):
        qc.sample_frames([2, 1], 1)


@pytest.mark.parametrize("mode", MODES)
def test_sample_keys_are_the_sampled_channels_as_blender_keys(mode):
    """Curve.sample_keys: the bake's dense keys in one call — per channel (frame, value) float32 rows
    of quats_to_channels(sample(frames), mode, reference). Quaternion keys stream through blocks of
    256 samples: 801 frames cross three block ends, and the reference flips every sample, so each
    block must carry the side of the sample before it."""
    rng = np.random.default_rng(5)
    key_times = np.arange(0.0, 60.0, 10.0)
    keys = rng.normal(size=(len(key_times), 4))
    keys[1::2] *= -1  # neighbours in opposite hemispheres
    curve = qc.Curve(key_times, keys / np.linalg.norm(keys, axis=1, keepdims=True), method="SQUAD")
    frames = np.arange(0.0, 50.0 + 1e-9, 1.0 / 16.0)
    reference = qc.quats_to_channels(-curve.sample(frames[:1]), mode)[0]
    expected = qc.quats_to_channels(curve.sample(frames), mode, reference)
    got = curve.sample_keys(frames, mode, reference)
    assert got.dtype == np.float32 and got.shape == (expected.shape[1], len(frames), 2)
    for c in range(expected.shape[1]):
        assert np.array_equal(got[c, :, 0], frames.astype(np.float32))
        assert np.array_equal(got[c, :, 1], expected[:, c].astype(np.float32))
    plain = curve.sample_keys(frames, mode)
    assert np.array_equal(plain[:, :, 1].T, qc.quats_to_channels(curve.sample(frames), mode).astype(np.float32))


def test_sample_keys_refuses_bad_arguments():
    curve = qc.Curve([0.0, 10.0], [[1, 0, 0, 0], [0, 1, 0, 0]])
    with pytest.raises(ValueError, match="rotation mode|mode"):
        curve.sample_keys([0.0, 1.0], "XYZW")
    with pytest.raises(ValueError, match="frames"):
        curve.sample_keys([[0.0, 1.0]], "QUATERNION")
    with pytest.raises(ValueError, match="reference"):
        curve.sample_keys([0.0, 1.0], "QUATERNION", [1.0, 0.0, 0.0])


def test_sample_keys_follow_a_per_frame_euler_reference():
    """The bake's same-order Euler output: one reference row per frame (the keyed angles, linear between
    keys) keeps the keyed turn counts, exactly as quats_to_channels does with it."""
    key_times = np.array([0.0, 10.0, 20.0])
    key_angles = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 3.5], [0.0, 0.0, 7.0]])  # two turns past π
    curve = qc.Curve.from_euler(key_times, key_angles, order="XYZ", method="SLERP")
    frames = np.arange(0.0, 20.5, 0.5)
    reference = np.column_stack([np.interp(frames, key_times, key_angles[:, i]) for i in range(3)])
    expected = qc.quats_to_channels(curve.sample(frames), "XYZ", reference)
    got = curve.sample_keys(frames, "XYZ", reference)
    assert np.array_equal(got[:, :, 1].T, expected.astype(np.float32))
    assert abs(got[2, -1, 1] - 7.0) < 1e-5  # the Z angle ends at 7 rad, not wrapped to 7 - 2π
