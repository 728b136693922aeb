"""Cleaning captured rotations (docs/clean.md) on plain arrays: one target's channel values in its
rotation mode, cleaned as rotations by the native `clean_rotations`, back as continuous channel values
of the same mode. No Blender data here (tests/python imports it without bpy): clean.py, the task behind
the `quatcurve.clean` operator, `cli.py --clean` and `batch --clean`, reads the F-curves' keys into
arrays and writes the result back.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

from . import native


@dataclass
class CleanedChannels:
    values: np.ndarray   # (N, C) channel values of the input's mode, continuous
    flips: int           # Euler: rows' branch or 360° jumps repaired; otherwise quaternion sign flips
    result: Any          # the native CleanResult (quats, spike_frames, noise, deviation, max_deviation, ...)


def clean_channels(frames, values, mode, **options):
    """Clean the rotation channel rows `values` (N, 4 | 3) of rotation mode `mode` ('QUATERNION',
    'XYZ' ... 'ZYX', 'AXIS_ANGLE') keyed at `frames` (N,); `options` are clean_rotations' keywords
    (noise, deviation, deviation_factor, spikes, spike_threshold, spike_max_run, spike_min_angle,
    smooth, smoothness; radians). The rows come back in the same mode, continuous: Euler rows on the
    input's branch (its flips removed first), quaternions starting on the first row's sign,
    axis-angle starting on the first row's axis side and turn. Every non-spike row's rotation is
    within result.deviation of the input row's. Raises ValueError for bad input, RuntimeError when the
    native module is unavailable."""
    qc = native.require()
    frames = np.ascontiguousarray(frames, dtype=float)
    values = np.ascontiguousarray(values, dtype=float)
    euler = mode not in ("QUATERNION", "AXIS_ANGLE")
    flips = 0
    if euler:
        values, flips = qc.remove_euler_flips(values, mode)
    result = qc.clean_rotations(frames, qc.channels_to_quats(values, mode), **options)
    if euler:
        # each row the Euler angles nearest its (flip-free) input row, then chained forward from the
        # first (a spike row's input may lie on another branch): the input's branch and turns kept
        out, _ = qc.remove_euler_flips(qc.quat_to_euler(result.quats, mode, compat=values), mode)
    else:
        out = qc.quats_to_channels(result.quats, mode, reference=values[0])
        flips = result.flips
    return CleanedChannels(out, int(flips), result)
