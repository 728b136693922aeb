"""quatcurve.blender_evaluate (Blender's F-curve evaluation, emulated): closed forms, Blender's special
cases, agreement with the independent numpy re-implementation (fcurve_reference.py) and with the
reducer's own keys, and the argument errors. Against Blender itself: tests/blender/test_blender_eval.py."""
import numpy as np
import pytest

import quatcurve
import fcurve_reference as ref

F32 = np.float32


def thirds(frames, values, slopes):
    """Handles at 1/3 of each neighbouring segment with the given slopes (inside the segments)."""
    frames = np.asarray(frames, float)
    gap_l = np.diff(frames, prepend=frames[0] - 1.0)
    gap_r = np.diff(frames, append=frames[-1] + 1.0)
    hl = np.stack([frames - gap_l / 3, values - slopes * gap_l / 3], axis=-1)
    hr = np.stack([frames + gap_r / 3, values + slopes * gap_r / 3], axis=-1)
    return hl, hr


def test_linear_closed_form_and_constant_extrapolation():
    out = quatcurve.blender_evaluate([0, 10, 20], [0.0, 1.0, -1.0], [-5, 0, 2.5, 10, 15, 20, 25], "LINEAR")
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, [0.0, 0.0, 0.25, 1.0, 0.0, -1.0, -1.0])


def test_output_has_the_shape_of_eval_frames():
    out = quatcurve.blender_evaluate([0, 10], [0.0, 1.0], np.full((2, 3), 5.0), "LINEAR")
    assert out.shape == (2, 3)
    np.testing.assert_array_equal(out, 0.5)
    assert quatcurve.blender_evaluate([0, 10], [0.0, 1.0], 5.0, "LINEAR").shape == ()


def test_within_the_key_threshold_the_key_value_wins():
    out = quatcurve.blender_evaluate([0, 1, 2], [0.0, 1.0, 0.0], [0.99991, 1.00009, 1.0002], "LINEAR")
    assert out[0] == out[1] == 1.0
    assert out[2] < 1.0


def test_bezier_with_third_handles_is_the_bernstein_cubic():
    hl = [[-1.0, 0.2], [2.0, 0.9]]
    hr = [[1.0, -0.7], [4.0, -0.5]]
    u = np.array([0.1, 0.25, 0.5, 0.8, 0.95])
    v = 1 - u
    expected = v ** 3 * 0.2 + 3 * v * v * u * -0.7 + 3 * v * u * u * 0.9 + u ** 3 * -0.5
    out = quatcurve.blender_evaluate([0, 3], [0.2, -0.5], 3 * u, "BEZIER", hl, hr)
    np.testing.assert_allclose(out, expected, atol=1.5e-6)


def test_long_handles_are_scaled_back_to_their_segment():
    # (30, 6) reaches 30 frames into a 10-frame segment: Blender uses (10, 2) (factor 10/30).
    at = np.linspace(0.3, 9.7, 40)
    longer = quatcurve.blender_evaluate([0, 10], [0, 1], at, "BEZIER", [[-1, 0], [9, 1]], [[30, 6], [11, 1]])
    scaled = quatcurve.blender_evaluate([0, 10], [0, 1], at, "BEZIER", [[-1, 0], [9, 1]], [[10, 2], [11, 1]])
    np.testing.assert_allclose(longer, scaled, atol=1e-6)
    assert np.all(np.isfinite(longer))


@pytest.mark.parametrize("interpolation", ["LINEAR", "BEZIER"])
def test_agrees_with_the_numpy_reference(interpolation):
    rng = np.random.default_rng(7)
    frames = np.cumsum(rng.uniform(0.02, 50.0, 60))
    values = rng.normal(0, 3.0, 60)
    hl, hr = thirds(frames, values, rng.normal(0, 1.0, 60))
    at = np.concatenate([np.linspace(frames[0] - 5, frames[-1] + 5, 5000), frames, frames + 5e-5,
                         frames - 3e-4])
    got = quatcurve.blender_evaluate(frames, values, at, interpolation, hl, hr)
    want = ref.evaluate_channel(frames, values, hl, hr, interpolation, at)
    np.testing.assert_allclose(got, want, rtol=2e-6, atol=2e-6)


def test_reproduces_the_reducers_own_evaluation():
    # reduce_keys' max_error is measured with this emulator: re-evaluating its keys here gives the
    # same rotations, so the same error.
    rng = np.random.default_rng(3)
    t = np.arange(200, dtype=float)
    rv = np.cumsum(rng.normal(0, 0.03, (200, 3)), axis=0)
    ang = np.linalg.norm(rv, axis=1, keepdims=True)
    q = np.hstack([np.cos(ang / 2), np.sin(ang / 2) * rv / ang])
    r = quatcurve.reduce_keys(t, q, 1e-3, "BEZIER")
    evaluated = np.stack([quatcurve.blender_evaluate(c.frames, c.values, t, "BEZIER", c.handle_left,
                                                     c.handle_right) for c in r.channels], axis=-1)
    err = ref.quat_errors(evaluated, q)
    assert abs(err.max() - r.max_error) < 1e-9


def test_no_keys_give_zero():
    np.testing.assert_array_equal(quatcurve.blender_evaluate([], [], [1.0, 2.0], "LINEAR"), 0.0)


@pytest.mark.parametrize("args, kwargs, message", [
    (([0, 1], [0, 1], [0.5]), {}, "handle_left: required for BEZIER"),
    (([0, 1], [0, 1], [0.5]), {"handle_left": [[0, 0], [1, 1]]}, "handle_right: required for BEZIER"),
    (([0, 1], [0, 1], [0.5]), {"handle_left": [[0, 0]], "handle_right": [[0, 0], [1, 1]]},
     r"handle_left: expected shape \(2, 2\)"),
    (([0, 1], [0, 1], [0.5]), {"handle_left": [[0, 0], [1, 1]], "handle_right": [[0, 0, 0], [1, 1, 1]]},
     "handle_right: expected shape"),
    (([0, 1], [0, 1], [0.5]), {"handle_left": [[0, 0], [1, np.nan]], "handle_right": [[0, 0], [1, 1]]},
     r"handle_left\[1, 1\]: non-finite"),
    (([0, 1], [0, 1], [0.5], "LINEAR"), {}, None),
    (([0, 1], [0, 1, 2], [0.5], "LINEAR"), {}, "values: 3 values for 2 frames"),
    (([[0, 1]], [0, 1], [0.5], "LINEAR"), {}, "frames: expected a 1-D array"),
    (([0, 1], [[0, 1]], [0.5], "LINEAR"), {}, "values: expected a 1-D array"),
    (([0, np.nan], [0, 1], [0.5], "LINEAR"), {}, r"frames\[1\]: non-finite"),
    (([0, 1], [0, np.inf], [0.5], "LINEAR"), {}, r"values\[1\]: non-finite"),
    (([0, 1], [0, 1e39], [0.5], "LINEAR"), {}, r"values\[1\]: beyond float32"),
    (([1, 1], [0, 1], [0.5], "LINEAR"), {}, r"frames\[1\]: not increasing"),
    (([1, 1 + 1e-9], [0, 1], [0.5], "LINEAR"), {}, r"frames\[1\]: not increasing \(as float32"),
    (([0, 1], [0, 1], [0.5, np.nan], "LINEAR"), {}, r"eval_frames\[1\]: not a finite float32 frame"),
    (([0, 1], [0, 1], [[0.5, 1e39]], "LINEAR"), {}, r"eval_frames\[0, 1\]: not a finite float32 frame"),
    (([0, 1], [0, 1], ["a"], "LINEAR"), {}, "eval_frames: expected an array of numbers"),
    (([0, 1], [0, 1], [0.5], "CUBIC"), {}, "interpolation: unknown interpolation 'CUBIC'"),
])
def test_bad_input_names_the_argument(args, kwargs, message):
    if message is None:
        quatcurve.blender_evaluate(*args, **kwargs)
        return
    with pytest.raises(ValueError, match=message):
        quatcurve.blender_evaluate(*args, **kwargs)
