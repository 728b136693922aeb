"""Key reduction in Blender: replace rotation keys by as few keys as an angular bound allows.

Plain functions, no operator state: the `quatcurve.reduce` operator, the bake (tolerance > 0) and
scripts call the same code. The math is native (`quatcurve.reduce_keys`, `reduce_keys_euler`): it
chooses the keys and Bezier handles and verifies, by emulating Blender's F-curve evaluation in
float32, that every sample stays within the tolerance. This module only moves arrays between
F-curves (through fcurves.py) and the native reducer.

    targets = bake.gather_targets(bpy.context)
    result = reduce.reduce(targets, reduce.ReduceSettings(tolerance=0.1))
    print(result.summary())

Samples: a target's rotation channels as Blender evaluates them at every whole frame of its keyed
range and at every key frame — so the reduced keys stay within the tolerance of the original at
every frame and at every original key. Quaternion samples are made hemisphere-continuous first
(signs flipped where neighbours disagree: the same rotations, and no forced keys at the flips).
Rotation modes: quaternion and the six Euler orders (the bound is on the rotation Blender builds);
axis-angle is refused. F-curves with modifiers are refused (the bound is for the keys alone).
Everything is read and computed before anything is written, so an error leaves the file untouched.

Importing this module installs `reduce_values` as the bake's reduction hook (`bake.reduce_keys`), so
`quatcurve.bake` with tolerance > 0 writes BEZIER keys, per channel where that saves keys.
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np

from . import bake, fcurves, native

INTERPOLATIONS = ("LINEAR", "BEZIER")


class ReduceError(ValueError):
    """A reduction that cannot be done; the message names the target and what is wrong. Raised
    before anything is written. A ValueError, as the bake's reduction hook expects."""


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
    """Reduces dense channel values (N, 4) of mode 'QUATERNION' or (N, 3) of an Euler order, sampled
    at `frames`, to ReducedChannels. Quaternions are made hemisphere-continuous first. Raises
    ReduceError for other modes or input the native reducer refuses."""
    qc = native.require()
    frames = np.asarray(frames, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    try:
        if mode == "QUATERNION":
            values = bake.hemisphere_continuous(values)
            result = qc.reduce_keys(frames, values, tolerance_rad, interpolation, synchronized,
                                    detailed=True)
        elif mode in fcurves.EULER_ORDERS:
            result = qc.reduce_keys_euler(frames, values, mode, tolerance_rad, interpolation,
                                          synchronized, detailed=True)
        else:
            raise ReduceError("rotation mode %s: key reduction handles quaternion and Euler rotations "
                              "(bake to QUATERNION or an Euler order first)" % mode)
    except ValueError as error:
        raise ReduceError(str(error)) from error
    bezier = interpolation == "BEZIER"
    keys = [(ch.frames, ch.values, ch.handle_left if bezier else None, ch.handle_right if bezier else None)
            for ch in result.channels]
    return ReducedChannels(interpolation, keys, result.max_error)


def write_channels(channels, data_path, reduced, group=None):
    """Writes ReducedChannels as new F-curves on (data_path, 0..C-1) of `channels` (after removing
    the old ones there). Returns the key count."""
    channels.remove({data_path}, count=len(reduced.keys))
    for index, (frames, values, left, right) in enumerate(reduced.keys):
        if reduced.interpolation == "BEZIER":
            channels.write(data_path, index, frames, values, group=group, interpolation="BEZIER",
                           handle_left=left, handle_right=right)
        else:
            channels.write(data_path, index, frames, values, group=group, interpolation="LINEAR")
    return reduced.key_count


# ---- reducing existing keys (the operator) ----------------------------------------------------------

@dataclass(eq=False)
class TargetReduce:
    target: bake.Target
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


def sample_frames(key_frames):
    """Every whole frame from the first key to the last, plus every key frame (sorted, unique)."""
    first, last = float(key_frames[0]), float(key_frames[-1])
    whole = np.arange(math.ceil(first), math.floor(last) + 1, dtype=np.float64)
    return np.unique(np.concatenate([np.asarray(key_frames, dtype=np.float64), whole]))


def read_target(target):
    """TargetReduce of `target` in its current rotation mode (sampled, not yet reduced)."""
    try:
        source = bake.read_rotation_keys(target)
    except bake.BakeError as error:
        raise ReduceError(str(error)) from error
    if source.mode not in ("QUATERNION",) + fcurves.EULER_ORDERS:
        raise ReduceError("%s: rotation mode %s: key reduction handles quaternion and Euler rotations"
                          % (target.name, source.mode))
    for index, fcurve in enumerate(source.fcurves):
        if fcurve is not None and len(fcurve.modifiers):
            raise ReduceError("%s: %s[%d] has F-curve modifiers; the bound holds for keys alone "
                              "(apply or remove the modifiers first)" % (target.name, source.prop, index))
    frames = sample_frames(source.frames)
    values = source.evaluate(frames)
    if not np.isfinite(values).all():
        raise ReduceError("%s: %s evaluates to non-finite values" % (target.name, source.prop))
    before = sum(fcurves.key_count(f) for f in source.fcurves if f is not None)
    return TargetReduce(target, source.mode, source.prop, frames, values, before)


def reduce(targets, settings):
    """Reduces the rotation keys of `targets`; returns a ReduceResult. Raises ReduceError (nothing
    written) when a setting or a target is unusable."""
    begin = time.perf_counter()
    check_settings(settings)
    if not targets:
        raise ReduceError("Nothing to reduce: no targets")
    for target in targets:
        try:
            bake.check_editable(target, settings.new_action)
        except bake.BakeError as error:
            raise ReduceError(str(error)) from error
    items = [read_target(t) for t in targets]
    tol = math.radians(settings.tolerance)
    for item in items:
        try:
            item.reduced = reduce_values(item.frames, item.values, item.mode, tol,
                                         settings.interpolation, settings.synchronized)
        except ReduceError as error:
            raise ReduceError("%s: %s" % (item.target.name, error)) from error

    result = ReduceResult(settings.tolerance, settings.interpolation)
    copies = {}
    for item in items:
        id_data = item.target.id_data
        original = fcurves.active_action(id_data)
        action = original
        if settings.new_action:
            if original not in copies:
                copies[original] = fcurves.copy_action(original, "%s_reduced" % original.name)
            action = copies[original]
        channels = fcurves.Channels.of(id_data, action, create=True)
        path = item.target.data_path(item.prop)
        after = write_channels(channels, path, item.reduced, group=channels.group_of(path))
        error_deg = math.degrees(item.reduced.max_error)
        result.targets.append(TargetResult(item.target.name, item.mode, item.keys_before, after,
                                           error_deg, action.name))
        result.keys_before += item.keys_before
        result.keys_after += after
        result.max_error_deg = max(result.max_error_deg, error_deg)
    assigned = set()
    for item in items:
        id_data = item.target.id_data
        original = fcurves.active_action(id_data)
        if id_data.name_full not in assigned and original in copies:
            fcurves.assign_action(id_data, copies[original])
            assigned.add(id_data.name_full)
        id_data.update_tag(refresh={"TIME"})
    for original in copies:
        original.use_fake_user = True
    result.seconds = time.perf_counter() - begin
    return result


# The bake writes reduced keys (BEZIER, per-channel) through this hook when its tolerance is above 0.
bake.reduce_keys = reduce_values
