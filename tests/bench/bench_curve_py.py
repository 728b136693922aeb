"""SLERP through Python: quatcurve.Curve against scipy's Slerp on the same arrays (run by hand).

    PYTHONPATH=<build>/python .venv/bin/python tests/bench/bench_curve_py.py

Same work for both: 1,000 random keys at unit spacing, 10 samples per segment (sorted times), one
call each. Prints best-of-N wall times for sampling alone and for construction + sampling, and the
ratios (target: at least 20x on sampling). `--smoke` (tests/bench/smoke.py): 20 keys, each call
timed once.
"""
import time

import numpy as np
from scipy.spatial.transform import Rotation as R
from scipy.spatial.transform import Slerp

import quatcurve as qc
import smoke


def best(f, seconds=0.5):
    f()
    if smoke.SMOKE:
        t0 = time.perf_counter()
        f()
        return time.perf_counter() - t0
    reps, elapsed = 1, 0.0
    while elapsed < 0.05:
        t0 = time.perf_counter()
        for _ in range(reps):
            f()
        elapsed = time.perf_counter() - t0
        reps *= 2
    reps //= 2
    out = []
    deadline = time.perf_counter() + seconds
    while time.perf_counter() < deadline or len(out) < 5:
        t0 = time.perf_counter()
        for _ in range(reps):
            f()
        out.append((time.perf_counter() - t0) / reps)
    return min(out)


def main():
    keys = 20 if smoke.SMOKE else 1000
    per = 10
    times = np.arange(keys, dtype=float)
    rotations = R.random(keys, random_state=1)
    quats = rotations.as_quat(scalar_first=True)
    samples = np.arange((keys - 1) * per, dtype=float) / per

    curve = qc.Curve(times, quats, "SLERP")
    slerp = Slerp(times, rotations)
    ours = curve.sample(samples)
    theirs = slerp(samples).as_quat(scalar_first=True)
    err = np.max((R.from_quat(ours, scalar_first=True) * R.from_quat(theirs, scalar_first=True).inv()).magnitude())

    t_ours = best(lambda: curve.sample(samples))
    t_scipy = best(lambda: slerp(samples))
    t_ours_all = best(lambda: qc.Curve(times, quats, "SLERP").sample(samples))
    t_scipy_all = best(lambda: Slerp(times, R.from_quat(quats, scalar_first=True))(samples).as_quat(scalar_first=True))

    n = samples.size
    print(f"SLERP through Python: {keys} keys at unit spacing, {per} samples per segment ({n} sorted times)")
    print(f"{'':34s} {'ms':>9s} {'M samples/s':>12s}")
    print(f"{'scipy Slerp(times)':34s} {t_scipy * 1e3:9.3f} {n / t_scipy * 1e-6:12.1f}")
    print(f"{'quatcurve Curve.sample(times)':34s} {t_ours * 1e3:9.3f} {n / t_ours * 1e-6:12.1f}")
    print(f"{'  ratio (sampling)':34s} {t_scipy / t_ours:9.1f}x")
    print(f"{'scipy build + sample + as_quat':34s} {t_scipy_all * 1e3:9.3f}")
    print(f"{'quatcurve build + sample':34s} {t_ours_all * 1e3:9.3f}")
    print(f"{'  ratio (build + sampling)':34s} {t_scipy_all / t_ours_all:9.1f}x")
    print(f"max angle between the two: {err:.2e} rad")


if __name__ == "__main__":
    smoke.run(main)
