"""Native fuzzing: the smoke run of tests/python/fuzz_native.py (every public function of `quatcurve`
and every Curve method, random and extreme arrays, at least 100,000 cases), one pytest test per
target, plus the regression cases the fuzzer found.

The fuzzer runs in a child Python: a segfault or a hang (its watchdog dumps the stack and exits)
fails that target and the child is restarted for the rest, so one crash does not abort pytest.
Long campaign: QUATCURVE_FUZZ_LONG=1 (random seeds, 20,000 examples per target; see docs/testing.md,
"Hardening")."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import quatcurve as qc

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import fuzz_native as fz  # noqa: E402  (beside this file)

SMOKE_MIN_CASES = 100_000
TARGETS = fz.targets()


def exit_reason(code, stderr):
    if isinstance(code, int) and code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    if "Timeout (" in (stderr or ""):
        return f"hang: one call ran longer than {fz.CALL_TIMEOUT:.0f} s"
    return f"exit status {code}"


def run_children(names, workdir):
    """Fuzz `names` in child processes; a child that dies mid-target is restarted on the rest."""
    results, pending, attempt = {}, list(names), 0
    while pending:
        attempt += 1
        out = workdir / f"fuzz-{attempt}.jsonl"
        env = dict(os.environ, QUATCURVE_FUZZ_RESULTS=str(out), PYTHONFAULTHANDLER="1")
        try:
            proc = subprocess.run([sys.executable, str(HERE / "fuzz_native.py"), *pending], env=env,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                  timeout=None if fz.LONG else 1800)
            code, stderr = proc.returncode, proc.stderr
        except subprocess.TimeoutExpired as e:
            code, stderr = "timeout (1800 s)", e.stderr.decode() if isinstance(e.stderr, bytes) else (e.stderr or "")
        started = None
        for line in out.read_text().splitlines() if out.exists() else []:
            record = json.loads(line)
            if "start" in record:
                started = record["start"]
            else:
                results[record["target"]] = record
                started = None
        dead = [started] if started is not None else ([n for n in pending if n not in results] if code != 0 else [])
        for name in dead:
            results[name] = {"target": name, "status": "crash", "calls": 0, "rows": 0, "refused": 0,
                             "seconds": 0.0,
                             "message": f"the fuzzing child died in {name}: {exit_reason(code, stderr)}\n"
                                        f"{(stderr or '')[-4000:]}"}
        pending = [n for n in pending if n not in results]
    return results


@pytest.fixture(scope="module")
def fuzz(tmp_path_factory):
    start = time.perf_counter()
    results = run_children(TARGETS, tmp_path_factory.mktemp("fuzz"))
    return results, time.perf_counter() - start


def test_every_public_callable_has_a_strategy():
    missing = [n for n in fz.public_callables() if n not in fz.REGISTRY]
    assert not missing, f"public callables of quatcurve without a fuzz strategy in fuzz_native.REGISTRY: {missing}"


def test_every_curve_member_is_fuzzed():
    members = {n for n in dir(qc.Curve) if not n.startswith("_")}
    assert members <= fz.CURVE_MEMBERS, f"Curve members the fuzzer does not call: {sorted(members - fz.CURVE_MEMBERS)}"
    assert set(qc.METHODS) == {t[len("Curve["):-1] for t in TARGETS if t.startswith("Curve[")}


@pytest.mark.parametrize("target", TARGETS)
def test_fuzz(fuzz, target):
    results, _ = fuzz
    r = results[target]
    assert r["status"] == "ok", f"{target}: {r['status']}\n{r['message']}"


def test_fuzz_case_count(fuzz, capsys):
    results, seconds = fuzz
    rows = sum(r["rows"] for r in results.values())
    calls = sum(r["calls"] for r in results.values())
    refused = sum(r["refused"] for r in results.values())
    with capsys.disabled():
        print(f"\n[fuzz] {len(results)} targets, {calls} calls ({refused} refused with ValueError/TypeError), "
              f"{rows} cases (rows), {seconds:.1f} s{' (long campaign)' if fz.LONG else ''}")
    assert rows >= SMOKE_MIN_CASES


# ==== regressions found by the fuzzer ===============================================================
# Each is the smallest input found; the expected outcome is the contract (a ValueError, or a finite,
# unit result). Cases that hung or could crash run in a child process with a time limit.

def run_isolated(code, timeout=20):
    """Run `code` in a child Python; returns (exit status or 'timeout', stdout + stderr)."""
    try:
        proc = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, timeout=timeout)
        return proc.returncode, proc.stdout
    except subprocess.TimeoutExpired:
        return "timeout", ""


def assert_unit_rows(q, tol=1e-12):
    q = np.asarray(q)
    assert np.all(np.isfinite(q)), q
    assert np.allclose(np.linalg.norm(q, axis=-1), 1.0, atol=tol, rtol=0), q


DMAX = np.finfo(np.float64).max
NEXT1 = np.nextafter(1.0, 2.0)


# -- core (fixed in quat.cpp, euler.cpp, bind_core.cpp) -------------------------------------------

def test_normalize_components_near_max_double():
    assert_unit_rows(qc.quat_normalize([DMAX, DMAX, 0.0, 0.0]))
    assert_unit_rows(qc.axis_angle_to_quat([DMAX, DMAX, 0.0], 1.0))
    axis, angle = qc.quat_to_axis_angle([DMAX, -DMAX, 0.0, 0.0])
    assert np.isclose(np.linalg.norm(axis), 1.0) and np.isclose(angle, np.pi / 2)
    assert np.all(np.isfinite(qc.quat_log([DMAX, DMAX, 0.0, 0.0])))


def test_axis_of_a_subnormal_vector_part_is_unit():
    axis, _ = qc.quat_to_axis_angle([0.7551951280657864, 0.0, -5e-324, 5e-324])
    assert np.isclose(np.linalg.norm(axis), 1.0, atol=1e-15)


def test_badly_scaled_matrices_give_a_rotation_or_a_refusal():
    m = np.array([[-7.6808892265831930e+177, -2.0056231777034209e+178, 1.0792908155385849e+178],
                  [3.7997668954355075e+176, -1.1501378317683714e+178, -2.1102352318276547e+178],
                  [2.2772679184938136e+178, -6.5727636923254159e+177, 3.9923951508445395e+177]])
    assert_unit_rows(qc.matrix_to_quat(m))
    assert np.all(np.isfinite(qc.matrix_to_euler(m, "XYZ")))
    r = qc.nearest_rotation(m)
    assert np.allclose(r @ r.T, np.eye(3), atol=1e-12)
    # the same matrix scaled down to entries near 1e-180: still the same rotation
    assert np.allclose(qc.matrix_to_quat(m * 1e-180 * 1e-178), qc.matrix_to_quat(m), atol=1e-12)


def test_matrix_representation_projection_does_not_overflow():
    q = np.array([DMAX, -DMAX, DMAX / 2, 1.0])
    assert np.array_equal(qc.real4_to_quat(qc.quat_to_real4(q)), q)
    assert np.array_equal(qc.complex2_to_quat(qc.quat_to_complex2(q)), q)


def test_sandwich_rotation_with_a_huge_quaternion():
    v = np.array([1.0, 2.0, 3.0])
    assert np.allclose(qc.quat_rotate_sandwich([1e300, 1e300, 0.0, 0.0], v), qc.quat_rotate([1.0, 1.0, 0.0, 0.0], v))


def test_rotating_a_huge_vector_whose_image_is_finite():
    """90° about z maps (1e308, 1e308, 0) to (-1e308, 1e308, 0): 2·(u×P) overflowed on the way."""
    for rotate in (qc.quat_rotate, qc.quat_rotate_sandwich):
        assert np.allclose(rotate([1.0, 0, 0, 1.0], [1e308, 1e308, 0.0]), [-1e308, 1e308, 0.0], rtol=1e-15)


@pytest.mark.parametrize("call", [
    lambda: qc.quat_multiply([1e200, 0, 0, 0], [1e200, 0, 0, 0]),
    lambda: qc.quat_exp([710.0, 0, 0, 0]),
    lambda: qc.quat_norm([DMAX, DMAX, 0, 0]),
    lambda: qc.quat_pow([2.0, 0, 0, 0], 1e300),
    lambda: qc.quat_rotate([np.cos(np.pi / 8), 0, 0, np.sin(np.pi / 8)], [DMAX, DMAX, 0]),
    lambda: qc.transform_directions(np.eye(4) * 1e300, [1e300, 0, 0]),
    lambda: qc.quat_divide([1e175, 0, 0, 0], [1e-150, 0, 0, 0]),
], ids=["multiply", "exp", "norm", "pow", "rotate", "transform_directions", "divide"])
def test_a_result_beyond_double_range_is_refused(call):
    with pytest.raises(ValueError, match=r"result.*overflows"):
        call()


def test_euler_compat_of_a_huge_angle_keeps_the_rotation():
    angles = np.array([7.853981633974483, 1.657498103492454e266, -6.916919041777452e-323])
    for order in ("XYZ", "YXZ"):
        for ref in ([3500.0, 769.0, -5520.0], [0.0, 0.0, 0.0]):
            out = qc.euler_compat(angles, ref, order)
            assert np.all(np.isfinite(out))
            assert qc.angle_between(qc.euler_to_quat(out, order), qc.euler_to_quat(angles, order)) < 1e-9


# -- curve engine (native/src/curve*.cpp: in progress, reported to the lead) -------------------------

def test_from_euler_with_a_huge_turn_neither_hangs_nor_guesses():
    """A 1e8 rad Euler segment made Curve.from_euler run for minutes or raise MemoryError (it
    splits the turn into 2π/3 sub-arcs); 1e300 rad returned an arbitrary orientation (the sub-arc
    count overflows)."""
    code = """
        import resource
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))  # it allocates without bound
        import quatcurve as qc
        for turn in (1e8, 1e300):
            try:
                c = qc.Curve.from_euler([0.0, 1.0], [[0, 0, 0], [0, 0, turn]], method="SLERP")
                print("accepted", turn, c.sample([0.5]))
            except ValueError as e:
                print("refused", turn, e)
    """
    status, out = run_isolated(code, timeout=20)
    assert status == 0, f"from_euler with a 1e8 rad turn: {status} (hang or crash)\n{out}"
    for line in out.splitlines():
        assert line.startswith("refused"), f"a turn beyond what double precision can follow was accepted: {line}"


@pytest.mark.parametrize("method", ["QUAT_COMPONENTS", "NLERP", "SLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2"])
def test_curve_keys_with_components_near_max_double(method):
    c = qc.Curve([0.0, 1.0, 2.0], [[1.0, 0, 0, 0], [3e219, 1.0, 0, 0], [1.7e308, 1.7e308, 0, 0]], method=method)
    q = c.sample([0.0, 0.5, 1.0, 1.5, 2.0])
    assert_unit_rows(q, 1e-10)
    assert np.all(np.isfinite(c.angular_velocity([0.0, 0.5, 1.0, 1.5, 2.0])))


@pytest.mark.parametrize("times", [[1.0, NEXT1, np.nextafter(NEXT1, 2.0)], [0.0, 5e-324, 1e-323],
                                   [-DMAX, 0.0, DMAX]], ids=["consecutive_doubles", "subnormal", "span_overflow"])
def test_curve_extreme_key_spacing_passes_through_keys_or_is_refused(times):
    """Keys one ulp apart, subnormal spacing and a span beyond double range gave NaN samples, NaN or
    infinite angular velocity, or a sample at a key far from that key. Every method, from quaternion
    and from Euler keys; refusing such key times (ValueError) is fine."""
    angles = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [3.0, 2.0, 1.0]])
    keys = qc.euler_to_quat(angles, "XYZ")
    problems = []
    for method in qc.METHODS:
        for from_euler in (False, True):
            if method == "EULER" and not from_euler:
                continue
            label = f"{method} from {'Euler' if from_euler else 'quaternion'} keys"
            try:
                if from_euler:
                    c = qc.Curve.from_euler(times, angles, "XYZ", method=method)
                else:
                    c = qc.Curve(times, keys, method=method)
                at_keys = c.sample(np.array(times))
                velocity = c.angular_velocity(np.array(times))
            except ValueError:
                continue
            with np.errstate(all="ignore"):
                if not np.all(np.isfinite(at_keys)):
                    problems.append(f"{label}: non-finite sample at a key {at_keys.tolist()}")
                elif np.any(qc.angle_between(at_keys, keys) > 1e-9):
                    problems.append(f"{label}: samples at the keys are "
                                    f"{qc.angle_between(at_keys, keys).tolist()} rad off them")
                if not np.all(np.isfinite(velocity)):
                    problems.append(f"{label}: non-finite angular velocity {velocity.tolist()}")
    assert not problems, "\n".join(problems)


def test_euler_keys_near_max_double_pass_through_keys_or_are_refused():
    """EULER with key angles of ±1.8e308: the sample at a key was 1.3 rad off that key."""
    times = [0.0, 1.0, 2.0]
    keys = np.array([[6.283185307179586, 0.5306254996236452, -1.4961299944567985],
                     [-1.6685556679815037, DMAX, 1.0095826840323463],
                     [1.6420834655002471e+175, -DMAX, 0.5773783335143595]])
    try:
        c = qc.Curve.from_euler(times, keys, "XYZ", method="EULER")
    except (ValueError, MemoryError):
        return
    at_keys = c.sample(times)
    assert_unit_rows(at_keys, 1e-10)
    assert np.all(qc.angle_between(at_keys, qc.euler_to_quat(keys, "XYZ")) < 1e-9)


# -- metrics (native/src/metrics.cpp: in progress, reported to the lead) -----------------------------

def test_interval_speeds_with_subnormal_spacing_are_finite_or_refused():
    try:
        s = qc.interval_speeds([0.0, 5e-324], [[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
    except ValueError:
        return
    assert np.all(np.isfinite(s)), s


# -- key reduction (native/src/reduce*.cpp: in progress, reported to the lead) ------------------------

@pytest.mark.parametrize("interpolation", ["LINEAR", "BEZIER"])
def test_reduce_refuses_frames_that_collide_in_float32(interpolation):
    """Blender stores frames as float32: times one double-ulp apart became three keys on frame 1.0."""
    times = [1.0, NEXT1, np.nextafter(NEXT1, 2.0)]
    quats = [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [1.0, 0, 0, 0]]
    with pytest.raises(ValueError):
        qc.reduce_keys(times, quats, 0.0, interpolation)


def test_reduce_euler_refuses_angles_beyond_float32():
    """reduce_keys_euler(BEZIER) returned a key value of -inf for an angle of -8.8e199."""
    angles = [[-0.25, -np.pi, -8.760080489722479e+199], [7.5e-126, -1e-285, 7.916320560812919e+51]]
    with pytest.raises(ValueError):
        qc.reduce_keys_euler([-80.0, -79.0], angles, "XYZ", 4.0, "BEZIER")


@pytest.mark.parametrize("euler", [False, True], ids=["quats", "euler"])
def test_reduce_linear_bound_holds_or_input_is_refused(euler):
    """LINEAR, tolerance 0, detailed: a value beyond float32 (Blender stores float32) made
    max_error π — the bound the result promises did not hold, and nothing said so."""
    times = np.arange(2.0, 6.0)
    if euler:
        values = np.array([[-np.pi / 2, np.pi / 2, np.pi / 2], [5.19, 1.34, 2.88], [0.55, 5.47, 3.97],
                           [-0.077, 3.6e-247, 2.3714408279079944e+258]])
        call = lambda: qc.reduce_keys_euler(times, values, "XYZ", 0.0, "LINEAR", detailed=True)  # noqa: E731
    else:
        values = np.array([[1.44e-223, 2.36e-224, -1.21e-223, 8.14e-224], [1.0, 6.4e-136, -3e-159, -2.9e-38],
                           [-1e-155, -0.10257528408332377, 1.4492596851314581, -3.55e-188], [DMAX, 0.0, 1.0, 0.0]])
        call = lambda: qc.reduce_keys(times, values, 0.0, "LINEAR", detailed=True)  # noqa: E731
    try:
        result = call()
    except ValueError:
        return
    assert result.max_error <= 1e-6, f"max_error {result.max_error} rad for tolerance 0"


def test_reduce_refuses_frames_and_values_beyond_float32():
    quats = [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [1.0, 0, 0, 0]]
    with pytest.raises(ValueError):
        qc.reduce_keys([0.0, 1e300, 2e300], quats, 0.0, "BEZIER")
    with pytest.raises(ValueError):
        qc.reduce_keys([0.0, 1.0, 2.0], [[1e300, 0, 0, 0], [0, 1.0, 0, 0], [1.0, 0, 0, 0]], 0.0, "BEZIER")
