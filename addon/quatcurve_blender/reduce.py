"""Key reduction in Blender: replace rotation keys by as few keys as an angular bound allows.

Plain functions, no operator state: the `quatcurve.reduce` operator, the bake (tolerance > 0) and
scripts call the same code. The math is native (`quatcurve.reduce_keys`, `reduce_keys_euler`,
`reduce_keys_axis_angle`): it
chooses the keys and Bezier handles and verifies, by emulating Blender's F-curve evaluation in
float32, that every sample stays within the tolerance. This module only moves arrays between
targets (targets.py: reading), the native reducer, and write.py (writing).

    found = targets.gather_targets(bpy.context, verb="reduce")
    result = reduce.reduce(found, reduce.ReduceSettings(tolerance=0.1))
    print(result.summary())

Samples: a target's rotation channels as Blender evaluates them at every whole frame of its keyed
range and at every key frame — so the reduced keys stay within the tolerance of the original at
every frame and at every original key. Quaternion samples are made hemisphere-continuous first
(signs flipped where neighbours disagree: the same rotations, and no forced keys at the flips).
Rotation modes: quaternion, the six Euler orders and axis-angle (the bound is on the rotation Blender
builds; axis-angle channels are kept as Blender evaluates them, a zero axis is refused). F-curves
with modifiers are refused (the bound is for the keys alone).
Everything is read and computed before anything is written, so an error leaves the file untouched.

The bake calls `reduce_values` (imported by bake.py) when its tolerance is above 0, so
`quatcurve.bake` with tolerance > 0 writes BEZIER keys, per channel where that saves keys.
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np

from . import fcurves, native, targets, write
from .workers import parallel_imap
from .targets import TargetError

INTERPOLATIONS = ("LINEAR", "BEZIER")



class ReduceError(TargetError, ValueError):
    """A reduction that cannot be done; the message names the target and what is wrong. Raised
    before anything is written. A ValueError too, as the bake expects of its reduction."""


@dataclass
class ReduceSettings:
    """tolerance in degrees (a UI value; the native reducer takes radians). interpolation: the key
    interpolation written ('BEZIER' keeps far fewer keys; its handles are FREE and broken at keys).
    synchronized: the same key frames on every channel of a target (for glTF export and hand
    editing); off lets each channel keep its own keys where that saves keys. new_action: write into
    a copy of each action (the original is kept with a fake user); off: replace in place."""
    tolerance: float = 0.1
    interpolation: str = "BEZIER"
    synchronized: bool = False
    new_action: bool = True


def check_settings(settings):
    if not (settings.tolerance >= 0) or not math.isfinite(settings.tolerance):
        raise ReduceError("tolerance %r°: must be a finite angle of 0 or more" % (settings.tolerance,))
    if settings.interpolation not in INTERPOLATIONS:
        raise ReduceError("interpolation %r: unknown (expected LINEAR or BEZIER)" % (settings.interpolation,))


# ---- the native call ------------------------------------------------------------------------------

@dataclass
class ReducedChannels:
    """Reduced keys of one target's rotation channels. keys[i] = (frames, values, handle_left,
    handle_right) of channel i (handles (K, 2) for BEZIER, None for LINEAR); max_error in radians
    (Blender's evaluation, emulated, against the samples)."""
    interpolation: str
    keys: list
    max_error: float

    @property
    def key_count(self):
        return sum(len(k[0]) for k in self.keys)


def reduce_values(frames, values, mode, tolerance_rad, interpolation="BEZIER", synchronized=False):
    """Reduces dense channel values (N, 4) of mode 'QUATERNION' or 'AXIS_ANGLE' (angle, x, y, z) or
    (N, 3) of an Euler order, sampled at `frames`, to ReducedChannels. Quaternions are made
    hemisphere-continuous first; Euler and axis-angle values are kept as given. Raises ReduceError
    for other modes or input the native reducer refuses."""
    qc = native.require()
    frames = np.asarray(frames, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    try:
        if mode == "QUATERNION":
            values = qc.quats_to_channels(values, "QUATERNION")
            result = qc.reduce_keys(frames, values, tolerance_rad, interpolation, synchronized,
                                    detailed=True)
        elif mode in fcurves.EULER_ORDERS:
            result = qc.reduce_keys_euler(frames, values, mode, tolerance_rad, interpolation,
                                          synchronized, detailed=True)
        elif mode == "AXIS_ANGLE":
            result = qc.reduce_keys_axis_angle(frames, values, tolerance_rad, interpolation,
                                               synchronized, detailed=True)
        else:
            raise ReduceError("rotation mode %s: key reduction handles quaternion, Euler and axis-angle "
                              "rotations" % mode)
    except ValueError as error:
        raise ReduceError(str(error)) from error
    bezier = interpolation == "BEZIER"
    keys = [(ch.frames, ch.values, ch.handle_left if bezier else None, ch.handle_right if bezier else None)
            for ch in result.channels]
    return ReducedChannels(interpolation, keys, result.max_error)


# ---- reducing existing keys (the operator) ----------------------------------------------------------

@dataclass(eq=False)
class TargetReduce:
    target: targets.Target
    mode: str
    prop: str
    frames: np.ndarray          # sample frames
    values: np.ndarray          # (N, C) Blender's evaluation of the channels there
    keys_before: int
    reduced: ReducedChannels = None


@dataclass
class TargetResult:
    name: str
    mode: str
    keys_before: int
    keys_after: int
    max_error_deg: float
    action: str


@dataclass
class ReduceResult:
    tolerance: float
    interpolation: str
    targets: list = field(default_factory=list)
    keys_before: int = 0
    keys_after: int = 0
    max_error_deg: float = 0.0
    seconds: float = 0.0

    def summary(self):
        share = 100.0 * self.keys_after / self.keys_before if self.keys_before else 0.0
        return ("%d target%s, rotation keys %s → %s (%.1f %%), max error %.4f° (bound %g°), %.2f s"
                % (len(self.targets), "" if len(self.targets) == 1 else "s", f"{self.keys_before:,}",
                   f"{self.keys_after:,}", share, self.max_error_deg, self.tolerance, self.seconds))

    def lines(self):
        return ["%s (%s): %d → %d keys, max error %.4f° in '%s'"
                % (t.name, t.mode, t.keys_before, t.keys_after, t.max_error_deg, t.action)
                for t in self.targets]


def read_target(target):
    """TargetReduce of `target` in its current rotation mode (sampled, not yet reduced)."""
    try:
        source = targets.read_rotation_keys(target)
    except TargetError as error:
        raise ReduceError(str(error)) from error
    if source.mode not in ("QUATERNION", "AXIS_ANGLE") + fcurves.EULER_ORDERS:
        raise ReduceError("%s: rotation mode %s: key reduction handles quaternion, Euler and axis-angle "
                          "rotations" % (target.name, source.mode))
    for index, modifiers in enumerate(source.modifiers):
        if modifiers:
            raise ReduceError("%s: %s[%d] has F-curve modifiers; the bound holds for keys alone "
                              "(apply or remove the modifiers first)" % (target.name, source.prop, index))
    frames = native.require().whole_frame_samples(source.frames)  # every whole frame and key
    values = targets.playback(target).evaluate(frames)
    if not np.isfinite(values).all():
        raise ReduceError("%s: %s evaluates to non-finite values" % (target.name, source.prop))
    return TargetReduce(target, source.mode, source.prop, frames, values, source.key_count)


def reduce(found, settings):
    """Reduces the rotation keys of `found` (targets.Target); returns a ReduceResult. Raises
    ReduceError (nothing written) when a setting or a target is unusable."""
    begin = time.perf_counter()
    check_settings(settings)
    if not found:
        raise ReduceError("Nothing to reduce: no targets")
    for target in found:
        try:
            targets.check_editable(target, settings.new_action)
        except TargetError as error:
            raise ReduceError(str(error)) from error
    tol = math.radians(settings.tolerance)

    def read_all():
        with fcurves.read_cache():  # closed once the last target is read, before any write
            for target in found:
                yield read_target(target)

    def reduce_item(item):
        try:
            item.reduced = reduce_values(item.frames, item.values, item.mode, tol, settings.interpolation,
                                         settings.synchronized)
        except ReduceError as error:
            raise ReduceError("%s: %s" % (item.target.name, error)) from error
        return item

    # Blender is read on this thread, target after target, while worker threads reduce the targets
    # already read (the native reducer runs without the GIL). Into new actions the writing starts as
    # soon as everything is read — copying the action and writing the first targets while the workers
    # reduce the rest — and a failure on the way removes the new actions again; in place, everything
    # is computed before the first key is replaced.
    items = []

    def writes():
        for item in parallel_imap(reduce_item, read_all()):
            items.append(item)
            yield write.RotationWrite(item.target, item.mode, item.reduced.keys, item.reduced.interpolation,
                                      replace=(item.prop,))

    actions = write.write_rotations(writes() if settings.new_action else list(writes()),
                                    settings.new_action, "reduced")
    result = ReduceResult(settings.tolerance, settings.interpolation)
    for item, action in zip(items, actions):
        after = item.reduced.key_count
        error_deg = math.degrees(item.reduced.max_error)
        result.targets.append(TargetResult(item.target.name, item.mode, item.keys_before, after,
                                           error_deg, action.name))
        result.keys_before += item.keys_before
        result.keys_after += after
        result.max_error_deg = max(result.max_error_deg, error_deg)
    result.seconds = time.perf_counter() - begin
    return result
