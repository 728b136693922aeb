"""Key reduction under a distance bound (quatcurve.Skeleton.reduce) against today's angular reduction,
on the shared motion-capture clips (one run, prints a table; not a timed test).

Each clip's joints become an armature as plain arrays: a bone per joint, its head at the joint's rest
position, its Y axis toward its children (the mean of their offsets, or the End Site), so the tail
is where the child joint is; the BVH rotations are turned into each bone's local space and into
Euler channels of the joint's own order (what Blender's BVH importer keys). Offsets are read as
centimetres and posed in metres. Per clip, BEZIER per-channel keys:

- distance: Skeleton.reduce at 1 mm with a 10 cm shell: keys, the verified worst error, seconds;
- angular: reduce_keys_euler on every bone at one angle — the largest angle whose worst virtual-
  vertex error stays within the same 1 mm (bisection) — keys and seconds at that angle;
- the worst virtual-vertex error of the angular reduction at 0.1° (the add-on's default);
- the time of the angular reduction the add-on runs (reduce_keys_proved: reduced at the samples and
  proved against the original LINEAR keys' playback at every instant) at that same angle, and the
  distance reduction's time as a multiple of it.

Run: PYTHONPATH=<build>/python .venv/bin/python tests/bench/bench_skeleton.py [--smoke]
`--smoke` (tests/bench/smoke.py): the clips' first 40 frames, 3 bisection steps.
"""
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "python"))

import quatcurve  # noqa: E402
import bvh  # noqa: E402
import smoke  # noqa: E402

DEG = np.pi / 180.0
CM = 0.01  # BVH offsets in centimetres, posed in metres
DISTANCE, SHELL = 0.001, 0.1
CLIP_FRAMES = 40 if smoke.SMOKE else None
BISECTION_STEPS = 3 if smoke.SMOKE else 14
CLIPS = ("mocapbank.bvh", "freebvh.bvh")


def hierarchy(path):
    """Per joint, in file order: parent index, offset (3,), and the End Site offset (or None)."""
    parents, offsets, ends, stack = [], [], [], []
    in_end = False
    with open(path) as f:
        for line in f:
            tok = line.split()
            if not tok:
                continue
            if tok[0] in ("ROOT", "JOINT"):
                parents.append(stack[-1] if stack else -1)
                offsets.append(None)
                ends.append(None)
                stack.append(len(parents) - 1)
            elif tok[0] == "End":
                in_end = True
            elif tok[0] == "OFFSET":
                v = np.array(list(map(float, tok[1:4])))
                if in_end:
                    ends[stack[-1]] = v
                else:
                    offsets[stack[-1]] = v
            elif tok[0] == "}":
                if in_end:
                    in_end = False
                else:
                    stack.pop()
            elif tok[0] == "MOTION":
                break
    return parents, offsets, ends


def rotation_to(y_dir):
    """A unit quaternion (w, x, y, z) turning +Y onto y_dir (the shortest turn)."""
    d = y_dir / np.linalg.norm(y_dir)
    c = d[1]
    if c < -1 + 1e-12:
        return np.array([0.0, 0.0, 0.0, 1.0])
    axis = np.cross([0.0, 1.0, 0.0], d)
    q = np.array([1 + c, *axis])
    return q / np.linalg.norm(q)


def clip_armature(path):
    """(skeleton, times, rotations as (mode, Euler values), locations, scales, joints)."""
    clip = bvh.read_bvh(path)
    parents, offsets, ends = hierarchy(path)
    n = clip.frames if CLIP_FRAMES is None else min(CLIP_FRAMES, clip.frames)
    B = len(parents)
    heads = np.zeros((B, 3))
    for b in range(B):
        heads[b] = (heads[parents[b]] if parents[b] >= 0 else 0.0) + offsets[b] * CM
    rest, lengths, turns = np.zeros((B, 4, 4)), np.zeros(B), np.zeros((B, 4))
    for b in range(B):
        kids = [offsets[c] for c in range(B) if parents[c] == b]
        toward = np.mean(kids, axis=0) if kids else ends[b]
        if toward is None or np.linalg.norm(toward) < 1e-9:
            toward = np.array([0.0, 1.0, 0.0])
            lengths[b] = 0.0
        else:
            lengths[b] = np.linalg.norm(toward) * CM
        turns[b] = rotation_to(toward)
        rest[b] = quatcurve.rotation_matrix4(turns[b])
        rest[b, :3, 3] = heads[b]
    skeleton = quatcurve.Skeleton(parents, rest, lengths)
    times = np.arange(1.0, n + 1.0)
    rotations, locations, scales = [], np.zeros((B, n, 3)), np.ones((B, n, 3))
    for b, joint in enumerate(clip.joints):
        q = clip.quaternions(joint)[:n] if joint.rotation_columns else np.tile([1.0, 0, 0, 0], (n, 1))
        # The joint's rotation R (in its parent joint's axes, which are the armature's) in bone space:
        # A⁻¹·R·A with A the bone's rest turn.
        a = np.tile(turns[b], (n, 1))
        local = quatcurve.quat_multiply(quatcurve.quat_multiply(quatcurve.quat_conjugate(a), q), a)
        order = joint.blender_order if joint.rotation_columns else "XYZ"
        rotations.append((order, quatcurve.quats_to_channels(local, order)))
        if parents[b] < 0 and "Xposition" in joint.channels:
            cols = [joint.offset + joint.channels.index(c) for c in ("Xposition", "Yposition", "Zposition")]
            pos = clip.motion[:n, cols] * CM
            # pose head = rest·loc = head + A·loc  →  loc = A⁻¹·(pos − head)
            locations[b] = quatcurve.quat_rotate(np.tile(quatcurve.quat_conjugate(turns[b]), (n, 1)), pos - heads[b])
    return skeleton, times, rotations, locations, scales


def evaluate_keys(keys, mode, times):
    values = np.stack([quatcurve.blender_evaluate(ch.frames, ch.values, times, keys.interpolation,
                                                  ch.handle_left, ch.handle_right) for ch in keys.channels], axis=-1)
    return quatcurve.channels_to_quats(values, mode)


def angular(skeleton, times, rotations, locations, scales, angle):
    """Today's reduction at one angle for every bone: (keys, worst error, seconds)."""
    t0 = time.perf_counter()
    results = [quatcurve.reduce_keys_euler(times, values, mode, angle, "BEZIER", False) for mode, values in rotations]
    seconds = time.perf_counter() - t0
    original = np.stack([quatcurve.channels_to_quats(v, m) for m, v in rotations])
    reduced = np.stack([evaluate_keys(r, m, times) for r, (m, _) in zip(results, rotations)])
    error = skeleton.vertex_error((locations, original, scales), (locations, reduced, scales), SHELL)
    return sum(r.key_count for r in results), error.distance, seconds


def proved_seconds(times, rotations, angle):
    """Seconds of the add-on's angular reduction (reduce_keys_proved against the dense keys, LINEAR)."""
    t0 = time.perf_counter()
    for mode, values in rotations:
        channels = []
        for c in range(values.shape[1]):
            points = np.column_stack([times, values[:, c]])
            channels.append((times, values[:, c], points, points))
        quatcurve.reduce_keys_proved(channels, "LINEAR", mode, times, values, angle, "BEZIER", False)
    return time.perf_counter() - t0


def clip_row(name):
    path = bvh.mocap_path(name)
    skeleton, times, rotations, locations, scales = clip_armature(path)
    dense = sum(v.size for _, v in rotations)
    t0 = time.perf_counter()
    result = skeleton.reduce(times, rotations, locations, scales, DISTANCE, SHELL, "BEZIER", False)
    seconds = time.perf_counter() - t0
    # The largest uniform angle whose worst error stays within the distance (bisection in log angle).
    lo, hi = 1e-4 * DEG, 2.0 * DEG
    best = angular(skeleton, times, rotations, locations, scales, lo)
    for _ in range(BISECTION_STEPS):
        mid = np.sqrt(lo * hi)
        keys, err, secs = angular(skeleton, times, rotations, locations, scales, mid)
        if err <= DISTANCE:
            lo, best = mid, (keys, err, secs)
        else:
            hi = mid
    default = angular(skeleton, times, rotations, locations, scales, 0.1 * DEG)
    proved = proved_seconds(times, rotations, lo)
    saving = 100.0 * (1.0 - result.key_count / best[0])
    print(f"  {name:<15} {skeleton.bone_count:5d} {len(times):6d} {dense:7d} | {result.key_count:6d} "
          f"{1000 * result.error.distance:7.4f} {seconds:7.2f} | {lo / DEG:8.5f} {best[0]:6d} "
          f"{1000 * best[1]:7.4f} {best[2]:7.2f} | {saving:6.1f}% | {1000 * default[1]:8.3f} | "
          f"{proved:7.2f} {seconds / proved:6.2f}x")
    assert result.error.distance <= DISTANCE


def main():
    if not os.path.isdir(bvh.MOCAP_DIR):
        print("skipped: %s is absent (the shared mocap clips)" % os.path.relpath(bvh.MOCAP_DIR, ROOT))
        return 0
    print(f"distance {1000 * DISTANCE:g} mm, shell {100 * SHELL:g} cm, BEZIER per channel; "
          f"angular: the largest uniform angle within the same distance")
    print(f"  {'clip':<15} {'bones':>5} {'frames':>6} {'dense':>7} | {'keys':>6} {'mm':>7} {'s':>7} | "
          f"{'angle°':>8} {'keys':>6} {'mm':>7} {'s':>7} | {'fewer':>7} | {'mm @0.1°':>8} | "
          f"{'proved s':>7} {'ratio':>7}")
    for name in CLIPS:
        clip_row(name)
    return 0


if __name__ == "__main__":
    smoke.run(main)
