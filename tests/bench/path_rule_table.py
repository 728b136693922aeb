"""Worst path ratio per method over the spacing/hold test cases (tests/python/test_curve_tangents.py),
textbook tangents (clamped=False) against the default clamped ones.

    .venv/bin/python tests/bench/path_rule_table.py

ratio = path length / keyed arc of the worst key segment (arcs of 5° or more); 'rule' is the worst
excess over 1.5 × arc + 10° (≤ 0 obeys the path rule). `--smoke` (tests/bench/smoke.py): one spacing
ratio, one arc and two random trials."""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))
import quatcurve as qc  # noqa: E402
import smoke  # noqa: E402
from test_curve_tangents import DEG, chain, path_lengths  # noqa: E402


RATIOS, ARCS, TRIALS = ((10,), (40,), 2) if smoke.SMOKE else ((1, 10, 100, 1000), (5, 40, 120), 25)


def cases():
    rng = np.random.default_rng(0)
    for ratio in RATIOS:
        for arc in ARCS:
            for turning in (False, True):
                t = np.array([1, 2, 2 + ratio, 3 + ratio, 3 + 2 * ratio, 4 + 2 * ratio], float)
                axes = rng.normal(size=(5, 3)) if turning else [(0, 0, 1)] * 5
                yield t, chain([arc * DEG] * 5, axes)
    yield np.array([1.0, 2.0, 102.0]), chain([80 * DEG, 6 * DEG], [(1, 0, 0), (0.2, 1, 0)])
    yield np.array([1.0, 3.0, 203.0, 205.0]), chain([90 * DEG, 0.0, 120 * DEG], [(0, 0, 1), (0, 0, 1), (1, 0, 0)])
    gaps = np.array([0.5, 1, 2, 3, 5, 8, 12, 24, 48, 120])
    for trial in range(TRIALS):
        n = 4 + trial % 6
        t = np.cumsum(np.r_[1.0, rng.choice(gaps, n - 1)])
        arcs = np.where(rng.random(n - 1) < 0.2, 0.0, rng.random(n - 1) * 170 * DEG)
        yield t, chain(arcs, rng.normal(size=(n - 1, 3)))


def worst(method, **options):
    ratio, excess = 0.0, -np.inf
    for t, keys in cases():
        c = qc.Curve(t, keys, method, **options)
        lengths = path_lengths(c)
        arcs = c.segment_paths()[:, 0]
        big = arcs >= 5 * DEG
        if big.any():
            ratio = max(ratio, float((lengths[big] / arcs[big]).max()))
        excess = max(excess, float((lengths - 1.5 * arcs - 10 * DEG).max()))
    return ratio, excess / DEG


def main():
    print(f"{'method':<12} {'textbook ratio':>15} {'rule excess':>12} {'clamped ratio':>14} {'rule excess':>12}")
    for method in ("SQUAD", "TCB", "CATMULL_ROM"):
        (r0, e0), (r1, e1) = worst(method, clamped=False), worst(method)
        print(f"{method:<12} {r0:>15.2f} {e0:>11.1f}° {r1:>14.2f} {e1:>11.1f}°")
    for method in ("SLERP", "SPLINE_C2"):
        r, e = worst(method)
        print(f"{method:<12} {r:>15.2f} {e:>11.1f}°   (not clamped)")


if __name__ == "__main__":
    smoke.run(main)
