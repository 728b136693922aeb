"""quatcurve.blender_evaluate (Blender's F-curve evaluation, emulated) against Blender itself, in every
supported Blender: random F-curves built in a scratch action through the add-on's adapter (legacy or
slotted actions), handles computed by Blender (fcurve.update()), keys and handles read back with
foreach_get, then the emulator's values compared with fcurve.evaluate() at many frames — on keys,
within and just beyond Blender's 1e-4-frame key threshold, and at random subframes.

Covered: LINEAR and BEZIER; handle types FREE, ALIGNED, VECTOR, AUTO, AUTO_CLAMPED (and auto
smoothing NONE / CONT_ACCEL); FREE and ALIGNED handles longer than their segment (Blender scales them
back only at evaluation); key spacing from 0.02 to 1000 frames; values from 1e-6 to 1e4, negative.
The worst error per Blender is printed (run with -s to see it).
"""

import bpy
import numpy as np
import pytest

from quatcurve_blender import fcurves, native

HANDLE_TYPES = ("FREE", "ALIGNED", "VECTOR", "AUTO", "AUTO_CLAMPED")
SCALES = (1e-6, 1e-3, 1.0, 100.0, 1e4)
# Agreement required: |emulated - Blender| <= TOLERANCE · max(1, largest magnitude on the curve).
TOLERANCE = 1e-6
CURVES = 300  # per interpolation
# Offsets from every key: exactly on it, within Blender's 1e-4 threshold, at it, just beyond.
KEY_OFFSETS = np.array([0.0, 1e-6, -1e-6, 1e-5, -1e-5, 5e-5, -5e-5, 9.9e-5, -9.9e-5, 1e-4, -1e-4,
                        1.01e-4, -1.01e-4, 2e-4, -2e-4, 1e-3, -1e-3, 0.5, -0.5])

pytestmark = pytest.mark.skipif(native.module is None, reason="native module missing")


def random_curve(rng, interpolation):
    """Keys (frames, values), per-key (left, right) handle types and, for FREE/ALIGNED, handles
    (N, 2) — some longer than their segment — for one random F-curve."""
    n = int(rng.integers(2, 10))
    gaps = np.exp(rng.uniform(np.log(0.02), np.log(1000.0), n - 1))
    frames = np.concatenate([[rng.uniform(-100, 100)], rng.uniform(-100, 100) + np.cumsum(gaps)])
    frames = np.sort(frames.astype(np.float32).astype(np.float64))
    frames = np.unique(frames)
    n = len(frames)
    values = rng.normal(0.0, 1.0, n) * rng.choice(SCALES, n)
    types = rng.choice(HANDLE_TYPES, (n, 2)) if interpolation == "BEZIER" else None
    if types is not None:
        # AUTO and AUTO_CLAMPED act on both handles of a key; Blender makes the pair agree anyway.
        auto = np.isin(types[:, 0], ("AUTO", "AUTO_CLAMPED"))
        types[auto, 1] = types[auto, 0]
    gap_l = np.diff(frames, prepend=frames[0] - 1.0)
    gap_r = np.diff(frames, append=frames[-1] + 1.0)
    reach_l = gap_l * rng.uniform(0.05, 3.0, n)  # up to 3x the segment: scaled back at evaluation
    reach_r = gap_r * rng.uniform(0.05, 3.0, n)
    slope = rng.normal(0.0, 1.0, (n, 2)) * np.abs(values)[:, None] / np.maximum(gap_l, gap_r)[:, None]
    left = np.stack([frames - reach_l, values - slope[:, 0] * reach_l], axis=-1)
    right = np.stack([frames + reach_r, values + slope[:, 1] * reach_r], axis=-1)
    return frames, values, types, left, right


def build_in_blender(scratch, index, curve, interpolation, smoothing):
    """The F-curve in Blender: keys, handle types, then FREE/ALIGNED handle positions, then update()
    (Blender computes VECTOR/AUTO handles and aligns ALIGNED ones), as editing in Blender would."""
    frames, values, types, left, right = curve
    fcurve = scratch.write("location", index, frames, values, interpolation=interpolation)
    fcurve.auto_smoothing = smoothing
    if types is not None:
        for point, (lt, rt), hl, hr in zip(fcurve.keyframe_points, types, left, right):
            point.handle_left_type = lt
            point.handle_right_type = rt
            point.handle_left = hl
            point.handle_right = hr
    fcurve.update()
    return fcurve


def eval_frames(rng, frames):
    span = frames[-1] - frames[0]
    uniform = rng.uniform(frames[0] - 0.1 * span - 1, frames[-1] + 0.1 * span + 1, 400)
    near_keys = (frames[:, None] + KEY_OFFSETS[None, :]).ravel()
    mids = 0.5 * (frames[1:] + frames[:-1])
    return np.concatenate([uniform, near_keys, mids])


def compare(fcurve, interpolation, at):
    """(worst scaled error, its details) of the emulator against fcurve.evaluate at `at`."""
    frames, values = fcurves.read_keys(fcurve)
    left, right = fcurves.read_handles(fcurve)
    emulated = native.module.blender_evaluate(frames, values, at, interpolation, left, right)
    blender = np.array([fcurve.evaluate(float(f)) for f in at])
    scale = max(1.0, float(np.abs(values).max()), float(np.abs(left[:, 1]).max()),
                float(np.abs(right[:, 1]).max()))
    err = np.abs(emulated - blender) / scale
    k = int(np.argmax(err))
    return float(err[k]), "frame %r: emulated %r, Blender %r (scale %g; keys %s, left %s, right %s)" % (
        at[k], emulated[k], blender[k], scale, np.c_[frames, values].tolist(), left.tolist(), right.tolist())


@pytest.mark.parametrize("interpolation", ["LINEAR", "BEZIER"])
def test_emulator_agrees_with_blender(addon, interpolation):
    rng = np.random.default_rng(2024 if interpolation == "BEZIER" else 7)
    worst, where, count = 0.0, "", 0
    with fcurves.scratch_channels() as scratch:
        for index in range(CURVES):
            curve = random_curve(rng, interpolation)
            smoothing = "CONT_ACCEL" if interpolation == "BEZIER" and index % 4 == 3 else "NONE"
            fcurve = build_in_blender(scratch, index, curve, interpolation, smoothing)
            at = eval_frames(rng, curve[0])
            err, detail = compare(fcurve, interpolation, at)
            count += len(at)
            if err >= worst:
                worst, where = err, detail
    print("\nblender_evaluate vs Blender %s, %s: worst scaled error %.3g over %d frames of %d curves"
          % (bpy.app.version_string, interpolation, worst, count, CURVES))
    assert worst <= TOLERANCE, "worst error %.3g at %s" % (worst, where)


def test_long_handles_are_scaled_only_at_evaluation(addon):
    # A FREE handle reaching 3x past the next key: Blender keeps it stored as written and scales it
    # back while evaluating; the emulator, given the stored handle, does the same.
    with fcurves.scratch_channels() as scratch:
        curve = (np.array([0.0, 10.0]), np.array([0.0, 1.0]), np.array([["FREE", "FREE"]] * 2),
                 np.array([[-1.0, 0.0], [9.0, 1.0]]), np.array([[30.0, 6.0], [11.0, 1.0]]))
        fcurve = build_in_blender(scratch, 0, curve, "BEZIER", "NONE")
        assert tuple(fcurve.keyframe_points[0].handle_right) == (30.0, 6.0)
        err, detail = compare(fcurve, "BEZIER", np.linspace(0.01, 9.99, 500))
        assert err <= TOLERANCE, detail
