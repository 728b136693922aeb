"""quatcurve.BakeJob / BakeQueue: a bake's per-target native work on native worker threads. Each job's
result must be Curve.sample_keys and Curve.path_rule_breaks of the same curve, bit for bit, in job
order, whatever the thread count; errors come with their job."""

import numpy as np
import pytest

import quatcurve as qc

FRAMES = np.arange(-3.0, 205.0)


def jobs_and_expected(count=12, seed=5):
    """Mixed key modes, methods, output modes and references, with what the plain Curve gives."""
    rng = np.random.default_rng(seed)
    times = np.arange(0.0, 201.0, 10.0)
    cases = [("QUATERNION", "SQUAD", "QUATERNION", {"clamped": True}),
             ("XYZ", "TCB", "ZXY", {"tension": 0.4, "bias": -0.2}),
             ("AXIS_ANGLE", "CATMULL_ROM", "AXIS_ANGLE", {}),
             ("QUATERNION", "SPLINE_C2", "XYZ", {}),
             ("YZX", "SLERP", "YZX", {"shortest_path": False})]
    jobs, expected = [], []
    for i in range(count):
        keys_mode, method, mode, options = cases[i % len(cases)]
        values = rng.normal(0.0, 2.0, (len(times), 3 if keys_mode in ("XYZ", "YZX") else 4))
        if keys_mode == "XYZ" or keys_mode == "YZX":
            curve = qc.Curve.from_euler(times, values, order=keys_mode, method=method, **options)
        elif keys_mode == "AXIS_ANGLE":
            curve = qc.Curve.from_axis_angle(times, values, method=method, **options)
        else:
            curve = qc.Curve(times, values, method=method, **options)
        reference = None
        if mode == keys_mode == "YZX":
            reference = rng.normal(0.0, 1.0, (len(FRAMES), 3))  # one row per frame
        elif mode == keys_mode:
            reference = -values[0] if mode == "QUATERNION" else values[0]
        jobs.append(qc.BakeJob(times, values, keys_mode, method, mode, reference, **options))
        expected.append((curve.sample_keys(FRAMES, mode, reference), curve.path_rule_breaks()))
    return jobs, expected


@pytest.mark.parametrize("threads", [0, 1, 2, 4])
@pytest.mark.parametrize("window", [1, 8])
def test_results_are_the_curves_keys_bit_for_bit_in_order(threads, window):
    jobs, expected = jobs_and_expected()
    queue = qc.BakeQueue(FRAMES, jobs, threads=threads, window=window)
    assert len(queue) == len(jobs) and queue.remaining == len(jobs)
    got = list(queue)
    assert queue.remaining == 0
    assert len(got) == len(expected)
    for (keys, breaks), (want_keys, want_breaks) in zip(got, expected):
        assert keys.dtype == np.float32 and keys.shape == want_keys.shape
        assert keys.tobytes() == want_keys.tobytes()
        assert np.array_equal(breaks, want_breaks)


def test_path_rule_breaks_come_through():
    # SPLINE_C2 (never clamped) overshoots the holds around a quick 170° turn: segments 0 and 2 break.
    half = np.radians(85.0)
    keys = np.array([[1.0, 0, 0, 0], [1.0, 0, 0, 0], [np.cos(half), 0, 0, np.sin(half)],
                     [np.cos(half), 0, 0, np.sin(half)]])
    times = [0.0, 10.0, 11.0, 30.0]
    (_, breaks), = qc.BakeQueue(FRAMES, [qc.BakeJob(times, keys, "QUATERNION", "SPLINE_C2", "QUATERNION")],
                                threads=1)
    assert list(breaks[:, 0]) == [0.0, 2.0]
    assert np.array_equal(breaks, qc.Curve(times, keys, "SPLINE_C2").path_rule_breaks())


@pytest.mark.parametrize("threads", [0, 2])
def test_an_error_comes_with_its_job_alone(threads):
    jobs, expected = jobs_and_expected(count=5)
    bad = qc.BakeJob([0.0, 5.0, 5.0], np.eye(4)[:3], "QUATERNION", "SQUAD", "QUATERNION")
    queue = qc.BakeQueue(FRAMES, jobs[:2] + [bad] + jobs[2:], threads=threads, window=2)
    assert next(queue)[0].tobytes() == expected[0][0].tobytes()
    next(queue)
    with pytest.raises(ValueError, match=r"times\[2\]: not increasing"):
        next(queue)
    rest = list(queue)
    assert [k.tobytes() for k, _ in rest] == [k.tobytes() for k, _ in expected[2:]]
    with pytest.raises(StopIteration):
        next(queue)


def test_a_bad_reference_names_the_curve():
    job = qc.BakeJob([0.0, 10.0], np.eye(4)[:2], "QUATERNION", "TCB", "QUATERNION", [np.nan, 0, 0, 0])
    with pytest.raises(ValueError, match=r"^the TCB curve: reference\[0\]"):
        next(qc.BakeQueue(FRAMES, [job], threads=1))


def test_dropped_early_the_queue_stops():
    jobs, _ = jobs_and_expected(count=30)
    for threads in (1, 3):
        queue = qc.BakeQueue(np.arange(0.0, 2000.0), jobs, threads=threads, window=4)
        next(queue)
        del queue  # joins its workers; must return


@pytest.mark.parametrize("args, kwargs, match", [
    (([0.0, 1.0], np.ones((2, 3)), "QUATERNION", "SQUAD", "QUATERNION"), {}, r"values: expected shape"),
    (([0.0, 1.0], np.ones((2, 4)), "QUATERNIONS", "SQUAD", "QUATERNION"), {}, r"QUATERNIONS"),
    (([0.0, 1.0], np.ones((2, 4)), "QUATERNION", "SQUID", "QUATERNION"), {}, r"SQUID"),
    (([0.0, 1.0], np.ones((2, 4)), "QUATERNION", "SQUAD", "XYZ", np.ones(4)), {}, r"reference"),
    (([0.0, 1.0], np.ones((2, 4)), "QUATERNION", "SQUAD", "QUATERNION"), {"tension": 0.5}, r"tension"),
    ((np.ones((2, 2)), np.ones((2, 4)), "QUATERNION", "SQUAD", "QUATERNION"), {}, r"times: expected shape"),
])
def test_bad_jobs_are_refused_when_made(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        qc.BakeJob(*args, **kwargs)


def test_bad_queue_arguments():
    jobs, _ = jobs_and_expected(count=1)
    with pytest.raises(ValueError, match="window"):
        qc.BakeQueue(FRAMES, jobs, threads=1, window=0)
    with pytest.raises(ValueError, match="frames: expected shape"):
        qc.BakeQueue(np.ones((2, 2)), jobs)
    with pytest.raises(TypeError, match=r"jobs\[1\]: expected a quatcurve.BakeJob, got object"):
        qc.BakeQueue(FRAMES, [jobs[0], object()])
