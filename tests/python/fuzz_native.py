"""Fuzzing of the native module `quatcurve`: every public function and every Curve method gets random
and extreme arrays (NaN, ±inf, 1e±300, subnormals, zeros, antipodal pairs, duplicate and unsorted
times, huge counts, wrong shapes and dtypes). The outcome asserted for every call:

  * it returns, or raises ValueError or TypeError (MemoryError only for an output of more than
    MEMORY_LIMIT bytes: the child runs under an address-space limit);
  * no crash and no hang (a watchdog ends the process and dumps the stack after CALL_TIMEOUT s);
  * the output is finite (except the sentinels a function documents: NaN key jumps, +inf speed
    ratios) and every rotation quaternion it returns has unit length;
  * input the API promises to refuse (non-finite values, shapes that do not broadcast, junk
    types, unsorted or duplicate times) is refused.

One hypothesis example draws the structure of a case (modes, sizes, a seed) and numpy fills a batch
of many rows from that seed: rows are counted as cases. Targets are enumerated from
dir(quatcurve) (plus one per Curve method in quatcurve.METHODS), so a new public callable without a
strategy in REGISTRY is reported by test_fuzz.py.

Run by tests/python/test_fuzz.py in a child process (a segfault is a failed target, not an aborted
pytest run); directly:  python tests/python/fuzz_native.py [TARGET ...]
Environment: QUATCURVE_FUZZ_LONG=1 for the long campaign (random seeds, 100x the examples).
"""

from __future__ import annotations

import faulthandler
import json
import math
import os
import sys
import time
import traceback
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import quatcurve as qc

LONG = os.environ.get("QUATCURVE_FUZZ_LONG") == "1"
EXAMPLES = int(os.environ.get("QUATCURVE_FUZZ_EXAMPLES", "20000" if LONG else "130"))
EXAMPLE_SHARE = {"reduce_keys": 0.5, "reduce_keys_euler": 0.5, "reduce_keys_axis_angle": 0.5, "fit_keys": 0.5,
                 "fit_through_keys": 0.5, "fit_channels": 0.5, "FitQueue": 0.5,
                 "reduce_keys_proved": 0.5, "reduce_curve_proved": 0.5, "convert_keys_proved": 0.5, "reduce_slerp_proved": 0.5, "Skeleton": 0.5,
                 "smooth_rotations": 0.5, "clean_rotations": 0.5}  # slower targets: fewer examples
# The smoke run reports the first failing example as found (with its inputs); the long campaign,
# or QUATCURVE_FUZZ_SHRINK=1, also shrinks it to a smaller one first.
SHRINK = LONG or os.environ.get("QUATCURVE_FUZZ_SHRINK") == "1"
CALL_TIMEOUT = 600.0 if LONG else 30.0  # seconds one call may take before it counts as a hang
MEMORY_LIMIT = 1 << 29                  # outputs above 512 MiB may raise MemoryError
ADDRESS_SPACE = 6 << 30                 # RLIMIT_AS of the child: huge allocations fail cleanly
UNIT_TOL = 1e-10
ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")

NAN, INF = float("nan"), float("inf")
DMAX = np.finfo(np.float64).max
SPECIAL = np.array([0.0, -0.0, 1.0, -1.0, 5e-324, -5e-324, 1e-310, -2.2250738585072014e-308,
                    1e-300, -1e-300, 1e300, -1e300, DMAX, -DMAX, np.pi, -np.pi, np.pi / 2, -np.pi / 2,
                    2 * np.pi, 1e-8, 1e8, 1e15, -1e16, 0.5, 1 + 2.0 ** -52, 1 - 2.0 ** -53])


class Violation(AssertionError):
    """The contract was broken (not a ValueError/TypeError refusal)."""


# ==== value generators: numpy, seeded from hypothesis ================================================

LEVELS = ("calm", "extreme", "poison", "wild")  # wild = extreme values with non-finite ones mixed in


def fill(rng, shape, level):
    """Numbers of a given level: calm = N(0, 1); extreme = a mixture of specials, subnormals, 1e±300,
    small integers and multiples of pi/2; wild adds NaN and ±inf."""
    n = int(np.prod(shape, dtype=np.int64))
    out = rng.standard_normal(n)
    if level in ("extreme", "wild") and n:
        cls = rng.integers(0, 10, n)
        sign = rng.choice([-1.0, 1.0], n)
        pick = cls == 4
        out[pick] = rng.choice(SPECIAL, int(pick.sum()))
        pick = cls == 5
        out[pick] = sign[pick] * 10.0 ** rng.uniform(-323, -15, int(pick.sum()))
        pick = cls == 6
        out[pick] = sign[pick] * 10.0 ** rng.uniform(15, 308, int(pick.sum()))
        pick = cls == 7
        out[pick] = rng.integers(-3, 4, int(pick.sum()))
        pick = cls == 8
        out[pick] = rng.integers(-8, 9, int(pick.sum())) * (np.pi / 2)
        if level == "wild":
            pick = (cls == 9) & (rng.random(n) < 0.3)
            out[pick] = rng.choice([NAN, INF, -INF], int(pick.sum()))
    return out.reshape(shape)


def unit_rows(rng, n):
    q = rng.standard_normal((n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def quats(rng, batch, level):
    """(…, 4) quaternions: unit, scaled by 10^±300, axis-aligned, near identity, raw extreme numbers."""
    n = int(np.prod(batch, dtype=np.int64))
    q = unit_rows(rng, n)
    if level in ("extreme", "wild") and n:
        kind = rng.integers(0, 6, n)
        scale = 10.0 ** rng.uniform(-299, 300, n)
        q[kind == 1] *= scale[kind == 1, None]
        axes = np.eye(4)[rng.integers(0, 4, n)] * rng.choice([-1.0, 1.0], (n, 1))
        q[kind == 2] = axes[kind == 2]
        eps = 10.0 ** rng.uniform(-300, -8, (n, 3)) * rng.choice([-1.0, 1.0], (n, 3))
        near = np.concatenate([np.ones((n, 1)), eps], axis=1)
        q[kind == 3] = near[kind == 3]
        raw = fill(rng, (n, 4), level)
        q[kind == 4] = raw[kind == 4]
    return q.reshape(tuple(batch) + (4,))


def hamilton(a, b):
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], -1)


def partner_quats(rng, a, level):
    """A second quaternion batch related to `a` row by row: the same, antipodal, 180° away, a hair
    away (1e-15), or independent."""
    if a.size == 0 or a.shape[:-1] == ():
        return quats(rng, a.shape[:-1], level)
    b = quats(rng, a.shape[:-1], level)
    flat_a, flat_b = a.reshape(-1, 4), b.reshape(-1, 4)
    rel = rng.integers(0, 5, flat_a.shape[0])
    with np.errstate(all="ignore"):
        flat_b[rel == 0] = flat_a[rel == 0]
        flat_b[rel == 1] = -flat_a[rel == 1]
        half = hamilton(flat_a, np.array([0.0, 1.0, 0.0, 0.0]))
        flat_b[rel == 2] = half[rel == 2]
        hair = flat_a * (1 + 1e-15 * rng.standard_normal(flat_a.shape))
        flat_b[rel == 3] = hair[rel == 3]
    return flat_b.reshape(a.shape)


def vecs(rng, batch, level):
    return fill(rng, tuple(batch) + (3,), "calm" if level == "poison" else level)


def scalars(rng, batch, level):
    return fill(rng, tuple(batch), "calm" if level == "poison" else level)


def angles(rng, batch, level):
    """(…, 3) Euler angles: calm within ±2π; extreme adds gimbal lock (±π/2 middle angle exactly),
    spins (k·2π), and large magnitudes up to 1e300."""
    a = rng.uniform(-2 * np.pi, 2 * np.pi, tuple(batch) + (3,))
    if level in ("extreme", "wild") and a.size:
        flat = a.reshape(-1, 3)
        n = flat.shape[0]
        kind = rng.integers(0, 6, n)
        mid = rng.integers(0, 3, n)
        flat[kind == 1, :] = rng.choice([-1.0, 1.0], ((kind == 1).sum(), 3)) * np.pi / 2
        flat[kind == 2] += rng.integers(-1000, 1000, ((kind == 2).sum(), 3)) * 2 * np.pi
        raw = fill(rng, (n, 3), level)
        flat[kind == 3] = raw[kind == 3]
        rows = np.nonzero(kind == 4)[0]
        flat[rows, mid[rows]] = rng.choice([-1.0, 1.0], rows.size) * np.pi / 2
    return a


def rotations(rng, batch, level):
    """(…, 3, 3) matrices: exact rotations, scaled (10^±300, non-uniform), sheared, perturbed,
    or raw numbers."""
    n = int(np.prod(batch, dtype=np.int64))
    m = quat_to_matrix_np(unit_rows(rng, n))
    if level in ("extreme", "wild") and n:
        kind = rng.integers(0, 6, n)
        m[kind == 1] *= (10.0 ** rng.uniform(-290, 290, n))[kind == 1, None, None]
        m[kind == 2] *= (10.0 ** rng.uniform(-5, 5, (n, 1, 3)))[kind == 2]
        shear = np.triu(rng.standard_normal((n, 3, 3)), 1)
        m[kind == 3] = (m + m @ shear)[kind == 3]
        m[kind == 4] += 1e-9 * rng.standard_normal((int((kind == 4).sum()), 3, 3))
        raw = fill(rng, (n, 3, 3), level)
        m[kind == 5] = raw[kind == 5]
    return m.reshape(tuple(batch) + (3, 3))


def transforms(rng, batch, level):
    """(…, 4, 4) homogeneous transforms; extreme adds huge translations and projective bottom rows."""
    r = rotations(rng, batch, level)
    m = np.zeros(tuple(batch) + (4, 4))
    m[..., :3, :3] = r
    m[..., :3, 3] = fill(rng, tuple(batch) + (3,), "calm" if level == "poison" else level)
    m[..., 3, 3] = 1.0
    if level in ("extreme", "wild") and m.size:
        flat = m.reshape(-1, 4, 4)
        proj = rng.random(flat.shape[0]) < 0.2
        flat[proj, 3, :] = fill(rng, (int(proj.sum()), 4), level)
    return m


def complex2(rng, batch, level):
    q = quats(rng, batch, level)
    w, x, y, z = np.moveaxis(q, -1, 0)
    m = np.stack([w + 1j * x, y + 1j * z, -y + 1j * z, w - 1j * x], -1).reshape(tuple(batch) + (2, 2))
    if level in ("extreme", "wild") and m.size:
        m = m + 1j * fill(rng, m.shape, level) * (rng.random(m.shape) < 0.2)
    return m


def real4(rng, batch, level):
    q = quats(rng, batch, level)
    w, x, y, z = np.moveaxis(q, -1, 0)
    rows = [w, -x, -y, -z, x, w, -z, y, y, z, w, -x, z, -y, x, w]
    m = np.stack(rows, -1).reshape(tuple(batch) + (4, 4))
    if level in ("extreme", "wild") and m.size:
        m = m + fill(rng, m.shape, level) * (rng.random(m.shape) < 0.1)
    return m


def quat_to_matrix_np(q):
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                     2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                     2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1
                    ).reshape(q.shape[:-1] + (3, 3))


KINDS = {  # argument kind -> (generator(rng, batch, level), element tail)
    "quat": (quats, (4,)), "vec": (vecs, (3,)), "scalar": (scalars, ()), "angles": (angles, (3,)),
    "mat3": (rotations, (3, 3)), "mat4": (transforms, (4, 4)), "complex2": (complex2, (2, 2)),
    "real4": (real4, (4, 4)),
}

# What makes an element invalid, per kind, in the "poison" level: one element per case.
POISON_VALUES = (NAN, INF, -INF)


def poison(rng, arr, kind, zero_ok):
    """Make one element of `arr` (in place) invalid: a non-finite number, or — where the argument
    must be nonzero — a zero or subnormal-length element."""
    if arr.size == 0:
        return False
    flat = arr.reshape(-1)
    tail = int(np.prod(KINDS[kind][1], dtype=np.int64)) if kind in KINDS else 1
    if not zero_ok and rng.random() < 0.4:
        row = rng.integers(0, max(1, flat.size // tail))
        flat[row * tail:(row + 1) * tail] = 0.0
        if rng.random() < 0.5:
            flat[row * tail] = rng.choice([5e-324, 1e-310, -1e-305])
        return True
    value = rng.choice(POISON_VALUES)
    flat[rng.integers(0, flat.size)] = value * (1j if arr.dtype.kind == "c" and rng.random() < 0.5 else 1)
    return True


# ---- times ---------------------------------------------------------------------------------------

TIME_MODES = ("unit", "random", "tiny", "huge", "offset", "subnormal", "span_overflow", "negative")


def increasing_times(rng, n, mode):
    """n strictly increasing finite times with a given spacing character."""
    if n == 0:
        return np.zeros(0)
    if mode == "unit":
        t = np.arange(n, dtype=float) + rng.integers(-100, 100)
    elif mode == "random":
        t = np.cumsum(rng.exponential(1.0, n) + 1e-3) - 5
    elif mode == "tiny":  # consecutive doubles
        t = np.empty(n)
        t[0] = rng.choice([0.0, 1.0, 1e6])
        for i in range(1, n):
            t[i] = np.nextafter(t[i - 1], INF)
    elif mode == "huge":
        t = np.linspace(-1e300, 1e300, n) if n > 1 else np.array([1e300])
    elif mode == "offset":
        t = 1e15 + np.arange(n, dtype=float)
    elif mode == "subnormal":
        t = np.arange(n, dtype=float) * 5e-324
    elif mode == "span_overflow":  # t[-1] - t[0] overflows
        t = np.linspace(-DMAX, DMAX, n) if n > 1 else np.array([DMAX])
    else:
        t = -np.cumsum(rng.exponential(1.0, n))[::-1].copy()
    return t


def break_times(rng, t):
    """Make strictly increasing times invalid: a duplicate, a swap, or a non-finite value."""
    t = t.copy()
    how = rng.integers(0, 3) if t.size > 1 else 2
    if how == 0:
        i = rng.integers(1, t.size)
        t[i] = t[i - 1]
    elif how == 1:
        i = rng.integers(1, t.size)
        t[i - 1], t[i] = t[i], t[i - 1]
    else:
        t[rng.integers(0, t.size)] = rng.choice(POISON_VALUES)
    return t


# ---- junk: wrong types, shapes and dtypes ---------------------------------------------------------

class Opaque:
    pass


def junk_values(tail):
    """Junk for an array argument with element shape `tail`: a list of (value, must_fail). must_fail
    is False for what numpy converts to valid numbers (lists, int/bool/float16/str-digit arrays,
    Fortran-order and strided arrays, masked arrays, datetimes)."""
    tail = tuple(tail)
    n = int(np.prod(tail, dtype=np.int64))

    def shaped(arr):
        return arr.reshape(tail)

    strided = np.ones((3,) + tail[:-1] + (2 * tail[-1],))[..., ::2] if tail else np.ones(6)[::2]
    out = [
        (None, True), ("abc", True), (b"\x00\x01\x02\x03", True), ({"a": 1}, True), (Opaque(), True),
        (shaped(np.array([Opaque()] * n, dtype=object)), True),
        (shaped(np.array(["x"] * n)), True),
        (np.array([[1.0, 2.0], [3.0]], dtype=object), True),
        (shaped(np.zeros(n, dtype=[("a", "f8"), ("b", "i4")])), True),
        ([2 ** 2000] * n, True),
        ([None] + [0.0] * (n - 1), True),
        (shaped(np.array(["1"] * n)), False),
        (np.zeros(tail).tolist() if tail else 0.5, False),
        ([np.zeros(tail).tolist()] * 2 if tail else [0.5, 1.0], False),
        (np.ones(tail, dtype=bool), False), (np.ones(tail, dtype=np.int8), False),
        (np.ones(tail, dtype=np.float16), False), (np.ones(tail, dtype=np.longdouble), False),
        (np.ones(tail, dtype=np.uint64), False), (np.asfortranarray(np.ones((3,) + tail)), False),
        (strided, False), (np.ones((4,) + tail)[::-1], False),
        (np.ma.masked_array(np.ones((2,) + tail), mask=True), False),
        (shaped(np.array(["2020-01-01"] * n, dtype="datetime64[D]")), False),
    ]
    if tail:
        for shape in (tail + (2,), (5,) + tuple(t + 1 for t in tail), (), (0,) * (len(tail) + 1)):
            out.append((np.zeros(shape), shape[len(shape) - len(tail):] != tail))
    return out


def junk_strings():
    """(value, must_fail) for a string argument (Euler order, method, interpolation)."""
    return [(None, True), (3, True), (b"XYZ", False), ("", True), ("xyz", True), ("XYZ ", True),
            ("X\x00YZ", True), ("\u00dc\u00df", True), ("ZZZ", True), ("XYZXYZ" * 1000, True),
            (["XYZ"], True), (np.str_("XYZ"), False)]


# ==== cases ========================================================================================

@dataclass
class Case:
    call: Callable[[], Any]
    rows: int
    check: Callable[[Any], None] = lambda out: None
    must_fail: str = ""      # why the call must raise ValueError/TypeError ("" = it may pass)
    out_bytes: int = 0       # nominal output size: above MEMORY_LIMIT a MemoryError is fine
    inputs: Any = None       # the arguments, for the failure report


class Draw:
    """Hypothesis draws for the structure of a case; a numpy Generator for the bulk values."""

    def __init__(self, data):
        self.data = data
        self.rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1), label="seed"))

    def pick(self, options, label=None):
        return self.data.draw(st.sampled_from(options), label=label)

    def chance(self, p, label=None):
        return self.data.draw(st.integers(0, 999), label=label) < p * 1000

    def level(self):
        return self.pick(("calm", "extreme", "extreme", "poison", "wild"), "level")

    def count(self, small=64, huge=200_000, label="count"):
        """Row counts: mostly log-uniform in [2, small], sometimes 0, 1 or 2, rarely huge (up to
        `huge`). Hypothesis picks the class, the seeded generator the number."""
        kind = self.pick(("small",) * 8 + ("tiny", "huge"), label + "_kind")
        if kind == "tiny":
            return self.pick((0, 1, 2), label)
        if kind == "huge" and self.chance(0.2, label + "_huge"):
            return int(self.rng.integers(huge // 4, huge + 1))
        return int(np.exp(self.rng.uniform(np.log(2), np.log(small + 1))))

    def batch_shapes(self, nargs, huge=100_000):
        """Batch shapes for nargs broadcasting arguments (sometimes not broadcastable)."""
        kind = self.pick(("same", "same", "scalar_vs", "outer", "ndim", "empty", "mismatch", "zero_d"),
                         "shape_kind")
        n = self.count(small=1000, huge=huge)
        if nargs == 1 and kind in ("scalar_vs", "outer", "mismatch"):
            kind = "same"
        if kind == "same":
            return [(n,)] * nargs
        if kind == "scalar_vs":
            shapes = [(n,)] * nargs
            shapes[self.data.draw(st.integers(0, nargs - 1))] = ()
            return shapes
        if kind == "outer" and nargs > 1:
            a = self.data.draw(st.integers(1, 12))
            return [(a, 1)] + [(1, min(n, 64))] * (nargs - 1)
        if kind == "ndim":
            dims = tuple(self.data.draw(st.lists(st.integers(1, 3), min_size=2, max_size=6)))
            return [dims] * nargs
        if kind == "empty":
            return [(0,)] + [(1,)] * (nargs - 1) if self.chance(0.5) else [(2 ** 40, 0)] + [(0,)] * (nargs - 1)
        if kind == "mismatch" and nargs > 1:
            return [(n + 1,)] + [(n + 2,)] * (nargs - 1)
        return [()] * nargs


def broadcast_or_none(shapes):
    try:
        return np.broadcast_shapes(*shapes)
    except ValueError:
        return None


# ---- output checks --------------------------------------------------------------------------------

def expect(cond, message):
    """Raise Violation(message) unless cond; message may be a callable (built only on failure)."""
    if not cond:
        raise Violation(message() if callable(message) else message)


def finite(out, what="output", allow_nan=False, allow_posinf=False):
    a = np.asarray(out)
    expect(a.dtype.kind in "fciub", f"{what}: dtype {a.dtype}")
    bad = ~np.isfinite(a)
    if allow_nan:
        bad &= ~np.isnan(a)
    if allow_posinf:
        bad &= ~(np.isposinf(a) if a.dtype.kind != "c" else np.zeros_like(bad))
    if bad.any():
        idx = np.argwhere(bad)[0] if a.ndim else ()
        raise Violation(f"{what}: non-finite value {a[tuple(idx)]!r} at {tuple(int(i) for i in idx)}"
                        f" (shape {a.shape})")


def unit(out, what="output"):
    finite(out, what)
    n = np.linalg.norm(np.asarray(out), axis=-1)
    if n.size and np.max(np.abs(n - 1)) > UNIT_TOL:
        i = np.unravel_index(np.argmax(np.abs(n - 1)), n.shape)
        raise Violation(f"{what}: quaternion of length {n[i]!r} at {tuple(int(k) for k in i)}")


def shape_is(out, shape, what="output"):
    expect(isinstance(out, np.ndarray), f"{what}: not an ndarray but {type(out).__name__}")
    expect(out.shape == tuple(shape), f"{what}: shape {out.shape}, expected {tuple(shape)}")


def in_range(out, lo, hi, what="output", slack=1e-12):
    finite(out, what)
    a = np.asarray(out)
    if a.size and (a.min() < lo - slack or a.max() > hi + slack):
        raise Violation(f"{what}: values in [{a.min()!r}, {a.max()!r}], expected [{lo}, {hi}]")


def rotation_matrix(out, what="output"):
    finite(out, what)
    m = np.asarray(out)
    if m.size:
        err = np.abs(m @ np.swapaxes(m, -1, -2) - np.eye(3)).max()
        expect(err < 1e-9, f"{what}: not orthonormal (|M Mᵀ - I| = {err!r})")
        expect(np.abs(np.linalg.det(m) - 1).max() < 1e-9, f"{what}: det != 1")


def np_angle(a, b):
    """Geodesic rotation angle between quaternion arrays (sign-invariant), scaled safely."""
    a = a / np.abs(a).max(-1, keepdims=True)
    b = b / np.abs(b).max(-1, keepdims=True)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    d, s = np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1)
    return 4 * np.arctan2(np.minimum(d, s), np.maximum(d, s))


OUT_CHECKS = {  # output kind -> (element tail, checker(out))
    "quat": ((4,), finite), "unit": ((4,), unit), "vec": ((3,), finite), "scalar": ((), finite),
    "angle_pi": ((), lambda o: in_range(o, 0, np.pi)), "gimbal": ((), lambda o: in_range(o, 0, np.pi / 2)),
    "norm": ((), lambda o: in_range(o, 0, DMAX)), "rot3": ((3, 3), rotation_matrix),
    "mat4": ((4, 4), finite), "complex2": ((2, 2), finite), "angles": ((3,), finite),
    "rot4": ((4, 4), lambda o: (rotation_matrix(np.asarray(o)[..., :3, :3]), finite(o),
                                expect(np.all(np.asarray(o)[..., 3, :] == [0, 0, 0, 1]), "bottom row"))),
    "log": ((4,), lambda o: (finite(o), in_range(np.linalg.norm(np.asarray(o)[..., 1:], axis=-1), 0, np.pi,
                                                 "log vector part"))),
}


# ---- elementwise (broadcasting) core functions -------------------------------------------------------

@dataclass
class Elementwise:
    """A core function: array arguments of given kinds whose batch dimensions broadcast, an optional
    Euler order, an output kind, and which arguments must be nonzero (zero-length refused)."""
    args: tuple            # (name, kind, refuses_zero)
    out: str | tuple       # output kind, or a tuple of kinds for tuple results
    order: bool = False
    extra: Callable | None = None   # extra check(out, arrays)
    pair: bool = False     # second quaternion argument derived from the first (antipodal, …)
    optional: tuple = ()   # names of arguments for which None is valid

    def build(self, fn, d: Draw) -> Case:
        rng, level = d.rng, d.level()
        shapes = d.batch_shapes(len(self.args))
        arrays = []
        for i, ((_, kind, _), shape) in enumerate(zip(self.args, shapes)):
            gen = KINDS[kind][0]
            a = gen(rng, shape, "extreme" if level == "poison" else level)
            if self.pair and i == 1 and kind == "quat" and arrays and arrays[0].shape == a.shape:
                a = partner_quats(rng, arrays[0], level)
            arrays.append(np.require(a, requirements="C"))
        batch = broadcast_or_none(shapes)
        rows = int(np.prod(batch)) if batch is not None else sum(int(np.prod(s)) for s in shapes)
        must_fail = ""
        if batch is None:
            must_fail = f"batch shapes {shapes} do not broadcast"
        if d.chance(0.08, "junk_arg"):
            k = d.data.draw(st.integers(0, len(arrays) - 1), label="junk_index")
            value, bad = d.pick(junk_values(KINDS[self.args[k][1]][1]), "junk")
            arrays[k] = value
            bad = bad and not (value is None and self.args[k][0] in self.optional)
            # junk meets no element when another argument is empty (numpy makes None a 0-d nan)
            bad = bad and all(np.size(a) for i, a in enumerate(arrays) if i != k)
            must_fail = f"{self.args[k][0]}={type(value).__name__} junk" if bad else ""
            batch = None
        elif level == "wild" and rows:
            if any(not np.all(np.isfinite(a)) for a in arrays):
                must_fail = must_fail or "a non-finite element"
        elif level == "poison" and rows:
            k = d.data.draw(st.integers(0, len(arrays) - 1), label="poisoned_arg")
            if poison(rng, arrays[k], self.args[k][1], not self.args[k][2]):
                must_fail = must_fail or f"{self.args[k][0]} poisoned"
        kwargs = {}
        if self.order:
            if d.chance(0.1, "junk_order"):
                kwargs["order"], bad = d.pick(junk_strings(), "order")
                must_fail = f"order={kwargs['order']!r}" if bad else ""
            else:
                kwargs["order"] = d.pick(ORDERS, "order")
        tails = (OUT_CHECKS[self.out][0] if isinstance(self.out, str) else None)
        out_bytes = rows * 8 * (int(np.prod(tails)) if tails else 4)

        def check(out):
            kinds = (self.out,) if isinstance(self.out, str) else self.out
            outs = (out,) if isinstance(self.out, str) else out
            expect(isinstance(outs, tuple) and len(outs) == len(kinds), f"result {type(out).__name__}")
            for o, kind in zip(outs, kinds):
                tail, checker = OUT_CHECKS[kind]
                if batch is not None:
                    shape_is(o, tuple(batch) + tail, kind)
                checker(o)
            if self.extra is not None and batch is not None and rows:
                self.extra(out, arrays)

        return Case(lambda: fn(*arrays, **kwargs), rows, check, must_fail, out_bytes, (arrays, kwargs))


def same_direction(out, arrays):
    """quat_normalize keeps the sign: out · q > 0."""
    q = np.broadcast_to(arrays[0], out.shape)
    qs = q / np.abs(q).max(-1, keepdims=True)
    expect(np.all(np.sum(out * qs, -1) > 0), "quat_normalize flipped a sign")


def length_kept(out, arrays):
    """Rotation keeps vector length (relative 1e-9)."""
    v = np.broadcast_to(arrays[1], out.shape)
    scale = np.abs(v).max(-1, keepdims=True)
    scale[scale == 0] = 1
    ln, lo = np.linalg.norm(v / scale, axis=-1), np.linalg.norm(out / scale, axis=-1)
    err = np.abs(ln - lo) / np.maximum(ln, 1e-300)
    expect(np.all((err < 1e-9) | (ln < 1e-280)), f"rotation changed a length by {np.nanmax(err)!r}")


def axis_angle_ranges(out, arrays):
    axis, angle = out
    unit(np.concatenate([axis, np.zeros(axis.shape[:-1] + (1,))], -1), "axis")
    in_range(angle, 0, 2 * np.pi, "angle")


def euler_ranges(out, arrays):
    """Without compat: middle angle in [-π/2, π/2], the others in [-π, π]."""
    in_range(np.abs(out), 0, np.pi, "euler angles", slack=1e-12)


ELEMENTWISE = {
    "quat_multiply": Elementwise((("a", "quat", False), ("b", "quat", False)), "quat", pair=True),
    "quat_conjugate": Elementwise((("q", "quat", False),), "quat"),
    "quat_inverse": Elementwise((("q", "quat", True),), "quat"),
    "quat_divide": Elementwise((("a", "quat", False), ("b", "quat", True)), "quat", pair=True),
    "quat_norm": Elementwise((("q", "quat", False),), "norm"),
    "quat_normalize": Elementwise((("q", "quat", True),), "unit", extra=same_direction),
    "quat_exp": Elementwise((("q", "quat", False),), "quat"),
    "quat_log": Elementwise((("q", "quat", True),), "log"),
    "quat_pow": Elementwise((("q", "quat", True), ("t", "scalar", False)), "quat"),
    "quat_rotate": Elementwise((("q", "quat", True), ("v", "vec", False)), "vec", extra=length_kept),
    "quat_rotate_sandwich": Elementwise((("q", "quat", True), ("v", "vec", False)), "vec", extra=length_kept),
    "axis_angle_to_quat": Elementwise((("axis", "vec", True), ("angle", "scalar", False)), "unit"),
    "quat_to_axis_angle": Elementwise((("q", "quat", True),), ("vec", "scalar"), extra=axis_angle_ranges),
    "angle_between": Elementwise((("a", "quat", True), ("b", "quat", True)), "angle_pi", pair=True),
    "quat_to_matrix": Elementwise((("q", "quat", True),), "rot3"),
    "matrix_to_quat": Elementwise((("m", "mat3", True),), "unit"),
    "nearest_rotation": Elementwise((("m", "mat3", True),), "rot3"),
    "translation_matrix": Elementwise((("t", "vec", False),), "mat4"),
    "scale_matrix": Elementwise((("s", "vec", False),), "mat4"),
    "rotation_matrix4": Elementwise((("q", "quat", True),), "rot4"),
    "transform_points": Elementwise((("M", "mat4", True), ("P", "vec", False)), "vec"),
    "transform_directions": Elementwise((("M", "mat4", False), ("D", "vec", False)), "vec"),
    "quat_to_complex2": Elementwise((("q", "quat", False),), "complex2"),
    "complex2_to_quat": Elementwise((("m", "complex2", False),), "quat"),
    "quat_to_real4": Elementwise((("q", "quat", False),), "mat4"),
    "real4_to_quat": Elementwise((("m", "real4", False),), "quat"),
    "euler_to_quat": Elementwise((("angles", "angles", False),), "unit", order=True),
    "euler_to_matrix": Elementwise((("angles", "angles", False),), "rot3", order=True),
    "matrix_to_euler": Elementwise((("m", "mat3", True),), "angles", order=True, extra=euler_ranges),
    "euler_compat": Elementwise((("angles", "angles", False), ("ref", "angles", False)), "angles", order=True),
    "gimbal_distance": Elementwise((("angles", "angles", False),), "gimbal", order=True),
}


def build_quat_to_euler(fn, d: Draw) -> Case:
    """quat_to_euler(q, order, compat=None): without compat as an elementwise function; with compat a
    broadcasting pair (q, compat)."""
    if d.chance(0.5, "with_compat"):
        spec = Elementwise((("q", "quat", True), ("compat", "angles", False)), "angles", order=True,
                           optional=("compat",))
        case = spec.build(lambda q, c, **kw: fn(q, compat=c, **kw), d)
    else:
        spec = Elementwise((("q", "quat", True),), "angles", order=True, extra=euler_ranges)
        case = spec.build(fn, d)
    return case


def build_euler_filter(fn, d: Draw) -> Case:
    """euler_filter(angles (…, N, 3), order): sequences with spins, gimbal lock, huge angles."""
    rng, level = d.rng, d.level()
    n = d.count(small=200, huge=100_000)
    lead = d.pick(((), (), (3,), (2, 2), (0,)), "lead")
    shape = tuple(lead) + (n,)
    a = angles(rng, shape, "extreme" if level == "poison" else level)
    if d.chance(0.3, "smooth") and n:
        a = np.cumsum(rng.normal(0, 0.5, tuple(lead) + (n, 3)), axis=-2)
    must_fail = ""
    rows = int(np.prod(shape))
    if level == "wild" and not np.all(np.isfinite(a)) and rows:
        must_fail = "non-finite"
    if level == "poison" and rows:
        poison(rng, a, "angles", True)
        must_fail = "poisoned"
    order = d.pick(ORDERS, "order")
    arg: Any = a
    if d.chance(0.08, "junk"):
        arg, bad = d.pick(junk_values((3,)), "junk")
        must_fail = "junk" if bad else ""

    def check(out):
        if arg is a:
            shape_is(out, a.shape)
        finite(out)
        if arg is a and rows and np.all(np.abs(a) < 1e6):
            # the filter changes no orientation
            err = np_angle(qc.euler_to_quat(out, order), qc.euler_to_quat(a, order)).max()
            expect(err < 1e-6, f"euler_filter changed an orientation by {err!r} rad")

    return Case(lambda: fn(arg, order), max(rows, 1), check, must_fail, rows * 24, (arg, order))


def build_euler_middle_axis(fn, d: Draw) -> Case:
    if d.chance(0.5, "valid"):
        order = d.pick(ORDERS, "order")
        return Case(lambda: fn(order), 1, lambda out: expect(out in (0, 1, 2), f"axis {out!r}"))
    value, bad = d.pick(junk_strings(), "order")
    return Case(lambda: fn(value), 1, lambda out: expect(out in (0, 1, 2), f"axis {out!r}"),
                "junk order" if bad else "")


# ---- metrics: paths (N,) times, (N, 4) quats, key times ------------------------------------------------

@dataclass
class Path:
    times: np.ndarray
    quats: np.ndarray
    keys: np.ndarray
    must_fail: str
    rows: int


def draw_path(d: Draw, small=120, huge=50_000) -> Path:
    rng = d.rng
    level = d.level()
    n = d.count(small=small, huge=huge)
    tmode = d.pick(TIME_MODES, "time_mode")
    t = increasing_times(rng, n, tmode)
    qmode = d.pick(("random", "smooth", "antipodal", "constant", "extreme"), "quat_mode")
    if qmode == "smooth" and n:
        q = qc.quat_normalize(np.cumsum(rng.normal(0, 0.05, (n, 4)), 0) + [4, 0, 0, 0])
    elif qmode == "antipodal" and n:
        q = unit_rows(rng, n)
        q[1::2] = -q[0::2][: q[1::2].shape[0]]
    elif qmode == "constant" and n:
        q = np.tile(unit_rows(rng, 1), (n, 1))
    else:
        q = quats(rng, (n,), "extreme" if qmode == "extreme" else "calm")
    must_fail = ""
    if n and rng.random() < 0.5:
        keys = np.unique(np.concatenate([t[[0, -1]], rng.choice(t, min(n, rng.integers(0, 8)))]))
    else:
        keys = t[[0, -1]] if n > 1 else t[:n].copy()
    if level == "poison" and n:
        what = d.pick(("times", "quats", "keys"), "poison_what")
        if what == "times":
            t = break_times(rng, t)
        elif what == "quats":
            poison(rng, q, "quat", False)
        else:
            keys = keys.copy()
            if keys.size == 0:
                keys = np.array([NAN])
            else:
                keys[rng.integers(0, keys.size)] = rng.choice([NAN, INF, t[0] - 1.0, 0.5 * (t[0] + t[-1]) + 0.1234])
            # a key between samples is refused; one that happens to hit a sample is fine
            if np.all(np.isin(keys, t)) and np.all(np.diff(keys) > 0):
                what = ""
        must_fail = f"poisoned {what}" if what else ""
    if level == "wild" and n:
        q = quats(rng, (n,), "wild")
        if not np.all(np.isfinite(q)):
            must_fail = "non-finite quats"
    return Path(np.ascontiguousarray(t), np.ascontiguousarray(q), np.ascontiguousarray(keys), must_fail, n)


def maybe_junk(d: Draw, args: list, tails: list, names: list, must_fail: str) -> str:
    """Replace one of the first len(tails) arguments by junk with probability 0.08. Returns the new
    must_fail reason: the junk's, or "" for junk numpy may convert (the other reason may be gone)."""
    if not d.chance(0.08, "junk_arg"):
        return must_fail
    k = d.data.draw(st.integers(0, len(tails) - 1), label="junk_index")
    value, bad = d.pick(junk_values(tails[k]), "junk")
    args[k] = value
    return f"{names[k]} junk ({type(value).__name__})" if bad else ""


def needs(cond, reason):
    return "" if cond else reason


def build_angular_deviation(fn, d):
    p = draw_path(d)
    ref = partner_quats(d.rng, p.quats, "calm") if p.rows else p.quats.copy()
    args = [p.quats, ref]
    must_fail = p.must_fail if "quats" in p.must_fail or "non-finite" in p.must_fail else ""
    if d.chance(0.1, "mismatch"):
        args[1] = ref[:-1] if ref.shape[0] else np.zeros((1, 4))
        must_fail = must_fail or "lengths differ"
    given = list(args)
    must_fail = maybe_junk(d, args, [(4,), (4,)], ["quats", "reference"], must_fail)

    def check(out):
        if all(a is g for a, g in zip(args, given)):
            shape_is(out, (p.rows,))
        in_range(out, 0, np.pi)
    return Case(lambda: fn(*args), max(p.rows, 1), check, must_fail, p.rows * 8, args)


def path_only_fail(p: Path, *parts):
    return p.must_fail if any(x in p.must_fail for x in parts) else ""


def build_interval_speeds(fn, d):
    p = draw_path(d)
    args = [p.times, p.quats]
    must_fail = path_only_fail(p, "times", "quats") or needs(p.rows >= 2, "fewer than 2 samples")
    given = list(args)
    must_fail = maybe_junk(d, args, [(), (4,)], ["times", "quats"], must_fail)

    def check(out):
        if all(a is g for a, g in zip(args, given)):
            shape_is(out, (p.rows - 1,))
        in_range(out, 0, DMAX, "speeds")
    return Case(lambda: fn(*args), max(p.rows, 1), check, must_fail, p.rows * 8, args)


def build_segment_speed_ratios(fn, d):
    p = draw_path(d)
    args = [p.times, p.quats, p.keys]
    must_fail = p.must_fail
    given = list(args)
    must_fail = maybe_junk(d, args, [(), (4,), ()], ["times", "quats", "key_times"], must_fail)

    def check(out):
        if all(a is g for a, g in zip(args, given)):
            shape_is(out, (max(p.keys.size - 1, 0),))
        finite(out, "speed ratios", allow_posinf=True)
        expect(np.all(out >= 1 - 1e-12), f"speed ratio below 1: {out.min()!r}")
    return Case(lambda: fn(*args), max(p.rows, 1), check, must_fail, p.rows * 8, args)


def build_segment_speed_ratios_from_velocity(fn, d):
    p = draw_path(d)
    vel = vecs(d.rng, (p.rows,), d.pick(("calm", "extreme"), "vel_level"))
    args = [p.times, vel, p.keys]
    must_fail = path_only_fail(p, "times", "keys")
    if "quats" in p.must_fail and p.rows:
        poison(d.rng, vel, "vec", True)
        must_fail = "poisoned velocities"
    given = list(args)
    must_fail = maybe_junk(d, args, [(), (3,), ()], ["times", "velocities", "key_times"], must_fail)

    def check(out):
        if all(a is g for a, g in zip(args, given)):
            shape_is(out, (max(p.keys.size - 1, 0),))
        finite(out, "speed ratios", allow_nan=True, allow_posinf=True)
        ok = out[~np.isnan(out)]
        expect(np.all(ok >= 1 - 1e-12), f"speed ratio below 1: {ok.min() if ok.size else None!r}")
    return Case(lambda: fn(*args), max(p.rows, 1), check, must_fail, p.rows * 8, args)


def build_path_length(fn, d):
    p = draw_path(d)
    args = [p.quats]
    must_fail = path_only_fail(p, "quats", "non-finite")
    must_fail = maybe_junk(d, args, [(4,)], ["quats"], must_fail)

    def check(out):
        expect(isinstance(out, float), f"path_length returned {type(out).__name__}")
        in_range(out, 0, np.pi * max(p.rows, 1), "path length")
    return Case(lambda: fn(*args), max(p.rows, 1), check, must_fail, 0, args)


def build_key_jumps(fn, d):
    p = draw_path(d)
    args = [p.times, p.quats, p.keys]
    given = list(args)
    must_fail = maybe_junk(d, args, [(), (4,), ()], ["times", "quats", "key_times"], p.must_fail)

    def check(out):
        expect(isinstance(out, tuple) and len(out) == 2, "key_jumps: not a pair")
        for name, o in zip(("velocity", "acceleration"), out):
            if all(a is g for a, g in zip(args, given)):
                shape_is(o, (p.keys.size,), name)
            finite(o, name + " jumps", allow_nan=True)
            in_range(o[~np.isnan(o)], 0, DMAX, name + " jumps")
    return Case(lambda: fn(*args), max(p.rows, 1), check, must_fail, p.rows * 8, args)


def build_gimbal_distances(fn, d):
    rng, level = d.rng, d.level()
    n = d.count(small=200, huge=100_000)
    a = angles(rng, (n,), "extreme" if level == "poison" else level)
    must_fail = "non-finite" if level == "wild" and not np.all(np.isfinite(a)) else ""
    if level == "poison" and n:
        poison(rng, a, "angles", True)
        must_fail = "poisoned"
    args = [a, d.pick(ORDERS, "order")]
    generated = a
    if d.chance(0.05, "junk_order"):
        args[1], bad = d.pick(junk_strings(), "order")
        must_fail = must_fail or ("junk order" if bad else "")
    must_fail = maybe_junk(d, args, [(3,)], ["angles"], must_fail)

    def check(out):
        if args[0] is generated:
            shape_is(out, (n,))
        in_range(out, 0, np.pi / 2)
    return Case(lambda: fn(*args), max(n, 1), check, must_fail, n * 8, args)


def build_gimbal_distances_from_quats(fn, d):
    rng, level = d.rng, d.level()
    n = d.count(small=200, huge=100_000)
    q = quats(rng, (n,), "extreme" if level == "poison" else level)
    must_fail = "non-finite" if level == "wild" and not np.all(np.isfinite(q)) else ""
    if level == "poison" and n:
        poison(rng, q, "quat", False)
        must_fail = "poisoned"
    args = [q, d.pick(ORDERS, "order")]
    generated = q
    must_fail = maybe_junk(d, args, [(4,)], ["quats"], must_fail)

    def check(out):
        if args[0] is generated:
            shape_is(out, (n,))
        in_range(out, 0, np.pi / 2)
    return Case(lambda: fn(*args), max(n, 1), check, must_fail, n * 8, args)


def build_closest_gimbal_approach(fn, d):
    rng = d.rng
    p = draw_path(d)
    dist = np.abs(scalars(rng, (p.rows,), d.pick(("calm", "extreme"), "dist_level")))
    tol = d.pick((0.0, 1e-6, 0.1, 1e300, -1.0, NAN, INF), "tolerance")
    args = [p.times, dist, tol]
    must_fail = ("non-finite times" if not np.all(np.isfinite(p.times)) else "") or needs(p.rows >= 1, "no samples") or \
        needs(math.isfinite(tol) and tol >= 0, f"tolerance {tol}")
    if d.chance(0.15, "bad_distance") and p.rows:
        dist[rng.integers(0, p.rows)] = rng.choice([NAN, INF])
        must_fail = must_fail or "bad distance"
    must_fail = maybe_junk(d, args, [(), ()], ["times", "distances"], must_fail)

    def check(out):
        expect(isinstance(out, tuple) and len(out) == 2, "not a pair")
        finite(out[0], "distance")
        finite(out[1], "times")
        expect(out[1].size >= 1, "no time of closest approach")
    return Case(lambda: fn(*args), max(p.rows, 1), check, must_fail, p.rows * 8, args)


def build_path_metrics(fn, d):
    p = draw_path(d)
    ref = partner_quats(d.rng, p.quats, "calm") if p.rows else p.quats.copy()
    key_quats = None
    if d.chance(0.4, "key_quats"):
        key_quats = quats(d.rng, (p.keys.size,), d.pick(("calm", "extreme"), "kq_level"))
    args = [p.times, p.quats, p.keys, ref, key_quats]
    must_fail = p.must_fail or needs(p.rows >= 1, "no samples")
    must_fail = maybe_junk(d, args, [(), (4,), (), (4,), (4,)],
                           ["times", "quats", "key_times", "reference", "key_quats"], must_fail)

    def check(out):
        expect(isinstance(out, dict), "path_metrics: not a dict")
        for k, v in out.items():
            if k in ("velocity_jumps", "acceleration_jumps"):
                finite(v, k, allow_nan=True)
            elif k in ("segment_speed_ratios", "speed_ratio", "path_length_ratio"):
                finite(v, k, allow_posinf=True)
            else:
                finite(v, k)
    return Case(lambda: fn(*args), max(p.rows, 1), check, must_fail, p.rows * 64, args)


# ---- key reduction --------------------------------------------------------------------------------

def check_indices(idx, n, what):
    shape_is(idx, idx.shape, what)
    expect(idx.dtype.kind == "i", f"{what}: dtype {idx.dtype}")
    expect(idx.ndim == 1 and idx.size >= min(n, 2 if n > 1 else 1), f"{what}: {idx.size} indices for {n}")
    if idx.size:
        expect(idx[0] == 0 and idx[-1] == n - 1, f"{what}: first/last sample not kept")
        expect(np.all(np.diff(idx) > 0), f"{what}: indices not increasing")


def frames_distinct(frames, what):
    """Blender stores frames as float32: kept keys must stay distinct there (two keys on one frame)."""
    f32 = np.asarray(frames, dtype=np.float64).astype(np.float32)
    finite(f32.astype(np.float64), f"{what} (as float32)")
    expect(np.all(np.diff(f32) > 0), lambda: f"{what}: two kept keys on one float32 frame "
                                             f"({f32[np.nonzero(np.diff(f32) <= 0)[0][0]]!r})")


def axis_angle_rows(rng, v):
    """Quaternion-shaped rows (N, 4) as axis-angle channels (angle, axis): the first column scaled to
    angles over several turns, the axis as drawn (rows whose axis is zero stay zero)."""
    out = np.array(v, dtype=np.float64, copy=True)
    if out.size:
        with np.errstate(all="ignore"):
            out[:, 0] = out[:, 0] * 7.0
    return out


def zero_axis(v):
    """Some row of axis-angle channels v has a zero axis (no rotation axis defined)."""
    return bool(np.size(v)) and bool(np.any(np.all(np.asarray(v)[:, 1:] == 0, axis=1)))


def draw_samples(d, euler, axis_angle=False):
    """Dense samples for the reducer and the fitter: (t, values, tolerance, must_fail); axis_angle:
    (angle, x, y, z) rows."""
    rng = d.rng
    level = d.level()
    n = d.count(small=300, huge=20_000)
    tmode = d.pick(TIME_MODES, "time_mode")
    t = increasing_times(rng, n, tmode)
    width = 3 if euler else 4
    vmode = d.pick(("smooth", "noise", "constant", "extreme", "spin"), "value_mode")
    if vmode == "smooth" and n:
        v = np.cumsum(rng.normal(0, 0.02, (n, width)), 0)
        v = v + ([0.0] * 3 if euler else [3.0, 0, 0, 0])
    elif vmode == "spin" and n:
        v = np.zeros((n, width))
        v[:, 0] = np.linspace(0, 40 * np.pi, n) if euler else np.cos(np.linspace(0, 20 * np.pi, n))
        if not euler:
            v[:, 3] = np.sin(np.linspace(0, 20 * np.pi, n))
    elif vmode == "constant" and n:
        v = np.tile(rng.normal(0, 1, (1, width)) + (0 if euler else 2), (n, 1))
    elif vmode == "extreme":
        v = angles(rng, (n,), "extreme") if euler else quats(rng, (n,), "extreme")
    else:
        v = angles(rng, (n,), "calm") if euler else quats(rng, (n,), "calm")
    tol = d.pick((0.0, 1e-9, 1e-7, 1e-4, 0.01, 0.1, 1.0, 4.0, 1e300), "tolerance")
    must_fail = needs(n >= 1, "no samples")
    if level == "poison" and n:
        what = d.pick(("times", "values", "tolerance"), "poison_what")
        if what == "times":
            t = break_times(rng, t)
        elif what == "values":
            poison(rng, v, "angles" if euler else "quat", euler)
        else:
            tol = d.pick((-1e-9, -1.0, NAN, INF, -INF), "bad_tolerance")
        must_fail = must_fail or f"poisoned {what}"
    if axis_angle:
        v = axis_angle_rows(rng, v)
        if vmode == "spin" and n:
            v[:, 1:] = [0.0, 0.3, 1.0]
            v[:, 0] = np.linspace(0, 40 * np.pi, n)
        must_fail = must_fail or ("zero axis" if zero_axis(v) else "")
    return t, v, tol, must_fail


def build_reduce(fn, d, euler, axis_angle=False):
    t, v, tol, must_fail = draw_samples(d, euler, axis_angle)
    n, width = len(t), 3 if euler else 4
    interpolation = d.pick(("LINEAR", "BEZIER"), "interpolation")
    synchronized = d.pick((True, False), "synchronized")
    args = [t, v] + ([d.pick(ORDERS, "order")] if euler else []) + [tol, interpolation, synchronized]
    kwargs = {"detailed": True} if d.chance(0.3, "detailed") else {}
    if d.chance(0.08, "junk_string"):
        k = 2 if euler and d.chance(0.5) else len(args) - 2
        args[k], bad = d.pick(junk_strings(), "junk_string")
        must_fail = must_fail or (f"junk string {args[k]!r}" if bad else "")
    if d.chance(0.05, "length_mismatch") and n:
        args[1] = v[:-1]
        must_fail = must_fail or "lengths differ"
    must_fail = maybe_junk(d, args, [(), (width,)],
                           ["times", "angles" if euler else "values" if axis_angle else "quats"], must_fail)
    if d.chance(0.04, "junk_tolerance"):
        k = 3 if euler else 2
        args[k], bad = d.pick([("0.1", True), (None, True), (np.float64(0.1), False), (True, False),
                               (np.array([0.1]), False), ([0.1], True)], "junk_tolerance")
        must_fail = must_fail or ("junk tolerance" if bad else "")

    def check(out):
        if isinstance(out, np.ndarray):
            check_indices(out, n, "indices")
            frames_distinct(t[out], "kept frames")
        elif isinstance(out, list):
            expect(len(out) == width, f"{len(out)} channels")
            for c, idx in enumerate(out):
                check_indices(idx, n, f"channel {c} indices")
                frames_distinct(t[idx], f"channel {c} frames")
        else:
            expect(type(out).__name__ == "ReducedKeys", f"result {type(out).__name__}")
            expect(len(out.channels) == width, f"{len(out.channels)} channels")
            finite(out.max_error, "max_error")
            expect(out.max_error <= max(tol, 1e-6), f"max_error {out.max_error!r} above tolerance {tol!r}")
            expect(out.key_count == sum(len(c) for c in out.channels), "key_count")
            for c, ch in enumerate(out.channels):
                check_indices(ch.indices, n, f"channel {c} indices")
                for name in ("frames", "values", "handle_left", "handle_right"):
                    finite(getattr(ch, name), f"channel {c} {name}")
                frames_distinct(ch.frames, f"channel {c} frames")
                handles = len(ch) if out.interpolation == "BEZIER" else 0
                expect(ch.handle_left.shape == (handles, 2), f"channel {c} handle_left shape {ch.handle_left.shape}")
            repr(out)
            repr(out.channels[0])

    return Case(lambda: fn(*args, **kwargs), max(n, 1), check, must_fail, 0, (args, kwargs))


def build_reduce_slerp(fn, d):
    """reduce_slerp: glTF LINEAR keys among dense quaternion samples; every sample within the tolerance
    of the kept keys' glTF slerp (checked here with the same formula written in numpy)."""
    t, v, tol, must_fail = draw_samples(d, euler=False)
    n = len(t)
    args = [t, v, tol]
    kwargs = {}
    # a loop: the last sample made the first's rotation (either sign), or left open (refused)
    if d.chance(0.2, "cyclic"):
        kwargs["cyclic"] = True
        if n >= 2 and not must_fail and isinstance(v, np.ndarray) and v.shape == (n, 4):
            v = v.copy()
            if d.chance(0.8, "closed"):
                v[-1] = v[0] * d.pick((1.0, -1.0, 2.5), "close_scale")
            else:
                a = v[0] / np.linalg.norm(v[0])
                b = v[-1] / np.linalg.norm(v[-1])
                if np_angle(a, b) > 1e-4:
                    must_fail = "loop not closed"
            args[1] = v
    if d.chance(0.05, "length_mismatch") and n:
        args[1] = v[:-1]
        must_fail = must_fail or "lengths differ"
    must_fail = maybe_junk(d, args, [(), (4,), ()], ["times", "quats", "tolerance"], must_fail)

    def check(out):
        expect(type(out).__name__ == "SlerpKeys", f"result {type(out).__name__}")
        check_indices(out.indices, n, "indices")
        k = len(out.indices)
        expect(k >= 1 and out.indices[0] == 0 and out.indices[-1] == n - 1, "first and last samples kept")
        if kwargs.get("cyclic") and k >= 2:
            expect(np_angle(out.quats[0], out.quats[-1]) < 1e-15, "loop: the last key is not the first rotation")
        shape_is(out.quats, (k, 4), "quats")
        finite(out.quats, "quats")
        expect(np.allclose(np.linalg.norm(out.quats, axis=1), 1.0, atol=1e-12), "keys not unit")
        expect(np.all(np.sum(out.quats[1:] * out.quats[:-1], axis=1) >= 0), "keys not sign-continuous")
        finite(out.max_error, "max_error")
        expect(out.max_error <= tol or tol == 0 and out.max_error < 1e-12,
               f"max_error {out.max_error!r} above tolerance {tol!r}")
        if n <= 2000 and k >= 2:
            # glTF 2.0 Appendix C: slerp the short way between consecutive keys at each sample's time.
            seg = np.clip(np.searchsorted(t[out.indices], t, side="right") - 1, 0, k - 2)
            a, b = out.quats[seg], out.quats[seg + 1]
            u = (t - t[out.indices][seg]) / (t[out.indices][seg + 1] - t[out.indices][seg])
            dot = np.sum(a * b, axis=1)
            b = np.where(dot[:, None] < 0, -b, b)
            theta = np.arccos(np.clip(np.abs(dot), -1, 1))
            with np.errstate(all="ignore"):
                wa = np.where(theta > 1e-9, np.sin((1 - u) * theta) / np.sin(theta), 1 - u)
                wb = np.where(theta > 1e-9, np.sin(u * theta) / np.sin(theta), u)
            played = wa[:, None] * a + wb[:, None] * b
            if np.all(np.isfinite(played)) and np.all(np.linalg.norm(played, axis=1) > 0):
                err = np_angle(played, v).max()
                expect(err <= max(tol, 0) + 1e-6, f"a sample is {err!r} rad from the keys' slerp (tolerance {tol!r})")
        repr(out)

    return Case(lambda: fn(*args, **kwargs), max(n, 1), check, must_fail, 0, args + [kwargs])


def build_gltf_slerp(fn, d):
    """gltf_slerp(a, b, t): a unit quaternion; at t = 0 and 1 the rotations a and b."""
    rng = d.rng
    a, b = quats(rng, (2,), d.pick(("calm", "extreme"), "level"))
    t = d.pick((0.0, 1.0, 0.5, float(rng.uniform(0, 1)), -0.5, 2.0), "t")
    must_fail = ""
    if d.chance(0.1, "poison"):
        (a if d.chance(0.5) else b)[int(rng.integers(0, 4))] = rng.choice(POISON_VALUES)
        must_fail = "poisoned quaternion"
    if d.chance(0.05, "zero"):
        a = np.zeros(4)
        must_fail = must_fail or "zero quaternion"
    args = [a, b, t]
    must_fail = maybe_junk(d, args, [(4,), (4,), ()], ["a", "b", "t"], must_fail)

    def check(out):
        shape_is(out, (4,), "gltf_slerp")
        finite(out, "gltf_slerp")
        expect(abs(np.linalg.norm(out) - 1) < 1e-9, "not unit")
        if t in (0.0, 1.0):
            expect(np_angle(out[None], (a if t == 0.0 else b)[None]).max() < 1e-6, "does not hit the key")

    return Case(lambda: fn(*args), 1, check, must_fail, 0, args)


def build_axis_angle_span(fn, d):
    """axis_angle_span(quats (N, 4), start (4,), end (4,)): channels of the same rotations."""
    rng = d.rng
    n = d.count(small=200, huge=20_000, label="samples")
    q = quats(rng, (n,), d.pick(("calm", "extreme"), "level"))
    start = np.array([rng.normal(0, 10), *rng.normal(0, 1, 3)])
    end = np.array([rng.normal(0, 10), *rng.normal(0, 1, 3)])
    must_fail = ""
    if d.chance(0.1, "poison") and n:
        poison(rng, q, "quat", False)
        must_fail = "poisoned quats"
    if d.chance(0.05, "bad_end"):
        end[int(rng.integers(0, 4))] = rng.choice(POISON_VALUES)
        must_fail = must_fail or ("non-finite end" if not np.all(np.isfinite(end)) else "")
    args = [q, start, end]
    must_fail = maybe_junk(d, args, [(4,), (4,), (4,)], ["quats", "start", "end"], must_fail)

    def check(out):
        shape_is(out, (n, 4), "axis_angle_span")
        finite(out, "axis_angle_span")
        if n:
            err = np_angle(qc.channels_to_quats(out, "AXIS_ANGLE"), q)
            expect(err.max() < 1e-6, f"axis_angle_span changed a rotation by {err.max()!r} rad")

    return Case(lambda: fn(*args), max(n, 1), check, must_fail, 0, args)


def build_fit(fn, d):
    """fit_keys: the reducer with forced keys; forced indices stay keys of every channel."""
    euler = d.chance(0.4, "euler")
    axis_angle = not euler and d.chance(0.3, "axis_angle")
    t, v, tol, must_fail = draw_samples(d, euler, axis_angle)
    n = len(t)
    rng = d.rng
    forced = np.sort(rng.choice(n, size=min(n, int(rng.integers(0, 8))), replace=False)) if n else np.zeros(0, int)
    form = d.pick(("ok", "ok", "ok", "out_of_range", "unsorted", "negative", "fraction", "2d"), "forced_form")
    if form == "out_of_range" and n:
        forced = np.append(forced, n + int(rng.integers(0, 3)))
        must_fail = must_fail or "forced out of range"
    elif form == "unsorted" and forced.size >= 2:
        forced = forced[::-1].copy()
        must_fail = must_fail or "forced not increasing"
    elif form == "negative":
        forced = np.append(-1, forced)
        must_fail = must_fail or "negative forced index"
    elif form == "fraction":
        forced = np.append(forced.astype(float), 0.5)
        must_fail = must_fail or "fractional forced index"
    elif form == "2d":
        forced = forced.reshape(1, -1)
        must_fail = must_fail or "forced not 1-D"
    min_gap = d.pick((0.0, 0.01, 0.3, -1.0, NAN), "min_gap")
    if not min_gap >= 0:
        must_fail = must_fail or f"min_gap {min_gap!r}"
    mode = d.pick(ORDERS, "order") if euler else "AXIS_ANGLE" if axis_angle else "QUATERNION"
    kwargs = {"mode": mode, "interpolation": d.pick(("LINEAR", "BEZIER"), "interpolation"),
              "synchronized": d.pick((True, False), "synchronized"), "min_gap": min_gap}

    def check(out):
        expect(type(out).__name__ == "ReducedKeys", f"result {type(out).__name__}")
        expect(len(out.channels) == (3 if euler else 4), f"{len(out.channels)} channels")  # axis-angle: 4
        finite(out.max_error, "max_error")
        if min_gap == 0.0:
            expect(out.max_error <= max(tol, 1e-6), f"max_error {out.max_error!r} above tolerance {tol!r}")
        for c, ch in enumerate(out.channels):
            check_indices(ch.indices, n, f"channel {c} indices")
            frames_distinct(ch.frames, f"channel {c} frames")
            missing = set(int(k) for k in np.ravel(forced)) - set(int(k) for k in ch.indices)
            expect(not missing, f"channel {c} lost forced samples {sorted(missing)[:5]}")

    return Case(lambda: fn(t, v, forced, tol, **kwargs), max(n, 1), check, must_fail, 0,
                ((t, v, forced, tol), kwargs))


def build_fit_through_keys(fn, d, channels=False):
    """fit_through_keys: a curve of any method through a few keys of any rotation mode, fitted; the
    samples are the subframe grid plus the keys, the keys stay keys of every channel with their
    values (as float32), and bad arguments are refused. channels: fit_channels, which builds the
    curve and signs the quaternion keys itself (KeyFit.key_values: the keys as signed here)."""
    rng = d.rng
    euler = d.chance(0.35, "euler")
    axis_angle = not euler and d.chance(0.35, "axis_angle")
    mode = d.pick(ORDERS, "order") if euler else "AXIS_ANGLE" if axis_angle else "QUATERNION"
    k = int(rng.integers(2, 12))
    frames = np.cumsum(rng.uniform(0.05, 30.0, k)) + rng.uniform(-50, 50)
    if euler:
        values = rng.uniform(-7, 7, (k, 3))
    elif axis_angle:
        values = np.column_stack([rng.uniform(-10, 10, k), rng.normal(size=(k, 3)) * rng.uniform(0.2, 3.0, (k, 1))])
    else:
        values = rng.normal(size=(k, 4)) * rng.uniform(0.3, 2.0, (k, 1))
    method = d.pick(tuple(m for m in qc.METHODS if m != "EULER" or euler), "method")
    raw = values
    if euler:
        curve = qc.Curve.from_euler(frames, values, order=mode, method=method)
    elif axis_angle:
        curve = qc.Curve.from_axis_angle(frames, values, method=method)
    else:
        curve = qc.Curve(frames, values, method=method)
    if mode == "QUATERNION":  # the sign the curve reaches each key with, as the fit writes them
        values = values * np.where(np.sum(curve.sample(frames) * values, axis=1) < 0, -1.0, 1.0)[:, None]
    subframes = d.pick((1, 2, 4, 4, 7, 0, -1), "subframes")
    tol = d.pick((0.0, 1e-4, 1e-3, 0.01, 0.1, -1.0, NAN), "tolerance")
    must_fail = needs(subframes >= 1, f"subframes {subframes}") or needs(tol > 0, f"tolerance {tol!r}")
    args = [curve, frames, values, mode]
    if channels:  # fit_channels(key_frames, key_values, mode, method): the curve and the signs are its own
        args = [None, frames, raw, mode]
    form = d.pick(("ok", "ok", "ok", "one_key", "unsorted", "wide", "mode"), "form")
    if form == "one_key":
        args[1], args[2] = frames[:1], values[:1]
        must_fail = must_fail or "one key"
    elif form == "unsorted":
        args[1] = frames[::-1].copy()
        must_fail = must_fail or "key frames not increasing"
    elif form == "wide":
        args[2] = np.column_stack([values, values[:, :1]])
        must_fail = must_fail or "key values of the wrong width"
    elif form == "mode":
        args[3] = d.pick(("EULER", "quaternion", ""), "bad_mode")
        must_fail = must_fail or f"mode {args[3]!r}"
    kwargs = {"subframes": subframes, "tolerance": tol, "min_gap": 0.01}

    def check(out):
        times, forced, fitted = out.times, out.forced, out.keys
        expect(bool(np.all(np.diff(times) > 0)), "times are not increasing")
        if subframes >= 1:
            grid = np.arange(math.ceil(frames[0] * subframes - 1e-9), math.floor(frames[-1] * subframes + 1e-9) + 1) / subframes
            near = np.min(np.abs(grid[:, None] - frames[None, :]), axis=1) < 1e-6
            expect(bool(np.all(np.isin(np.union1d(grid[~near], frames), times))),
                   "times lack a grid point or a key (the proof only adds samples)")
        expect(np.array_equal(times[forced], frames), "forced indices do not point at the keys")
        expect(len(fitted.channels) == (3 if euler else 4), f"{len(fitted.channels)} channels")
        finite(fitted.max_error, "max_error")
        expect(out.proof.bound >= out.proof.max_evaluated, "the proved bound is below an evaluated angle")
        for c, ch in enumerate(fitted.channels):
            at = np.searchsorted(ch.indices, forced)
            expect(bool(np.all(ch.indices[np.minimum(at, len(ch.indices) - 1)] == forced)), f"channel {c} lost a key")
            kept = ch.values[at]
            expect(np.array_equal(kept.astype(np.float32), values[:, c].astype(np.float32)),
                   f"channel {c}: a key's value changed")
        if channels:
            expect(np.array_equal(out.key_values, values), "key_values are not the keys signed as the curve")

    if channels:
        return Case(lambda: fn(*args[1:], method, **kwargs), 100 * k * max(subframes, 1), check, must_fail, 0,
                    (args[1:] + [method], kwargs))
    return Case(lambda: fn(*args, **kwargs), 100 * k * max(subframes, 1), check, must_fail, 0, (args, kwargs))


def build_fit_channels(fn, d):
    """fit_channels: as fit_through_keys, from the keys alone (build_fit_through_keys)."""
    return build_fit_through_keys(fn, d, channels=True)


def build_fit_queue(fn, d):
    """A queue of 1-4 drawn fit_channels jobs (build_fit_through_keys' draws, some of them refits of
    the job before) on 0-3 worker threads: each job must give what fit_channels gives, bit for bit
    (keys, handles, samples, proof), or fail where it fails — at push for bad arguments, when taken
    for a fit's own error."""
    drawn = [build_fit_through_keys(qc.fit_channels, d, channels=True) for _ in range(d.pick((1, 2, 4), "jobs"))]
    threads, window = d.pick((0, 1, 2, 3), "threads"), d.pick((1, 2, 8), "window")
    refit = d.chance(0.5, "refit")

    def outcome(call):
        try:
            return call()
        except (ValueError, TypeError) as error:
            return error

    def call():
        queue = fn(threads=threads, window=window)
        pushed, results, last = [], [], None
        for case in drawn:
            args, kwargs = case.inputs
            previous = last if refit else None  # the fit before, of these keys or others
            want = outcome(lambda: qc.fit_channels(*args, previous=previous, **kwargs))
            if not isinstance(want, Exception):
                last = want
            try:
                queue.push(*args, previous=previous, **kwargs)
            except (ValueError, TypeError) as error:
                results.append((want, error))
                continue
            pushed.append((case, want))
            results.append((want, None))
        queue.close()
        expect(len(queue) == len(pushed) and queue.remaining == len(pushed), "FitQueue length")
        taken = iter(outcome(lambda: next(queue)) for _ in pushed)
        out = [(want, refused if refused is not None else next(taken)) for want, refused in results]
        expect(queue.remaining == 0, "FitQueue.remaining after every job")
        expect(list(queue) == [], "FitQueue gave more results than jobs")
        return out

    def check(out):
        for want, got in out:
            if isinstance(want, Exception) or isinstance(got, Exception):
                expect(isinstance(want, Exception) and isinstance(got, Exception),
                       f"fit_channels gave {want!r}, the queue {got!r}")
                continue
            expect(np.array_equal(got.times, want.times) and got.proof.bound == want.proof.bound and
                   got.refitted == want.refitted, "the queue's fit differs from fit_channels'")
            for x, y in zip(got.keys.channels, want.keys.channels):
                for name in ("indices", "frames", "values", "handle_left", "handle_right"):
                    expect(np.array_equal(getattr(x, name), getattr(y, name)), f"channel {name} differs")

    return Case(call, sum(c.rows for c in drawn), check, "", 0, {"jobs": [c.inputs for c in drawn],
                                                                  "threads": threads, "refit": refit})


# ---- Blender's F-curve evaluation, emulated --------------------------------------------------------

def build_blender_evaluate(fn, d):
    """Random F-curves (extreme key times and values, handles of any length and direction) at random
    frames: the result must be finite and of eval_frames' shape, or a ValueError."""
    rng = d.rng
    level = d.level()
    k = d.count(small=40, huge=5_000, label="keys")
    # Most modes of increasing_times collapse in float32 (refused); Blender-like spacing is drawn more.
    frames = increasing_times(rng, k, d.pick(("unit", "random", "negative") * 3 + TIME_MODES, "time_mode"))
    values = fill(rng, (k,), "extreme" if level in ("extreme", "wild") else "calm")
    span = np.abs(fill(rng, (k, 2), level)) + 1e-3
    handle_left = np.stack([frames - span[:, 0], values + fill(rng, (k,), level)], axis=-1) if k else np.zeros((0, 2))
    handle_right = np.stack([frames + span[:, 1], values + fill(rng, (k,), level)], axis=-1) if k else np.zeros((0, 2))
    if d.chance(0.5, "float32_range"):  # extreme, yet storable: the evaluation itself is exercised
        with np.errstate(invalid="ignore"):
            values, handle_left, handle_right = (np.clip(a, -1e30, 1e30) for a in (values, handle_left, handle_right))
    m = d.count(small=200, huge=100_000, label="eval_count")
    lo, hi = (float(frames[0]), float(frames[-1])) if k and np.all(np.isfinite(frames[[0, -1]])) else (0.0, 1.0)
    at = rng.uniform(lo - 1.0, hi + 1.0, m) if np.isfinite(hi - lo) else fill(rng, (m,), "extreme")
    if k and d.chance(0.3, "on_keys"):
        at = np.concatenate([at, frames, frames + 5e-5, frames - 2e-4])
    interpolation = d.pick(("LINEAR", "BEZIER"), "interpolation")
    used = (frames, values, at) + ((handle_left, handle_right) if interpolation == "BEZIER" else ())
    with np.errstate(all="ignore"):
        f32_ok = all(np.all(np.isfinite(np.asarray(a, dtype=np.float64).astype(np.float32))) for a in used)
        increasing = k < 2 or bool(np.all(np.diff(np.asarray(frames, dtype=np.float32)) > 0))
    must_fail = needs(f32_ok, "a number beyond float32") or needs(increasing, "frames not increasing as float32")
    args = [frames, values, at, interpolation, handle_left, handle_right]
    if d.chance(0.05, "handle_shape") and k:
        args[4 + int(d.chance(0.5))] = handle_left[:-1]
        must_fail = must_fail or ("handle shape" if interpolation == "BEZIER" else "")
    if d.chance(0.04, "no_handles"):
        args[4] = None
        must_fail = must_fail or ("no handles" if interpolation == "BEZIER" else "")
    if d.chance(0.05, "junk_string"):
        args[3], bad = d.pick(junk_strings(), "junk_string")
        must_fail = must_fail or (f"junk string {args[3]!r}" if bad else "")
    must_fail = maybe_junk(d, args, [(), (), ()], ["frames", "values", "eval_frames"], must_fail)
    shape = np.shape(args[2]) if isinstance(args[2], np.ndarray) else None

    def check(out):
        finite(out, "values")
        if shape is not None:
            shape_is(out, shape)

    return Case(lambda: fn(*args), max(m, 1), check, must_fail, 8 * m, args)


# ---- the Curve class: one target per method ----------------------------------------------------------

CURVE_MEMBERS = {"angular_velocity", "from_axis_angle", "from_channels", "from_euler", "method", "options", "quats", "path_rule_breaks",
                 "sample", "sample_keys", "segment_paths", "times", "corner_times", "motion_bounds"}
CLAMPED_METHODS = ("SQUAD", "TCB", "CATMULL_ROM")
TCB_OPTIONS = ("tension", "continuity", "bias", "ease_in", "ease_out")
EASE_OPTIONS = ("ease_in", "ease_out")


TURN_METHODS = ("NLERP", "SLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2")


def draw_turns(d: Draw, method, k, turnable):
    """turns for a method that takes them: whole numbers (non-zero only when `turnable`: no two
    consecutive keys are the same rotation, so every segment has an axis), or a fraction, a non-finite
    value, a wrong length. Returns (value or None, must_fail)."""
    if method not in TURN_METHODS or not d.chance(0.15, "turns"):
        return None, ""
    rng = d.rng
    form = d.pick(("zero", "scalar", "per_key", "fraction", "nan", "wrong_length"), "turns_form")
    if form in ("scalar", "per_key") and not turnable:
        form = "zero"
    if form == "zero":
        return 0.0, ""
    if form == "scalar":
        return float(rng.integers(-2, 3)), ""
    if form == "per_key":
        return rng.integers(-2, 3, k).astype(float), ""
    if form == "fraction":
        return float(rng.choice([0.5, -1.25, 1e-9])), "turns not whole"
    if form == "nan":
        return rng.choice([NAN, INF, -INF]), "turns non-finite"
    return np.zeros(k + 1 if k != 0 else 2), "turns wrong length"


def draw_options(d: Draw, method, k, turnable=False):
    """Options for a method: mostly valid, sometimes out of range, non-finite, wrong length, of
    another method, unknown, or of a junk type. Returns (kwargs, must_fail)."""
    rng = d.rng
    kwargs, must_fail = {}, ""
    turns, must_fail = draw_turns(d, method, k, turnable)
    if turns is not None:
        kwargs["turns"] = turns
    if method == "SLERP" and d.chance(0.5, "sp"):
        kwargs["shortest_path"], bad = d.pick([(True, False), (False, False), (2, True), ("yes", True),
                                               (np.bool_(False), False), (None, True)], "shortest_path")
        must_fail = "bad shortest_path" if bad else ""
    if method in CLAMPED_METHODS and d.chance(0.3, "clamped"):
        kwargs["clamped"], bad = d.pick([(True, False), (False, False), (np.bool_(True), False), (0.5, True),
                                         ("no", True)], "clamped")
        must_fail = must_fail or ("bad clamped" if bad else "")
    # every method takes ease_in / ease_out; TCB also tension, continuity, bias
    for name in TCB_OPTIONS if method == "TCB" else EASE_OPTIONS:
        if not d.chance(0.5 if method == "TCB" else 0.2, name):
            continue
        lo = 0.0 if name.startswith("ease") else -1.0
        form = d.pick(("scalar", "per_key", "edge", "out_of_range", "nan", "wrong_length", "bool", "junk"),
                      name + "_form")
        if form == "scalar":
            kwargs[name] = float(rng.uniform(lo, 1))
        elif form == "per_key":
            kwargs[name] = rng.uniform(lo, 1, k)
        elif form == "edge":
            kwargs[name] = rng.choice([lo, 1.0, -0.0], k)
        elif form == "out_of_range":
            kwargs[name] = float(rng.choice([1 + 1e-12, lo - 1e-9, 1e300, -1e300]))
            must_fail = must_fail or f"{name} out of range"
        elif form == "nan":
            kwargs[name] = rng.choice([NAN, INF])
            must_fail = must_fail or f"{name} non-finite"
        elif form == "wrong_length":
            kwargs[name] = np.zeros(k + 1 if k != 0 else 2)
            must_fail = must_fail or f"{name} wrong length"
        elif form == "bool":
            kwargs[name] = True
        else:
            kwargs[name], bad = d.pick(junk_values(()), name + "_junk")
            must_fail = must_fail or (f"{name} junk" if bad else "")
    if d.chance(0.05, "foreign_option"):
        name = d.pick(("shortest_path", "tension", "frobnicate", "", "ease_in"), "foreign")
        if name not in kwargs:
            kwargs[name] = 0.0 if name != "shortest_path" else True
            takes = ((method == "SLERP" and name == "shortest_path") or (method == "TCB" and name in TCB_OPTIONS)
                     or name in EASE_OPTIONS)
            must_fail = must_fail or ("" if takes else f"option {name!r} for {method}")
    return kwargs, must_fail


def build_curve(method, d: Draw) -> Case:
    rng = d.rng
    level = d.level()
    k = d.count(small=40, huge=20_000, label="keys")
    tmode = d.pick(TIME_MODES, "time_mode")
    times = increasing_times(rng, k, tmode)
    from_euler = method == "EULER" or d.chance(0.35, "from_euler")
    from_axis_angle = not from_euler and d.chance(0.3, "from_axis_angle")
    kmode = d.pick(("random", "antipodal", "same", "half_turn", "near", "extreme", "spin"), "key_mode")
    if from_euler:
        keys = angles(rng, (k,), "extreme" if kmode == "extreme" else "calm")
        if kmode == "spin" and k:
            keys = np.cumsum(rng.choice([-1, 1], (k, 3)) * rng.uniform(1.5, 4.0, (k, 3)), 0)
        elif kmode == "same" and k:
            keys[:] = keys[0]
        elif kmode == "half_turn" and k:
            keys = np.zeros((k, 3))
            keys[:, 2] = np.arange(k) * np.pi
    else:
        keys = quats(rng, (k,), "extreme" if kmode == "extreme" else "calm")
        if k > 1:
            if kmode == "antipodal":
                keys[1::2] = -keys[0::2][: keys[1::2].shape[0]]
            elif kmode == "same":
                keys[:] = keys[0]
            elif kmode == "half_turn":
                keys = np.tile([[1.0, 0, 0, 0], [0.0, 1, 0, 0]], (k // 2 + 1, 1))[:k]
            elif kmode == "near":
                keys = np.tile(keys[:1], (k, 1)) + 1e-15 * rng.standard_normal((k, 4))
    must_fail = needs(k >= 1, "no keys")
    if from_axis_angle:
        keys = axis_angle_rows(rng, keys)
        if kmode == "spin" and k:
            keys[:, 1:] = [0.0, 0.3, 1.0]
            keys[:, 0] = np.arange(k) * 2 * np.pi  # exact full turns
    if method == "EULER" and not from_euler:
        must_fail = must_fail or "EULER from quaternions"
    if level == "poison" and k:
        what = d.pick(("times", "keys"), "poison_what")
        if what == "times":
            times = break_times(rng, times)
        else:
            poison(rng, keys, "angles" if from_euler else "quat", from_euler)
        must_fail = must_fail or f"poisoned {what}"
    if level == "wild" and k:
        keys = fill(rng, keys.shape, "wild")
        if not np.all(np.isfinite(keys)):
            must_fail = must_fail or "non-finite keys"
        elif not from_euler and not from_axis_angle and np.any(np.linalg.norm(keys, axis=1) < 1e-300):
            must_fail = must_fail or "zero key"
    if from_axis_angle and isinstance(keys, np.ndarray) and keys.ndim == 2 and zero_axis(keys):
        must_fail = must_fail or "zero axis"
    # non-zero turns only where every segment has an axis (distinct random keys, Euler spins)
    turnable = kmode in ("random", "spin") and level not in ("wild", "poison")
    kwargs, opt_fail = draw_options(d, method, k, turnable)
    must_fail = must_fail or opt_fail
    # a loop (curve.hpp "Loops"): the last key made the first's rotation (either sign, Euler angles
    # whole turns on, an axis-angle turned once more), or left open (refused)
    # (not on wild, poisoned or extreme keys, whose refusals the closing would change)
    cyclic = level not in ("wild", "poison") and kmode != "extreme" and d.chance(0.2, "cyclic")
    order = d.pick(ORDERS, "order")
    if cyclic:
        kwargs["cyclic"] = d.pick((True, np.bool_(True), 1.0), "cyclic_value")
        close = d.pick(("closed", "turned", "open"), "loop_form")
        if k >= 2 and not must_fail:
            keys = np.array(keys, dtype=float)
            if close == "open":
                mode = order if from_euler else ("AXIS_ANGLE" if from_axis_angle else "QUATERNION")
                first_q = qc.Curve.from_channels([0.0], keys[:1], mode).quats[0]
                last_q = qc.Curve.from_channels([0.0], keys[-1:], mode).quats[0]
                if qc.angle_between(first_q, last_q) > 1e-4:
                    must_fail = "loop not closed"
            elif from_euler:
                keys[-1] = keys[0] + (2 * np.pi * rng.integers(-1, 2, 3) if close == "turned" else 0.0)
            elif from_axis_angle:
                keys[-1] = keys[0]
                if close == "turned":
                    keys[-1, 0] += 2 * np.pi * rng.choice([-1, 1])
            else:
                keys[-1] = keys[0] * (rng.choice([-1.0, 1.0]) if close == "turned" else 1.0)
    if d.chance(0.05, "mismatch") and k:
        keys = keys[:-1]
        must_fail = must_fail or "lengths differ"
    meth = method
    if d.chance(0.04, "junk_method"):
        meth, bad = d.pick(junk_strings() + [("slerp", True)], "junk_method")
        must_fail = must_fail or ("junk method" if bad else "")
    args = [times, keys]
    must_fail = maybe_junk(d, args, [(), (3,) if from_euler else (4,)], ["times", "keys"], must_fail)

    # sample times: around the key range, extremes, unsorted, duplicates, huge counts
    m = d.count(small=200, huge=200_000, label="samples")
    smode = d.pick(("inside", "sorted", "extreme", "keys", "unsorted", "poison", "2d"), "sample_mode")
    finite_keys = times[np.isfinite(times)] if isinstance(times, np.ndarray) else np.zeros(1)
    lo, hi = (finite_keys.min(), finite_keys.max()) if finite_keys.size else (0.0, 1.0)
    with np.errstate(all="ignore"):
        span = hi - lo if np.isfinite(hi - lo) else DMAX
        ts = lo + rng.random(m) * span * 1.2 - 0.1 * span
    if smode == "sorted":
        ts.sort()
    elif smode == "extreme":
        ts = fill(rng, (m,), "extreme")
    elif smode == "keys" and finite_keys.size:
        ts = rng.choice(finite_keys, m)
    elif smode == "2d":
        ts = ts[: (m // 2) * 2].reshape(-1, 2) if m > 1 else ts.reshape(1, -1)
    if smode == "poison" and m:
        ts[rng.integers(0, m)] = rng.choice(POISON_VALUES)
    sample_fail = "non-finite sample time" if not np.all(np.isfinite(ts)) else ""
    ts = np.ascontiguousarray(ts)
    sample_arg: Any = ts
    if d.chance(0.05, "junk_times"):
        sample_arg, bad = d.pick(junk_values(()), "junk_times")
        sample_fail = "junk sample times" if bad else ""  # replaces the drawn times, poisoned or not
    cls = qc.Curve
    keys_mode = d.pick(("QUATERNION",) + ORDERS + ("AXIS_ANGLE",), "keys_mode")
    # The same keys through Curve.from_channels, the add-on's one way to build a curve: the same curve
    # or the same refusal.
    via_channels = d.chance(0.3, "from_channels")
    channels_mode = order if from_euler else ("AXIS_ANGLE" if from_axis_angle else "QUATERNION")

    def call():
        if via_channels:
            c = cls.from_channels(*args, channels_mode, method=meth, **kwargs)
        elif from_euler:
            c = cls.from_euler(*args, order=order, method=meth, **kwargs)
        elif from_axis_angle:
            c = cls.from_axis_angle(*args, method=meth, **kwargs)
        else:
            c = cls(*args, method=meth, **kwargs)
        results = {"curve": c, "keys_times": c.times, "keys_quats": c.quats, "method": c.method,
                   "options": c.options, "repr": repr(c)}
        for name in ("sample", "angular_velocity"):
            try:
                results[name] = getattr(c, name)(sample_arg)
                results[name + "_error"] = None
            except (ValueError, TypeError) as e:
                results[name + "_error"] = e
        results["at_keys"] = c.sample(c.times)
        if cyclic:  # the same curve one to three periods away, both ways
            kt = c.times
            period = kt[-1] - kt[0]
            if kt.size >= 2 and np.isfinite(period) and period > 0:
                base = np.linspace(kt[0], kt[-1], 41)
                shift = float(rng.integers(1, 4)) * d.pick((-1.0, 1.0), "loop_shift")
                results["periodic"] = (base, c.sample(base), c.sample(base + shift * period), shift * period,
                                       c.motion_bounds(float(kt[0]), float(kt[-1]))[0])
        # the bake's dense keys at the key times: the channels of the samples, as float32 pairs
        results["keys_of_mode"] = c.sample_keys(c.times, keys_mode)
        results["paths"] = c.segment_paths()
        results["breaks"] = c.path_rule_breaks()
        # motion bounds on a stretch between corners: 33 samples to hold them against
        corners = c.corner_times()
        results["corners"] = corners
        if corners.size >= 2 and np.all(np.isfinite(corners)):
            j = int(rng.integers(0, corners.size - 1))
            lo, hi = corners[j], corners[j + 1]
            span = rng.uniform(0.05, 1.0) * (hi - lo)
            a = lo + rng.uniform(0, 1) * (hi - lo - span)
            st = np.linspace(a, a + span, 33)
            across = False
            if cyclic and corners.size >= 2:  # a stretch some periods away, or across the seam
                period = corners[-1] - corners[0]
                across = d.chance(0.5, "across_seam")
                if across:
                    st = np.linspace(corners[-1] - 0.3 * span, corners[-1] + 0.3 * span, 33)
                else:
                    st = st + float(rng.integers(-3, 4)) * period
            results["bounded"] = (st, c.sample(st), c.motion_bounds(float(st[0]), float(st[-1])), across)
        return results

    def check(r):
        kt = r["keys_times"]
        given_times = np.asarray(args[0], dtype=float).reshape(-1)
        expect(np.array_equal(kt, given_times), "Curve.times differs from the key times")
        expect(r["options"].get("cyclic") is bool(cyclic), f"Curve.options['cyclic'] is {r['options'].get('cyclic')!r}")
        if "periodic" in r:
            base, q0, q1, shift, speed = r["periodic"]
            # the wrapped time is off by rounding of |t| + |shift|: the angle by the speed times that
            slack = 1e-9 + (speed if np.isfinite(speed) else 0.0) * 4e-16 * (np.abs(base).max() + abs(shift)) * 8
            err = np_angle(q0, q1)
            expect(not np.isfinite(speed) or err.max() <= slack,
                   f"loop: sample(t + {shift!r}) is {err.max()!r} rad off sample(t)")
        unit(r["keys_quats"], "Curve.quats")
        expect(r["method"] == method, f"Curve.method {r['method']!r}")
        expect(isinstance(r["options"], dict), "Curve.options not a dict")
        # passes through its keys (any method), sign-invariant
        at = r["at_keys"]
        unit(at, "sample(keys)")
        err = np_angle(at, r["keys_quats"])
        if err.size:
            expect(err.max() < 1e-6, f"sample at key {int(err.argmax())} is {err.max()!r} rad off the key")
        pairs = r["keys_of_mode"]
        channels = qc.quats_to_channels(at, keys_mode).astype(np.float32) if at.size else np.zeros((0, 1))
        shape_is(pairs, (channels.shape[1] if at.size else pairs.shape[0], kt.size, 2), "sample_keys")
        if at.size:
            expect(np.array_equal(pairs[:, :, 0], np.broadcast_to(kt.astype(np.float32), pairs.shape[:2]))
                   and np.array_equal(pairs[:, :, 1].T, channels),
                   f"sample_keys({keys_mode}) differs from quats_to_channels(sample) in float32")
        # the path rule: every key segment of a clamped tangent method (the default) turns at most
        # PATH_RULE_FACTOR × its keyed arc + PATH_RULE_SLACK (the clamp keeps a 2% margin)
        paths = r["paths"]
        shape_is(paths, (max(kt.size - 1, 0), 2), "segment_paths")
        finite(paths, "segment_paths")
        expect(bool(np.all(paths >= 0)), "segment_paths: negative arc or length")
        # path_rule_breaks (no sampling where the construction settled it) names exactly the
        # segments whose sampled path breaks the rule
        if paths.size:
            over = np.flatnonzero(paths[:, 1] > qc.PATH_RULE_FACTOR * paths[:, 0] + qc.PATH_RULE_SLACK)
        else:
            over = np.zeros(0, dtype=int)
        named = r["breaks"][:, 0].astype(int)
        expect(np.array_equal(named, over), f"path_rule_breaks names {named.tolist()}, segment_paths {over.tolist()}")
        if method in CLAMPED_METHODS and kwargs.get("clamped", True) is not False and paths.size:
            excess = paths[:, 1] - (qc.PATH_RULE_FACTOR * paths[:, 0] + qc.PATH_RULE_SLACK)
            expect(excess.max() <= 1e-9, f"segment {int(excess.argmax())} breaks the path rule by {excess.max()!r} rad")
        # corner times: sorted, the keys among them; between two of them the curve's speed and
        # |q''| stay within motion_bounds (finite differences of dense samples)
        corners = r["corners"]
        expect(bool(np.all(np.diff(corners) >= 0)) and bool(np.all(np.isin(kt, corners))),
               "corner_times: not sorted, or a key missing")
        if "bounded" in r:
            # (across a loop's seam, a corner: the speed bound only)
            st, q, (speed, accel), across = r["bounded"]
            expect(speed >= 0 and accel >= 0, f"motion_bounds negative: {speed}, {accel}")
            for i in range(1, len(q)):  # the same sign along the samples (the curve's may flip at a key)
                if np.dot(q[i], q[i - 1]) < 0:
                    q[i] = -q[i]
            dt = st[1] - st[0]
            if dt > 1e-6 and np.isfinite(speed):
                moved = np_angle(q[1:], q[:-1]) / dt
                expect(moved.max() <= speed * (1 + 1e-6) + 1e-6 / dt * 1e-3,
                       f"speed {moved.max()!r} rad/frame above motion_bounds' {speed!r} in [{st[0]!r}, {st[-1]!r}]")
            if dt > 1e-3 and np.isfinite(accel) and not across:
                second = np.linalg.norm(q[2:] - 2 * q[1:-1] + q[:-2], axis=1) / dt ** 2
                expect(second.max() <= accel * (1 + 1e-6) + 1e-9 / dt ** 2,
                       f"|q''| {second.max()!r} above motion_bounds' {accel!r} in [{st[0]!r}, {st[-1]!r}]")
        for name, tail in (("sample", (4,)), ("angular_velocity", (3,))):
            e = r[name + "_error"]
            if sample_fail:
                expect(e is not None, f"{name} accepted {sample_fail}")
                continue
            expect(e is None, f"{name} refused valid times: {e!r}")
            out = r[name]
            shape_is(out, ts.shape + tail, name) if sample_arg is ts else None
            (unit if name == "sample" else finite)(out, name)

    inputs = {"from_euler": from_euler, "from_axis_angle": from_axis_angle, "times": args[0], "keys": args[1], "order": order, "method": meth,
              "options": kwargs, "sample_times": sample_arg}
    return Case(call, max(k, 1) + m, check, must_fail, m * 32, inputs)



# ==== the bound at every instant (bound.hpp) =====================================================

def build_prove_playback(fn, d):
    """prove_playback: keys of any mode fitted (or reduced, LINEAR or BEZIER) along a curve, proved
    against it; the verdict is checked by dense evaluation of the same keys: nowhere above the
    proved bound (up to Blender's float32 arithmetic), and a violation is a real one."""
    rng = d.rng
    mode = d.pick(("QUATERNION", "AXIS_ANGLE") + ORDERS, "mode")
    k = int(rng.integers(2, 7))
    frames = np.cumsum(rng.uniform(0.3, 12.0, k)) + rng.uniform(-20, 20)
    if mode in ORDERS:
        values = rng.uniform(-4, 4, (k, 3))
    elif mode == "AXIS_ANGLE":
        values = np.column_stack([rng.uniform(-7, 7, k), rng.normal(size=(k, 3)) + 0.1])
    else:
        values = rng.normal(size=(k, 4))
    method = d.pick(tuple(m for m in qc.METHODS if m not in ("EULER", "QUAT_COMPONENTS")), "method")
    tol = float(d.pick((1e-3, 1e-2, 0.05), "tolerance"))
    interpolation = d.pick(("BEZIER", "LINEAR"), "interpolation")
    times = np.union1d(np.arange(math.ceil(frames[0]), math.floor(frames[-1]) + 1.0), frames)
    channels = None
    while channels is None:
        curve = qc.Curve.from_channels(frames, values, mode, method=method)
        if mode == "QUATERNION":
            values = values * np.where(np.sum(curve.sample(frames) * values, axis=1) < 0, -1.0, 1.0)[:, None]
        if interpolation == "LINEAR" and mode == "QUATERNION":
            channels = qc.reduce_keys(times, curve.sample(times), tol, "LINEAR", detailed=True).channels
            break
        interpolation = "BEZIER"
        try:
            channels = qc.fit_through_keys(curve, frames, values, mode, subframes=2, tolerance=tol * 3).keys.channels
        except ValueError:  # Euler keys the method reaches on another branch (refused): quaternion keys
            mode, values = "QUATERNION", qc.channels_to_quats(values, mode)
    form = d.pick(("ok", "ok", "ok", "unsorted", "tolerance", "step", "channels"), "form")
    args, kwargs, must_fail = [curve, channels, interpolation, mode, times, tol], {}, ""
    if form == "unsorted":
        args[4] = times[::-1].copy()
        must_fail = "unsorted times"
    elif form == "tolerance":
        args[5] = d.pick((-1.0, NAN, INF), "bad_tolerance")
        must_fail = f"tolerance {args[5]!r}"
    elif form == "step":
        kwargs["min_step"] = d.pick((0.0, -1.0, NAN), "bad_step")
        must_fail = f"min_step {kwargs['min_step']!r}"
    elif form == "channels":
        args[1] = list(channels)[:-1]
        must_fail = "a channel missing"

    def check(p):
        finite(p.max_evaluated, "max_evaluated")
        expect(p.bound >= p.max_evaluated, "bound below an evaluated angle")
        expect(p.proven == (len(p.violations) == 0 and len(p.unproven) == 0), "proven disagrees with the lists")
        ts = np.sort(np.concatenate([np.linspace(times[0], times[-1], 4001), rng.uniform(times[0], times[-1], 2000)]))
        vals = np.stack([qc.blender_evaluate(c.frames, c.values, ts, interpolation, c.handle_left if len(c.handle_left) else None,
                                             c.handle_right if len(c.handle_right) else None) for c in channels], 1)
        if mode == "AXIS_ANGLE":
            vals[np.all(vals[:, 1:] == 0, axis=1), 1] = 1.0  # Blender's zero axis: no rotation
            vals[np.all(vals[:, 1:] == 0, axis=1), 0] = 0.0
        if mode == "QUATERNION":
            vals[np.all(vals == 0, axis=1), 1] = 1.0  # Blender's normalize of zero
        dense = np_angle(qc.channels_to_quats(vals, mode), curve.sample(ts))
        expect(dense.max() <= p.bound + 1e-5,
               f"dense evaluation {dense.max()!r} rad at frame {ts[dense.argmax()]!r} above the proved {p.bound!r}")

    return Case(lambda: fn(*args, **kwargs), 4 * len(times), check, must_fail, 0, (args, kwargs))


def playback_quats(channels, interpolation, mode, ts):
    """Blender's rotation (N, 4) from F-curves [(frames, values, handle_left, handle_right)] at ts, by
    the emulation (a zero quaternion is (0, 1, 0, 0), a zero axis no rotation, as Blender builds them)."""
    vals = np.stack([qc.blender_evaluate(c[0], c[1], ts, interpolation,
                                         c[2] if interpolation == "BEZIER" else None,
                                         c[3] if interpolation == "BEZIER" else None) for c in channels], 1)
    if mode == "AXIS_ANGLE":
        zero = np.all(vals[:, 1:] == 0, axis=1)
        vals[zero, 0], vals[zero, 1] = 0.0, 1.0
    if mode == "QUATERNION":
        vals[np.all(vals == 0, axis=1), 1] = 1.0
    return qc.channels_to_quats(vals, mode)


def mixed_playback_quats(out, mode, ts):
    """Blender's rotation (N, 4) of a ProvedKeys' keys at ts, each key with its own interpolation (a key
    in a copied span [f0, f1) the original's, copied_interpolation): a value depends only on the segment
    holding t, so each channel is evaluated both ways and each time takes its segment's key's."""
    keys = out.keys
    cols = []
    for c in keys.channels:
        handles = (c.handle_left, c.handle_right) if len(c.handle_left) else (None, None)
        both = {ipo: qc.blender_evaluate(c.frames, c.values, ts, ipo, *(handles if ipo == "BEZIER" else (None, None)))
                for ipo in {keys.interpolation, out.copied_interpolation if len(out.copied) else keys.interpolation}}
        seg = c.frames[np.clip(np.searchsorted(c.frames.astype(np.float32), ts.astype(np.float32), "right") - 1,
                               0, len(c.frames) - 1)]
        copied = np.zeros(len(ts), dtype=bool)
        for f0, f1 in out.copied:
            copied |= (seg >= f0) & (seg < f1)
        cols.append(np.where(copied, both.get(out.copied_interpolation), both[keys.interpolation]) if copied.any()
                    else both[keys.interpolation])
    vals = np.stack(cols, 1)
    if mode == "AXIS_ANGLE":
        zero = np.all(vals[:, 1:] == 0, axis=1)
        vals[zero, 0], vals[zero, 1] = 0.0, 1.0
    if mode == "QUATERNION":
        vals[np.all(vals == 0, axis=1), 1] = 1.0
    return qc.channels_to_quats(vals, mode)


def proved_keys_checks(out, tol, mode, interpolation_out, reference, t0, t1, flips, rng):
    """What every ProvedKeys must hold: its lists and verdict agree, every sample pair in `flips` lies
    in a copied span, and Blender's playback of its keys (emulated at 2000 even and 1000 random
    times, each key with its own interpolation) is nowhere above the proved bound, inside the copied
    spans too; tolerance 0 proves nothing (bound inf)."""
    expect(type(out).__name__ == "ProvedKeys", f"result {type(out).__name__}")
    keys, proof = out.keys, out.proof
    expect(len(keys.channels) == _channel_count(mode), f"{len(keys.channels)} channels")
    expect(keys.interpolation == interpolation_out, f"interpolation {keys.interpolation}")
    finite(keys.max_error, "max_error")
    expect(proof.proven == (len(proof.violations) == 0 and len(proof.unproven) == 0), "proven disagrees with the lists")
    copied = np.asarray(out.copied).reshape(-1, 2)
    for a, b in flips:
        expect(any(f0 <= a and b <= f1 for f0, f1 in copied), lambda: f"flip {a}|{b} outside the copied {copied!r}")
    expect(out.times.ndim == 1 and np.all(np.diff(out.times) > 0), "times not increasing")
    expect(1 <= out.rounds <= 8, f"{out.rounds} rounds")
    repr(out)
    if tol == 0:
        expect(math.isinf(proof.bound) and not proof.proven, "tolerance 0 proved something")
        return
    finite(proof.bound, "bound")
    expect(proof.bound >= proof.max_evaluated, "bound below an evaluated angle")
    if t1 <= t0:
        return
    ts = np.sort(np.concatenate([np.linspace(t0, t1, 2001), rng.uniform(t0, t1, 1000)]))
    got = mixed_playback_quats(out, mode, ts)
    dense = np_angle(got, reference(ts))
    expect(dense.max() <= proof.bound + 1e-6,
           f"dense evaluation {dense.max()!r} rad at frame {ts[dense.argmax()]!r} above the proved {proof.bound!r}")


def draw_original(d, mode):
    """Original F-curves of `mode` keyed every 0.3-3 frames (smooth random walks; quaternions with
    sign flips; BEZIER handles from calm to swinging) and the reducer's samples of them: (channels,
    interpolation, times, values)."""
    rng = d.rng
    k = int(rng.integers(2, 40))
    # Far frames too: float32 steps of 2^-10 frames near 10,000 (both playbacks evaluate at them).
    offset = float(d.pick((0.0, 0.0, 9000.0, 30000.0), "frame_offset"))
    frames = (np.cumsum(rng.uniform(0.3, 3.0, k)) + rng.uniform(-50, 50) + offset).astype(np.float32).astype(np.float64)
    width = _channel_count(mode)
    values = np.cumsum(rng.normal(0, 0.15, (k, width)), 0)
    if mode == "QUATERNION":
        values += [2.0, 0, 0, 0]
        values *= np.where(rng.uniform(size=(k, 1)) < 0.1, -1.0, 1.0)  # stored signs that flip
    elif mode == "AXIS_ANGLE":
        values[:, 1:] += [0.3, 0.2, 1.0]
    values = values.astype(np.float32).astype(np.float64)
    interpolation = d.pick(("BEZIER", "BEZIER", "LINEAR"), "channel_interpolation")
    swing = float(d.pick((0.0, 1.0, 4.0), "swing"))
    channels = []
    for c in range(width):
        slope = np.gradient(values[:, c], frames) if k > 1 else np.zeros(k)
        span = rng.uniform(0.05, 0.6, (k, 2)) * np.minimum(np.diff(frames, prepend=frames[0] - 1),
                                                           np.diff(frames, append=frames[-1] + 1))[:, None]
        lean = slope * swing + rng.normal(0, 0.05, k) * swing
        handle_left = np.column_stack([frames - span[:, 0], values[:, c] - lean * span[:, 0]])
        handle_right = np.column_stack([frames + span[:, 1], values[:, c] + lean * span[:, 1]])
        channels.append((frames, values[:, c], handle_left.astype(np.float32).astype(np.float64),
                         handle_right.astype(np.float32).astype(np.float64)))
    times = qc.whole_frame_samples(frames)
    sampled = np.stack([qc.blender_evaluate(c[0], c[1], times, interpolation, c[2] if interpolation == "BEZIER" else None,
                                            c[3] if interpolation == "BEZIER" else None) for c in channels], 1)
    return channels, interpolation, times, sampled


def build_reduce_keys_proved(fn, d):
    """reduce_keys_proved: random original F-curves of any mode (LINEAR or BEZIER, handles that swing
    between keys, quaternion sign flips), reduced and proved against their own playback; the proof is
    checked by dense evaluation of both (emulated), nowhere above the bound, inside the sign flips too
    (the sample pairs in opposite hemispheres lie in copied spans, the original's keys)."""
    rng = d.rng
    mode = d.pick(("QUATERNION", "AXIS_ANGLE") + ORDERS, "mode")
    channels, channel_ipo, times, values = draw_original(d, mode)
    tol = float(d.pick((0.0, 1e-4, 1e-3, 0.01, 0.05), "tolerance"))
    interpolation = d.pick(("BEZIER", "LINEAR"), "interpolation")
    synchronized = d.pick((False, True), "synchronized")
    flips = np.zeros((0, 2))
    if mode == "QUATERNION":
        flip = np.flatnonzero(np.sum(values[1:] * values[:-1], axis=1) < 0)
        t32 = times.astype(np.float32).astype(np.float64)
        flips = np.column_stack([t32[flip], t32[flip + 1]]).reshape(-1, 2)
    form = d.pick(("ok",) * 6 + ("unsorted", "tolerance", "channels", "handles", "width", "junk"), "form")
    args, must_fail = [channels, channel_ipo, mode, times, values, tol, interpolation, synchronized], ""
    if form == "unsorted" and len(times) > 1:
        args[3] = times[::-1].copy()
        must_fail = "unsorted times"
    elif form == "tolerance":
        args[5] = d.pick((-1.0, NAN, INF), "bad_tolerance")
        must_fail = f"tolerance {args[5]!r}"
    elif form == "channels":
        args[0] = channels[:-1]
        must_fail = "a channel missing"
    elif form == "handles" and channel_ipo == "BEZIER":
        args[0] = [channels[0][:2] + (channels[0][2][:-1], channels[0][3])] + channels[1:]
        must_fail = "a handle missing"
    elif form == "width":
        args[4] = values[:, :-1]
        must_fail = "values of the wrong width"
    elif form == "junk":
        args[0] = d.pick(([None] * len(channels), [(1, 2, 3)] * len(channels), "abc"), "junk_channels")
        must_fail = "junk channels"

    def reference(ts):
        return playback_quats(channels, channel_ipo, mode, ts)

    def check(out):
        proved_keys_checks(out, tol, mode, interpolation, reference, times[0], times[-1], flips, rng)
        expect(out.copied_interpolation == channel_ipo, f"copied_interpolation {out.copied_interpolation}")
        # Never unproved where the original's keys could be kept (all within the samples' range).
        t0, t1 = np.float32(times[0]), np.float32(times[-1])
        inside = all(len(c[0]) <= 1 or (c[0][0] >= t0 and c[0][-1] <= t1) for c in channels)
        expect(tol == 0 or not inside or out.proof.proven,
               lambda: f"unproved at tolerance {tol!r} (bound {out.proof.bound!r}): the original's keys were not kept")

    return Case(lambda: fn(*args), 4 * len(times), check, must_fail, 0, args)


def build_convert_keys_proved(fn, d):
    """convert_keys_proved: random original F-curves of any mode (as reduce_keys_proved's), converted
    to another mode with random forced samples, proved against the original's playback; checked by
    dense evaluation of both (emulated), nowhere above the bound; every forced frame a key of every
    channel."""
    rng = d.rng
    modes = ("QUATERNION", "AXIS_ANGLE") + ORDERS
    source = d.pick(modes, "from_mode")
    target = d.pick(tuple(m for m in modes if m != source), "to_mode")
    channels, channel_ipo, times, sampled = draw_original(d, source)
    values = qc.quats_to_channels(qc.channels_to_quats(sampled, source), target)
    forced = np.unique(np.r_[0, len(times) - 1, rng.integers(0, len(times), int(rng.integers(0, 5)))]).astype(np.int64)
    tol = float(d.pick((1e-4, 1e-3, 0.01, 0.05), "tolerance"))
    form = d.pick(("ok",) * 6 + ("unsorted", "tolerance", "forced", "channels", "width"), "form")
    args, must_fail = [channels, channel_ipo, source, target, times, values, forced, tol, 0.01], ""
    if form == "unsorted" and len(times) > 1:
        args[4] = times[::-1].copy()
        must_fail = "unsorted times"
    elif form == "tolerance":
        args[7] = d.pick((0.0, -1.0, NAN, INF), "bad_tolerance")
        must_fail = f"tolerance {args[7]!r}"
    elif form == "forced":
        args[6] = d.pick((forced[::-1].copy() if len(forced) > 1 else np.array([len(times)]),
                          np.array([len(times) + 3])), "bad_forced")
        must_fail = f"forced {args[6]!r}"
    elif form == "channels":
        args[0] = channels[:-1]
        must_fail = "a channel missing"
    elif form == "width":
        args[5] = values[:, :-1]
        must_fail = "values of the wrong width"

    def reference(ts):
        return playback_quats(channels, channel_ipo, source, ts)

    def check(out):
        proved_keys_checks(out, tol, target, "BEZIER", reference, times[0], times[-1], np.zeros((0, 2)), rng)
        expect(len(out.copied) == 0, f"copied {out.copied!r} in a conversion")
        for c, ch in enumerate(out.keys.channels):
            missing = np.setdiff1d(times[forced], ch.frames)
            expect(len(missing) == 0, lambda: f"channel {c}: no key at forced frames {missing!r}")

    return Case(lambda: fn(*args), 4 * len(times), check, must_fail, 0, args)


def build_reduce_curve_proved(fn, d):
    """reduce_curve_proved: samples of a method's curve through random keys as channel values of any
    mode, reduced and proved against the curve; checked by dense evaluation, nowhere above the bound."""
    rng = d.rng
    mode = d.pick(("QUATERNION", "AXIS_ANGLE") + ORDERS, "mode")
    k = int(rng.integers(2, 7))
    frames = np.cumsum(rng.uniform(0.5, 12.0, k)) + rng.uniform(-20, 20)
    method = d.pick(tuple(m for m in qc.METHODS if m not in ("EULER", "QUAT_COMPONENTS")), "method")
    curve = qc.Curve(frames, rng.normal(size=(k, 4)), method=method)
    times = qc.whole_frame_samples(frames.astype(np.float32).astype(np.float64))
    values = qc.quats_to_channels(curve.sample(times), mode)
    tol = float(d.pick((0.0, 1e-3, 0.01, 0.05), "tolerance"))
    interpolation = d.pick(("BEZIER", "LINEAR"), "interpolation")
    form = d.pick(("ok",) * 5 + ("unsorted", "tolerance", "width"), "form")
    args, must_fail = [curve, mode, times, values, tol, interpolation, d.pick((False, True), "synchronized")], ""
    if form == "unsorted" and len(times) > 1:
        args[2] = times[::-1].copy()
        must_fail = "unsorted times"
    elif form == "tolerance":
        args[4] = d.pick((-1.0, NAN, INF), "bad_tolerance")
        must_fail = f"tolerance {args[4]!r}"
    elif form == "width":
        args[3] = values[:, :-1]
        must_fail = "values of the wrong width"

    def check(out):
        proved_keys_checks(out, tol, mode, interpolation, curve.sample, times[0], times[-1], np.zeros((0, 2)), rng)
        expect(len(out.copied) == 0, f"copied {out.copied!r} against a curve")

    return Case(lambda: fn(*args), 4 * len(times), check, must_fail, 0, args)


def build_reduce_slerp_proved(fn, d):
    """reduce_slerp_proved: glTF slerp keys against a method's curve or against random original
    F-curves' playback (either form), proved at every instant; checked by dense evaluation of the
    keys' slerp (numpy, glTF's formula) against the reference, nowhere above the proved bound; the
    keys sit on the returned samples, first and last kept."""
    rng = d.rng
    form = d.pick(("curve", "playback"), "reference")
    if form == "curve":
        k = int(rng.integers(2, 7))
        frames = np.cumsum(rng.uniform(0.5, 12.0, k)) + rng.uniform(-20, 20)
        method = d.pick(tuple(m for m in qc.METHODS if m not in ("EULER", "QUAT_COMPONENTS")), "method")
        curve = qc.Curve(frames, rng.normal(size=(k, 4)), method=method)
        times = np.arange(frames[0], frames[-1], float(d.pick((1.0, 0.25, 0.05), "step")))
        times = np.append(times, frames[-1]) if times[-1] < frames[-1] - 1e-9 else times
        head, reference = [curve], curve.sample
        excluded = ()
    else:
        mode = d.pick(("QUATERNION", "AXIS_ANGLE") + ORDERS, "mode")
        channels, channel_ipo, times, values = draw_original(d, mode)
        head = [channels, channel_ipo, mode]

        def reference(ts):
            return playback_quats(channels, channel_ipo, mode, ts)
        # Blender's own quaternion sign flips play a fast turn inside one interval: slerp keys take
        # the short way there (as the reduction does); those intervals are not checked.
        excluded = ()
        if mode == "QUATERNION":
            flip = np.flatnonzero(np.sum(values[1:] * values[:-1], axis=1) < 0)
            excluded = tuple(zip(times[flip], times[flip + 1]))
    tol = float(d.pick((1e-4, 1e-3, 0.01, 0.05), "tolerance"))
    bad = d.pick(("ok",) * 6 + ("unsorted", "tolerance", "one"), "form")
    args, must_fail = head + [times, tol], ""
    if bad == "unsorted" and len(times) > 2:
        args[-2] = times[::-1].copy()
        must_fail = "unsorted times"
    elif bad == "tolerance":
        args[-1] = d.pick((-1.0, NAN, INF), "bad_tolerance")
        must_fail = f"tolerance {args[-1]!r}"
    elif bad == "one":
        args[-2] = times[:1]
        must_fail = "one sample"

    def check(out):
        expect(type(out).__name__ == "ProvedSlerpKeys", f"result {type(out).__name__}")
        expect(out.times.ndim == 1 and np.all(np.diff(out.times) > 0), "times not increasing")
        expect(1 <= out.rounds <= 8, f"{out.rounds} rounds")
        idx = out.keys.indices
        expect(idx[0] == 0 and idx[-1] == len(out.times) - 1, "first and last samples not kept")
        expect(np.array_equal(out.key_times, out.times[idx]), "key_times are not the kept samples")
        proof = out.proof
        expect(proof.proven == (len(proof.violations) == 0 and len(proof.unproven) == 0), "proven disagrees")
        finite(proof.bound, "bound")
        repr(out)
        # Every flip of the samples lies in a span left out (the key segment around it); nothing else is.
        spans = np.asarray(out.excluded).reshape(-1, 2)
        for a, b in excluded:
            expect(bool(np.any((spans[:, 0] <= a) & (b <= spans[:, 1]))), f"the flip {a}-{b} is not left out: {spans!r}")
        if form == "curve":
            expect(len(spans) == 0, "a curve has no flips to leave out")
        kt, kq = out.key_times, out.keys.quats
        ts = np.sort(np.concatenate([np.linspace(kt[0], kt[-1], 2001), rng.uniform(kt[0], kt[-1], 1000)]))
        for a, b in spans:
            ts = ts[~((ts > a) & (ts < b))]
        seg = np.clip(np.searchsorted(kt, ts, side="right") - 1, 0, len(kt) - 2)
        a, b = kq[seg], kq[seg + 1]
        u = (ts - kt[seg]) / (kt[seg + 1] - kt[seg])
        b = np.where(np.sum(a * b, axis=1)[:, None] < 0, -b, b)
        ang = np.arccos(np.clip(np.sum(a * b, axis=1), -1.0, 1.0))
        small = ang < 1e-7
        sa = np.where(small, 1.0, np.sin(ang))
        w0 = np.where(small, 1 - u, np.sin((1 - u) * ang) / sa)
        w1 = np.where(small, u, np.sin(u * ang) / sa)
        got = w0[:, None] * a + w1[:, None] * b
        got /= np.linalg.norm(got, axis=1, keepdims=True)
        dense = np_angle(got, reference(ts))
        expect(dense.max() <= proof.bound + 1e-6,
               f"dense evaluation {dense.max()!r} rad at frame {ts[dense.argmax()]!r} above the proved {proof.bound!r}")

    return Case(lambda: fn(*args), 4 * len(times), check, must_fail, 0, args)


# ==== the bake queue (bake.hpp) ==================================================================

def draw_bake_job(d: Draw):
    """Arguments of a BakeJob — keys of any rotation mode (sometimes poisoned or of the wrong width),
    a method and its options, an output mode and a reference (none, a row, one per frame, of the
    wrong width, non-finite) — as (args, kwargs). Whether it is refused is not predicted: the
    oracle is the same curve made and sampled through Curve (curve_keys)."""
    rng = d.rng
    k = d.count(small=30, huge=3_000, label="keys")
    times = increasing_times(rng, k, d.pick(TIME_MODES, "time_mode"))
    keys_mode = d.pick(("QUATERNION",) + ORDERS + ("AXIS_ANGLE", "QUATERNIONS"), "keys_mode")
    if keys_mode in ORDERS:
        values = angles(rng, (k,), d.pick(("calm", "extreme"), "angle_level"))
    else:
        values = quats(rng, (k,), d.pick(("calm", "extreme"), "quat_level"))
        if keys_mode == "AXIS_ANGLE":
            values = axis_angle_rows(rng, values)
    if d.chance(0.1, "poison") and k:
        poison(rng, values, "angles" if keys_mode in ORDERS else "quat", keys_mode in ORDERS)
    if d.chance(0.05, "wrong_width") and k:
        values = values[:, :3] if values.shape[1] == 4 else np.concatenate([values, values[:, :1]], 1)
    method = d.pick(tuple(qc.METHODS), "method")
    kwargs, _ = draw_options(d, method, k)
    mode = d.pick(MODES, "mode")
    width = _channel_count(mode)
    kind = d.pick(("none", "none", "row", "rows", "wide", "nan"), "reference")
    reference = {"none": None, "row": fill(rng, (width,), "calm"), "rows": fill(rng, (3, width), "calm"),
                 "wide": np.zeros(width + 1), "nan": np.full(width, NAN)}[kind]
    args = [times, values, keys_mode, method, mode, reference]
    maybe_junk(d, args, [(), (4,)], ["times", "values"], "")
    return args, kwargs


def curve_keys(frames, times, values, keys_mode, method, mode, reference, **kwargs):
    """The oracle of a BakeJob: (Curve.sample_keys(frames, mode, reference), Curve.path_rule_breaks())
    of the same curve made through Curve, or the ValueError / TypeError it raises."""
    try:
        if keys_mode in ORDERS:
            curve = qc.Curve.from_euler(times, values, order=keys_mode, method=method, **kwargs)
        elif keys_mode == "AXIS_ANGLE":
            curve = qc.Curve.from_axis_angle(times, values, method=method, **kwargs)
        elif keys_mode == "QUATERNION":
            curve = qc.Curve(times, values, method=method, **kwargs)
        else:
            raise ValueError("keys mode %r" % (keys_mode,))
        return curve.sample_keys(frames, mode, reference), curve.path_rule_breaks()
    except (ValueError, TypeError) as error:
        return error


def build_bake_job(fn, d):
    args, kwargs = draw_bake_job(d)

    def check(job):
        expect(type(job).__name__ == "BakeJob", f"result {type(job).__name__}")

    return Case(lambda: fn(*args, **kwargs), max(np.size(args[1]), 1), check, "", 0, (args, kwargs))


def build_bake_queue(fn, d):
    """A queue of drawn jobs on 0-3 worker threads: every job must give exactly what its curve made
    through Curve gives, bit for bit (keys and path-rule breaks), or fail where that fails; a job
    BakeJob refuses must be one Curve refuses too."""
    rng = d.rng
    drawn = [draw_bake_job(d) for _ in range(d.pick((1, 2, 3, 5), "jobs"))]
    m = d.count(small=300, huge=20_000, label="frames")
    frames = np.sort(rng.uniform(-20.0, 120.0, m))
    if d.chance(0.1, "unsorted") and m > 1:
        frames = frames[::-1].copy()
    if d.chance(0.05, "frame_poison") and m:
        frames[rng.integers(0, m)] = rng.choice(POISON_VALUES)
    threads, window = d.pick((0, 1, 2, 3), "threads"), d.pick((1, 2, 8), "window")
    made = []

    def call():
        jobs, results = [], []
        for args, kwargs in drawn:
            try:
                jobs.append(qc.BakeJob(*args, **kwargs))
                made.append(True)
            except (ValueError, TypeError):
                made.append(False)
        queue = fn(frames, jobs, threads=threads, window=window)
        expect(len(queue) == len(jobs) and queue.remaining == len(jobs), "BakeQueue length")
        for _ in jobs:
            try:
                results.append(next(queue))
            except ValueError as error:
                results.append(error)
        expect(queue.remaining == 0, "BakeQueue.remaining after every job")
        try:
            next(queue)
            raise Violation("BakeQueue gave more results than jobs")
        except StopIteration:
            pass
        return results

    def check(results):
        results = iter(results)
        for (args, kwargs), was_made in zip(drawn, made):
            want = curve_keys(frames, *args, **kwargs)
            if not was_made:
                expect(isinstance(want, Exception), "BakeJob refused keys Curve takes")
                continue
            got = next(results)
            if isinstance(want, Exception):
                expect(isinstance(got, Exception), f"the queue took keys Curve refuses ({want})")
                continue
            expect(not isinstance(got, Exception), f"the queue refused keys Curve takes: {got}")
            keys, breaks = got
            expect(keys.dtype == np.float32 and keys.shape == want[0].shape, f"keys {keys.dtype} {keys.shape}")
            expect(keys.tobytes() == want[0].tobytes(), "keys differ from Curve.sample_keys")
            expect(np.array_equal(breaks, want[1]), "path-rule breaks differ from Curve.path_rule_breaks")

    rows = sum(max(np.size(a[1]), 1) for a, _ in drawn) + m
    return Case(call, rows, check, "", 32 * m * len(drawn), {"jobs": drawn, "frames": frames, "threads": threads})

# ==== channels (channels.hpp) ====================================================================

MODES = ("QUATERNION",) + ORDERS + ("AXIS_ANGLE",)


def _channel_count(mode):
    return 3 if mode in ORDERS else 4


def build_quats_to_channels(fn, d: Draw) -> Case:
    """quats_to_channels(quats (N, 4), mode, reference=None|(C,)|(N, C), euler): the channel
    values give back the orientations."""
    rng, level = d.rng, d.level()
    n = d.count(small=200, huge=50_000)
    mode = d.pick(MODES, "mode")
    c = _channel_count(mode)
    q = quats(rng, (n,), "extreme" if level == "poison" else level)
    must_fail = "non-finite or zero" if level == "wild" and n and not np.all(np.isfinite(q)) else ""
    if level == "poison" and n:
        poison(rng, q, "quat", False)
        must_fail = "poisoned"
    ref = d.pick((None, "row", "rows"), "reference")
    reference = None
    if ref == "row":
        reference = fill(rng, (c,), "calm")
    elif ref == "rows" and mode in ORDERS:
        reference = fill(rng, (n, c), "calm")
    args = [q, mode, reference, d.pick(("continuous", "blender"), "euler")]
    generated = q
    if d.chance(0.05, "junk_mode"):
        args[1], bad = d.pick(junk_strings(), "mode")
        must_fail = must_fail or ("junk mode" if bad else "")
    must_fail = maybe_junk(d, args, [(4,)], ["quats"], must_fail)

    def check(out):
        if args[0] is not generated or args[1] != mode:
            return
        shape_is(out, (n, c))
        finite(out)
        if n and np.all(np.abs(q) < 1e150) and np.all(np.linalg.norm(q, axis=1) > 1e-150):
            err = np_angle(qc.channels_to_quats(out, mode), q).max()
            expect(err < 1e-6, f"quats_to_channels changed an orientation by {err!r} rad")
    return Case(lambda: fn(*args), max(n, 1), check, must_fail, n * 32, args)


def build_channels_to_quats(fn, d: Draw) -> Case:
    rng, level = d.rng, d.level()
    n = d.count(small=200, huge=50_000)
    mode = d.pick(MODES, "mode")
    v = fill(rng, (n, _channel_count(mode)), level)
    must_fail = "non-finite" if n and not np.all(np.isfinite(v)) else ""
    args = [v, mode]
    generated = v
    must_fail = maybe_junk(d, args, [(_channel_count(mode),)], ["values"], must_fail)

    def check(out):
        if args[0] is generated:
            shape_is(out, (n, 4))
        unit(out)
    return Case(lambda: fn(*args), max(n, 1), check, must_fail, n * 32, args)


def build_quat_to_euler_blender(fn, d: Draw) -> Case:
    if d.chance(0.5, "with_compat"):
        spec = Elementwise((("q", "quat", True), ("compat", "angles", False)), "angles", order=True,
                           optional=("compat",))
        return spec.build(lambda q, c, **kw: fn(q, compat=c, **kw), d)
    return Elementwise((("q", "quat", True),), "angles", order=True).build(fn, d)


def build_frames_policy(fn, d: Draw, kind) -> Case:
    """step_frames / sample_frames / whole_frame_samples / segment_handles on ordinary and extreme
    ranges: sorted finite frames out, or ValueError (non-finite, unsorted, too many frames)."""
    rng = d.rng
    n = d.count(small=50, huge=10_000)
    t = increasing_times(rng, n, d.pick(("unit", "random", "tiny", "huge", "offset", "subnormal",
                                         "span_overflow", "negative"), "times"))
    if d.chance(0.1, "unsorted") and n > 1:
        t = t[::-1].copy()
    if kind == "step":
        args = [float(t[0]) if n else 0.0, float(t[-1]) if n else d.pick((-1.0, 1.0, np.nan)),
                d.pick((1.0, 1.5, 4.0, 0.5, 0.0, np.inf, np.nan, 1e300), "step")]
    elif kind == "sample":
        args = [t, d.pick((1, 2, 7, 1000, 0, -1), "per_frame")]
    elif kind == "whole":
        args = [t]
    else:
        args = [t, fill(rng, (n,), d.level())]

    def check(out):
        for arr in (out if isinstance(out, tuple) else (out,)):
            finite(arr)
        if kind != "handles":
            expect(np.all(np.diff(out) > 0), "frames not increasing")
    return Case(lambda: fn(*args), max(n, 1), check, "", 8 * 10 ** 8, args)


# ==== cleaning captured rotations (clean.hpp) ====================================================

def draw_clip(d: Draw):
    """A clip for the cleaning functions: (times, quats, must_fail); draw_path's poisoned key times
    are not an argument here. Fewer than 3 frames must be refused."""
    p = draw_path(d, small=300, huge=20_000)
    must_fail = "" if "keys" in p.must_fail else p.must_fail
    if p.rows < 3:
        must_fail = must_fail or "fewer than 3 frames"
    if d.chance(0.15, "noisy_smooth") and p.rows and not must_fail:
        # smooth motion with noise and a spike: the case the functions are for
        rng = d.rng
        steps = np.cumsum(rng.normal(0, 0.02, (p.rows, 3)), 0) + rng.normal(0, 0.01, (p.rows, 3))
        steps[rng.integers(0, p.rows)] += rng.normal(0, 0.5, 3)
        angle = np.linalg.norm(steps, axis=1, keepdims=True)
        with np.errstate(all="ignore"):
            axis = np.where(angle > 0, steps / np.where(angle > 0, angle, 1), [[1.0, 0, 0]])
        q = np.concatenate([np.cos(angle / 2), np.sin(angle / 2) * axis], axis=1)
        return p.times, np.ascontiguousarray(q * rng.choice([-1.0, 1.0], (p.rows, 1))), must_fail
    return p.times, p.quats, must_fail


def spike_indices(idx, n, what):
    shape_is(idx, idx.shape, what)
    expect(idx.dtype.kind == "i" and idx.ndim == 1, f"{what}: dtype {idx.dtype}, shape {idx.shape}")
    expect(np.all((idx >= 0) & (idx < n)) and np.all(np.diff(idx) > 0), f"{what}: {idx!r} for {n} frames")


def clean_checks(out_quats, q, n, deviation, free, what="quats"):
    """Unit, sign-continuous rows; every frame not in `free` within `deviation` of the input."""
    shape_is(out_quats, (n, 4), what)
    unit(out_quats, what)
    expect(np.all(np.sum(out_quats[1:] * out_quats[:-1], axis=1) >= -1e-12), f"{what}: not sign-continuous")
    if n <= 5000 and np.all(np.abs(q) < 1e150) and np.all(np.linalg.norm(q, axis=1) > 1e-150):
        bound = np.setdiff1d(np.arange(n), free)
        if bound.size:
            err = np_angle(out_quats[bound], q[bound]).max()
            expect(err <= deviation * (1 + 1e-9) + 1e-12, f"{what}: a frame {err!r} rad off (deviation {deviation!r})")


def build_remove_quat_flips(fn, d):
    """remove_quat_flips(quats): the same rotations, sign-continuous, the repaired pairs counted."""
    p = draw_path(d, small=300, huge=50_000)
    q, n = p.quats, p.rows
    must_fail = "" if "keys" in p.must_fail or "times" in p.must_fail else p.must_fail
    args = [q]
    must_fail = maybe_junk(d, args, [(4,)], ["quats"], must_fail)

    def check(out):
        quats, flips = out
        if args[0] is not q:
            return
        shape_is(quats, (n, 4))
        finite(quats)
        expect(np.array_equal(np.abs(quats), np.abs(q)), "a component changed beyond its sign")
        if n:
            def scaled(a):  # each row over its largest component: the dots neither overflow nor underflow
                return a / np.abs(a).max(axis=1, keepdims=True)
            a, b = scaled(quats), scaled(q)
            a, b = a / np.linalg.norm(a, axis=1, keepdims=True), b / np.linalg.norm(b, axis=1, keepdims=True)
            # (dots within rounding of 0, orthogonal rotations, may go either way)
            expect(np.all(np.sum(a[1:] * a[:-1], axis=1) >= -1e-12), "not sign-continuous")
            dots = np.sum(b[1:] * b[:-1], axis=1)
            expect(np.sum(dots < -1e-12) <= flips <= np.sum(dots < 1e-12), f"flips {flips}")

    return Case(lambda: fn(*args), max(n, 1), check, must_fail, n * 32, args)


def build_remove_euler_flips(fn, d):
    """remove_euler_flips(angles, order): every orientation kept."""
    rng, level = d.rng, d.level()
    n = d.count(small=300, huge=50_000)
    a = angles(rng, (n,), "extreme" if level == "poison" else level)
    if d.chance(0.4, "smooth") and n:
        a = np.cumsum(rng.normal(0, 0.3, (n, 3)), axis=0)
    must_fail = "non-finite" if level == "wild" and n and not np.all(np.isfinite(a)) else ""
    if level == "poison" and n:
        poison(rng, a, "angles", True)
        must_fail = "poisoned"
    order = d.pick(ORDERS, "order")
    args = [a, order]
    must_fail = maybe_junk(d, args, [(3,)], ["angles"], must_fail)

    def check(out):
        result, flips = out
        if args[0] is not a:
            return
        shape_is(result, (n, 3))
        finite(result)
        expect(0 <= flips < max(n, 1), f"flips {flips}")
        if n and np.all(np.abs(a) < 1e6):
            err = np_angle(qc.euler_to_quat(result, order), qc.euler_to_quat(a, order)).max()
            expect(err < 1e-6, f"an orientation changed by {err!r} rad")

    return Case(lambda: fn(*args), max(n, 1), check, must_fail, n * 24, args)


def build_estimate_rotation_noise(fn, d):
    t, q, must_fail = draw_clip(d)
    args = [t, q]
    if d.chance(0.05, "length_mismatch") and len(t):
        args[1] = q[:-1]
        must_fail = must_fail or "lengths differ"
    must_fail = maybe_junk(d, args, [(), (4,)], ["times", "quats"], must_fail)

    def check(out):
        finite(out, "noise")
        expect(0 <= out <= 2 * np.pi, f"noise {out!r}")

    return Case(lambda: fn(*args), max(len(t), 1), check, must_fail, 0, args)


SPIKE_NOISE = (None, None, 0.0, 1e-3, 0.05, 1.0, 1e300, -1.0, NAN, INF)


def build_find_spikes(fn, d):
    t, q, must_fail = draw_clip(d)
    n = len(t)
    noise = d.pick(SPIKE_NOISE, "noise")
    if noise is not None and not (np.isfinite(noise) and noise >= 0):
        must_fail = must_fail or f"noise {noise!r}"
    kwargs = {"max_run": d.pick((1, 2, 3, 5), "max_run")}
    if d.chance(0.3, "threshold"):
        kwargs["threshold"] = d.pick((0.0, 1.0, 4.0, 1e300), "threshold")
    if d.chance(0.2, "min_angle"):
        kwargs["min_angle"] = d.pick((0.0, 1e-9, 0.5, -0.1, NAN), "min_angle")
        if not kwargs["min_angle"] >= 0:
            must_fail = must_fail or "min_angle"
    args = [t, q, noise]
    must_fail = maybe_junk(d, args, [(), (4,)], ["times", "quats"], must_fail)

    def check(out):
        frames, departures = out
        spike_indices(frames, n, "frames")
        shape_is(departures, frames.shape, "departures")
        in_range(departures, 0.0, np.pi, "departures")

    return Case(lambda: fn(*args, **kwargs), max(n, 1), check, must_fail, 0, (args, kwargs))


def build_replace_spikes(fn, d):
    t, q, must_fail = draw_clip(d)
    n = len(t)
    rng = d.rng
    frames = np.unique(rng.integers(0, max(n, 1), rng.integers(0, 6))) if n else np.zeros(0, int)
    if d.chance(0.1, "bad_frames") and frames.size:
        frames = frames[::-1].copy() if frames.size > 1 else np.array([n + 3])
        must_fail = must_fail or "frames not increasing or out of range"
    args = [t, q, frames]
    must_fail = maybe_junk(d, args, [(), (4,)], ["times", "quats"], must_fail)

    def check(out):
        if args[1] is not q:
            return
        clean_checks(out, q, n, 0.0, frames)

    return Case(lambda: fn(*args), max(n, 1), check, must_fail, n * 32, args)


DEVIATIONS = (0.0, 1e-12, 1e-3, 0.02, 0.3, 4.0, 1e300, -1e-3, NAN, INF)


def build_smooth_rotations(fn, d):
    t, q, must_fail = draw_clip(d)
    n = len(t)
    deviation = d.pick(DEVIATIONS, "deviation")
    if not (np.isfinite(deviation) and deviation >= 0):
        must_fail = must_fail or f"deviation {deviation!r}"
    kwargs = {}
    if d.chance(0.3, "smoothness"):
        kwargs["smoothness"] = d.pick((1e-3, 1.0, 1e4, 1e10, 0.0, -1.0, NAN), "smoothness")
        if not (np.isfinite(kwargs["smoothness"]) and kwargs["smoothness"] > 0):
            must_fail = must_fail or "smoothness"
    if d.chance(0.3, "noise"):
        kwargs["noise"] = d.pick((0.0, 0.01, 1.0, -1.0), "noise")
        if kwargs["noise"] < 0:
            must_fail = must_fail or "noise"
    free = np.unique(d.rng.integers(0, max(n, 1), d.rng.integers(0, 4))) if n and d.chance(0.3, "free") else None
    if free is not None:
        kwargs["free_frames"] = free
    args = [t, q, deviation]
    must_fail = maybe_junk(d, args, [(), (4,)], ["times", "quats"], must_fail)

    def check(out):
        expect(type(out).__name__ == "Smoothed", f"result {type(out).__name__}")
        finite(out.max_deviation, "max_deviation")
        expect(out.max_deviation <= deviation, f"max_deviation {out.max_deviation!r} above {deviation!r}")
        finite(out.smoothness, "smoothness")
        if args[1] is q:
            clean_checks(out.quats, q, n, deviation, free if free is not None else [])

    return Case(lambda: fn(*args, **kwargs), max(n, 1), check, must_fail, n * 32, (args, kwargs))


def build_clean_rotations(fn, d):
    t, q, must_fail = draw_clip(d)
    n = len(t)
    kwargs = {}
    if d.chance(0.3, "deviation"):
        kwargs["deviation"] = d.pick(DEVIATIONS, "deviation")
        if not (np.isfinite(kwargs["deviation"]) and kwargs["deviation"] >= 0):
            must_fail = must_fail or "deviation"
    if d.chance(0.2, "noise"):
        kwargs["noise"] = d.pick(SPIKE_NOISE[2:], "noise")
        if not (np.isfinite(kwargs["noise"]) and kwargs["noise"] >= 0):
            must_fail = must_fail or "noise"
    if d.chance(0.2, "switches"):
        kwargs["spikes"] = d.pick((True, False), "spikes")
        kwargs["smooth"] = d.pick((True, False), "smooth")
    if d.chance(0.1, "max_run"):
        kwargs["spike_max_run"] = d.pick((1, 4), "spike_max_run")
    args = [t, q]
    must_fail = maybe_junk(d, args, [(), (4,)], ["times", "quats"], must_fail)

    def check(out):
        expect(type(out).__name__ == "CleanResult", f"result {type(out).__name__}")
        for name in ("noise", "deviation", "max_deviation", "smoothness"):
            finite(getattr(out, name), name)
        expect(out.max_deviation <= out.deviation, f"max_deviation {out.max_deviation!r} above {out.deviation!r}")
        spike_indices(out.spike_frames, n, "spike_frames")
        in_range(out.spike_departures, 0.0, np.pi, "spike_departures")
        if args[1] is q:
            clean_checks(out.quats, q, n, out.deviation, out.spike_frames)
        repr(out)

    return Case(lambda: fn(*args, **kwargs), max(n, 1), check, must_fail, n * 32, (args, kwargs))


# ==== the registry ===============================================================================

def _elementwise(name):
    spec = ELEMENTWISE[name]
    return lambda fn, d: spec.build(fn, d)


def build_skeleton(fn, d):
    """Skeleton: a random armature (now and then a bad parent, a non-rigid or non-finite rest matrix, a
    negative length) and one of its methods on random channels of any level; the pose, vertices,
    errors and budgets must be finite, a reduction within its distance (or refused)."""
    rng, level = d.rng, d.level()
    bones = d.count(small=6, huge=40, label="bones")
    n = d.count(small=12, huge=200, label="samples")
    parents = np.array([-1] + [int(rng.integers(0, b)) for b in range(1, bones)]) if bones else np.zeros(0, int)
    rest = np.tile(np.eye(4), (bones, 1, 1))
    if bones:
        q = fill(rng, (bones, 4), "calm")
        rest[:, :3, :3] = quat_to_matrix_np(q / np.linalg.norm(q, axis=1, keepdims=True))
        rest[:, :3, 3] = fill(rng, (bones, 3), "calm")
    lengths = np.abs(fill(rng, (bones,), "calm"))
    must_fail = ""
    if bones and d.chance(0.1, "bad_skeleton"):
        what = d.pick(("parent", "rest", "length"), "bad_part")
        if what == "parent":
            parents[-1] = bones
        elif what == "rest":
            rest[-1, 0, 0] = d.pick((2.0, NAN, INF), "bad_rest")
        else:
            lengths[-1] = d.pick((-1.0, NAN), "bad_length")
        must_fail = "bad skeleton " + what
    flags = dict(inherit_rotation=rng.random(bones) < 0.7, connected=rng.random(bones) < 0.3,
                 inherit_scale=[d.pick(("FULL", "NONE"), "scale_mode") for _ in range(bones)] if bones else None)
    loc = fill(rng, (bones, n, 3), level)
    rot = fill(rng, (bones, n, 4), level)
    scale = fill(rng, (bones, n, 3), level)
    shell = float(d.pick((0.1, 0.0, 1.0, -1.0, NAN), "shell"))
    method = d.pick(("pose", "virtual_vertices", "vertex_error", "vertex_distances", "dominant_shell_budgets", "reduce",
                     "reduce_slerp"), "method")
    finite_in = all(np.all(np.isfinite(a)) for a in (loc, rot, scale))
    if method in ("pose", "vertex_error", "vertex_distances") and not finite_in:
        must_fail = must_fail or "non-finite channels"
    if method != "pose" and not (shell >= 0):
        must_fail = must_fail or "bad shell"
    distance = float(d.pick((0.001, 0.1, 0.0, NAN), "distance"))

    def call():
        sk = fn(parents, rest, lengths, **flags)
        if method == "pose":
            return sk.pose(loc, rot, scale)
        if method == "virtual_vertices":
            return sk.virtual_vertices(sk.pose(loc, rot, scale), shell)
        if method == "vertex_error":
            return sk.vertex_error((loc, rot, scale), (loc, rot[:, ::-1], scale), shell)
        if method == "vertex_distances":
            return sk.vertex_distances((loc, rot, scale), (loc, rot[:, ::-1], scale), shell)
        if method == "dominant_shell_budgets":
            return sk.dominant_shell_budgets(sk.pose(loc, rot, scale), distance, shell)
        m = min(n, 20)
        angles = np.clip(np.cumsum(fill(rng, (bones, m, 3), "calm") * 0.05, axis=1), -10, 10)
        if method == "reduce_slerp":
            # Per bone: kept, held at samples (half-frame times) or proved against a curve through the frames.
            t = np.arange(m, dtype=float)
            dense = np.arange(2 * m - 1) * 0.5
            quats = np.array([qc.euler_to_quat(a, "XYZ") for a in angles]) if bones else np.zeros((0, m, 4))
            specs = []
            for b in range(bones):
                kind = d.pick(("kept", "samples", "curve"), "slerp_bone")
                curve = qc.Curve(t, quats[b], method="SQUAD") if m >= 2 else None
                if kind == "kept" or curve is None:
                    specs.append(None)
                elif kind == "samples":
                    specs.append(qc.SlerpBone(dense, samples=curve.sample(dense)))
                else:
                    specs.append(qc.SlerpBone(dense, reference=curve))
                if curve is not None:
                    quats[b] = curve.sample(t)
            return sk.reduce_slerp(t, quats, np.clip(loc[:, :m], -1e3, 1e3), np.ones((bones, m, 3)), distance, shell,
                                   specs)
        return sk.reduce(np.arange(m, dtype=float), [("XYZ", a) for a in angles], np.clip(loc[:, :m], -1e3, 1e3),
                         np.ones((bones, m, 3)), distance, shell)  # unit scales: the float32 floor stays below the distance

    def check(out):
        if method in ("reduce", "reduce_slerp"):
            finite(out.budgets, "budgets")
            expect(out.error.distance <= distance or out.error.distance < 1e-5,  # or the float32 floor
                   f"error {out.error.distance!r} above distance {distance!r}")
        elif method == "vertex_error":
            finite(out.distance, "distance")
            finite(out.per_bone, "per_bone")
        else:
            finite(out, method)

    return Case(call, max(bones * n, 1), check, must_fail, 200 * bones * n, (parents, rest, lengths, method))


def build_slerp_bone(fn, d):
    """SlerpBone(times, reference=... | samples=...): built from a Curve, from F-curves of any mode, or
    from samples; refused with neither, with both, with samples that do not match the times, with bad
    F-curves or a bad mode."""
    rng = d.rng
    n = int(rng.integers(2, 30))
    times = np.cumsum(rng.uniform(0.1, 3.0, n))
    form = d.pick(("curve", "playback", "samples", "neither", "both", "short", "bad_mode"), "form")
    curve = qc.Curve(times, rng.normal(size=(n, 4)), method="SLERP")
    must_fail = {"neither": "no reference or samples", "both": "reference and samples", "short": "samples short",
                 "bad_mode": "unknown mode"}.get(form, "")

    def call():
        if form == "curve":
            return fn(times, reference=curve, cyclic=False)
        if form in ("playback", "bad_mode"):
            channels = [(times, rng.normal(size=n)) for _ in range(4)]
            return fn(times, reference=(channels, "LINEAR", "QUATERNION" if form == "playback" else "XYZW"))
        if form == "samples":
            return fn(times, samples=curve.sample(times))
        if form == "both":
            return fn(times, reference=curve, samples=curve.sample(times))
        if form == "short":
            return fn(times, samples=curve.sample(times)[:-1])
        return fn(times)

    def check(out):
        expect(out.proved == (form in ("curve", "playback")), "proved flag")
        expect(np.array_equal(out.times, times), "times kept")
        repr(out)

    return Case(call, n, check, must_fail, 0, (form,))


def build_play_slerp_keys(fn, d):
    """play_slerp_keys: unit rotations; the keys themselves (float32) at their times; the first key
    before them and the last after (or wrapped, cyclic); refused for sizes that differ, unsorted or
    non-finite times, no keys."""
    rng = d.rng
    k = int(rng.integers(1, 12))
    kt = np.cumsum(rng.uniform(0.1, 5.0, k))
    keys = rng.normal(size=(k, 4))
    at = np.concatenate([kt, rng.uniform(kt[0] - 5, kt[-1] + 5, 20)])
    cyclic = bool(d.chance(0.3, "cyclic"))
    bad = d.pick(("ok",) * 5 + ("sizes", "unsorted", "nan", "empty"), "form")
    must_fail = ""
    if bad == "sizes":
        keys, must_fail = keys[:-1] if k > 1 else np.zeros((0, 4)), "sizes differ"
    elif bad == "unsorted" and k > 1:
        kt, must_fail = kt[::-1].copy(), "unsorted"
    elif bad == "nan":
        at, must_fail = np.append(at, NAN), "nan time"
    elif bad == "empty":
        kt, keys, must_fail = np.zeros(0), np.zeros((0, 4)), "no keys"

    def check(out):
        shape_is(out, (len(at), 4), "play_slerp_keys")
        unit(out, "play_slerp_keys")
        stored = keys.astype(np.float32).astype(np.float64)
        stored /= np.linalg.norm(stored, axis=1, keepdims=True)
        got = out[:k]
        expect(np.all(np_angle(got[:-1] if cyclic else got, stored[:-1] if cyclic else stored) < 1e-6),
               "keys not played at their times")

    return Case(lambda: fn(kt, keys, at, cyclic=cyclic), len(at), check, must_fail, 0, (kt, keys, cyclic))


def build_cpu_level(fn, d):
    """cpu_level(): 0, 3 or 4; any argument refused."""
    args = d.pick(((), (), (1,), ("x",)), "args")

    def check(out):
        assert out in (0, 3, 4), out

    return Case(lambda: fn(*args), 1, check, "cpu_level takes no arguments" if args else "")


def _not_constructible(fn, d):
    """Result classes (ReducedKeys, ReducedChannel) are not built from Python: any call is refused."""
    args = d.pick(((), (1,), (None,), ("x", 2), (np.zeros(4),)), "args")
    return Case(lambda: fn(*args), 1, lambda out: None, "result class constructed from Python")


REGISTRY: dict[str, Callable[[Callable, Draw], Case]] = {name: _elementwise(name) for name in ELEMENTWISE}
REGISTRY.update({
    "quat_to_euler": build_quat_to_euler,
    "euler_filter": build_euler_filter,
    "euler_middle_axis": build_euler_middle_axis,
    "angular_deviation": build_angular_deviation,
    "interval_speeds": build_interval_speeds,
    "segment_speed_ratios": build_segment_speed_ratios,
    "segment_speed_ratios_from_velocity": build_segment_speed_ratios_from_velocity,
    "path_length": build_path_length,
    "key_jumps": build_key_jumps,
    "gimbal_distances": build_gimbal_distances,
    "gimbal_distances_from_quats": build_gimbal_distances_from_quats,
    "closest_gimbal_approach": build_closest_gimbal_approach,
    "quats_to_channels": build_quats_to_channels,
    "channels_to_quats": build_channels_to_quats,
    "quat_to_euler_blender": build_quat_to_euler_blender,
    "step_frames": lambda fn, d: build_frames_policy(fn, d, "step"),
    "sample_frames": lambda fn, d: build_frames_policy(fn, d, "sample"),
    "whole_frame_samples": lambda fn, d: build_frames_policy(fn, d, "whole"),
    "segment_handles": lambda fn, d: build_frames_policy(fn, d, "handles"),
    "path_metrics": build_path_metrics,
    "reduce_keys": lambda fn, d: build_reduce(fn, d, euler=False),
    "reduce_keys_euler": lambda fn, d: build_reduce(fn, d, euler=True),
    "reduce_keys_axis_angle": lambda fn, d: build_reduce(fn, d, euler=False, axis_angle=True),
    "axis_angle_span": build_axis_angle_span,
    "fit_keys": build_fit,
    "fit_through_keys": build_fit_through_keys,
    "fit_channels": build_fit_channels,
    "FitQueue": build_fit_queue,
    "blender_evaluate": build_blender_evaluate,
    "BakeJob": build_bake_job,
    "BakeQueue": build_bake_queue,
    "reduce_slerp": build_reduce_slerp,
    "gltf_slerp": build_gltf_slerp,
    "cpu_level": build_cpu_level,
    "SlerpKeys": _not_constructible,
    "KeyFit": _not_constructible,
    "PlaybackBound": _not_constructible,
    "prove_playback": build_prove_playback,
    "reduce_keys_proved": build_reduce_keys_proved,
    "reduce_curve_proved": build_reduce_curve_proved,
    "convert_keys_proved": build_convert_keys_proved,
    "reduce_slerp_proved": build_reduce_slerp_proved,
    "ProvedSlerpKeys": _not_constructible,
    "ProvedKeys": _not_constructible,
    "ReducedKeys": _not_constructible,
    "ReducedChannel": _not_constructible,
    "Skeleton": build_skeleton,
    "VertexError": _not_constructible,
    "SkeletonReduction": _not_constructible,
    "SkeletonSlerpReduction": _not_constructible,
    "SlerpBone": build_slerp_bone,
    "play_slerp_keys": build_play_slerp_keys,
    "remove_quat_flips": build_remove_quat_flips,
    "remove_euler_flips": build_remove_euler_flips,
    "estimate_rotation_noise": build_estimate_rotation_noise,
    "find_spikes": build_find_spikes,
    "replace_spikes": build_replace_spikes,
    "smooth_rotations": build_smooth_rotations,
    "clean_rotations": build_clean_rotations,
    "Smoothed": _not_constructible,
    "CleanResult": _not_constructible,
    # "Curve" itself is fuzzed per method: targets "Curve[<METHOD>]" (see targets()).
    "Curve": None,
})


def public_callables():
    """Every public callable of the module (what must have a strategy)."""
    return sorted(n for n in dir(qc) if not n.startswith("_") and callable(getattr(qc, n)))


def targets():
    """Fuzz targets: each public callable with a strategy, and Curve once per method."""
    out = [n for n in public_callables() if REGISTRY.get(n) is not None]
    out += [f"Curve[{m}]" for m in getattr(qc, "METHODS", ())]
    return out


def builder(target):
    if target.startswith("Curve["):
        method = target[len("Curve["):-1]
        return lambda d: build_curve(method, d)
    fn = getattr(qc, target)
    return lambda d: REGISTRY[target](fn, d)


# ==== running ====================================================================================

def run_target(target, examples=None):
    """Fuzz one target; returns a result dict (status ok/fail, counts, message)."""
    build = builder(target)
    if examples is None:
        examples = max(1, int(EXAMPLES * EXAMPLE_SHARE.get(target, 1.0)))
    phases = tuple(Phase) if SHRINK else tuple(p for p in Phase if p not in (Phase.shrink, Phase.explain))
    stats = {"calls": 0, "rows": 0, "refused": 0}

    @settings(max_examples=examples, derandomize=not LONG, database=None, deadline=None, phases=phases,
              suppress_health_check=list(HealthCheck), print_blob=LONG, report_multiple_bugs=False)
    @given(st.data())
    def prop(data):
        case = build(Draw(data))
        try:
            run_case(case, stats)
        except Violation as v:
            raise Violation(f"{v}\ninputs: {describe(case.inputs)}") from None
        stats["calls"] += 1
        stats["rows"] += case.rows

    def run_case(case, stats):
        faulthandler.dump_traceback_later(CALL_TIMEOUT, exit=True)
        try:
            out = case.call()
        except (ValueError, TypeError) as e:
            stats["refused"] += 1
            expect(str(e).strip() != "", f"{type(e).__name__} without a message")
        except MemoryError as e:
            if case.out_bytes <= MEMORY_LIMIT:
                raise Violation(f"MemoryError for an output of {case.out_bytes} bytes: {e}") from e
        except Violation:
            raise
        except BaseException as e:  # noqa: BLE001 — anything else breaks the contract
            raise Violation(f"raised {type(e).__name__}: {e}") from e
        else:
            if case.must_fail:
                raise Violation(f"accepted bad input ({case.must_fail}); returned {summary(out)}")
            case.check(out)
        finally:
            faulthandler.cancel_dump_traceback_later()

    start = time.perf_counter()
    result = {"target": target, "status": "ok", "message": ""}
    try:
        prop()
    except Exception as e:  # noqa: BLE001 — the failure is the report
        result["status"] = "fail"
        text = "".join(traceback.format_exception(e))
        result["message"] = text[-6000:]
    result.update(stats, seconds=round(time.perf_counter() - start, 3))
    return result


def describe(x, depth=0):
    """Inputs for a failure report: small arrays in full (17 digits), large ones by shape, dtype,
    their first rows and where their non-finite values are."""
    if isinstance(x, np.ndarray):
        if x.size <= 48:
            body = np.array2string(x, precision=17, separator=", ", threshold=64) if x.dtype.kind in "fciub" else repr(x.tolist())
            return f"array({body}, dtype={x.dtype})"
        text = f"array(shape={x.shape}, dtype={x.dtype}, first={np.array2string(x.reshape(-1)[:12], precision=17, separator=', ')}"
        if x.dtype.kind in "fc":
            bad = np.argwhere(~np.isfinite(x))
            text += f", non-finite at {bad[:4].tolist()}" if bad.size else ""
            text += f", |max|={np.nanmax(np.abs(x)) if np.isfinite(x).any() else None!r}"
        return text + ")"
    if isinstance(x, (list, tuple)) and depth < 3:
        inner = ", ".join(describe(v, depth + 1) for v in x[:8])
        return ("[" + inner + "]") if isinstance(x, list) else ("(" + inner + ")")
    if isinstance(x, dict) and depth < 3:
        return "{" + ", ".join(f"{k!r}: {describe(v, depth + 1)}" for k, v in x.items()) + "}"
    return repr(x)[:300]


def summary(out):
    if isinstance(out, np.ndarray):
        return f"array{out.shape} {np.array2string(out.reshape(-1)[:8], threshold=8)}"
    if isinstance(out, dict):
        return "{" + ", ".join(f"{k}: {summary(v)}" for k, v in list(out.items())[:6]) + "}"
    return repr(out)[:300]


def limit_memory():
    try:
        import resource
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))
    except (ImportError, ValueError, OSError):
        pass


def main(argv):
    """Child entry: fuzz the targets named in argv (all when none), one JSON line per target into
    $QUATCURVE_FUZZ_RESULTS (or stdout). A line {"start": target} precedes each target, so a crash
    is attributed to it."""
    faulthandler.enable()
    warnings.simplefilter("ignore")
    limit_memory()
    names = argv or targets()
    path = os.environ.get("QUATCURVE_FUZZ_RESULTS")
    sink = open(path, "a", buffering=1) if path else sys.stdout
    for name in names:
        sink.write(json.dumps({"start": name}) + "\n")
        sink.flush()
        result = run_target(name)
        sink.write(json.dumps(result) + "\n")
        sink.flush()
        if not path:
            print(f"{name}: {result['status']} {result['rows']} rows in {result['seconds']} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
