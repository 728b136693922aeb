"""quatcurve.Curve from Python, with scipy.spatial.transform as the oracle.

Quaternions are (w, x, y, z); Blender's Euler 'XYZ' is scipy's extrinsic 'xyz' with angles (ax, ay, az).
"""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation as R
from scipy.spatial.transform import RotationSpline, Slerp

import quatcurve as qc

ALL = ("EULER", "QUAT_COMPONENTS", "NLERP", "SLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2")
QUAT_METHODS = ALL[1:]
SMOOTH = ("SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2")


def rot(q):
    return R.from_quat(np.asarray(q, float).reshape(-1, 4), scalar_first=True)


def angle(a, b):
    """Geodesic angle between rotations given as (..., 4) quaternions."""
    return (rot(a) * rot(b).inv()).magnitude()


def keys(n, seed, max_angle=2.0):
    """Non-uniform times and random keys whose neighbours differ by at most max_angle; random stored signs."""
    rng = np.random.default_rng(seed)
    t = 1.5 + np.concatenate([[0.0], np.cumsum(rng.uniform(0.5, 3.0, n - 1))])
    steps = R.from_rotvec(rng.normal(size=(n, 3)) * (max_angle / 3.0))
    r = [R.random(random_state=seed)]
    for i in range(1, n):
        r.append(r[-1] * steps[i])
    q = R.concatenate(r).as_quat(scalar_first=True)
    q *= rng.choice([-1.0, 1.0], size=(n, 1))
    angles = np.cumsum(rng.uniform(-1.2, 1.2, size=(n, 3)), axis=0)
    return t, q, angles


def make(method, t, q, a, **options):
    if method == "EULER":
        return qc.Curve.from_euler(t, a, "XYZ", method, **options)
    return qc.Curve(t, q, method, **options)


def key_rotations(method, q, a):
    return R.from_euler("xyz", a).as_quat(scalar_first=True) if method == "EULER" else q


def fd_velocity(c, times, e=1e-6):
    q0 = rot(c.sample(times - e))
    q1 = rot(c.sample(times + e))
    return (q1 * q0.inv()).as_rotvec() / (2 * e)


# ---- API ------------------------------------------------------------------------------------------
def test_methods_constant_and_properties():
    assert qc.METHODS == ALL
    t, q, a = keys(5, 1)
    c = qc.Curve(t, q, "TCB", tension=0.25, bias=[0.0, 0.1, -0.1, 0.2, 0.0])
    assert c.method == "TCB"
    np.testing.assert_array_equal(c.times, t)
    np.testing.assert_allclose(c.quats, q / np.linalg.norm(q, axis=1, keepdims=True), atol=1e-15)
    assert c.options["tension"] == 0.25 and c.options["continuity"] == 0.0
    np.testing.assert_array_equal(c.options["bias"], [0.0, 0.1, -0.1, 0.2, 0.0])
    assert set(c.options) == {"clamped", "tension", "continuity", "bias", "ease_in", "ease_out", "turns", "cyclic"}
    assert c.options["clamped"] is True
    ease = {"ease_in": 0.0, "ease_out": 0.0, "turns": 0.0, "cyclic": False}
    assert qc.Curve(t, q).options == {"shortest_path": True, **ease}
    assert qc.Curve(t, q, "SLERP", shortest_path=False).options == {"shortest_path": False, **ease}
    assert qc.Curve(t, q, "SQUAD").options == {"clamped": True, **ease}
    assert qc.Curve(t, q, "CATMULL_ROM", clamped=False).options == {"clamped": False, **ease}
    assert qc.Curve(t, q, "SPLINE_C2", ease_in=0.5).options == {"ease_in": 0.5, "ease_out": 0.0, "turns": 0.0,
                                                                         "cyclic": False}
    assert "TCB" in repr(c) and "keys=5" in repr(c)
    assert "euler_order='ZYX'" in repr(qc.Curve.from_euler(t, a, "ZYX"))
    with pytest.raises(ValueError):
        c.times[0] = 7.0  # read-only
    with pytest.raises(AttributeError):
        c.method = "SLERP"


def test_sample_shapes():
    t, q, a = keys(4, 2)
    c = qc.Curve(t, q, "SQUAD")
    assert c.sample(t[1]).shape == (4,)
    assert c.sample(t).shape == (4, 4)
    assert c.sample(np.zeros((2, 3))).shape == (2, 3, 4)
    assert c.angular_velocity(t[1]).shape == (3,)
    assert c.angular_velocity(np.zeros((2, 3))).shape == (2, 3, 3)
    assert c.sample([]).shape == (0, 4)
    np.testing.assert_allclose(c.sample([t[0] - 5, t[-1] + 5]), c.sample([t[0], t[-1]]), atol=1e-15)
    assert not np.any(c.angular_velocity([t[0] - 5, t[-1] + 5]))


# ---- every method -----------------------------------------------------------------------------------
@pytest.mark.parametrize("method", ALL)
def test_passes_through_keys(method):
    for seed in range(3):
        t, q, a = keys(9, seed)
        c = make(method, t, q, a)
        assert np.max(angle(c.sample(t), key_rotations(method, q, a))) <= 1e-9
        e = qc.Curve.from_euler(t, a, "YZX", method)
        ref = R.from_euler("yzx", a[:, [1, 2, 0]]).as_quat(scalar_first=True)
        assert np.max(angle(e.sample(t), ref)) <= 1e-9


@pytest.mark.parametrize("method", ALL)
def test_angular_velocity_is_the_derivative_of_sample(method):
    t, q, a = keys(7, 5)
    options = dict(tension=0.2, continuity=0.3, bias=-0.4, ease_in=0.3, ease_out=[0.5, 0, 0.2, 0, 0, 0.1, 0]) \
        if method == "TCB" else {}
    c = make(method, t, q, a, **options)
    ts = np.linspace(t[0] + 0.011, t[-1] - 0.011, 400)
    ts = ts[np.min(np.abs(ts[:, None] - t[None, :]), axis=1) > 1e-4]
    w = c.angular_velocity(ts)
    np.testing.assert_allclose(w, fd_velocity(c, ts), atol=1e-6 * (1 + np.max(np.abs(w))))


@pytest.mark.parametrize("method", SMOOTH)
def test_c1_at_non_uniform_keys(method):
    t, q, a = keys(10, 7)
    c = make(method, t, q, a, **(dict(tension=0.3, bias=0.2) if method == "TCB" else {}))
    left, right = c.angular_velocity(t[1:-1] - 1e-7), c.angular_velocity(t[1:-1])
    assert np.max(np.linalg.norm(left - right, axis=1)) <= 1e-5
    s = make("SLERP", t, q, a)
    assert np.max(np.linalg.norm(s.angular_velocity(t[1:-1] - 1e-7) - s.angular_velocity(t[1:-1]), axis=1)) > 0.05


@pytest.mark.parametrize("method", SMOOTH)
def test_large_turns_between_keys_stay_continuous(method):
    """Keys up to ~170° apart with stored neighbours in opposite hemispheres (the demo's
    "Hemisphere" object): the curve neither jumps inside a segment nor breaks C1 at keys."""
    s, c = np.sin(np.radians(60)), np.cos(np.radians(60))
    q = np.array([(1, 0, 0, 0), (c, s, 0, 0), (-c, 0, -s, 0), (0.5, 0.5, 0.5, 0.5)])
    t = np.array([1.0, 21.0, 41.0, 61.0])
    for qs, ts in ((q, t), keys(12, 11, max_angle=2.9)[:2][::-1]):
        curve = qc.Curve(ts, qs, method)
        dense = np.linspace(ts[0], ts[-1], 4001)
        step = angle(curve.sample(dense[:-1]), curve.sample(dense[1:]))
        speed = np.linalg.norm(curve.angular_velocity(dense), axis=1)
        assert np.max(step) <= 1.01 * np.max(speed) * (dense[1] - dense[0]) + 1e-9
        left, right = curve.angular_velocity(ts[1:-1] - 1e-7), curve.angular_velocity(ts[1:-1])
        assert np.max(np.linalg.norm(left - right, axis=1)) <= 1e-4 * (1 + np.max(speed))


def test_slerp_from_curved_euler_paths_keeps_constant_speed():
    """A curved Euler path whose turn stays below a full turn is one constant-speed arc, on the side
    the path goes round (found by compare: a 176.9° segment used to be split on the Euler path)."""
    c = qc.Curve.from_euler([1, 8, 30, 35], np.radians([[0, 0, 0], [40, 10, -30], [80, 60, 20], [10, -20, 170]]),
                            "XYZ", "SLERP")
    rng = np.random.default_rng(3)
    d = qc.Curve.from_euler(np.arange(12.0), np.cumsum(rng.uniform(-1.5, 1.5, (12, 3)), axis=0), "ZXY", "SLERP")
    for curve in (c, d):
        for t0, t1 in zip(curve.times[:-1], curve.times[1:]):
            ts = np.linspace(t0, t1, 51)
            speed = np.linalg.norm(curve.angular_velocity(ts[:-1]), axis=1)
            assert np.ptp(speed) <= 1e-9 * (1 + speed.max())
            step = angle(curve.sample(ts[:-1]), curve.sample(ts[1:]))
            np.testing.assert_allclose(step, speed * (ts[1] - ts[0]), rtol=1e-6, atol=1e-12)


def test_spline_c2_acceleration_is_continuous():
    t, q, a = keys(10, 8, max_angle=2.5)
    e = 1e-5

    def accel_jump(c):
        al = (c.angular_velocity(t[1:-1] - e) - c.angular_velocity(t[1:-1] - 3 * e)) / (2 * e)
        ar = (c.angular_velocity(t[1:-1] + 3 * e) - c.angular_velocity(t[1:-1] + e)) / (2 * e)
        return np.max(np.linalg.norm(al - ar, axis=1))

    assert accel_jump(qc.Curve(t, q, "SPLINE_C2")) <= 2e-3
    assert accel_jump(qc.Curve(t, q, "SQUAD")) > 5e-2


def test_spline_c2_equals_scipy_rotation_spline():
    rng = np.random.default_rng(9)
    t = np.cumsum(rng.uniform(0.5, 3.0, 12))
    r = R.from_rotvec(rng.normal(size=(12, 3)) * 0.4)
    c = qc.Curve(t, r.as_quat(scalar_first=True), "SPLINE_C2")
    spline = RotationSpline(t, r)
    ts = np.linspace(t[0], t[-1], 777)
    assert np.max(angle(c.sample(ts), spline(ts).as_quat(scalar_first=True))) <= 1e-9
    # scipy's angular rate is in the body frame
    body = rot(c.sample(ts)).inv().apply(c.angular_velocity(ts))
    np.testing.assert_allclose(body, spline(ts, 1), atol=1e-8)
    # on large rotations scipy stops its fixed-point iteration early; ours is C2 where scipy is not
    big = R.random(8, random_state=3)
    tb = np.cumsum(rng.uniform(0.5, 3.0, 8))
    sb = RotationSpline(tb, big)
    cb = qc.Curve(tb, big.as_quat(scalar_first=True), "SPLINE_C2")
    ours = np.max(angle(cb.sample(tb[1:-1] + 1e-3), sb(tb[1:-1] + 1e-3).as_quat(scalar_first=True)))
    assert ours < 1e-2  # the same curve up to scipy's unconverged iteration


def test_slerp_equals_scipy_and_has_constant_speed():
    t, q, a = keys(9, 10, max_angle=3.0)
    c = qc.Curve(t, q)
    ts = np.linspace(t[0], t[-1], 1001)
    ref = Slerp(t, rot(q))(ts).as_quat(scalar_first=True)
    assert np.max(angle(c.sample(ts), ref)) <= 1e-9
    speed = np.linalg.norm(c.angular_velocity(ts), axis=1)
    seg = np.clip(np.searchsorted(t, ts, side="right") - 1, 0, len(t) - 2)
    expected = angle(q[:-1], q[1:]) / np.diff(t)
    np.testing.assert_allclose(speed, expected[seg], rtol=1e-12)


def test_squad_at_uniform_spacing_is_shoemake():
    t, q, a = keys(8, 11, max_angle=1.5)
    t = np.arange(8) * 2.0
    qs = q.copy()
    for i in range(1, len(qs)):
        if np.dot(qs[i - 1], qs[i]) < 0:
            qs[i] = -qs[i]
    rs = rot(qs)

    def log(r):  # quaternion log (vector, half angle) of rotations as rotation vectors / 2
        return r.as_rotvec() / 2

    s = [rs[0]]
    for i in range(1, len(qs) - 1):
        s.append(rs[i] * R.from_rotvec(-2 * (log(rs[i].inv() * rs[i + 1]) + log(rs[i].inv() * rs[i - 1])) / 4))
    s.append(rs[-1])

    def slerp(x, y, h):
        return x * R.from_rotvec(h * (x.inv() * y).as_rotvec())

    c = qc.Curve(t, q, "SQUAD")
    for i in range(len(qs) - 1):
        for h in (0.1, 0.5, 0.77):
            ref = slerp(slerp(rs[i], rs[i + 1], h), slerp(s[i], s[i + 1], h), 2 * h * (1 - h))
            assert angle(c.sample(t[i] + 2 * h), ref.as_quat(scalar_first=True))[0] <= 1e-9


def test_euler_is_each_angle_linear():
    t, q, a = keys(6, 12)
    a = a * 3.0
    for order in ("XYZ", "ZYX"):
        c = qc.Curve.from_euler(t, a, order, "EULER")
        ts = np.linspace(t[0], t[-1], 301)
        lin = np.stack([np.interp(ts, t, a[:, k]) for k in range(3)], axis=1)
        seq = order.lower()
        idx = ["xyz".index(ch) for ch in seq]
        ref = R.from_euler(seq, lin[:, idx]).as_quat(scalar_first=True)
        assert np.max(angle(c.sample(ts), ref)) <= 1e-12


def test_quat_components_is_componentwise_lerp_with_flips():
    t = np.array([0.0, 2.0, 3.0, 7.0])
    q = np.array([[1, 0, 0, 0], [-0.8, 0, 0.6, 0], [0.2, 0.9, -0.3, 0.1], [0.5, -0.5, 0.5, 0.5]])
    c = qc.Curve(t, q, "QUAT_COMPONENTS")
    ts = np.linspace(0, 7, 141)
    lin = np.stack([np.interp(ts, t, q[:, k]) for k in range(4)], axis=1)
    np.testing.assert_allclose(c.sample(ts), lin / np.linalg.norm(lin, axis=1, keepdims=True), atol=1e-15)
    # the flipped key makes Blender's lerp go the long way, unlike NLERP
    assert angle(c.sample(1.0), qc.Curve(t, q, "NLERP").sample(1.0))[0] > 1.0


def test_fixed_angle_example_slerp_midpoint():
    c = qc.Curve.from_euler([0, 10], np.radians([[0, 90, 0], [90, 45, 90]]), "XYZ", "SLERP")
    mid = R.from_quat(c.sample(5.0), scalar_first=True)
    np.testing.assert_allclose(mid.as_euler("xyz", degrees=True), [90, 67.5, 90], atol=1e-7)


@pytest.mark.parametrize("method", ("NLERP", "SLERP") + SMOOTH)
def test_antipodal_neighbouring_keys(method):
    q = R.from_rotvec([0.3, -0.2, 0.5]).as_quat(scalar_first=True)
    c = qc.Curve([0, 1, 2], [q, -q, q], method)
    assert np.max(angle(c.sample(np.linspace(0, 2, 21)), q)) <= 1e-12
    assert np.max(np.abs(c.angular_velocity(np.linspace(0, 2, 21)))) <= 1e-12
    near = -(R.from_quat(q, scalar_first=True) * R.from_rotvec([0, 0, 0.2])).as_quat(scalar_first=True)
    d = qc.Curve([0, 1], [q, near], method)
    assert angle(d.sample(1.0), near)[0] <= 1e-12
    assert angle(d.sample(0.5), q)[0] == pytest.approx(0.1, abs=1e-9)


@pytest.mark.parametrize("method", QUAT_METHODS)
def test_near_identical_keys(method):
    base = R.from_rotvec([0.1, 0.2, 0.3])
    q = (base * R.from_rotvec([[0, 0, 0], [1e-13, 0, 0], [1e-13, 1e-13, 0], [0.5, 0, 0]])).as_quat(scalar_first=True)
    c = qc.Curve([0, 1, 2, 3], q, method)
    ts = np.linspace(-0.5, 3.5, 97)
    s, w = c.sample(ts), c.angular_velocity(ts)
    assert np.all(np.isfinite(s)) and np.all(np.isfinite(w))
    np.testing.assert_allclose(np.linalg.norm(s, axis=1), 1.0, atol=1e-14)
    assert np.max(angle(c.sample([0, 1, 2, 3]), q)) <= 1e-9


@pytest.mark.parametrize("method", QUAT_METHODS)
def test_exactly_half_turn_segments(method):
    c = qc.Curve([0, 2], [[1, 0, 0, 0], [0, 0, 0, 1]], method)
    assert angle(c.sample(1.0), [1, 0, 0, 0])[0] == pytest.approx(np.pi / 2, abs=1e-9)
    e = qc.Curve.from_euler([0, 2], [[0, 0, 0], [0, 0, -np.pi]], "XYZ", method)
    assert angle(e.sample(1.0), R.from_rotvec([0, 0, -np.pi / 2]).as_quat(scalar_first=True))[0] <= 1e-9


@pytest.mark.parametrize("method", ALL)
def test_one_key_and_two_keys(method):
    q = R.from_rotvec([0.4, 0.1, -0.7]).as_quat(scalar_first=True)
    c = make(method, [3.0], [q], [[0.4, 0.1, -0.7]])
    assert np.max(angle(c.sample([-1e9, 3.0, 1e9]), c.sample(3.0))) == 0.0
    assert not np.any(c.angular_velocity([0.0, 3.0, 5.0]))
    if method in SMOOTH:  # with two keys every smooth method is SLERP
        r = R.from_rotvec([-1.0, 0.5, 1.2]).as_quat(scalar_first=True)
        ts = np.linspace(1, 4, 31)
        c2, s2 = qc.Curve([1, 4], [q, r], method), qc.Curve([1, 4], [q, r])
        assert np.max(angle(c2.sample(ts), s2.sample(ts))) <= 1e-12
        np.testing.assert_allclose(c2.angular_velocity(ts), s2.angular_velocity(ts), atol=1e-12)


@pytest.mark.parametrize("method", ALL)
def test_spins_survive(method):
    c = qc.Curve.from_euler([0, 10], [[0, 0, 0], [0, 0, 4 * np.pi]], "XYZ", method)
    ts = np.linspace(0, 10, 2001)
    r = rot(c.sample(ts))
    turned = np.sum((r[1:] * r[:-1].inv()).as_rotvec()[:, 2])
    assert turned == pytest.approx(4 * np.pi, abs=1e-6)
    # a 100°-per-key spin keeps turning forward
    k = np.arange(8)
    s = qc.Curve.from_euler(k * 5.0, np.stack([0 * k, 0 * k, np.radians(100) * k], axis=1), "XYZ", method)
    assert np.all(s.angular_velocity(np.arange(0.5, 35, 1.0))[:, 2] > 0)


def test_tcb_options():
    t, q, a = keys(6, 13)
    c = qc.Curve(t, q, "TCB", tension=[0, 0, 1, 0, 0, 0])
    assert np.linalg.norm(c.angular_velocity(t[2])) <= 1e-12
    e = qc.Curve(t, q, "TCB", ease_out=[0, 1, 0, 0, 0, 0])
    assert np.linalg.norm(e.angular_velocity(t[1])) <= 1e-12
    assert np.max(angle(e.sample(t), q)) <= 1e-9
    np.testing.assert_allclose(qc.Curve(t, q, "TCB").sample(t + 0.3), qc.Curve(t, q, "SQUAD").sample(t + 0.3),
                               atol=1e-15)


# ---- bad input ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("args, kwargs, match", [
    (([0, np.nan], [[1, 0, 0, 0]] * 2), {}, r"times\[1\]"),
    (([0, np.inf], [[1, 0, 0, 0]] * 2), {}, r"times\[1\]"),
    (([0, 1, 1], [[1, 0, 0, 0]] * 3), {}, r"times\[2\].*not increasing"),
    (([0, 2, 1], [[1, 0, 0, 0]] * 3), {}, r"times\[2\]"),
    (([], np.zeros((0, 4))), {}, "times"),
    (([[0, 1]], [[1, 0, 0, 0]] * 2), {}, "times"),
    (("ab", [[1, 0, 0, 0]] * 2), {}, "times"),
    (([0, 1], [[1, 0, 0, 0]]), {}, "quats"),
    (([0, 1], [[1, 0, 0]] * 2), {}, "quats"),
    (([0, 1], [[1, 0, 0, 0], [0, 0, 0, 0]]), {}, r"quats\[1\]"),
    (([0, 1], [[1, 0, 0, 0], [np.nan, 0, 0, 1]]), {}, r"quats\[1\]"),
    (([0, 1], [[1, 0, 0, 0]] * 2, "slerp"), {}, "method"),
    (([0, 1], [[1, 0, 0, 0]] * 2, "EULER"), {}, "from_euler"),
    (([0, 1], [[1, 0, 0, 0]] * 2), {"tension": 0.1}, "tension.*SLERP"),
    (([0, 1], [[1, 0, 0, 0]] * 2), {"stiffness": 0.1}, "stiffness"),
    (([0, 1], [[1, 0, 0, 0]] * 2, "SQUAD"), {"shortest_path": False}, "shortest_path"),
    (([0, 1], [[1, 0, 0, 0]] * 2), {"shortest_path": 0.5}, "shortest_path"),
    (([0, 1], [[1, 0, 0, 0]] * 2, "TCB"), {"tension": 1.5}, "tension"),
    (([0, 1], [[1, 0, 0, 0]] * 2, "TCB"), {"bias": [0, 0, 0]}, "bias"),
    (([0, 1], [[1, 0, 0, 0]] * 2, "TCB"), {"continuity": np.nan}, "continuity"),
    (([0, 1], [[1, 0, 0, 0]] * 2, "TCB"), {"ease_in": -0.1}, "ease_in"),
    (([0, 1], [[1, 0, 0, 0]] * 2, "TCB"), {"ease_out": [[0.1]]}, "ease_out"),
    (([0, 1], [[1, 0, 0, 0], [-1, 0, 0, 0]]), {"shortest_path": False}, "opposite"),
    # key times double precision cannot follow
    (([0, 5e-324], [[1, 0, 0, 0]] * 2), {}, r"times\[1\].*at least 1e-09 frames"),
    (([-1.7976931348623157e308, 0.0, 1.7976931348623157e308], [[1, 0, 0, 0]] * 3), {}, r"times\[1\].*at most 1e\+12"),
    (([1.0, np.nextafter(1.0, 2.0)], [[1, 0, 0, 0]] * 2), {}, r"times\[1\].*at least 1e-09 frames"),
    (([1e15, 1e15 + 1], [[1, 0, 0, 0]] * 2), {}, r"times\[1\].*resolution"),
    (([0, 1e-3, 1e4], [[1, 0, 0, 0]] * 3, "SPLINE_C2"), {}, r"times\[2\].*SPLINE_C2.*factor of 1e\+06"),
])
def test_bad_input_raises_value_error(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        qc.Curve(*args, **kwargs)


def test_bad_input_from_euler_and_sampling():
    with pytest.raises(ValueError, match="order"):
        qc.Curve.from_euler([0, 1], np.zeros((2, 3)), "XYX")
    with pytest.raises(ValueError, match=r"angles\[1\]"):
        qc.Curve.from_euler([0, 1], [[0, 0, 0], [0, np.nan, 0]])
    with pytest.raises(ValueError, match="angles"):
        qc.Curve.from_euler([0, 1], np.zeros((3, 3)))
    with pytest.raises(ValueError, match="angles"):
        qc.Curve.from_euler([0, 1], np.zeros((2, 4)))
    with pytest.raises(ValueError, match="method"):
        qc.Curve.from_euler([0, 1], np.zeros((2, 3)), "XYZ", "BEZIER")
    for method in ALL:  # a turn double precision cannot follow is refused at once, never followed
        with pytest.raises(ValueError, match=r"angles\[1\]\[2\]: segment turns 100000 rad.*10000 turns"):
            qc.Curve.from_euler([0, 1], [[0, 0, 0], [0, 0, 1e5]], method=method)
        with pytest.raises(ValueError, match=r"angles\[0\]\[1\]: 1e\+300 rad is beyond"):
            qc.Curve.from_euler([0, 1], [[0, 1e300, 0], [0, 1e300, 0]], method=method)
    c = qc.Curve([0, 1], [[1, 0, 0, 0]] * 2)
    with pytest.raises(ValueError, match=r"times\[1\]"):
        c.sample([0.5, np.nan])
    with pytest.raises(ValueError, match=r"times\[0\]"):
        c.angular_velocity([np.inf])
    with pytest.raises(ValueError, match="times"):
        c.sample("x")


def test_local_methods_accept_uneven_spacing_and_keep_long_spins():
    """The spacing-ratio limit is for the tangent methods only; a spin of 9,000 turns in one segment
    is accepted and kept (its length from the closed-form Euler speed, bounded work)."""
    keys = R.random(3, random_state=5).as_quat(scalar_first=True)
    for method in ("QUAT_COMPONENTS", "NLERP", "SLERP"):
        c = qc.Curve([0, 1e-3, 1e4], keys, method=method)
        assert np.max(angle(c.sample([0, 1e-3, 1e4]), keys)) <= 1e-9
    turn = 9000 * 2 * np.pi
    for method in ("SLERP", "SPLINE_C2"):
        c = qc.Curve.from_euler([0, 1], [[0, 0, 0], [0.3, 0.2, turn]], method=method)
        speed = np.linalg.norm(c.angular_velocity([0.5]), axis=-1)[0]
        assert speed == pytest.approx(turn, rel=1e-3)


@pytest.mark.parametrize("method", ["QUAT_COMPONENTS", "NLERP"])
def test_lerp_keys_of_very_different_size_pass_through_their_keys(method):
    """QUAT_COMPONENTS lerps the keys as given: 1.7e308 and 1e-300 components neither overflow nor
    lose the smaller key to cancellation (two-weight form, power-of-two scaling)."""
    keys = np.array([[-5.09e36, 1.99e36, 1.17e36, -3.83e36], [1.0, 1.7e-159, 0, 9.6e-171],
                     [1.7e308, 1.7e308, 0, 0], [1e-300, 0, 2e-300, 0]])
    c = qc.Curve([0.0, 2.0, 3.0, 5.0], keys, method=method)
    t = np.array([0.0, 2.0, 3.0, 5.0])
    assert np.max(qc.angle_between(c.sample(t), keys)) <= 1e-12
    mid = np.linspace(0, 5, 41)
    q = c.sample(mid)
    assert np.all(np.isfinite(q)) and np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-14)
    assert np.all(np.isfinite(c.angular_velocity(mid)))
