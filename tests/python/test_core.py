"""Property tests of the orientation core (quat.hpp / euler.hpp through the `quatcurve` module).

Every property runs vectorized over 10^5 random inputs (fixed seeds) against a plain numpy double
reference and against scipy.spatial.transform.Rotation, for all six Euler orders, including
near-gimbal angles, near-identity and antipodal quaternions. Blender's 'XYZ' (R = Rz·Ry·Rx) is
scipy's extrinsic 'xyz'; scipy quaternions are (x, y, z, w), ours (w, x, y, z).
"""

import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import quatcurve as qc

N = 100_000
ORDERS = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"]
MIDDLE = {o: "XYZ".index(o[1]) for o in ORDERS}


# ---- plain numpy references ---------------------------------------------------------------------

def np_mul(a, b):
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def np_conj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def np_unit(q):
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def np_rotate(q, v):
    u = np_unit(q)
    p = np.concatenate([np.zeros(v.shape[:-1] + (1,)), v], axis=-1)
    return np_mul(np_mul(u, p), np_conj(u))[..., 1:]


def to_scipy(q):
    return np.asarray(q)[..., [1, 2, 3, 0]]


def from_scipy(x):
    return np.asarray(x)[..., [3, 0, 1, 2]]


def to_seq(angles, order):
    """(ax, ay, az) -> angles in the order's sequence, as scipy takes them."""
    return angles[..., ["XYZ".index(c) for c in order]]


def from_seq(seq, order):
    out = np.empty_like(seq)
    for n, c in enumerate(order):
        out[..., "XYZ".index(c)] = seq[..., n]
    return out


def scipy_euler(angles, order):
    return Rotation.from_euler(order.lower(), to_seq(angles, order))


def rotation_angle(a, b):
    """Geodesic angle between rotations, scipy's way (2·atan2(|v|, |w|) of a⁻¹b)."""
    return (Rotation.from_quat(to_scipy(a)).inv() * Rotation.from_quat(to_scipy(b))).magnitude()


def same_up_to_sign(a, b, tol):
    d = np.minimum(np.abs(a - b).max(axis=-1), np.abs(a + b).max(axis=-1))
    assert d.max() <= tol, d.max()


# ---- random inputs ------------------------------------------------------------------------------

def random_quats(rng, n=N):
    """Unit quaternions, with near-identity, near-antipodal and tiny-angle cases mixed in."""
    q = np_unit(rng.normal(size=(n, 4)))
    k = n // 10
    q[:k] = np_unit(np.concatenate([np.ones((k, 1)), 10.0 ** rng.uniform(-12, -2, (k, 1)) * rng.normal(size=(k, 3))], 1))
    q[k:2 * k] = -q[:k]  # near −identity: the same rotations, other hemisphere
    return q


def random_angles(rng, order, n=N, span=np.pi):
    """Euler triples with the middle angle in [−π/2, π/2]; 20 % within 1e-1..1e-15 of gimbal lock,
    2 % exactly at it."""
    a = rng.uniform(-span, span, (n, 3))
    m = MIDDLE[order]
    a[:, m] = rng.uniform(-np.pi / 2, np.pi / 2, n)
    k = n // 5
    a[:k, m] = np.sign(rng.uniform(-1, 1, k)) * (np.pi / 2 - 10.0 ** rng.uniform(-15, -1, k))
    a[k:k + n // 50, m] = np.sign(rng.uniform(-1, 1, n // 50)) * np.pi / 2
    return a


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


# ---- algebra ------------------------------------------------------------------------------------

def test_multiply_matches_reference_scipy_and_broadcasts(rng):
    a, b = rng.normal(size=(N, 4)), rng.normal(size=(N, 4))
    ab = qc.quat_multiply(a, b)
    np.testing.assert_allclose(ab, np_mul(a, b), rtol=0, atol=1e-13)
    # scipy's p * q applies q first: the Hamilton product p·q of unit quaternions
    ua, ub = np_unit(a), np_unit(b)
    same_up_to_sign(qc.quat_multiply(ua, ub), from_scipy((Rotation.from_quat(to_scipy(ua)) * Rotation.from_quat(to_scipy(ub))).as_quat()), 1e-14)
    # a single value broadcasts against a batch; (n,1) against (1,m)
    np.testing.assert_allclose(qc.quat_multiply(a[0], b[:100]), np_mul(a[:1], b[:100]), atol=1e-13)
    grid = qc.quat_multiply(a[:30, None], b[None, :40])
    assert grid.shape == (30, 40, 4)
    np.testing.assert_allclose(grid, np_mul(a[:30, None], b[None, :40]), atol=1e-13)


def test_conjugate_inverse_divide_norm_normalize(rng):
    a, b = rng.normal(size=(N, 4)), rng.normal(size=(N, 4))
    np.testing.assert_array_equal(qc.quat_conjugate(a), np_conj(a))
    n = np.linalg.norm(a, axis=-1)
    np.testing.assert_allclose(qc.quat_norm(a), n, rtol=1e-15)
    np.testing.assert_allclose(qc.quat_inverse(a), np_conj(a) / (n * n)[:, None], rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(qc.quat_multiply(qc.quat_divide(a, b), b), a, atol=1e-12)
    np.testing.assert_allclose(qc.quat_normalize(a), a / n[:, None], rtol=0, atol=2e-16)
    # overflow- and underflow-safe norms
    np.testing.assert_allclose(qc.quat_norm([[3e300, 4e300, 0, 0], [0, 0, 3e-300, 4e-300]]), [5e300, 5e-300], rtol=1e-15)
    np.testing.assert_allclose(qc.quat_normalize([0, 3e-250, 0, 4e-250]), [0, 0.6, 0, 0.8], rtol=1e-15)


def test_exp_log_pow(rng):
    q = rng.normal(size=(N, 4))
    np.testing.assert_allclose(qc.quat_exp(qc.quat_log(q)), q, rtol=0, atol=1e-12 * np.abs(q).max())
    u = random_quats(rng)
    u[u[:, 0] < 0] *= -1  # w ≥ 0: pow follows the shortest path, as scipy's rotation vectors
    t = rng.uniform(-2, 2, N)
    expected = Rotation.from_rotvec(t[:, None] * Rotation.from_quat(to_scipy(u)).as_rotvec())
    same_up_to_sign(qc.quat_pow(u, t), from_scipy(expected.as_quat()), 1e-13)
    # the log of a unit quaternion is half its rotation vector; exact for tiny angles
    np.testing.assert_allclose(2.0 * qc.quat_log(u)[:, 1:], Rotation.from_quat(to_scipy(u)).as_rotvec(), rtol=1e-12, atol=1e-15)
    assert np.abs(qc.quat_log(u)[:, 0]).max() < 1e-15
    tiny = np.array([[0.0, 1e-200, 0, 0], [0.0, 0, 1e-9, 0]])
    np.testing.assert_allclose(qc.quat_exp(tiny)[:, 1:], tiny[:, 1:], rtol=1e-16)
    np.testing.assert_array_equal(qc.quat_log([-2.0, 0, 0, 0]), [np.log(2.0), np.pi, 0, 0])


# ---- rotation of points ---------------------------------------------------------------------------

def test_rotate_matches_sandwich_reference_and_scipy(rng):
    q = rng.normal(size=(N, 4)) * rng.uniform(0.1, 10, (N, 1))  # not unit: normalized first
    v = rng.normal(size=(N, 3))
    fast = qc.quat_rotate(q, v)
    np.testing.assert_allclose(fast, np_rotate(q, v), atol=1e-13)
    np.testing.assert_allclose(qc.quat_rotate_sandwich(q, v), fast, atol=1e-13)
    np.testing.assert_allclose(fast, Rotation.from_quat(to_scipy(q)).apply(v), atol=1e-13)
    np.testing.assert_allclose(np.linalg.norm(fast, axis=-1), np.linalg.norm(v, axis=-1), rtol=1e-14)
    # one rotation against many points, and the seed's example
    np.testing.assert_allclose(qc.quat_rotate(q[0], v[:50]), np_rotate(q[:1], v[:50]), atol=1e-13)
    y90 = qc.axis_angle_to_quat([0, 1, 0], np.pi / 2)
    np.testing.assert_allclose(qc.quat_rotate(y90, [0, 1, 1]), [1, 1, 0], atol=1e-15)


# ---- axis-angle and angle_between -----------------------------------------------------------------

def test_axis_angle_round_trip_and_scipy(rng):
    axis = rng.normal(size=(N, 3))
    angle = rng.uniform(0, 2 * np.pi, N)
    q = qc.axis_angle_to_quat(axis, angle)
    unit_axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    same_up_to_sign(q, from_scipy(Rotation.from_rotvec(unit_axis * angle[:, None]).as_quat()), 1e-14)
    a2, t2 = qc.quat_to_axis_angle(q)
    np.testing.assert_allclose(t2, angle, atol=1e-13)
    np.testing.assert_allclose(a2, unit_axis, atol=1e-11)
    # identity: Blender's default axis (0, 1, 0); angles above π for w < 0
    axis0, angle0 = qc.quat_to_axis_angle([[1.0, 0, 0, 0], [-1.0, 0, 0, 0]])
    np.testing.assert_array_equal(axis0, [[0, 1, 0], [0, 1, 0]])
    np.testing.assert_allclose(angle0, [0, 2 * np.pi])


def test_angle_between_matches_scipy_and_is_sign_invariant(rng):
    a, b = random_quats(rng), random_quats(np.random.default_rng(7))
    got = qc.angle_between(a, b)
    np.testing.assert_allclose(got, rotation_angle(a, b), atol=1e-13)
    np.testing.assert_array_equal(qc.angle_between(a, -b), got)
    assert got.min() >= 0 and got.max() <= np.pi
    np.testing.assert_array_equal(qc.angle_between(a, -a), 0.0)  # antipodal: the same rotation


@pytest.mark.parametrize("delta", [1e-12, 1e-9, 1e-6, 1e-3, np.pi - 1e-9])
def test_angle_between_accurate_near_zero_and_pi(rng, delta):
    a = random_quats(rng)
    u = rng.normal(size=(N, 3))
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    d = np.concatenate([np.full((N, 1), np.cos(delta / 2)), np.sin(delta / 2) * u], axis=-1)
    b = np_mul(a, d)
    err = np.abs(qc.angle_between(a, b) - delta)
    assert err.max() < 2e-15 + 1e-12 * delta, err.max()
    # the acos of the dot product loses half the digits there: ours is far better
    naive = 2 * np.arccos(np.minimum(1.0, np.abs(np.sum(a * b, axis=-1))))
    if delta < 1e-6:
        assert np.abs(naive - delta).max() > 100 * err.max()


# ---- matrices and homogeneous transforms ----------------------------------------------------------

def test_quat_to_matrix_and_back(rng):
    q = random_quats(rng)
    m = qc.quat_to_matrix(q)
    np.testing.assert_allclose(m, Rotation.from_quat(to_scipy(q)).as_matrix(), atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(m), 1.0, atol=1e-14)
    back = qc.matrix_to_quat(m)
    assert (back[:, 0] >= 0).all()
    same_up_to_sign(back, q, 2e-15)
    # noise, scale and 4×4 transforms
    noisy = m + 1e-8 * rng.normal(size=m.shape)
    assert rotation_angle(qc.matrix_to_quat(noisy), q).max() < 1e-7
    scale = rng.uniform(0.01, 100, (N, 3))
    assert rotation_angle(qc.matrix_to_quat(m * scale[:, None, :]), q).max() < 1e-13   # R·S
    assert rotation_angle(qc.matrix_to_quat(scale[:, :, None] * m), q).max() < 1e-13   # S·R
    m4 = qc.translation_matrix(rng.normal(size=(N, 3))) @ qc.rotation_matrix4(q)
    same_up_to_sign(qc.matrix_to_quat(m4), q, 2e-15)
    r = qc.nearest_rotation(noisy)
    np.testing.assert_allclose(r @ np.swapaxes(r, -1, -2), np.broadcast_to(np.eye(3), r.shape), atol=1e-15)


def test_homogeneous_compounding(rng):
    n = N // 10
    t, s, q, p = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), random_quats(rng, n), rng.normal(size=(n, 3))
    m1, m2, m3 = qc.translation_matrix(t), qc.rotation_matrix4(q), qc.scale_matrix(s)
    expected = np_rotate(q, p * s) + t  # M3 first (scale, reflections included), then M2, then M1
    np.testing.assert_allclose(qc.transform_points(m1 @ m2 @ m3, p), expected, atol=1e-12)
    np.testing.assert_allclose(qc.transform_points(m1, qc.transform_points(m2, qc.transform_points(m3, p))), expected, atol=1e-12)
    np.testing.assert_allclose(qc.transform_directions(m1 @ m2, p), np_rotate(q, p), atol=1e-13)
    np.testing.assert_allclose(np.linalg.det(m3), np.prod(s, axis=-1), rtol=1e-12)


def test_matrix_representations_map_products_to_products(rng):
    a, b = rng.normal(size=(N, 4)), rng.normal(size=(N, 4))
    ab = np_mul(a, b)
    ca, cb = qc.quat_to_complex2(a), qc.quat_to_complex2(b)
    assert ca.dtype == np.complex128 and ca.shape == (N, 2, 2)
    np.testing.assert_allclose(ca @ cb, qc.quat_to_complex2(ab), atol=1e-13)
    np.testing.assert_allclose(np.linalg.det(ca), np.sum(a * a, axis=-1), rtol=1e-13)
    la, lb = qc.quat_to_real4(a), qc.quat_to_real4(b)
    np.testing.assert_allclose(la @ lb, qc.quat_to_real4(ab), atol=1e-13)
    np.testing.assert_allclose((la @ b[..., None])[..., 0], ab, atol=1e-13)
    np.testing.assert_allclose(qc.complex2_to_quat(ca), a, atol=1e-15)
    np.testing.assert_allclose(qc.real4_to_quat(la), a, atol=1e-15)


# ---- Euler angles ---------------------------------------------------------------------------------

@pytest.mark.parametrize("order", ORDERS)
def test_euler_to_quat_and_matrix_match_scipy(rng, order):
    angles = rng.uniform(-10, 10, (N, 3))
    r = scipy_euler(angles, order)
    same_up_to_sign(qc.euler_to_quat(angles, order), from_scipy(r.as_quat()), 2e-15)
    np.testing.assert_allclose(qc.euler_to_matrix(angles, order), r.as_matrix(), atol=3e-15)


@pytest.mark.parametrize("order", ORDERS)
def test_quat_to_euler_matches_scipy_including_gimbal_lock(rng, order):
    angles = random_angles(rng, order)
    q = qc.euler_to_quat(angles, order)
    got = qc.quat_to_euler(q, order)
    m = MIDDLE[order]
    # every result is the same rotation, in the documented ranges
    assert rotation_angle(qc.euler_to_quat(got, order), q).max() < 5e-15
    assert np.abs(got[:, m]).max() <= np.pi / 2 and np.abs(got).max() <= np.pi
    # away from the lock the angles are unique: equal to the input and to scipy's
    far = np.abs(np.cos(angles[:, m])) > 1e-4
    np.testing.assert_allclose(got[far], angles[far], atol=1e-11)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scipy warns about gimbal lock
        sp = from_seq(Rotation.from_quat(to_scipy(q)).as_euler(order.lower()), order)
    np.testing.assert_allclose(got[far], sp[far], atol=1e-11)
    # at the lock: middle exactly ±π/2, last angle 0, scipy's middle angle agrees
    locked = np.abs(np.cos(got[:, m])) < 1e-15
    assert locked.sum() >= N // 50
    last = "XYZ".index(order[2])
    assert (got[locked, last] == 0).all()
    np.testing.assert_allclose(got[locked, m], sp[locked, m], atol=1e-7)
    # matrices convert the same way (near the lock single angles are ill-conditioned: compare rotations)
    from_m = qc.matrix_to_euler(qc.quat_to_matrix(q), order)
    np.testing.assert_allclose(from_m[far], got[far], atol=1e-11)
    assert rotation_angle(qc.euler_to_quat(from_m, order), q).max() < 5e-15


@pytest.mark.parametrize("order", ORDERS)
def test_quat_to_euler_compat_recovers_the_keyed_angles(rng, order):
    angles = rng.uniform(-10, 10, (N, 3))  # any range: middle beyond ±π/2, several turns
    q = qc.euler_to_quat(angles, order)
    ref = angles + rng.uniform(-0.3, 0.3, (N, 3))
    got = qc.quat_to_euler(q, order, compat=ref)
    # Exact but within 16·FLT_EPSILON of gimbal lock, which compat treats as locked (as Blender does:
    # float32 data reaches a lock only that closely), where the locked family nearest ref is returned.
    locked = np.abs(np.cos(angles[:, MIDDLE[order]])) <= 16 * np.finfo(np.float32).eps
    error = rotation_angle(qc.euler_to_quat(got, order), q)
    assert error[~locked].max() < 5e-14
    assert error.max() < 2 * np.pi * 16 * np.finfo(np.float32).eps
    far = np.abs(np.cos(angles[:, MIDDLE[order]])) > 1e-3
    np.testing.assert_allclose(got[far], angles[far], atol=1e-9)
    # never farther from ref than the keyed angles (the minimum over every equivalent triple)
    assert (np.abs(got - ref).sum(-1) <= np.abs(angles - ref).sum(-1) + 1e-9).all()
    # a single reference broadcasts
    assert qc.quat_to_euler(q[:10], order, compat=[0.0, 0.0, 0.0]).shape == (10, 3)
    np.testing.assert_allclose(qc.euler_compat(angles[:1000] + 2 * np.pi * rng.integers(-3, 4, (1000, 3)), angles[:1000], order), angles[:1000], atol=1e-12)


@pytest.mark.parametrize("order", ORDERS)
def test_euler_filter_keeps_orientations_and_removes_jumps(rng, order):
    seqs, steps = 200, 500  # 10^5 triples
    t = np.linspace(0, 10, steps)
    rates = rng.uniform(-2, 2, (seqs, 1, 3))
    path = rng.uniform(-np.pi, np.pi, (seqs, 1, 3)) + rates * t[None, :, None]
    m = MIDDLE[order]
    path[:, :, m] = 2.2 * np.sin(rates[:, :, m] * t[None, :])  # crosses ±π/2 back and forth
    converted = qc.quat_to_euler(qc.euler_to_quat(path, order), order)
    start = converted.copy()
    start[:, 0] = path[:, 0]  # the filter keeps the first triple
    filtered = qc.euler_filter(start, order)
    assert filtered.shape == path.shape
    assert rotation_angle(qc.euler_to_quat(filtered, order), qc.euler_to_quat(converted, order)).max() < 1e-13
    np.testing.assert_allclose(filtered, path, atol=1e-8)
    assert np.abs(np.diff(converted, axis=1)).max() > 3  # the conversion alone jumps
    assert np.abs(np.diff(filtered, axis=1)).max() < 0.2
    np.testing.assert_array_equal(qc.euler_filter(start[0], order), filtered[0])  # (N, 3) alone


@pytest.mark.parametrize("order", ORDERS)
def test_gimbal_distance(rng, order):
    angles = rng.uniform(-10, 10, (N, 3))
    b = angles[:, MIDDLE[order]]
    wrapped = np.mod(b + np.pi / 2, np.pi) - np.pi / 2  # b modulo π, in [−π/2, π/2)
    np.testing.assert_allclose(qc.gimbal_distance(angles, order), np.pi / 2 - np.abs(wrapped), atol=1e-12)
    assert np.abs(qc.gimbal_distance([[0, 0, 0], [np.pi / 2] * 3, [-np.pi / 2] * 3], order)).max() <= np.pi / 2
    assert qc.euler_middle_axis(order) == MIDDLE[order]


def test_seed_fixed_angle_examples():
    d = np.radians
    # (ε, −90°, 0) and (0, −90°, ε) are the same orientation in 'XYZ'
    eps = 1e-3
    assert qc.angle_between(qc.euler_to_quat([eps, d(-90), 0]), qc.euler_to_quat([0, d(-90), eps])) < 1e-15
    # the slerp midpoint of XYZ (0, 90°, 0) and (90°, 45°, 90°) is (90°, 67.5°, 90°), not the average
    q1, q2 = qc.euler_to_quat(d([0, 90, 0])), qc.euler_to_quat(d([90, 45, 90]))
    mid = qc.quat_multiply(qc.quat_pow(qc.quat_multiply(q2, qc.quat_conjugate(q1)), 0.5), q1)
    np.testing.assert_allclose(np.degrees(qc.quat_to_euler(mid)), [90, 67.5, 90], atol=1e-11)
    assert abs(np.degrees(qc.angle_between(mid, qc.euler_to_quat(d([45, 67.5, 45])))) - 17.13) < 0.005
