"""reduce_slerp and gltf_slerp against a numpy reference written from the glTF 2.0 specification
(Appendix C: a = arccos(|v_k·v_k+1|), s = sign(v_k·v_k+1), v_t = sin(a(1−t))/sin(a)·v_k +
s·sin(a·t)/sin(a)·v_k+1): the kept keys, played that way at every sample's time, stay within the
tolerance; scipy's Slerp as a second oracle; bad input."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

import quatcurve

DEG = np.pi / 180.0


def spec_slerp(a, b, t):
    """glTF's slerp of 4-vectors a, b (any component order; normalized first) at t."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    d = float(np.dot(a, b))
    s = 1.0 if d >= 0 else -1.0
    angle = np.arccos(min(1.0, abs(d)))
    if angle < 1e-12:
        return (1 - t) * a + s * t * b
    return np.sin(angle * (1 - t)) / np.sin(angle) * a + s * np.sin(angle * t) / np.sin(angle) * b


def angle(a, b):
    """Geodesic angle between rotations (sign-invariant), radians: 4·atan2(|a − b|, |a + b|) on unit a, b
    in one hemisphere (arccos of the dot product loses half the digits near 0)."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    if np.dot(a, b) < 0:
        b = -b
    return 4 * np.arctan2(np.linalg.norm(a - b), np.linalg.norm(a + b))


def played(times, key_times, key_quats):
    """The keys played at `times` as a glTF LINEAR rotation sampler (spec_slerp between keys)."""
    out = []
    for t in times:
        k = min(int(np.searchsorted(key_times, t, side="right")) - 1, len(key_times) - 2)
        u = (t - key_times[k]) / (key_times[k + 1] - key_times[k])
        out.append(spec_slerp(key_quats[k], key_quats[k + 1], u))
    return np.array(out)


def wobble(n=961, seed=3, step=0.25):
    rng = np.random.default_rng(seed)
    u, v = rng.normal(size=3), rng.normal(size=3)
    t = step * np.arange(n)
    r = Rotation.from_rotvec(np.outer(1.4 * np.sin(t / 13.0), u / np.linalg.norm(u))) * \
        Rotation.from_rotvec(np.outer(0.05 * t, v / np.linalg.norm(v)))
    xyzw = r.as_quat()
    q = xyzw[:, [3, 0, 1, 2]]
    q[rng.random(n) < 0.3] *= -1  # sample signs must not matter
    return t, q


@pytest.mark.parametrize("tolerance_deg", [0.01, 0.1, 0.5, 2.0])
def test_keys_played_per_spec_stay_within_tolerance(tolerance_deg):
    t, q = wobble()
    keys = quatcurve.reduce_slerp(t, q, tolerance_deg * DEG)
    idx = keys.indices
    assert idx[0] == 0 and idx[-1] == len(t) - 1 and (np.diff(idx) > 0).all()
    assert np.allclose(np.abs(np.sum(keys.quats * q[idx], axis=1)) / np.linalg.norm(q[idx], axis=1), 1.0)
    assert (np.sum(keys.quats[1:] * keys.quats[:-1], axis=1) >= 0).all()  # signs continuous
    got = played(t, t[idx], keys.quats)
    errors = np.array([angle(a, b) for a, b in zip(got, q)])
    assert errors.max() <= tolerance_deg * DEG + 1e-12
    assert keys.max_error == pytest.approx(errors.max(), abs=1e-12)
    if tolerance_deg >= 0.1:
        assert len(idx) < len(t) / 4


def test_agrees_with_scipy_slerp():
    t, q = wobble(n=401)
    keys = quatcurve.reduce_slerp(t, q, 0.2 * DEG)
    xyzw = keys.quats[:, [1, 2, 3, 0]]
    scipy_played = Slerp(t[keys.indices], Rotation.from_quat(xyzw))(t).as_quat()[:, [3, 0, 1, 2]]
    ours = played(t, t[keys.indices], keys.quats)
    assert max(angle(a, b) for a, b in zip(scipy_played, ours)) < 1e-9


def test_gltf_slerp_is_the_spec_formula():
    rng = np.random.default_rng(9)
    for _ in range(200):
        a, b = rng.normal(size=4), rng.normal(size=4)
        t = rng.uniform(0, 1)
        want = spec_slerp(a / np.linalg.norm(a), b / np.linalg.norm(b), t)
        got = quatcurve.gltf_slerp(a, b, t)
        assert np.allclose(got, want / np.linalg.norm(want), atol=1e-12)


def test_constant_speed_keeps_two_keys_and_spins_keep_more():
    t = np.arange(101.0)
    half = np.outer(0.01 * t, [0, 0, 1.0])
    q = np.column_stack([np.cos(half[:, 2]), np.zeros((101, 2)), np.sin(half[:, 2])])
    assert list(quatcurve.reduce_slerp(t, q, 1e-9).indices) == [0, 100]
    spin = np.column_stack([np.cos(0.04 * t), np.zeros((101, 2)), np.sin(0.04 * t)])  # 460°
    keys = quatcurve.reduce_slerp(t, spin, 1e-6)
    assert len(keys) >= 3 and keys.max_error <= 1e-6


@pytest.mark.parametrize("times, quats, tolerance, message", [
    ([0, 1], [[1, 0, 0, 0]], 0.1, "quats: 1 rows for 2 times"),
    ([0, 0], [[1, 0, 0, 0]] * 2, 0.1, "times[1]: not increasing"),
    ([0, np.nan], [[1, 0, 0, 0]] * 2, 0.1, "times[1]"),
    ([0, 1], [[1, 0, 0, 0], [0, 0, 0, 0]], 0.1, "quats[1]"),
    ([0, 1], [[1, 0, 0, 0]] * 2, -1.0, "tolerance"),
    ([0, 1], [[1, 0, 0, 0]] * 2, np.inf, "tolerance"),
    ([], np.zeros((0, 4)), 0.1, "times"),
])
def test_bad_input_is_refused(times, quats, tolerance, message):
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        quatcurve.reduce_slerp(np.array(times, float), np.array(quats, float), tolerance)


def test_reduce_slerp_proved_holds_blenders_playback_at_every_instant():
    """Against Blender's playback of Euler BEZIER keys (auto-like handles): the keys' slerp, evaluated by
    glTF's formula at 64 points per sample interval, stays within the proved bound and the tolerance;
    bad input is refused."""
    frames = np.array([1.0, 7.0, 15.0, 22.0, 30.0])
    values = np.radians([[0, 0, 0], [80, -20, 40], [10, 85, 170], [-60, 30, 250], [0, 10, 360]])
    channels = []
    for c in range(3):
        slope = np.gradient(values[:, c], frames)
        h = np.diff(frames, prepend=frames[0] - 3)[:, None] / 3
        left = np.column_stack([frames - h[:, 0], values[:, c] - slope * h[:, 0]])
        right = np.column_stack([frames + h[:, 0], values[:, c] + slope * h[:, 0]])
        channels.append((frames, values[:, c], left, right))
    times = np.arange(1.0, 30.0 + 1e-9, 0.25)
    tol = np.radians(0.5)
    out = quatcurve.reduce_slerp_proved(channels, "BEZIER", "XYZ", times, tol)
    assert out.proof.proven, out
    dense = np.linspace(1.0, 30.0, 29 * 4 * 64 + 1)
    ref = quatcurve.channels_to_quats(np.stack([quatcurve.blender_evaluate(f, v, dense, "BEZIER", hl, hr)
                                         for f, v, hl, hr in channels], 1), "XYZ")
    got = quatcurve.Curve(out.key_times, out.keys.quats, "SLERP").sample(dense)
    err = 2 * np.arctan2(np.linalg.norm(got - np.sign(np.sum(got * ref, 1))[:, None] * ref, axis=1),
                         np.linalg.norm(got + np.sign(np.sum(got * ref, 1))[:, None] * ref, axis=1))
    assert err.max() <= min(out.proof.bound, tol) + 1e-7
    assert len(out.keys.indices) < len(times) / 2
    with pytest.raises(ValueError, match="tolerance"):
        quatcurve.reduce_slerp_proved(channels, "BEZIER", "XYZ", times, -1.0)
    with pytest.raises(ValueError, match="at least two"):
        quatcurve.reduce_slerp_proved(channels, "BEZIER", "XYZ", times[:1], tol)
