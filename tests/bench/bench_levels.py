"""The hot samplers' versions against each other, through Python, in one run (run by hand).

    PYTHONPATH=<build>/python .venv/bin/python tests/bench/bench_levels.py
    PYTHONPATH=<folder of an installed wheel> <its Python> tests/bench/bench_levels.py

The module runs the x86-64-v4, x86-64-v3 or baseline version of its hot samplers, chosen by cpuid at
the first call (native/src/curve_impl.hpp); QUATCURVE_CPU_LEVEL=0 or 3 caps the level. This script runs
itself once per level in a child process (the level is fixed for a process) and prints, per method,
ns a sample of Curve.sample at each level and the ratio to the baseline version: 1,000 random keys
(large arcs) at unit spacing, 10 samples per segment (sorted times), best of a few calls. A level the
CPU does not have runs the highest it has (the column says which ran). `--smoke`
(tests/bench/smoke.py): 20 keys, each call timed once.
"""
import json
import os
import subprocess
import sys
import time

import numpy as np

import smoke

METHODS = ("SLERP", "SQUAD", "SPLINE_C2")
LEVELS = ("0", "3", "4")


def measure():
    """{method: ns a sample} of this process's version, and the module's own level."""
    import quatcurve as qc

    rng = np.random.default_rng(7)
    keys = 20 if smoke.SMOKE else 1000
    q = rng.normal(size=(keys, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    t = np.arange(keys, dtype=np.float64)
    times = np.linspace(0.0, keys - 1.0, (keys - 1) * 10)
    out = {}
    for method in METHODS:
        curve = qc.Curve(t, q, method)
        curve.sample(times)
        best = float("inf")
        for _ in range(1 if smoke.SMOKE else 20):
            t0 = time.perf_counter()
            curve.sample(times)
            best = min(best, time.perf_counter() - t0)
        out[method] = best / times.size * 1e9
    return out


def main():
    if os.environ.get("QUATCURVE_BENCH_LEVELS_CHILD"):
        print(json.dumps(measure()))
        return 0
    rows = {}
    for level in LEVELS:
        env = dict(os.environ, QUATCURVE_CPU_LEVEL=level, QUATCURVE_BENCH_LEVELS_CHILD="1")
        run = subprocess.run([sys.executable, os.path.abspath(__file__)] + sys.argv[1:], env=env,
                             capture_output=True, text=True, check=True)
        rows[level] = json.loads(run.stdout.strip().splitlines()[-1])
    print("Curve.sample, ns a sample, by the version run (QUATCURVE_CPU_LEVEL caps it; load average %s)"
          % " ".join("%.2f" % x for x in os.getloadavg()))
    print("%-10s %12s %12s %12s %14s %14s" % ("method", "baseline", "x86-64-v3", "x86-64-v4", "v3 / baseline",
                                             "v4 / baseline"))
    for method in METHODS:
        base, v3, v4 = (rows[level][method] for level in LEVELS)
        print("%-10s %12.2f %12.2f %12.2f %13.2fx %13.2fx" % (method, base, v3, v4, base / v3, base / v4))
    return 0


if __name__ == "__main__":
    smoke.run(main)
