"""Independent numpy re-implementation of Blender's F-curve evaluation and of the rotation error,
for verifying key reduction (test support code, not product code).

Blender stores key frames, values and handles as float32 and evaluates in float32:
- before/at the first key and at/after the last key: the end key's value (constant extrapolation);
- within 1e-4 frames of a key: that key's value;
- LINEAR segment: change * time / duration + begin (BLI_easing_linear_ease), float32;
- BEZIER segment: the frame cubic x(u) through (x0, hx_right0, hx_left1, x1) is solved for u (Blender:
  Cardano in double from float32 coefficients; here: Newton in double from the same float32
  coefficients — the same root to far below float32 resolution), u is rounded to float32, and the
  value cubic is evaluated in float32.
Then a quaternion is normalized (no hemisphere fix) and Euler angles build the rotation.
"""
from __future__ import annotations

import numpy as np

F32 = np.float32


def evaluate_channel(frames, values, handle_left, handle_right, interpolation, at):
    """Blender's evaluation of one F-curve at the frames `at` (float64 array out)."""
    kx = np.asarray(frames, dtype=F32)
    ky = np.asarray(values, dtype=F32)
    t = np.asarray(at, dtype=F32)
    out = np.empty(t.shape, dtype=F32)
    n = len(kx)
    before = t <= kx[0]
    after = t >= kx[-1]
    out[before] = ky[0]
    out[after & ~before] = ky[-1]
    inside = ~before & ~after
    if n >= 2 and np.any(inside):
        ti = t[inside]
        seg = np.clip(np.searchsorted(kx, ti, side="right") - 1, 0, n - 2)
        x0, x1 = kx[seg], kx[seg + 1]
        y0, y1 = ky[seg], ky[seg + 1]
        if interpolation == "LINEAR":
            val = (y1 - y0) * (ti - x0) / (x1 - x0) + y0
        else:
            hl = np.asarray(handle_left, dtype=F32).reshape(-1, 2)
            hr = np.asarray(handle_right, dtype=F32).reshape(-1, 2)
            q1x, q1y = hr[seg, 0], hr[seg, 1]
            q2x, q2y = hl[seg + 1, 0], hl[seg + 1, 1]
            three, two = F32(3), F32(2)
            # Frame cubic coefficients in float32, solved in double by Newton from the linear guess.
            c0 = (x0 - ti).astype(np.float64)
            c1 = (three * (q1x - x0)).astype(np.float64)
            c2 = (three * (x0 - two * q1x + q2x)).astype(np.float64)
            c3 = (x1 - x0 + three * (q1x - q2x)).astype(np.float64)
            u = -c0 / (c1 + c2 + c3)
            for _ in range(8):
                fu = c0 + u * (c1 + u * (c2 + u * c3))
                du = c1 + u * (2 * c2 + u * 3 * c3)
                u = u - fu / du
            u = u.astype(F32)
            d0 = y0
            d1 = three * (q1y - y0)
            d2 = three * (y0 - two * q1y + q2y)
            d3 = y1 - y0 + three * (q1y - q2y)
            val = d0 + u * d1 + u * u * d2 + u * u * u * d3
            flat = (np.abs(y0 - y1) < np.finfo(F32).eps) & (np.abs(q1y - q2y) < np.finfo(F32).eps) \
                & (np.abs(q2y - y1) < np.finfo(F32).eps)
            val = np.where(flat, y0, val)
        # Within 1e-4 frames of a key: the key's value.
        near_left = np.abs(ti - x0) <= F32(1e-4)
        near_right = np.abs(x1 - ti) <= F32(1e-4)
        val = np.where(near_left, y0, np.where(near_right, y1, val))
        out[inside] = val
    return out.astype(np.float64)


def quat_angle(a, b):
    """Geodesic angle between rotations a and b ((N, 4) w, x, y, z, any norm), sign-invariant.
    Written here in numpy on purpose, apart from quatcurve.angle_between: this module is the oracle
    the native reducer's own measurement is checked against."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    # d = conj(a)·b
    aw, ax, ay, az = a.T
    bw, bx, by, bz = b.T
    dw = aw * bw + ax * bx + ay * by + az * bz
    dx = aw * bx - ax * bw - ay * bz + az * by
    dy = aw * by + ax * bz - ay * bw - az * bx
    dz = aw * bz - ax * by + ay * bx - az * bw
    return 2 * np.arctan2(np.sqrt(dx * dx + dy * dy + dz * dz), np.abs(dw))


def euler_rotation(angles, order):
    """Blender Euler (angles about X, Y, Z; 'XYZ' = Rz·Ry·Rx) as a scipy Rotation (extrinsic).
    scipy is imported here only: Blender's Python has numpy but not scipy."""
    from scipy.spatial.transform import Rotation
    angles = np.asarray(angles, dtype=np.float64)
    cols = ["XYZ".index(a) for a in order]
    return Rotation.from_euler(order.lower(), angles[:, cols])


def evaluate_result(result, times, interpolation):
    """(N, C) Blender evaluation of every channel of a ReducedKeys at `times`."""
    return np.stack([evaluate_channel(ch.frames, ch.values, ch.handle_left, ch.handle_right,
                                      interpolation, times) for ch in result.channels], axis=1)


def evaluate_linear_indices(times, samples, indices):
    """(N, C) Blender LINEAR evaluation when every channel keeps the samples at `indices`
    (one index array for all channels, or a list with one per channel)."""
    times = np.asarray(times, dtype=np.float64)
    samples = np.asarray(samples, dtype=np.float64)
    C = samples.shape[1]
    per = indices if isinstance(indices, (list, tuple)) else [indices] * C
    cols = []
    for c in range(C):
        idx = np.asarray(per[c])
        cols.append(evaluate_channel(times[idx], samples[idx, c], None, None, "LINEAR", times))
    return np.stack(cols, axis=1)


def quat_errors(evaluated, quats):
    ev = np.array(evaluated, dtype=np.float64)
    zero = ~np.any(ev != 0, axis=1)
    ev[zero] = (0.0, 1.0, 0.0, 0.0)  # Blender's normalize of a zero quaternion
    return quat_angle(ev, quats)


def euler_errors(evaluated, angles, order):
    r_eval = euler_rotation(evaluated, order)
    r_ref = euler_rotation(angles, order)
    return (r_ref.inv() * r_eval).magnitude()
