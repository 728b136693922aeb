"""quatcurve.Skeleton: the pose against a numpy reference of Blender's pose formulas, the virtual
vertices, and the distance bound of Skeleton.reduce checked by an independent evaluation of the keys."""
import numpy as np
import pytest

import quatcurve as qc


def quat_matrix(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def random_skeleton(rng, bones):
    """Bone-relative specs (BKE_bone_offset_matrix_get: bone_mat, head, parent length) and their rest."""
    parents = [-1] + [int(rng.integers(0, b)) for b in range(1, bones)]
    lengths = rng.uniform(0.05, 0.5, bones)
    connected = np.array([b > 0 and rng.random() < 0.4 for b in range(bones)])
    inherit = np.array([b == 0 or rng.random() < 0.7 for b in range(bones)])
    offs = np.zeros((bones, 4, 4))
    rest = np.zeros((bones, 4, 4))
    for b in range(bones):
        offs[b] = np.eye(4)
        offs[b, :3, :3] = quat_matrix(rng.normal(size=4))
        head = np.zeros(3) if connected[b] else rng.uniform(-0.2, 0.2, 3)
        if parents[b] >= 0:
            head[1] += lengths[parents[b]]
        offs[b, :3, 3] = head
        rest[b] = offs[b] if parents[b] < 0 else rest[parents[b]] @ offs[b]
    return parents, lengths, connected, inherit, offs, rest


def reference_pose(parents, lengths, connected, inherit, offs, rest, loc, rot, scale):
    """Blender's pose (BKE_pchan_to_mat4, BKE_bone_parent_transform_calc_from_matrices and _apply), inherit
    scale FULL, in numpy."""
    B, N = rot.shape[:2]
    out = np.zeros((B, N, 4, 4))
    for b in range(B):
        for s in range(N):
            chan = np.eye(4)
            chan[:3, :3] = quat_matrix(rot[b, s]) @ np.diag(scale[b, s])
            if not connected[b]:
                chan[:3, 3] = loc[b, s]
            p = parents[b]
            if p < 0:
                out[b, s] = rest[b] @ chan
                continue
            parent = out[p, s]
            if inherit[b]:
                rotscale = parent @ offs[b]
            else:
                t = rest[p].copy()
                t[:3, :3] = t[:3, :3] * np.linalg.norm(parent[:3, :3], axis=0)  # the parent's axis lengths
                rotscale = t @ offs[b]
            m = rotscale @ chan
            m[:3, 3] = (parent @ offs[b] @ np.append(chan[:3, 3], 1.0))[:3]
            out[b, s] = m
    return out


def test_pose_matches_numpy_reference():
    rng = np.random.default_rng(29)
    for bones in (1, 3, 12):
        parents, lengths, connected, inherit, offs, rest = random_skeleton(rng, bones)
        sk = qc.Skeleton(parents, rest, lengths, inherit_rotation=inherit, connected=connected)
        N = 4
        loc = rng.uniform(-0.3, 0.3, (bones, N, 3))
        rot = rng.normal(size=(bones, N, 4))
        scale = rng.uniform(0.5, 1.5, (bones, N, 3))
        got = sk.pose(loc, rot, scale)
        np.testing.assert_allclose(got, reference_pose(parents, lengths, connected, inherit, offs, rest, loc, rot, scale),
                                   atol=1e-10)
        verts = sk.virtual_vertices(got, 0.1)
        assert verts.shape == (bones, N, 4, 3)
        tail = got[..., :3, 3] + got[..., :3, 1] * lengths[:, None, None]
        np.testing.assert_allclose(verts[:, :, 0], tail, atol=1e-12)
        np.testing.assert_allclose(verts[:, :, 3], got[..., :3, 3] + 0.1 * got[..., :3, 2], atol=1e-12)


def test_vertex_error_and_budgets():
    rest = np.tile(np.eye(4), (2, 1, 1))
    rest[1, 1, 3] = 1.0
    sk = qc.Skeleton([-1, 0], rest, [1.0, 0.5], connected=[0, 1])
    loc, scale = np.zeros((2, 3, 3)), np.ones((2, 3, 3))
    a = np.tile([1.0, 0, 0, 0], (2, 3, 1))
    b = a.copy()
    b[0, 1] = [np.cos(0.005), np.sin(0.005), 0, 0]  # the root turns 0.01 rad about X at sample 1
    e = sk.vertex_error((loc, a, scale), (loc, b, scale), 0.1)
    assert (e.bone, e.vertex, e.sample) == (1, 0, 1)
    assert e.distance == pytest.approx(2 * 1.5 * np.sin(0.005), abs=1e-12)
    budgets = sk.dominant_shell_budgets(sk.pose(loc, a, scale), 0.001, 0.1)
    np.testing.assert_allclose(budgets, [0.001 / 1.5, 0.001 / 0.5])
    # per bone and sample: only sample 1 moves, each bone's maximum over its four vertices
    d = sk.vertex_distances((loc, a, scale), (loc, b, scale), 0.1)
    assert d.shape == (2, 3)
    assert d[:, [0, 2]].max() == 0.0
    assert d.max() == e.distance and d[1, 1] == e.distance
    np.testing.assert_allclose(d[:, 1], e.per_bone)
    assert d[0, 1] == pytest.approx(2 * 1.0 * np.sin(0.005), abs=1e-12)
    with pytest.raises(ValueError, match="shell"):
        sk.vertex_distances((loc, a, scale), (loc, b, scale), -0.1)


def test_reduce_keeps_the_distance():
    rng = np.random.default_rng(7)
    parents, lengths, connected, inherit, offs, rest = random_skeleton(rng, 6)
    sk = qc.Skeleton(parents, rest, lengths, inherit_rotation=inherit, connected=connected)
    N = 50
    times = np.arange(1.0, N + 1.0)
    t = times[:, None]
    rotations = []
    for b in range(6):
        angles = 0.6 * np.sin(rng.uniform(0.02, 0.1, 3) * t + rng.uniform(-3, 3, 3))
        mode = ("XYZ", "QUATERNION", "ZXY")[b % 3]
        values = angles if mode != "QUATERNION" else qc.quats_to_channels(qc.channels_to_quats(angles, "XYZ"), mode)
        rotations.append((mode, values))
    loc, scale = np.zeros((6, N, 3)), np.ones((6, N, 3))
    result = sk.reduce(times, rotations, loc, scale, 0.001, 0.1)
    assert result.error.distance <= 0.001
    original = np.stack([qc.channels_to_quats(v, m) for m, v in rotations])
    reduced = []
    for keys, (mode, _) in zip(result.keys, rotations):
        values = np.stack([qc.blender_evaluate(ch.frames, ch.values, times, keys.interpolation, ch.handle_left,
                                               ch.handle_right) for ch in keys.channels], axis=-1)
        reduced.append(qc.channels_to_quats(values, mode))
    e = sk.vertex_error((loc, original, scale), (loc, np.stack(reduced), scale), 0.1)
    assert e.distance == pytest.approx(result.error.distance, abs=1e-12)
    assert result.key_count < sum(v.size for _, v in rotations) / 2
    assert result.budgets.shape == (6,)


def spec_slerp(a, b, u):
    """glTF 2.0 Appendix C: the shortest way from a to b."""
    if np.dot(a, b) < 0:
        b = -b
    angle = np.arccos(min(1.0, float(np.dot(a, b))))
    if angle < 1e-9:
        q = a * (1 - u) + b * u
    else:
        q = (np.sin(angle * (1 - u)) * a + np.sin(angle * u) * b) / np.sin(angle)
    return q / np.linalg.norm(q)


def spec_play(key_times, keys, t):
    """A glTF LINEAR rotation sampler at t: keys as float32, clamped outside them."""
    keys = keys.astype(np.float32).astype(np.float64)
    keys /= np.linalg.norm(keys, axis=1, keepdims=True)
    if t <= key_times[0]:
        return keys[0]
    if t >= key_times[-1]:
        return keys[-1]
    j = int(np.searchsorted(key_times, t, side="right"))
    return spec_slerp(keys[j - 1], keys[j], (t - key_times[j - 1]) / (key_times[j] - key_times[j - 1]))


def test_reduce_slerp_keeps_the_distance_and_each_bone_its_budget():
    rng = np.random.default_rng(11)
    parents, lengths, connected, inherit, offs, rest = random_skeleton(rng, 6)
    sk = qc.Skeleton(parents, rest, lengths, inherit_rotation=inherit, connected=connected)
    N = 40
    times = np.arange(1.0, N + 1.0)
    dense = np.arange(4 * (N - 1) + 1) * 0.25 + 1.0
    curves, bones = [], []
    for b in range(6):
        angles = 0.6 * np.sin(rng.uniform(0.02, 0.1, 3) * times[:, None] + rng.uniform(-3, 3, 3))
        curves.append(qc.Curve(times, qc.channels_to_quats(angles, "YXZ"), method="CATMULL_ROM"))
        bones.append(None if b == 3 else qc.SlerpBone(dense, reference=curves[-1], file_unit=1 / 24))
    original = np.stack([c.sample(times) for c in curves])
    loc, scale = np.zeros((6, N, 3)), np.ones((6, N, 3))
    result = sk.reduce_slerp(times, original, loc, scale, 0.002, 0.1, bones)
    assert type(result).__name__ == "SkeletonSlerpReduction" and len(result.keys) == 6
    assert len(result.keys[3].key_times) == 0  # kept
    played = original.copy()
    for b, keys in enumerate(result.keys):
        if b == 3:
            continue
        assert keys.proof.proven
        played[b] = [spec_play(keys.key_times, keys.keys.quats, t) for t in times]
        assert np.allclose(np.abs(np.sum(played[b] * qc.play_slerp_keys(keys.key_times, keys.keys.quats, times), 1)), 1)
        # Within its budget between the samples too (64 points per frame, scipy-free numpy slerp).
        fine = np.linspace(dense[0], dense[-1], 64 * (N - 1) + 1)
        got = np.array([spec_play(keys.key_times, keys.keys.quats, t) for t in fine])
        want = curves[b].sample(fine)
        angle = 2 * np.arccos(np.clip(np.abs(np.sum(got * want, 1)), 0, 1))
        assert angle.max() <= result.budgets[b] + 1e-6
    e = sk.vertex_error((loc, original, scale), (loc, played, scale), 0.1)
    assert e.distance <= 0.002
    assert e.distance == pytest.approx(result.error.distance, abs=1e-9)
    assert result.key_count < 5 * N


def test_slerp_bone_refuses_what_it_cannot_hold():
    times = np.arange(5.0)
    curve = qc.Curve(times, np.tile([1.0, 0, 0, 0], (5, 1)))
    with pytest.raises(ValueError, match="reference or samples"):
        qc.SlerpBone(times)
    with pytest.raises(ValueError, match="not both"):
        qc.SlerpBone(times, reference=curve, samples=curve.sample(times))
    with pytest.raises(ValueError, match="samples: 4 rows for 5 times"):
        qc.SlerpBone(times, samples=curve.sample(times)[:4])
    sk = qc.Skeleton([-1], np.eye(4)[None], [0.1])
    with pytest.raises(ValueError, match="bones: 2 for 1"):
        sk.reduce_slerp(times, curve.sample(times)[None], np.zeros((1, 5, 3)), np.ones((1, 5, 3)), 0.001, 0.1,
                        [None, None])
    with pytest.raises(TypeError, match="bones\\[0\\]"):
        sk.reduce_slerp(times, curve.sample(times)[None], np.zeros((1, 5, 3)), np.ones((1, 5, 3)), 0.001, 0.1, [1])


def test_reduce_keeps_the_bones_not_reduced():
    """reduced=False bones get no keys and are posed as sampled; the bound holds with them."""
    rng = np.random.default_rng(8)
    parents, lengths, connected, inherit, offs, rest = random_skeleton(rng, 5)
    sk = qc.Skeleton(parents, rest, lengths, inherit_rotation=inherit, connected=connected)
    N = 40
    times = np.arange(1.0, N + 1.0)
    rotations = [("XYZ", 0.5 * np.sin(rng.uniform(0.02, 0.1, 3) * times[:, None] + rng.uniform(-3, 3, 3)))
                 for _ in range(5)]
    loc, scale = np.zeros((5, N, 3)), np.ones((5, N, 3))
    flags = np.array([True, False, True, True, False])
    result = sk.reduce(times, rotations, loc, scale, 0.001, 0.1, reduced=flags)
    assert result.error.distance <= 0.001
    original = np.stack([qc.channels_to_quats(v, m) for m, v in rotations])
    posed = []
    for b, (keys, (mode, values)) in enumerate(zip(result.keys, rotations)):
        if not flags[b]:
            assert keys.key_count == 0 and len(keys.channels) == 0
            posed.append(original[b])
            continue
        values = np.stack([qc.blender_evaluate(ch.frames, ch.values, times, keys.interpolation, ch.handle_left,
                                               ch.handle_right) for ch in keys.channels], axis=-1)
        posed.append(qc.channels_to_quats(values, mode))
    e = sk.vertex_error((loc, original, scale), (loc, np.stack(posed), scale), 0.1)
    assert e.distance == pytest.approx(result.error.distance, abs=1e-12)
    with pytest.raises(ValueError, match="reduced: 2 flags for 5 bones"):
        sk.reduce(times, rotations, loc, scale, 0.001, 0.1, reduced=[True, False])


def test_refuses_bad_input():
    rest = np.tile(np.eye(4), (2, 1, 1))
    with pytest.raises(ValueError, match="parents"):
        qc.Skeleton([1, -1], rest, [1.0, 1.0])
    with pytest.raises(ValueError, match="rest"):
        qc.Skeleton([-1, 0], rest * 2, [1.0, 1.0])
    with pytest.raises(ValueError, match="inherit_scale"):
        qc.Skeleton([-1, 0], rest, [1.0, 1.0], inherit_scale=["FULL", "ALIGNED"])
    sk = qc.Skeleton([-1, 0], rest, [1.0, 1.0])
    with pytest.raises(ValueError, match="rotation"):
        sk.pose(np.zeros((2, 3, 3)), np.zeros((2, 3, 4)), np.ones((2, 3, 3)))
    with pytest.raises(ValueError, match="locations"):
        sk.pose(np.zeros((2, 2, 3)), np.ones((2, 3, 4)), np.ones((2, 3, 3)))
    with pytest.raises(ValueError, match="distance"):
        sk.reduce([1.0, 2.0], [("XYZ", np.zeros((2, 3)))] * 2, np.zeros((2, 2, 3)), np.ones((2, 2, 3)), 0.0, 0.1)
