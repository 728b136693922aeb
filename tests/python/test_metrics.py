"""Path metrics of the `quatcurve` module against scipy.spatial.transform (the oracle) and closed forms."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

import quatcurve

RNG = np.random.default_rng(20240505)


def wxyz(rot):
    """scipy's (x, y, z, w) → (w, x, y, z)."""
    return np.roll(rot.as_quat(), 1, axis=-1)


def slerp_path(times, key_times, key_rots):
    return wxyz(Slerp(key_times, key_rots)(times))


def euler_linear_path(times, key_times, key_angles, order="xyz"):
    """Each Euler angle linear between keys (Blender's Euler mode with LINEAR keys)."""
    angles = np.stack([np.interp(times, key_times, key_angles[:, i]) for i in range(3)], axis=1)
    return wxyz(Rotation.from_euler(order, angles)), angles


def test_deviation_matches_scipy_and_is_sign_invariant():
    a = Rotation.random(500, random_state=1)
    b = Rotation.random(500, random_state=2)
    expected = (a.inv() * b).magnitude()
    qa, qb = wxyz(a), wxyz(b)
    signs = np.where(RNG.random(500) < 0.5, -1.0, 1.0)[:, None]
    got = quatcurve.angular_deviation(qa * signs, qb * 3.0)  # non-unit: normalized
    np.testing.assert_allclose(got, expected, atol=1e-12)


def test_fixed_angle_example_euler_mode_lies_17_13_degrees_from_slerp():
    # Euler 'XYZ' keys (0, 90, 0) → (90, 45, 90): linear Euler angles vs SLERP at the middle frame.
    key_times = np.array([1.0, 21.0])
    key_angles = np.radians([[0, 90, 0], [90, 45, 90]])
    times = np.arange(1.0, 22.0)
    euler_q, _ = euler_linear_path(times, key_times, key_angles)
    slerp_q = slerp_path(times, key_times, Rotation.from_euler("xyz", key_angles))
    m = quatcurve.path_metrics(times, euler_q, key_times, slerp_q)
    assert np.degrees(m["deviation"][10]) == pytest.approx(17.13, abs=0.05)
    assert m["max_deviation"] == pytest.approx(m["deviation"].max())
    assert m["max_deviation_time"] == times[np.argmax(m["deviation"])]
    assert m["mean_deviation"] == pytest.approx(m["deviation"].mean())


def test_slerp_has_constant_speed_per_segment():
    key_times = np.array([0.0, 7.0, 12.0, 30.0])
    keys = Rotation.random(4, random_state=7)
    times = np.linspace(0.0, 30.0, 301)
    q = slerp_path(times, key_times, keys)
    ratios = quatcurve.segment_speed_ratios(times, q, key_times)
    np.testing.assert_allclose(ratios, 1.0, atol=1e-6)
    speeds = quatcurve.interval_speeds(times, q)
    seg = np.searchsorted(key_times, 0.5 * (times[1:] + times[:-1])) - 1
    angles = (keys[:-1].inv() * keys[1:]).magnitude() / np.diff(key_times)
    np.testing.assert_allclose(speeds, angles[seg], rtol=1e-9)


@pytest.mark.parametrize("degrees", [20.0, 90.0, 150.0, 178.0])
def test_nlerp_speed_ratio_is_closed_form(degrees):
    theta = np.radians(degrees)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    q1 = wxyz(Rotation.from_rotvec(theta * np.array([0.6, 0.0, 0.8])))
    t = np.linspace(0.0, 1.0, 241)
    q = (1 - t)[:, None] * q0 + t[:, None] * q1  # not normalized: the metrics normalize
    ratio = quatcurve.segment_speed_ratios(t * 24, q, [0.0, 24.0])
    assert ratio[0] == pytest.approx(2 / (1 + np.cos(theta / 2)), abs=1e-4)


def test_speed_ratio_from_velocity():
    t = np.arange(6.0)
    w = np.array([[0, 0, 1], [0, 0, 1], [0, 2, 0], [0, 0, 1], [0, 0, 3], [1, 0, 0]], float)
    r = quatcurve.segment_speed_ratios_from_velocity(t, w, [0.0, 3.0, 5.0])
    assert r[0] == 2.0 and r[1] == 1.0


def test_path_length_counts_spins_beyond_key_geodesics():
    # Euler Z from 0 to 720°: the key orientations coincide, the path turns twice.
    key_times = np.array([0.0, 40.0])
    times = np.arange(0.0, 41.0)
    q, _ = euler_linear_path(times, key_times, np.radians([[0, 0, 0], [0, 0, 720]]))
    assert quatcurve.path_length(q) == pytest.approx(4 * np.pi, rel=1e-9)
    assert quatcurve.path_length(q[[0, -1]]) == pytest.approx(0.0, abs=1e-7)
    m = quatcurve.path_metrics(times, q, key_times, q)
    assert m["path_length"] == pytest.approx(4 * np.pi)
    assert m["path_length_ratio"] == np.inf


def test_key_jumps_velocity_and_acceleration():
    # About x at 0.3 rad/frame to the key, then about world y at 0.4: velocity jump 0.5.
    t = np.linspace(0.0, 20.0, 41)
    k = 10.0
    before = Rotation.from_rotvec(np.outer(0.3 * np.minimum(t, k), [1, 0, 0]))
    after = Rotation.from_rotvec(np.outer(0.4 * np.maximum(t - k, 0), [0, 1, 0]))
    q = wxyz(after * before)
    vel, acc = quatcurve.key_jumps(t, q, [0.0, k, 20.0])
    assert np.isnan(vel[0]) and np.isnan(vel[2])
    assert vel[1] == pytest.approx(0.5, abs=1e-9)
    assert acc[1] == pytest.approx(0.0, abs=1e-7)


def test_gimbal_distances_against_scipy_middle_angle():
    rots = Rotation.random(300, random_state=3)
    for order, middle in (("XYZ", 1), ("ZXY", 0), ("YZX", 2)):
        angles = rots.as_euler(order.lower())  # scipy: angles in the order's sequence
        # Blender's triple is (about X, about Y, about Z) whatever the order.
        triple = np.empty_like(angles)
        for slot, axis in enumerate(order):
            triple[:, "XYZ".index(axis)] = angles[:, slot]
        expected = np.pi / 2 - np.abs(triple[:, middle])
        np.testing.assert_allclose(quatcurve.gimbal_distances(triple, order), expected, atol=1e-9)
        np.testing.assert_allclose(quatcurve.gimbal_distances_from_quats(wxyz(rots), order), expected,
                                   atol=1e-6)
    distance, frames = quatcurve.closest_gimbal_approach([1.0, 2.0, 3.0, 4.0], [0.5, 0.1, 0.3, 0.1])
    assert distance == pytest.approx(0.1)
    np.testing.assert_array_equal(frames, [2.0, 4.0])


def test_path_metrics_keys():
    t = np.linspace(0.0, 10.0, 11)
    q = slerp_path(t, [0.0, 10.0], Rotation.random(2, random_state=9))
    m = quatcurve.path_metrics(t, q, [0.0, 10.0], q)
    assert set(m) == {
        "deviation", "max_deviation", "max_deviation_time", "mean_deviation", "speeds",
        "segment_speed_ratios", "speed_ratio", "path_length", "key_path_length", "path_length_ratio",
        "velocity_jumps", "acceleration_jumps", "max_velocity_jump", "max_velocity_jump_time",
        "max_acceleration_jump", "max_acceleration_jump_time"}
    assert m["deviation"].shape == (11,) and m["speeds"].shape == (10,)
    assert m["speed_ratio"] == pytest.approx(1.0, abs=1e-9)
    assert m["path_length_ratio"] == pytest.approx(1.0)


@pytest.mark.parametrize("call, message", [
    (lambda: quatcurve.angular_deviation(np.zeros((3, 4)), np.ones((3, 4))), "quats[0]"),
    (lambda: quatcurve.angular_deviation(np.ones((3, 4)), np.ones((2, 4))), "reference"),
    (lambda: quatcurve.angular_deviation(np.ones((3, 3)), np.ones((3, 4))), "quats: expected shape"),
    (lambda: quatcurve.interval_speeds([0.0, 2.0, 1.0], np.ones((3, 4))), "times[2]: not increasing"),
    (lambda: quatcurve.interval_speeds([[0.0, 1.0]], np.ones((2, 4))), "times: expected shape (N,)"),
    (lambda: quatcurve.interval_speeds([0.0, 5e-324], [[1, 0, 0, 0], [0, 1, 0, 0]]),
     "times[1]: speed over the interval from times[0] overflows"),
    (lambda: quatcurve.segment_speed_ratios([0.0, 1.0, 2.0], np.ones((3, 4)), [0.0, 1.5]),
     "key_times[1]: not a sample time"),
    (lambda: quatcurve.key_jumps([0.0, 1.0, 2.0], [[1, 0, 0, 0], [1, 0, 0, 0], [np.nan, 0, 0, 0]],
                                 [0.0, 2.0]), "quats[2]"),
    (lambda: quatcurve.path_length("abc"), "quats"),
    (lambda: quatcurve.gimbal_distances(np.zeros((2, 3)), "XYQ"), "XYQ"),
    (lambda: quatcurve.gimbal_distances([[0.0, np.inf, 0.0]], "XYZ"), "angles[0]"),
    (lambda: quatcurve.closest_gimbal_approach([0.0], [0.1], tolerance=-1.0), "tolerance"),
    (lambda: quatcurve.path_metrics([0.0, 1.0], np.ones((2, 4)), [0.0, 1.0], np.ones((2, 4)),
                                    key_quats=np.ones((3, 4))), "key_quats"),
])
def test_bad_input_raises_value_error_naming_the_element(call, message):
    with pytest.raises(ValueError) as err:
        call()
    assert message in str(err.value)
